//! What the node (or a replay) emits: every message goes to its DDS publisher when there is one
//! and to the recording when there is one, built once. Status reports also go to the log.

use std::sync::Arc;

use ros2_client::Publisher;

use super::clock::NodeClock;
use super::cloud::encode_cloud;
use super::messages::{
    Header, Interaction, Mesh, MeshStamped, PointCloud2, RosMessage, SkinningWeights, Status,
    SubspaceState,
};
use super::params::{PublishParams, Topics};
use crate::bag::{QosProfile, Recorder, TopicInfo};
use crate::pipeline::SoftBody;
use crate::shm::ShmPublisher;

/// The node's DDS publishers (absent when switched off in `publish.*`).
pub struct Publishers {
    pub deformed_points: Option<Publisher<PointCloud2>>,
    pub weights: Option<Publisher<SkinningWeights>>,
    pub weights_cloud: Option<Publisher<PointCloud2>>,
    pub state: Option<Publisher<SubspaceState>>,
    pub status: Publisher<Status>,
}

/// Every topic the node uses, with its type and QoS: what DDS offers and what a recording says
/// was offered.
pub fn topic_table(topics: &Topics) -> Vec<TopicInfo> {
    let t = topics;
    vec![
        TopicInfo::of::<PointCloud2>(&t.points, QosProfile::sensor(5)),
        TopicInfo::of::<Mesh>(&t.mesh, QosProfile::sensor(5)),
        TopicInfo::of::<MeshStamped>(&t.mesh_stamped, QosProfile::sensor(5)),
        TopicInfo::of::<Interaction>(&t.interaction, QosProfile::reliable(10, false)),
        TopicInfo::of::<PointCloud2>(&t.deformed_points, QosProfile::reliable(2, false)),
        TopicInfo::of::<PointCloud2>(&t.weights_cloud, QosProfile::reliable(4, true)),
        TopicInfo::of::<SkinningWeights>(&t.weights, QosProfile::reliable(4, true)),
        TopicInfo::of::<SubspaceState>(&t.state, QosProfile::reliable(10, false)),
        TopicInfo::of::<Status>(&t.status, QosProfile::reliable(50, true)),
    ]
}

/// Where outputs go, shared by the build and step threads.
pub struct Outputs {
    pub dds: Option<Publishers>,
    pub recorder: Option<Recorder>,
    /// Zero-copy hand-off to local programs.
    pub shm: Option<ShmPublisher>,
    pub topics: Topics,
    pub publish: PublishParams,
    pub clock: NodeClock,
    /// Put wall-clock timings (step_time_ms, build times) into messages. Replays leave them
    /// out so that two replays give identical bytes; they print them instead.
    pub timings: bool,
}

impl Outputs {
    pub fn header(&self, frame: &str) -> Header {
        Header {
            stamp: self.clock.now(),
            frame_id: frame.into(),
        }
    }

    /// Declares every topic to the recording, so a channel exists even for a silent topic.
    pub fn declare_topics(&self) {
        if let Some(recorder) = &self.recorder {
            for topic in topic_table(&self.topics) {
                if let Err(e) = recorder.declare(topic) {
                    eprintln!("[physskin] error: recording: {e}");
                }
            }
        }
    }

    /// Records an input as it arrives (log time now; publish time its stamp when it has one).
    pub fn record_input<M: RosMessage>(&self, topic: &str, stamp: Option<i64>, message: &M) {
        if let Some(recorder) = &self.recorder {
            let now = self.clock.now_nanos().unwrap_or(0);
            let sent = stamp.filter(|s| *s > 0).unwrap_or(now);
            if let Err(e) = recorder.record(topic, now, sent, message) {
                eprintln!("[physskin] error: recording {topic}: {e}");
            }
        }
    }

    /// Records and publishes one message.
    fn emit<M: RosMessage>(&self, topic: &str, publisher: Option<&Publisher<M>>, message: M) {
        if let Some(recorder) = &self.recorder {
            let now = self.clock.now_nanos().unwrap_or(0);
            if let Err(e) = recorder.record(topic, now, now, &message) {
                eprintln!("[physskin] error: recording {topic}: {e}");
            }
        }
        if let Some(p) = publisher {
            if let Err(e) = p.publish(message) {
                // Not through `report`: a failing status publisher would recurse.
                eprintln!("[physskin] warn: {topic} not published: {e:?}");
            }
        }
    }

    /// Publishes a status and writes the same line to the log (stderr).
    pub fn report(&self, level: u8, shape_id: u32, event: &str, message: String) {
        let tag = ["info", "warn", "error"][level.min(2) as usize];
        eprintln!("[physskin] {tag} {event} (shape {shape_id}): {message}");
        let status = Status {
            header: self.header(""),
            shape_id,
            level,
            event: event.into(),
            message,
        };
        self.emit(
            &self.topics.status,
            self.dds.as_ref().map(|d| &d.status),
            status,
        );
    }

    /// The weights of a new shape, as physskin/SkinningWeights and as a PointCloud2 with one
    /// float32 field per handle (w0 is the rigid handle).
    pub fn publish_weights(
        &self,
        shape_id: u32,
        frame: &str,
        rest: &[f32],
        weights: &[f32],
        handles: usize,
    ) {
        let header = self.header(frame);
        if let Some(shm) = &self.shm {
            let stamp = header.stamp.nanos();
            if let Err(e) = shm.publish_weights(shape_id, stamp, handles, weights) {
                eprintln!("[physskin] warn: weights not handed over on iceoryx2: {e}");
            }
        }
        if self.publish.weights_cloud {
            let channels: Vec<String> = (0..handles).map(|i| format!("w{i}")).collect();
            let cloud = encode_cloud(header.clone(), rest, &channels, weights);
            let publisher = self.dds.as_ref().and_then(|d| d.weights_cloud.as_ref());
            self.emit(&self.topics.weights_cloud, publisher, cloud);
        }
        if self.publish.weights {
            let message = SkinningWeights {
                header,
                shape_id,
                point_count: (rest.len() / 3) as u32,
                handle_count: handles as u32,
                weights: weights.to_vec(),
            };
            let publisher = self.dds.as_ref().and_then(|d| d.weights.as_ref());
            self.emit(&self.topics.weights, publisher, message);
        }
    }

    /// The deformed points and the state of a body after a step.
    pub fn publish_step(&self, shape_id: u32, frame: &str, body: &SoftBody) {
        let header = self.header(frame);
        if let Some(shm) = &self.shm {
            let stamp = header.stamp.nanos();
            if let Err(e) = shm.publish_deformed(shape_id, stamp, body.handles(), body.deformed()) {
                eprintln!("[physskin] warn: deformed points not handed over on iceoryx2: {e}");
            }
        }
        if self.publish.deformed_points {
            let cloud = encode_cloud(header.clone(), body.deformed(), &[], &[]);
            let publisher = self.dds.as_ref().and_then(|d| d.deformed_points.as_ref());
            self.emit(&self.topics.deformed_points, publisher, cloud);
        }
        if let (true, Some(report)) = (self.publish.state, body.last_step()) {
            let rows = |m: &nalgebra::DMatrix<f64>| -> Vec<f64> {
                (0..m.nrows())
                    .flat_map(|r| m.row(r).iter().copied().collect::<Vec<_>>())
                    .collect()
            };
            let state = SubspaceState {
                header,
                shape_id,
                handle_count: body.handles() as u32,
                z: rows(body.state()),
                z_velocity: rows(&body.velocity()),
                elastic_energy: report.elastic_energy,
                kinetic_energy: report.kinetic_energy,
                gravity_energy: report.gravity_energy,
                newton_iterations: report.iterations as u32,
                converged: report.converged,
                fallback: report.fallback,
                residual: report.decrement,
                step_time_ms: if self.timings {
                    report.seconds * 1e3
                } else {
                    0.0
                },
                sleeping: body.is_sleeping(),
                cubature_points: body.cubature_len() as u32,
                decision: body.decision().into(),
            };
            let publisher = self.dds.as_ref().and_then(|d| d.state.as_ref());
            self.emit(&self.topics.state, publisher, state);
        }
    }
}

pub type SharedOutputs = Arc<Outputs>;
