//! Tests that span several formats: the writers' checks, the errors of every reader, and the loader.

use std::io;
use std::path::Path;

use super::test_util::{
    assert_same_triangles, cube, cube_with_normals, hand_written_ply, obj_bytes, ply_bytes,
    stl_ascii, stl_binary, Enc, PlyBuilder,
};
use super::{
    load_geometry, parse_obj, parse_ply, parse_stl, write_obj, write_ply, LoadError, LocationKind,
    RawGeometry,
};

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
            parse_ply(b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nend_header\n"),
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
