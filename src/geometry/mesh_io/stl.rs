//! The STL reader, binary and ASCII.

use std::collections::HashMap;

use super::{
    check_finite, is_blank, line_error, parse_error, parse_vec3, to_u64, LoadError, LocationKind,
    RawGeometry,
};

const STL: &str = "STL";

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
                close_stl_facet(&corners, facet_count, line, &mut triangles)?;
                facet_count += 1;
                facet_start = None;
            }
            (_, start) => return Err(unexpected_stl_keyword(&keyword, start, line)),
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

/// Fan-triangulates the corners of the facet that ends at `line`.
fn close_stl_facet(
    corners: &[u32],
    facet_count: usize,
    line: usize,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<(), LoadError> {
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
    Ok(())
}

/// The error for a `keyword` at `line` that is misplaced (`facet_start` is the
/// line of the facet that is open, if any) or unknown.
fn unexpected_stl_keyword(keyword: &str, facet_start: Option<usize>, line: usize) -> LoadError {
    let message = match (keyword, facet_start) {
        ("solid" | "endsolid" | "facet", Some(start)) => format!(
            "`{keyword}` inside the facet that starts at line {start} (missing `endfacet`?)"
        ),
        ("outer" | "endloop" | "vertex" | "endfacet", None) => {
            format!("`{keyword}` outside of a facet (missing `facet normal`?)")
        }
        _ => format!(
            "unexpected `{keyword}`; expected solid, facet, outer loop, vertex, \
             endloop, endfacet or endsolid"
        ),
    };
    line_error(STL, line, message)
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{assert_same_triangles, cube, stl_ascii, stl_binary};
    use super::parse_stl;

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
}
