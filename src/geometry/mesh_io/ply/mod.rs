//! The PLY reader and writer; the header and the data after it are read in `header` and `body`.

use std::io::{self, Write};

use self::body::{open_body, read_face_element, read_vertex_element, skip_element};
use self::header::{parse_ply_header, PlyElement, PropKind};
use super::{invalid_input, is_blank, line_error, validate_for_writing, LoadError, RawGeometry};

mod body;
mod header;

const PLY: &str = "PLY";

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

    let mut vertices = Vertices::new(vel, extra_names)?;
    let face_el = elements.iter().position(|e| e.name == "face");
    let face_list = face_el
        .map(|i| face_list_property(&elements[i]))
        .transpose()?;

    // Before reserving anything, check that the declared elements fit the data.
    let mut body = open_body(bytes, &header)?;

    // Every vertex takes at least one byte or value, so the count fits in memory now.
    let vertex_count = checked_vertex_count(vel)?;
    vertices.reserve(vertex_count);
    let mut triangles = Vec::new();

    for (ei, element) in elements.iter().enumerate() {
        if element.props.is_empty() {
            continue;
        }
        if ei == vertex_el {
            read_vertex_element(&mut body, element, &mut vertices)?;
        } else if Some(ei) == face_el {
            let list = face_list.unwrap_or(usize::MAX);
            read_face_element(&mut body, element, list, vertex_count, &mut triangles)?;
        } else {
            skip_element(&mut body, element)?;
        }
    }
    Ok(vertices.finish(triangles))
}

/// The vertex element: where each of its properties goes, and the values read so far.
struct Vertices {
    slots: Vec<Slot>,
    has_normals: bool,
    positions: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    extras: ExtraValues,
}

impl Vertices {
    /// Assigns the properties of the vertex element `vel`: `x y z` (required),
    /// `nx ny nz` (when all three are present), and each of `extra_names` that
    /// is a scalar property not taken already.
    fn new(vel: &PlyElement, extra_names: &[&str]) -> Result<Self, LoadError> {
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
        Ok(Vertices {
            slots,
            has_normals,
            positions: Vec::new(),
            normals: Vec::new(),
            extras,
        })
    }

    /// Reserves room for `vertex_count` vertices.
    fn reserve(&mut self, vertex_count: usize) {
        self.positions = Vec::with_capacity(vertex_count);
        self.normals = Vec::with_capacity(if self.has_normals { vertex_count } else { 0 });
        for extra in self.extras.iter_mut().flatten() {
            extra.reserve_exact(vertex_count);
        }
    }

    /// The geometry read, with `triangles`, and the values of the extra properties.
    fn finish(self, triangles: Vec<[u32; 3]>) -> (RawGeometry, ExtraValues) {
        let geometry = RawGeometry {
            positions: self.positions,
            normals: self.has_normals.then_some(self.normals),
            triangles,
        };
        (geometry, self.extras)
    }
}

/// The index of the face element's `vertex_indices` (or `vertex_index`) list property.
fn face_list_property(fel: &PlyElement) -> Result<usize, LoadError> {
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
        })
}

/// The vertex count of `vel`, checked to fit in a `u32`.
fn checked_vertex_count(vel: &PlyElement) -> Result<usize, LoadError> {
    usize::try_from(vel.count)
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
        })
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
    check_extra_properties(extra, n)?;
    out.write_all(ply_header(geometry, extra).as_bytes())?;

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

/// Checks that every entry of `extra` has a usable name and one value for each
/// of the `n` vertices.
fn check_extra_properties(extra: &[(&str, &[f32])], n: usize) -> io::Result<()> {
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
    Ok(())
}

/// The header that [`write_ply`] writes for `geometry` and the `extra` properties.
fn ply_header(geometry: &RawGeometry, extra: &[(&str, &[f32])]) -> String {
    let n = geometry.positions.len();
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
    header
}

#[cfg(test)]
mod tests;
