//! Reading and writing triangle meshes and point clouds in OBJ, STL and PLY.
//!
//! The readers turn a file into a [`RawGeometry`]: finite positions, optional
//! per-vertex normals and 0-based triangle indices that are guaranteed to be in
//! range. Polygons are fan-triangulated, STL triangle soup is welded into an
//! indexed mesh, and a file without faces becomes a point cloud.
//!
//! The readers never panic on malformed input and never allocate more than a
//! small multiple of the input size: element counts claimed by a header are
//! checked against the bytes that are actually present before anything is
//! reserved.
//!
//! Conventions used in error messages: line numbers are 1-based, byte offsets
//! are 0-based from the start of the file, vertex and face numbers of PLY and
//! STL files are 0-based, OBJ vertices are reported with their 1-based OBJ
//! number, and OBJ faces are 0-based but always come with their line.

use std::collections::HashMap;
use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Geometry as read from a file: a triangle mesh, or a bare point cloud when `triangles` is empty.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RawGeometry {
    /// Vertex positions; the readers guarantee that every coordinate is finite.
    pub positions: Vec<[f64; 3]>,
    /// One normal per position, when the file has them (PLY `nx ny nz`; OBJ `vn`
    /// only if exactly one normal can be assigned to every vertex, otherwise `None`).
    pub normals: Option<Vec<[f64; 3]>>,
    /// Triangles as 0-based indices into `positions`; the readers guarantee they are in range.
    pub triangles: Vec<[u32; 3]>,
}

/// What the number `line_or_offset` of a [`LoadError::Parse`] counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocationKind {
    /// A 1-based line number in a text file or a text header.
    Line,
    /// A 0-based byte offset from the start of a binary file.
    ByteOffset,
}

impl fmt::Display for LocationKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LocationKind::Line => "line",
            LocationKind::ByteOffset => "byte offset",
        })
    }
}

/// Why a file could not be turned into a [`RawGeometry`].
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read from disk.
    #[error("cannot read `{}`: {source}", .path.display())]
    Io { path: PathBuf, source: io::Error },

    /// The file name has no extension, or one that is not `.obj`, `.stl` or `.ply`.
    #[error(
        "cannot tell the geometry format of `{}`: the extension must be .obj, .stl or .ply (any case)",
        .path.display()
    )]
    UnknownFormat { path: PathBuf },

    /// The content does not follow the format's syntax.
    #[error("{format} parse error at {kind} {line_or_offset}: {message}")]
    Parse {
        format: &'static str,
        kind: LocationKind,
        line_or_offset: usize,
        message: String,
    },

    /// A face refers to a vertex that does not exist. `index` is the index as
    /// written in the file (1-based or negative for OBJ, 0-based for PLY), `face`
    /// is the 0-based number of the face.
    #[error(
        "{format}: {location} refers to vertex index {index}, but only {vertex_count} vertices are available"
    )]
    IndexOutOfRange {
        format: &'static str,
        face: usize,
        index: i64,
        vertex_count: usize,
        location: String,
    },

    /// A vertex position has a NaN or infinite coordinate. `index` is the 0-based
    /// vertex number (for STL: `3 * facet + corner`, counted before welding).
    #[error(
        "{format}: {location} has a non-finite coordinate ({}, {}, {})",
        .position[0], .position[1], .position[2]
    )]
    NonFinite {
        format: &'static str,
        index: usize,
        position: [f64; 3],
        location: String,
    },

    /// The data ends before everything the file declares (a header count, a
    /// list length) has been read.
    #[error(
        "{format}: file is truncated: {what} needs at least {expected} {unit}, but only {got} are present"
    )]
    Truncated {
        format: &'static str,
        what: String,
        expected: u64,
        got: u64,
        unit: &'static str,
    },

    /// The file is empty or defines no vertex at all.
    #[error("{format}: the file contains no vertices")]
    Empty { format: &'static str },
}

const OBJ: &str = "OBJ";
const STL: &str = "STL";
const PLY: &str = "PLY";

fn parse_error(
    format: &'static str,
    kind: LocationKind,
    line_or_offset: usize,
    message: impl Into<String>,
) -> LoadError {
    LoadError::Parse {
        format,
        kind,
        line_or_offset,
        message: message.into(),
    }
}

fn line_error(format: &'static str, line: usize, message: impl Into<String>) -> LoadError {
    parse_error(format, LocationKind::Line, line, message)
}

fn check_finite(
    format: &'static str,
    index: usize,
    position: [f64; 3],
    location: impl FnOnce() -> String,
) -> Result<(), LoadError> {
    if position.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(LoadError::NonFinite {
            format,
            index,
            position,
            location: location(),
        })
    }
}

fn to_u64(n: usize) -> u64 {
    u64::try_from(n).unwrap_or(u64::MAX)
}

fn is_blank(bytes: &[u8]) -> bool {
    bytes.iter().all(u8::is_ascii_whitespace)
}

/// Loads a mesh or point cloud, choosing the parser by the file extension
/// (`.obj`, `.stl`, `.ply`, case-insensitive).
pub fn load_geometry(path: &Path) -> Result<RawGeometry, LoadError> {
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let parse: fn(&[u8]) -> Result<RawGeometry, LoadError> = match extension.as_deref() {
        Some("obj") => parse_obj,
        Some("stl") => parse_stl,
        Some("ply") => parse_ply,
        _ => {
            return Err(LoadError::UnknownFormat {
                path: path.to_path_buf(),
            });
        }
    };
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(&bytes)
}

/// Reads three numbers from `tokens` (further tokens are left alone).
fn parse_vec3<'a>(
    format: &'static str,
    tokens: &mut impl Iterator<Item = &'a str>,
    what: &str,
    line: usize,
) -> Result<[f64; 3], LoadError> {
    let mut v = [0.0; 3];
    for (axis, c) in v.iter_mut().enumerate() {
        let token = tokens.next().ok_or_else(|| {
            line_error(
                format,
                line,
                format!("{what} has {axis} coordinates, but 3 are needed"),
            )
        })?;
        *c = token.parse().map_err(|_| {
            line_error(
                format,
                line,
                format!("{what} coordinate `{token}` is not a number"),
            )
        })?;
    }
    Ok(v)
}

// ---------------------------------------------------------------------------
// OBJ
// ---------------------------------------------------------------------------

#[derive(Clone, Copy, Debug)]
struct ObjCorner {
    vertex: u32,
    normal: Option<u32>,
}

/// A positive index that refers to a vertex or normal defined later in the
/// file; it is validated once the whole file has been read.
struct ForwardRef {
    index: i64,
    resolved: u64,
    normal: bool,
    line: usize,
    face: usize,
}

/// Parses a Wavefront OBJ file: `v`, `vn` and `f` statements (all other
/// statements are ignored). Faces may use the `i`, `i/j`, `i//k` and `i/j/k`
/// forms and negative (relative) indices; polygons are fan-triangulated.
pub fn parse_obj(bytes: &[u8]) -> Result<RawGeometry, LoadError> {
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut normals: Vec<[f64; 3]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut corners: Vec<ObjCorner> = Vec::new();
    let mut face: Vec<ObjCorner> = Vec::new();
    let mut forward: Vec<ForwardRef> = Vec::new();
    let mut face_count = 0usize;

    for (line_index, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line_index + 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let raw = raw
            .iter()
            .position(|&b| b == b'#')
            .map_or(raw, |p| &raw[..p]);
        let text = String::from_utf8_lossy(raw);
        let mut tokens = text.split_ascii_whitespace();
        match tokens.next() {
            Some("v") => {
                let p = parse_vec3(OBJ, &mut tokens, "vertex", line)?;
                let index = positions.len();
                check_finite(OBJ, index, p, || {
                    format!("vertex {} (line {line})", index + 1)
                })?;
                positions.push(p);
            }
            Some("vn") => normals.push(parse_vec3(OBJ, &mut tokens, "normal", line)?),
            Some("f") => {
                face.clear();
                for token in tokens {
                    let counts = (positions.len(), normals.len());
                    face.push(obj_corner(token, line, face_count, counts, &mut forward)?);
                }
                if face.len() < 3 {
                    return Err(line_error(
                        OBJ,
                        line,
                        format!(
                            "face {face_count} has {} vertices, but at least 3 are needed",
                            face.len()
                        ),
                    ));
                }
                let first = face[0].vertex;
                for pair in face[1..].windows(2) {
                    triangles.push([first, pair[0].vertex, pair[1].vertex]);
                }
                corners.extend_from_slice(&face);
                face_count += 1;
            }
            // o, g, s, usemtl, mtllib, vt, vp, l, p and anything else: ignored.
            _ => {}
        }
    }

    if positions.is_empty() {
        return Err(LoadError::Empty { format: OBJ });
    }
    for f in &forward {
        let available = if f.normal {
            normals.len()
        } else {
            positions.len()
        };
        if f.resolved >= to_u64(available) {
            return Err(obj_out_of_range(
                f.normal, f.index, available, f.line, f.face,
            ));
        }
    }
    let normals = assign_obj_normals(positions.len(), &normals, &corners);
    Ok(RawGeometry {
        positions,
        normals,
        triangles,
    })
}

fn obj_out_of_range(
    normal: bool,
    index: i64,
    available: usize,
    line: usize,
    face: usize,
) -> LoadError {
    if normal {
        line_error(
            OBJ,
            line,
            format!(
                "face {face} refers to normal index {index}, but only {available} normals are available"
            ),
        )
    } else {
        LoadError::IndexOutOfRange {
            format: OBJ,
            face,
            index,
            vertex_count: available,
            location: format!("face {face} (line {line})"),
        }
    }
}

/// Parses one face corner (`i`, `i/j`, `i//k`, `i/j/k`). `counts` holds the
/// number of vertices and normals defined so far.
fn obj_corner(
    token: &str,
    line: usize,
    face: usize,
    counts: (usize, usize),
    forward: &mut Vec<ForwardRef>,
) -> Result<ObjCorner, LoadError> {
    let mut parts = token.split('/');
    let vertex = parts.next().unwrap_or_default();
    let _texture = parts.next();
    let normal = parts.next();
    if parts.next().is_some() {
        return Err(line_error(
            OBJ,
            line,
            format!("face vertex `{token}` has more than three `/`-separated parts"),
        ));
    }
    let vertex = obj_index(vertex, token, false, line, face, counts.0, forward)?;
    let normal = match normal {
        Some(n) if !n.is_empty() => Some(obj_index(n, token, true, line, face, counts.1, forward)?),
        _ => None,
    };
    Ok(ObjCorner { vertex, normal })
}

fn obj_index(
    text: &str,
    token: &str,
    normal: bool,
    line: usize,
    face: usize,
    defined: usize,
    forward: &mut Vec<ForwardRef>,
) -> Result<u32, LoadError> {
    let what = if normal { "normal" } else { "vertex" };
    let index: i64 = text.parse().map_err(|_| {
        line_error(
            OBJ,
            line,
            format!("invalid {what} index `{text}` in face vertex `{token}`"),
        )
    })?;
    let defined_i64 = i64::try_from(defined).unwrap_or(i64::MAX);
    let resolved = match index {
        0 => {
            return Err(line_error(
                OBJ,
                line,
                format!(
                    "{what} index 0 in face vertex `{token}` is invalid: OBJ indices start at 1 \
                     (negative indices count back from the latest definition)"
                ),
            ));
        }
        i if i > 0 => i - 1,
        i => defined_i64.saturating_add(i),
    };
    if resolved < 0 {
        return Err(obj_out_of_range(normal, index, defined, line, face));
    }
    if resolved >= defined_i64 {
        forward.push(ForwardRef {
            index,
            resolved: resolved.unsigned_abs(),
            normal,
            line,
            face,
        });
    }
    u32::try_from(resolved).map_err(|_| {
        line_error(
            OBJ,
            line,
            format!("{what} index {index} is too large (at most 2^32 - 1 are supported)"),
        )
    })
}

/// One normal per vertex when that assignment is unambiguous: either no face
/// refers to normals and there are exactly as many normals as vertices (paired
/// in order), or every face corner names a normal, each vertex gets only
/// identical normals, and every vertex is used by some face.
fn assign_obj_normals(
    vertex_count: usize,
    normals: &[[f64; 3]],
    corners: &[ObjCorner],
) -> Option<Vec<[f64; 3]>> {
    if normals.is_empty() {
        return None;
    }
    if corners.iter().all(|c| c.normal.is_none()) {
        return (normals.len() == vertex_count).then(|| normals.to_vec());
    }
    let mut assigned: Vec<Option<[f64; 3]>> = vec![None; vertex_count];
    for corner in corners {
        let normal = *normals.get(usize::try_from(corner.normal?).ok()?)?;
        let slot = assigned.get_mut(usize::try_from(corner.vertex).ok()?)?;
        match slot {
            None => *slot = Some(normal),
            Some(old) if old.map(f64::to_bits) == normal.map(f64::to_bits) => {}
            Some(_) => return None,
        }
    }
    assigned.into_iter().collect()
}

/// Writes `geometry` as a Wavefront OBJ file (`v`, optional `vn`, and `f`
/// lines with 1-based indices). Coordinates are written with the shortest
/// representation that reads back to the same `f64`.
pub fn write_obj(geometry: &RawGeometry, out: &mut impl Write) -> io::Result<()> {
    let n = geometry.positions.len();
    validate_for_writing(geometry, u64::from(u32::MAX))?;
    let mut w = io::BufWriter::with_capacity(1 << 16, out);
    writeln!(
        w,
        "# written by mesh_io: {n} vertices, {} triangles",
        geometry.triangles.len()
    )?;
    for [x, y, z] in &geometry.positions {
        writeln!(w, "v {x:?} {y:?} {z:?}")?;
    }
    if let Some(normals) = &geometry.normals {
        for [x, y, z] in normals {
            writeln!(w, "vn {x:?} {y:?} {z:?}")?;
        }
    }
    let with_normals = geometry.normals.is_some();
    for t in &geometry.triangles {
        let [a, b, c] = t.map(|i| u64::from(i) + 1);
        if with_normals {
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        } else {
            writeln!(w, "f {a} {b} {c}")?;
        }
    }
    w.flush()
}

fn invalid_input(message: String) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidInput, message)
}

/// Checks what every writer needs: normals per vertex and triangle indices in range.
fn validate_for_writing(geometry: &RawGeometry, max_index: u64) -> io::Result<()> {
    let n = geometry.positions.len();
    if let Some(normals) = &geometry.normals {
        if normals.len() != n {
            return Err(invalid_input(format!(
                "geometry has {} normals for {n} positions",
                normals.len()
            )));
        }
    }
    for (t, tri) in geometry.triangles.iter().enumerate() {
        for &i in tri {
            if u64::from(i) >= to_u64(n) || u64::from(i) > max_index {
                return Err(invalid_input(format!(
                    "triangle {t} refers to vertex {i}, but there are only {n} vertices"
                )));
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------
// STL
// ---------------------------------------------------------------------------

/// Merges bit-identical positions (after mapping -0.0 to +0.0) into one vertex.
struct Welder {
    map: HashMap<[u64; 3], u32>,
    positions: Vec<[f64; 3]>,
}

impl Welder {
    fn with_capacity(n: usize) -> Self {
        Welder {
            map: HashMap::with_capacity(n),
            positions: Vec::with_capacity(n),
        }
    }

    fn add(&mut self, p: [f64; 3]) -> Option<u32> {
        let key = p.map(|c| (c + 0.0).to_bits());
        if let Some(&i) = self.map.get(&key) {
            return Some(i);
        }
        let i = u32::try_from(self.positions.len()).ok()?;
        self.map.insert(key, i);
        self.positions.push(p);
        Some(i)
    }
}

fn too_many_vertices(format: &'static str, kind: LocationKind, at: usize) -> LoadError {
    parse_error(
        format,
        kind,
        at,
        "more than 2^32 distinct vertices are not supported",
    )
}

/// Parses an STL file, ASCII or binary. A file is binary when its size is
/// exactly `84 + 50 n` for the facet count `n` stored at bytes 80..84 (even if
/// the header starts with `solid`); otherwise it is ASCII when it starts with
/// `solid` and contains `facet` or `endsolid`, and binary (possibly truncated)
/// otherwise. The triangle soup is welded: bit-identical positions become one
/// vertex. STL facet normals are per face and therefore not returned.
pub fn parse_stl(bytes: &[u8]) -> Result<RawGeometry, LoadError> {
    if is_blank(bytes) {
        return Err(LoadError::Empty { format: STL });
    }
    let declared = bytes
        .get(80..84)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map(u32::from_le_bytes);
    if let Some(n) = declared {
        if to_u64(bytes.len()) == 84 + 50 * u64::from(n) {
            return parse_stl_binary(bytes, n);
        }
    }
    if looks_like_ascii_stl(bytes) {
        return parse_stl_ascii(bytes);
    }
    match declared {
        Some(n) => parse_stl_binary(bytes, n),
        None => Err(LoadError::Truncated {
            format: STL,
            what:
                "a binary STL header (the file does not start with `solid`, so it is not ASCII STL)"
                    .into(),
            expected: 84,
            got: to_u64(bytes.len()),
            unit: "bytes",
        }),
    }
}

fn contains_ignore_case(haystack: &[u8], needle: &[u8]) -> bool {
    haystack
        .windows(needle.len())
        .any(|w| w.eq_ignore_ascii_case(needle))
}

fn looks_like_ascii_stl(bytes: &[u8]) -> bool {
    let start = bytes
        .iter()
        .position(|b| !b.is_ascii_whitespace())
        .unwrap_or(bytes.len());
    let rest = &bytes[start..];
    rest.get(..5)
        .is_some_and(|s| s.eq_ignore_ascii_case(b"solid"))
        && (contains_ignore_case(rest, b"facet") || contains_ignore_case(rest, b"endsolid"))
}

fn f32_at(bytes: &[u8], offset: usize) -> f64 {
    let mut a = [0u8; 4];
    if let Some(b) = bytes.get(offset..offset + 4) {
        a.copy_from_slice(b);
    }
    f64::from(f32::from_le_bytes(a))
}

fn parse_stl_binary(bytes: &[u8], count: u32) -> Result<RawGeometry, LoadError> {
    let expected = 84 + 50 * u64::from(count);
    let got = to_u64(bytes.len());
    if got < expected {
        return Err(LoadError::Truncated {
            format: STL,
            what: format!("binary STL data for {count} facets (count read from bytes 80..84)"),
            expected,
            got,
            unit: "bytes",
        });
    }
    if count == 0 {
        return Err(LoadError::Empty { format: STL });
    }
    // `expected <= bytes.len()`, so these conversions and the slice cannot fail.
    let count = usize::try_from(count).unwrap_or(usize::MAX);
    let end = usize::try_from(expected).unwrap_or(usize::MAX);
    let data = bytes.get(84..end).unwrap_or_default();
    let mut welder = Welder::with_capacity(count);
    let mut triangles = Vec::with_capacity(count);
    for (f, record) in data.chunks_exact(50).enumerate() {
        let mut tri = [0u32; 3];
        for (c, slot) in tri.iter_mut().enumerate() {
            let o = 12 + 12 * c;
            let p = [
                f32_at(record, o),
                f32_at(record, o + 4),
                f32_at(record, o + 8),
            ];
            let offset = 84 + 50 * f + o;
            check_finite(STL, 3 * f + c, p, || {
                format!("facet {f}, vertex {c} (byte offset {offset})")
            })?;
            *slot = welder
                .add(p)
                .ok_or_else(|| too_many_vertices(STL, LocationKind::ByteOffset, offset))?;
        }
        triangles.push(tri);
    }
    Ok(RawGeometry {
        positions: welder.positions,
        normals: None,
        triangles,
    })
}

fn parse_stl_ascii(bytes: &[u8]) -> Result<RawGeometry, LoadError> {
    let mut welder = Welder::with_capacity(0);
    let mut triangles = Vec::new();
    let mut corners: Vec<u32> = Vec::new();
    let mut facet_start: Option<usize> = None;
    let mut facet_count = 0usize;
    let mut soup_count = 0usize;
    let mut last_line = 1;

    for (line_index, raw) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = line_index + 1;
        last_line = line;
        let text = String::from_utf8_lossy(raw);
        let mut tokens = text.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        let keyword = keyword.to_ascii_lowercase();
        match (keyword.as_str(), facet_start) {
            ("solid" | "endsolid", None) => {}
            ("facet", None) => {
                facet_start = Some(line);
                corners.clear();
            }
            ("outer" | "endloop", Some(_)) => {}
            ("vertex", Some(_)) => {
                let p = parse_vec3(STL, &mut tokens, "vertex", line)?;
                let corner = corners.len();
                check_finite(STL, soup_count, p, || {
                    format!("facet {facet_count}, vertex {corner} (line {line})")
                })?;
                soup_count += 1;
                corners.push(
                    welder
                        .add(p)
                        .ok_or_else(|| too_many_vertices(STL, LocationKind::Line, line))?,
                );
            }
            ("endfacet", Some(_)) => {
                if corners.len() < 3 {
                    return Err(line_error(
                        STL,
                        line,
                        format!(
                            "facet {facet_count} has {} vertices, but at least 3 are needed",
                            corners.len()
                        ),
                    ));
                }
                let first = corners[0];
                for pair in corners[1..].windows(2) {
                    triangles.push([first, pair[0], pair[1]]);
                }
                facet_count += 1;
                facet_start = None;
            }
            ("solid" | "endsolid" | "facet", Some(start)) => {
                return Err(line_error(
                    STL,
                    line,
                    format!(
                        "`{keyword}` inside the facet that starts at line {start} (missing `endfacet`?)"
                    ),
                ));
            }
            ("outer" | "endloop" | "vertex" | "endfacet", None) => {
                return Err(line_error(
                    STL,
                    line,
                    format!("`{keyword}` outside of a facet (missing `facet normal`?)"),
                ));
            }
            _ => {
                return Err(line_error(
                    STL,
                    line,
                    format!(
                        "unexpected `{keyword}`; expected solid, facet, outer loop, vertex, \
                         endloop, endfacet or endsolid"
                    ),
                ));
            }
        }
    }
    if let Some(start) = facet_start {
        return Err(line_error(
            STL,
            last_line,
            format!("the file ends inside the facet that starts at line {start}"),
        ));
    }
    if welder.positions.is_empty() {
        return Err(LoadError::Empty { format: STL });
    }
    Ok(RawGeometry {
        positions: welder.positions,
        normals: None,
        triangles,
    })
}

// ---------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
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

    fn name(self) -> &'static str {
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

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes one value; `b` must hold at least `self.size()` bytes.
    fn decode(self, b: &[u8], big_endian: bool) -> f64 {
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
enum PlyFormat {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Clone, Copy, Debug)]
enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct PlyProperty {
    name: String,
    kind: PropKind,
}

#[derive(Debug)]
struct PlyElement {
    name: String,
    count: u64,
    props: Vec<PlyProperty>,
    line: usize,
}

impl PlyElement {
    /// The smallest number of bytes one instance can take in a binary file
    /// (lists may be empty).
    fn min_row_bytes(&self) -> u64 {
        self.props
            .iter()
            .map(|p| match p.kind {
                PropKind::Scalar(t) | PropKind::List { count: t, .. } => to_u64(t.size()),
            })
            .sum()
    }

    fn scalar(&self, name: &str) -> Option<usize> {
        self.props
            .iter()
            .position(|p| p.name == name && matches!(p.kind, PropKind::Scalar(_)))
    }
}

#[derive(Debug)]
struct PlyHeader {
    format: PlyFormat,
    elements: Vec<PlyElement>,
    /// Byte offset of the first data byte.
    body_start: usize,
    /// Line number of the first data line (for ASCII bodies).
    body_line: usize,
}

fn parse_ply_header(bytes: &[u8]) -> Result<PlyHeader, LoadError> {
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
            Some("format") => {
                format = Some(match tokens.next() {
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
                });
            }
            Some("element") => {
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
                elements.push(PlyElement {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                    line,
                });
            }
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

/// Whitespace-separated tokens of an ASCII PLY body, with line numbers.
#[derive(Clone)]
struct Tokens<'a> {
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

enum Body<'a> {
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

#[derive(Clone, Copy)]
enum Slot {
    Skip,
    /// x, y, z, nx, ny, nz
    Coord(usize),
    Extra(usize),
}

/// Parses a PLY file (ascii, binary_little_endian or binary_big_endian).
/// Positions come from the `vertex` element's `x y z`, normals from `nx ny nz`,
/// triangles from the `face` element's `vertex_indices` (or `vertex_index`)
/// list, fan-triangulated. Other properties and elements are skipped.
pub fn parse_ply(bytes: &[u8]) -> Result<RawGeometry, LoadError> {
    parse_ply_with_extras(bytes, &[]).map(|(geometry, _)| geometry)
}

/// Values of requested extra vertex properties, `None` where the file lacks one.
type ExtraValues = Vec<Option<Vec<f64>>>;

/// Like [`parse_ply`], and also returns, for each name in `extra_names`, the
/// values of that scalar vertex property (`None` when the file lacks it).
fn parse_ply_with_extras(
    bytes: &[u8],
    extra_names: &[&str],
) -> Result<(RawGeometry, ExtraValues), LoadError> {
    if is_blank(bytes) {
        return Err(LoadError::Empty { format: PLY });
    }
    let header = parse_ply_header(bytes)?;
    let elements = &header.elements;
    let Some(vertex_el) = elements.iter().position(|e| e.name == "vertex") else {
        return Err(LoadError::Empty { format: PLY });
    };
    let vel = &elements[vertex_el];
    if vel.count == 0 {
        return Err(LoadError::Empty { format: PLY });
    }

    let mut slots = vec![Slot::Skip; vel.props.len()];
    for (k, name) in ["x", "y", "z"].into_iter().enumerate() {
        let i = vel.scalar(name).ok_or_else(|| {
            line_error(
                PLY,
                vel.line,
                format!("the vertex element has no scalar `{name}` property"),
            )
        })?;
        slots[i] = Slot::Coord(k);
    }
    let normal_props = [vel.scalar("nx"), vel.scalar("ny"), vel.scalar("nz")];
    let has_normals = normal_props.iter().all(Option::is_some);
    if has_normals {
        for (k, i) in normal_props.into_iter().flatten().enumerate() {
            slots[i] = Slot::Coord(3 + k);
        }
    }
    let mut extras: ExtraValues = vec![None; extra_names.len()];
    for (k, name) in extra_names.iter().enumerate() {
        if let Some(i) = vel.scalar(name) {
            if matches!(slots[i], Slot::Skip) {
                slots[i] = Slot::Extra(k);
                extras[k] = Some(Vec::new());
            }
        }
    }

    let face_el = elements.iter().position(|e| e.name == "face");
    let face_list = match face_el.map(|i| &elements[i]) {
        None => None,
        Some(fel) => Some(
            fel.props
                .iter()
                .position(|p| {
                    matches!(p.kind, PropKind::List { .. })
                        && (p.name == "vertex_indices" || p.name == "vertex_index")
                })
                .ok_or_else(|| {
                    line_error(
                        PLY,
                        fel.line,
                        "the face element has no `vertex_indices` (or `vertex_index`) list property",
                    )
                })?,
        ),
    };

    // Before reserving anything, check that the declared elements fit the data.
    let declared = elements
        .iter()
        .map(|e| format!("{} {}", e.count, e.name))
        .collect::<Vec<_>>()
        .join(", ");
    let what = format!("the data of the elements declared in the header ({declared})");
    let mut body = match header.format {
        PlyFormat::Ascii => {
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
            let needed = elements.iter().fold(0u64, |acc, e| {
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
            Body::Ascii {
                tokens,
                total,
                consumed: 0,
            }
        }
        PlyFormat::BinaryLittleEndian | PlyFormat::BinaryBigEndian => {
            let needed = elements.iter().fold(to_u64(header.body_start), |acc, e| {
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
            Body::Binary {
                bytes,
                pos: header.body_start,
                big_endian: header.format == PlyFormat::BinaryBigEndian,
            }
        }
    };

    // Every vertex takes at least one byte or value, so the count fits in memory now.
    let vertex_count = usize::try_from(vel.count)
        .ok()
        .filter(|&n| u32::try_from(n).is_ok())
        .ok_or_else(|| {
            line_error(
                PLY,
                vel.line,
                format!(
                    "{} vertices are more than the supported 2^32 - 1",
                    vel.count
                ),
            )
        })?;
    let mut positions = Vec::with_capacity(vertex_count);
    let mut normals = Vec::with_capacity(if has_normals { vertex_count } else { 0 });
    let mut triangles = Vec::new();
    for extra in extras.iter_mut().flatten() {
        extra.reserve_exact(vertex_count);
    }

    for (ei, element) in elements.iter().enumerate() {
        if element.props.is_empty() {
            continue;
        }
        if ei == vertex_el {
            for i in 0..element.count {
                let start = body.offset();
                let mut values = [0.0f64; 6];
                for (prop, slot) in element.props.iter().zip(&slots) {
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
                            if let Some(Some(extra)) = extras.get_mut(k) {
                                extra.push(v);
                            }
                        }
                        _ => body.skip_property(prop, &ctx)?,
                    }
                }
                let p = [values[0], values[1], values[2]];
                check_finite(PLY, positions.len(), p, || {
                    let (kind, at) = body.location(start);
                    format!("vertex {i} ({kind} {at})")
                })?;
                positions.push(p);
                if has_normals {
                    normals.push([values[3], values[4], values[5]]);
                }
            }
        } else if Some(ei) == face_el {
            let list = face_list.unwrap_or(usize::MAX);
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
                            read_ply_polygon(
                                &mut body,
                                (count, item),
                                f,
                                vertex_count,
                                &ctx,
                                &mut triangles,
                            )?;
                        }
                        _ => body.skip_property(prop, &ctx)?,
                    }
                }
            }
        } else {
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
        }
    }

    let geometry = RawGeometry {
        positions,
        normals: has_normals.then_some(normals),
        triangles,
    };
    Ok((geometry, extras))
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

/// Writes `geometry` as a binary_little_endian PLY: `x y z` as float, `nx ny nz`
/// when the geometry has normals, one float property per entry of `extra`
/// (name, one value per vertex), then the faces as
/// `list uchar int vertex_indices`. Positions and normals are rounded to `f32`.
///
/// Fails with [`io::ErrorKind::InvalidInput`] when the normals or an extra
/// property do not have one value per vertex, when an extra name is empty,
/// contains whitespace, is repeated or clashes with `x y z nx ny nz`, or when a
/// triangle index is out of range.
pub fn write_ply(
    geometry: &RawGeometry,
    extra: &[(&str, &[f32])],
    out: &mut impl Write,
) -> io::Result<()> {
    let n = geometry.positions.len();
    validate_for_writing(geometry, u64::from(i32::MAX.unsigned_abs()))?;
    const RESERVED: [&str; 6] = ["x", "y", "z", "nx", "ny", "nz"];
    for (k, (name, values)) in extra.iter().enumerate() {
        if name.is_empty() || !name.bytes().all(|b| b.is_ascii_graphic()) {
            return Err(invalid_input(format!(
                "extra property name `{name}` must be non-empty printable ASCII without spaces"
            )));
        }
        if RESERVED.contains(name) || extra[..k].iter().any(|(other, _)| other == name) {
            return Err(invalid_input(format!(
                "extra property name `{name}` is used twice or clashes with x y z nx ny nz"
            )));
        }
        if values.len() != n {
            return Err(invalid_input(format!(
                "extra property `{name}` has {} values for {n} vertices",
                values.len()
            )));
        }
    }

    let mut header =
        String::from("ply\nformat binary_little_endian 1.0\ncomment written by mesh_io\n");
    header.push_str(&format!("element vertex {n}\n"));
    for axis in ["x", "y", "z"] {
        header.push_str(&format!("property float {axis}\n"));
    }
    if geometry.normals.is_some() {
        for axis in ["nx", "ny", "nz"] {
            header.push_str(&format!("property float {axis}\n"));
        }
    }
    for (name, _) in extra {
        header.push_str(&format!("property float {name}\n"));
    }
    header.push_str(&format!(
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        geometry.triangles.len()
    ));
    out.write_all(header.as_bytes())?;

    const CHUNK: usize = 1 << 16;
    let mut buf: Vec<u8> = Vec::with_capacity(CHUNK + 256);
    for (i, p) in geometry.positions.iter().enumerate() {
        for c in p {
            buf.extend_from_slice(&(*c as f32).to_le_bytes());
        }
        if let Some(normal) = geometry.normals.as_ref().and_then(|ns| ns.get(i)) {
            for c in normal {
                buf.extend_from_slice(&(*c as f32).to_le_bytes());
            }
        }
        for (_, values) in extra {
            let v = values.get(i).copied().unwrap_or_default();
            buf.extend_from_slice(&v.to_le_bytes());
        }
        if buf.len() >= CHUNK {
            out.write_all(&buf)?;
            buf.clear();
        }
    }
    for tri in &geometry.triangles {
        buf.push(3);
        for &i in tri {
            // Validated above to be at most i32::MAX.
            let i = i32::try_from(i).unwrap_or(i32::MAX);
            buf.extend_from_slice(&i.to_le_bytes());
        }
        if buf.len() >= CHUNK {
            out.write_all(&buf)?;
            buf.clear();
        }
    }
    out.write_all(&buf)?;
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    // -- helpers -----------------------------------------------------------

    /// Unit cube: vertex `x + 2y + 4z`, two triangles per side.
    fn cube() -> RawGeometry {
        let positions = (0..8u32)
            .map(|i| {
                [
                    f64::from(i & 1),
                    f64::from((i >> 1) & 1),
                    f64::from((i >> 2) & 1),
                ]
            })
            .collect();
        let triangles = vec![
            [0, 2, 3],
            [0, 3, 1],
            [4, 5, 7],
            [4, 7, 6],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [0, 4, 6],
            [0, 6, 2],
            [1, 3, 7],
            [1, 7, 5],
        ];
        RawGeometry {
            positions,
            normals: None,
            triangles,
        }
    }

    fn cube_with_normals() -> RawGeometry {
        let mut g = cube();
        let s = 1.0 / 3f64.sqrt();
        g.normals = Some(
            g.positions
                .iter()
                .map(|p| p.map(|c| if c > 0.5 { s } else { -s }))
                .collect(),
        );
        g
    }

    fn point_cloud() -> RawGeometry {
        // Values exactly representable as f32, so the PLY round trip is exact.
        let positions = (0..5)
            .map(|i| {
                let t = f64::from(i);
                [t * 0.5, -t * 0.25, 3.0 + t * 0.125]
            })
            .collect();
        let normals = (0..5)
            .map(|i| {
                let t = f64::from(i);
                [t * 0.125, 1.0 - t * 0.125, 0.5]
            })
            .collect();
        RawGeometry {
            positions,
            normals: Some(normals),
            triangles: Vec::new(),
        }
    }

    #[derive(Clone, Copy, PartialEq)]
    enum Enc {
        Ascii,
        Le,
        Be,
    }

    impl Enc {
        fn name(self) -> &'static str {
            match self {
                Enc::Ascii => "ascii",
                Enc::Le => "binary_little_endian",
                Enc::Be => "binary_big_endian",
            }
        }
    }

    /// Builds a PLY file by hand in any of the three encodings.
    struct PlyBuilder {
        enc: Enc,
        out: Vec<u8>,
    }

    macro_rules! put {
        ($fn:ident, $t:ty) => {
            fn $fn(&mut self, v: $t) -> &mut Self {
                match self.enc {
                    Enc::Ascii => self.out.extend_from_slice(format!("{v:?} ").as_bytes()),
                    Enc::Le => self.out.extend_from_slice(&v.to_le_bytes()),
                    Enc::Be => self.out.extend_from_slice(&v.to_be_bytes()),
                }
                self
            }
        };
    }

    impl PlyBuilder {
        /// `header` is everything after the format line, up to and including `end_header\n`.
        fn new(enc: Enc, header: &str) -> Self {
            let out = format!("ply\nformat {} 1.0\n{header}", enc.name()).into_bytes();
            PlyBuilder { enc, out }
        }
        put!(f64, f64);
        put!(f32, f32);
        put!(i32, i32);
        put!(u32, u32);
        put!(u8, u8);
        put!(i16, i16);
        put!(u16, u16);
        fn nl(&mut self) -> &mut Self {
            if self.enc == Enc::Ascii {
                self.out.push(b'\n');
            }
            self
        }
    }

    fn stl_ascii(g: &RawGeometry) -> String {
        let mut s = String::from("solid cube\n");
        for t in &g.triangles {
            s.push_str("  facet normal 0 0 0\n    outer loop\n");
            for &i in t {
                let [x, y, z] = g.positions[i as usize];
                s.push_str(&format!("      vertex {x:e} {y:e} {z:e}\n"));
            }
            s.push_str("    endloop\n  endfacet\n");
        }
        s.push_str("endsolid cube\n");
        s
    }

    fn stl_binary(header: &[u8], g: &RawGeometry) -> Vec<u8> {
        let mut out = vec![0u8; 80];
        out[..header.len()].copy_from_slice(header);
        out.extend_from_slice(&(g.triangles.len() as u32).to_le_bytes());
        for t in &g.triangles {
            out.extend_from_slice(&[0u8; 12]);
            for &i in t {
                for c in g.positions[i as usize] {
                    out.extend_from_slice(&(c as f32).to_le_bytes());
                }
            }
            out.extend_from_slice(&[0u8; 2]);
        }
        out
    }

    /// The welded mesh must describe the same triangles, corner by corner.
    fn assert_same_triangles(original: &RawGeometry, welded: &RawGeometry) {
        assert_eq!(original.triangles.len(), welded.triangles.len());
        for (a, b) in original.triangles.iter().zip(&welded.triangles) {
            for k in 0..3 {
                assert_eq!(
                    original.positions[a[k] as usize],
                    welded.positions[b[k] as usize]
                );
            }
        }
    }

    fn ply_bytes(g: &RawGeometry, extra: &[(&str, &[f32])]) -> Vec<u8> {
        let mut out = Vec::new();
        write_ply(g, extra, &mut out).unwrap();
        out
    }

    fn obj_bytes(g: &RawGeometry) -> Vec<u8> {
        let mut out = Vec::new();
        write_obj(g, &mut out).unwrap();
        out
    }

    // -- round trips --------------------------------------------------------

    #[test]
    fn ply_round_trip_cube() {
        let g = cube();
        assert_eq!(parse_ply(&ply_bytes(&g, &[])).unwrap(), g);
        let g = cube_with_normals();
        let back = parse_ply(&ply_bytes(&g, &[])).unwrap();
        assert_eq!(back.positions, g.positions);
        assert_eq!(back.triangles, g.triangles);
        let normals = back.normals.unwrap();
        for (a, b) in normals.iter().zip(g.normals.as_ref().unwrap()) {
            for k in 0..3 {
                assert_eq!(a[k], f64::from(b[k] as f32));
            }
        }
    }

    #[test]
    fn ply_round_trip_point_cloud_with_normals_and_extras() {
        let g = point_cloud();
        let intensity = [0.5f32, 1.5, -2.25, 1e-3, 7.0];
        let curvature = [0.1f32, 0.2, 0.3, 0.4, f32::MAX];
        let bytes = ply_bytes(&g, &[("intensity", &intensity), ("curvature", &curvature)]);
        let (back, extras) =
            parse_ply_with_extras(&bytes, &["curvature", "intensity", "missing"]).unwrap();
        assert_eq!(back, g);
        let want = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<_>>();
        assert_eq!(extras[0].as_deref(), Some(&want(&curvature)[..]));
        assert_eq!(extras[1].as_deref(), Some(&want(&intensity)[..]));
        assert_eq!(extras[2], None);
        // Point clouds are written with an empty face element.
        assert!(back.triangles.is_empty());
    }

    #[test]
    fn obj_round_trip_cube_and_exact_coordinates() {
        let g = cube();
        assert_eq!(parse_obj(&obj_bytes(&g)).unwrap(), g);
        let g = cube_with_normals();
        assert_eq!(parse_obj(&obj_bytes(&g)).unwrap(), g);
        // Arbitrary doubles survive exactly.
        let mut g = cube();
        g.positions[3] = [0.1, 1.0 / 3.0, -1e-300];
        g.positions[5] = [1e300, -0.0, std::f64::consts::PI];
        assert_eq!(parse_obj(&obj_bytes(&g)).unwrap(), g);
    }

    #[test]
    fn obj_round_trip_point_cloud_with_normals() {
        let g = point_cloud();
        assert_eq!(parse_obj(&obj_bytes(&g)).unwrap(), g);
    }

    #[test]
    fn writers_reject_inconsistent_input() {
        let mut g = cube();
        g.triangles.push([0, 1, 8]);
        let mut out = Vec::new();
        assert_eq!(
            write_ply(&g, &[], &mut out).unwrap_err().kind(),
            io::ErrorKind::InvalidInput
        );
        assert_eq!(
            write_obj(&g, &mut out).unwrap_err().kind(),
            io::ErrorKind::InvalidInput
        );
        let g = cube();
        let short = [1.0f32; 3];
        let full = [1.0f32; 8];
        for extra in [
            &[("w", &short[..])][..],
            &[("x", &full[..])][..],
            &[("a b", &full[..])][..],
            &[("w", &full[..]), ("w", &full[..])][..],
        ] {
            let err = write_ply(&g, extra, &mut out).unwrap_err();
            assert_eq!(err.kind(), io::ErrorKind::InvalidInput, "{err}");
        }
    }

    // -- hand-written PLY ------------------------------------------------------

    const HAND_HEADER: &str = "comment written by hand\n\
        obj_info double coordinates with colors between x and y\n\
        element vertex 4\n\
        property double x\n\
        property uchar red\n\
        property uint8 green\n\
        property float64 y\n\
        property double z\n\
        property float intensity\n\
        element face 2\n\
        property list uchar int vertex_indices\n\
        property uchar flags\n\
        end_header\n";

    const HAND_POSITIONS: [[f64; 3]; 4] = [
        [0.1, 0.2, 0.3],
        [1.5, 0.0, -2.0],
        [1e-3, 2.5, 3.25],
        [-7.0, 8.0, 9.125],
    ];

    fn hand_written_ply(enc: Enc) -> Vec<u8> {
        let mut b = PlyBuilder::new(enc, HAND_HEADER);
        for (i, p) in HAND_POSITIONS.iter().enumerate() {
            b.f64(p[0])
                .u8(255)
                .u8(i as u8 * 10)
                .f64(p[1])
                .f64(p[2])
                .f32(i as f32 * 0.5)
                .nl();
        }
        b.u8(3).i32(0).i32(1).i32(2).u8(1).nl();
        b.u8(4).i32(0).i32(2).i32(3).i32(1).u8(0).nl();
        b.out
    }

    #[test]
    fn hand_written_ply_ascii_and_binary_with_doubles_and_colors() {
        let expected = RawGeometry {
            positions: HAND_POSITIONS.to_vec(),
            normals: None,
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 3, 1]],
        };
        for enc in [Enc::Ascii, Enc::Le, Enc::Be] {
            let bytes = hand_written_ply(enc);
            let (g, extras) = parse_ply_with_extras(&bytes, &["intensity", "green"]).unwrap();
            assert_eq!(g, expected, "{}", enc.name());
            assert_eq!(extras[0], Some(vec![0.0, 0.5, 1.0, 1.5]));
            assert_eq!(extras[1], Some(vec![0.0, 10.0, 20.0, 30.0]));
        }
        // CRLF header lines are accepted too.
        let text = String::from_utf8(hand_written_ply(Enc::Ascii)).unwrap();
        let crlf = text.replace('\n', "\r\n");
        assert_eq!(parse_ply(crlf.as_bytes()).unwrap(), expected);
    }

    #[test]
    fn ply_with_extra_elements_before_and_after_faces() {
        let header = "element vertex 4\n\
            property float32 x\n\
            property float32 y\n\
            property float32 z\n\
            property int16 nx\n\
            property int16 ny\n\
            property int16 nz\n\
            element edge 2\n\
            property int vertex1\n\
            property list uint8 uint32 path\n\
            property int vertex2\n\
            element face 2\n\
            property list uchar uint vertex_index\n\
            element material 2\n\
            property list int float weights\n\
            property uchar red\n\
            property list ushort double more\n\
            element empty_props 5\n\
            end_header\n";
        for enc in [Enc::Ascii, Enc::Le, Enc::Be] {
            let mut b = PlyBuilder::new(enc, header);
            for i in 0..4 {
                let t = i as f32;
                b.f32(t).f32(t * 2.0).f32(-t).i16(0).i16(1).i16(-1).nl();
            }
            b.i32(0).u8(3).u32(7).u32(8).u32(9).i32(1).nl();
            b.i32(2).u8(0).i32(3).nl();
            b.u8(3).u32(0).u32(1).u32(2).nl();
            b.u8(3).u32(0).u32(2).u32(3).nl();
            b.i32(2).f32(0.5).f32(0.25).u8(9).u16(1).f64(4.5).nl();
            b.i32(0).u8(1).u16(0).nl();
            let g = parse_ply(&b.out).unwrap_or_else(|e| panic!("{}: {e}", enc.name()));
            assert_eq!(g.positions.len(), 4);
            assert_eq!(g.positions[3], [3.0, 6.0, -3.0]);
            assert_eq!(g.normals.as_ref().unwrap()[2], [0.0, 1.0, -1.0]);
            assert_eq!(g.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        }
    }

    #[test]
    fn ply_without_face_element_is_a_point_cloud() {
        let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n\
                    property float y\nproperty float z\nend_header\n1 2 3\n4 5 6\n";
        let g = parse_ply(text.as_bytes()).unwrap();
        assert_eq!(g.positions, vec![[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]);
        assert!(g.triangles.is_empty());
        assert_eq!(g.normals, None);
    }

    // -- STL ------------------------------------------------------------------

    #[test]
    fn stl_ascii_and_binary_cube_are_welded() {
        let g = cube();
        let ascii = parse_stl(stl_ascii(&g).as_bytes()).unwrap();
        assert_eq!(ascii.positions.len(), 8);
        assert_eq!(ascii.triangles.len(), 12);
        assert_same_triangles(&g, &ascii);
        let binary = parse_stl(&stl_binary(b"binary cube", &g)).unwrap();
        assert_eq!(binary, ascii);
        assert_eq!(binary.normals, None);
    }

    #[test]
    fn stl_ascii_upper_case_crlf_and_polygon() {
        let text =
            "SOLID x\r\nFACET NORMAL 0 0 1\r\nOUTER LOOP\r\nVERTEX 0 0 0\r\nVERTEX 1 0 0\r\n\
                    VERTEX 1 1 0\r\nVERTEX 0 1 0\r\nENDLOOP\r\nENDFACET\r\nENDSOLID x\r\n";
        let g = parse_stl(text.as_bytes()).unwrap();
        assert_eq!(g.positions.len(), 4);
        assert_eq!(g.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn stl_binary_header_starting_with_solid() {
        let g = cube();
        for header in [&b"solid cube"[..], b"solid facet endsolid vertex", b"solid"] {
            let bytes = stl_binary(header, &g);
            let parsed = parse_stl(&bytes).unwrap();
            assert_eq!(parsed.positions.len(), 8);
            assert_same_triangles(&g, &parsed);
        }
    }

    #[test]
    fn stl_welds_negative_zero_with_zero() {
        let mut g = cube();
        g.positions[0] = [-0.0, 0.0, -0.0];
        let parsed = parse_stl(&stl_binary(b"", &g)).unwrap();
        assert_eq!(parsed.positions.len(), 8);
    }

    // -- OBJ ------------------------------------------------------------------

    #[test]
    fn obj_quads_negative_indices_and_slash_forms() {
        let text = "# a comment\r\n\
                    mtllib scene.mtl\r\n\
                    o thing\r\n\
                    v 0 0 0 1.0\r\n\
                    v 1 0 0 0.5 0.2 0.3\r\n\
                    v 1 1 0 # trailing comment\r\n\
                    v 0 1 0\r\n\
                    \r\n\
                    vt 0 0\r\n\
                    vn 0 0 1\r\n\
                    g group\r\n\
                    usemtl red\r\n\
                    s off\r\n\
                    f 1/1/1 2/1/1 3/1/1 4/1/1\r\n\
                    v 0 0 1\r\n\
                    f -1 -5 -4\r\n\
                    f 1/1 2/1 5/1\r\n\
                    f 2//1 3//1 5//1\r\n\
                    l 1 2\r\n\
                    p 3\r\n";
        let g = parse_obj(text.as_bytes()).unwrap();
        assert_eq!(
            g.positions,
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0]
            ]
        );
        assert_eq!(
            g.triangles,
            vec![[0, 1, 2], [0, 2, 3], [4, 0, 1], [0, 1, 4], [1, 2, 4]]
        );
        // Some corners have no normal: no unambiguous per-vertex normal.
        assert_eq!(g.normals, None);
    }

    #[test]
    fn obj_normals_only_when_unambiguous() {
        let consistent = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//1\n";
        let g = parse_obj(consistent.as_bytes()).unwrap();
        assert_eq!(g.normals, Some(vec![[0.0, 0.0, 1.0]; 3]));
        let conflicting = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvn 0 0 1\nvn 0 0 -1\nf 1//1 2//1 3//1\nf 2//2 4//2 3//2\n";
        assert_eq!(parse_obj(conflicting.as_bytes()).unwrap().normals, None);
        let unused_vertex = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 5 5 5\nvn 0 0 1\nf 1//1 2//1 3//1\n";
        assert_eq!(parse_obj(unused_vertex.as_bytes()).unwrap().normals, None);
        // Forward references are resolved after the whole file is read.
        let forward = "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
        assert_eq!(
            parse_obj(forward.as_bytes()).unwrap().triangles,
            vec![[0, 1, 2]]
        );
    }

    // -- errors -----------------------------------------------------------------

    #[test]
    fn error_truncated_binary() {
        let g = cube();
        let mut stl = stl_binary(b"binary", &g);
        stl.truncate(stl.len() - 7);
        let err = parse_stl(&stl).unwrap_err();
        assert!(
            matches!(err, LoadError::Truncated { format: "STL", expected, got, .. }
                if expected == 84 + 50 * 12 && got == expected - 7),
            "{err:?}"
        );
        assert!(err.to_string().contains("truncated"), "{err}");
        assert!(err.to_string().contains("12 facets"), "{err}");

        let mut ply = ply_bytes(&g, &[]);
        ply.truncate(ply.len() - 3);
        let err = parse_ply(&ply).unwrap_err();
        assert!(
            matches!(err, LoadError::Truncated { format: "PLY", .. }),
            "{err:?}"
        );
        // A list longer than the data left.
        let mut b = PlyBuilder::new(
            Enc::Le,
            "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
             element face 1\nproperty list uint int vertex_indices\nend_header\n",
        );
        for _ in 0..9 {
            b.f32(0.0);
        }
        b.u32(1_000_000).i32(0).i32(1).i32(2);
        let err = parse_ply(&b.out).unwrap_err();
        assert!(
            matches!(err, LoadError::Truncated { unit: "bytes", .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("face 0"), "{err}");

        let err = parse_stl(b"not an stl").unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::Truncated {
                    expected: 84,
                    got: 10,
                    ..
                }
            ),
            "{err:?}"
        );
    }

    #[test]
    fn error_bad_index() {
        let err = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::IndexOutOfRange {
                    format: "OBJ",
                    index: 9,
                    vertex_count: 3,
                    face: 0,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("line 4"), "{err}");
        let err = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n").unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::IndexOutOfRange {
                    index: -4,
                    vertex_count: 3,
                    ..
                }
            ),
            "{err:?}"
        );
        let err = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::Parse {
                    line_or_offset: 4,
                    kind: LocationKind::Line,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("start at 1"), "{err}");
        let err = parse_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n").unwrap_err();
        assert!(err.to_string().contains("normal index 1"), "{err}");

        let mut bytes = hand_written_ply(Enc::Le);
        // Last face's last index (before the trailing flags byte) -> 4.
        let at = bytes.len() - 5;
        bytes[at..at + 4].copy_from_slice(&4i32.to_le_bytes());
        let err = parse_ply(&bytes).unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::IndexOutOfRange {
                    format: "PLY",
                    face: 1,
                    index: 4,
                    vertex_count: 4,
                    ..
                }
            ),
            "{err:?}"
        );
        let offset = bytes.len() - 5;
        assert_eq!(
            err.to_string(),
            format!(
                "PLY: face 1 (byte offset {offset}) refers to vertex index 4, \
                 but only 4 vertices are available"
            )
        );
        let mut bytes = hand_written_ply(Enc::Be);
        let at = bytes.len() - 5;
        bytes[at..at + 4].copy_from_slice(&(-1i32).to_be_bytes());
        let err = parse_ply(&bytes).unwrap_err();
        assert!(
            matches!(err, LoadError::IndexOutOfRange { index: -1, .. }),
            "{err:?}"
        );
    }

    #[test]
    fn error_bad_index_ascii_ply_names_the_line() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                    end_header\n1 2 3\n1 2 3\n1 2 3\n3 0 1 5\n";
        let err = parse_ply(text.as_bytes()).unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::IndexOutOfRange {
                    index: 5,
                    vertex_count: 3,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("face 0 (line 13)"), "{err}");
    }

    #[test]
    fn error_non_finite() {
        let err = parse_obj(b"v 0 0 0\nv 1 nan 0\n").unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::NonFinite {
                    format: "OBJ",
                    index: 1,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("vertex 2 (line 2)"), "{err}");

        let mut g = cube();
        g.positions[5][2] = f64::INFINITY;
        let err = parse_ply(&ply_bytes(&g, &[])).unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::NonFinite {
                    format: "PLY",
                    index: 5,
                    ..
                }
            ),
            "{err:?}"
        );
        assert!(err.to_string().contains("vertex 5"), "{err}");
        assert!(err.to_string().contains("inf"), "{err}");

        let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
                    property float z\nend_header\n1 2 3\n1 NaN 3\n";
        let err = parse_ply(text.as_bytes()).unwrap_err();
        assert!(
            matches!(err, LoadError::NonFinite { index: 1, .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("vertex 1 (line 9)"), "{err}");

        let mut g = cube();
        g.positions[7][0] = f64::NAN;
        let err = parse_stl(&stl_binary(b"", &g)).unwrap_err();
        assert!(
            matches!(err, LoadError::NonFinite { format: "STL", .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("facet 2, vertex 2"), "{err}");
        let err = parse_stl(stl_ascii(&g).as_bytes()).unwrap_err();
        assert!(
            matches!(err, LoadError::NonFinite { format: "STL", .. }),
            "{err:?}"
        );
        assert!(err.to_string().contains("line"), "{err}");
    }

    #[test]
    fn error_unknown_extension_io_and_load_by_extension() {
        for name in ["mesh.xyz", "mesh", "mesh.obj.bak"] {
            let err = load_geometry(Path::new(name)).unwrap_err();
            assert!(matches!(err, LoadError::UnknownFormat { .. }), "{err:?}");
            assert!(err.to_string().contains(name), "{err}");
        }
        let missing = std::env::temp_dir().join("mesh_io_definitely_missing_file.obj");
        let err = load_geometry(&missing).unwrap_err();
        assert!(matches!(err, LoadError::Io { .. }), "{err:?}");
        assert!(
            err.to_string().contains("mesh_io_definitely_missing_file"),
            "{err}"
        );

        let dir = std::env::temp_dir();
        let pid = std::process::id();
        let g = cube();
        let files = [
            (
                dir.join(format!("mesh_io_test_{pid}.PLY")),
                ply_bytes(&g, &[]),
            ),
            (dir.join(format!("mesh_io_test_{pid}.Obj")), obj_bytes(&g)),
            (
                dir.join(format!("mesh_io_test_{pid}.stl")),
                stl_binary(b"", &g),
            ),
        ];
        for (path, bytes) in &files {
            std::fs::write(path, bytes).unwrap();
            let loaded = load_geometry(path);
            std::fs::remove_file(path).unwrap();
            let loaded = loaded.unwrap();
            assert_eq!(loaded.positions.len(), 8);
            assert_same_triangles(&g, &loaded);
        }
    }

    #[test]
    fn error_empty() {
        for (format, result) in [
            ("OBJ", parse_obj(b"")),
            ("STL", parse_stl(b"")),
            ("PLY", parse_ply(b"")),
            ("OBJ", parse_obj(b"# only a comment\n\no name\n")),
            ("STL", parse_stl(b"solid empty\nendsolid empty\n")),
            ("STL", parse_stl(&stl_binary(b"", &RawGeometry::default()))),
            (
                "PLY",
                parse_ply(
                    b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nend_header\n",
                ),
            ),
        ] {
            let err = result.unwrap_err();
            assert!(
                matches!(err, LoadError::Empty { format: f } if f == format),
                "{err:?}"
            );
            assert!(err.to_string().contains("no vertices"), "{err}");
        }
    }

    #[test]
    fn error_huge_claimed_count() {
        let header = "element vertex 1000000000000\nproperty float x\nproperty float y\n\
                      property float z\nelement face 1000000000000\n\
                      property list uchar int vertex_indices\nend_header\n";
        for enc in [Enc::Ascii, Enc::Le, Enc::Be] {
            let mut b = PlyBuilder::new(enc, header);
            while b.out.len() < 1000 {
                b.f32(1.0);
            }
            let err = parse_ply(&b.out).unwrap_err();
            assert!(
                matches!(err, LoadError::Truncated { format: "PLY", expected, got, .. }
                    if expected >= 3_000_000_000_000 && got < 1100),
                "{err:?}"
            );
            assert!(err.to_string().contains("1000000000000 vertex"), "{err}");
        }
        let mut stl = vec![b' '; 80];
        stl.extend_from_slice(&u32::MAX.to_le_bytes());
        stl.extend_from_slice(&[0u8; 900]);
        let err = parse_stl(&stl).unwrap_err();
        assert!(
            matches!(
                err,
                LoadError::Truncated {
                    format: "STL",
                    got: 984,
                    ..
                }
            ),
            "{err:?}"
        );
        // Elements without properties cost no data and are not iterated.
        let text = "ply\nformat binary_little_endian 1.0\nelement nothing 18446744073709551615\n\
                    element vertex 1\nproperty double x\nproperty double y\nproperty double z\n\
                    end_header\n";
        let mut bytes = text.as_bytes().to_vec();
        for v in [1.0f64, 2.0, 3.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        assert_eq!(parse_ply(&bytes).unwrap().positions, vec![[1.0, 2.0, 3.0]]);
    }

    #[test]
    fn error_messages_for_malformed_headers_and_lines() {
        let cases: [(&[u8], &str); 8] = [
            (b"plx\n", "`ply` magic"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\n", "end_header"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n", "float128"),
            (b"ply\nformat utf8 1.0\nend_header\n", "unsupported format"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n", "no scalar `y`"),
            (b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 abc 3\n", "`abc` is not a valid float"),
            (b"v 1 2\n", "vertex has 2 coordinates"),
            (b"v 0 0 0\nf 1 1\n", "at least 3"),
        ];
        for (bytes, needle) in cases {
            let err = if bytes.starts_with(b"v ") {
                parse_obj(bytes)
            } else {
                parse_ply(bytes)
            }
            .unwrap_err();
            assert!(matches!(err, LoadError::Parse { .. }), "{err:?}");
            assert!(err.to_string().contains(needle), "`{err}` lacks `{needle}`");
        }
        let err = parse_stl(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nendsolid\n")
            .unwrap_err();
        assert!(err.to_string().contains("line 5"), "{err}");
        assert!(err.to_string().contains("starts at line 2"), "{err}");
    }

    /// Every prefix and many single-byte corruptions of valid files must give
    /// `Ok` or `Err`, never a panic.
    #[test]
    fn malformed_input_never_panics() {
        let g = cube_with_normals();
        let weights = [0.5f32; 8];
        type Parser = fn(&[u8]) -> Result<RawGeometry, LoadError>;
        let inputs: Vec<(Parser, Vec<u8>)> = vec![
            (parse_ply, ply_bytes(&g, &[("w", &weights)])),
            (parse_ply, hand_written_ply(Enc::Ascii)),
            (parse_ply, hand_written_ply(Enc::Be)),
            (parse_stl, stl_binary(b"solid", &g)),
            (parse_stl, stl_ascii(&g).into_bytes()),
            (parse_obj, obj_bytes(&g)),
        ];
        for (parse, bytes) in &inputs {
            for len in 0..=bytes.len() {
                let _ = parse(&bytes[..len]);
            }
            let mut corrupted = bytes.clone();
            for i in 0..corrupted.len() {
                for value in [0u8, 0xff, b'9', b' ', b'-'] {
                    let old = corrupted[i];
                    corrupted[i] = value;
                    let _ = parse(&corrupted);
                    corrupted[i] = old;
                }
            }
        }
    }
}
