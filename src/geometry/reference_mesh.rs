//! The tetrahedral mesh a shape's full-space FEM reference runs on (the demo's, a scene's and
//! the error-budget probe's), and the vertices it pins.

use std::sync::Arc;

use nalgebra::Vector3;

use super::{Shape, TetMesh, VoxelGrid};

/// FEM mesh size of the reference: at least this many vertices.
const REFERENCE_VERTICES: usize = 500;

/// A shape's reference mesh and the diagonal of its solid, m (errors are % of it).
pub struct ReferenceMesh {
    /// The tetrahedral mesh the FEM runs on.
    pub mesh: Arc<TetMesh>,
    /// Diagonal of the voxelized solid's bounds, m.
    pub diagonal: f64,
}

/// The coarsest tetrahedral mesh of the shape's interior with REFERENCE_VERTICES vertices: the
/// FEM's cost grows fast with vertices on compact shapes.
pub fn reference_mesh(shape: &Shape) -> ReferenceMesh {
    let fine = VoxelGrid::from_shape(shape, 128, None);
    let mut resolution = 8;
    let grid = loop {
        let grid = fine.resample(resolution);
        if TetMesh::from_grid(&grid).vertices.len() >= REFERENCE_VERTICES || resolution >= 64 {
            break grid;
        }
        resolution += 2;
    };
    let (lo, hi) = grid.solid_bounds();
    ReferenceMesh {
        mesh: Arc::new(TetMesh::from_grid(&grid)),
        diagonal: (hi - lo).norm(),
    }
}

/// The vertices in the lowest 10% along gravity: the FEM's counterpart of `pin_bottom`.
pub fn bottom_vertices(vertices: &[Vector3<f64>], gravity: &Vector3<f64>) -> Vec<usize> {
    let up = if gravity.norm() > 0.0 {
        -gravity.normalize()
    } else {
        Vector3::z()
    };
    let heights: Vec<f64> = vertices.iter().map(|v| v.dot(&up)).collect();
    let lo = heights.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = heights.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let slab = 0.1 * (hi - lo);
    (0..vertices.len())
        .filter(|&i| heights[i] <= lo + slab)
        .collect()
}
