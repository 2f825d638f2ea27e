//! `physskin simulate --input FILE`: any mesh or cloud file (one camera's scan included) built as
//! the node builds it, run through a bench scenario, and measured against the full-space FEM of
//! the whole object: a reference mesh, or the input itself when it is a closed mesh.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use nalgebra::Vector3;
use serde::Serialize;

use super::sim::{prepare_shape, run_fem, run_reduced, scenario_params, shape_on_grid, Scenario};
use crate::error::{Error, Result};
use crate::geometry::{load_geometry, Completion, Shape};
use crate::physics::Solver;
use crate::pipeline::{build_seen, BodyOptions, SoftBody, Support, DEFAULT_MAX_BUILD_POINTS};
use crate::runtime::REPLAY_REFINE;
use crate::skinning::NeuralModel;

/// What to simulate and against what.
#[derive(Clone, Debug)]
pub struct InputSimOptions {
    /// A mesh or cloud: OBJ, STL or PLY.
    pub input: PathBuf,
    /// Where the cloud was seen from (its sensor's origin, in the file's coordinates): the
    /// cloud is then one view and is completed. None: the cloud is the whole object.
    pub viewpoint: Option<Vector3<f64>>,
    /// The whole object's closed mesh for the FEM; None: the input when it is a closed mesh.
    pub reference: Option<PathBuf>,
    /// `hanging`, `drop` or `poke`; another name is refused.
    pub scenario: String,
    /// Steps of 1/60 s.
    pub steps: usize,
    /// Young's modulus, Pa.
    pub young: f64,
    /// Cubature points of the body.
    pub cubature: usize,
    /// The reduced solver.
    pub solver: Solver,
    /// FEM grid cells across the longest side; 0: the coarsest grid whose mesh has
    /// `REFERENCE_VERTICES` vertices.
    pub resolution: usize,
}

/// The FEM mesh's size when no resolution is given: fine enough for an error of a few tenths
/// of a percent, small enough for seconds per run on 2 cores.
pub const REFERENCE_VERTICES: usize = 4000;

/// What `simulate --input` measured. Lengths in m, volumes in m^3, masses in kg.
#[derive(Clone, Debug, Serialize)]
pub struct InputSimSummary {
    /// The input file's path, as given.
    pub input: String,
    /// The scenario's name.
    pub scenario: String,
    /// Points (or vertices) read from the input.
    pub points: usize,
    /// The simulated body's volume and mass (after completion, for a view).
    pub volume: f64,
    /// The body's mass, kg.
    pub mass: f64,
    /// The reference mesh's enclosed volume (null without a reference).
    pub reference_volume: Option<f64>,
    /// RMS distance of the reference mesh's vertices, lifted by the body, to the FEM's over the
    /// whole run, in % of the bounding diagonal (null without a reference).
    pub error_pct: Option<f64>,
    /// The same for the body built from the whole reference mesh: what a complete input gives.
    pub whole_mesh_error_pct: Option<f64>,
    /// Largest displacement of a lifted vertex at the last step.
    pub max_displacement: f64,
    /// The same for the FEM at its last step (null without a reference).
    pub fem_max_displacement: Option<f64>,
    /// Median reduced step, ms.
    pub step_ms: f64,
    /// 99th-percentile reduced step, ms.
    pub step_p99_ms: f64,
    /// Largest reduced step, ms.
    pub step_max_ms: f64,
    /// Building the body: completion, inference, subspace, ms.
    pub build_ms: f64,
    /// What the completion of a view did; empty for inputs that needed none.
    pub completion: serde_json::Value,
}

/// Builds the input's body and runs the scenario on it, against the FEM of the reference.
pub fn simulate_input(options: &InputSimOptions) -> Result<InputSimSummary> {
    let scenario = Scenario::named(&options.scenario)?;
    let input = load_shape(&options.input)?;
    let model = NeuralModel::bundled()?;
    let body_options = scenario_body_options(options.cubature);
    let started = std::time::Instant::now();
    let (body, completion) = build(&model, &input, options.viewpoint.as_ref(), &body_options)?;
    let build_ms = started.elapsed().as_secs_f64() * 1e3;
    let reference = match &options.reference {
        Some(path) => Some(load_shape(path)?),
        None => input.closed_volume().is_some().then(|| input.clone()),
    };
    // Without a reference the scenario runs on the body's own solid, with no FEM to compare.
    let stage = match &reference {
        Some(mesh) => prepare_shape(
            mesh.clone(),
            options.young,
            options.resolution,
            REFERENCE_VERTICES,
            0,
        )?,
        None => shape_on_grid(
            input.clone(),
            body.solid().resample(options.resolution.max(24)),
            options.young,
            0,
        )?,
    };
    let params = scenario_params(&stage);
    let fem = match &reference {
        Some(_) => Some(run_fem(&stage, scenario, &params, options.steps)?.0),
        None => None,
    };
    let trajectory = fem
        .clone()
        .unwrap_or_else(|| vec![Vec::new(); options.steps]);
    let (row, lifted) = run_reduced(
        &stage,
        scenario,
        &params,
        &body.subspace(),
        options.solver,
        &trajectory,
    )?;
    let whole_mesh_error_pct = match &reference {
        Some(mesh) => {
            let (whole, _) = build(&model, mesh, None, &body_options)?;
            let subspace = whole.subspace();
            let (row, _) = run_reduced(
                &stage,
                scenario,
                &params,
                &subspace,
                options.solver,
                &trajectory,
            )?;
            Some(row.error_pct)
        }
        None => None,
    };
    let displacement = |positions: &[f64]| {
        positions
            .chunks(3)
            .zip(&stage.mesh.vertices)
            .map(|(x, v)| (Vector3::new(x[0], x[1], x[2]) - v).norm())
            .fold(0.0, f64::max)
    };
    let lifted: Vec<f64> = lifted.iter().map(|&x| x as f64).collect();
    Ok(InputSimSummary {
        input: options.input.display().to_string(),
        scenario: scenario.name().into(),
        points: input.positions.len(),
        volume: body.volume(),
        mass: body.mass(),
        reference_volume: reference.as_ref().and_then(Shape::closed_volume),
        error_pct: fem.is_some().then_some(row.error_pct),
        whole_mesh_error_pct,
        max_displacement: displacement(&lifted),
        fem_max_displacement: fem.as_ref().and_then(|f| f.last()).map(|l| displacement(l)),
        step_ms: row.step_ms,
        step_p99_ms: row.step_p99_ms,
        step_max_ms: row.step_max_ms,
        build_ms,
        completion: completion.map_or_else(
            || serde_json::json!({}),
            |c| serde_json::to_value(c).expect("a completion serializes"),
        ),
    })
}

/// A body's options for a bench scenario: free (the scenario pins it), `cubature` points.
pub(crate) fn scenario_body_options(cubature: usize) -> BodyOptions {
    BodyOptions {
        cubature,
        support: Support::Free,
        // Refined as a replay refines (by the iterations, never by the clock), so that runs repeat.
        refine: REPLAY_REFINE,
        ..BodyOptions::default()
    }
}

/// A mesh or cloud file as a shape, refused when it is a line or a plane.
fn load_shape(path: &Path) -> Result<Shape> {
    let shape = Shape::from_raw(load_geometry(path)?)
        .map_err(|e| Error::Geometry(format!("{}: {e}", path.display())))?;
    shape
        .check_solid()
        .map_err(|e| Error::Geometry(format!("{}: {e}", path.display())))?;
    Ok(shape)
}

/// The body the node would build from `shape` (see [`build_seen`]).
pub(crate) fn build(
    model: &Arc<NeuralModel>,
    shape: &Shape,
    viewpoint: Option<&Vector3<f64>>,
    options: &BodyOptions,
) -> Result<(SoftBody, Option<Completion>)> {
    let seen = build_seen(
        model,
        &shape.positions,
        &shape.triangles,
        viewpoint,
        DEFAULT_MAX_BUILD_POINTS,
        options,
    )?;
    Ok((seen.body, seen.completion))
}
