//! Shapes made in code: the bundled defaults of the CLI and the bench, and test fixtures.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::shape::Shape;

/// The bundled shapes, by name.
pub const BUNDLED: [&str; 5] = ["plate", "rod", "creature", "box", "sphere"];

/// A bundled shape (world units, metres): `plate` (thin), `rod` (long and thin), `creature`
/// (an animal of capsules, the large one), `box`, `sphere`.
pub fn bundled(name: &str) -> Option<Shape> {
    Some(match name {
        "plate" => box_mesh(Vector3::new(1.0, 0.6, 0.04)),
        "rod" => capsule_mesh(1.2, 0.05),
        "creature" => creature(),
        "box" => box_mesh(Vector3::new(0.4, 0.3, 0.2)),
        "sphere" => sdf_mesh(&|p: &Vector3<f64>| p.norm() - 0.25, 0.3, 40),
        _ => return None,
    })
}

/// An axis-aligned box centered at the origin, outward-wound.
pub fn box_mesh(size: Vector3<f64>) -> Shape {
    let h = size / 2.0;
    let positions = (0..8)
        .map(|c| {
            Vector3::new(
                if c & 1 == 0 { -h.x } else { h.x },
                if c & 2 == 0 { -h.y } else { h.y },
                if c & 4 == 0 { -h.z } else { h.z },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1], // z-
        [4, 5, 7, 6], // z+
        [0, 1, 5, 4], // y-
        [2, 6, 7, 3], // y+
        [0, 4, 6, 2], // x-
        [1, 3, 7, 5], // x+
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Shape::new(positions, None, triangles).expect("a box is valid")
}

/// An axis-aligned box centered at the origin with its faces divided into squares of about
/// `spacing` (vertices shared along the edges), outward-wound: a box whose vertices are worth
/// publishing, not just its 8 corners.
pub fn box_grid_mesh(size: Vector3<f64>, spacing: f64) -> Shape {
    let h = size / 2.0;
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut positions: Vec<Vector3<f64>> = Vec::new();
    let mut triangles = Vec::new();
    let quantum = spacing.min(size.min()) * 1e-6;
    let mut vertex = |p: Vector3<f64>| -> u32 {
        let key = [0, 1, 2].map(|a| (p[a] / quantum).round() as i64);
        *index.entry(key).or_insert_with(|| {
            positions.push(p);
            (positions.len() - 1) as u32
        })
    };
    // Each face: the axis it faces along, its sign, and two in-plane axes ordered so that
    // u x v points outward.
    for (axis, sign) in [
        (0, 1.0),
        (0, -1.0),
        (1, 1.0),
        (1, -1.0),
        (2, 1.0),
        (2, -1.0),
    ] {
        let (mut u, mut v) = ((axis + 1) % 3, (axis + 2) % 3);
        if sign < 0.0 {
            std::mem::swap(&mut u, &mut v);
        }
        let cells = |a: usize| ((size[a] / spacing).ceil() as usize).clamp(1, 64);
        let (nu, nv) = (cells(u), cells(v));
        let mut ids = vec![0u32; (nu + 1) * (nv + 1)];
        for j in 0..=nv {
            for i in 0..=nu {
                let mut p = Vector3::zeros();
                p[axis] = sign * h[axis];
                p[u] = -h[u] + size[u] * i as f64 / nu as f64;
                p[v] = -h[v] + size[v] * j as f64 / nv as f64;
                ids[j * (nu + 1) + i] = vertex(p);
            }
        }
        for j in 0..nv {
            for i in 0..nu {
                let a = ids[j * (nu + 1) + i];
                let b = ids[j * (nu + 1) + i + 1];
                let c = ids[(j + 1) * (nu + 1) + i + 1];
                let d = ids[(j + 1) * (nu + 1) + i];
                triangles.push([a, b, c]);
                triangles.push([a, c, d]);
            }
        }
    }
    Shape::new(positions, None, triangles).expect("a box is valid")
}

/// A capsule along x: `length` end to end, `radius`.
pub fn capsule_mesh(length: f64, radius: f64) -> Shape {
    let half = length / 2.0 - radius;
    let sdf = move |p: &Vector3<f64>| {
        let x = p.x.clamp(-half, half);
        (p - Vector3::new(x, 0.0, 0.0)).norm() - radius
    };
    sdf_mesh(&sdf, length / 2.0 + 0.05 * length, 96)
}

/// A four-legged animal of capsules and ellipsoids, about 1 m long.
pub fn creature() -> Shape {
    sdf_mesh(&creature_sdf, 0.85, 80)
}

fn creature_sdf(p: &Vector3<f64>) -> f64 {
    let capsule = |p: &Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>, r: f64| {
        let ab = b - a;
        let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
        (p - (a + ab * t)).norm() - r
    };
    let body = {
        let q = Vector3::new(p.x / 0.42, p.y / 0.2, (p.z - 0.05) / 0.18);
        (q.norm() - 1.0) * 0.18
    };
    let mut d = body;
    for (x, y) in [(-0.28, -0.12), (-0.28, 0.12), (0.26, -0.12), (0.26, 0.12)] {
        let leg = capsule(
            p,
            Vector3::new(x, y, 0.0),
            Vector3::new(x * 1.1, y * 1.2, -0.38),
            0.065,
        );
        d = smooth_union(d, leg, 0.06);
    }
    let neck = capsule(
        p,
        Vector3::new(0.35, 0.0, 0.1),
        Vector3::new(0.52, 0.0, 0.33),
        0.08,
    );
    let head = capsule(
        p,
        Vector3::new(0.5, 0.0, 0.36),
        Vector3::new(0.68, 0.0, 0.3),
        0.1,
    );
    let tail = capsule(
        p,
        Vector3::new(-0.4, 0.0, 0.08),
        Vector3::new(-0.68, 0.0, 0.25),
        0.04,
    );
    for part in [neck, head, tail] {
        d = smooth_union(d, part, 0.05);
    }
    d
}

fn smooth_union(a: f64, b: f64, k: f64) -> f64 {
    let h = (0.5 + 0.5 * (b - a) / k).clamp(0.0, 1.0);
    b * (1.0 - h) + a * h - k * h * (1.0 - h)
}

/// Triangulates the zero level set of `sdf` (negative inside) within the cube [-half, half]^3 on
/// a `resolution`^3 lattice, by surface nets: one vertex per cell the surface crosses (the mean
/// of its edge crossings), one quad per crossed lattice edge.
pub fn sdf_mesh(sdf: &dyn Fn(&Vector3<f64>) -> f64, half: f64, resolution: usize) -> Shape {
    let n = resolution + 1;
    let step = 2.0 * half / resolution as f64;
    let at = |i: usize, j: usize, k: usize| {
        Vector3::new(i as f64, j as f64, k as f64) * step - Vector3::repeat(half)
    };
    let idx = |i: usize, j: usize, k: usize| i + n * (j + n * k);
    let mut values = vec![0.0; n * n * n];
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                values[idx(i, j, k)] = sdf(&at(i, j, k));
            }
        }
    }
    let mut cell_vertex: HashMap<[usize; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    for k in 0..resolution {
        for j in 0..resolution {
            for i in 0..resolution {
                let mut sum = Vector3::zeros();
                let mut crossings = 0;
                for (a, b) in CUBE_EDGES {
                    let ca = [i + (a & 1), j + ((a >> 1) & 1), k + (a >> 2)];
                    let cb = [i + (b & 1), j + ((b >> 1) & 1), k + (b >> 2)];
                    let (va, vb) = (
                        values[idx(ca[0], ca[1], ca[2])],
                        values[idx(cb[0], cb[1], cb[2])],
                    );
                    if (va < 0.0) != (vb < 0.0) {
                        let t = va / (va - vb);
                        sum += at(ca[0], ca[1], ca[2]) * (1.0 - t) + at(cb[0], cb[1], cb[2]) * t;
                        crossings += 1;
                    }
                }
                if crossings > 0 {
                    positions.push(sum / crossings as f64);
                    cell_vertex.insert([i, j, k], (positions.len() - 1) as u32);
                }
            }
        }
    }
    let mut triangles = Vec::new();
    for k in 1..resolution {
        for j in 1..resolution {
            for i in 1..resolution {
                for axis in 0..3 {
                    let mut end = [i, j, k];
                    end[axis] += 1;
                    let inside_start = values[idx(i, j, k)] < 0.0;
                    if inside_start == (values[idx(end[0], end[1], end[2])] < 0.0) {
                        continue;
                    }
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    let cell = |du: usize, dv: usize| {
                        let mut c = [i, j, k];
                        c[u] -= 1 - du;
                        c[v] -= 1 - dv;
                        cell_vertex[&c]
                    };
                    let quad = [cell(0, 0), cell(1, 0), cell(1, 1), cell(0, 1)];
                    let quad = if inside_start {
                        quad
                    } else {
                        [quad[0], quad[3], quad[2], quad[1]]
                    };
                    triangles.push([quad[0], quad[1], quad[2]]);
                    triangles.push([quad[0], quad[2], quad[3]]);
                }
            }
        }
    }
    Shape::new(positions, None, triangles).expect("a level set inside its lattice is valid")
}

/// The 12 edges of a cube as pairs of corner numbers (bit 0 = x, bit 1 = y, bit 2 = z).
const CUBE_EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];
