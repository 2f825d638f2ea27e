//! The recording and replay bench: how much faster than real time the demo bag replays (with
//! its output recorded), and what recording adds to a 60 Hz step of a 10k-point cloud.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use serde::Serialize;

use super::latency::sample_cloud;
use crate::bag::{RecordOptions, Recorder};
use crate::msg::Time;
use crate::replay::{replay, ReplayOptions};
use crate::runtime::{BuildOutcome, BuildRequest, Builder, NodeClock, NodeParams, Outputs, Stage};
use crate::skinning::NeuralModel;
use crate::Result;

/// What `bench replay` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct ReplayBenchReport {
    /// Simulated seconds of the demo bag per wall second, output recorded (median of 3).
    pub realtime_factor: f64,
    /// Wall time of the median replay, s.
    pub replay_wall_s: f64,
    /// Log time the median replay covered, s.
    pub replay_sim_s: f64,
    /// Points of the cloud of the recording-overhead run.
    pub points: usize,
    /// Mean time of a 60 Hz tick (step, lift, messages), without and with recording, ms.
    pub tick_ms_without: f64,
    /// The same with recording on, ms.
    pub tick_ms_with: f64,
    /// What recording adds to the tick, % (negative: within noise).
    pub record_overhead_pct: f64,
    /// Ticks timed without recording, and as many with (every other tick recorded).
    pub ticks_per_side: usize,
}

/// Replays `demo_bag` (an MCAP recording's bytes) three times, its output recorded
/// into `scratch`, then times a 10k-point body's 60 Hz tick without and with
/// recording; `progress` gets a line per replay and one for the ticks. Errs when `scratch`
/// cannot be created or a replay, the body's build or the recording fails.
pub fn run_replay_bench(
    demo_bag: &[u8],
    scratch: &std::path::Path,
    mut progress: impl FnMut(&str),
) -> Result<ReplayBenchReport> {
    let model = NeuralModel::bundled()?;
    std::fs::create_dir_all(scratch).map_err(|e| crate::Error::Io {
        path: scratch.into(),
        source: e,
    })?;
    let mut runs = Vec::new();
    for run in 0..3 {
        let options = ReplayOptions {
            record: Some(RecordOptions {
                path: scratch.join("replay.mcap"),
                ..Default::default()
            }),
            ..Default::default()
        };
        let summary = replay(demo_bag, "demo", &model, &options, &mut |_| {})?;
        progress(&format!(
            "replay {}: {:.2} s simulated in {:.3} s ({:.1}x)",
            run + 1,
            summary.sim_seconds,
            summary.wall_seconds,
            summary.realtime_factor
        ));
        runs.push(summary);
    }
    runs.sort_by(|a, b| a.realtime_factor.total_cmp(&b.realtime_factor));
    let middle = &runs[1];

    let (points, without, with) =
        record_overhead(&model, scratch.join("overhead.mcap"), &mut progress)?;
    Ok(ReplayBenchReport {
        realtime_factor: middle.realtime_factor,
        replay_wall_s: middle.wall_seconds,
        replay_sim_s: middle.sim_seconds,
        points,
        tick_ms_without: without,
        tick_ms_with: with,
        record_overhead_pct: (with / without - 1.0) * 100.0,
        ticks_per_side: TICKS_PER_SIDE,
    })
}

const TICKS_PER_SIDE: usize = 480;

/// One 10k-point body stepped at 60 Hz (paced by the wall clock, so the recorder's thread has
/// the time between ticks it has in a node), every other tick recorded. Alternating ticks see
/// the same motion: in blocks of 240 ticks a side, the body's motion differed from block to
/// block, and runs gave 1 to 19 % for the same code.
fn record_overhead(
    model: &Arc<NeuralModel>,
    path: PathBuf,
    progress: &mut impl FnMut(&str),
) -> Result<(usize, f64, f64)> {
    let params = NodeParams::default();
    let cloud = sample_cloud("creature", 10_000, "bench", 5);
    let request = BuildRequest::from_cloud(&cloud, params.max_points, &params.instance_field)
        .map_err(crate::Error::Geometry)?
        .remove(0);
    let clock = NodeClock::simulated();
    let topics = crate::runtime::Topics::default_resolved();
    let outputs = || Outputs::new(topics.clone(), params.publish.clone(), clock.clone(), true);
    let quiet = outputs();
    let BuildOutcome::Ready(body, _) = Builder::default().build(&request, &params, model, &quiet)
    else {
        return Err(crate::Error::Geometry(
            "the bench cloud did not build".into(),
        ));
    };
    let points = body.body.point_count();
    let mut stage = Stage::default();
    stage.add(*body, &quiet, false);
    let recorder = Arc::new(Recorder::start(
        RecordOptions {
            path,
            ..Default::default()
        },
        Vec::new(),
    )?);
    for topic in crate::runtime::topic_table(&topics) {
        recorder.declare(topic)?;
    }
    let mut recording = outputs();
    recording.sinks.push(Box::new(recorder.clone()));
    let period = Duration::from_secs_f64(1.0 / params.rate_hz);
    let mut times = [Vec::new(), Vec::new()];
    let start = Instant::now();
    for i in 0..2 * TICKS_PER_SIDE {
        let side = i % 2;
        let out = if side == 0 { &quiet } else { &recording };
        clock.set(&Time::from_nanos((i as i64 + 1) * period.as_nanos() as i64));
        if i % 60 == (i / 60) % 2 {
            // A push a second keeps the body moving, as a handled object would; on recorded
            // and unrecorded ticks in turn.
            poke(&mut stage, out, i);
        }
        let t = Instant::now();
        stage.tick(out);
        times[side].push(t.elapsed().as_secs_f64() * 1e3);
        if let Some(wait) = (period * (i as u32 + 1)).checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    progress(&format!(
        "mean tick {:.3} ms not recording, {:.3} ms recording",
        mean(&times[0]),
        mean(&times[1])
    ));
    recorder.finish()?;
    Ok((points, mean(&times[0]), mean(&times[1])))
}

fn poke(stage: &mut Stage, outputs: &Outputs, i: usize) {
    use crate::msg::{Header, Interaction, Point, Vector3 as RosVector3};
    let side = if (i / 60).is_multiple_of(2) {
        1.0
    } else {
        -1.0
    };
    let force = Vector3::new(0.0, 200.0 * side, 0.0);
    stage.interact(
        &Interaction {
            header: Header::default(),
            shape_id: 0,
            kind: Interaction::FORCE,
            point: Point {
                x: 0.3,
                y: 0.0,
                z: 0.2,
            },
            force: RosVector3 {
                x: force.x,
                y: force.y,
                z: force.z,
            },
            duration: 0.2,
            radius: 0.0,
        },
        outputs,
    );
}
