//! A soft body: inference of its skinning field, its reduced simulation, and its input points
//! lifted every step.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, Isometry3, Vector3};
use serde::Serialize;

use super::input::{truncate, Fill, NetworkInput};
use super::options::{BodyOptions, SleepRule};
use super::support::apply_support;
use super::switch::{refine_on_solid, BasisPlan, PreparedBasis, SwitchReport};
use crate::geometry::{Completed, ContactSamples, Cubature, Normalization, Shape, VoxelGrid};
use crate::physics::{Lifter, Obstacle, ReducedSim, StepReport, Subspace};
use crate::skinning::{NeuralModel, RefineBudget, RefineOptions, SkinningField};
use crate::{Error, Result};

mod hands;

/// Contact points a body's hull for other bodies is made of (every k-th): the hull of 256
/// points evenly spread over a 0.1 m ball's surface stays within about 0.6 mm of the sphere
/// (chord sag s^2 / 8r for their ~2.2 cm spacing), with a few hundred faces to test.
pub const HULL_POINTS: usize = 256;

/// Where the build time went, ms.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BuildTimings {
    /// The inside test and the network's input samples.
    pub voxelize_ms: f64,
    /// The network's forward pass.
    pub infer_ms: f64,
    /// Cubature, subspace and simulator, its support and the solver's factorization.
    pub subspace_ms: f64,
    /// The skinning weights at the input points.
    pub weights_ms: f64,
    /// Refining the field toward the eigenmodes and switching to it (0 when off).
    pub refine_ms: f64,
    /// The whole build.
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
    /// Surface samples (world) and their areas: the points that collide.
    surface: ContactSamples,
    timings: BuildTimings,
    last: Option<StepReport>,
    sleep: Option<SleepRule>,
    activity: Activity,
    /// Bounds of the deformed input points after the last step (min, max).
    bounds: (Vector3<f64>, Vector3<f64>),
    decision: String,
    /// The solid the body was built on (world units), for drawing a cloud's surface.
    grid: VoxelGrid,
}

/// Whether the body steps, and what it needs to go to sleep or wake.
#[derive(Clone, Debug, Default)]
struct Activity {
    /// Simulated seconds the body has been still.
    still_for: f64,
    asleep: bool,
    /// It fell asleep in the last call to `step`.
    fell_asleep: bool,
    /// Something happened to it (force, pin, attachment, collider) since the last step.
    disturbed: bool,
    /// The colliders' bounds when it fell asleep: the same colliders standing still beside it do
    /// not wake it.
    colliders_when_asleep: Vec<Option<(Vector3<f64>, Vector3<f64>)>>,
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
        Self::build_filled(model, shape, None, points, options)
    }

    /// Builds the body of a view completed to a solid ([`Completed`]): the
    /// network reads its closed surface, the inside test its fill; `points` (usually the
    /// observed ones) are deformed.
    pub fn build_view(
        model: &Arc<NeuralModel>,
        view: &Completed,
        points: &[Vector3<f64>],
        options: &BodyOptions,
    ) -> Result<Self> {
        let surface = Shape::new(view.surface.clone(), None, Vec::new())?;
        let solid = Shape::new(view.solid.clone(), None, Vec::new())?;
        let fill = Fill {
            solid: &solid,
            centre: &view.centre,
        };
        let mut body = Self::build_filled(model, &surface, Some(fill), points, options)?;
        let r = &view.report;
        body.decision = format!(
            "{}; completed one view ({}, prior {}): observed {:.1} % of the surface, {:.3e} m^3, {:.3} m deep",
            body.decision,
            r.method,
            r.prior.name(),
            100.0 * r.observed_fraction,
            body.volume(),
            r.depth
        );
        Ok(body)
    }

    fn build_filled(
        model: &Arc<NeuralModel>,
        shape: &Shape,
        fill: Option<Fill>,
        points: &[Vector3<f64>],
        options: &BodyOptions,
    ) -> Result<Self> {
        let started = Instant::now();
        let input = NetworkInput::new(shape, fill, options)?;
        let t = Instant::now();
        let field: Arc<dyn SkinningField> =
            Arc::new(model.field(&input.surface, &input.reference, input.map)?);
        let infer_ms = t.elapsed().as_secs_f64() * 1e3;
        let mut body = Self::assemble(input, field, points, options, started, infer_ms)?;
        // The constant handle alone (a rigid body with affine freedom) has nothing to refine.
        if options.refine != RefineBudget::Off && body.handles > 1 {
            let t = Instant::now();
            let refine = RefineOptions {
                budget: options.refine,
                ..Default::default()
            };
            match body.basis_plan().refined(&refine) {
                Ok(plan) => {
                    body.switch_to(plan)?;
                }
                // A solid too thin to refine on keeps the network's field, and says so.
                Err(Error::Geometry(why)) => {
                    body.decision = format!("{}; network field kept, {why}", body.decision);
                }
                Err(e) => return Err(e),
            }
            body.timings.refine_ms = t.elapsed().as_secs_f64() * 1e3;
            body.timings.total_ms = started.elapsed().as_secs_f64() * 1e3;
        }
        Ok(body)
    }

    /// Builds the body of `shape` with a field already inferred for the same geometry (up to
    /// a translation: fields live in the normalized frame), e.g. from a cache.
    pub fn with_field(
        field: Arc<dyn SkinningField>,
        shape: &Shape,
        points: &[Vector3<f64>],
        options: &BodyOptions,
    ) -> Result<Self> {
        let started = Instant::now();
        let input = NetworkInput::new(shape, None, options)?;
        Self::assemble(input, field, points, options, started, 0.0)
    }

    /// `field` cut to `handles` for `shape` (as `BodyOptions::handles` does): for callers that
    /// cache fields, so that copies of a shape share their columns exactly.
    pub fn truncated_field(
        field: Arc<dyn SkinningField>,
        shape: &Shape,
        options: &BodyOptions,
        handles: usize,
    ) -> Result<Arc<dyn SkinningField>> {
        if handles >= field.handle_count() {
            return Ok(field);
        }
        let input = NetworkInput::new(shape, None, options)?;
        Ok(truncate(field, &input.grid, &input.map, handles))
    }

    /// The field of `shape` in one forward pass, refined as `options.refine` says, for
    /// callers of [`SoftBody::with_field`] that keep fields (the same geometry always gives
    /// the same network input).
    pub fn infer(
        model: &Arc<NeuralModel>,
        shape: &Shape,
        options: &BodyOptions,
    ) -> Result<Arc<dyn SkinningField>> {
        let input = NetworkInput::new(shape, None, options)?;
        let field = model.field(&input.surface, &input.reference, input.map)?;
        Self::refine_on_input(Arc::new(field), &input, options.refine)
    }

    /// `field` (of `shape`'s geometry, e.g. cut to fewer handles) refined toward the skinning
    /// eigenmodes as `budget` says; `field` itself when the budget is off.
    pub fn refined_field(
        field: Arc<dyn SkinningField>,
        shape: &Shape,
        options: &BodyOptions,
        budget: RefineBudget,
    ) -> Result<Arc<dyn SkinningField>> {
        if budget == RefineBudget::Off {
            return Ok(field);
        }
        let input = NetworkInput::new(shape, None, options)?;
        Self::refine_on_input(field, &input, budget)
    }

    fn refine_on_input(
        field: Arc<dyn SkinningField>,
        input: &NetworkInput,
        budget: RefineBudget,
    ) -> Result<Arc<dyn SkinningField>> {
        if budget == RefineBudget::Off || field.handle_count() <= 1 {
            return Ok(field);
        }
        let refine = RefineOptions {
            budget,
            ..Default::default()
        };
        match refine_on_solid(field.as_ref(), &input.grid, input.map, &refine, &|| false) {
            Ok(refined) => Ok(Arc::new(refined.field)),
            // A solid too thin to refine on keeps the network's field.
            Err(Error::Geometry(_)) => Ok(field),
            Err(e) => Err(e),
        }
    }

    fn assemble(
        input: NetworkInput,
        field: Arc<dyn SkinningField>,
        points: &[Vector3<f64>],
        options: &BodyOptions,
        started: Instant,
        infer_ms: f64,
    ) -> Result<Self> {
        let ms = |t: Instant| t.elapsed().as_secs_f64() * 1e3;
        let NetworkInput {
            map,
            grid,
            mut contact,
            voxelize_ms,
            ..
        } = input;
        let mut timings = BuildTimings {
            voxelize_ms,
            infer_ms,
            ..Default::default()
        };

        let t = Instant::now();
        let cubature = Cubature::stratified(&grid, options.cubature, grid.solid_volume());
        let field = match options.handles {
            Some(m) if m < field.handle_count() => truncate(field, &grid, &map, m),
            _ => field,
        };
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
        apply_support(&mut sim, options, &cubature, &mut contact, 0.5 * grid.cell);
        sim.prepare();
        timings.subspace_ms = ms(t);

        let t = Instant::now();
        let handles = field.handle_count();
        let (weights, _) = crate::physics::sample(field.as_ref(), &map, points, false);
        let lifter = Lifter::from_weights(handles, &weights, points);
        let deformed: Vec<f32> = points
            .iter()
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
            .collect();
        timings.weights_ms = ms(t);
        timings.total_ms = ms(started);
        let decision = format!(
            "{handles} handles, {} cubature points (fixed)",
            cubature.len()
        );
        Ok(Self {
            sim,
            field,
            map,
            lifter,
            handles,
            weights: weights.into_iter().map(|w| w as f32).collect(),
            bounds: bounds_of(&deformed),
            deformed,
            cubature,
            surface: contact,
            timings,
            last: None,
            sleep: options.sleep,
            activity: Activity::default(),
            decision,
            grid,
        })
    }

    /// What preparing a switch to another field of this shape needs (`BasisPlan`): owned,
    /// for another thread.
    pub fn basis_plan(&self) -> BasisPlan {
        BasisPlan {
            field: self.field.clone(),
            map: self.map,
            cubature: self.cubature.clone(),
            points: self.lifter.rest_points(),
            contacts: self.sim.contact_rests(),
            setup: self.sim.setup(),
            grid: self.grid.clone(),
        }
    }

    /// Continues in the prepared field's subspace from where the body is now (call it between
    /// two steps): the state is fitted by least squares on the cubature points and the body's
    /// points (`BasisPlan`), and the points are lifted anew; reports how far the farthest point
    /// moved at the switch. Refused when the basis was prepared from another body or an
    /// earlier build of this one.
    pub fn switch_to(&mut self, prepared: PreparedBasis) -> Result<SwitchReport> {
        if !Arc::ptr_eq(&self.field, &prepared.from) {
            return Err(crate::Error::InvalidParameter {
                name: "basis",
                reason: "prepared from a field this body no longer runs (it was rebuilt)".into(),
            });
        }
        self.sim
            .rebase(prepared.twin, &prepared.projection, prepared.contact_phis)?;
        let handles = prepared.field.handle_count();
        let lifter = prepared.lifter;
        let mut deformed = vec![0.0f32; self.deformed.len()];
        lifter.lift(self.sim.state(), &mut deformed);
        let max_jump_m = deformed
            .chunks_exact(3)
            .zip(self.deformed.chunks_exact(3))
            .map(|(a, b)| {
                let d = Vector3::new(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
                d.cast::<f64>().norm()
            })
            .fold(0.0, f64::max);
        if let Some(report) = &prepared.refine {
            self.decision = format!(
                "{}; field refined toward the eigenmodes ({} iterations)",
                self.decision, report.iterations
            );
        }
        self.bounds = bounds_of(&deformed);
        self.deformed = deformed;
        self.lifter = lifter;
        self.handles = handles;
        self.weights = prepared.weights;
        self.field = prepared.field;
        Ok(SwitchReport {
            max_jump_m,
            handles,
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
        if !points.len().is_multiple_of(3) {
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

    /// Advances one time step and lifts the input points; a sleeping body stays as it is and
    /// reports its last step again.
    pub fn step(&mut self) -> &StepReport {
        let activity = &mut self.activity;
        activity.fell_asleep = false;
        if activity.asleep {
            if !std::mem::take(&mut activity.disturbed) {
                return self.last.get_or_insert_with(StepReport::default);
            }
            // Asleep means still: wake at rest velocity.
            activity.asleep = false;
            activity.still_for = 0.0;
            self.sim.set_state(self.sim.state().clone(), None);
        }
        let disturbed = std::mem::take(&mut self.activity.disturbed);
        let report = self.sim.step();
        self.lift_deformed();
        if let Some(rule) = self.sleep {
            self.update_sleep(&rule, &report, disturbed);
        }
        self.last.insert(report)
    }

    /// Does now the work its next step would begin with (see `ReducedSim::prepare`): call it
    /// once a step's outputs are out, and that work no longer delays the next step's.
    pub fn prepare(&mut self) {
        self.sim.prepare();
    }

    fn update_sleep(&mut self, rule: &SleepRule, report: &StepReport, disturbed: bool) {
        let mass = self.sim.subspace().total_mass();
        let speed = (2.0 * report.kinetic_energy / mass).sqrt();
        let forced = self.sim.has_active_pokes();
        let activity = &mut self.activity;
        if disturbed || forced || speed.is_nan() || speed >= rule.speed {
            activity.still_for = 0.0;
            return;
        }
        activity.still_for += self.sim.params().dt;
        if activity.still_for >= rule.after {
            activity.asleep = true;
            activity.fell_asleep = true;
            activity.colliders_when_asleep = self.sim.collider_bounds();
        }
    }

    /// Starts from the affine pose x = A X + t of the rest shape, at rest velocity: A may be
    /// any matrix, a mirror or a squash included (the stress cases start inverted this way).
    pub fn start_from_affine(&mut self, a: &nalgebra::Matrix3<f64>, t: &Vector3<f64>) {
        let z = self.sim.subspace().rigid_state(a, t);
        self.sim.set_state(z, None);
        self.lift_deformed();
    }

    /// The input points and their bounds where the state now puts them.
    fn lift_deformed(&mut self) {
        self.lifter.lift(self.sim.state(), &mut self.deformed);
        self.bounds = bounds_of(&self.deformed);
    }

    /// The body's mass, kg.
    pub fn mass(&self) -> f64 {
        self.sim.subspace().total_mass()
    }

    /// The volume of the solid the body was built on (its voxels', surface cells half full).
    pub fn volume(&self) -> f64 {
        self.grid.solid_volume()
    }

    /// The bounding box of the deformed points (min and max corners), m.
    pub fn deformed_bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        self.bounds
    }

    /// Whether the body sleeps (is not being stepped).
    pub fn is_sleeping(&self) -> bool {
        self.activity.asleep
    }

    /// Whether the body fell asleep in the last step: its last frame before sleeping.
    pub fn fell_asleep(&self) -> bool {
        self.activity.fell_asleep
    }

    /// Replaces the moving obstacles (robot links at their current poses). A collider that
    /// moved to within reach of a sleeping body, or away from it (a press lifting off the block
    /// it held down), wakes it.
    pub fn set_colliders(&mut self, colliders: Vec<Obstacle>) {
        if self.activity.asleep {
            let margin = 0.1 * self.diagonal();
            let (lo, hi) = self.bounds;
            let near = |(clo, chi): &(Vector3<f64>, Vector3<f64>)| {
                (0..3).all(|d| clo[d] - margin <= hi[d] && chi[d] + margin >= lo[d])
            };
            let before = &self.activity.colliders_when_asleep;
            let woken = colliders.iter().enumerate().any(|(i, c)| {
                let now = c.bounds(0.0);
                match (before.get(i).copied().flatten(), now) {
                    (Some(was), Some(now)) => {
                        let moved =
                            (was.0 - now.0).amax().max((was.1 - now.1).amax()) > 1e-6 * margin;
                        moved && (near(&was) || near(&now))
                    }
                    (None, Some(now)) => near(&now),
                    (_, None) => false,
                }
            });
            self.activity.disturbed |= woken;
        }
        self.sim.set_colliders(colliders);
    }

    /// The bounding-box diagonal of the deformed points, m.
    fn diagonal(&self) -> f64 {
        (self.bounds.1 - self.bounds.0).norm()
    }

    /// Makes the surface collide with obstacles and colliders (floors, robot links).
    pub fn enable_contacts(&mut self) {
        if !self.sim.has_contact_points() {
            self.sim
                .add_contact_points(&self.surface.points, &self.surface.areas);
        }
    }

    /// An obstacle that stays put (a static object); the surface collides with it.
    pub fn add_obstacle(&mut self, obstacle: Obstacle) {
        self.enable_contacts();
        self.sim.add_obstacle(obstacle);
    }

    /// A floor at height `z`, solid below; the surface collides with it.
    pub fn add_floor(&mut self, z: f64) {
        self.enable_contacts();
        self.sim.add_obstacle(Obstacle::floor(z));
    }

    /// What was chosen for this body (handles, cubature) and why, for the state topic and log.
    pub fn decision(&self) -> &str {
        &self.decision
    }

    /// Replaces what [`SoftBody::decision`] reports (a scene states its own choice of handles
    /// and cubature).
    pub fn set_decision(&mut self, decision: String) {
        self.decision = decision;
    }

    /// The number of cubature points.
    pub fn cubature_len(&self) -> usize {
        self.cubature.len()
    }

    /// The body's reduced space (its field at its cubature points), for running it in another
    /// simulation, e.g. a benchmark's scenario against the FEM.
    pub fn subspace(&self) -> Arc<crate::physics::Subspace> {
        self.sim.shared_subspace()
    }

    /// The solid the body was built on, voxelized (world units).
    pub fn solid(&self) -> &VoxelGrid {
        &self.grid
    }

    /// A lifter for other points of this body (rest positions, world units), e.g. the vertices
    /// of a reference mesh: `lifter.lift(body.state(), out)` deforms them like the body.
    pub fn lifter_for(&self, points: &[Vector3<f64>]) -> Lifter {
        Lifter::new(self.field.as_ref(), &self.map, points)
    }

    /// A closed surface of the body's solid at rest, world units: the boundary of its voxels
    /// resampled to `resolution` cells across. What a viewer draws for a point cloud.
    pub fn voxel_surface(&self, resolution: usize) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        self.grid.resample(resolution).boundary_mesh()
    }

    /// Back to the rest pose, at rest: forces, pins and contacts stay as they are.
    pub fn reset(&mut self) {
        self.sim.reset();
        self.sim.clear_pokes();
        self.lift_deformed();
        self.activity = Activity::default();
        self.last = None;
    }

    /// The lifter of the input points (their weights, blocked for lifting).
    pub fn lifter(&self) -> &Lifter {
        &self.lifter
    }

    /// Skinning weights at the input points: points x handles, row-major.
    pub fn weights(&self) -> &[f32] {
        &self.weights
    }

    /// Deformed input points after the last step: x, y, z per point.
    pub fn deformed(&self) -> &[f32] {
        &self.deformed
    }

    /// The number of input points deformed.
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

    /// Where the handle matrix goes at the next step if it keeps its velocity (3 x 4K).
    pub fn predicted_state(&self) -> DMatrix<f64> {
        self.sim.predicted()
    }

    /// The reduced velocity (3 x 4K): the handle matrix's change over the last step over dt.
    pub fn velocity(&self) -> DMatrix<f64> {
        self.sim.velocity()
    }

    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.sim.time()
    }

    /// The convex hull of (up to `HULL_POINTS` of) the body's contact points where they are
    /// now: how other deformable objects collide with it. None without contact points, or
    /// when they span no volume.
    pub fn contact_hull(&self) -> Option<Obstacle> {
        let points = self.sim.contact_positions();
        // Contact points come spread evenly in Morton order: every k-th is an even sample.
        let every = points.len().div_ceil(HULL_POINTS).max(1);
        let sample: Vec<Vector3<f64>> = points.into_iter().step_by(every).collect();
        Obstacle::hull_of(&sample)
    }

    /// The last step's report; None before the first step.
    pub fn last_step(&self) -> Option<&StepReport> {
        self.last.as_ref()
    }

    /// Where the build time went.
    pub fn timings(&self) -> &BuildTimings {
        &self.timings
    }

    /// The number of pinned points.
    pub fn pin_count(&self) -> usize {
        self.sim.pin_count()
    }

    /// The farthest a pinned point is from its target now, m (0 without pins).
    pub fn pin_drift(&self) -> f64 {
        self.sim.pin_drift()
    }

    /// Whether a push acts in the next step or will later.
    pub fn is_pushed(&self) -> bool {
        self.sim.has_active_pokes()
    }

    /// Pulls observed material points toward where a sensor saw them over the next steps
    /// (see [`crate::physics::ReducedSim::observe`]); it wakes the body. The node's tracker
    /// makes the term from a camera's frame.
    pub fn observe(&mut self, term: &crate::physics::ObservationTerm) -> Result<()> {
        self.sim.observe(term)?;
        self.activity.disturbed = true;
        Ok(())
    }

    /// Moves the body at once by the rigid `motion`, its velocity turned with it.
    pub fn move_rigidly(&mut self, motion: &Isometry3<f64>) {
        let rotation = motion.rotation.to_rotation_matrix().into_inner();
        self.sim.move_rigidly(&rotation, &motion.translation.vector);
        self.lift_deformed();
    }

    /// Drops the force the frames showed and nothing modelled (see `UnmodelledForce`).
    pub fn forget_unmodelled(&mut self) {
        self.sim.forget_unmodelled();
    }

    /// The steps from now on run on physics alone.
    pub fn forget_observation(&mut self) {
        self.sim.forget_observation();
    }

    /// The time step, s.
    pub fn dt(&self) -> f64 {
        self.sim.params().dt
    }

    /// Samples of the whole surface at rest (world units; the hidden side of a completed view
    /// included), with their areas: the points that collide.
    pub fn surface_samples(&self) -> &ContactSamples {
        &self.surface
    }

    /// Bounds of the body's surface at rest (min, max).
    pub(crate) fn rest_bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in &self.surface.points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        (lo, hi)
    }
}

fn bounds_of(xyz: &[f32]) -> (Vector3<f64>, Vector3<f64>) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in xyz.chunks_exact(3) {
        let p = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        lo = lo.inf(&p);
        hi = hi.sup(&p);
    }
    (lo, hi)
}
