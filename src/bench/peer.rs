//! `bench peer`: the same soft block in MuJoCo and in physskin, each against our FEM reference,
//! on the same cores in one run. MuJoCo runs its flexcomp (a grid of vertices with its built-in
//! 3D flex elasticity) with each of its dof variants (`full`: every vertex a body; `trilinear`:
//! 8 corner nodes; `quadratic`: 27 nodes) from `benches/peers/mujoco_block.py`; physskin runs
//! the body it builds from the block's mesh (network field refined 8 iterations) at a few
//! sizes. The block is 0.2 m, E = 100 kPa, nu = 0.45, 1000 kg/m^3, 1/60 s frames, g = 9.81,
//! dropped tilted onto a floor and poked while held at one side, as in `bench sim`. Errors are
//! RMS distances at the FEM mesh's vertices over the run, % of the block's diagonal; MuJoCo's
//! positions there are trilinear in its vertex grid, which is how its flex deforms between
//! vertices.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::plot::{scatter_svg, Series};
use super::real_to_sim::scenario_body_options;
use super::sim::{
    drop_tilt, floor_height, pinned_vertices, poke, run_fem, run_reduced, scenario_params,
    shape_on_grid, BenchShape, Scenario,
};
use super::stats::{median, quantile};
use crate::error::{Error, Result};
use crate::geometry::{box_grid_mesh, VoxelGrid};
use crate::physics::{SimParams, Solver};
use crate::pipeline::SoftBody;
use crate::skinning::NeuralModel;

/// The block's edge, m, and Young's modulus, Pa (Poisson's ratio, density, time step and
/// gravity are `SimParams`' defaults).
const SIZE: f64 = 0.2;
const YOUNG: f64 = 1e5;
/// FEM cells along an edge: 1.25 cm cells, 4,913 vertices.
const FEM_CELLS: usize = 16;
/// MuJoCo's dof variants.
const MUJOCO_VARIANTS: [&str; 3] = ["full", "trilinear", "quadratic"];
/// physskin's sizes: (handles with the constant one, cubature points).
const PHYSSKIN_SIZES: [(usize, usize); 20] = [
    (1, 16),
    (1, 64),
    (2, 16),
    (3, 16),
    (3, 64),
    (4, 16),
    (5, 20),
    (5, 32),
    (5, 64),
    (5, 256),
    (9, 64),
    (9, 256),
    (11, 48),
    (11, 64),
    (13, 52),
    (13, 64),
    (13, 128),
    (17, 128),
    (17, 256),
    (17, 1024),
];
const SCENARIOS: [Scenario; 2] = [Scenario::Drop, Scenario::Poke];

/// How the bench runs.
#[derive(Clone, Debug)]
pub struct PeerOptions {
    /// A Python that imports mujoco (e.g. target/mujoco-venv/bin/python).
    pub python: PathBuf,
    /// Frames per scenario (1/60 s each).
    pub steps: usize,
    /// MuJoCo grid vertices along an edge.
    pub count: usize,
    /// MuJoCo steps per frame, one set of rows per count.
    pub substeps: Vec<usize>,
}

/// One engine and setting in one scenario.
#[derive(Clone, Debug, Serialize)]
pub struct PeerRow {
    /// `mujoco` or `physskin`.
    pub engine: String,
    /// The setting: MuJoCo's dof variant and substeps, physskin's handles and cubature.
    pub variant: String,
    /// `drop` or `poke`.
    pub scenario: String,
    /// Degrees of freedom simulated.
    pub dofs: usize,
    /// Median wall-clock time of one 1/60 s frame, ms.
    pub step_ms: f64,
    /// 99th percentile of the same, ms.
    pub step_ms_p99: f64,
    /// RMS distance to the FEM at its vertices over the run, % of the diagonal; None when the
    /// run left finite numbers.
    pub error_pct: Option<f64>,
    /// For a MuJoCo row: the physskin row of the same scenario that is at least as accurate
    /// and faster, or at least as fast and more accurate; None when there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beaten_by: Option<String>,
}

/// What `bench peer` reports.
#[derive(Clone, Debug, Serialize)]
pub struct PeerReport {
    /// The MuJoCo version the script ran.
    pub mujoco_version: String,
    /// Vertices of the FEM reference mesh.
    pub fem_vertices: usize,
    /// Every row, scenario by scenario.
    pub rows: Vec<PeerRow>,
    /// Whether every MuJoCo row has a physskin row that beats it.
    pub every_mujoco_row_beaten: bool,
}

/// What the MuJoCo script prints.
#[derive(Deserialize)]
struct MujocoRun {
    mujoco_version: String,
    nv: usize,
    /// Vertex rest positions in the block's frame.
    rest: Vec<[f64; 3]>,
    /// World positions of every vertex after each frame, flattened.
    frames: Vec<Vec<f64>>,
    step_s: Vec<f64>,
}

/// Runs both scenarios in the FEM, in MuJoCo (each variant and substep count) and in physskin
/// (each size); `progress` gets a line per row.
pub fn run_peer_bench(options: &PeerOptions, mut progress: impl FnMut(&str)) -> Result<PeerReport> {
    let stage = block_stage()?;
    let params = scenario_params(&stage);
    let model = NeuralModel::bundled()?;
    let bodies = physskin_bodies(&model, &stage)?;
    let mut rows = Vec::new();
    let mut version = String::new();
    for scenario in SCENARIOS {
        let (fem, _) = run_fem(&stage, scenario, &params, options.steps)?;
        progress(&format!("{}: FEM done", scenario.name()));
        for variant in MUJOCO_VARIANTS {
            for &substeps in &options.substeps {
                let run = run_mujoco(options, &stage, &params, scenario, variant, substeps)?;
                version.clone_from(&run.mujoco_version);
                let row = mujoco_row(&run, &stage, &fem, scenario, variant, substeps);
                progress(&describe(&row));
                rows.push(row);
            }
        }
        for (name, body) in &bodies {
            let subspace = body.subspace();
            let (sim_row, _) = run_reduced(
                &stage,
                scenario,
                &params,
                &subspace,
                Solver::QuasiNewton,
                &fem,
            )?;
            let row = PeerRow {
                engine: "physskin".into(),
                variant: name.clone(),
                scenario: scenario.name().into(),
                dofs: subspace.dofs(),
                step_ms: sim_row.step_ms,
                step_ms_p99: sim_row.step_p99_ms,
                error_pct: Some(sim_row.error_pct).filter(|e| e.is_finite()),
                beaten_by: None,
            };
            progress(&describe(&row));
            rows.push(row);
        }
    }
    mark_beaten(&mut rows);
    Ok(PeerReport {
        mujoco_version: version,
        fem_vertices: stage.mesh.vertices.len(),
        every_mujoco_row_beaten: rows
            .iter()
            .filter(|r| r.engine == "mujoco")
            .all(|r| r.beaten_by.is_some()),
        rows,
    })
}

/// The bodies physskin builds from the block's mesh at each of `PHYSSKIN_SIZES`, named by
/// their size.
fn physskin_bodies(
    model: &Arc<NeuralModel>,
    stage: &BenchShape,
) -> Result<Vec<(String, SoftBody)>> {
    PHYSSKIN_SIZES
        .iter()
        .map(|&(handles, cubature)| {
            let options = crate::pipeline::BodyOptions {
                handles: Some(handles),
                ..scenario_body_options(cubature)
            };
            let body = SoftBody::build(model, &stage.source, &stage.source.positions, &options)?;
            let plural = if handles == 1 { "" } else { "s" };
            Ok((
                format!("{handles} handle{plural}, {cubature} cubature"),
                body,
            ))
        })
        .collect()
}

fn describe(row: &PeerRow) -> String {
    format!(
        "{} {:<8} {:<32} step {:.3} / p99 {:.3} ms  error {}",
        row.scenario,
        row.engine,
        row.variant,
        row.step_ms,
        row.step_ms_p99,
        row.error_pct
            .map_or_else(|| "not finite".into(), |e| format!("{e:.3} %"))
    )
}

/// The block on a grid whose cells fit it exactly, so that the FEM's mesh is the block itself
/// (a voxelization of its surface would add a layer).
fn block_stage() -> Result<BenchShape> {
    let cell = SIZE / FEM_CELLS as f64;
    let n = FEM_CELLS + 2;
    let inside = |i: usize| (1..=FEM_CELLS).contains(&i);
    let mut grid = VoxelGrid {
        origin: Vector3::repeat(-SIZE / 2.0 - cell),
        cell,
        dims: [n; 3],
        surface: vec![false; n * n * n],
        solid: vec![false; n * n * n],
    };
    for index in 0..grid.len() {
        let c = grid.coords(index);
        grid.solid[index] = c.iter().all(|&i| inside(i));
        grid.surface[index] = grid.solid[index] && c.iter().any(|&i| i == 1 || i == FEM_CELLS);
    }
    let shape = box_grid_mesh(Vector3::repeat(SIZE), cell);
    shape_on_grid(shape, grid, YOUNG, 0)
}

/// Runs the MuJoCo script for one scenario and variant.
fn run_mujoco(
    options: &PeerOptions,
    stage: &BenchShape,
    params: &SimParams,
    scenario: Scenario,
    variant: &str,
    substeps: usize,
) -> Result<MujocoRun> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/peers/mujoco_block.py");
    let mut command = Command::new(&options.python);
    command.arg(&script).args([
        "--variant",
        variant,
        "--scenario",
        scenario.name(),
        "--size",
        &SIZE.to_string(),
        "--count",
        &options.count.to_string(),
        "--young",
        &params.young.to_string(),
        "--poisson",
        &params.poisson.to_string(),
        "--density",
        &params.density.to_string(),
        "--dt",
        &params.dt.to_string(),
        "--substeps",
        &substeps.to_string(),
        "--steps",
        &options.steps.to_string(),
        "--gravity-z",
        &params.gravity.z.to_string(),
        "--friction",
        &params.friction.to_string(),
    ]);
    match scenario {
        Scenario::Drop => {
            let tilt = drop_tilt();
            let degrees = tilt[(0, 2)].atan2(tilt[(0, 0)]).to_degrees();
            command.args([
                "--tilt-deg",
                &degrees.to_string(),
                "--floor-z",
                &floor_height(stage).to_string(),
            ]);
        }
        _ => {
            let poke = poke(stage, params);
            let pinned = pinned_vertices(&stage.mesh);
            let pin_x = pinned
                .iter()
                .map(|&v| stage.mesh.vertices[v].x)
                .fold(f64::NEG_INFINITY, f64::max);
            let csv = |v: &Vector3<f64>| format!("{},{},{}", v.x, v.y, v.z);
            command.args([
                "--pin-x",
                &(pin_x + 1e-9).to_string(),
                "--poke-at",
                &csv(&poke.point),
                "--force",
                &csv(&poke.force),
                "--poke-s",
                &(poke.end - poke.start).to_string(),
            ]);
        }
    }
    script_json(&mut command, "the MuJoCo script")
}

/// Runs a peer's script (`command`: a Python, the script, its arguments) and reads the one
/// JSON object it prints on stdout; `what` names the script in errors. Errs when the Python
/// cannot start, the script fails (with its stderr) or prints something else.
pub(super) fn script_json<T: serde::de::DeserializeOwned>(
    command: &mut Command,
    what: &str,
) -> Result<T> {
    let python = command.get_program().to_string_lossy().into_owned();
    let out = (command.output()).map_err(|e| Error::Peer(format!("{python}: {e}")))?;
    if !out.status.success() {
        let args: Vec<_> = command.get_args().map(|a| a.to_string_lossy()).collect();
        return Err(Error::Peer(format!(
            "{python} {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    serde_json::from_slice(&out.stdout).map_err(|e| Error::Peer(format!("{what}'s output: {e}")))
}

/// MuJoCo's run against the FEM: its vertex grid's positions, trilinear at each FEM vertex.
fn mujoco_row(
    run: &MujocoRun,
    stage: &BenchShape,
    fem: &[Vec<f64>],
    scenario: Scenario,
    variant: &str,
    substeps: usize,
) -> PeerRow {
    let grid = VertexGrid::new(&run.rest);
    let mut squared = 0.0;
    for (frame, expected) in run.frames.iter().zip(fem) {
        for (v, rest) in stage.mesh.vertices.iter().enumerate() {
            let x = grid.position(frame, rest);
            let e = Vector3::new(expected[3 * v], expected[3 * v + 1], expected[3 * v + 2]);
            squared += (x - e).norm_squared();
        }
    }
    let samples = (run.frames.len().min(fem.len()) * stage.mesh.vertices.len()) as f64;
    let error = (squared / samples).sqrt() / stage.diagonal * 100.0;
    PeerRow {
        engine: "mujoco".into(),
        variant: format!(
            "{variant}, {0}^3 vertices, {substeps} substep{1}",
            grid.count,
            if substeps == 1 { "" } else { "s" }
        ),
        scenario: scenario.name().into(),
        dofs: run.nv,
        step_ms: median(&run.step_s) * 1e3,
        step_ms_p99: quantile(&run.step_s, 0.99) * 1e3,
        error_pct: Some(error).filter(|e| e.is_finite()),
        beaten_by: None,
    }
}

/// MuJoCo's vertices as a regular grid over the block (rest frame), indexed (i, j, k).
struct VertexGrid {
    count: usize,
    spacing: f64,
    /// Vertex number of grid point (i, j, k) at i + count (j + count k).
    vertex: Vec<usize>,
}

impl VertexGrid {
    fn new(rest: &[[f64; 3]]) -> Self {
        let count = (rest.len() as f64).cbrt().round() as usize;
        let spacing = SIZE / (count - 1) as f64;
        let mut vertex = vec![usize::MAX; count * count * count];
        for (v, p) in rest.iter().enumerate() {
            let [i, j, k] = p.map(|x| ((x + SIZE / 2.0) / spacing).round() as usize);
            vertex[i + count * (j + count * k)] = v;
        }
        assert!(
            vertex.iter().all(|&v| v != usize::MAX),
            "MuJoCo's vertices fill a {count}^3 grid"
        );
        Self {
            count,
            spacing,
            vertex,
        }
    }

    /// The trilinear interpolation of the frame's vertex positions at rest point `p`.
    fn position(&self, frame: &[f64], p: &Vector3<f64>) -> Vector3<f64> {
        let cell = |x: f64| {
            let f = (x + SIZE / 2.0) / self.spacing;
            let i = (f.floor().max(0.0) as usize).min(self.count - 2);
            (i, (f - i as f64).clamp(0.0, 1.0))
        };
        let [(i, u), (j, v), (k, w)] = [cell(p.x), cell(p.y), cell(p.z)];
        let mut x = Vector3::zeros();
        for (dk, wk) in [(0, 1.0 - w), (1, w)] {
            for (dj, wj) in [(0, 1.0 - v), (1, v)] {
                for (di, wi) in [(0, 1.0 - u), (1, u)] {
                    let n = self.vertex[(i + di) + self.count * ((j + dj) + self.count * (k + dk))];
                    let q = Vector3::new(frame[3 * n], frame[3 * n + 1], frame[3 * n + 2]);
                    x += q * (wi * wj * wk);
                }
            }
        }
        x
    }
}

/// Gives each MuJoCo row the fastest physskin row of its scenario that beats it: at least as
/// accurate and faster, or at least as fast and more accurate.
fn mark_beaten(rows: &mut [PeerRow]) {
    let physskin: Vec<PeerRow> = rows
        .iter()
        .filter(|r| r.engine == "physskin")
        .cloned()
        .collect();
    for row in rows.iter_mut().filter(|r| r.engine == "mujoco") {
        let theirs = row.error_pct.unwrap_or(f64::INFINITY);
        row.beaten_by = physskin
            .iter()
            .filter(|p| p.scenario == row.scenario)
            .filter(|p| {
                let ours = p.error_pct.unwrap_or(f64::INFINITY);
                (ours <= theirs && p.step_ms < row.step_ms)
                    || (p.step_ms <= row.step_ms && ours < theirs)
            })
            .min_by(|a, b| a.step_ms.total_cmp(&b.step_ms))
            .map(|p| p.variant.clone());
    }
}

/// Step time against error, one series per engine and scenario.
pub fn peer_plot(report: &PeerReport) -> String {
    let colours = [
        ("mujoco", "drop", "#d62728"),
        ("mujoco", "poke", "#ff9896"),
        ("physskin", "drop", "#1f77b4"),
        ("physskin", "poke", "#aec7e8"),
    ];
    let labels: Vec<String> = colours
        .iter()
        .map(|(e, s, _)| format!("{e}, {s}"))
        .collect();
    let series: Vec<Series> = colours
        .iter()
        .zip(&labels)
        .map(|((engine, scenario, colour), label)| Series {
            label,
            color: colour,
            points: report
                .rows
                .iter()
                .filter(|r| r.engine == *engine && r.scenario == *scenario)
                .filter_map(|r| r.error_pct.map(|e| (r.step_ms, e)))
                .collect(),
        })
        .collect();
    scatter_svg(
        "A 0.2 m soft block: MuJoCo flexcomp and physskin against our FEM",
        "frame step, ms (median, log scale)",
        "error, % of the diagonal",
        &series,
    )
}
