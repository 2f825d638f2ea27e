//! Tests of the PLY reader and writer.

use super::super::test_util::{
    cube, cube_with_normals, hand_written_ply, ply_bytes, point_cloud, Enc, PlyBuilder,
    HAND_POSITIONS,
};
use super::super::{LoadError, RawGeometry};
use super::{parse_ply, parse_ply_with_extras};

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
