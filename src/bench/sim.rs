//! `bench sim`'s pieces: its shapes, scenarios, options and rows, and the FEM and the reduced
//! body run over the same steps (the sweep that runs them all is `sweep.rs`).

use std::sync::Arc;

use nalgebra::Vector3;
use serde::Serialize;

use super::stats::{median, quantile};
use crate::error::{Error, Result};
use crate::geometry::{stratified_subset, Shape, TetMesh, VoxelGrid};
use crate::physics::{
    BulkIntegration, FemElement, FemSim, Lifter, Obstacle, Poke, ReducedSim, SimParams, Solver,
    Subspace,
};
use crate::skinning::{EigenmodeField, EigenmodeOptions};

/// What to run.
#[derive(Clone, Debug, Default)]
pub struct SimBenchOptions {
    /// Small meshes, few steps, fewer variants: fits in CI.
    pub quick: bool,
    /// Only these shapes, scenarios, handle counts, cubature sizes and solvers (each: all of
    /// the run's own when empty), so a subset runs in minutes.
    pub shapes: Vec<String>,
    /// Only these scenarios (hanging, drop, poke; another name is refused); empty: hanging
    /// and drop with `quick`, all three otherwise.
    pub scenarios: Vec<String>,
    /// Only these handle counts, without the constant one (0 is refused); empty: 4 and 16
    /// with `quick`, 4, 8, 16 and 32 otherwise.
    pub handles: Vec<usize>,
    /// Only these cubature sizes (0 is refused); empty: 256 and 1024.
    pub cubatures: Vec<usize>,
    /// Only these solvers; empty: Newton and quasi-Newton.
    pub solvers: Vec<Solver>,
    /// How the reduced bodies integrate the bulk term, each in turn; empty: points.
    pub bulks: Vec<BulkIntegration>,
    /// The FEM reference's element (linear by default).
    pub reference: FemElement,
    /// Poisson's ratio of every body and its reference; None: the default material's.
    pub poisson: Option<f64>,
}

/// The bench's bundled shapes.
pub(super) const SHAPES: [&str; 3] = ["plate", "rod", "creature"];
/// Each of `SHAPES`' Young's modulus, Pa.
pub(super) const YOUNGS: [f64; 3] = [2e7, 5e6, 2e6];

/// `SHAPES`' FEM resolutions (cells across the longest side; 0: the smallest whose mesh has
/// `bench_min_vertices` vertices), quick or full.
pub(super) fn bench_resolutions(quick: bool) -> [usize; 3] {
    if quick {
        [24, 32, 0]
    } else {
        [72, 64, 0]
    }
}

/// The vertices a resolution of 0 asks for, quick or full.
pub(super) fn bench_min_vertices(quick: bool) -> usize {
    if quick {
        2_000
    } else {
        30_000
    }
}

impl SimBenchOptions {
    /// `all` cut to `chosen` when something was chosen.
    pub(super) fn pick<T: Clone + PartialEq>(all: &[T], chosen: &[T]) -> Vec<T> {
        if chosen.is_empty() {
            all.to_vec()
        } else {
            chosen.to_vec()
        }
    }

    /// The scenarios chosen, or the run's own: hanging and drop with `quick`, all three
    /// otherwise.
    pub(super) fn chosen_scenarios(&self) -> Result<Vec<Scenario>> {
        if self.scenarios.is_empty() {
            let quick = [Scenario::Hanging, Scenario::Drop];
            return Ok(if self.quick {
                quick.to_vec()
            } else {
                Scenario::ALL.to_vec()
            });
        }
        self.scenarios.iter().map(|n| Scenario::named(n)).collect()
    }

    /// Each solver with each way of integrating the bulk term, as chosen.
    pub(super) fn variants(&self) -> Vec<(Solver, BulkIntegration)> {
        let solvers = Self::pick(&[Solver::Newton, Solver::QuasiNewton], &self.solvers);
        let bulks = Self::pick(&[BulkIntegration::Points], &self.bulks);
        (solvers.iter())
            .flat_map(|&solver| bulks.iter().map(move |&bulk| (solver, bulk)))
            .collect()
    }

    pub(super) fn check(&self) -> Result<()> {
        for name in &self.shapes {
            if !SHAPES.contains(&name.as_str()) {
                return Err(Error::InvalidParameter {
                    name: "shape",
                    reason: format!("unknown bench shape {name:?} ({})", SHAPES.join(", ")),
                });
            }
        }
        for name in &self.scenarios {
            Scenario::named(name)?;
        }
        if let Some(poisson) = self.poisson {
            SimParams {
                poisson,
                ..SimParams::default()
            }
            .validate()?;
        }
        if let Some(&bad) = self
            .handles
            .iter()
            .chain(&self.cubatures)
            .find(|&&n| n == 0)
        {
            return Err(Error::InvalidParameter {
                name: "handles",
                reason: format!("handle counts and cubature sizes must be positive, not {bad}"),
            });
        }
        Ok(())
    }
}

/// One reduced simulation and its FEM reference: a row of `bench sim` (serialized for
/// `--json`), or the figures of `simulate`.
#[derive(Clone, Debug, Serialize)]
pub struct SimRow {
    /// The bundled shape's name.
    pub shape: String,
    /// Vertices of the FEM mesh.
    pub vertices: usize,
    /// `hanging`, `drop` or `poke`.
    pub scenario: String,
    /// The skinning field: `eigen` or `learned`.
    pub field: String,
    /// Handles without the constant one.
    pub handles: usize,
    /// Cubature points of the reduced simulation.
    pub cubature: usize,
    /// `newton` or `quasi_newton`.
    pub solver: String,
    /// How the reduced body integrates the bulk term: `points` or `regions`.
    pub bulk: BulkIntegration,
    /// Median reduced step, ms.
    pub step_ms: f64,
    /// Mean reduced step, ms (shows the cost of the slow steps the median hides).
    pub step_mean_ms: f64,
    /// 99th percentile and largest reduced step, ms.
    pub step_p99_ms: f64,
    /// Largest reduced step, ms.
    pub step_max_ms: f64,
    /// Mean of `ReducedSim::prepare` after each step, ms: the held Hessian's refresh that a
    /// slow step asked for, made between the steps (as the node does once a step's outputs
    /// are out), so in none of the step figures.
    pub prepare_mean_ms: f64,
    /// Largest `ReducedSim::prepare` after a step, ms.
    pub prepare_max_ms: f64,
    /// Median FEM step, ms.
    pub fem_step_ms: f64,
    /// Median FEM step over median reduced step.
    pub speedup: f64,
    /// RMS distance of the lifted FEM vertices to the FEM reference over the whole trajectory,
    /// in % of the bounding-box diagonal.
    pub error_pct: f64,
    /// RMS distance of the lifted vertices of the reduced body's hanging equilibrium to the
    /// FEM's (both solved statically), % of the diagonal; NaN where not measured.
    pub static_error_pct: f64,
    /// Rayleigh's lowest frequency of the reduced body's hanging equilibrium over the FEM's
    /// (see `statics`); NaN where not measured.
    pub frequency_ratio: f64,
    /// Solver iterations per step, mean over the run.
    pub mean_iterations: f64,
    /// Steps where the solver hit its iteration limit.
    pub unconverged_steps: usize,
    /// Steps the quasi-Newton solver handed to full Newton.
    pub fallback_steps: usize,
}

/// What `bench sim` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct SimBenchReport {
    /// One row per shape, scenario, handle count, cubature size and solver, in that
    /// nesting order.
    pub rows: Vec<SimRow>,
    /// Median time to lift 100k points (m = 16 handles plus the constant), ms; with the
    /// creature only.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lift_100k_ms: Option<f64>,
}

/// A shape ready for the scenarios: its FEM mesh, voxel grid and eigenmode baseline.
pub(crate) struct BenchShape {
    pub source: Shape,
    pub mesh: Arc<TetMesh>,
    pub grid: VoxelGrid,
    /// The eigenmode baseline; None when the shape was prepared without it (the learned field
    /// needs no eigen-solve).
    pub eigen: Option<EigenmodeField>,
    pub diagonal: f64,
    pub young: f64,
    /// Its Poisson's ratio (the default material's unless a run asks for another).
    pub poisson: f64,
    /// The element of its FEM reference: linear unless a run asks for quadratic.
    pub reference: FemElement,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Scenario {
    Hanging,
    Drop,
    Poke,
}

impl Scenario {
    pub(crate) const ALL: [Scenario; 3] = [Scenario::Hanging, Scenario::Drop, Scenario::Poke];

    /// The scenario called `name`, or why there is none.
    pub(crate) fn named(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|s| s.name() == name)
            .ok_or_else(|| Error::InvalidParameter {
                name: "scenario",
                reason: format!("unknown scenario {name:?} (hanging, drop, poke)"),
            })
    }

    pub(crate) fn name(self) -> &'static str {
        match self {
            Scenario::Hanging => "hanging",
            Scenario::Drop => "drop",
            Scenario::Poke => "poke",
        }
    }
}

impl BenchShape {
    pub(crate) fn eigen_normalization(&self) -> crate::geometry::Normalization {
        self.source.normalization()
    }

    /// The eigenmode baseline of a shape prepared with modes.
    pub(crate) fn eigen(&self) -> &EigenmodeField {
        self.eigen
            .as_ref()
            .expect("the shape was prepared with its eigenmodes")
    }
}

/// Voxelizes and tetrahedralizes `shape` (at `resolution` cells across, or with 0, the
/// smallest resolution giving `min_vertices` vertices) and computes its `modes` eigenmodes (none for 0).
pub(crate) fn prepare_shape(
    shape: Shape,
    young: f64,
    resolution: usize,
    min_vertices: usize,
    modes: usize,
) -> Result<BenchShape> {
    let fine = VoxelGrid::from_shape(&shape, 128, None);
    let grid = match resolution {
        0 => fine.resample(smallest_resolution(&fine, min_vertices)),
        r => fine.resample(r),
    };
    shape_on_grid(shape, grid, young, modes)
}

/// The smallest resolution (from 16, by 4, at most 128) at which `fine`, resampled, gives a
/// mesh of at least `min_vertices` vertices.
pub(super) fn smallest_resolution(fine: &VoxelGrid, min_vertices: usize) -> usize {
    (16..128)
        .step_by(4)
        .find(|&r| TetMesh::from_grid(&fine.resample(r)).vertices.len() >= min_vertices)
        .unwrap_or(128)
}

/// The tetrahedral mesh of `grid` (a voxelization of `shape`) and, with `modes` > 0, its
/// eigenmodes.
pub(crate) fn shape_on_grid(
    shape: Shape,
    grid: VoxelGrid,
    young: f64,
    modes: usize,
) -> Result<BenchShape> {
    let mesh = TetMesh::from_grid(&grid);
    let (lo, hi) = grid.solid_bounds();
    let eigen = if modes > 0 {
        Some(EigenmodeField::compute(
            mesh.clone(),
            shape.normalization(),
            &EigenmodeOptions {
                modes,
                ..Default::default()
            },
        )?)
    } else {
        None
    };
    Ok(BenchShape {
        source: shape,
        mesh: Arc::new(mesh),
        grid,
        eigen,
        diagonal: (hi - lo).norm(),
        young,
        poisson: SimParams::default().poisson,
        reference: FemElement::Linear,
    })
}

pub(crate) fn scenario_params(shape: &BenchShape) -> SimParams {
    SimParams {
        young: shape.young,
        poisson: shape.poisson,
        ..SimParams::default()
    }
}

/// The x values from which a vertex lies in the 10% slab of the mesh's x extent at its min
/// end (`side` -1, at most the first) or its max end (`side` +1, at least the second).
/// The bounds are a pass over the voxel grid: taken once, not once per vertex.
fn end_slabs(mesh: &TetMesh) -> (f64, f64) {
    let (lo, hi) = mesh.bounds();
    let slab = 0.1 * (hi.x - lo.x);
    (lo.x + slab + 1e-9, hi.x - slab - 1e-9)
}

fn in_end_slab((low, high): (f64, f64), side: f64, x: f64) -> bool {
    if side < 0.0 {
        x <= low
    } else {
        x >= high
    }
}

/// Which end of the x extent the object hangs from: the one whose 10% slab holds more
/// vertices (the creature hangs by its head, not by the tip of its tail); -1 for min x.
fn pinned_side(mesh: &TetMesh) -> f64 {
    let slabs = end_slabs(mesh);
    let count = |side| {
        mesh.vertices
            .iter()
            .filter(|v| in_end_slab(slabs, side, v.x))
            .count()
    };
    if count(1.0) > count(-1.0) {
        1.0
    } else {
        -1.0
    }
}

/// Vertices within 10% of the x extent from the pinned end.
pub(crate) fn pinned_vertices(mesh: &TetMesh) -> Vec<usize> {
    let (side, slabs) = (pinned_side(mesh), end_slabs(mesh));
    (0..mesh.vertices.len())
        .filter(|&v| in_end_slab(slabs, side, mesh.vertices[v].x))
        .collect()
}

/// The drop starts tilted by 20 degrees about y, so it lands on an edge and turns over.
pub(crate) fn drop_tilt() -> nalgebra::Matrix3<f64> {
    *nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), 20f64.to_radians()).matrix()
}

/// 2% of the diagonal below the lowest point of the tilted object.
pub(crate) fn floor_height(shape: &BenchShape) -> f64 {
    let tilt = drop_tilt();
    let lowest = shape
        .mesh
        .vertices
        .iter()
        .map(|v| (tilt * v).z)
        .fold(f64::INFINITY, f64::min);
    lowest - 0.02 * shape.diagonal
}

/// The tip poke: half the object's weight, sideways and down, on the vertex farthest from the
/// pinned end, for 0.15 s.
pub(crate) fn poke(shape: &BenchShape, params: &SimParams) -> Poke {
    let mesh = &shape.mesh;
    let side = pinned_side(mesh);
    let tip = (0..mesh.vertices.len())
        .min_by(|&a, &b| (side * mesh.vertices[a].x).total_cmp(&(side * mesh.vertices[b].x)))
        .expect("vertices");
    let weight = mesh.volume() * params.density * 9.81;
    Poke {
        point: mesh.vertices[tip],
        force: Vector3::new(0.0, 0.4, -0.3) * weight,
        start: 0.0,
        end: 0.15,
    }
}

/// The FEM reference of `shape` (of its `reference` element) through `steps` steps of
/// `scenario`: the vertex positions after each step and each step's time, s.
pub(crate) fn run_fem(
    shape: &BenchShape,
    scenario: Scenario,
    params: &SimParams,
    steps: usize,
) -> Result<(Vec<Vec<f64>>, Vec<f64>)> {
    let (mesh, params) = (shape.mesh.clone(), params.clone());
    match shape.reference {
        FemElement::Linear => run_fem_on(FemSim::new(mesh, params)?, shape, scenario, steps),
        FemElement::Quadratic => {
            run_fem_on(FemSim::quadratic(mesh, params)?, shape, scenario, steps)
        }
    }
}

fn run_fem_on<const N: usize, const D: usize>(
    mut fem: FemSim<N, D>,
    shape: &BenchShape,
    scenario: Scenario,
    steps: usize,
) -> Result<(Vec<Vec<f64>>, Vec<f64>)> {
    let params = fem.params().clone();
    match scenario {
        Scenario::Hanging => fem.pin_vertices(&pinned_vertices(&shape.mesh)),
        Scenario::Drop => {
            let tilt = drop_tilt();
            let tilted: Vec<f64> = shape
                .mesh
                .vertices
                .iter()
                .flat_map(|v| (tilt * v).iter().copied().collect::<Vec<_>>())
                .collect();
            fem.set_positions(&tilted);
            fem.add_obstacle(Obstacle::floor(floor_height(shape)));
        }
        Scenario::Poke => {
            fem.pin_vertices(&pinned_vertices(&shape.mesh));
            fem.add_poke(poke(shape, &params));
        }
    }
    let mut trajectory = Vec::with_capacity(steps);
    let mut times = Vec::with_capacity(steps);
    for _ in 0..steps {
        let report = fem.step()?;
        times.push(report.seconds);
        trajectory.push(fem.positions().to_vec());
    }
    Ok((trajectory, times))
}

pub(crate) fn run_reduced(
    shape: &BenchShape,
    scenario: Scenario,
    params: &SimParams,
    subspace: &Arc<Subspace>,
    solver: Solver,
    reference: &[Vec<f64>],
) -> Result<(SimRow, Vec<f32>)> {
    let mesh = &shape.mesh;
    let mut sim = ReducedSim::new(subspace.clone(), params.clone(), solver, shape.diagonal)?;
    let masses: Vec<f64> = mesh
        .lumped_volumes()
        .iter()
        .map(|v| v * params.density)
        .collect();
    let pin = |sim: &mut ReducedSim| {
        let pinned = pinned_vertices(mesh);
        let points: Vec<_> = pinned.iter().map(|&v| mesh.vertices[v]).collect();
        let weights: Vec<_> = pinned.iter().map(|&v| masses[v]).collect();
        sim.add_pins(&points, &weights);
    };
    match scenario {
        Scenario::Hanging => pin(&mut sim),
        Scenario::Drop => {
            let (points, areas) = contact_points(mesh, 512);
            sim.add_contact_points(&points, &areas);
            sim.add_obstacle(Obstacle::floor(floor_height(shape)));
            sim.set_state(subspace.rigid_state(&drop_tilt(), &Vector3::zeros()), None);
        }
        Scenario::Poke => {
            pin(&mut sim);
            sim.add_poke(poke(shape, params));
        }
    }
    sim.prepare();
    let lifter = Lifter::new(subspace.field(), subspace.normalization(), &mesh.vertices);
    let mut lifted = vec![0.0f32; 3 * mesh.vertices.len()];
    let mut times = Vec::with_capacity(reference.len());
    let mut prepares = Vec::with_capacity(reference.len());
    let mut iterations = 0;
    let mut unconverged_steps = 0;
    let mut fallback_steps = 0;
    let mut squared = 0.0;
    for expected in reference {
        let report = sim.step();
        times.push(report.seconds);
        iterations += report.iterations;
        unconverged_steps += usize::from(!report.converged);
        fallback_steps += usize::from(report.fallback);
        lifter.lift(sim.state(), &mut lifted);
        let started = std::time::Instant::now();
        sim.prepare();
        prepares.push(started.elapsed().as_secs_f64());
        squared += lifted
            .iter()
            .zip(expected)
            .map(|(a, b)| (*a as f64 - b).powi(2))
            .sum::<f64>();
    }
    let samples = (reference.len() * mesh.vertices.len()) as f64;
    let row = SimRow {
        shape: String::new(),
        vertices: 0,
        scenario: String::new(),
        field: String::new(),
        handles: 0,
        cubature: 0,
        solver: String::new(),
        bulk: params.bulk,
        step_ms: median(&times) * 1e3,
        step_mean_ms: times.iter().sum::<f64>() / times.len() as f64 * 1e3,
        step_p99_ms: quantile(&times, 0.99) * 1e3,
        step_max_ms: times.iter().cloned().fold(f64::NAN, f64::max) * 1e3,
        prepare_mean_ms: prepares.iter().sum::<f64>() / prepares.len() as f64 * 1e3,
        prepare_max_ms: prepares.iter().cloned().fold(f64::NAN, f64::max) * 1e3,
        fem_step_ms: 0.0,
        speedup: 0.0,
        error_pct: (squared / samples).sqrt() / shape.diagonal * 100.0,
        static_error_pct: f64::NAN,
        frequency_ratio: f64::NAN,
        mean_iterations: iterations as f64 / reference.len() as f64,
        unconverged_steps,
        fallback_steps,
    };
    Ok((row, lifted))
}

/// Up to `count` boundary vertices of the mesh, evenly spread, each carrying the boundary area
/// of the vertices it stands for.
fn contact_points(mesh: &TetMesh, count: usize) -> (Vec<Vector3<f64>>, Vec<f64>) {
    let points: Vec<_> = mesh
        .boundary_vertices
        .iter()
        .map(|&v| mesh.vertices[v as usize])
        .collect();
    let (chosen, areas) = stratified_subset(&points, &mesh.boundary_areas, mesh.grid().cell, count);
    (chosen.iter().map(|&i| points[i]).collect(), areas)
}

/// Step time against error, one colour per solver.
pub fn sim_plot(report: &SimBenchReport) -> String {
    let series = |solver: &str, label, color| super::plot::Series {
        label,
        color,
        points: report
            .rows
            .iter()
            .filter(|r| r.solver == solver)
            .map(|r| (r.step_ms, r.error_pct))
            .collect(),
    };
    super::plot::scatter_svg(
        "physskin: reduced step time against error vs FEM",
        "median reduced step (ms, log scale)",
        "RMS error (% of bounding diagonal)",
        &[
            series("newton", "full Newton", "#d62728"),
            series(
                "quasi_newton",
                "quasi-Newton (L-BFGS, held Hessian)",
                "#1f77b4",
            ),
        ],
    )
}

/// Static error against handles (log scale), one series per shape and cubature size: what
/// doubling the handles or quadrupling the points buys.
pub fn handles_plot(report: &SimBenchReport) -> String {
    const COLORS: [&str; 6] = [
        "#1f77b4", "#aec7e8", "#d62728", "#ff9896", "#2ca02c", "#98df8a",
    ];
    let mut kinds: Vec<(&str, usize)> = (report.rows.iter())
        .map(|r| (r.shape.as_str(), r.cubature))
        .collect();
    kinds.sort_unstable_by_key(|&(shape, cubature)| {
        (SHAPES.iter().position(|&s| s == shape), cubature)
    });
    kinds.dedup();
    let labels: Vec<String> = (kinds.iter())
        .map(|(shape, cubature)| format!("{shape}, {cubature} points"))
        .collect();
    let series: Vec<_> = (kinds.iter().zip(&labels).enumerate())
        .map(|(i, (&(shape, cubature), label))| {
            let mut points: Vec<(f64, f64)> = (report.rows.iter())
                .filter(|r| r.shape == shape && r.cubature == cubature)
                .map(|r| (r.handles as f64, r.static_error_pct))
                .filter(|(_, error)| error.is_finite())
                .collect();
            // Every scenario of a size repeats its static error: one mark each.
            points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            points.dedup();
            super::plot::Series {
                label,
                color: COLORS[i % COLORS.len()],
                points,
            }
        })
        .collect();
    super::plot::scatter_svg(
        "physskin: static error against handles",
        "handles besides the constant one (log scale)",
        "static error vs FEM (% of bounding diagonal)",
        &series,
    )
}
