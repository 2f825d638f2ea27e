//! `physskin scene FILE`: a scene file run offline, its robots following their scripted
//! motion, with what was decided for each object and the error against the FEM; and
//! `physskin bench scene`.

use std::path::PathBuf;

use crate::bench::{run_scene, run_scene_bench, SceneRun, SceneRunOptions, WORKCELL};
use crate::scene::{FieldCache, SceneFile, SceneOptions};
use crate::skinning::NeuralModel;

#[derive(clap::Args)]
pub struct SceneArgs {
    /// Scene file (YAML). Default the bundled robot cell.
    #[arg(default_value = WORKCELL)]
    file: PathBuf,
    /// Simulated seconds of motion after the objects have settled.
    #[arg(long, default_value_t = 3.5)]
    seconds: f64,
    /// Simulate every object at full size every step (no error budget, no sleeping).
    #[arg(long)]
    no_decisions: bool,
    /// Compare every deformable object with the full-space FEM (slower).
    #[arg(long)]
    reference: bool,
    /// Settle exactly this many steps before the motion (default: until every object sleeps,
    /// at most 8 s; exactly 8 s with --no-decisions).
    #[arg(long)]
    settle_steps: Option<usize>,
    #[arg(long)]
    json: bool,
}

pub fn run(args: SceneArgs) -> crate::Result<()> {
    let file = SceneFile::load(&args.file)?;
    let compare = if args.reference {
        file.objects
            .iter()
            .filter(|o| o.kind == crate::scene::ObjectKind::Deformable)
            .map(|o| o.name.clone())
            .collect()
    } else {
        Vec::new()
    };
    let run = run_scene(
        &file,
        &NeuralModel::bundled()?,
        &FieldCache::default(),
        &SceneRunOptions {
            scene: SceneOptions {
                decisions: !args.no_decisions,
                only: Vec::new(),
                scripted: true,
                ..SceneOptions::default()
            },
            seconds: args.seconds,
            settle_steps: args.settle_steps.unwrap_or((8.0 * file.rate_hz) as usize),
            settle_exactly: args.no_decisions || args.settle_steps.is_some(),
            compare,
        },
    )?;
    if args.json {
        super::print_json(&run);
    } else {
        print_run(&run);
    }
    Ok(())
}

fn print_run(run: &SceneRun) {
    println!(
        "{:<10} {:<11} {:>7} {:>9} {:>8} {:>9}  decision",
        "object", "kind", "handles", "cubature", "asleep", "error %"
    );
    for o in &run.objects {
        let error = run
            .errors
            .iter()
            .find(|e| e.name == o.name)
            .map_or("-".to_string(), |e| format!("{:.3}", e.error_pct));
        println!(
            "{:<10} {:<11} {:>7} {:>9} {:>8} {:>9}  {}",
            o.name,
            format!("{:?}", o.kind).to_lowercase(),
            o.handles,
            o.cubature,
            if o.sleeping { "yes" } else { "no" },
            error,
            o.decision
        );
    }
    println!(
        "built in {:.0} ms ({} inferences, {} reused); settled in {} steps; {} steps: {:.3} ms a step \
         (p99 {:.3}), {:.2} of {} deformable objects awake on average",
        run.build_ms,
        run.inferences,
        run.inferences_reused,
        run.settle_steps,
        run.steps,
        run.step_ms,
        run.step_ms_p99,
        run.awake_mean,
        run.deformable
    );
}

pub fn bench(seconds: f64, json: bool) -> crate::Result<()> {
    let r = run_scene_bench(seconds, |line| eprintln!("{line}"))?;
    if json {
        super::print_json(&r);
        return Ok(());
    }
    println!(
        "bundled robot cell, {} s of motion; error: RMS distance to the full-space FEM, % of size",
        seconds
    );
    println!(
        "{:<34} {:>8} {:>10} {:>10} {:>9} {:>9}",
        "run", "objects", "step ms", "p99 ms", "awake", "error %"
    );
    for (name, run, error) in [
        (
            "the 2 active objects alone",
            &r.active_alone,
            r.active_alone_error_pct,
        ),
        (
            "full scene, with decisions",
            &r.full_scene,
            r.full_scene_error_pct,
        ),
        (
            "full scene, without decisions",
            &r.no_decisions,
            r.no_decisions_error_pct,
        ),
    ] {
        println!(
            "{:<34} {:>8} {:>10.3} {:>10.3} {:>9.2} {:>9.3}",
            name, run.deformable, run.step_ms, run.step_ms_p99, run.awake_mean, error
        );
    }
    println!(
        "full scene / active alone: {:.3}x step time; idle objects' error {:.3} % asleep, {:.3} % simulated",
        r.step_ratio, r.idle_error_pct, r.idle_error_pct_no_decisions
    );
    Ok(())
}
