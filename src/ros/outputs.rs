//! What the node publishes, shared by its threads, and the status reports that go with it.

use std::sync::Arc;

use ros2_client::Publisher;

use super::clock::NodeClock;
use super::cloud::encode_cloud;
use super::messages::{Header, PointCloud2, SkinningWeights, Status, SubspaceState};
use crate::pipeline::SoftBody;

/// The node's publishers (absent when switched off in `publish.*`).
pub struct Outputs {
    pub deformed_points: Option<Publisher<PointCloud2>>,
    pub weights: Option<Publisher<SkinningWeights>>,
    pub weights_cloud: Option<Publisher<PointCloud2>>,
    pub state: Option<Publisher<SubspaceState>>,
    pub status: Publisher<Status>,
    pub clock: NodeClock,
}

impl Outputs {
    pub fn header(&self, frame: &str) -> Header {
        Header {
            stamp: self.clock.now(),
            frame_id: frame.into(),
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
        if let Err(e) = self.status.publish(status) {
            eprintln!("[physskin] warn: status not published: {e:?}");
        }
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
        if let Some(p) = &self.weights_cloud {
            let channels: Vec<String> = (0..handles).map(|i| format!("w{i}")).collect();
            let cloud = encode_cloud(header.clone(), rest, &channels, weights);
            if let Err(e) = p.publish(cloud) {
                self.report(
                    Status::WARN,
                    shape_id,
                    "publish_failed",
                    format!("weights cloud: {e:?}"),
                );
            }
        }
        if let Some(p) = &self.weights {
            let message = SkinningWeights {
                header,
                shape_id,
                point_count: (rest.len() / 3) as u32,
                handle_count: handles as u32,
                weights: weights.to_vec(),
            };
            if let Err(e) = p.publish(message) {
                self.report(
                    Status::WARN,
                    shape_id,
                    "publish_failed",
                    format!("weights: {e:?}"),
                );
            }
        }
    }

    /// The deformed points and the state of a body after a step.
    pub fn publish_step(&self, shape_id: u32, frame: &str, body: &SoftBody) {
        let header = self.header(frame);
        if let Some(p) = &self.deformed_points {
            let cloud = encode_cloud(header.clone(), body.deformed(), &[], &[]);
            if let Err(e) = p.publish(cloud) {
                self.report(
                    Status::WARN,
                    shape_id,
                    "publish_failed",
                    format!("deformed points: {e:?}"),
                );
            }
        }
        if let (Some(p), Some(report)) = (&self.state, body.last_step()) {
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
                step_time_ms: report.seconds * 1e3,
            };
            if let Err(e) = p.publish(state) {
                self.report(
                    Status::WARN,
                    shape_id,
                    "publish_failed",
                    format!("state: {e:?}"),
                );
            }
        }
    }
}

pub type SharedOutputs = Arc<Outputs>;
