//! The demo's accuracy figure: each shape again in the full-space FEM (same material, support,
//! gravity, time step and pokes) on a tetrahedral mesh of its interior, against the replay's
//! body lifted to the same mesh vertices every step.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::script::{DemoScript, DemoShape, DEMO_START_NS};
use crate::geometry::{bottom_vertices, reference_mesh, ReferenceMesh};
use crate::physics::{FemSim, Lifter, Poke, SimParams};
use crate::Result;

/// One shape's reduced trajectory at its reference mesh's vertices.
pub struct Trajectory {
    pub frame: String,
    reference: ReferenceMesh,
    lifter: Option<Lifter>,
    /// Per step of the replayed body: x, y, z per mesh vertex.
    steps: Vec<Vec<f32>>,
    /// Per step: the tick's log time, ns.
    times_ns: Vec<i64>,
    /// Log time of the body's first step, ns.
    first_step_ns: Option<i64>,
}

impl Trajectory {
    pub fn new(shape: &DemoShape) -> Result<Self> {
        Ok(Self {
            frame: shape.frame.into(),
            reference: reference_mesh(&shape.shape),
            lifter: None,
            steps: Vec::new(),
            times_ns: Vec::new(),
            first_step_ns: None,
        })
    }

    /// After a tick of the replay: the body of this frame, lifted to the mesh vertices.
    pub fn record(&mut self, time_ns: i64, body: &crate::pipeline::SoftBody) {
        let lifter = self
            .lifter
            .get_or_insert_with(|| body.lifter_for(&self.reference.mesh.vertices));
        let mut x = vec![0.0f32; 3 * lifter.len()];
        lifter.lift(body.state(), &mut x);
        self.steps.push(x);
        self.times_ns.push(time_ns);
        self.first_step_ns.get_or_insert(time_ns);
    }
}

/// Per shape: the RMS distance between the replay and the FEM over all vertices and steps, in
/// percent of the shape's bounding diagonal; the FEM's median step time, ms; and how far each
/// side moved at every step, for the demo's plot.
pub struct ReferenceError {
    /// The shape's frame.
    pub frame: String,
    /// Vertices of the FEM reference mesh.
    pub vertices: usize,
    /// RMS distance between the replay and the FEM over all vertices and steps, % of the
    /// shape's bounding diagonal.
    pub error_pct: f64,
    /// Median FEM step, ms.
    pub fem_step_ms: f64,
    /// How far each side moved at every step, for the plot.
    pub displacement: DisplacementSeries,
}

/// One shape's motion over the replay, the replay's beside the FEM's: per step, the RMS
/// distance of the reference mesh's vertices from their rest positions. RMS rather than the
/// maximum: a poke moves a few FEM vertices far, which the largest would show as spikes that
/// say little about the shape's motion.
#[derive(Clone, Debug, Default)]
pub struct DisplacementSeries {
    /// Seconds since the recording's start ([`DEMO_START_NS`]), per step.
    pub times_s: Vec<f64>,
    /// The replayed body lifted to the mesh, m.
    pub reduced_m: Vec<f64>,
    /// The FEM, m.
    pub fem_m: Vec<f64>,
}

/// Runs the FEM of every recorded shape (in parallel) and compares.
pub fn reference_errors(
    trajectories: &[Trajectory],
    script: &DemoScript,
    params: &SimParams,
    period_ns: i64,
) -> Result<Vec<ReferenceError>> {
    trajectories
        .par_iter()
        .filter(|t| !t.steps.is_empty())
        .map(|t| fem_error(t, script, params, period_ns))
        .collect()
}

fn fem_error(
    t: &Trajectory,
    script: &DemoScript,
    params: &SimParams,
    period_ns: i64,
) -> Result<ReferenceError> {
    let mesh = &t.reference.mesh;
    let mut fem = FemSim::new(mesh.clone(), params.clone())?;
    fem.pin_vertices(&bottom_vertices(mesh, &params.gravity));
    let first = t
        .first_step_ns
        .expect("a trajectory with steps has a start");
    // The replay applies an interaction before the first tick at or after its log time; that
    // tick is step k of the body, whose simulated time is then k * dt.
    for poke in script.pokes.iter().filter(|p| p.frame == t.frame) {
        let late = DemoScript::time_ns(poke.at_s) - first;
        let step = if late <= 0 {
            0
        } else {
            (late + period_ns - 1) / period_ns
        };
        let start = step as f64 * params.dt;
        fem.add_poke(Poke {
            point: poke.point,
            force: poke.force,
            start,
            end: start + poke.duration_s,
        });
    }
    let mut squared = 0.0;
    let mut samples = 0usize;
    let mut times = Vec::with_capacity(t.steps.len());
    let mut displacement = DisplacementSeries::default();
    for (reduced, &time_ns) in t.steps.iter().zip(&t.times_ns) {
        let report = fem.step()?;
        times.push(report.seconds * 1e3);
        for (r, f) in reduced.chunks(3).zip(fem.positions().chunks(3)) {
            let d = Vector3::new(r[0] as f64 - f[0], r[1] as f64 - f[1], r[2] as f64 - f[2]);
            squared += d.norm_squared();
            samples += 1;
        }
        displacement
            .times_s
            .push((time_ns - DEMO_START_NS) as f64 * 1e-9);
        displacement
            .reduced_m
            .push(rms_displacement(reduced.as_slice(), &mesh.vertices));
        displacement
            .fem_m
            .push(rms_displacement(fem.positions(), &mesh.vertices));
    }
    times.sort_by(f64::total_cmp);
    Ok(ReferenceError {
        frame: t.frame.clone(),
        vertices: mesh.vertices.len(),
        error_pct: (squared / samples.max(1) as f64).sqrt() / t.reference.diagonal * 100.0,
        fem_step_ms: times[times.len() / 2],
        displacement,
    })
}

/// RMS distance of points (x, y, z per point) from their rest positions, m.
fn rms_displacement<T: Copy + Into<f64>>(points: &[T], rest: &[Vector3<f64>]) -> f64 {
    let squared: f64 = points
        .chunks_exact(3)
        .zip(rest)
        .map(|(p, r)| {
            (Vector3::<f64>::new(p[0].into(), p[1].into(), p[2].into()) - r).norm_squared()
        })
        .sum();
    (squared / rest.len().max(1) as f64).sqrt()
}
