//! The ROS 2 node: parameters, subscriptions and publishers on ros2-client, wired to the build
//! and step threads. Subscriptions only decode and forward; nothing slow runs on the executor.

use std::net::Ipv4Addr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::channel;
use std::sync::{Arc, RwLock};
use std::time::Duration;

use futures::StreamExt;
use ros2_client::ros2::policy::{Durability, History, Reliability, ResourceLimits};
use ros2_client::ros2::{QosPolicies, QosPolicyBuilder};
use ros2_client::rustdds::DomainParticipantBuilder;
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue, Publisher,
    Subscription,
};

use super::builder::{run_builder, BuildRequest};
use super::clock::NodeClock;
use super::messages::{
    Clock, Interaction, JointState, Mesh, MeshStamped, PointCloud2, RosMessage, Status,
};
use super::outputs::{topic_table, Outputs, Publishers};
use super::params::NodeParams;
use super::stepper::{run_stepper, StepperCommand, StepperStats};
use crate::bag::{QosProfile, RecordOptions, Recorder, TopicInfo};
use crate::scene::{FieldCache, Scene, SceneFile, SceneOptions};
use crate::shm::{ShmOptions, ShmPublisher};
use crate::skinning::NeuralModel;

/// Why the node could not start.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    #[error("DDS: {0}")]
    Dds(String),
    #[error("invalid node name: {0}")]
    Name(String),
    #[error(transparent)]
    Params(#[from] super::params::ParamError),
    #[error("signal handler: {0}")]
    Signal(String),
    #[error(transparent)]
    Record(#[from] crate::bag::BagError),
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
}

/// How to start the node.
#[derive(Clone, Debug)]
pub struct NodeConfig {
    pub params: NodeParams,
    /// Default "physskin".
    pub name: String,
    /// Default "/".
    pub namespace: String,
    /// ROS_DOMAIN_ID. Default 0.
    pub domain_id: u16,
    /// Restrict DDS to 127.0.0.1 (tests and benchmarks outside a private network namespace).
    pub loopback_only: bool,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self {
            params: NodeParams::default(),
            name: "physskin".into(),
            namespace: "/".into(),
            domain_id: 0,
            loopback_only: false,
        }
    }
}

impl NodeConfig {
    pub fn fully_qualified_name(&self) -> String {
        format!("{}/{}", self.namespace.trim_end_matches('/'), self.name)
    }
}

/// A DDS context, restricted to loopback when asked.
pub fn context(domain_id: u16, loopback_only: bool) -> Result<Context, NodeError> {
    let dds = |e: ros2_client::ros2::CreateError| NodeError::Dds(format!("{e:?}"));
    let mut builder = DomainParticipantBuilder::new(domain_id);
    if loopback_only {
        builder = builder.with_only_networks([Ipv4Addr::LOCALHOST]);
    }
    Context::from_domain_participant(builder.build().map_err(dds)?).map_err(dds)
}

/// Sensor inputs: keep-last 5, best effort, volatile (ROS's sensor-data profile). A best-effort
/// reader also matches reliable writers.
pub fn sensor_qos() -> QosPolicies {
    QosPolicyBuilder::new()
        .history(History::KeepLast { depth: 5 })
        .reliability(Reliability::BestEffort)
        .durability(Durability::Volatile)
        .build()
}

/// The DDS QoS of a recorded profile.
pub fn qos_of(profile: QosProfile) -> QosPolicies {
    if profile.reliable {
        reliable_qos(profile.depth as i32, profile.transient_local)
    } else {
        QosPolicyBuilder::new()
            .history(History::KeepLast {
                depth: profile.depth as i32,
            })
            .reliability(Reliability::BestEffort)
            .durability(Durability::Volatile)
            .build()
    }
}

/// Reliable keep-last `depth`, transient local when late joiners should still get the last ones.
/// The resource limit holds the writer to `depth` samples: RustDDS 0.14 prunes a reliable
/// writer's history only down to what every matched reader acknowledged, so with no reader it
/// kept up to 8192 samples (the soak measured +50 MB/min from the weights topics alone).
pub fn reliable_qos(depth: i32, transient_local: bool) -> QosPolicies {
    QosPolicyBuilder::new()
        .history(History::KeepLast { depth })
        .resource_limits(ResourceLimits {
            max_samples: depth,
            max_instances: 1,
            max_samples_per_instance: depth,
        })
        .reliability(Reliability::Reliable {
            max_blocking_time: ros2_client::ros2::Duration::from_millis(100),
        })
        .durability(if transient_local {
            Durability::TransientLocal
        } else {
            Durability::Volatile
        })
        .build()
}

fn topic_of<M: RosMessage>(
    node: &Node,
    name: &str,
    qos: &QosPolicies,
) -> Result<ros2_client::rustdds::Topic, NodeError> {
    let parsed =
        Name::parse(name).map_err(|e| NodeError::Name(format!("topic `{name}`: {e:?}")))?;
    node.create_topic(&parsed, MessageTypeName::new(M::PACKAGE, M::NAME), qos)
        .map_err(|e| NodeError::Dds(format!("topic `{name}`: {e:?}")))
}

pub fn publisher<M: RosMessage>(
    node: &mut Node,
    name: &str,
    qos: QosPolicies,
) -> Result<Publisher<M>, NodeError> {
    let topic = topic_of::<M>(node, name, &qos)?;
    node.create_publisher(&topic, Some(qos))
        .map_err(|e| NodeError::Dds(format!("publisher `{name}`: {e:?}")))
}

pub fn subscription<M: RosMessage>(
    node: &mut Node,
    name: &str,
    qos: QosPolicies,
) -> Result<Subscription<M>, NodeError> {
    let topic = topic_of::<M>(node, name, &qos)?;
    node.create_subscription(&topic, Some(qos))
        .map_err(|e| NodeError::Dds(format!("subscription `{name}`: {e:?}")))
}

/// Runs the node until `stop` is set; returns the stepper's counters.
pub fn run_node(
    config: NodeConfig,
    model: Arc<NeuralModel>,
    stop: Arc<AtomicBool>,
) -> Result<StepperStats, NodeError> {
    config
        .params
        .validate()
        .map_err(|e| super::params::ParamError::Invalid {
            name: "parameters".into(),
            reason: e.to_string(),
        })?;
    let params = Arc::new(RwLock::new(config.params.clone()));
    let p = config.params.clone();
    let context = context(config.domain_id, config.loopback_only)?;

    let mut options = NodeOptions::new().enable_rosout(true);
    for (name, value) in p.to_ros() {
        if name != "use_sim_time" {
            options = options.declare_parameter(&name, value);
        }
    }
    let check = params.clone();
    let apply = params.clone();
    options = options
        .parameter_validator(Box::new(move |name: &str, value: &ParameterValue| {
            let current = check.read().map_err(|_| "parameters poisoned".to_string())?.clone();
            current.with_ros(name, value).map(|_| ()).map_err(|e| e.to_string())
        }))
        .parameter_set_action(Box::new(move |name: &str, value: &ParameterValue| {
            let mut current = apply.write().map_err(|_| "parameters poisoned".to_string())?;
            let updated = current.with_ros(name, value).map_err(|e| e.to_string())?;
            if updated == *current {
                return Ok(());
            }
            *current = updated;
            eprintln!("[physskin] info: parameter {name} set to {value:?}; it applies to shapes that arrive from now on");
            Ok(())
        }));
    let node_name = NodeName::new(&config.namespace, &config.name)
        .map_err(|e| NodeError::Name(format!("{e:?}")))?;
    let mut node = context
        .new_node(node_name, options)
        .map_err(|e| NodeError::Dds(format!("{e:?}")))?;
    if p.use_sim_time {
        let _ = node.set_parameter("use_sim_time", ParameterValue::Boolean(true));
    }

    let clock = if p.use_sim_time {
        NodeClock::simulated()
    } else {
        NodeClock::Wall
    };
    let t = &p.topics;
    let table = topic_table(t);
    let qos = |topic: &str| {
        qos_of(
            table
                .iter()
                .find(|info| info.name == topic)
                .map_or(QosProfile::sensor(5), |info| info.qos),
        )
    };
    let recorder = if p.record.path.is_empty() {
        None
    } else {
        let options = RecordOptions {
            path: p.record.path.clone().into(),
            split_size_mb: p.record.split_size_mb,
            split_duration_s: p.record.split_duration_s,
            ..Default::default()
        };
        Some(Recorder::start(options, p.record.topics.clone()).map_err(NodeError::Record)?)
    };
    let pubs = &p.publish;
    let dds = Publishers {
        deformed_points: pubs
            .deformed_points
            .then(|| publisher(&mut node, &t.deformed_points, qos(&t.deformed_points)))
            .transpose()?,
        weights: pubs
            .weights
            .then(|| publisher(&mut node, &t.weights, qos(&t.weights)))
            .transpose()?,
        weights_cloud: pubs
            .weights_cloud
            .then(|| publisher(&mut node, &t.weights_cloud, qos(&t.weights_cloud)))
            .transpose()?,
        state: pubs
            .state
            .then(|| publisher(&mut node, &t.state, qos(&t.state)))
            .transpose()?,
        status: publisher(&mut node, &t.status, qos(&t.status))?,
    };
    let shm = if p.shm.enabled {
        let options = ShmOptions {
            deformed_service: p.shm.deformed_service.clone(),
            weights_service: p.shm.weights_service.clone(),
            ..Default::default()
        };
        match ShmPublisher::create(&options) {
            Ok(shm) => Some(shm),
            Err(e) => {
                // Local zero-copy consumers are optional: DDS and the recording go on.
                eprintln!("[physskin] error: no iceoryx2 hand-off: {e}");
                None
            }
        }
    } else {
        None
    };
    let outputs = Arc::new(Outputs {
        dds: Some(dds),
        recorder,
        shm,
        topics: t.clone(),
        publish: p.publish.clone(),
        clock: clock.clone(),
        timings: true,
    });
    outputs.declare_topics();
    let points_sub = subscription::<PointCloud2>(&mut node, &t.points, qos(&t.points))?;
    let mesh_sub = subscription::<Mesh>(&mut node, &t.mesh, qos(&t.mesh))?;
    let stamped_sub =
        subscription::<MeshStamped>(&mut node, &t.mesh_stamped, qos(&t.mesh_stamped))?;
    let interaction_sub =
        subscription::<Interaction>(&mut node, &t.interaction, qos(&t.interaction))?;
    let clock_sub = subscription::<Clock>(&mut node, "/clock", sensor_qos())?;
    // A scene file is read (and its mistakes refused) before anything starts; its objects are
    // built on a thread of their own, and join the stepper when ready.
    let scene_file = if p.scene.is_empty() {
        None
    } else {
        Some(SceneFile::load(std::path::Path::new(&p.scene))?)
    };
    let mut joint_subs = Vec::new();
    let mut scene_objects = 0u32;
    if let Some(file) = &scene_file {
        scene_objects = file
            .objects
            .iter()
            .filter(|o| o.kind == crate::scene::ObjectKind::Deformable && o.topic.is_none())
            .count() as u32;
        // One subscription per topic, for every robot on it (a JointState may carry the joints
        // of several robots).
        let mut topics: std::collections::BTreeMap<&str, Vec<String>> = Default::default();
        for r in &file.robots {
            topics
                .entry(r.joint_states.as_str())
                .or_default()
                .push(r.name.clone());
        }
        for (topic, robots) in topics {
            if let Some(recorder) = &outputs.recorder {
                let info = TopicInfo::of::<JointState>(topic, QosProfile::sensor(5));
                if let Err(e) = recorder.declare(info) {
                    eprintln!("[physskin] error: recording: {e}");
                }
            }
            let sub = subscription::<JointState>(&mut node, topic, sensor_qos())?;
            joint_subs.push((robots, topic.to_string(), sub));
        }
    }

    let (build_tx, build_rx) = channel::<BuildRequest>();
    let (ready_tx, ready_rx) = channel();
    let (step_tx, step_rx) = channel::<StepperCommand>();
    let builder = {
        let (params, outputs) = (params.clone(), outputs.clone());
        std::thread::Builder::new()
            .name("physskin-build".into())
            .spawn({
                let model = model.clone();
                move || run_builder(build_rx, ready_tx, params, model, outputs, scene_objects)
            })
            .map_err(|e| NodeError::Dds(format!("cannot start the build thread: {e}")))?
    };
    let scene_builder = scene_file.map(|file| {
        let (outputs, step_tx, frame) = (outputs.clone(), step_tx.clone(), p.mesh_frame.clone());
        std::thread::spawn(move || build_scene(&file, &model, &outputs, &step_tx, frame))
    });
    // Ready bodies reach the stepper through its own channel, so it waits on one queue only.
    let forward = {
        let step_tx = step_tx.clone();
        std::thread::spawn(move || {
            for ready in ready_rx {
                if step_tx.send(StepperCommand::Add(Box::new(ready))).is_err() {
                    break;
                }
            }
        })
    };
    let stepper = {
        let outputs = outputs.clone();
        let rate = p.rate_hz;
        std::thread::Builder::new()
            .name("physskin-step".into())
            .spawn(move || run_stepper(step_rx, rate, outputs))
            .map_err(|e| NodeError::Dds(format!("cannot start the step thread: {e}")))?
    };
    outputs.report(
        Status::INFO,
        0,
        "node_started",
        format!(
            "{} listening on {} and {}, stepping at {} Hz{}",
            config.fully_qualified_name(),
            t.points,
            t.mesh,
            p.rate_hz,
            if p.use_sim_time {
                " of /clock time"
            } else {
                ""
            }
        ),
    );

    let executor = smol::Executor::new();
    let spinner = node
        .spinner()
        .map_err(|e| NodeError::Dds(format!("{e:?}")))?;
    executor.spawn(spinner.spin()).detach();
    let max_points = p.max_points;
    let mesh_frame = p.mesh_frame.clone();
    let work = async {
        let submit = |request: Result<BuildRequest, String>| match request {
            Ok(request) => {
                let _ = build_tx.send(request);
            }
            Err(problem) => outputs.report(Status::ERROR, 0, "input_rejected", problem),
        };
        let clouds = points_sub.async_stream().for_each(|m| {
            if let Ok((cloud, _)) = m {
                outputs.record_input(&t.points, Some(cloud.header.stamp.nanos()), &cloud);
                submit(BuildRequest::from_cloud(&cloud, max_points));
            }
            async {}
        });
        let meshes = mesh_sub.async_stream().for_each(|m| {
            if let Ok((mesh, _)) = m {
                outputs.record_input(&t.mesh, None, &mesh);
                submit(BuildRequest::from_mesh(&mesh, &mesh_frame, max_points));
            }
            async {}
        });
        let stamped = stamped_sub.async_stream().for_each(|m| {
            if let Ok((m, _)) = m {
                outputs.record_input(&t.mesh_stamped, Some(m.header.stamp.nanos()), &m);
                submit(BuildRequest::from_mesh(
                    &m.mesh,
                    &m.header.frame_id,
                    max_points,
                ));
            }
            async {}
        });
        let interactions = interaction_sub.async_stream().for_each(|m| {
            if let Ok((i, _)) = m {
                outputs.record_input(&t.interaction, Some(i.header.stamp.nanos()), &i);
                let _ = step_tx.send(StepperCommand::Interact(i));
            }
            async {}
        });
        let ticks = clock_sub.async_stream().for_each(|m| {
            if let Ok((c, _)) = m {
                clock.set(&c.clock);
            }
            async {}
        });
        let (outputs, step_tx) = (&outputs, &step_tx);
        let joints = futures::future::join_all(joint_subs.iter().map(|(robots, topic, sub)| {
            sub.async_stream().for_each(move |m| {
                if let Ok((state, _)) = m {
                    outputs.record_input(topic, Some(state.header.stamp.nanos()), &state);
                    let robots = robots.clone();
                    let _ = step_tx.send(StepperCommand::Joints { robots, state });
                }
                async {}
            })
        }));
        futures::join!(clouds, meshes, stamped, interactions, ticks, joints);
    };
    let stopped = async {
        while !stop.load(Ordering::Relaxed) {
            smol::Timer::after(Duration::from_millis(50)).await;
        }
    };
    smol::block_on(executor.run(smol::future::race(work, stopped)));

    drop(build_tx);
    drop(step_tx);
    let _ = builder.join();
    let _ = forward.join();
    if let Some(scene_builder) = scene_builder {
        let _ = scene_builder.join();
    }
    let stats = stepper.join().unwrap_or_default();
    outputs.report(
        Status::INFO,
        0,
        "node_stopped",
        format!("{} ticks, {} missed", stats.ticks, stats.missed),
    );
    if let Some(recorder) = &outputs.recorder {
        match recorder.finish() {
            Ok(summary) => eprintln!(
                "[physskin] info: recorded {} messages in {}",
                summary.messages,
                summary
                    .files
                    .iter()
                    .map(|f| f.path.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            Err(e) => eprintln!("[physskin] error: recording: {e}"),
        }
    }
    node.stop_spinner();
    drop(executor);
    Ok(stats)
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
    super::builder::yield_to_stepping();
    let options = SceneOptions {
        scripted: false,
        ..SceneOptions::default()
    };
    let built = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .start_handler(|_| super::builder::yield_to_stepping())
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
