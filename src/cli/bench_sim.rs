//! `physskin bench sim`: its arguments, and the table it prints.

use std::path::PathBuf;

use crate::bench::{run_sim_bench, SimBenchOptions, SimBenchReport};
use crate::cli::simulate::{BulkArg, SolverArg};
use crate::physics::FemElement;

/// Where the plot goes unless `--plot` says.
const DEFAULT_PLOT: &str = "target/bench/sim.svg";

/// Reduced simulation against the FEM reference: step time next to error.
#[derive(clap::Args)]
pub struct SimArgs {
    /// Small meshes and fewer variants (fits in CI).
    #[arg(long)]
    pub quick: bool,
    /// Print JSON instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Where to write the step-time-against-error plot (SVG); the static error against
    /// handles goes beside it, its name ending in `-handles.svg`.
    #[arg(long, default_value = DEFAULT_PLOT)]
    pub plot: PathBuf,
    /// Only these shapes (plate, rod, creature; comma-separated).
    #[arg(long, value_delimiter = ',')]
    pub shape: Vec<String>,
    /// Only these scenarios (hanging, drop, poke).
    #[arg(long, value_delimiter = ',')]
    pub scenario: Vec<String>,
    /// Only these handle counts (besides the constant one).
    #[arg(long, value_delimiter = ',')]
    pub handles: Vec<usize>,
    /// Only these cubature sizes.
    #[arg(long, value_delimiter = ',')]
    pub cubature: Vec<usize>,
    /// Only these solvers.
    #[arg(long, value_delimiter = ',', value_enum)]
    pub solver: Vec<SolverArg>,
    /// How the reduced bodies integrate the bulk term, each in turn (default: points).
    #[arg(long, value_delimiter = ',', value_enum)]
    pub bulk: Vec<BulkArg>,
    /// The FEM reference on quadratic tetrahedra of the same mesh (free of the linear
    /// ones' locking, some seven times the unknowns).
    #[arg(long)]
    pub quadratic: bool,
    /// Poisson's ratio of every body and its FEM (default: the material's, 0.45).
    #[arg(long)]
    pub poisson: Option<f64>,
}

impl Default for SimArgs {
    /// What `physskin bench` without a subcommand runs: the full bench.
    fn default() -> Self {
        SimArgs {
            quick: false,
            json: false,
            plot: DEFAULT_PLOT.into(),
            shape: Vec::new(),
            scenario: Vec::new(),
            handles: Vec::new(),
            cubature: Vec::new(),
            solver: Vec::new(),
            bulk: Vec::new(),
            quadratic: false,
            poisson: None,
        }
    }
}

impl SimArgs {
    fn options(self) -> SimBenchOptions {
        SimBenchOptions {
            quick: self.quick,
            shapes: self.shape,
            scenarios: self.scenario,
            handles: self.handles,
            cubatures: self.cubature,
            solvers: self.solver.into_iter().map(Into::into).collect(),
            bulks: self.bulk.into_iter().map(Into::into).collect(),
            reference: if self.quadratic {
                FemElement::Quadratic
            } else {
                FemElement::Linear
            },
            poisson: self.poisson,
        }
    }
}

/// Runs `bench sim` as `args` ask: a table (or JSON) on stdout, the plot of step time against
/// error, and beside it (`NAME-handles.svg`) the static error against handles.
pub(crate) fn run(args: SimArgs) -> crate::Result<()> {
    let (json, plot) = (args.json, args.plot.clone());
    let report = run_sim_bench(&args.options(), |line| eprintln!("{line}"))?;
    crate::cli::write_plot(&plot, &crate::bench::sim_plot(&report))?;
    let stem = plot
        .file_stem()
        .map_or("sim".into(), |s| s.to_string_lossy());
    let by_handles = plot.with_file_name(format!("{stem}-handles.svg"));
    crate::cli::write_plot(&by_handles, &crate::bench::handles_plot(&report))?;
    if json {
        crate::cli::print_json(&report);
    } else {
        print_table(&report);
        println!("plots: {} and {}", plot.display(), by_handles.display());
    }
    Ok(())
}

fn print_table(report: &SimBenchReport) {
    println!(
        "{:<9} {:>6} {:<8} {:<6} {:>3} {:>5} {:<12} {:>9} {:>9} {:>9} {:>9} {:>10} {:>8} {:>8} {:>8} {:>6} {:>6} {:>6} {:>6}",
        "shape",
        "verts",
        "scenario",
        "field",
        "m",
        "cub",
        "solver",
        "step_ms",
        "mean_ms",
        "p99_ms",
        "prep_max",
        "fem_ms",
        "speedup",
        "err_%",
        "static_%",
        "freq",
        "iters",
        "unconv",
        "fallbk"
    );
    for r in &report.rows {
        println!(
            "{:<9} {:>6} {:<8} {:<6} {:>3} {:>5} {:<12} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>10.1} {:>8.0} {:>8.3} {:>8.3} {:>6.3} {:>6.1} {:>6} {:>6}",
            r.shape,
            r.vertices,
            r.scenario,
            r.field,
            r.handles,
            r.cubature,
            r.solver,
            r.step_ms,
            r.step_mean_ms,
            r.step_p99_ms,
            r.prepare_max_ms,
            r.fem_step_ms,
            r.speedup,
            r.error_pct,
            r.static_error_pct,
            r.frequency_ratio,
            r.mean_iterations,
            r.unconverged_steps,
            r.fallback_steps
        );
    }
    if let Some(ms) = report.lift_100k_ms {
        println!("lift 100k points: {ms:.3} ms (median)");
    }
}
