//! `physskin bench track`: one camera's stream of a soft object, rebuilt, uncorrected and
//! tracked, against the FEM (see `bench::track`).

use std::path::PathBuf;

use clap::Args;

use crate::runtime::params::TrackingParams;

use crate::bench::{
    run_track_bench, track_plot, TrackBenchOptions, TrackSpread, DEFAULT_TRACK_SEED,
    DEFAULT_TRACK_VIEW,
};

/// Arguments of `bench track`.
#[derive(Args)]
pub struct TrackArgs {
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Length of each sequence, s.
    #[arg(long, default_value_t = 2.5)]
    seconds: f64,
    /// How hard a frame pulls (`tracking.stiffness`).
    #[arg(long)]
    stiffness: Option<f64>,
    /// How long a frame pulls, s (`tracking.hold_s`).
    #[arg(long)]
    hold_s: Option<f64>,
    /// Only the sequences whose name contains one of these (comma-separated).
    #[arg(long, value_delimiter = ',')]
    sequence: Vec<String>,
    /// Only these modes: rebuild, uncorrected, tracked (comma-separated).
    #[arg(long, value_delimiter = ',')]
    modes: Vec<String>,
    /// Write the first sequence's frames to this MCAP file (a camera's stream to replay).
    #[arg(long)]
    write_stream: Option<PathBuf>,
    /// Share of a frame's miss kept as a force nothing modelled (`tracking.force_gain`).
    #[arg(long)]
    force_gain: Option<f64>,
    /// How long that force lasts, s (`tracking.force_memory_s`).
    #[arg(long)]
    force_memory_s: Option<f64>,
    /// A Python that imports mujoco: MuJoCo's soft block runs four sequences more
    /// (`benches/peers/mujoco_track.py`).
    #[arg(long)]
    python: Option<PathBuf>,
    /// Direction from the object toward the camera, x,y,z (any length).
    #[arg(long, value_delimiter = ',', default_values_t = DEFAULT_TRACK_VIEW)]
    view: Vec<f64>,
    /// Seeds of the camera's noise, comma-separated: each sequence runs once per seed, and
    /// with several the report gives each row's spread over them.
    #[arg(long, value_delimiter = ',', default_values_t = [DEFAULT_TRACK_SEED])]
    seeds: Vec<u64>,
    /// Where the plot of the first sequence's error over time goes.
    #[arg(long, default_value = "target/bench/track.svg")]
    plot: PathBuf,
}

/// `--view`'s three numbers as a direction (its length is checked by the bench).
fn view_of(numbers: &[f64]) -> crate::Result<nalgebra::Vector3<f64>> {
    match numbers {
        [x, y, z] => Ok(nalgebra::Vector3::new(*x, *y, *z)),
        _ => Err(crate::Error::InvalidParameter {
            name: "view",
            reason: format!("three numbers x,y,z are needed, not {numbers:?}"),
        }),
    }
}

/// Runs the bench and prints its table (or JSON). Its tracking options are checked as the
/// node's `tracking.*` parameters are: a force gain of 2, which the node refuses, made the
/// kept force diverge (MuJoCo's squeezed block 171.9 % off, printed).
pub fn run(args: TrackArgs) -> crate::Result<()> {
    let mut params = TrackingParams::default();
    params.stiffness = args.stiffness.unwrap_or(params.stiffness);
    params.hold_s = args.hold_s.unwrap_or(params.hold_s);
    params.force_gain = args.force_gain.unwrap_or(params.force_gain);
    params.force_memory_s = args.force_memory_s.unwrap_or(params.force_memory_s);
    params.validate()?;
    let options = TrackBenchOptions {
        seconds: args.seconds,
        tracking: params.options(),
        sequences: args.sequence,
        modes: args.modes,
        write_stream: args.write_stream,
        python: args.python,
        view: view_of(&args.view)?,
        seeds: args.seeds,
    };
    let report = run_track_bench(&options, |line| eprintln!("{line}"))?;
    super::write_plot(&args.plot, &track_plot(&report))?;
    if args.json {
        super::print_json(&report);
        return Ok(());
    }
    println!("| sequence | mode | seed | builds | frames | seen error % | hidden error % | blocked error % | subspace's best % | Chamfer % | correction ms median | p99 | step ms median | p99 | CPU share |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for r in &report.rows {
        println!(
            "| {} | {} | {} | {} | {} | {:.4} | {:.4} | {} | {} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} |",
            r.sequence,
            r.mode,
            r.seed,
            r.builds,
            r.frames,
            r.seen_error_pct,
            r.hidden_error_pct,
            r.blocked_error_pct.map_or("-".into(), |e| format!("{e:.4}")),
            r.subspace_fit_pct.map_or("-".into(), |e| format!("{e:.4}")),
            r.chamfer_pct,
            r.correction_ms_median,
            r.correction_ms_p99,
            r.step_ms_median,
            r.step_ms_p99,
            r.cpu_share
        );
    }
    println!(
        "observation floor (noisy points against their true places): {:.4} % of the diagonal; plot: {}",
        report.observation_floor_pct,
        args.plot.display()
    );
    print_spread(&report.spread);
    let [x, y, z] = report.camera_direction;
    println!("camera toward ({x:.3}, {y:.3}, {z:.3}) from the object");
    if let Some(version) = &report.mujoco_version {
        println!("MuJoCo {version} made the mujoco sequences");
    }
    Ok(())
}

/// The spread table, when several seeds ran.
fn print_spread(spread: &[TrackSpread]) {
    if spread.is_empty() {
        return;
    }
    println!("\n| sequence | mode | seeds | seen error % mean | least | largest | while blocked, largest % | Chamfer largest % |");
    println!("|---|---|---:|---:|---:|---:|---:|---:|");
    for s in spread {
        println!(
            "| {} | {} | {} | {:.4} | {:.4} | {:.4} | {} | {:.4} |",
            s.sequence,
            s.mode,
            s.seeds,
            s.seen_error_pct_mean,
            s.seen_error_pct_min,
            s.seen_error_pct_max,
            s.blocked_error_pct_max
                .map_or("-".into(), |e| format!("{e:.4}")),
            s.chamfer_pct_max
        );
    }
}
