//! `physskin demo`: the main job. The bundled recording through the whole pipeline, a summary,
//! an output MCAP, a picture and a plot of the displacement against the FEM's.

use std::path::PathBuf;

use crate::demo::{run_demo, write_demo_bag, DemoOptions, DemoScript};
use crate::skinning::NeuralModel;

#[derive(clap::Args)]
pub struct DemoArgs {
    /// Input recording (default: bags/demo.mcap, compiled into the binary).
    #[arg(long)]
    input: Option<PathBuf>,
    /// Output recording: the inputs and every output topic.
    #[arg(long, default_value = "target/demo/demo_out.mcap")]
    out: PathBuf,
    /// Strip of frames (PNG). The displacement plot goes beside it, `<name>_displacement.svg`.
    #[arg(long, default_value = "target/demo/demo.png")]
    picture: PathBuf,
    /// Skip the full-space FEM reference (no error figure).
    #[arg(long)]
    no_reference: bool,
    /// Replay at this multiple of real time instead of as fast as possible.
    #[arg(long)]
    pace: Option<f64>,
    #[arg(long)]
    json: bool,
    /// Write the demo's input recording (from its script) to this file and stop.
    #[arg(long, value_name = "FILE")]
    write_input: Option<PathBuf>,
}

pub fn run(args: DemoArgs) -> crate::Result<()> {
    if let Some(path) = &args.write_input {
        let summary = write_demo_bag(&DemoScript::new(), path)?;
        eprintln!("wrote {} messages to {}", summary.messages, path.display());
        return Ok(());
    }
    let model = NeuralModel::bundled()?;
    let options = DemoOptions {
        input: args.input,
        out: args.out,
        picture: args.picture,
        reference: !args.no_reference,
        pace: args.pace,
        ..Default::default()
    };
    eprintln!(
        "replaying {} through the pipeline (inference, subspace, 60 Hz simulation){}...",
        options
            .input
            .as_ref()
            .map_or("the bundled bags/demo.mcap".into(), |p| p
                .display()
                .to_string()),
        if options.reference {
            ", then the FEM reference"
        } else {
            ""
        }
    );
    let summary = run_demo(&options, &model)?;
    if args.json {
        super::print_json(&summary);
        return Ok(());
    }
    let r = &summary.replay;
    println!(
        "{:<10} {:<6} {:>6} {:>7} {:>9} {:>9} {:>9} {:>8} {:>9} {:>9}",
        "frame",
        "input",
        "points",
        "handles",
        "build ms",
        "step ms",
        "step p99",
        "max disp",
        "FEM ms",
        "error %"
    );
    for s in &summary.shapes {
        let p = &s.replay;
        println!(
            "{:<10} {:<6} {:>6} {:>7} {:>9.1} {:>9.3} {:>9.3} {:>7.3}m {:>9.1} {:>9.3}",
            p.frame,
            p.source,
            p.points,
            p.handles,
            p.build_ms,
            p.step_ms_median,
            p.step_ms_p99,
            p.max_displacement_m,
            s.fem_step_ms,
            s.error_pct
        );
    }
    println!(
        "replay      {} inputs ({} rejected), {} ticks, {:.2} s simulated in {:.2} s ({:.1}x real time)",
        r.input_messages, r.rejected, r.ticks, r.sim_seconds, r.wall_seconds, r.realtime_factor
    );
    if let Some(rec) = &r.recording {
        let topics: Vec<String> = rec
            .per_topic
            .iter()
            .map(|(t, n)| format!("{t} {n}"))
            .collect();
        println!(
            "recorded    {} messages to {}: {}",
            rec.messages,
            summary.output.display(),
            topics.join(", ")
        );
    }
    println!("picture     {}", summary.picture.display());
    if let Some(plot) = &summary.displacement_plot {
        println!("plot        {}", plot.display());
    }
    Ok(())
}
