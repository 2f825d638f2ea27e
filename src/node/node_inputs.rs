//! What the node's executor serves: its subscriptions (decoded and forwarded, nothing slow),
//! tf2, the `~/reset` and `~/clear` services, and /diagnostics once a second.

use std::sync::atomic::Ordering;
use std::sync::mpsc::Sender;
use std::time::Duration;

use futures::StreamExt;
use ros2_client::{Node, Publisher, Server, Subscription};

use super::dds::{sensor_qos, subscription, NodeError, QosTable};
use super::services::{serve as serve_trigger, trigger_server, Control as Kind, Trigger};
use super::shared::Shared;
use crate::bag::Recorder;
use crate::msg::{
    Clock, DiagnosticArray, Interaction, JointState, KeyValue, Mesh, MeshStamped, PointCloud2,
    Status, StringMessage, TFMessage,
};
use crate::runtime::builder::BuildRequest;
use crate::runtime::inputs::JointReaders;
use crate::runtime::names::NameResolver;
use crate::runtime::outputs::{TF, TF_STATIC};
use crate::runtime::params::Topics;
use crate::runtime::qos_overrides::Endpoint;
use crate::runtime::stepper::StepperCommand;
use crate::runtime::{Input, InputKind, InputTopics};

/// The node's subscriptions.
pub struct Inputs {
    topics: Topics,
    points: Subscription<PointCloud2>,
    mesh: Subscription<Mesh>,
    mesh_stamped: Subscription<MeshStamped>,
    interaction: Subscription<Interaction>,
    clock: Subscription<Clock>,
    tf: Subscription<TFMessage>,
    tf_static: Subscription<TFMessage>,
    /// Per joint-state topic: the robots on it, the topic, its subscription.
    joints: Vec<(JointReaders, String, Subscription<JointState>)>,
    /// The robot's URDF (`robot.description_topic`), and the topic.
    description: Option<(String, Subscription<StringMessage>)>,
}

impl Inputs {
    /// Subscribes to the input topics (with their QoS and overrides), /clock, /tf,
    /// /tf_static, `robot_description` and the robots' joint-state topics, declaring the last
    /// two to the recorder. An error when a name is refused or DDS cannot create a
    /// subscription.
    pub fn create(
        node: &mut Node,
        t: &Topics,
        qos: &QosTable,
        input_topics: &InputTopics,
        recorder: Option<&Recorder>,
    ) -> Result<Self, NodeError> {
        let q = |topic: &str| qos.of(topic, Endpoint::Subscription);
        let mut inputs = Self {
            topics: t.clone(),
            points: subscription(node, &t.points, q(&t.points))?,
            mesh: subscription(node, &t.mesh, q(&t.mesh))?,
            mesh_stamped: subscription(node, &t.mesh_stamped, q(&t.mesh_stamped))?,
            interaction: subscription(node, &t.interaction, q(&t.interaction))?,
            clock: subscription(node, "/clock", sensor_qos())?,
            tf: subscription(node, TF, q(TF))?,
            tf_static: subscription(node, TF_STATIC, q(TF_STATIC))?,
            joints: Vec::new(),
            description: None,
        };
        for info in input_topics.robot_topic_table() {
            if let Some(recorder) = recorder {
                if let Err(e) = recorder.declare(info) {
                    log::error!("recording: {e}");
                }
            }
        }
        // One subscription per joint-state topic (for every robot on it), one for the URDF.
        for (topic, kind) in input_topics.all() {
            match kind {
                InputKind::Joints(robots) => {
                    let sub = subscription::<JointState>(node, topic, q(topic))?;
                    inputs.joints.push((robots.clone(), topic.to_string(), sub));
                }
                InputKind::RobotDescription => {
                    let sub = subscription::<StringMessage>(node, topic, q(topic))?;
                    inputs.description = Some((topic.to_string(), sub));
                }
                _ => {}
            }
        }
        Ok(inputs)
    }
}

/// The `~/reset` and `~/clear` services.
pub struct Control {
    reset: Server<Trigger>,
    clear: Server<Trigger>,
}

impl Control {
    /// Creates both servers under the node's resolved names. An error when a name is
    /// refused or DDS cannot create a server.
    pub fn create(node: &mut Node, names: &NameResolver) -> Result<Self, NodeError> {
        Ok(Self {
            reset: trigger_server(node, &names.resolve("~/reset")?)?,
            clear: trigger_server(node, &names.resolve("~/clear")?)?,
        })
    }
}

/// Serves everything until the executor stops.
pub async fn serve(
    inputs: Inputs,
    control: Control,
    diagnostics: Publisher<DiagnosticArray>,
    shared: &Shared,
    build_tx: &Sender<BuildRequest>,
    step_tx: &Sender<StepperCommand>,
    node_name: &str,
) {
    let outputs = &shared.outputs;
    // Read once at start: the size limit, mesh frame and instance field the inputs are decoded
    // with take a `ros2 param set` from the next start on.
    let p = shared.params.read().map(|p| p.clone()).unwrap_or_default();
    let submit = |input: Result<Input, String>| match input {
        Ok(Input::Geometry(requests)) => {
            for request in requests {
                let _ = step_tx.send(StepperCommand::Seen(request.key()));
                shared.health.builds_queued.fetch_add(1, Ordering::Relaxed);
                let _ = build_tx.send(request);
            }
        }
        Ok(Input::Robot(robot, notes)) => {
            let _ = step_tx.send(StepperCommand::Robot(robot, notes));
        }
        Ok(_) => {}
        Err(problem) => outputs.report(Status::ERROR, 0, "input_rejected", problem),
    };
    let t = &inputs.topics;
    let clouds = inputs.points.async_stream().for_each(|m| {
        if let Ok((cloud, _)) = m {
            shared.record_input(&t.points, Some(cloud.header.stamp.nanos()), &cloud);
            submit(Input::cloud(&cloud, &p));
        }
        async {}
    });
    let meshes = inputs.mesh.async_stream().for_each(|m| {
        if let Ok((mesh, _)) = m {
            shared.record_input(&t.mesh, None, &mesh);
            submit(Input::mesh(&mesh, &p));
        }
        async {}
    });
    let stamped = inputs.mesh_stamped.async_stream().for_each(|m| {
        if let Ok((m, _)) = m {
            let stamp = m.header.stamp.nanos();
            shared.record_input(&t.mesh_stamped, Some(stamp), &m);
            submit(Input::mesh_stamped(&m, &p));
        }
        async {}
    });
    let interactions = inputs.interaction.async_stream().for_each(|m| {
        if let Ok((i, _)) = m {
            shared.record_input(&t.interaction, Some(i.header.stamp.nanos()), &i);
            let _ = step_tx.send(StepperCommand::Interact(i));
        }
        async {}
    });
    let ticks = inputs.clock.async_stream().for_each(|m| {
        if let Ok((c, _)) = m {
            outputs.clock.set(&c.clock);
        }
        async {}
    });
    let tf = transforms(&inputs.tf, TF, false, shared);
    let tf_static = transforms(&inputs.tf_static, TF_STATIC, true, shared);
    let joints = futures::future::join_all(inputs.joints.iter().map(|(robots, topic, sub)| {
        sub.async_stream().for_each(move |m| {
            if let Ok((state, _)) = m {
                shared.record_input(topic, Some(state.header.stamp.nanos()), &state);
                let robots = robots.clone();
                let _ = step_tx.send(StepperCommand::Joints { robots, state });
            }
            async {}
        })
    }));
    let description = inputs.description.iter().map(|(topic, sub)| {
        sub.async_stream().for_each(move |m| {
            if let Ok((urdf, _)) = m {
                shared.record_input(topic, None, &urdf);
                // Parsed here (meshes read, hulls made), not on the stepping thread.
                submit(Input::robot(&urdf));
            }
            async {}
        })
    });
    let description = futures::future::join_all(description);
    let reset = serve_trigger(control.reset, Kind::Reset, step_tx.clone());
    let clear = serve_trigger(control.clear, Kind::Clear, step_tx.clone());
    let health = report_health(diagnostics, shared, node_name);
    futures::join!(
        clouds,
        meshes,
        stamped,
        interactions,
        ticks,
        tf,
        tf_static,
        joints,
        description,
        reset,
        clear,
        health
    );
}

/// /tf or /tf_static into the buffer (and the recording); a bad transform is reported once
/// per child frame.
async fn transforms(sub: &Subscription<TFMessage>, topic: &str, is_static: bool, shared: &Shared) {
    let mut reported = std::collections::HashSet::new();
    let mut stream = std::pin::pin!(sub.async_stream());
    while let Some(m) = stream.next().await {
        let Ok((message, _)) = m else { continue };
        shared.record_input(topic, None, &message);
        let Ok(mut buffer) = shared.tf.write() else {
            continue;
        };
        for t in &message.transforms {
            if let Err(e) = buffer.insert(t, is_static) {
                if reported.insert(t.child_frame_id.clone()) {
                    let problem = format!("{topic}: {e}");
                    shared
                        .outputs
                        .report(Status::WARN, 0, "transform_ignored", problem);
                }
            }
        }
    }
}

/// /diagnostics once a second; an instance that takes a shard of the objects names it.
async fn report_health(publisher: Publisher<DiagnosticArray>, shared: &Shared, node_name: &str) {
    let shard = shared
        .params
        .read()
        .ok()
        .and_then(|p| p.shard().ok())
        .unwrap_or_default();
    loop {
        smol::Timer::after(Duration::from_secs(1)).await;
        let outputs = &shared.outputs;
        let recording = shared.recorder.as_ref().map(|r| r.health());
        let dropped = shared.dropped.load(Ordering::Relaxed);
        let mut report = shared
            .health
            .report(outputs.header(""), node_name, recording, dropped);
        for status in report.status.iter_mut().filter(|_| shard.is_split()) {
            status.name = format!("{} (shard {shard})", status.name);
            status.values.push(KeyValue {
                key: "shard".into(),
                value: shard.to_string(),
            });
        }
        shared.relay("/diagnostics", &report);
        if let Err(e) = publisher.publish(report) {
            log::warn!("/diagnostics not published: {e}");
        }
    }
}
