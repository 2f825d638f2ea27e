//! The data after a PLY header: reading values and lists, and reading or skipping whole elements.

use std::fmt;

use super::super::{check_finite, line_error, parse_error, to_u64, LoadError, LocationKind};
use super::header::{PlyElement, PlyFormat, PlyHeader, PlyProperty, PropKind, Scalar};
use super::{Slot, Vertices, PLY};

/// Whitespace-separated tokens of an ASCII PLY body, with line numbers.
#[derive(Clone)]
pub(super) struct Tokens<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Tokens<'a> {
    fn next_token(&mut self) -> Option<(&'a [u8], usize)> {
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_whitespace() {
                break;
            }
            if b == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self
            .bytes
            .get(self.pos)
            .is_some_and(|b| !b.is_ascii_whitespace())
        {
            self.pos += 1;
        }
        let token = self.bytes.get(start..self.pos)?;
        (!token.is_empty()).then_some((token, self.line))
    }
}

/// Names the value being read, for error messages.
struct Ctx<'a> {
    element: &'a str,
    instance: u64,
    property: &'a str,
}

impl fmt::Display for Ctx<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "property `{}` of {} {}",
            self.property, self.element, self.instance
        )
    }
}

pub(super) enum Body<'a> {
    Binary {
        bytes: &'a [u8],
        pos: usize,
        big_endian: bool,
    },
    Ascii {
        tokens: Tokens<'a>,
        total: u64,
        consumed: u64,
    },
}

impl Body<'_> {
    /// The current byte offset of a binary body (0 for ASCII).
    fn offset(&self) -> usize {
        match self {
            Body::Binary { pos, .. } => *pos,
            Body::Ascii { .. } => 0,
        }
    }

    /// Where something that began at binary offset `start` is: that byte offset
    /// for binary bodies, the line of the latest token for ASCII ones.
    fn location(&self, start: usize) -> (LocationKind, usize) {
        match self {
            Body::Binary { .. } => (LocationKind::ByteOffset, start),
            Body::Ascii { tokens, .. } => (LocationKind::Line, tokens.line),
        }
    }

    fn read(&mut self, ty: Scalar, ctx: &Ctx) -> Result<f64, LoadError> {
        match self {
            Body::Binary {
                bytes,
                pos,
                big_endian,
            } => {
                let end = pos.saturating_add(ty.size());
                let Some(chunk) = bytes.get(*pos..end) else {
                    return Err(LoadError::Truncated {
                        format: PLY,
                        what: format!("{ctx} (type {})", ty.name()),
                        expected: to_u64(end),
                        got: to_u64(bytes.len()),
                        unit: "bytes",
                    });
                };
                *pos = end;
                Ok(ty.decode(chunk, *big_endian))
            }
            Body::Ascii {
                tokens,
                total,
                consumed,
            } => {
                let Some((token, line)) = tokens.next_token() else {
                    return Err(LoadError::Truncated {
                        format: PLY,
                        what: format!("{ctx}"),
                        expected: *consumed + 1,
                        got: *total,
                        unit: "values",
                    });
                };
                *consumed += 1;
                let value = std::str::from_utf8(token)
                    .ok()
                    .and_then(|s| s.parse::<f64>().ok());
                match value {
                    Some(v) if !ty.is_integer() || v.fract() == 0.0 => Ok(v),
                    _ => Err(line_error(
                        PLY,
                        line,
                        format!(
                            "`{}` is not a valid {} value for {ctx}",
                            String::from_utf8_lossy(token),
                            ty.name()
                        ),
                    )),
                }
            }
        }
    }

    /// Reads a list length and checks that the list's items are present.
    fn read_list_len(&mut self, count: Scalar, item: Scalar, ctx: &Ctx) -> Result<u64, LoadError> {
        let start = self.offset();
        let n = self.read(count, ctx)?;
        if n < 0.0 {
            let (kind, at) = self.location(start);
            return Err(parse_error(
                PLY,
                kind,
                at,
                format!("negative list length {n} for {ctx}"),
            ));
        }
        // An integer-typed value of at most 32 bits: exact and non-negative.
        let n = n as u64;
        match self {
            Body::Binary { bytes, pos, .. } => {
                let expected = to_u64(*pos).saturating_add(n.saturating_mul(to_u64(item.size())));
                if expected > to_u64(bytes.len()) {
                    return Err(LoadError::Truncated {
                        format: PLY,
                        what: format!("the list of {n} {} items in {ctx}", item.name()),
                        expected,
                        got: to_u64(bytes.len()),
                        unit: "bytes",
                    });
                }
            }
            Body::Ascii {
                total, consumed, ..
            } => {
                let expected = consumed.saturating_add(n);
                if expected > *total {
                    return Err(LoadError::Truncated {
                        format: PLY,
                        what: format!("the list of {n} items in {ctx}"),
                        expected,
                        got: *total,
                        unit: "values",
                    });
                }
            }
        }
        Ok(n)
    }

    /// Skips `n` list items whose presence `read_list_len` has checked.
    fn skip_items(&mut self, n: u64, item: Scalar) {
        match self {
            Body::Binary { pos, .. } => {
                let skip = usize::try_from(n.saturating_mul(to_u64(item.size())));
                *pos = pos.saturating_add(skip.unwrap_or(usize::MAX));
            }
            Body::Ascii {
                tokens, consumed, ..
            } => {
                for _ in 0..n {
                    if tokens.next_token().is_none() {
                        break;
                    }
                    *consumed += 1;
                }
            }
        }
    }

    fn skip_property(&mut self, prop: &PlyProperty, ctx: &Ctx) -> Result<(), LoadError> {
        match prop.kind {
            PropKind::Scalar(ty) => {
                self.read(ty, ctx)?;
            }
            PropKind::List { count, item } => {
                let n = self.read_list_len(count, item, ctx)?;
                self.skip_items(n, item);
            }
        }
        Ok(())
    }
}

/// Checks that the data of the elements declared in `header` fits in `bytes`
/// (before anything is reserved) and returns the body, at its first value.
pub(super) fn open_body<'a>(bytes: &'a [u8], header: &PlyHeader) -> Result<Body<'a>, LoadError> {
    let declared = header
        .elements
        .iter()
        .map(|e| format!("{} {}", e.count, e.name))
        .collect::<Vec<_>>()
        .join(", ");
    let what = format!("the data of the elements declared in the header ({declared})");
    match header.format {
        PlyFormat::Ascii => ascii_body(bytes, header, what),
        PlyFormat::BinaryLittleEndian | PlyFormat::BinaryBigEndian => {
            binary_body(bytes, header, what)
        }
    }
}

/// An ASCII body, once it holds at least one value per declared property.
fn ascii_body<'a>(
    bytes: &'a [u8],
    header: &PlyHeader,
    what: String,
) -> Result<Body<'a>, LoadError> {
    let tokens = Tokens {
        bytes,
        pos: header.body_start,
        line: header.body_line,
    };
    let mut counter = tokens.clone();
    let mut total = 0u64;
    while counter.next_token().is_some() {
        total += 1;
    }
    let needed = header.elements.iter().fold(0u64, |acc, e| {
        acc.saturating_add(e.count.saturating_mul(to_u64(e.props.len())))
    });
    if needed > total {
        return Err(LoadError::Truncated {
            format: PLY,
            what,
            expected: needed,
            got: total,
            unit: "values",
        });
    }
    Ok(Body::Ascii {
        tokens,
        total,
        consumed: 0,
    })
}

/// A binary body, once it holds the smallest size of every declared element.
fn binary_body<'a>(
    bytes: &'a [u8],
    header: &PlyHeader,
    what: String,
) -> Result<Body<'a>, LoadError> {
    let needed = header
        .elements
        .iter()
        .fold(to_u64(header.body_start), |acc, e| {
            acc.saturating_add(e.count.saturating_mul(e.min_row_bytes()))
        });
    if needed > to_u64(bytes.len()) {
        return Err(LoadError::Truncated {
            format: PLY,
            what,
            expected: needed,
            got: to_u64(bytes.len()),
            unit: "bytes",
        });
    }
    Ok(Body::Binary {
        bytes,
        pos: header.body_start,
        big_endian: header.format == PlyFormat::BinaryBigEndian,
    })
}

/// Reads every instance of the vertex element: each property goes where
/// `vertices.slots` says (other properties are skipped).
pub(super) fn read_vertex_element(
    body: &mut Body,
    element: &PlyElement,
    vertices: &mut Vertices,
) -> Result<(), LoadError> {
    for i in 0..element.count {
        let start = body.offset();
        let mut values = [0.0f64; 6];
        for (prop, slot) in element.props.iter().zip(&vertices.slots) {
            let ctx = Ctx {
                element: &element.name,
                instance: i,
                property: &prop.name,
            };
            match (*slot, prop.kind) {
                (Slot::Coord(k), PropKind::Scalar(ty)) => {
                    let v = body.read(ty, &ctx)?;
                    if let Some(value) = values.get_mut(k) {
                        *value = v;
                    }
                }
                (Slot::Extra(k), PropKind::Scalar(ty)) => {
                    let v = body.read(ty, &ctx)?;
                    if let Some(Some(extra)) = vertices.extras.get_mut(k) {
                        extra.push(v);
                    }
                }
                _ => body.skip_property(prop, &ctx)?,
            }
        }
        let p = [values[0], values[1], values[2]];
        check_finite(PLY, vertices.positions.len(), p, || {
            let (kind, at) = body.location(start);
            format!("vertex {i} ({kind} {at})")
        })?;
        vertices.positions.push(p);
        if vertices.has_normals {
            vertices.normals.push([values[3], values[4], values[5]]);
        }
    }
    Ok(())
}

/// Reads every instance of the face element: the list property at index `list`
/// is fan-triangulated into `triangles`, other properties are skipped.
pub(super) fn read_face_element(
    body: &mut Body,
    element: &PlyElement,
    list: usize,
    vertex_count: usize,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<(), LoadError> {
    triangles.reserve(usize::try_from(element.count).unwrap_or(0));
    for f in 0..element.count {
        for (pi, prop) in element.props.iter().enumerate() {
            let ctx = Ctx {
                element: &element.name,
                instance: f,
                property: &prop.name,
            };
            match prop.kind {
                PropKind::List { count, item } if pi == list => {
                    read_ply_polygon(body, (count, item), f, vertex_count, &ctx, triangles)?;
                }
                _ => body.skip_property(prop, &ctx)?,
            }
        }
    }
    Ok(())
}

/// Skips every instance of an element that is neither `vertex` nor `face`.
pub(super) fn skip_element(body: &mut Body, element: &PlyElement) -> Result<(), LoadError> {
    for n in 0..element.count {
        for prop in &element.props {
            let ctx = Ctx {
                element: &element.name,
                instance: n,
                property: &prop.name,
            };
            body.skip_property(prop, &ctx)?;
        }
    }
    Ok(())
}

fn read_ply_polygon(
    body: &mut Body,
    (count, item): (Scalar, Scalar),
    face: u64,
    vertex_count: usize,
    ctx: &Ctx,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<(), LoadError> {
    let start = body.offset();
    let n = body.read_list_len(count, item, ctx)?;
    if n < 3 {
        let (kind, at) = body.location(start);
        return Err(parse_error(
            PLY,
            kind,
            at,
            format!("face {face} has {n} vertex indices, but at least 3 are needed"),
        ));
    }
    let index = |body: &mut Body| -> Result<u32, LoadError> {
        let start = body.offset();
        let v = body.read(item, ctx)?;
        let (kind, at) = body.location(start);
        if v.fract() != 0.0 {
            return Err(parse_error(
                PLY,
                kind,
                at,
                format!("vertex index {v} of face {face} is not an integer"),
            ));
        }
        if v < 0.0 || v >= vertex_count as f64 {
            return Err(LoadError::IndexOutOfRange {
                format: PLY,
                face: usize::try_from(face).unwrap_or(usize::MAX),
                index: v as i64,
                vertex_count,
                location: format!("face {face} ({kind} {at})"),
            });
        }
        // In range of `vertex_count`, which fits in a u32.
        Ok(v as u32)
    };
    let first = index(body)?;
    let mut previous = index(body)?;
    for _ in 2..n {
        let next = index(body)?;
        triangles.push([first, previous, next]);
        previous = next;
    }
    Ok(())
}
