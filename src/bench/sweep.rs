//! `bench sim`'s sweep: every shape, scenario, handle count, cubature size and solver of the
//! run, the reduced body against the FEM over the same steps and at its hanging equilibrium.

use std::sync::Arc;
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::sim::{
    bench_min_vertices, bench_resolutions, prepare_shape, run_fem, run_reduced, scenario_params,
    BenchShape, SimBenchOptions, SimBenchReport, SimRow, SHAPES, YOUNGS,
};
use super::statics::{fem_hanging, reduced_against};
use super::stats::median;
use crate::error::Result;
use crate::geometry::{bundled, sample_surface, Cubature, SurfaceSampling, VoxelGrid};
use crate::physics::{Lifter, SimParams, Subspace};
use crate::skinning::{EigenmodeField, SkinningField};

/// Runs the bench; `progress` receives a line per finished piece of work.
pub fn run_sim_bench(
    options: &SimBenchOptions,
    mut progress: impl FnMut(&str),
) -> Result<SimBenchReport> {
    options.check()?;
    let quick = options.quick;
    let handle_counts = SimBenchOptions::pick(
        if quick { &[4, 16] } else { &[4, 8, 16, 32] },
        &options.handles,
    );
    let cubatures = SimBenchOptions::pick(&[256, 1024], &options.cubatures);
    let variants = options.variants();
    let scenarios = options.chosen_scenarios()?;
    let steps = if quick { 20 } else { 60 };
    let max_modes = *handle_counts
        .iter()
        .max()
        .expect("at least one handle count");
    let resolutions = bench_resolutions(quick);
    let shapes = (0..SHAPES.len())
        .map(|i| (SHAPES[i], YOUNGS[i], resolutions[i]))
        .filter(|(name, _, _)| {
            options.shapes.is_empty() || options.shapes.iter().any(|s| s == name)
        });
    let min_big_vertices = bench_min_vertices(quick);
    let mut rows = Vec::new();
    let mut lift_field = None;
    for (name, young, resolution) in shapes {
        let source = bundled(name).expect("a bundled shape");
        let mut shape = prepare_shape(source, young, resolution, min_big_vertices, max_modes)?;
        shape.reference = options.reference;
        if let Some(poisson) = options.poisson {
            shape.poisson = poisson;
        }
        progress(&format!(
            "{name}: {} FEM vertices, {} tets, eigenmodes in {} iterations",
            shape.mesh.vertices.len(),
            shape.mesh.tets.len(),
            shape.eigen().iterations
        ));
        let started = Instant::now();
        let equilibrium = fem_hanging(&shape, &scenario_params(&shape))?;
        progress(&format!(
            "{name}: FEM hanging equilibrium ({} nodes) in {} static steps ({:.0} s)",
            equilibrium.nodes,
            equilibrium.steps,
            started.elapsed().as_secs_f64()
        ));
        for &scenario in &scenarios {
            let params = scenario_params(&shape);
            let started = Instant::now();
            let (reference, fem_times) = run_fem(&shape, scenario, &params, steps)?;
            let fem_step_ms = median(&fem_times) * 1e3;
            progress(&format!(
                "{name}/{}: FEM {steps} steps, median {fem_step_ms:.1} ms ({:.0} s)",
                scenario.name(),
                started.elapsed().as_secs_f64()
            ));
            for &m in &handle_counts {
                let field: Arc<dyn SkinningField> = Arc::new(shape.eigen().truncated(m));
                for &cubature_size in &cubatures {
                    let cubature =
                        Cubature::stratified(&shape.grid, cubature_size, shape.mesh.volume());
                    let subspace = Arc::new(Subspace::build(
                        field.clone(),
                        shape.eigen_normalization(),
                        &cubature,
                        params.density,
                    ));
                    for &(solver, bulk) in &variants {
                        let params = SimParams {
                            bulk,
                            ..params.clone()
                        };
                        let (row, _) =
                            run_reduced(&shape, scenario, &params, &subspace, solver, &reference)?;
                        let (static_error_pct, frequency_ratio) =
                            reduced_against(&shape, &params, &subspace, solver, &equilibrium)?;
                        let row = SimRow {
                            shape: name.into(),
                            vertices: shape.mesh.vertices.len(),
                            scenario: scenario.name().into(),
                            field: field.kind().into(),
                            handles: m,
                            cubature: cubature.len(),
                            solver: solver.name().into(),
                            fem_step_ms,
                            speedup: fem_step_ms / row.step_ms,
                            static_error_pct,
                            frequency_ratio,
                            ..row
                        };
                        progress(&format!(
                            "  m={m:<2} cubature={:<5} {:<12} {:<7?} step {:>8.3} ms  error {:.3}%  static {:.3}%  frequency {:.3}x",
                            row.cubature, row.solver, bulk, row.step_ms, row.error_pct, static_error_pct, frequency_ratio
                        ));
                        rows.push(row);
                    }
                }
            }
        }
        if name == "creature" && max_modes >= 16 {
            lift_field = Some((shape.eigen().truncated(16), shape));
        }
    }
    let lift_100k_ms = match lift_field {
        Some((field, shape)) => Some(time_lift(&field, &shape)?),
        None => None,
    };
    Ok(SimBenchReport { rows, lift_100k_ms })
}

/// Median time to lift 100k surface points of `shape` with `field`.
fn time_lift(field: &EigenmodeField, shape: &BenchShape) -> Result<f64> {
    let source = &shape.source;
    let grid = VoxelGrid::from_shape(source, 64, None);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let samples = sample_surface(
        source,
        &grid,
        &SurfaceSampling {
            count: 100_000,
            ..Default::default()
        },
        &mut rng,
    );
    let lifter = Lifter::new(field, field.normalization(), &samples.points);
    let z = nalgebra::DMatrix::from_fn(3, 4 * field.handle_count(), |d, a| {
        0.01 * ((d + 3 * a) as f64).sin()
    });
    let mut out = vec![0.0f32; 3 * lifter.len()];
    let mut times = Vec::new();
    for _ in 0..50 {
        let started = Instant::now();
        lifter.lift(&z, &mut out);
        times.push(started.elapsed().as_secs_f64());
    }
    Ok(median(&times) * 1e3)
}
