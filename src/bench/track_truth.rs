//! `bench track`'s truth: the full-space FEM run through a sequence, and the surface the camera
//! sees on it.

use std::sync::Arc;

use nalgebra::Vector3;

use crate::error::Result;
use crate::geometry::{reference_mesh, Shape, TetMesh};
use crate::physics::{FemSim, Obstacle, Poke};
use crate::runtime::NodeParams;

/// The FEM's run of a sequence: its tetrahedral mesh, surface, and vertex positions per step.
pub(super) struct Truth {
    pub(super) mesh: Arc<TetMesh>,
    pub(super) surface: Vec<[u32; 3]>,
    pub(super) positions: Vec<Vec<Vector3<f64>>>,
    pub(super) diagonal: f64,
}

impl Truth {
    /// Points spread over the FEM's surface at `step`, about as dense as a body's surface
    /// samples: each triangle at 15 barycentric points (its corners, edges and inside).
    pub(super) fn dense_surface(&self, step: usize) -> Vec<Vector3<f64>> {
        let x = &self.positions[step];
        let mut out = Vec::with_capacity(15 * self.surface.len());
        for t in &self.surface {
            let [a, b, c] = t.map(|i| x[i as usize]);
            for i in 0..=4 {
                for j in 0..=(4 - i) {
                    let (u, v) = (i as f64 / 4.0, j as f64 / 4.0);
                    out.push(a * (1.0 - u - v) + b * u + c * v);
                }
            }
        }
        out
    }

    pub(super) fn at(&self, step: usize, (t, b): (usize, [f64; 3])) -> Vector3<f64> {
        let tri = self.surface[t];
        (0..3)
            .map(|i| self.positions[step][tri[i] as usize] * b[i])
            .sum()
    }
}

/// The FEM stepped through the sequence: a floor at z = 0, the node's default material.
pub(super) fn run_truth(
    shape: &Shape,
    lifted: f64,
    pokes: &[Poke],
    params: &NodeParams,
    seconds: f64,
) -> Result<Truth> {
    let reference = reference_mesh(shape);
    let mut mesh = (*reference.mesh).clone();
    mesh.vertices.iter_mut().for_each(|v| v.z += lifted);
    let mesh = Arc::new(mesh);
    let mut fem = FemSim::new(mesh.clone(), params.sim_params())?;
    fem.add_obstacle(Obstacle::floor(0.0));
    for poke in pokes {
        let mut poke = *poke;
        poke.point.z += lifted;
        fem.add_poke(poke);
    }
    let steps = (seconds * params.rate_hz).round() as usize;
    let read = |fem: &FemSim| -> Vec<Vector3<f64>> {
        fem.positions()
            .chunks_exact(3)
            .map(|p| Vector3::new(p[0], p[1], p[2]))
            .collect()
    };
    let mut positions = vec![read(&fem)];
    for _ in 0..steps {
        fem.step()?;
        positions.push(read(&fem));
    }
    Ok(Truth {
        surface: boundary(&mesh),
        diagonal: reference.diagonal,
        mesh,
        positions,
    })
}

/// The outward-wound boundary triangles of a tetrahedral mesh: faces of one tetrahedron only.
fn boundary(mesh: &TetMesh) -> Vec<[u32; 3]> {
    let mut faces: std::collections::HashMap<[u32; 3], ([u32; 3], u32)> = Default::default();
    let mut count: std::collections::HashMap<[u32; 3], usize> = Default::default();
    for tet in &mesh.tets {
        for skip in 0..4 {
            let face: Vec<u32> = (0..4).filter(|&i| i != skip).map(|i| tet[i]).collect();
            let mut key = [face[0], face[1], face[2]];
            key.sort_unstable();
            *count.entry(key).or_default() += 1;
            faces.insert(key, ([face[0], face[1], face[2]], tet[skip]));
        }
    }
    let v = |i: u32| mesh.vertices[i as usize];
    let mut out: Vec<[u32; 3]> = count
        .into_iter()
        .filter(|(_, n)| *n == 1)
        .map(|(key, _)| {
            let (f, opposite) = faces[&key];
            let normal = (v(f[1]) - v(f[0])).cross(&(v(f[2]) - v(f[0])));
            if normal.dot(&(v(opposite) - v(f[0]))) > 0.0 {
                [f[0], f[2], f[1]]
            } else {
                f
            }
        })
        .collect();
    out.sort_unstable();
    out
}
