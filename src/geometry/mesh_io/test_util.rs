//! Test helpers shared by the tests of every format: sample geometry and file builders.

use super::{write_obj, write_ply, RawGeometry};

/// Unit cube: vertex `x + 2y + 4z`, two triangles per side.
pub(super) fn cube() -> RawGeometry {
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

pub(super) fn cube_with_normals() -> RawGeometry {
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

pub(super) fn point_cloud() -> RawGeometry {
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
pub(super) enum Enc {
    Ascii,
    Le,
    Be,
}

impl Enc {
    pub(super) fn name(self) -> &'static str {
        match self {
            Enc::Ascii => "ascii",
            Enc::Le => "binary_little_endian",
            Enc::Be => "binary_big_endian",
        }
    }
}

/// Builds a PLY file by hand in any of the three encodings.
pub(super) struct PlyBuilder {
    enc: Enc,
    pub(super) out: Vec<u8>,
}

macro_rules! put {
    ($fn:ident, $t:ty) => {
        pub(super) fn $fn(&mut self, v: $t) -> &mut Self {
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
    pub(super) fn new(enc: Enc, header: &str) -> Self {
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
    pub(super) fn nl(&mut self) -> &mut Self {
        if self.enc == Enc::Ascii {
            self.out.push(b'\n');
        }
        self
    }
}

pub(super) fn stl_ascii(g: &RawGeometry) -> String {
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

pub(super) fn stl_binary(header: &[u8], g: &RawGeometry) -> Vec<u8> {
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
pub(super) fn assert_same_triangles(original: &RawGeometry, welded: &RawGeometry) {
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

pub(super) fn ply_bytes(g: &RawGeometry, extra: &[(&str, &[f32])]) -> Vec<u8> {
    let mut out = Vec::new();
    write_ply(g, extra, &mut out).unwrap();
    out
}

pub(super) fn obj_bytes(g: &RawGeometry) -> Vec<u8> {
    let mut out = Vec::new();
    write_obj(g, &mut out).unwrap();
    out
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

pub(super) const HAND_POSITIONS: [[f64; 3]; 4] = [
    [0.1, 0.2, 0.3],
    [1.5, 0.0, -2.0],
    [1e-3, 2.5, 3.25],
    [-7.0, 8.0, 9.125],
];

pub(super) fn hand_written_ply(enc: Enc) -> Vec<u8> {
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
