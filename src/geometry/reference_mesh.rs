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
/// FEM's cost grows fast with vertices on compact shapes. Its cells tile the shape's bounds, so
/// that the reference ends where the shape does: a mesh a cut cell wider on every side (3 mm
/// on a 0.2 m box) closes gaps between stacked objects that the reduced bodies still have.
pub fn reference_mesh(shape: &Shape) -> ReferenceMesh {
    let fine = VoxelGrid::from_shape(shape, 128, None);
    let (lo, hi) = shape.bounds();
    let mut resolution = 8;
    let mesh = loop {
        let (grid, stretch) = fine.resample_fitted(lo, hi, resolution);
        let mesh = TetMesh::from_fitted_grid(&grid, stretch);
        if mesh.vertices.len() >= REFERENCE_VERTICES || resolution >= 64 {
            break mesh;
        }
        resolution += 2;
    };
    let (lo, hi) = mesh.bounds();
    ReferenceMesh {
        mesh: Arc::new(mesh),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::box_mesh;

    /// A box's reference ends where the box does on every axis, so that a gap between two
    /// stacked boxes, or a ball's drop onto a slab, is the same in the FEM as in the scene.
    /// Resampled from the solid cells' bounds instead, the 0.2 m box's mesh spanned 0.203 m;
    /// with cubic cells fitted to the longest side only, the 6 cm slab was 6.67 cm thick.
    #[test]
    fn a_box_reference_mesh_ends_where_the_box_does() {
        let sides = [
            [0.2, 0.2, 0.2],
            [0.16, 0.16, 0.16],
            [0.05, 0.05, 0.05],
            [0.4, 0.4, 0.06],
        ];
        for side in sides.map(Vector3::from) {
            let mesh = reference_mesh(&box_mesh(side)).mesh;
            for axis in 0..3 {
                let (lo, hi) = mesh
                    .vertices
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(lo, hi), v| {
                        (lo.min(v[axis]), hi.max(v[axis]))
                    });
                let half = side[axis] / 2.0;
                assert!(
                    (lo + half).abs() < 1e-9 && (hi - half).abs() < 1e-9,
                    "{side:?} m box, axis {axis}: mesh spans {lo} .. {hi}"
                );
            }
            let volume = mesh.volume();
            let boundary: f64 = mesh.boundary_areas.iter().sum();
            let area = 2.0 * (side.x * side.y + side.y * side.z + side.z * side.x);
            assert!(
                (volume / side.product() - 1.0).abs() < 1e-9,
                "volume {volume}"
            );
            assert!(
                (boundary / area - 1.0).abs() < 1e-9,
                "boundary area {boundary}"
            );
        }
    }
}
