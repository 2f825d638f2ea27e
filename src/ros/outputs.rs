//! What the node (or a replay) emits: every message goes to its DDS publisher when there is one
//! and to the recording when there is one, built once. Status reports also go to the log.

use std::sync::Arc;

use ros2_client::{NodeLoggingHandle, Publisher, RosoutRaw};

use super::args::LogLevel;
use super::clock::NodeClock;
use super::cloud_objects::CloudTemplate;
use super::markers::{delete_marker, MarkerSurface};
use super::params::{PublishParams, Topics};
use crate::bag::Recorder;
use crate::msg::cloud::encode_cloud;
use crate::msg::{
    Header, Interaction, MarkerArray, Mesh, MeshStamped, PointCloud2, RosMessage, SkinningWeights,
    Status, SubspaceState, TFMessage,
};
use crate::msg::{QosProfile, TopicInfo};
use crate::pipeline::SoftBody;
use crate::shm::ShmPublisher;

/// The node's DDS publishers (absent when switched off in `publish.*`).
pub struct Publishers {
    /// The deformed points (`publish.deformed_points`).
    pub deformed_points: Option<Publisher<PointCloud2>>,
    /// The weights as physskin/SkinningWeights (`publish.weights`).
    pub weights: Option<Publisher<SkinningWeights>>,
    /// The weights as a PointCloud2 (`publish.weights_cloud`).
    pub weights_cloud: Option<Publisher<PointCloud2>>,
    /// The reduced state after each step (`publish.state`).
    pub state: Option<Publisher<SubspaceState>>,
    /// What the node did with its inputs; always on.
    pub status: Publisher<Status>,
    /// The deformed surfaces for RViz (when `markers.rate_hz` > 0).
    pub markers: Option<Publisher<MarkerArray>>,
}

/// Where the node's log lines go besides stderr: /rosout, as rcl_interfaces/msg/Log.
pub struct NodeLog {
    /// None with `--disable-rosout-logs`.
    pub rosout: Option<NodeLoggingHandle>,
    /// The logger's name: the node's fully qualified name.
    pub name: String,
    /// Lines below this level are dropped (`--log-level`).
    pub level: LogLevel,
}

impl NodeLog {
    /// Writes `line` to stderr and /rosout when its level passes.
    pub fn write(&self, level: LogLevel, line: &str) {
        if level < self.level {
            return;
        }
        eprintln!("{line}");
        if let Some(rosout) = &self.rosout {
            let now = ros2_client::ros2::Timestamp::now();
            use ros2_client::ros2::LogLevel as Rcl;
            let rcl = match level {
                LogLevel::Debug => Rcl::Debug,
                LogLevel::Info => Rcl::Info,
                LogLevel::Warn => Rcl::Warn,
                LogLevel::Error => Rcl::Error,
                LogLevel::Fatal => Rcl::Fatal,
            };
            rosout.rosout_raw(now, rcl, &self.name, line, file!(), "report", line!());
        }
    }
}

/// Every topic the node uses, with its type and QoS: what DDS offers and what a recording says
/// was offered.
pub fn topic_table(topics: &Topics) -> Vec<TopicInfo> {
    let t = topics;
    vec![
        TopicInfo::of::<PointCloud2>(&t.points, QosProfile::sensor(5)),
        // Meshes are one-shot data: a mesh published before the node started still arrives.
        TopicInfo::of::<Mesh>(&t.mesh, QosProfile::reliable(5, true)),
        TopicInfo::of::<MeshStamped>(&t.mesh_stamped, QosProfile::reliable(5, true)),
        TopicInfo::of::<Interaction>(&t.interaction, QosProfile::reliable(10, false)),
        // Per-step outputs: room for several objects' samples of a tick before their readers
        // acknowledge (the writers never wait; see dds::never_blocking).
        TopicInfo::of::<PointCloud2>(&t.deformed_points, QosProfile::reliable(10, false)),
        TopicInfo::of::<PointCloud2>(&t.weights_cloud, QosProfile::reliable(4, true)),
        TopicInfo::of::<SkinningWeights>(&t.weights, QosProfile::reliable(4, true)),
        TopicInfo::of::<SubspaceState>(&t.state, QosProfile::reliable(10, false)),
        TopicInfo::of::<Status>(&t.status, QosProfile::reliable(50, true)),
        TopicInfo::of::<MarkerArray>(&t.markers, QosProfile::reliable(10, false)),
        TopicInfo::of::<TFMessage>(TF, QosProfile::reliable(100, false)),
        TopicInfo::of::<TFMessage>(TF_STATIC, QosProfile::reliable(100, true)),
    ]
}

/// tf2's topics: global names, never remapped by the node's namespace.
pub const TF: &str = "/tf";
/// tf2's topic of static transforms.
pub const TF_STATIC: &str = "/tf_static";

/// Where outputs go, shared by the build and step threads.
pub struct Outputs {
    /// The DDS publishers; None in a replay.
    pub dds: Option<Publishers>,
    /// The recording, when one was asked for.
    pub recorder: Option<Recorder>,
    /// Zero-copy hand-off to local programs.
    pub shm: Option<ShmPublisher>,
    /// The topic names, resolved.
    pub topics: Topics,
    /// Which outputs are published.
    pub publish: PublishParams,
    /// Where stamps take their time from.
    pub clock: NodeClock,
    /// Put wall-clock timings (step_time_ms, build times) into messages. Replays leave them
    /// out so that two replays give identical bytes; they print them instead.
    pub timings: bool,
    /// The node's log (a replay has none: its lines go to stderr only).
    pub log: Option<NodeLog>,
    /// Publications DDS refused because a reader was too far behind.
    pub dropped: std::sync::atomic::AtomicU64,
}

impl Outputs {
    /// A header in `frame`, stamped now by `clock`.
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
                self.dropped(topic, &e);
            }
        }
    }

    /// Counts a publication DDS refused (a reader too far behind); says so on the first and
    /// then every 100th. Not through `report`: a failing status publisher would recurse.
    fn dropped<D>(&self, topic: &str, e: &ros2_client::ros2::WriteError<D>) {
        let n = self
            .dropped
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        if n % 100 == 0 {
            // Display, not Debug: the Debug form carries the whole message.
            eprintln!(
                "[physskin] warn: {topic} not published ({e}: a reader is behind); {} publications dropped so far",
                n + 1
            );
        }
    }

    /// Publishes a status and writes the same line to the log (stderr, and /rosout in a node).
    pub fn report(&self, level: u8, shape_id: u32, event: &str, message: String) {
        let tag = ["info", "warn", "error"][level.min(2) as usize];
        let line = format!("[physskin] {tag} {event} (shape {shape_id}): {message}");
        let severity = [LogLevel::Info, LogLevel::Warn, LogLevel::Error][level.min(2) as usize];
        match &self.log {
            Some(log) => log.write(severity, &line),
            None => eprintln!("{line}"),
        }
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

    /// The deformed points and the state of a body after a step, and its surface marker when
    /// `surface` is given (under one header, so a viewer can match them).
    pub fn publish_step(
        &self,
        shape_id: u32,
        header: Header,
        body: &SoftBody,
        surface: Option<(&mut MarkerSurface, &str)>,
        cloud: DeformedCloud,
        tracked: Option<&crate::pipeline::FrameFit>,
    ) {
        if let Some((surface, ns)) = surface {
            let marker = surface.marker(body, header.clone(), ns, shape_id);
            self.publish_markers(MarkerArray {
                markers: vec![marker],
            });
        }
        if let Some(shm) = &self.shm {
            let stamp = header.stamp.nanos();
            if let Err(e) = shm.publish_deformed(shape_id, stamp, body.handles(), body.deformed()) {
                eprintln!("[physskin] warn: deformed points not handed over on iceoryx2: {e}");
            }
        }
        let cloud = match cloud {
            _ if !self.publish.deformed_points => None,
            DeformedCloud::Skip => None,
            DeformedCloud::XyzOnly => Some(encode_cloud(header.clone(), body.deformed(), &[], &[])),
            DeformedCloud::Template(t) => Some(t.fill(header.clone(), body.deformed())),
        };
        if let Some(cloud) = cloud {
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
                tracking_residual_m: tracked.map_or(0.0, |f| f.residual_m),
                tracking_points: tracked.map_or(0, |f| f.correspondences as u32),
                tracking_ms: match tracked {
                    Some(f) if self.timings => f.ms,
                    _ => 0.0,
                },
            };
            let publisher = self.dds.as_ref().and_then(|d| d.state.as_ref());
            self.emit(&self.topics.state, publisher, state);
        }
    }
}

impl Outputs {
    fn publish_markers(&self, markers: MarkerArray) {
        let publisher = self.dds.as_ref().and_then(|d| d.markers.as_ref());
        self.emit(&self.topics.markers, publisher, markers);
    }

    /// Tells viewers that an object went away: its marker is deleted.
    pub fn publish_removed(&self, shape_id: u32, frame: &str, ns: &str) {
        let marker = delete_marker(self.header(frame), ns, shape_id);
        self.publish_markers(MarkerArray {
            markers: vec![marker],
        });
    }
}

/// The outputs, shared between the node's threads.
pub type SharedOutputs = Arc<Outputs>;

/// Whether a step's deformed cloud goes out, and in which layout.
#[derive(Clone, Copy)]
pub enum DeformedCloud<'a> {
    /// Not this step (`publish.rate_hz`).
    Skip,
    /// Float32 x, y, z only (meshes, scene objects).
    XyzOnly,
    /// The input cloud's layout and fields.
    Template(&'a CloudTemplate),
}

impl<'a> DeformedCloud<'a> {
    /// The input cloud's layout when there is one, else x, y, z only.
    pub fn of(template: Option<&'a CloudTemplate>) -> Self {
        template.map_or(Self::XyzOnly, Self::Template)
    }
}
