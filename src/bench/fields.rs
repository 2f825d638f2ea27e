//! `eval`: the learned skinning fields of shapes the model never saw, by the paper's metrics,
//! inference time, and simulation error next to the eigenmodes' at the same number of handles.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::input::prepare_input;
use super::sim::{prepare_shape, run_fem, run_reduced, scenario_params, BenchShape, Scenario};
use super::statics::{fem_hanging, reduced_against};
use crate::geometry::TetMesh;
use crate::geometry::{Cubature, Shape, VoxelGrid};
use crate::physics::{SimParams, Solver, Subspace};
use crate::skinning::{
    refine_field, FieldMetrics, NeuralField, NeuralModel, RefineBudget, RefineOptions,
    SkinningField, DEFAULT_REFINE_MS,
};
use crate::Result;

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
    /// How the network's field is refined toward the eigenmodes (on the FEM grid's tet mesh).
    /// Default: within 60 ms, which with the network's ~45 ms, the tet mesh and the last
    /// iteration's overshoot keeps a new shape's build within 150 ms.
    pub refine: RefineOptions,
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
            refine: RefineOptions {
                budget: RefineBudget::Millis(DEFAULT_REFINE_MS),
                ..Default::default()
            },
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
    /// The same mean for the network's field refined toward the eigenmodes within the budget
    /// (NaN if not simulated).
    pub refined_error_pct: f64,
    /// Per scenario: (name, learned error %, eigenmode error %, refined error %).
    pub scenarios: Vec<(String, f64, f64, f64)>,
    /// The hanging equilibrium, solved statically, against the FEM's: RMS distance of the
    /// mesh's vertices, % of the diagonal, per field (NaN if not simulated).
    pub static_error_pct: PerField,
    /// Rayleigh's lowest frequency of that equilibrium over the FEM's, per field (NaN if not
    /// simulated): above 1, the reduced body is too stiff.
    pub frequency_ratio: PerField,
    /// Time of the eigen-solve the learned field replaces, ms.
    pub eigen_solve_ms: f64,
    /// The refinement: the tet mesh, the start block, the factorization and the iterations, ms
    /// (NaN if not simulated).
    pub refine_ms: f64,
    /// Refinement iterations run within the budget.
    pub refine_iterations: usize,
    /// A new shape's basis: the network's inference plus the refinement, ms.
    pub build_ms: f64,
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
    /// Mean of the refined field's error against the FEM, % of the diagonal.
    pub refined_error_pct: f64,
    /// Mean of the per-shape ratios refined / eigenmode error.
    pub refined_error_ratio: f64,
    /// The largest per-shape ratio refined / eigenmode error.
    pub refined_error_ratio_max: f64,
    /// Mean refinement time, ms.
    pub refine_ms: f64,
    /// Mean build time of a new shape's basis (inference plus refinement), ms.
    pub build_ms: f64,
    /// Means of the shapes' static errors, % of the diagonal.
    pub static_error_pct: PerField,
    /// Means of the shapes' frequency ratios.
    pub frequency_ratio: PerField,
}

/// One figure for each field `eval` simulates.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct PerField {
    /// The network's field.
    pub learned: f64,
    /// The skinning eigenmodes with as many handles.
    pub eigen: f64,
    /// The network's field refined toward the eigenmodes.
    pub refined: f64,
}

impl PerField {
    const NAN: Self = Self {
        learned: f64::NAN,
        eigen: f64::NAN,
        refined: f64::NAN,
    };
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
            "{name}: omega {:.3e} kappa {:.4} h {:.5} infer {:.1} ms, error learned {:.3} % eigen {:.3} % \
             refined {:.3} % ({} iterations, {:.1} ms); static learned {:.3} % eigen {:.3} % \
             refined {:.3} %, frequency x{:.3} x{:.3} x{:.3}",
            row.omega_orth,
            row.kappa_log,
            row.h_spec,
            row.infer_ms,
            row.sim_error_pct,
            row.eigen_error_pct,
            row.refined_error_pct,
            row.refine_iterations,
            row.refine_ms,
            row.static_error_pct.learned,
            row.static_error_pct.eigen,
            row.static_error_pct.refined,
            row.frequency_ratio.learned,
            row.frequency_ratio.eigen,
            row.frequency_ratio.refined
        ));
        rows.push(row);
    }
    let n = rows.len().max(1) as f64;
    let mean_of = |f: &dyn Fn(&ShapeEval) -> f64| rows.iter().map(f).sum::<f64>() / n;
    let per_field_mean = |f: &dyn Fn(&ShapeEval) -> PerField| PerField {
        learned: mean_of(&|r| f(r).learned),
        eigen: mean_of(&|r| f(r).eigen),
        refined: mean_of(&|r| f(r).refined),
    };
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
        refined_error_pct: mean_of(&|r| r.refined_error_pct),
        refined_error_ratio: mean_of(&|r| r.refined_error_pct / r.eigen_error_pct),
        refined_error_ratio_max: rows
            .iter()
            .map(|r| r.refined_error_pct / r.eigen_error_pct)
            .fold(f64::NAN, f64::max),
        refine_ms: mean_of(&|r| r.refine_ms),
        build_ms: mean_of(&|r| r.build_ms),
        static_error_pct: per_field_mean(&|r| r.static_error_pct),
        frequency_ratio: per_field_mean(&|r| r.frequency_ratio),
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
        refined_error_pct: f64::NAN,
        scenarios: Vec::new(),
        static_error_pct: PerField::NAN,
        frequency_ratio: PerField::NAN,
        eigen_solve_ms: f64::NAN,
        refine_ms: f64::NAN,
        refine_iterations: 0,
        build_ms: f64::NAN,
    };
    if options.simulate {
        simulate_both(&mut row, shape, Arc::new(field), options)?;
    }
    Ok(row)
}

/// Each scenario with the FEM, the eigenmodes, the learned field and the learned field refined
/// on the eigenmodes' own mesh (same m, same cubature).
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
    // The product builds the tet mesh for the refinement itself: its time counts.
    let started = Instant::now();
    let mesh = TetMesh::from_grid(&bench.grid);
    let refined = refine_field(
        learned.as_ref(),
        mesh,
        bench.eigen_normalization(),
        &options.refine,
    )?;
    row.refine_ms = started.elapsed().as_secs_f64() * 1e3;
    row.refine_iterations = refined.report.iterations;
    row.build_ms = row.infer_ms + row.refine_ms;
    let params = scenario_params(&bench);
    let cubature = Cubature::stratified(&bench.grid, options.cubature, bench.mesh.volume());
    let references = fem_references(&bench, &params, options.steps)?;
    let equilibrium = fem_hanging(&bench, &params)?;
    let fields: [Arc<dyn SkinningField>; 3] = [
        learned,
        Arc::new(bench.eigen().truncated(modes)),
        Arc::new(refined.field),
    ];
    let mut errors = Vec::new();
    let mut statics = Vec::new();
    for field in fields {
        let subspace = field_subspace(&bench, field, &cubature, &params);
        let (error, ratio) = reduced_against(
            &bench,
            &params,
            &subspace,
            Solver::QuasiNewton,
            &equilibrium,
        )?;
        statics.push([error, ratio]);
        errors.push(field_errors(&bench, &references, &subspace, &params)?);
    }
    let per_field = |i: usize| PerField {
        learned: statics[0][i],
        eigen: statics[1][i],
        refined: statics[2][i],
    };
    row.static_error_pct = per_field(0);
    row.frequency_ratio = per_field(1);
    let mut sums = [0.0; 3];
    for (i, scenario) in Scenario::ALL.iter().enumerate() {
        for (sum, field) in sums.iter_mut().zip(&errors) {
            *sum += field[i];
        }
        let name = scenario.name().to_string();
        row.scenarios
            .push((name, errors[0][i], errors[1][i], errors[2][i]));
    }
    let count = Scenario::ALL.len() as f64;
    row.sim_error_pct = sums[0] / count;
    row.eigen_error_pct = sums[1] / count;
    row.refined_error_pct = sums[2] / count;
    Ok(())
}

/// The FEM's trajectory of every scenario ([`Scenario::ALL`]), `steps` steps each.
pub(crate) fn fem_references(
    bench: &BenchShape,
    params: &SimParams,
    steps: usize,
) -> Result<Vec<Vec<Vec<f64>>>> {
    Scenario::ALL
        .iter()
        .map(|&scenario| Ok(run_fem(bench, scenario, params, steps)?.0))
        .collect()
}

/// `field`'s subspace on `cubature`, in the frame of `bench`'s eigenmodes.
pub(crate) fn field_subspace(
    bench: &BenchShape,
    field: Arc<dyn SkinningField>,
    cubature: &Cubature,
    params: &SimParams,
) -> Arc<Subspace> {
    Arc::new(Subspace::build(
        field,
        bench.eigen_normalization(),
        cubature,
        params.density,
    ))
}

/// The error against the FEM, % of the diagonal, of the reduced simulation of every scenario
/// in `subspace` ([`field_subspace`]; quasi-Newton), against `references` ([`fem_references`]).
pub(crate) fn field_errors(
    bench: &BenchShape,
    references: &[Vec<Vec<f64>>],
    subspace: &Arc<Subspace>,
    params: &SimParams,
) -> Result<Vec<f64>> {
    Scenario::ALL
        .iter()
        .zip(references)
        .map(|(&scenario, reference)| {
            let (result, _) = run_reduced(
                bench,
                scenario,
                params,
                subspace,
                Solver::QuasiNewton,
                reference,
            )?;
            Ok(result.error_pct)
        })
        .collect()
}
