//! A soft body: inference of its skinning field, its reduced simulation, and its input points
//! lifted every step.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::geometry::{
    sample_surface, Cubature, Normalization, Shape, SurfaceSamples, SurfaceSampling, VoxelGrid,
};
use crate::physics::{Lifter, Obstacle, Poke, ReducedSim, SimParams, Solver, StepReport, Subspace};
use crate::skinning::{NeuralModel, SkinningField};
use crate::Result;

/// What holds an object in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Support {
    /// Nothing: the object falls freely.
    Free,
    /// A floor (z = the object's lowest point), penalty contact.
    Floor,
    /// The top 10% of the object (against gravity) is pinned: it hangs.
    PinTop,
    /// The bottom 10% (along gravity) is pinned: it stands.
    PinBottom,
}

/// How a body is built from geometry.
#[derive(Clone, Debug)]
pub struct BodyOptions {
    /// Surface samples encoded by the network. Default 4096 (the trained count).
    pub surface_points: usize,
    /// Interior points that fix the field's output normalization. Default 2048.
    pub reference_points: usize,
    /// Voxels across the longest side for the inside test. Default 64.
    pub voxel_resolution: usize,
    /// Cubature points of the elastic energy. Default 256.
    pub cubature: usize,
    pub sim: SimParams,
    /// Default quasi-Newton.
    pub solver: Solver,
    /// Default pin_bottom.
    pub support: Support,
}

impl Default for BodyOptions {
    fn default() -> Self {
        Self {
            surface_points: 4096,
            reference_points: 2048,
            voxel_resolution: 64,
            cubature: 256,
            sim: SimParams {
                damping: 1.0,
                young: 2e5,
                ..SimParams::default()
            },
            solver: Solver::QuasiNewton,
            support: Support::PinBottom,
        }
    }
}

/// Where the build time went, ms.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BuildTimings {
    pub voxelize_ms: f64,
    pub infer_ms: f64,
    pub subspace_ms: f64,
    pub weights_ms: f64,
    pub total_ms: f64,
}

/// One object: its skinning weights at the input points, its reduced simulation, and the
/// deformed input points after the last step. Slices are borrowed, never copied.
pub struct SoftBody {
    sim: ReducedSim,
    field: Arc<dyn SkinningField>,
    map: Normalization,
    lifter: Lifter,
    handles: usize,
    weights: Vec<f32>,
    deformed: Vec<f32>,
    cubature: Cubature,
    timings: BuildTimings,
    last: Option<StepReport>,
}

impl SoftBody {
    /// Builds the body of `shape`; `points` are the points to deform and report weights for
    /// (usually the shape's own positions).
    pub fn build(
        model: &Arc<NeuralModel>,
        shape: &Shape,
        points: &[Vector3<f64>],
        options: &BodyOptions,
    ) -> Result<Self> {
        options.sim.validate()?;
        let started = Instant::now();
        let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
        let map = shape.normalization();
        let grid = VoxelGrid::from_shape(shape, options.voxel_resolution, None);
        if grid.solid_volume() <= 0.0 {
            return Err(crate::Error::Geometry(
                "the shape encloses no volume at this voxel resolution".into(),
            ));
        }
        let (world, surface, reference) = network_input(
            shape,
            &grid,
            options.surface_points,
            options.reference_points,
        );
        let mut timings = BuildTimings {
            voxelize_ms: ms(started),
            ..Default::default()
        };

        let t = Instant::now();
        let field: Arc<dyn SkinningField> = Arc::new(model.field(&surface, &reference, map)?);
        timings.infer_ms = ms(t);

        let t = Instant::now();
        let cubature = Cubature::stratified(&grid, options.cubature, grid.solid_volume());
        let subspace = Arc::new(Subspace::build(
            field.clone(),
            map,
            &cubature,
            options.sim.density,
        ));
        let (lo, hi) = grid.solid_bounds();
        let mut sim = ReducedSim::new(
            subspace,
            options.sim.clone(),
            options.solver,
            (hi - lo).norm(),
        )?;
        apply_support(&mut sim, options, &cubature, &world.points, &world.areas);
        sim.prepare();
        timings.subspace_ms = ms(t);

        let t = Instant::now();
        let handles = field.handle_count();
        let (weights, _) = crate::physics::sample(field.as_ref(), &map, points, false);
        let lifter = Lifter::from_weights(handles, &weights, points);
        let deformed = points
            .iter()
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        timings.weights_ms = ms(t);
        timings.total_ms = ms(started);
        Ok(Self {
            sim,
            field,
            map,
            lifter,
            handles,
            weights: weights.into_iter().map(|w| w as f32).collect(),
            deformed,
            cubature,
            timings,
            last: None,
        })
    }

    /// The embedding entry point: a body from raw geometry with the bundled model. `points` holds
    /// x, y, z per point (world units, as a cloud's or a mesh's vertices); `triangles` indexes
    /// them (empty for a point cloud). The body then deforms exactly these points.
    pub fn from_points(
        points: &[f32],
        triangles: &[[u32; 3]],
        options: &BodyOptions,
    ) -> Result<Self> {
        if points.len() % 3 != 0 {
            return Err(crate::Error::Geometry(format!(
                "{} coordinates are not x, y, z triples",
                points.len()
            )));
        }
        let positions: Vec<Vector3<f64>> = points
            .chunks_exact(3)
            .map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .collect();
        let shape = Shape::new(positions.clone(), None, triangles.to_vec())?;
        Self::build(&NeuralModel::bundled()?, &shape, &positions, options)
    }

    /// Advances one time step and lifts the input points.
    pub fn step(&mut self) -> &StepReport {
        let report = self.sim.step();
        self.lifter.lift(self.sim.state(), &mut self.deformed);
        self.last.insert(report)
    }

    /// A force on the material point at `rest` (world, rest frame) for `duration` seconds from now.
    pub fn push(&mut self, rest: Vector3<f64>, force: Vector3<f64>, duration: f64) {
        let start = self.sim.time();
        self.sim.add_poke(Poke {
            point: rest,
            force,
            start,
            end: start + duration,
        });
    }

    /// Holds the material within `radius` of `rest` where it is now; returns the points held.
    pub fn hold(&mut self, rest: &Vector3<f64>, radius: f64) -> usize {
        let (points, masses) = self.cubature_within(rest, radius);
        self.sim.hold(&points, &masses);
        self.sim.prepare();
        points.len()
    }

    /// Releases the pins within `radius` of `rest`; returns how many.
    pub fn release(&mut self, rest: &Vector3<f64>, radius: f64) -> usize {
        let released = self.sim.release_pins_within(rest, radius);
        self.sim.prepare();
        released
    }

    fn cubature_within(&self, center: &Vector3<f64>, radius: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
        let density = self.sim.params().density;
        self.cubature
            .points
            .iter()
            .zip(&self.cubature.volumes)
            .filter(|(p, _)| (*p - center).norm() <= radius)
            .map(|(p, v)| (*p, v * density))
            .unzip()
    }

    /// A lifter for other points of this body (rest positions, world units), e.g. the vertices
    /// of a reference mesh: `lifter.lift(body.state(), out)` deforms them like the body.
    pub fn lifter_for(&self, points: &[Vector3<f64>]) -> Lifter {
        Lifter::new(self.field.as_ref(), &self.map, points)
    }

    /// Skinning weights at the input points: points x handles, row-major.
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// Deformed input points after the last step: x, y, z per point.
    pub fn deformed(&self) -> &[f32] {
        &self.deformed
    }

    pub fn point_count(&self) -> usize {
        self.lifter.len()
    }

    /// Handles, the constant one included.
    pub fn handles(&self) -> usize {
        self.handles
    }

    /// The 3 x 4K handle matrix.
    pub fn state(&self) -> &DMatrix<f64> {
        self.sim.state()
    }

    pub fn velocity(&self) -> DMatrix<f64> {
        self.sim.velocity()
    }

    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.sim.time()
    }

    pub fn last_step(&self) -> Option<&StepReport> {
        self.last.as_ref()
    }

    pub fn timings(&self) -> &BuildTimings {
        &self.timings
    }

    pub fn pin_count(&self) -> usize {
        self.sim.pin_count()
    }
}

/// What the network reads from a shape: `surface_points` surface samples (in world units, and
/// in the normalized frame) and `reference_points` stratified interior points (normalized) that
/// fix the output normalization. A fixed seed: the same geometry always gives the same input.
pub(crate) fn network_input(
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
    let reference = Cubature::stratified(grid, reference_points, grid.solid_volume())
        .points
        .iter()
        .map(|p| map.to_normalized(p))
        .collect();
    (world, surface, reference)
}

/// Pins a slab of the cubature points or adds a floor, per `options.support`.
fn apply_support(
    sim: &mut ReducedSim,
    options: &BodyOptions,
    cubature: &Cubature,
    surface: &[Vector3<f64>],
    areas: &[f64],
) {
    let g = options.sim.gravity;
    // "Up" is against gravity; without gravity, +z.
    let up = if g.norm() > 0.0 {
        -g.normalize()
    } else {
        Vector3::z()
    };
    let heights: Vec<f64> = cubature.points.iter().map(|p| p.dot(&up)).collect();
    let (lo, hi) = heights
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &h| {
            (a.min(h), b.max(h))
        });
    let slab = 0.1 * (hi - lo);
    let pin_where = |keep: &dyn Fn(f64) -> bool| -> (Vec<Vector3<f64>>, Vec<f64>) {
        cubature
            .points
            .iter()
            .zip(&cubature.volumes)
            .zip(&heights)
            .filter(|(_, &h)| keep(h))
            .map(|((p, v), _)| (*p, v * options.sim.density))
            .unzip()
    };
    match options.support {
        Support::Free => {}
        Support::PinTop => {
            let (points, masses) = pin_where(&|h| h >= hi - slab);
            sim.add_pins(&points, &masses);
        }
        Support::PinBottom => {
            let (points, masses) = pin_where(&|h| h <= lo + slab);
            sim.add_pins(&points, &masses);
        }
        Support::Floor => {
            let floor = surface.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
            sim.add_contact_points(surface, areas);
            sim.add_obstacle(Obstacle::floor(floor));
        }
    }
}
