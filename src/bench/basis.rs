//! `bench basis`: how soon a new shape has an accurate basis. Per shape, the error against the
//! FEM (the mean over the hanging, drop and poke scenarios) of the network's field, of that
//! field refined 1, 2, ... iterations toward the skinning eigenmodes, each beside its build
//! time (inference, plus the tet mesh and the refinement), of the full refinement, and of the
//! exact eigenmodes beside their eigen-solve's time.

use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

use super::fields::{fem_references, field_errors, field_subspace};
use super::input::prepare_input;
use super::plot::{scatter_svg, Series};
use super::sim::{prepare_shape, scenario_params, BenchShape};
use crate::geometry::{bundled, load_geometry, Cubature, Shape, TetMesh};
use crate::physics::SimParams;
use crate::skinning::{
    refine_field, NeuralField, NeuralModel, RefineBudget, RefineOptions, SkinningField,
};
use crate::Result;

/// What to run.
#[derive(Clone, Debug)]
pub struct BasisOptions {
    /// Bundled shape names or mesh files. Default the plate, the rod, the creature and the
    /// bunny scan in config/samples (a path relative to the working directory: run it from
    /// the repository).
    pub shapes: Vec<String>,
    /// Refinement iterations to measure after. Default 1, 2, 3, 5, 8.
    pub iterations: Vec<u32>,
    /// FEM grid cells across the longest side (the eigenmodes and the refinement run on its
    /// tet mesh). Default 24, as `eval`.
    pub resolution: usize,
    /// Cubature points of the reduced simulations. Default 1024.
    pub cubature: usize,
    /// Steps per scenario. Default 40.
    pub steps: usize,
}

impl Default for BasisOptions {
    fn default() -> Self {
        Self {
            shapes: ["plate", "rod", "creature", "config/samples/bunny.obj"]
                .map(String::from)
                .to_vec(),
            iterations: vec![1, 2, 3, 5, 8],
            resolution: 24,
            cubature: 1024,
            steps: 40,
        }
    }
}

/// One basis of a shape: how long it took and how accurate it is.
#[derive(Clone, Debug, Serialize)]
pub struct BasisPoint {
    /// The shape.
    pub shape: String,
    /// Tet mesh vertices the refinement and the eigenmodes run on.
    pub mesh_vertices: usize,
    /// "network", "refined" or "eigenmodes".
    pub basis: String,
    /// Refinement iterations run (null for the network and the eigenmodes).
    pub iterations: Option<usize>,
    /// Time to the basis, ms: inference (and refinement), or the eigen-solve.
    pub build_ms: f64,
    /// Mean over the scenarios of the error against the FEM, % of the diagonal.
    pub error_pct: f64,
}

/// What `bench basis` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct BasisReport {
    /// Per shape in the order given: the network alone, then after each measured iteration
    /// count, then fully refined, then the exact eigenmodes.
    pub rows: Vec<BasisPoint>,
}

/// Runs every shape of `options`; `log` gets a line per basis measured.
pub fn run_basis_bench(options: &BasisOptions, log: impl Fn(&str)) -> Result<BasisReport> {
    let model = NeuralModel::bundled()?;
    let mut rows = Vec::new();
    for name in &options.shapes {
        let shape = load_shape(name)?;
        rows.extend(shape_basis(&model, name, &shape, options, &log)?);
    }
    Ok(BasisReport { rows })
}

fn load_shape(name: &str) -> Result<Shape> {
    match bundled(name) {
        Some(shape) => Ok(shape),
        None => Ok(Shape::from_raw(load_geometry(std::path::Path::new(name))?)?),
    }
}

fn shape_basis(
    model: &Arc<NeuralModel>,
    name: &str,
    shape: &Shape,
    options: &BasisOptions,
    log: &impl Fn(&str),
) -> Result<Vec<BasisPoint>> {
    let (learned, infer_ms) = infer(model, shape)?;
    let handles = learned.handle_count();
    // Stiff enough that gravity bends it visibly but not wildly, as in `eval`.
    let young = 500.0 * 1000.0 * 9.81 * shape.bounding_diagonal();
    let started = Instant::now();
    let bench = prepare_shape(shape.clone(), young, options.resolution, 0, handles - 1)?;
    let eigen_ms = started.elapsed().as_secs_f64() * 1e3;
    let runs = Runs::new(&bench, options)?;
    let point = |basis: &str, iterations, build_ms, error_pct| BasisPoint {
        shape: name.to_string(),
        mesh_vertices: bench.mesh.vertices.len(),
        basis: basis.into(),
        iterations,
        build_ms,
        error_pct,
    };
    let mut points = vec![point(
        "network",
        None,
        infer_ms,
        runs.error(learned.clone())?,
    )];
    let budgets = options
        .iterations
        .iter()
        .map(|&i| RefineBudget::Iterations(i));
    for budget in budgets.chain([RefineBudget::Full]) {
        let started = Instant::now();
        let refined = refine_field(
            learned.as_ref(),
            TetMesh::from_grid(&bench.grid),
            bench.eigen_normalization(),
            &RefineOptions {
                budget,
                ..Default::default()
            },
        )?;
        let refine_ms = started.elapsed().as_secs_f64() * 1e3;
        let error_pct = runs.error(Arc::new(refined.field))?;
        let iterations = Some(refined.report.iterations);
        points.push(point(
            "refined",
            iterations,
            infer_ms + refine_ms,
            error_pct,
        ));
    }
    let eigen = runs.error(Arc::new(bench.eigen().truncated(handles - 1)))?;
    points.push(point("eigenmodes", None, eigen_ms, eigen));
    for p in &points {
        let iterations = p
            .iterations
            .map_or(String::new(), |i| format!(" ({i} iterations)"));
        log(&format!(
            "{name}: {}{iterations}: {:.1} ms, error {:.3} %",
            p.basis, p.build_ms, p.error_pct
        ));
    }
    Ok(points)
}

/// The network's field of `shape` and its inference time, ms (timed twice, the second run
/// reported: the first pays for page faults and allocation).
fn infer(model: &Arc<NeuralModel>, shape: &Shape) -> Result<(Arc<NeuralField>, f64)> {
    let input = prepare_input(shape, 4096, 4096);
    let mut timed = None;
    for _ in 0..2 {
        let started = Instant::now();
        let field = model.field(&input.surface, &input.reference, shape.normalization())?;
        timed = Some((Arc::new(field), started.elapsed().as_secs_f64() * 1e3));
    }
    Ok(timed.expect("inferred"))
}

/// The FEM's trajectories of a shape, run once, and what a field's error needs beside them.
struct Runs<'a> {
    bench: &'a BenchShape,
    references: Vec<Vec<Vec<f64>>>,
    cubature: Cubature,
    params: SimParams,
}

impl<'a> Runs<'a> {
    fn new(bench: &'a BenchShape, options: &BasisOptions) -> Result<Self> {
        let params = scenario_params(bench);
        Ok(Self {
            references: fem_references(bench, &params, options.steps)?,
            cubature: Cubature::stratified(&bench.grid, options.cubature, bench.mesh.volume()),
            bench,
            params,
        })
    }

    /// Mean over the scenarios of the field's error against the FEM, %.
    fn error(&self, field: Arc<dyn SkinningField>) -> Result<f64> {
        let subspace = field_subspace(self.bench, field, &self.cubature, &self.params);
        let errors = field_errors(self.bench, &self.references, &subspace, &self.params)?;
        Ok(errors.iter().sum::<f64>() / errors.len() as f64)
    }
}

/// Error against time to the basis, one series per shape (log-scaled ms).
pub fn basis_plot(report: &BasisReport) -> String {
    const COLORS: [&str; 6] = [
        "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
    ];
    let mut shapes: Vec<&str> = Vec::new();
    for row in &report.rows {
        if !shapes.contains(&row.shape.as_str()) {
            shapes.push(&row.shape);
        }
    }
    let series: Vec<Series> = shapes
        .iter()
        .zip(COLORS.iter().cycle())
        .map(|(&shape, color)| Series {
            label: shape,
            color,
            points: (report.rows.iter())
                .filter(|r| r.shape == shape)
                .map(|r| (r.build_ms, r.error_pct))
                .collect(),
        })
        .collect();
    scatter_svg(
        "Time to a basis: network, refined, eigenmodes",
        "ms to the basis (log)",
        "error against the FEM, %",
        &series,
    )
}
