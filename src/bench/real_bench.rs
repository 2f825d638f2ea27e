//! `bench real`: one camera's scans of the bundled shapes, completed and simulated as the node
//! does, against the FEM of the whole object and beside the body built from the whole mesh.
//! The targets: volume within 30 %, error at most 2x the whole mesh's, no step over
//! 5 ms.

use nalgebra::Vector3;
use serde::Serialize;

use super::real_to_sim::{build, scenario_body_options, REFERENCE_VERTICES};
use super::sim::{prepare_shape, run_fem, run_reduced, scenario_params, Scenario};
use crate::error::Result;
use crate::geometry::{bundled, scan_points, Camera};
use crate::physics::Solver;
use crate::skinning::NeuralModel;

/// The shapes scanned (the plate is left out: one view of a thin plate is refused as flat).
pub const SCANNED: [&str; 4] = ["sphere", "box", "creature", "rod"];
/// The sides the camera looks from.
pub const DIRECTIONS: [[f64; 3]; 2] = [[1.0, 0.6, 0.8], [-0.7, 1.0, 0.5]];
const SCENARIOS: [Scenario; 2] = [Scenario::Hanging, Scenario::Drop];
/// Image size: a few thousand points on the larger shapes.
const IMAGE: (usize, usize) = (160, 120);
const STEPS: usize = 60;
const YOUNG: f64 = 5e6;
const CUBATURE: usize = 1024;

/// One scan in one scenario.
#[derive(Clone, Debug, Serialize)]
pub struct ScanRow {
    /// The bundled shape scanned.
    pub shape: String,
    /// The side the camera looks from (one of `DIRECTIONS`).
    pub direction: [f64; 3],
    /// `hanging` or `drop`.
    pub scenario: String,
    /// Points in the scan.
    pub points: usize,
    /// Completed volume over the mesh's.
    pub volume_ratio: f64,
    /// Observed points over all points of the completed surface (1 when no completion
    /// was made).
    pub observed_fraction: f64,
    /// Building the body from the scan (completion, inference, subspace), ms.
    pub build_ms: f64,
    /// RMS distance of the FEM mesh's vertices, lifted by the scan's body, to the FEM's
    /// over the run, % of the bounding diagonal.
    pub error_pct: f64,
    /// The body built from the whole mesh, same scenario and FEM.
    pub whole_mesh_error_pct: f64,
    /// `error_pct` over `whole_mesh_error_pct`.
    pub error_ratio: f64,
    /// Median reduced step, ms.
    pub step_ms: f64,
    /// 99th-percentile reduced step, ms.
    pub step_p99_ms: f64,
    /// Largest reduced step, ms.
    pub step_max_ms: f64,
}

/// What `bench real` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct RealBenchReport {
    /// One row per shape, scenario and camera direction, in that nesting order.
    pub rows: Vec<ScanRow>,
    /// Largest |`volume_ratio` - 1| over the rows, %.
    pub worst_volume_error_pct: f64,
    /// Largest `error_ratio` over the rows.
    pub worst_error_ratio: f64,
    /// Largest `step_max_ms` over the rows, ms.
    pub worst_step_ms: f64,
}

/// Scans each of `SCANNED` from each of `DIRECTIONS` (160 x 120 pixels), builds
/// a body from each scan as the node does and runs the hanging and drop scenarios
/// (60 steps, E = 5 MPa, 1024 cubature points, quasi-Newton) against the FEM of
/// the whole mesh; `progress` gets a line per row. Errs when a scan, a build or a
/// simulation fails.
pub fn run_real_bench(mut progress: impl FnMut(&str)) -> Result<RealBenchReport> {
    let model = NeuralModel::bundled()?;
    let options = scenario_body_options(CUBATURE);
    let mut rows = Vec::new();
    for name in SCANNED {
        let mesh = bundled(name).expect("a bundled shape");
        let truth = mesh.closed_volume().unwrap_or(f64::NAN);
        let stage = prepare_shape(mesh.clone(), YOUNG, 0, REFERENCE_VERTICES, 0)?;
        let params = scenario_params(&stage);
        let (whole, _) = build(&model, &mesh, None, &options)?;
        let scans: Vec<_> = DIRECTIONS
            .iter()
            .map(|d| {
                let camera = Camera::looking_at(&mesh, Vector3::from(*d), 1.5, IMAGE.0, IMAGE.1);
                let points = scan_points(&mesh, &camera)?;
                let cloud = crate::geometry::Shape::new(points, None, Vec::new())?;
                let started = std::time::Instant::now();
                let (body, completion) = build(&model, &cloud, Some(&camera.position), &options)?;
                let build_ms = started.elapsed().as_secs_f64() * 1e3;
                Ok((*d, cloud.positions.len(), body, completion, build_ms))
            })
            .collect::<Result<_>>()?;
        for scenario in SCENARIOS {
            let (fem, _) = run_fem(&stage, scenario, &params, STEPS)?;
            let solver = Solver::QuasiNewton;
            let (baseline, _) =
                run_reduced(&stage, scenario, &params, &whole.subspace(), solver, &fem)?;
            for (direction, points, body, completion, build_ms) in &scans {
                let (row, _) =
                    run_reduced(&stage, scenario, &params, &body.subspace(), solver, &fem)?;
                let row = ScanRow {
                    shape: name.into(),
                    direction: *direction,
                    scenario: scenario.name().into(),
                    points: *points,
                    volume_ratio: body.volume() / truth,
                    observed_fraction: completion.as_ref().map_or(1.0, |c| c.observed_fraction),
                    build_ms: *build_ms,
                    error_pct: row.error_pct,
                    whole_mesh_error_pct: baseline.error_pct,
                    error_ratio: row.error_pct / baseline.error_pct,
                    step_ms: row.step_ms,
                    step_p99_ms: row.step_p99_ms,
                    step_max_ms: row.step_max_ms,
                };
                progress(&format!(
                    "{name:<8} {direction:?} {:<7} {points:>5} points  volume {:.3}  error {:.3} % (whole mesh {:.3} %, {:.2}x)  step {:.3} / max {:.3} ms",
                    row.scenario, row.volume_ratio, row.error_pct, row.whole_mesh_error_pct, row.error_ratio, row.step_ms, row.step_max_ms
                ));
                rows.push(row);
            }
        }
    }
    let worst = |f: &dyn Fn(&ScanRow) -> f64| rows.iter().map(f).fold(f64::NAN, f64::max);
    Ok(RealBenchReport {
        worst_volume_error_pct: worst(&|r| (r.volume_ratio - 1.0).abs() * 100.0),
        worst_error_ratio: worst(&|r| r.error_ratio),
        worst_step_ms: worst(&|r| r.step_max_ms),
        rows,
    })
}
