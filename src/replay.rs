//! Replay: the inputs of a recording go through the node's own pipeline (the same builder and
//! stage), on the log's time, in log-time order, as fast as possible or at the recorded pace.
//! Everything runs on one thread in a fixed order, so two replays give identical messages.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::bag::{read_recording, BagError, BagMessage, RecordOptions, RecordSummary, Recorder};
use crate::msg::{Status, TFMessage, Time};
use crate::runtime::{
    topic_table, BuildOutcome, BuildRequest, Builder, Input, InputTopics, NameResolver, NodeClock,
    NodeParams, Outputs, Stage, StageOptions, TfBuffer, Topics,
};
use crate::scene::{FieldCache, Scene, SceneFile, SceneOptions};
use crate::skinning::NeuralModel;

/// How to replay.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// The node's parameters: topics, rate, material, inference.
    pub params: NodeParams,
    /// The node whose topics are replayed (its name, namespace and remappings). Default node
    /// `physskin` in `/`.
    pub names: NameResolver,
    /// Where and how to record inputs and outputs; None: nothing is written.
    pub record: Option<RecordOptions>,
    /// Topics recorded in `out`; empty: all.
    pub record_topics: Vec<String>,
    /// None: as fast as possible. Some(r): r times the recorded pace (1 = real time).
    pub pace: Option<f64>,
    /// Keep stepping this long after the last input, s. Default 1.
    pub tail_s: f64,
    /// Wall-clock timings in the messages (then replays are no longer byte-identical).
    pub timings: bool,
    /// Hand the deformed points and weights to local programs over iceoryx2 as well.
    pub shm: Option<crate::shm::ShmOptions>,
}

impl Default for ReplayOptions {
    fn default() -> Self {
        Self {
            params: NodeParams::default(),
            names: NameResolver::default(),
            record: None,
            record_topics: Vec::new(),
            pace: None,
            tail_s: 1.0,
            timings: false,
            shm: None,
        }
    }
}

/// One object of a replay.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ShapeSummary {
    /// The id the node gave the object (`shape_id` in its messages).
    pub shape_id: u32,
    /// The input's frame.
    pub frame: String,
    /// "cloud" or "mesh".
    pub source: String,
    /// Points deformed and published.
    pub points: usize,
    /// Handles, the rigid one included.
    pub handles: usize,
    /// Steps taken (and timed).
    pub steps: usize,
    /// Build time: voxels, inference and subspace, ms.
    pub build_ms: f64,
    /// Median step time, ms.
    pub step_ms_median: f64,
    /// 99th percentile step time, ms.
    pub step_ms_p99: f64,
    /// Largest distance of a point from its rest position over the replay, m.
    pub max_displacement_m: f64,
}

/// One object of the scene a replay ran (`scene` parameter).
#[derive(Clone, Debug, Default, Serialize)]
pub struct SceneObjectSummary {
    /// The object's id (`shape_id` in its messages).
    pub shape_id: u32,
    /// The object's name in the scene file.
    pub name: String,
    /// Handles, the rigid one included.
    pub handles: usize,
    /// Cubature points of its subspace.
    pub cubature: usize,
    /// Largest distance of a point from where it was when the scene was built, m.
    pub max_displacement_m: f64,
    /// What was chosen for it (handles, cubature) and why.
    pub decision: String,
}

/// What a replay did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ReplaySummary {
    /// Recorded messages on the topics the node listens to.
    pub input_messages: usize,
    /// Inputs refused (each reported on the status topic with the reason).
    pub rejected: usize,
    /// Clouds taken as frames of an object already running (`tracking.enabled`).
    pub observations: usize,
    /// The damaged parts of the recording, skipped (each also reported on the status topic).
    pub damage: Vec<String>,
    /// The objects built from the recording's inputs, by id.
    pub shapes: Vec<ShapeSummary>,
    /// The scene's objects, when the parameters name a scene: its robots follow the recorded
    /// JointState messages.
    pub scene_objects: Vec<SceneObjectSummary>,
    /// Simulation ticks run (at the `rate_hz` parameter).
    pub ticks: u64,
    /// Log time covered, s.
    pub sim_seconds: f64,
    /// Wall-clock time of the replay loop, s.
    pub wall_seconds: f64,
    /// Simulated seconds per wall second.
    pub realtime_factor: f64,
    /// What was recorded, when `record` was set.
    pub recording: Option<RecordSummary>,
}

/// One moment of a replay, handed to an observer after every tick.
pub struct Tick<'a> {
    /// Log time, ns.
    pub time_ns: i64,
    /// The stage after the tick: its bodies and their state.
    pub stage: &'a Stage,
}

/// Replays the recording in `bytes` (named `source` in messages).
pub fn replay(
    bytes: &[u8],
    source: &str,
    model: &Arc<NeuralModel>,
    options: &ReplayOptions,
    observe: &mut dyn FnMut(&Tick),
) -> crate::Result<ReplaySummary> {
    let params = &options.params;
    params.validate()?;
    let topics = &params
        .topics
        .resolved(&options.names)
        .map_err(|e| crate::Error::Geometry(e.to_string()))?;
    let scene_file = if params.scene.is_empty() {
        None
    } else {
        Some(SceneFile::load(std::path::Path::new(&params.scene))?)
    };
    let robot = params
        .robot
        .resolved(&options.names)
        .map_err(|e| crate::Error::Geometry(e.to_string()))?;
    let input_topics = InputTopics::new(topics, &robot, scene_file.as_ref());
    let recording = read_recording(bytes, source)?;
    let inputs: Vec<BagMessage> = (recording.messages.into_iter())
        .filter(|m| input_topics.kind(&m.topic).is_some())
        .collect();
    let clock = NodeClock::simulated();
    let (outputs, recorder) = replay_outputs(options, topics, &clock, &input_topics)?;

    // A damaged recording replays what is intact; each damaged part is reported once.
    for damage in &recording.damage {
        outputs.report(Status::ERROR, 0, "recording_damaged", damage.clone());
    }
    let mut summary = ReplaySummary {
        input_messages: inputs.len(),
        damage: recording.damage,
        ..Default::default()
    };
    let (Some(first), Some(last)) = (inputs.first(), inputs.last()) else {
        summary.recording = finish(recorder.as_deref())?;
        return Ok(summary);
    };
    let (start, end) = (
        first.log_time,
        last.log_time + (options.tail_s * 1e9) as i64,
    );
    let period = (1e9 / params.rate_hz) as i64;
    let mut run = Run::start(params, model, &outputs, &clock, scene_file.as_ref(), start)?;
    let decoded: Vec<Result<Input, String>> = inputs
        .iter()
        .map(|m| {
            let at = format!("{source} at {} ns, {}", m.log_time, m.topic);
            let (kind, encoding) = (&m.type_name, &m.encoding);
            input_topics.decode(&m.topic, kind, encoding, &m.data, params, &at)
        })
        .collect();
    // Transforms are taken up to tf.timeout_s ahead of an input, as the node waits as long for
    // the transform of a cloud's stamp.
    let mut transforms = TransformFeed::new(&inputs, &decoded, params.tf.timeout_s);
    let mut next_input = inputs.iter().zip(&decoded).peekable();
    let wall = Instant::now();
    let mut tick_time = start;
    while tick_time <= end {
        while let Some((m, d)) = next_input.next_if(|(m, _)| m.log_time <= tick_time) {
            clock.set(&Time::from_nanos(m.log_time));
            run.take(m.log_time, d, &mut transforms, &mut summary);
            if let Some(recorder) = &recorder {
                recorder.record_raw(&m.topic, m.log_time, m.publish_time, &m.data)?;
            }
        }
        if let Some(pace) = options.pace {
            keep_pace(pace, tick_time - start, wall);
        }
        clock.set(&Time::from_nanos(tick_time));
        run.stage.tick(&outputs);
        summary.ticks += 1;
        run.measure();
        observe(&Tick {
            time_ns: tick_time,
            stage: &run.stage,
        });
        tick_time += period;
    }
    summary.wall_seconds = wall.elapsed().as_secs_f64();
    summary.sim_seconds = (tick_time - period - start) as f64 / 1e9;
    summary.realtime_factor = summary.sim_seconds / summary.wall_seconds.max(1e-9);
    run.summarize(&mut summary);
    summary.recording = finish(recorder.as_deref())?;
    Ok(summary)
}

/// The replay's outputs: the recorder and shared memory the options ask for, on the simulated
/// `clock`, with every output topic and the scene robots' joint-state topics declared. The
/// recorder is also returned on its own: the replay copies the recording's inputs into it.
fn replay_outputs(
    options: &ReplayOptions,
    topics: &Topics,
    clock: &NodeClock,
    input_topics: &InputTopics,
) -> crate::Result<(Outputs, Option<Arc<Recorder>>)> {
    let mut outputs = Outputs::new(
        topics.clone(),
        options.params.publish.clone(),
        clock.clone(),
        options.timings,
    );
    let recorder = match &options.record {
        Some(record) => {
            let recorder = Recorder::start(record.clone(), options.record_topics.clone())?;
            for topic in topic_table(topics) {
                recorder.declare(topic)?;
            }
            for info in input_topics.robot_topic_table() {
                recorder.declare(info)?;
            }
            let recorder = Arc::new(recorder);
            outputs.sinks.push(Box::new(recorder.clone()));
            Some(recorder)
        }
        None => None,
    };
    if let Some(shm) = &options.shm {
        outputs
            .sinks
            .push(Box::new(crate::shm::ShmPublisher::create(shm)?));
    }
    Ok((outputs, recorder))
}

/// Sleeps until the wall clock since `wall` catches up with `elapsed_ns` of log time played
/// `pace` times the recorded speed.
fn keep_pace(pace: f64, elapsed_ns: i64, wall: Instant) {
    let due = Duration::from_secs_f64(elapsed_ns as f64 / 1e9 / pace);
    if let Some(wait) = due.checked_sub(wall.elapsed()) {
        std::thread::sleep(wait);
    }
}

/// The pipeline a replay drives and what it measures of each body along the way.
struct Run<'a> {
    params: &'a NodeParams,
    model: &'a Arc<NeuralModel>,
    outputs: &'a Outputs,
    // The fields below drop in this order, as the locals of the single function this was split
    // from did: the stage before the builder before the tf buffer.
    /// Largest displacement so far of each scene object from where the scene built it, m.
    scene_moved: BTreeMap<u32, f64>,
    /// Each body's step times, ms.
    step_times: BTreeMap<u32, Vec<f64>>,
    shapes: BTreeMap<u32, ShapeSummary>,
    /// Each built body's input points, x, y, z.
    rest: BTreeMap<u32, Vec<f32>>,
    /// Each scene object's points as the scene built them, x, y, z.
    scene_rest: BTreeMap<u32, Vec<f32>>,
    stage: Stage,
    builder: Builder,
    tf: Arc<std::sync::RwLock<TfBuffer>>,
}

impl<'a> Run<'a> {
    /// The stage and builder of a replay starting at log time `start`, with the scene of
    /// `scene_file` set on the stage when there is one (its ids reserved from the builder).
    fn start(
        params: &'a NodeParams,
        model: &'a Arc<NeuralModel>,
        outputs: &'a Outputs,
        clock: &NodeClock,
        scene_file: Option<&SceneFile>,
        start: i64,
    ) -> crate::Result<Self> {
        let tf = Arc::new(std::sync::RwLock::new(TfBuffer::new(params.tf.buffer_s)));
        let mut builder = Builder::default();
        builder.refine_in_build();
        let mut stage = Stage::immediate(StageOptions::from_params(
            params,
            Some(tf.clone()),
            Some(builder.registry()),
        ));
        let mut reserved = 0;
        let mut scene_rest: BTreeMap<u32, Vec<f32>> = BTreeMap::new();
        if let Some(file) = scene_file {
            let options = SceneOptions {
                scripted: false,
                ..SceneOptions::default()
            };
            let scene = Scene::build(file, model, &FieldCache::default(), &options)?;
            clock.set(&Time::from_nanos(start));
            stage.set_scene(scene, 1, params.mesh_frame.clone(), outputs);
            for (id, _, body) in stage.scene_bodies() {
                scene_rest.insert(id, body.deformed().to_vec());
                reserved = reserved.max(id);
            }
        }
        builder.reserve_ids(reserved);
        Ok(Self {
            params,
            model,
            outputs,
            scene_moved: BTreeMap::new(),
            step_times: BTreeMap::new(),
            shapes: BTreeMap::new(),
            rest: BTreeMap::new(),
            scene_rest,
            stage,
            builder,
            tf,
        })
    }

    /// Hands one decoded input, logged at `log_time`, to the pipeline; a refused one counts in
    /// `summary.rejected`.
    fn take(
        &mut self,
        log_time: i64,
        d: &Result<Input, String>,
        transforms: &mut TransformFeed,
        summary: &mut ReplaySummary,
    ) {
        let outputs = self.outputs;
        match d {
            Ok(Input::Geometry(requests)) => {
                transforms.feed(&self.tf, log_time, true, outputs);
                for request in requests {
                    self.build(request, summary);
                }
            }
            Ok(Input::Interaction(i)) => {
                transforms.feed(&self.tf, log_time, false, outputs);
                self.stage.interact(i, outputs)
            }
            Ok(Input::Transforms(..)) => transforms.feed(&self.tf, log_time, false, outputs),
            Ok(Input::Joints(robots, state)) => self.stage.set_joints(robots, state, outputs),
            Ok(Input::Robot(robot, notes)) => {
                transforms.feed(&self.tf, log_time, false, outputs);
                self.stage.set_robot((**robot).clone(), notes, outputs)
            }
            Err(problem) => {
                summary.rejected += 1;
                outputs.report(Status::ERROR, 0, "input_rejected", problem.clone());
            }
        }
    }

    /// Places `request` in the fixed frame and builds its body; a ready body joins the stage
    /// and the summary's shapes, a refused one counts in `summary.rejected`.
    fn build(&mut self, request: &BuildRequest, summary: &mut ReplaySummary) {
        let (params, model, outputs) = (self.params, self.model, self.outputs);
        let mut request = request.clone();
        let placed = self
            .tf
            .read()
            .map_err(|_| "the tf buffer is poisoned".to_string())
            .and_then(|buffer| request.move_to_fixed_frame(params, &buffer));
        let outcome = match placed {
            Ok(()) => {
                self.stage.seen(&request.key(), outputs);
                self.builder.build(&request, params, model, outputs)
            }
            Err(problem) => {
                outputs.report(Status::ERROR, 0, "input_rejected", problem);
                BuildOutcome::Rejected
            }
        };
        let request = &request;
        if let BuildOutcome::Ready(ready, announcement) = outcome {
            let points: Vec<f32> = request
                .points
                .iter()
                .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect();
            self.shapes.insert(
                ready.id,
                ShapeSummary {
                    shape_id: ready.id,
                    frame: ready.frame.clone(),
                    source: request.source.into(),
                    points: ready.body.point_count(),
                    handles: ready.body.handles(),
                    build_ms: ready.body.timings().total_ms,
                    ..Default::default()
                },
            );
            self.rest.insert(ready.id, points);
            announcement.publish(outputs);
            self.stage.add(*ready, outputs, false);
        } else if let BuildOutcome::Observed(frame) = outcome {
            summary.observations += 1;
            self.stage.observe(frame, outputs);
        } else if let BuildOutcome::Rejected = outcome {
            summary.rejected += 1;
        }
    }

    /// After a tick: each body's step time and how far its points and the scene's have moved.
    fn measure(&mut self) {
        for b in self.stage.bodies() {
            if let Some(report) = b.body.last_step() {
                self.step_times
                    .entry(b.id)
                    .or_default()
                    .push(report.seconds * 1e3);
            }
            if let (Some(shape), Some(rest)) = (self.shapes.get_mut(&b.id), self.rest.get(&b.id)) {
                shape.max_displacement_m = shape
                    .max_displacement_m
                    .max(max_distance(b.body.deformed(), rest));
            }
        }
        for (id, _, body) in self.stage.scene_bodies() {
            if let Some(rest) = self.scene_rest.get(&id) {
                let moved = max_distance(body.deformed(), rest);
                let entry = self.scene_moved.entry(id).or_insert(0.0);
                *entry = entry.max(moved);
            }
        }
    }

    /// Puts the shapes, with their step-time statistics, and the scene's objects in `summary`.
    fn summarize(&mut self, summary: &mut ReplaySummary) {
        for (id, mut shape) in std::mem::take(&mut self.shapes) {
            let mut times = self.step_times.remove(&id).unwrap_or_default();
            times.sort_by(f64::total_cmp);
            shape.steps = times.len();
            if !times.is_empty() {
                shape.step_ms_median = times[times.len() / 2];
                shape.step_ms_p99 =
                    times[((times.len() as f64 * 0.99) as usize).min(times.len() - 1)];
            }
            summary.shapes.push(shape);
        }
        for (id, name, body) in self.stage.scene_bodies() {
            summary.scene_objects.push(SceneObjectSummary {
                shape_id: id,
                name: name.into(),
                handles: body.handles(),
                cubature: body.cubature_len(),
                max_displacement_m: self.scene_moved.get(&id).copied().unwrap_or(0.0),
                decision: body.decision().into(),
            });
        }
    }
}

/// The largest distance between corresponding points of two x, y, z arrays.
fn max_distance(a: &[f32], b: &[f32]) -> f64 {
    a.chunks(3)
        .zip(b.chunks(3))
        .map(|(x, r)| {
            let d = [x[0] - r[0], x[1] - r[1], x[2] - r[2]];
            ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) as f64).sqrt()
        })
        .fold(0.0, f64::max)
}

fn finish(recorder: Option<&Recorder>) -> Result<Option<RecordSummary>, BagError> {
    recorder.map(|r| r.finish()).transpose()
}

/// The recording's transforms, fed to the tf buffer in log-time order.
struct TransformFeed {
    /// (log time, message, from /tf_static), in log-time order.
    messages: Vec<(i64, TFMessage, bool)>,
    next: usize,
    lookahead_ns: i64,
}

impl TransformFeed {
    fn new(inputs: &[BagMessage], decoded: &[Result<Input, String>], lookahead_s: f64) -> Self {
        let messages = inputs
            .iter()
            .zip(decoded)
            .filter_map(|(m, d)| match d {
                Ok(Input::Transforms(message, is_static)) => {
                    Some((m.log_time, message.clone(), *is_static))
                }
                _ => None,
            })
            .collect();
        Self {
            messages,
            next: 0,
            lookahead_ns: (lookahead_s * 1e9) as i64,
        }
    }

    /// Every transform logged up to `time` (and the lookahead, for an input waiting for its
    /// transform) goes into the buffer.
    fn feed(
        &mut self,
        tf: &std::sync::RwLock<TfBuffer>,
        time: i64,
        ahead: bool,
        outputs: &Outputs,
    ) {
        let until = time + if ahead { self.lookahead_ns } else { 0 };
        let Ok(mut buffer) = tf.write() else {
            return;
        };
        while let Some((at, message, is_static)) = self.messages.get(self.next) {
            if *at > until {
                break;
            }
            for t in &message.transforms {
                if let Err(e) = buffer.insert(t, *is_static) {
                    outputs.report(Status::WARN, 0, "transform_ignored", e.to_string());
                }
            }
            self.next += 1;
        }
    }
}
