//! What the network reads from a shape (surface samples and reference points, drawn with fixed
//! seeds so the same geometry always gives the same input), and a field cut to fewer handles.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::options::BodyOptions;
use crate::geometry::{
    contact_samples, sample_surface, ContactSamples, Cubature, Normalization, Shape,
    SurfaceSamples, SurfaceSampling, VoxelGrid,
};
use crate::skinning::{SkinningField, TruncatedField};
use crate::Result;

/// A completed view's fill: points on and inside its surface, and the centre its prior reflects
/// through, where the inside test's grid puts a cell corner so that a solid the prior made
/// symmetric stays symmetric (see `VoxelGrid::from_filled_cloud`).
pub(super) struct Fill<'a> {
    pub(super) solid: &'a Shape,
    pub(super) centre: &'a Vector3<f64>,
}

/// What the network reads from a shape: `surface_points` surface samples (in world units, and
/// in the normalized frame) and `reference_points` stratified interior points (normalized) that
/// fix the output normalization. A fixed seed: the same geometry always gives the same input.
pub(super) struct NetworkInput {
    pub(super) map: Normalization,
    pub(super) grid: VoxelGrid,
    /// Evenly spread surface samples, the points that collide.
    pub(super) contact: ContactSamples,
    pub(super) surface: SurfaceSamples,
    pub(super) reference: Vec<Vector3<f64>>,
    pub(super) voxelize_ms: f64,
}

impl NetworkInput {
    /// `fill`: points filling `shape` (a completed view's), voxelized in its place.
    pub(super) fn new(shape: &Shape, fill: Option<Fill>, options: &BodyOptions) -> Result<Self> {
        options.sim.validate()?;
        shape.check_solid()?;
        let started = Instant::now();
        let grid = match fill {
            Some(fill) => VoxelGrid::from_filled_cloud(
                fill.solid,
                shape,
                options.voxel_resolution,
                fill.centre,
            ),
            None => VoxelGrid::from_shape(shape, options.voxel_resolution, None),
        };
        if grid.solid_volume() <= 0.0 {
            return Err(crate::Error::Geometry(
                "the shape encloses no volume at this voxel resolution".into(),
            ));
        }
        let (_, surface, reference) = network_input(
            shape,
            &grid,
            options.surface_points,
            options.reference_points,
        );
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let contact = contact_samples(shape, &grid, options.surface_points, &mut rng);
        Ok(Self {
            map: shape.normalization(),
            grid,
            contact,
            surface,
            reference,
            voxelize_ms: started.elapsed().as_secs_f64() * 1e3,
        })
    }
}

/// What the network reads from a shape: `surface_points` surface samples (in world units, and
/// in the normalized frame) and `reference_points` stratified interior points (normalized) that
/// fix the output normalization. A fixed seed: the same geometry always gives the same input.
pub fn network_input(
    shape: &Shape,
    grid: &VoxelGrid,
    surface_points: usize,
    reference_points: usize,
) -> (SurfaceSamples, SurfaceSamples, Vec<Vector3<f64>>) {
    let map = shape.normalization();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let world = sample_surface(
        shape,
        grid,
        &SurfaceSampling {
            count: surface_points,
            ..Default::default()
        },
        &mut rng,
    );
    let surface = SurfaceSamples {
        points: world.points.iter().map(|p| map.to_normalized(p)).collect(),
        normals: world.normals.clone(),
        areas: world.areas.clone(),
    };
    let reference = Cubature::stratified_points(grid, reference_points)
        .iter()
        .map(|p| map.to_normalized(p))
        .collect();
    (world, surface, reference)
}

/// Points on which the smoothest columns are chosen: a fixed number, whatever the body's own
/// cubature, so that every size of one shape keeps the same columns.
const TRUNCATION_POINTS: usize = 512;

pub(super) fn truncate(
    field: Arc<dyn SkinningField>,
    grid: &VoxelGrid,
    map: &Normalization,
    handles: usize,
) -> Arc<dyn SkinningField> {
    let points = Cubature::stratified(grid, TRUNCATION_POINTS, grid.solid_volume());
    let normalized: Vec<_> = points.points.iter().map(|p| map.to_normalized(p)).collect();
    Arc::new(TruncatedField::smoothest(
        field,
        &normalized,
        &points.volumes,
        handles,
    ))
}
