//! A new shape made ready for the network, as the product does it: used by `eval` and by
//! `bench sim` with the learned fields.

use nalgebra::Vector3;

use crate::geometry::{Shape, SurfaceSamples, VoxelGrid};

/// What the product does with a new shape before the network: the inside test, surface samples
/// with normals, stratified interior reference points, all in the normalized frame.
pub struct PreparedInput {
    /// The inside test: the shape voxelized at 128 cells across its longest side, largest
    /// solid island only.
    pub grid: VoxelGrid,
    /// Surface samples with unit outward normals, points in the normalized frame.
    pub surface: SurfaceSamples,
    /// Stratified interior reference points, normalized frame: they fix the output normalization.
    pub reference: Vec<Vector3<f64>>,
}

/// Prepares `shape` as the product does: `surface_points` surface samples and
/// `reference_points` interior reference points (a fixed seed: the same shape
/// always gives the same input).
pub fn prepare_input(
    shape: &Shape,
    surface_points: usize,
    reference_points: usize,
) -> PreparedInput {
    let mut grid = VoxelGrid::from_shape(shape, 128, None);
    grid.keep_largest_component();
    let (_, surface, reference) =
        crate::pipeline::network_input(shape, &grid, surface_points, reference_points);
    PreparedInput {
        grid,
        surface,
        reference,
    }
}
