//! What the runtime emits: every message is built once and handed to each sink of its shell
//! (DDS publishers, a recording, iceoryx2, a test's collector). Status reports also go to the
//! log, as records of the `log` facade.

use std::sync::Arc;

use super::clock::NodeClock;
use super::cloud_objects::CloudTemplate;
use super::markers::{delete_marker, MarkerSurface};
use super::params::{PublishParams, Topics};
use crate::msg::cloud::encode_cloud;
use crate::msg::{
    Header, Interaction, MarkerArray, Mesh, MeshStamped, Output, PointCloud2, QosProfile, Sink,
    SkinningWeights, Status, SubspaceState, TFMessage, TopicInfo,
};
use crate::pipeline::SoftBody;

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
    /// Every output goes to each of these, in order.
    pub sinks: Vec<Box<dyn Sink>>,
    /// The topic names, resolved.
    pub topics: Topics,
    /// Which outputs are published.
    pub publish: PublishParams,
    /// Where stamps take their time from.
    pub clock: NodeClock,
    /// Put wall-clock timings (step_time_ms, build times) into messages. Replays leave them
    /// out so that two replays give identical bytes; they print them instead.
    pub timings: bool,
    /// Status reports less severe than this are neither sent nor logged (`--log-level`).
    pub status_level: log::LevelFilter,
}

impl Outputs {
    /// Outputs on `topics` that go nowhere yet: add sinks to `sinks`.
    pub fn new(topics: Topics, publish: PublishParams, clock: NodeClock, timings: bool) -> Self {
        Self {
            sinks: Vec::new(),
            topics,
            publish,
            clock,
            timings,
            status_level: log::LevelFilter::Info,
        }
    }

    /// A header in `frame`, stamped now by `clock`.
    pub fn header(&self, frame: &str) -> Header {
        Header {
            stamp: self.clock.now(),
            frame_id: frame.into(),
        }
    }

    /// Hands one message to every sink.
    fn emit(&self, topic: &str, message: Output) {
        let now = self.clock.now_nanos().unwrap_or(0);
        for sink in &self.sinks {
            sink.send(topic, now, &message);
        }
    }

    /// Sends a status and logs the same event (node-wide events, shape 0, name no shape).
    pub fn report(&self, level: u8, shape_id: u32, event: &str, message: String) {
        let severity =
            [log::Level::Info, log::Level::Warn, log::Level::Error][level.min(2) as usize];
        if severity > self.status_level {
            return;
        }
        match shape_id {
            0 => log::log!(severity, "{event}: {message}"),
            id => log::log!(severity, "{event} (shape {id}): {message}"),
        }
        let status = Status {
            header: self.header(""),
            shape_id,
            level,
            event: event.into(),
            message,
        };
        self.emit(&self.topics.status, Output::Status(status));
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
        for sink in &self.sinks {
            sink.weights(shape_id, header.stamp.nanos(), handles, weights);
        }
        if self.publish.weights_cloud {
            let channels: Vec<String> = (0..handles).map(|i| format!("w{i}")).collect();
            let cloud = encode_cloud(header.clone(), rest, &channels, weights);
            self.emit(&self.topics.weights_cloud, Output::Cloud(cloud));
        }
        if self.publish.weights {
            let message = SkinningWeights {
                header,
                shape_id,
                point_count: (rest.len() / 3) as u32,
                handle_count: handles as u32,
                weights: weights.to_vec(),
            };
            self.emit(&self.topics.weights, Output::Weights(message));
        }
    }

    /// Publishes a step, with a warning if it did not converge and a note if its budget was
    /// extended or its pin springs stiffened.
    pub fn publish_step_reported(
        &self,
        id: u32,
        frame: &str,
        body: &SoftBody,
        surface: Option<(&mut MarkerSurface, &str)>,
        cloud: DeformedCloud,
        tracked: Option<&crate::pipeline::FrameFit>,
    ) {
        let Some(report) = body.last_step() else {
            return;
        };
        if !report.converged {
            let message = format!(
                "step did not converge ({} iterations, decrement {:e})",
                report.iterations, report.decrement
            );
            self.report(Status::WARN, id, "step_unconverged", message);
        }
        if report.budget_extensions > 0 {
            let message = format!(
                "step took {} iterations: its budget was given again {} times while it still descended",
                report.iterations, report.budget_extensions
            );
            self.report(Status::INFO, id, "step_budget_extended", message);
        }
        if report.pin_stiffenings > 0 {
            let message = format!(
                "a force past what the pin springs hold: made {}x stiffer for this step",
                report.pin_spring_boost()
            );
            self.report(Status::INFO, id, "pin_springs_stiffened", message);
        }
        self.publish_step(id, self.header(frame), body, surface, cloud, tracked);
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
        for sink in &self.sinks {
            sink.deformed(
                shape_id,
                header.stamp.nanos(),
                body.handles(),
                body.deformed(),
            );
        }
        let cloud = match cloud {
            _ if !self.publish.deformed_points => None,
            DeformedCloud::Skip => None,
            DeformedCloud::XyzOnly => Some(encode_cloud(header.clone(), body.deformed(), &[], &[])),
            DeformedCloud::Template(t) => Some(t.fill(header.clone(), body.deformed())),
        };
        if let Some(cloud) = cloud {
            self.emit(&self.topics.deformed_points, Output::Cloud(cloud));
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
            self.emit(&self.topics.state, Output::State(state));
        }
    }
}

impl Outputs {
    fn publish_markers(&self, markers: MarkerArray) {
        self.emit(&self.topics.markers, Output::Markers(markers));
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

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::msg::Collector;

    /// Every sink takes each output once, on its resolved topic and at the clock's time; a
    /// status below the level is neither sent nor logged.
    #[test]
    fn each_sink_takes_every_output_once() {
        let clock = NodeClock::simulated();
        clock.set(&crate::msg::Time::from_nanos(42));
        let mut outputs = Outputs::new(
            Topics::default_resolved(),
            PublishParams::default(),
            clock,
            false,
        );
        let (first, second) = (
            Arc::new(Collector::default()),
            Arc::new(Collector::default()),
        );
        outputs.sinks.push(Box::new(first.clone()));
        outputs.sinks.push(Box::new(second.clone()));
        outputs.status_level = log::LevelFilter::Warn;
        outputs.report(Status::INFO, 0, "quiet", "below the level".into());
        outputs.report(Status::WARN, 3, "loud", "at the level".into());
        for sink in [first, second] {
            let got = sink.take();
            assert_eq!(got.len(), 1, "one status each");
            let (topic, at, message) = &got[0];
            assert_eq!((topic.as_str(), *at), ("/physskin/status", 42));
            let Output::Status(status) = message else {
                panic!("a status, not {message:?}")
            };
            assert_eq!((status.shape_id, status.event.as_str()), (3, "loud"));
        }
    }
}
