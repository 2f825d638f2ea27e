//! `eval`: the learned skinning fields of shapes the model never saw, by the paper's metrics,
//! inference time, and simulation error next to the eigenmodes' at the same number of handles.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::input::prepare_input;
use super::sim::{prepare_shape, run_fem, run_reduced, scenario_params, Scenario};
use physskin::geometry::{Cubature, Shape, VoxelGrid};
use physskin::physics::{Solver, Subspace};
use physskin::skinning::{FieldMetrics, NeuralField, NeuralModel, SkinningField};
use physskin::Result;

/// What to measure.
#[derive(Clone, Debug)]
pub struct EvalOptions {
    /// Encoded surface points. Default 4096 (as trained).
    pub surface_points: usize,
    /// Interior points fixing the output normalization. Default 4096.
    pub reference_points: usize,
    /// Interior points the metrics are measured on (not the reference ones). Default 10000.
    pub query_points: usize,
    /// Run the simulation comparison against the FEM. Default true.
    pub simulate: bool,
    /// FEM grid cells across the longest side. Default 24.
    pub resolution: usize,
    /// Cubature points of the reduced simulations. Default 1024.
    pub cubature: usize,
    /// Steps per scenario. Default 40.
    pub steps: usize,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            surface_points: 4096,
            reference_points: 4096,
            query_points: 10_000,
            simulate: true,
            resolution: 24,
            cubature: 1024,
            steps: 40,
        }
    }
}

/// One shape's figures.
#[derive(Clone, Debug, Serialize)]
pub struct ShapeEval {
    /// The shape's name.
    pub name: String,
    /// Query points the metrics were measured on.
    pub points: usize,
    /// Handles, the constant one included (the metrics cover all of them).
    pub handles: usize,
    /// Omega_orth of the network's output on the query points: ||G - I||_F^2 / (K (K - 1));
    /// lower is better.
    pub omega_orth: f64,
    /// kappa_log of the network's output: log2(1 + lambda_max / lambda_min) of G; 1 at best.
    pub kappa_log: f64,
    /// H_spec of the network's output: the spectral entropy of G over log K; 1 at best.
    pub h_spec: f64,
    /// The same metrics of the product's weights, whitened over the reference points (the
    /// network's output above is only centered and scaled).
    pub whitened: FieldMetrics,
    /// Encoding the surface points, normalizing on the reference points, decoding the query
    /// points, ms.
    pub infer_ms: f64,
    /// Decoding 100k query points once encoded, ms.
    pub decode_100k_ms: f64,
    /// Mean over the scenarios of the RMS error against the FEM, % of the diagonal (NaN if not
    /// simulated).
    pub sim_error_pct: f64,
    /// The same mean for the skinning eigenmodes with as many handles and the same
    /// cubature, % of the diagonal (NaN if not simulated).
    pub eigen_error_pct: f64,
    /// Per scenario: (name, learned error %, eigenmode error %).
    pub scenarios: Vec<(String, f64, f64)>,
    /// Time of the eigen-solve the learned field replaces, ms.
    pub eigen_solve_ms: f64,
}

/// Means over the shapes.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EvalMean {
    /// Mean of the shapes' `omega_orth` (the network's output).
    pub omega_orth: f64,
    /// Mean of the shapes' `kappa_log` (the network's output).
    pub kappa_log: f64,
    /// Mean of the shapes' `h_spec` (the network's output).
    pub h_spec: f64,
    /// Mean of the shapes' whitened Omega_orth.
    pub whitened_omega_orth: f64,
    /// Mean of the shapes' whitened kappa_log.
    pub whitened_kappa_log: f64,
    /// Mean of the shapes' whitened H_spec.
    pub whitened_h_spec: f64,
    /// Mean inference time (encode, normalize, decode the query points), ms.
    pub infer_ms: f64,
    /// Mean time to decode 100k query points once encoded, ms.
    pub decode_100k_ms: f64,
    /// Mean of the learned field's error against the FEM, % of the diagonal (NaN if not
    /// simulated).
    pub sim_error_pct: f64,
    /// Mean of the eigenmodes' error against the FEM, % of the diagonal (NaN if not
    /// simulated).
    pub eigen_error_pct: f64,
    /// Mean of the per-shape ratios learned / eigenmode error.
    pub error_ratio: f64,
}

/// What `eval` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct EvalReport {
    /// One row per shape, in the order given.
    pub shapes: Vec<ShapeEval>,
    /// Means over the shapes.
    pub mean: EvalMean,
}

/// Evaluates `model` on named shapes (world units).
pub fn evaluate_fields(
    model: &Arc<NeuralModel>,
    shapes: &[(String, Shape)],
    options: &EvalOptions,
    mut progress: impl FnMut(&str),
) -> Result<EvalReport> {
    let mut rows = Vec::new();
    for (name, shape) in shapes {
        let row = evaluate_shape(model, name, shape, options)?;
        progress(&format!(
            "{name}: omega {:.3e} kappa {:.4} h {:.5} infer {:.1} ms, error learned {:.3} % eigen {:.3} %",
            row.omega_orth, row.kappa_log, row.h_spec, row.infer_ms, row.sim_error_pct, row.eigen_error_pct
        ));
        rows.push(row);
    }
    let n = rows.len().max(1) as f64;
    let mean_of = |f: &dyn Fn(&ShapeEval) -> f64| rows.iter().map(f).sum::<f64>() / n;
    let mean = EvalMean {
        omega_orth: mean_of(&|r| r.omega_orth),
        kappa_log: mean_of(&|r| r.kappa_log),
        h_spec: mean_of(&|r| r.h_spec),
        whitened_omega_orth: mean_of(&|r| r.whitened.omega_orth),
        whitened_kappa_log: mean_of(&|r| r.whitened.kappa_log),
        whitened_h_spec: mean_of(&|r| r.whitened.h_spec),
        infer_ms: mean_of(&|r| r.infer_ms),
        decode_100k_ms: mean_of(&|r| r.decode_100k_ms),
        sim_error_pct: mean_of(&|r| r.sim_error_pct),
        eigen_error_pct: mean_of(&|r| r.eigen_error_pct),
        error_ratio: mean_of(&|r| r.sim_error_pct / r.eigen_error_pct),
    };
    Ok(EvalReport { shapes: rows, mean })
}

/// Uniform random points inside the voxel solid, normalized frame.
pub fn interior_points(
    grid: &VoxelGrid,
    shape: &Shape,
    count: usize,
    seed: u64,
) -> Vec<Vector3<f64>> {
    let map = shape.normalization();
    let solid: Vec<usize> = (0..grid.len()).filter(|&i| grid.solid[i]).collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let cell = grid.coords(solid[rng.random_range(0..solid.len())]);
            let jitter = Vector3::new(
                rng.random::<f64>(),
                rng.random::<f64>(),
                rng.random::<f64>(),
            );
            map.to_normalized(&(grid.cell_corner(cell) + jitter * grid.cell))
        })
        .collect()
}

fn evaluate_shape(
    model: &Arc<NeuralModel>,
    name: &str,
    shape: &Shape,
    options: &EvalOptions,
) -> Result<ShapeEval> {
    let input = prepare_input(shape, options.surface_points, options.reference_points);
    let queries = interior_points(&input.grid, shape, options.query_points, 3);
    let handles = model.config().handles + 1;

    // Timed twice; the second run is reported (the first pays for page faults and allocation).
    let mut weights = vec![0.0; queries.len() * handles];
    let mut infer_ms = 0.0;
    let mut field = None;
    for _ in 0..2 {
        let started = Instant::now();
        let f = model.field(&input.surface, &input.reference, shape.normalization())?;
        f.evaluate(&queries, &mut weights, None);
        infer_ms = started.elapsed().as_secs_f64() * 1e3;
        field = Some(f);
    }
    let field: NeuralField = field.expect("evaluated");
    let whitened = FieldMetrics::of(&weights, handles);
    let metrics = FieldMetrics::of(&field.network_output(&queries)?, handles);

    let many = interior_points(&input.grid, shape, 100_000, 5);
    let mut many_weights = vec![0.0; many.len() * handles];
    let started = Instant::now();
    field.evaluate(&many, &mut many_weights, None);
    let decode_100k_ms = started.elapsed().as_secs_f64() * 1e3;

    let mut row = ShapeEval {
        name: name.to_string(),
        points: queries.len(),
        handles,
        omega_orth: metrics.omega_orth,
        kappa_log: metrics.kappa_log,
        h_spec: metrics.h_spec,
        whitened,
        infer_ms,
        decode_100k_ms,
        sim_error_pct: f64::NAN,
        eigen_error_pct: f64::NAN,
        scenarios: Vec::new(),
        eigen_solve_ms: f64::NAN,
    };
    if options.simulate {
        simulate_both(&mut row, shape, Arc::new(field), options)?;
    }
    Ok(row)
}

/// Each scenario with the FEM, the eigenmodes and the learned field (same m, same cubature).
fn simulate_both(
    row: &mut ShapeEval,
    shape: &Shape,
    learned: Arc<NeuralField>,
    options: &EvalOptions,
) -> Result<()> {
    let diagonal = shape.bounding_diagonal();
    // Stiff enough that gravity bends it visibly but not wildly: E = 500 rho g L.
    let young = 500.0 * 1000.0 * 9.81 * diagonal;
    let modes = row.handles - 1;
    let started = Instant::now();
    let bench = prepare_shape(shape.clone(), young, options.resolution, 0, modes)?;
    row.eigen_solve_ms = started.elapsed().as_secs_f64() * 1e3;
    let params = scenario_params(&bench);
    let cubature = Cubature::stratified(&bench.grid, options.cubature, bench.mesh.volume());
    let eigen: Arc<dyn SkinningField> = Arc::new(bench.eigen().truncated(modes));
    let learned: Arc<dyn SkinningField> = learned;
    let (mut sum_learned, mut sum_eigen) = (0.0, 0.0);
    for scenario in Scenario::ALL {
        let (reference, _) = run_fem(&bench, scenario, &params, options.steps)?;
        let mut errors = [0.0; 2];
        for (i, field) in [&learned, &eigen].into_iter().enumerate() {
            let subspace = Arc::new(Subspace::build(
                field.clone(),
                bench.eigen_normalization(),
                &cubature,
                params.density,
            ));
            let (result, _) = run_reduced(
                &bench,
                scenario,
                &params,
                &subspace,
                Solver::QuasiNewton,
                &reference,
            )?;
            errors[i] = result.error_pct;
        }
        sum_learned += errors[0];
        sum_eigen += errors[1];
        row.scenarios
            .push((scenario.name().to_string(), errors[0], errors[1]));
    }
    row.sim_error_pct = sum_learned / Scenario::ALL.len() as f64;
    row.eigen_error_pct = sum_eigen / Scenario::ALL.len() as f64;
    Ok(())
}
