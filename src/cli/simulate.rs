//! `physskin simulate`: a bundled shape, or any mesh or cloud file, in its skinning subspace
//! through a bench scenario, against the full-space FEM.

use std::path::PathBuf;

use crate::bench::{simulate, simulate_input, InputSimOptions, InputSimSummary, SimulateOptions};
use crate::physics::Solver;
use crate::{Error, Result};
use nalgebra::Vector3;

#[derive(clap::Args)]
pub struct SimulateArgs {
    /// Bundled shape: plate, rod, creature, box, sphere (without --input).
    #[arg(long, default_value = "rod")]
    shape: String,
    /// A mesh or cloud file (OBJ, STL, PLY) instead of a bundled shape: built as the node
    /// builds it and measured against the FEM of --reference (or of the input, when it is a
    /// closed mesh).
    #[arg(long)]
    input: Option<PathBuf>,
    /// Where the input cloud was seen from, x,y,z in the file's coordinates: the cloud is one
    /// camera's view and is completed first.
    #[arg(long, value_parser = parse_point, allow_hyphen_values = true)]
    viewpoint: Option<Vector3<f64>>,
    /// The whole object's closed mesh, for the FEM reference of --input.
    #[arg(long)]
    reference: Option<PathBuf>,
    /// hanging, drop or poke.
    #[arg(long, default_value = "hanging")]
    scenario: String,
    /// Handles besides the constant one.
    #[arg(long, default_value_t = 16)]
    modes: usize,
    #[arg(long, default_value_t = 1024)]
    cubature: usize,
    #[arg(long, value_enum, default_value = "quasi-newton")]
    solver: SolverArg,
    #[arg(long, default_value_t = 60)]
    steps: usize,
    /// FEM grid cells across the longest side. Default: 48 for a bundled shape; for --input
    /// the coarsest grid whose mesh has 4,000 vertices.
    #[arg(long)]
    resolution: Option<usize>,
    /// Young's modulus, Pa.
    #[arg(long, default_value_t = 5e6)]
    young: f64,
    /// Skip the FEM reference (no error figure; bundled shapes only).
    #[arg(long)]
    no_reference: bool,
    /// Skinning field: learned (the bundled network) or eigen (eigenmodes of the FEM mesh;
    /// bundled shapes only).
    #[arg(long, value_enum, default_value = "learned")]
    field: FieldArg,
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, PartialEq, clap::ValueEnum)]
enum FieldArg {
    Learned,
    Eigen,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum SolverArg {
    Newton,
    QuasiNewton,
}

impl From<SolverArg> for Solver {
    fn from(arg: SolverArg) -> Self {
        match arg {
            SolverArg::Newton => Solver::Newton,
            SolverArg::QuasiNewton => Solver::QuasiNewton,
        }
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub(crate) enum BulkArg {
    Points,
    Regions,
}

impl From<BulkArg> for crate::physics::BulkIntegration {
    fn from(arg: BulkArg) -> Self {
        match arg {
            BulkArg::Points => Self::Points,
            BulkArg::Regions => Self::Regions,
        }
    }
}

/// `x,y,z` as a point.
pub(super) fn parse_point(text: &str) -> std::result::Result<Vector3<f64>, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| format!("`{text}` is not x,y,z: {e}"))?;
    match values[..] {
        [x, y, z] if values.iter().all(|v| v.is_finite()) => Ok(Vector3::new(x, y, z)),
        _ => Err(format!("`{text}` is not three finite numbers x,y,z")),
    }
}

pub fn run(args: SimulateArgs) -> Result<()> {
    let solver = Solver::from(args.solver);
    let Some(input) = args.input.clone() else {
        let options = SimulateOptions {
            shape: args.shape,
            scenario: args.scenario,
            modes: args.modes,
            cubature: args.cubature,
            solver,
            steps: args.steps,
            resolution: args.resolution.unwrap_or(48),
            young: args.young,
            reference: !args.no_reference,
            learned: args.field == FieldArg::Learned,
        };
        return run_bundled(options, args.json);
    };
    if args.field != FieldArg::Learned || args.no_reference || args.modes != 16 {
        return Err(Error::InvalidParameter {
            name: "input",
            reason: "a file runs with the learned field's 16 handles, and is compared with the FEM whenever a reference exists".into(),
        });
    }
    let options = InputSimOptions {
        input,
        viewpoint: args.viewpoint,
        reference: args.reference,
        scenario: args.scenario,
        steps: args.steps,
        young: args.young,
        cubature: args.cubature,
        solver,
        resolution: args.resolution.unwrap_or(0),
    };
    eprintln!(
        "simulating {} ({}), {} steps...",
        options.input.display(),
        options.scenario,
        options.steps
    );
    let summary = simulate_input(&options)?;
    if args.json {
        super::print_json(&summary);
    } else {
        print_input_summary(&summary);
    }
    Ok(())
}

fn print_input_summary(s: &InputSimSummary) {
    let or_none = |v: Option<f64>, unit: &str| v.map_or("-".into(), |v| format!("{v:.4}{unit}"));
    println!("input            {} ({} points)", s.input, s.points);
    println!("scenario         {}", s.scenario);
    println!(
        "body             volume {:.4e} m^3 (reference {}), mass {:.4} kg, built in {:.1} ms",
        s.volume,
        s.reference_volume
            .map_or("-".into(), |v| format!("{v:.4e} m^3")),
        s.mass,
        s.build_ms
    );
    if let Some(c) = s.completion.as_object().filter(|c| !c.is_empty()) {
        println!("completion       {}", serde_json::Value::Object(c.clone()));
    }
    println!(
        "reduced step     {:.3} ms median, {:.3} ms p99, {:.3} ms max",
        s.step_ms, s.step_p99_ms, s.step_max_ms
    );
    println!(
        "error vs FEM     {} of the bounding diagonal (the whole mesh's body: {})",
        or_none(s.error_pct, " %"),
        or_none(s.whole_mesh_error_pct, " %")
    );
    println!(
        "max displacement {:.4} m at the last step (FEM: {})",
        s.max_displacement,
        or_none(s.fem_max_displacement, " m")
    );
}

fn run_bundled(options: SimulateOptions, json: bool) -> Result<()> {
    eprintln!(
        "simulating {} ({}), {} handles + constant, {} cubature points, {} steps...",
        options.shape, options.scenario, options.modes, options.cubature, options.steps
    );
    let summary = simulate(&options)?;
    if json {
        super::print_json(&summary);
        return Ok(());
    }
    let r = &summary.row;
    println!(
        "shape            {} ({} FEM vertices, {} tets)",
        r.shape, r.vertices, summary.tets
    );
    println!("scenario         {}", r.scenario);
    println!(
        "field            {} ({} handles + constant)",
        r.field, r.handles
    );
    println!("cubature         {} points", r.cubature);
    println!(
        "reduced step     {:.3} ms median, {:.3} ms mean ({}, {:.1} iterations/step, {} steps unconverged, {} handed to Newton)",
        r.step_ms, r.step_mean_ms, r.solver, r.mean_iterations, r.unconverged_steps, r.fallback_steps
    );
    if r.error_pct.is_finite() {
        println!(
            "FEM step         {:.1} ms median (speed-up {:.0}x)",
            r.fem_step_ms, r.speedup
        );
        println!(
            "error vs FEM     {:.3} % of the bounding diagonal (RMS over all vertices and steps)",
            r.error_pct
        );
    }
    println!(
        "max displacement {:.4} m at the last step (FEM: {:.4} m)",
        summary.max_displacement_m, summary.fem_max_displacement_m
    );
    Ok(())
}
