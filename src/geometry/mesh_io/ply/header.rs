//! The PLY header: scalar types, elements and their properties, and the header parser.

use super::super::{line_error, to_u64, LoadError};
use super::PLY;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    pub(super) fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }

    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub(super) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes one value; `b` must hold at least `self.size()` bytes.
    pub(super) fn decode(self, b: &[u8], big_endian: bool) -> f64 {
        fn array<const N: usize>(b: &[u8]) -> [u8; N] {
            let mut a = [0u8; N];
            if let Some(src) = b.get(..N) {
                a.copy_from_slice(src);
            }
            a
        }
        macro_rules! decode {
            ($t:ty, $n:literal) => {{
                let a = array::<$n>(b);
                f64::from(if big_endian {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                })
            }};
        }
        match self {
            Scalar::I8 => decode!(i8, 1),
            Scalar::U8 => decode!(u8, 1),
            Scalar::I16 => decode!(i16, 2),
            Scalar::U16 => decode!(u16, 2),
            Scalar::I32 => decode!(i32, 4),
            Scalar::U32 => decode!(u32, 4),
            Scalar::F32 => decode!(f32, 4),
            Scalar::F64 => {
                let a = array::<8>(b);
                if big_endian {
                    f64::from_be_bytes(a)
                } else {
                    f64::from_le_bytes(a)
                }
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum PlyFormat {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Clone, Copy, Debug)]
pub(super) enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
pub(super) struct PlyProperty {
    pub(super) name: String,
    pub(super) kind: PropKind,
}

#[derive(Debug)]
pub(super) struct PlyElement {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) props: Vec<PlyProperty>,
    pub(super) line: usize,
}

impl PlyElement {
    /// The smallest number of bytes one instance can take in a binary file
    /// (lists may be empty).
    pub(super) fn min_row_bytes(&self) -> u64 {
        self.props
            .iter()
            .map(|p| match p.kind {
                PropKind::Scalar(t) | PropKind::List { count: t, .. } => to_u64(t.size()),
            })
            .sum()
    }

    pub(super) fn scalar(&self, name: &str) -> Option<usize> {
        self.props
            .iter()
            .position(|p| p.name == name && matches!(p.kind, PropKind::Scalar(_)))
    }
}

#[derive(Debug)]
pub(super) struct PlyHeader {
    pub(super) format: PlyFormat,
    pub(super) elements: Vec<PlyElement>,
    /// Byte offset of the first data byte.
    pub(super) body_start: usize,
    /// Line number of the first data line (for ASCII bodies).
    pub(super) body_line: usize,
}

pub(super) fn parse_ply_header(bytes: &[u8]) -> Result<PlyHeader, LoadError> {
    if !bytes.starts_with(b"ply") {
        return Err(line_error(
            PLY,
            1,
            "the file does not start with the `ply` magic line",
        ));
    }
    let mut format = None;
    let mut elements: Vec<PlyElement> = Vec::new();
    let mut pos = 0usize;
    let mut line = 0usize;
    loop {
        if pos >= bytes.len() {
            return Err(line_error(
                PLY,
                line.max(1),
                "the header is not terminated by an `end_header` line",
            ));
        }
        let rest = &bytes[pos..];
        let len = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        let raw = &rest[..len];
        pos += (len + 1).min(rest.len());
        line += 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let text = std::str::from_utf8(raw)
            .map_err(|_| line_error(PLY, line, "the header line is not valid text"))?;
        let mut tokens = text.split_ascii_whitespace();
        if line == 1 {
            if text.trim() != "ply" {
                return Err(line_error(
                    PLY,
                    1,
                    format!("expected the magic line `ply`, found `{text}`"),
                ));
            }
            continue;
        }
        match tokens.next() {
            None | Some("comment" | "obj_info") => {}
            Some("format") => format = Some(parse_ply_format(tokens.next(), line)?),
            Some("element") => elements.push(parse_ply_element(&mut tokens, line)?),
            Some("property") => {
                let Some(element) = elements.last_mut() else {
                    return Err(line_error(
                        PLY,
                        line,
                        "`property` appears before any `element`",
                    ));
                };
                let property = parse_ply_property(&mut tokens, line)?;
                element.props.push(property);
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(line_error(
                    PLY,
                    line,
                    format!("unknown header keyword `{other}`"),
                ));
            }
        }
    }
    let format = format.ok_or_else(|| {
        line_error(
            PLY,
            line,
            "the header has no `format` line before `end_header`",
        )
    })?;
    Ok(PlyHeader {
        format,
        elements,
        body_start: pos,
        body_line: line + 1,
    })
}

/// Reads the encoding named on a `format` line.
fn parse_ply_format(name: Option<&str>, line: usize) -> Result<PlyFormat, LoadError> {
    Ok(match name {
        Some("ascii") => PlyFormat::Ascii,
        Some("binary_little_endian") => PlyFormat::BinaryLittleEndian,
        Some("binary_big_endian") => PlyFormat::BinaryBigEndian,
        other => {
            return Err(line_error(
                PLY,
                line,
                format!(
                    "unsupported format `{}`; expected ascii, binary_little_endian \
                     or binary_big_endian",
                    other.unwrap_or("")
                ),
            ));
        }
    })
}

/// Reads the rest of an `element <name> <count>` line.
fn parse_ply_element<'a>(
    tokens: &mut impl Iterator<Item = &'a str>,
    line: usize,
) -> Result<PlyElement, LoadError> {
    let (Some(name), Some(count)) = (tokens.next(), tokens.next()) else {
        return Err(line_error(PLY, line, "expected `element <name> <count>`"));
    };
    let count = count.parse::<u64>().map_err(|_| {
        line_error(
            PLY,
            line,
            format!("element `{name}` has an invalid count `{count}`"),
        )
    })?;
    Ok(PlyElement {
        name: name.to_string(),
        count,
        props: Vec::new(),
        line,
    })
}

fn parse_ply_property<'a>(
    tokens: &mut impl Iterator<Item = &'a str>,
    line: usize,
) -> Result<PlyProperty, LoadError> {
    let scalar = |name: Option<&str>| {
        let name = name.unwrap_or("");
        Scalar::from_name(name)
            .ok_or_else(|| line_error(PLY, line, format!("unknown property type `{name}`")))
    };
    let first = tokens.next();
    let kind = if first == Some("list") {
        let count = scalar(tokens.next())?;
        if !count.is_integer() {
            return Err(line_error(
                PLY,
                line,
                format!("list length type `{}` is not an integer type", count.name()),
            ));
        }
        let item = scalar(tokens.next())?;
        PropKind::List { count, item }
    } else {
        PropKind::Scalar(scalar(first)?)
    };
    let name = tokens
        .next()
        .ok_or_else(|| line_error(PLY, line, "the property has no name"))?;
    Ok(PlyProperty {
        name: name.to_string(),
        kind,
    })
}
