//! The Wavefront OBJ reader and writer.

use std::io::{self, Write};

use super::{
    check_finite, line_error, parse_vec3, to_u64, validate_for_writing, LoadError, RawGeometry,
};

const OBJ: &str = "OBJ";

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
    check_forward_refs(&forward, positions.len(), normals.len())?;
    let normals = assign_obj_normals(positions.len(), &normals, &corners);
    Ok(RawGeometry {
        positions,
        normals,
        triangles,
    })
}

/// Checks the forward references once every vertex and normal has been read.
fn check_forward_refs(
    forward: &[ForwardRef],
    vertex_count: usize,
    normal_count: usize,
) -> Result<(), LoadError> {
    for f in forward {
        let available = if f.normal { normal_count } else { vertex_count };
        if f.resolved >= to_u64(available) {
            return Err(obj_out_of_range(
                f.normal, f.index, available, f.line, f.face,
            ));
        }
    }
    Ok(())
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

#[cfg(test)]
mod tests {
    use super::super::test_util::{cube, cube_with_normals, obj_bytes, point_cloud};
    use super::parse_obj;

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
}
