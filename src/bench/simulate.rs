//! `simulate`: one bundled shape in its subspace and, optionally, in the full-space FEM.

use std::sync::Arc;

use nalgebra::Vector3;
use serde::Serialize;

use super::sim::{prepare_shape, run_fem, run_reduced, scenario_params, Scenario, SimRow};
use super::stats::median;
use crate::error::{Error, Result};
use crate::geometry::{bundled, Cubature};
use crate::physics::{Solver, Subspace};
use crate::skinning::SkinningField;

/// One simulation of a bundled shape, reduced and (optionally) against the FEM reference: the
/// CLI's `simulate`.
#[derive(Clone, Debug)]
pub struct SimulateOptions {
    /// A bundled shape: plate, rod, creature, box or sphere. Default rod.
    pub shape: String,
    /// `hanging`, `drop` or `poke`. Default hanging.
    pub scenario: String,
    /// Handles besides the constant one; with the learned field, the bundled model's
    /// count. Default 16.
    pub modes: usize,
    /// Cubature points of the reduced simulation. Default 1024.
    pub cubature: usize,
    /// The reduced solver. Default quasi-Newton.
    pub solver: Solver,
    /// Steps of 1/60 s. Default 60.
    pub steps: usize,
    /// FEM grid cells across the longest side.
    pub resolution: usize,
    /// Young's modulus, Pa. Default 5e6.
    pub young: f64,
    /// Run the FEM reference and measure the error against it. Default true.
    pub reference: bool,
    /// The skinning field: the learned one (bundled model, one forward pass) or the
    /// eigenmodes (an eigen-solve on the FEM mesh).
    pub learned: bool,
}

impl Default for SimulateOptions {
    fn default() -> Self {
        Self {
            shape: "rod".into(),
            scenario: "hanging".into(),
            modes: 16,
            cubature: 1024,
            solver: Solver::QuasiNewton,
            steps: 60,
            resolution: 48,
            young: 5e6,
            reference: true,
            learned: true,
        }
    }
}

/// What `simulate` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct SimulateSummary {
    /// The run's row, its fields flattened into this object; without the reference,
    /// `error_pct`, `fem_step_ms` and `speedup` are NaN (null in JSON).
    #[serde(flatten)]
    pub row: SimRow,
    /// Tetrahedra of the FEM mesh.
    pub tets: usize,
    /// Iterations of the eigen-solve (0 with the learned field, which needs none).
    pub eigen_iterations: usize,
    /// Largest vertex displacement of the reduced simulation at the last step, m.
    pub max_displacement_m: f64,
    /// The same for the FEM reference (NaN without it), m.
    pub fem_max_displacement_m: f64,
}

/// Runs one bundled shape in its subspace and, unless `reference` is off, in the
/// FEM. Errs on an unknown shape or scenario, on `modes` other than the bundled
/// model's handles with the learned field, or when a simulation fails.
pub fn simulate(options: &SimulateOptions) -> Result<SimulateSummary> {
    let scenario = Scenario::named(&options.scenario)?;
    let name: &'static str = crate::geometry::BUNDLED
        .iter()
        .find(|n| **n == options.shape)
        .ok_or_else(|| Error::InvalidParameter {
            name: "shape",
            reason: format!(
                "unknown shape {:?} (one of {:?})",
                options.shape,
                crate::geometry::BUNDLED
            ),
        })?;
    let source = bundled(name).expect("a bundled shape");
    // The learned field needs no eigen-solve: prepare the shape without modes.
    let modes = if options.learned { 0 } else { options.modes };
    let shape = prepare_shape(source, options.young, options.resolution, 0, modes)?;
    let params = scenario_params(&shape);
    let (reference, fem_times) = if options.reference {
        run_fem(&shape, scenario, &params, options.steps)?
    } else {
        (Vec::new(), Vec::new())
    };
    let field: Arc<dyn SkinningField> = if options.learned {
        let model = crate::skinning::NeuralModel::bundled()?;
        if model.config().handles != options.modes {
            return Err(Error::InvalidParameter {
                name: "modes",
                reason: format!(
                    "the bundled model has {} learned handles; use --modes {} or the eigenmodes",
                    model.config().handles,
                    model.config().handles
                ),
            });
        }
        let input = super::input::prepare_input(&shape.source, 4096, 4096);
        Arc::new(model.field(
            &input.surface,
            &input.reference,
            shape.source.normalization(),
        )?)
    } else {
        Arc::new(shape.eigen().truncated(options.modes))
    };
    let cubature = Cubature::stratified(&shape.grid, options.cubature, shape.mesh.volume());
    let subspace = Arc::new(Subspace::build(
        field.clone(),
        shape.eigen_normalization(),
        &cubature,
        params.density,
    ));
    // Without a reference the trajectory is compared with nothing: feed rest positions.
    let placeholder;
    let trajectory: &[Vec<f64>] = if options.reference {
        &reference
    } else {
        placeholder = vec![Vec::new(); options.steps];
        &placeholder
    };
    let (mut row, lifted) = run_reduced(
        &shape,
        scenario,
        &params,
        &subspace,
        options.solver,
        trajectory,
    )?;
    let fem_step_ms = median(&fem_times) * 1e3;
    row = SimRow {
        shape: name.into(),
        vertices: shape.mesh.vertices.len(),
        scenario: scenario.name().into(),
        field: field.kind().into(),
        handles: options.modes,
        cubature: cubature.len(),
        solver: options.solver.name().into(),
        fem_step_ms,
        speedup: fem_step_ms / row.step_ms,
        error_pct: if options.reference {
            row.error_pct
        } else {
            f64::NAN
        },
        ..row
    };
    let max_displacement_m = lifted
        .chunks(3)
        .zip(&shape.mesh.vertices)
        .map(|(x, v)| (Vector3::new(x[0] as f64, x[1] as f64, x[2] as f64) - v).norm())
        .fold(0.0, f64::max);
    let fem_max_displacement_m = reference.last().map_or(f64::NAN, |last| {
        last.chunks(3)
            .zip(&shape.mesh.vertices)
            .map(|(x, v)| (Vector3::new(x[0], x[1], x[2]) - v).norm())
            .fold(0.0, f64::max)
    });
    Ok(SimulateSummary {
        fem_max_displacement_m,
        row,
        tets: shape.mesh.tets.len(),
        eigen_iterations: shape.eigen.as_ref().map_or(0, |e| e.iterations),
        max_displacement_m,
    })
}
