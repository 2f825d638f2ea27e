//! The build thread: new geometry in, a ready body out, off the stepping thread so running
//! objects never wait for inference.

use std::collections::hash_map::DefaultHasher;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, RwLock};

use nalgebra::Vector3;

use super::messages::Status;
use super::outputs::SharedOutputs;
use super::params::NodeParams;
use crate::geometry::Shape;
use crate::pipeline::SoftBody;
use crate::skinning::NeuralModel;

/// New geometry for the object in `frame`.
pub struct BuildRequest {
    pub frame: String,
    /// "cloud" or "mesh", for messages.
    pub source: &'static str,
    pub points: Vec<Vector3<f64>>,
    pub triangles: Vec<[u32; 3]>,
    /// Points dropped while decoding (NaN or Inf).
    pub dropped: usize,
}

/// A built body on its way to the stepper.
pub struct ReadyBody {
    pub id: u32,
    pub frame: String,
    pub body: SoftBody,
}

impl BuildRequest {
    fn content_hash(&self) -> u64 {
        let mut h = DefaultHasher::new();
        for p in &self.points {
            for c in p.iter() {
                c.to_bits().hash(&mut h);
            }
        }
        self.triangles.hash(&mut h);
        h.finish()
    }
}

/// Runs until `requests` closes. Geometry identical to the object already in its frame is not
/// rebuilt; when requests arrive faster than inference, only the newest per frame is built.
pub fn run_builder(
    requests: Receiver<BuildRequest>,
    ready: Sender<ReadyBody>,
    params: Arc<RwLock<NodeParams>>,
    model: Arc<NeuralModel>,
    outputs: SharedOutputs,
) {
    let threads = params.read().map_or(1, |p| p.inference.threads);
    // Inference gets its own thread pool, so it cannot occupy the pool the stepper uses.
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("physskin-infer-{i}"))
        .build()
    {
        Ok(pool) => pool,
        Err(e) => {
            outputs.report(
                Status::ERROR,
                0,
                "node_error",
                format!("no inference threads: {e}"),
            );
            return;
        }
    };
    let mut built: HashMap<String, u64> = HashMap::new();
    let mut next_id = 1u32;
    while let Ok(first) = requests.recv() {
        let mut newest: Vec<BuildRequest> = vec![first];
        for request in requests.try_iter() {
            if let Some(i) = newest.iter().position(|r| r.frame == request.frame) {
                newest[i] = request;
            } else {
                newest.push(request);
            }
        }
        for request in newest {
            let hash = request.content_hash();
            if built.get(&request.frame) == Some(&hash) {
                continue;
            }
            let snapshot = params.read().map(|p| p.clone()).unwrap_or_default();
            let id = next_id;
            next_id += 1;
            let body = snapshot.body_options().and_then(|options| {
                let shape = Shape::new(request.points.clone(), None, request.triangles.clone())?;
                pool.install(|| SoftBody::build(&model, &shape, &request.points, &options))
            });
            match body {
                Ok(body) => {
                    built.insert(request.frame.clone(), hash);
                    let t = body.timings().clone();
                    let rest: Vec<f32> = request
                        .points
                        .iter()
                        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
                        .collect();
                    let weights = body.weights().to_vec();
                    let handles = body.handles();
                    let count = body.point_count();
                    // The body goes to the stepper first: its first frame must not wait for
                    // the (large) weight messages.
                    if ready
                        .send(ReadyBody {
                            id,
                            frame: request.frame.clone(),
                            body,
                        })
                        .is_err()
                    {
                        return;
                    }
                    outputs.publish_weights(id, &request.frame, &rest, &weights, handles);
                    let dropped = if request.dropped > 0 {
                        format!(", {} NaN or Inf points dropped", request.dropped)
                    } else {
                        String::new()
                    };
                    outputs.report(
                        Status::INFO,
                        id,
                        "shape_ready",
                        format!(
                            "{} in frame `{}`: {count} points, {handles} handles{dropped}; built in {:.1} ms (voxels {:.1}, inference {:.1}, subspace {:.1}, weights {:.1})",
                            request.source, request.frame, t.total_ms, t.voxelize_ms, t.infer_ms, t.subspace_ms, t.weights_ms
                        ),
                    );
                }
                Err(e) => outputs.report(
                    Status::ERROR,
                    id,
                    "input_rejected",
                    format!("{} in frame `{}`: {e}", request.source, request.frame),
                ),
            }
        }
    }
}
