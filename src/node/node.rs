//! The ROS 2 node: parameters, subscriptions and publishers on ros2-client, wired to the build
//! and step threads. Subscriptions only decode and forward; nothing slow runs on the executor.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, RwLock};

use ros2_client::{Context, Node, NodeName, NodeOptions, ParameterValue};

use super::args::LogLevel;
use super::dds::{context, publisher, reliable_qos, NodeError, QosTable};
use super::foxglove::{ClientInput, LiveView};
use super::logger::{attach_rosout, detach_rosout, install_logger};
use super::publishers::Publishers;
use super::ros_params::RosParams;
use super::shared::Shared;
use crate::bag::{RecordOptions, Recorder};
use crate::msg::Status;
use crate::runtime::builder::Built;
use crate::runtime::clock::NodeClock;
use crate::runtime::diagnostics::Health;
use crate::runtime::names::NameResolver;
use crate::runtime::outputs::{topic_table, Outputs};
use crate::runtime::params::{NodeParams, Topics};
use crate::runtime::qos_overrides::QosOverrides;
use crate::runtime::stepper::{StepperCommand, StepperStats};
use crate::runtime::tf::TfBuffer;
use crate::runtime::InputTopics;
use crate::scene::{FieldCache, Scene, SceneFile, SceneOptions};
use crate::shm::{ShmOptions, ShmPublisher};
use crate::skinning::NeuralModel;

/// How to start the node.
#[derive(Clone, Debug)]
pub struct NodeConfig {
    /// The node's parameters.
    pub params: NodeParams,
    /// The node's name and namespace after `__node:=`/`__ns:=`, and the remapping rules.
    /// Default node `physskin` in `/`.
    pub names: NameResolver,
    /// `qos_overrides.*` parameters.
    pub qos: QosOverrides,
    /// ROS_DOMAIN_ID. Default 0.
    pub domain_id: u16,
    /// Restrict DDS to 127.0.0.1 (tests and benchmarks outside a private network namespace).
    pub loopback_only: bool,
    /// Log lines below this level are dropped. Default info.
    pub log_level: LogLevel,
    /// Log lines also go to /rosout. Default true.
    pub rosout: bool,
    /// Said once the node has started (on stderr and /rosout): ignored parameters and
    /// arguments.
    pub warnings: Vec<String>,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self {
            params: NodeParams::default(),
            names: NameResolver::default(),
            qos: QosOverrides::default(),
            domain_id: 0,
            loopback_only: false,
            log_level: LogLevel::Info,
            rosout: true,
            warnings: Vec::new(),
        }
    }
}

impl NodeConfig {
    /// The node's `/namespace/name`.
    pub fn fully_qualified_name(&self) -> String {
        self.names.fully_qualified_name()
    }
}

/// Runs the node until `stop` is set. Its last status, `node_stopped`, counts the ticks it
/// stepped and missed.
pub fn run(
    config: NodeConfig,
    model: Arc<NeuralModel>,
    stop: Arc<AtomicBool>,
) -> Result<(), NodeError> {
    run_counted(config, model, stop).map(|_| ())
}

/// [`run`], returning the stepper's counters (for `bench soak`).
pub(crate) fn run_counted(
    config: NodeConfig,
    model: Arc<NeuralModel>,
    stop: Arc<AtomicBool>,
) -> Result<StepperStats, NodeError> {
    config
        .params
        .validate()
        .map_err(|e| crate::runtime::params::ParamError::Invalid {
            name: "parameters".into(),
            reason: e.to_string(),
        })?;
    let p = config.params.clone();
    let topics = p.topics.resolved(&config.names)?;
    let context = context(config.domain_id, config.loopback_only)?;
    let params = Arc::new(RwLock::new(p.clone()));
    let mut node = create_node(&context, &config, &params)?;
    let scene_file = if p.scene.is_empty() {
        None
    } else {
        Some(SceneFile::load(std::path::Path::new(&p.scene))?)
    };
    let robot = p.robot.resolved(&config.names)?;
    let input_topics = InputTopics::new(&topics, &robot, scene_file.as_ref());
    let mut profiles = topic_table(&topics);
    profiles.extend(input_topics.robot_topic_table());
    let qos = QosTable {
        profiles,
        overrides: config.qos.clone(),
    };
    let clock = if p.use_sim_time {
        NodeClock::simulated()
    } else {
        NodeClock::Wall
    };
    install_logger(config.log_level.filter());
    if config.rosout {
        attach_rosout(node.logging_handle(), config.fully_qualified_name());
    }
    let publishers = Publishers::create(&mut node, &topics, &qos, &p)?;
    let dropped = publishers.dropped.clone();
    let recorder = start_recorder(&p, &topics)?.map(Arc::new);
    let mut outputs = Outputs::new(topics.clone(), p.publish.clone(), clock.clone(), true);
    outputs.status_level = config.log_level.filter();
    if let Some(recorder) = &recorder {
        outputs.sinks.push(Box::new(recorder.clone()));
    }
    if let Some(shm) = start_shm(&p) {
        outputs.sinks.push(Box::new(shm));
    }
    outputs.sinks.push(Box::new(publishers));
    // Validated with the other parameters at start.
    let live = (p.foxglove.socket_address().ok().flatten())
        .map(|address| Arc::new(LiveView::new(&topics, address)));
    if let Some(live) = &live {
        outputs.sinks.push(Box::new(live.clone()));
    }
    let outputs = Arc::new(outputs);
    for warning in &config.warnings {
        outputs.report(Status::WARN, 0, "node_warning", warning.clone());
    }
    let inputs = super::node_inputs::Inputs::create(
        &mut node,
        &topics,
        &qos,
        &input_topics,
        recorder.as_deref(),
    )?;
    let shared = Shared {
        params,
        outputs: outputs.clone(),
        tf: Arc::new(RwLock::new(TfBuffer::new(p.tf.buffer_s))),
        health: Arc::new(Health::default()),
        recorder,
        dropped,
        live,
    };
    let threads = Threads::start(&shared, &model, scene_file, &p)?;
    start_live_view(&shared, &config, &topics, &threads.step_tx)?;
    let control = super::node_inputs::Control::create(&mut node, &config.names)?;
    let diagnostics = publisher(&mut node, "/diagnostics", reliable_qos(10, false))?;
    outputs.report(
        Status::INFO,
        0,
        "node_started",
        started_line(&config, &topics),
    );

    let executor = smol::Executor::new();
    let spinner = node
        .spinner()
        .map_err(|e| NodeError::Dds(format!("{e:?}")))?;
    executor.spawn(spinner.spin()).detach();
    let node_name = config.fully_qualified_name();
    let served = super::node_inputs::serve(
        inputs,
        control,
        diagnostics,
        &shared,
        &threads.build_tx,
        &threads.step_tx,
        &node_name,
    );
    let stopped = async {
        while !stop.load(std::sync::atomic::Ordering::Relaxed) {
            smol::Timer::after(std::time::Duration::from_millis(50)).await;
        }
    };
    smol::block_on(executor.run(smol::future::race(served, stopped)));
    // First: its clients' listener holds a sender of the stepper's commands.
    if let Some(live) = &shared.live {
        live.stop();
    }
    let stats = threads.join();
    finish(&shared, &stats);
    detach_rosout();
    node.stop_spinner();
    drop(executor);
    Ok(stats)
}

/// The ROS node with its parameters declared: `ros2 param set` is checked like the file.
fn create_node(
    context: &Context,
    config: &NodeConfig,
    params: &Arc<RwLock<NodeParams>>,
) -> Result<Node, NodeError> {
    let p = &config.params;
    let mut options = NodeOptions::new().enable_rosout(config.rosout);
    for (name, value) in p.to_ros() {
        if name != "use_sim_time" {
            options = options.declare_parameter(&name, value);
        }
    }
    let (check, apply) = (params.clone(), params.clone());
    options = options
        .parameter_validator(Box::new(move |name: &str, value: &ParameterValue| {
            let current = check
                .read()
                .map_err(|_| "parameters poisoned".to_string())?
                .clone();
            current
                .with_ros(name, value)
                .map(|_| ())
                .map_err(|e| e.to_string())
        }))
        .parameter_set_action(Box::new(move |name: &str, value: &ParameterValue| {
            let mut current = apply
                .write()
                .map_err(|_| "parameters poisoned".to_string())?;
            let updated = current.with_ros(name, value).map_err(|e| e.to_string())?;
            if updated == *current {
                return Ok(());
            }
            *current = updated;
            log::info!(
                "parameter {name} set to {value:?}; it applies to shapes that arrive from now on"
            );
            Ok(())
        }));
    let names = &config.names;
    let node_name = NodeName::new(&names.namespace, &names.node)
        .map_err(|e| NodeError::Name(format!("{e:?}")))?;
    let node = context
        .new_node(node_name, options)
        .map_err(|e| NodeError::Dds(format!("{e:?}")))?;
    if p.use_sim_time {
        let _ = node.set_parameter("use_sim_time", ParameterValue::Boolean(true));
    }
    Ok(node)
}

/// The recording `record.*` asks for, with every output topic declared (a silent topic
/// still gets its channel).
fn start_recorder(p: &NodeParams, topics: &Topics) -> Result<Option<Recorder>, NodeError> {
    if p.record.path.is_empty() {
        return Ok(None);
    }
    let options = RecordOptions {
        path: p.record.path.clone().into(),
        split_size_mb: p.record.split_size_mb,
        split_duration_s: p.record.split_duration_s,
        ..Default::default()
    };
    let recorder = Recorder::start(options, p.record.topics.clone()).map_err(NodeError::Record)?;
    for topic in topic_table(topics) {
        recorder.declare(topic).map_err(NodeError::Record)?;
    }
    Ok(Some(recorder))
}

fn start_shm(p: &NodeParams) -> Option<ShmPublisher> {
    if !p.shm.enabled {
        return None;
    }
    let options = ShmOptions {
        deformed_service: p.shm.deformed_service.clone(),
        weights_service: p.shm.weights_service.clone(),
        ..Default::default()
    };
    ShmPublisher::create(&options)
        .map_err(|e| {
            // Local zero-copy consumers are optional: DDS and the recording go on.
            log::error!("no iceoryx2 hand-off: {e}");
        })
        .ok()
}

/// Starts the Foxglove server when `foxglove.address` names one, and says where it listens
/// (a warning when that is reachable from other machines).
fn start_live_view(
    shared: &Shared,
    config: &NodeConfig,
    topics: &Topics,
    step_tx: &std::sync::mpsc::Sender<StepperCommand>,
) -> Result<(), NodeError> {
    let Some(live) = &shared.live else {
        return Ok(());
    };
    let input = ClientInput {
        interaction_topic: topics.interaction.clone(),
        step_tx: std::sync::Mutex::new(step_tx.clone()),
        outputs: shared.outputs.clone(),
    };
    let name = config.fully_qualified_name();
    let port = live.start(&name, input, shared.params.clone())?;
    let ip = live.address().ip();
    let line = format!("Foxglove live view on ws://{ip}:{port}");
    if ip.is_loopback() {
        shared
            .outputs
            .report(Status::INFO, 0, "foxglove_started", line);
    } else {
        let line = format!("{line}, reachable from other machines (foxglove.address)");
        shared
            .outputs
            .report(Status::WARN, 0, "foxglove_started", line);
    }
    Ok(())
}

fn started_line(config: &NodeConfig, t: &Topics) -> String {
    let p = &config.params;
    let frame = if p.fixed_frame.is_empty() {
        String::new()
    } else {
        format!(", simulating in frame `{}`", p.fixed_frame)
    };
    format!(
        "{} listening on {}, {} and {}, stepping at {} Hz{}{frame}",
        config.fully_qualified_name(),
        t.points,
        t.mesh,
        t.mesh_stamped,
        p.rate_hz,
        if p.use_sim_time {
            " of /clock time"
        } else {
            ""
        }
    )
}

fn finish(shared: &Shared, stats: &StepperStats) {
    shared.outputs.report(
        Status::INFO,
        0,
        "node_stopped",
        format!("{} ticks, {} missed", stats.ticks, stats.missed),
    );
    if let Some(recorder) = &shared.recorder {
        match recorder.finish() {
            Ok(summary) => log::info!(
                "recorded {} messages in {}",
                summary.messages,
                summary
                    .files
                    .iter()
                    .map(|f| f.path.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Err(e) => log::error!("recording: {e}"),
        }
    }
}

/// The build thread, the stepper and what feeds them.
struct Threads {
    build_tx: std::sync::mpsc::Sender<crate::runtime::builder::BuildRequest>,
    step_tx: std::sync::mpsc::Sender<StepperCommand>,
    builder: std::thread::JoinHandle<()>,
    forward: std::thread::JoinHandle<()>,
    scene_builder: Option<std::thread::JoinHandle<()>>,
    stepper: std::thread::JoinHandle<StepperStats>,
}

impl Threads {
    fn start(
        shared: &Shared,
        model: &Arc<NeuralModel>,
        scene_file: Option<SceneFile>,
        p: &NodeParams,
    ) -> Result<Self, NodeError> {
        use std::sync::mpsc::channel;
        let spawn_error = |e: std::io::Error| NodeError::Dds(format!("cannot start a thread: {e}"));
        let scene_objects = scene_file.as_ref().map_or(0, |file| {
            file.objects
                .iter()
                .filter(|o| o.kind == crate::scene::ObjectKind::Deformable && o.topic.is_none())
                .count() as u32
        });
        let (build_tx, build_rx) = channel();
        let (ready_tx, ready_rx) = channel();
        let (step_tx, step_rx) = channel::<StepperCommand>();
        let registry = crate::runtime::builder::BuiltRegistry::default();
        let cx = crate::runtime::builder::BuildContext {
            params: shared.params.clone(),
            model: model.clone(),
            outputs: shared.outputs.clone(),
            tf: shared.tf.clone(),
            health: shared.health.clone(),
            registry: registry.clone(),
            reserved_ids: scene_objects,
        };
        let builder = std::thread::Builder::new()
            .name("physskin-build".into())
            .spawn(move || crate::runtime::builder::run_builder(build_rx, ready_tx, cx))
            .map_err(spawn_error)?;
        let scene_builder = scene_file.map(|file| {
            let (outputs, step_tx) = (shared.outputs.clone(), step_tx.clone());
            let (model, frame) = (model.clone(), scene_frame(p));
            std::thread::spawn(move || build_scene(&file, &model, &outputs, &step_tx, frame))
        });
        // Ready bodies reach the stepper through its own channel, so it waits on one queue only.
        let forward = {
            let step_tx = step_tx.clone();
            std::thread::spawn(move || {
                for built in ready_rx {
                    let command = match built {
                        Built::Body(ready) => StepperCommand::Add(Box::new(ready)),
                        Built::Refined(refined) => StepperCommand::Switch(Box::new(refined)),
                        Built::Observed(frame) => StepperCommand::Observe(Box::new(frame)),
                    };
                    if step_tx.send(command).is_err() {
                        break;
                    }
                }
            })
        };
        let stage = crate::runtime::stage::Stage::on_the_beat(
            crate::runtime::stage::StageOptions::from_params(
                p,
                Some(shared.tf.clone()),
                Some(registry),
            ),
        );
        let stepper = {
            let (outputs, health, rate) =
                (shared.outputs.clone(), shared.health.clone(), p.rate_hz);
            std::thread::Builder::new()
                .name("physskin-step".into())
                .spawn(move || {
                    crate::runtime::stepper::run_stepper(step_rx, rate, stage, outputs, health)
                })
                .map_err(spawn_error)?
        };
        Ok(Self {
            build_tx,
            step_tx,
            builder,
            forward,
            scene_builder,
            stepper,
        })
    }

    fn join(self) -> StepperStats {
        drop(self.build_tx);
        drop(self.step_tx);
        let _ = self.builder.join();
        let _ = self.forward.join();
        if let Some(scene_builder) = self.scene_builder {
            let _ = scene_builder.join();
        }
        self.stepper.join().unwrap_or_default()
    }
}

/// The frame a scene's objects are simulated and published in.
fn scene_frame(p: &NodeParams) -> String {
    if p.fixed_frame.is_empty() {
        p.mesh_frame.clone()
    } else {
        p.fixed_frame.clone()
    }
}

/// Builds a scene's objects off the stepping thread, at low priority, and hands the scene to
/// the stepper; a failure is reported and the node goes on without it.
fn build_scene(
    file: &SceneFile,
    model: &Arc<NeuralModel>,
    outputs: &Outputs,
    step_tx: &std::sync::mpsc::Sender<StepperCommand>,
    frame: String,
) {
    crate::runtime::builder::yield_to_stepping();
    let options = SceneOptions {
        scripted: false,
        ..SceneOptions::default()
    };
    let built = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .start_handler(|_| crate::runtime::builder::yield_to_stepping())
        .build()
        .map_err(|e| e.to_string())
        .and_then(|pool| {
            pool.install(|| Scene::build(file, model, &FieldCache::default(), &options))
                .map_err(|e| e.to_string())
        });
    match built {
        Ok(scene) => {
            let _ = step_tx.send(StepperCommand::Scene {
                scene: Box::new(scene),
                first_id: 1,
                frame,
            });
        }
        Err(e) => outputs.report(Status::ERROR, 0, "scene_rejected", e),
    }
}
