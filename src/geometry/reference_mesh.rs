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

/// The vertices in the lowest slab along gravity (see [`pinned_slab_top`], their lumped
/// volumes weighing them): the FEM's counterpart of `pin_bottom`, which pins the body's
/// cubature points in the same slab.
pub fn bottom_vertices(mesh: &TetMesh, gravity: &Vector3<f64>) -> Vec<usize> {
    let up = if gravity.norm() > 0.0 {
        -gravity.normalize()
    } else {
        Vector3::z()
    };
    let heights: Vec<f64> = mesh.vertices.iter().map(|v| v.dot(&up)).collect();
    let top = pinned_slab_top(&heights, &mesh.lumped_volumes());
    (0..heights.len()).filter(|&i| heights[i] <= top).collect()
}

/// The pinned slab is this fraction of the body's height.
const PINNED_SLAB: f64 = 0.1;
/// At least this share of the body's volume is pinned, the slab widened until it holds it. A
/// body whose lowest part is a corner (the rclpy peer's box, seen from one camera and
/// completed standing on its corner) had one of its 256 cubature points in the slab: pinned at
/// one point, the soft box toppled about it, its points moving 325.646 mm within 20 steps.
/// With its 8 lowest points pinned, its points moved 2.261-2.415 mm, and a switch to its
/// refined field moved one by 1.374-1.950 mm; holding a sixteenth of its volume, 0.942-1.050 mm
/// and 0.294-0.556 mm (printed).
const MIN_PINNED_SHARE: f64 = 1.0 / 16.0;

/// The height up to which points at `heights`, of volumes `weights`, are pinned from the
/// lowest: `PINNED_SLAB` of the heights' range, or as high as the lowest points holding
/// `MIN_PINNED_SHARE` of the volume reach if that is higher. The FEM's vertices and the reduced
/// body's cubature points are pinned alike.
pub fn pinned_slab_top(heights: &[f64], weights: &[f64]) -> f64 {
    let mut order: Vec<usize> = (0..heights.len()).collect();
    order.sort_by(|&a, &b| heights[a].total_cmp(&heights[b]));
    let (Some(&first), Some(&last)) = (order.first(), order.last()) else {
        return f64::NEG_INFINITY;
    };
    let (lo, hi) = (heights[first], heights[last]);
    let wanted = MIN_PINNED_SHARE * weights.iter().sum::<f64>();
    let mut held = 0.0;
    let enough = order
        .iter()
        .find(|&&i| {
            held += weights[i];
            held >= wanted
        })
        .map_or(hi, |&i| heights[i]);
    (lo + PINNED_SLAB * (hi - lo)).max(enough)
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

    /// The slab is a tenth of the height, widened to hold at least a sixteenth of the volume.
    #[test]
    fn the_pinned_slab_holds_at_least_a_sixteenth_of_the_volume() {
        let even: Vec<f64> = (0..100).map(|i| i as f64).collect();
        assert_eq!(pinned_slab_top(&even, &[1.0; 100]), 9.9);
        let mut corner = vec![0.0];
        corner.extend((0..99).map(|i| 10.0 + i as f64 * 0.9));
        let top = pinned_slab_top(&corner, &[1.0; 100]);
        assert_eq!(corner.iter().filter(|&&h| h <= top).count(), 7);
        // A heavy lowest point holds the share by itself.
        let mut heavy = vec![1.0; 100];
        heavy[0] = 10.0;
        assert_eq!(pinned_slab_top(&corner, &heavy), 0.1 * corner[99]);
        assert_eq!(pinned_slab_top(&[], &[]), f64::NEG_INFINITY);
    }
}
