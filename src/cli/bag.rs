//! `physskin replay` and `physskin recover`.

use std::path::PathBuf;

use crate::bag::{recover, RecordOptions};
use crate::node::{send_recording, RosArgs, SendOptions};
use crate::replay::{replay, ReplayOptions};
use crate::shm::ShmOptions;
use crate::skinning::NeuralModel;
use crate::Error;

#[derive(clap::Args)]
pub struct ReplayArgs {
    /// The recording whose inputs (clouds, meshes, interactions) are replayed.
    input: PathBuf,
    /// Where to record the inputs and every output.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Start a new output file past this size, MB (0: never).
    #[arg(long, default_value_t = 0.0)]
    split_size_mb: f64,
    /// Start a new output file past this much log time, s (0: never).
    #[arg(long, default_value_t = 0.0)]
    split_duration: f64,
    /// Node parameters (ROS 2 YAML), as for `physskin node`.
    #[arg(long)]
    params: Option<PathBuf>,
    /// Replay at this multiple of the recorded pace (1 = real time); default as fast as possible.
    #[arg(long)]
    pace: Option<f64>,
    /// Keep stepping this long after the last input, s.
    #[arg(long, default_value_t = 1.0)]
    tail: f64,
    /// Topics to record (repeat); default all.
    #[arg(long = "topic")]
    topics: Vec<String>,
    /// Put wall-clock timings into the messages (replays are then no longer byte-identical).
    #[arg(long)]
    timings: bool,
    /// Also hand the deformed points and weights to local programs over iceoryx2, on the
    /// services `<PREFIX>deformed_points` and `<PREFIX>weights`.
    #[arg(long, value_name = "PREFIX", num_args = 0..=1, default_missing_value = "physskin/")]
    shm: Option<String>,
    /// Run this scene file too (overrides the `scene` parameter): its robots follow the
    /// recording's JointState messages.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Instead of replaying here, publish the recording's inputs to a running node (the one
    /// `--ros-args` names, default /physskin) on their topics, at the recorded pace (or
    /// `--pace`), on ROS_DOMAIN_ID (or `--domain-id`).
    #[arg(long, conflicts_with_all = ["out", "shm", "scene", "timings"])]
    publish: bool,
    /// ROS_DOMAIN_ID for `--publish` (default: the environment's, else 0).
    #[arg(long, requires = "publish")]
    domain_id: Option<u16>,
    #[arg(long)]
    json: bool,
}

/// Publishes the inputs of `args.input` to the running node `names` resolves the topics of.
fn publish(args: &ReplayArgs, bytes: &[u8], topics: crate::runtime::Topics) -> crate::Result<()> {
    let options = SendOptions {
        topics,
        domain_id: args
            .domain_id
            .or_else(|| std::env::var("ROS_DOMAIN_ID").ok()?.parse().ok())
            .unwrap_or(0),
        pace: args.pace.unwrap_or(1.0),
        wait_s: 5.0,
    };
    let summary = send_recording(bytes, &args.input.display().to_string(), &options)?;
    if args.json {
        super::print_json(&summary);
        return Ok(());
    }
    for topic in &summary.unmatched {
        eprintln!("physskin: no subscriber on {topic} within 5 s; sent anyway");
    }
    for (topic, n) in &summary.sent {
        println!("{n} messages on {topic}");
    }
    println!("sent in {:.2} s", summary.wall_seconds);
    Ok(())
}

/// Replays `args.input`; `ros` names the replayed node and sets its parameters as for
/// `physskin node --ros-args ...`.
pub fn run_replay(args: ReplayArgs, ros: RosArgs) -> crate::Result<()> {
    let (names, loader) = super::node::ros_setup(&ros, "physskin", "/", args.params.as_deref())?;
    for warning in &loader.warnings {
        eprintln!("[physskin] warn: {warning}");
    }
    let mut params = loader.params;
    if let Some(scene) = &args.scene {
        params.scene = scene.display().to_string();
    }
    if args
        .pace
        .is_some_and(|p| p.is_nan() || p <= 0.0 || p.is_infinite())
        || args.tail.is_nan()
        || args.tail < 0.0
    {
        return Err(Error::InvalidParameter {
            name: "pace",
            reason: "--pace must be positive and --tail at least 0".into(),
        });
    }
    let bytes = std::fs::read(&args.input).map_err(|e| Error::Io {
        path: args.input.clone(),
        source: e,
    })?;
    if args.publish {
        let topics = params
            .topics
            .resolved(&names)
            .map_err(|e| Error::Geometry(e.to_string()))?;
        return publish(&args, &bytes, topics);
    }
    let model = NeuralModel::bundled()?;
    let options = ReplayOptions {
        params,
        names,
        record: args.out.map(|path| RecordOptions {
            path,
            split_size_mb: args.split_size_mb,
            split_duration_s: args.split_duration,
            ..Default::default()
        }),
        record_topics: args.topics,
        pace: args.pace,
        tail_s: args.tail,
        timings: args.timings,
        shm: args.shm.map(|prefix| ShmOptions {
            deformed_service: format!("{prefix}deformed_points"),
            weights_service: format!("{prefix}weights"),
            ..Default::default()
        }),
    };
    let summary = replay(
        &bytes,
        &args.input.display().to_string(),
        &model,
        &options,
        &mut |_| {},
    )?;
    if args.json {
        super::print_json(&summary);
    } else {
        println!(
            "{} inputs ({} rejected), {} shapes, {} ticks: {:.2} s simulated in {:.2} s ({:.1}x real time)",
            summary.input_messages,
            summary.rejected,
            summary.shapes.len(),
            summary.ticks,
            summary.sim_seconds,
            summary.wall_seconds,
            summary.realtime_factor
        );
        for damage in &summary.damage {
            println!("skipped, damaged: {damage}");
        }
        for o in &summary.scene_objects {
            println!(
                "scene object {} (shape {}): moved up to {:.4} m; {}",
                o.name, o.shape_id, o.max_displacement_m, o.decision
            );
        }
        if let Some(rec) = &summary.recording {
            let files: Vec<String> = rec
                .files
                .iter()
                .map(|f| f.path.display().to_string())
                .collect();
            println!("recorded {} messages in {}", rec.messages, files.join(", "));
        }
    }
    Ok(())
}

#[derive(clap::Args)]
pub struct RecoverArgs {
    /// A recording cut short (a killed recorder): no summary, maybe a torn last chunk.
    input: PathBuf,
    /// The rewritten, complete file.
    #[arg(long)]
    out: PathBuf,
}

pub fn run_recover(args: RecoverArgs) -> crate::Result<()> {
    let recovered = recover(&args.input, &args.out)?;
    let s = &recovered.summary;
    println!(
        "recovered {} messages on {} topics into {}{}",
        s.messages,
        s.per_topic.len(),
        args.out.display(),
        recovered
            .stopped_by
            .map_or(String::new(), |why| format!(" (reading stopped: {why})"))
    );
    Ok(())
}
