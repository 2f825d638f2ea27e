//! The build thread: new geometry in, a ready body out, off the stepping thread so running
//! objects never wait for inference.

use std::collections::HashMap;
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, RwLock};

use nalgebra::Vector3;

use super::cloud::decode_cloud;
use super::messages::{Mesh, PointCloud2, Status};
use super::outputs::{Outputs, SharedOutputs};
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
    /// The geometry of a cloud (its frame from the header); why not, naming the problem.
    pub fn from_cloud(cloud: &PointCloud2, max_points: usize) -> Result<Self, String> {
        let frame = cloud.header.frame_id.clone();
        let decoded = decode_cloud(cloud, max_points)
            .map_err(|e| format!("cloud in frame `{frame}`: {e}"))?;
        Ok(Self {
            frame,
            source: "cloud",
            points: decoded.points,
            triangles: Vec::new(),
            dropped: decoded.dropped,
        })
    }

    /// The geometry of a mesh in `frame`.
    pub fn from_mesh(mesh: &Mesh, frame: &str, max_points: usize) -> Result<Self, String> {
        if mesh.vertices.len() > max_points {
            return Err(format!(
                "mesh in frame `{frame}`: {} vertices, more than max_points = {max_points}",
                mesh.vertices.len()
            ));
        }
        Ok(Self {
            frame: frame.into(),
            source: "mesh",
            points: mesh
                .vertices
                .iter()
                .map(|v| Vector3::new(v.x, v.y, v.z))
                .collect(),
            triangles: mesh.triangles.iter().map(|t| t.vertex_indices).collect(),
            dropped: 0,
        })
    }

    fn content_hash(&self) -> u64 {
        crate::geometry::content_hash(&self.points, &self.triangles)
    }
}

/// Turns requests into bodies: numbers them, skips geometry identical to what its frame already
/// runs, reports failures. The node runs it on its build thread; a replay calls it in line.
#[derive(Default)]
pub struct Builder {
    built: HashMap<String, u64>,
    next_id: u32,
}

impl Builder {
    /// A builder whose first id follows `reserved` ids (those of a scene's objects).
    pub fn after_reserved_ids(reserved: u32) -> Self {
        Self {
            next_id: reserved,
            ..Self::default()
        }
    }
}

/// What is announced once a body is with the stepper: its weights and a `shape_ready` status.
pub struct Announcement {
    id: u32,
    frame: String,
    rest: Vec<f32>,
    weights: Vec<f32>,
    handles: usize,
    message: String,
}

impl Announcement {
    pub fn publish(self, outputs: &Outputs) {
        outputs.publish_weights(
            self.id,
            &self.frame,
            &self.rest,
            &self.weights,
            self.handles,
        );
        outputs.report(Status::INFO, self.id, "shape_ready", self.message);
    }
}

/// What became of a request.
pub enum BuildOutcome {
    Ready(Box<ReadyBody>, Announcement),
    /// The frame already runs this geometry.
    Unchanged,
    /// Refused; the reason went out on the status topic.
    Rejected,
}

impl Builder {
    /// Builds the body of `request`.
    pub fn build(
        &mut self,
        request: &BuildRequest,
        params: &NodeParams,
        model: &Arc<NeuralModel>,
        outputs: &Outputs,
    ) -> BuildOutcome {
        let hash = request.content_hash();
        if self.built.get(&request.frame) == Some(&hash) {
            return BuildOutcome::Unchanged;
        }
        self.next_id += 1;
        let id = self.next_id;
        let body = match build_body(request, params, model) {
            Ok(body) => body,
            Err(e) => {
                let message = format!("{} in frame `{}`: {e}", request.source, request.frame);
                outputs.report(Status::ERROR, id, "input_rejected", message);
                return BuildOutcome::Rejected;
            }
        };
        self.built.insert(request.frame.clone(), hash);
        let t = body.timings();
        let dropped = if request.dropped > 0 {
            format!(", {} NaN or Inf points dropped", request.dropped)
        } else {
            String::new()
        };
        let timings = if outputs.timings {
            format!(
                "; built in {:.1} ms (voxels {:.1}, inference {:.1}, subspace {:.1}, weights {:.1})",
                t.total_ms, t.voxelize_ms, t.infer_ms, t.subspace_ms, t.weights_ms
            )
        } else {
            String::new()
        };
        let announcement = Announcement {
            id,
            frame: request.frame.clone(),
            rest: request
                .points
                .iter()
                .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect(),
            weights: body.weights().to_vec(),
            handles: body.handles(),
            message: format!(
                "{} in frame `{}`: {} points, {} handles{dropped}{timings}",
                request.source,
                request.frame,
                body.point_count(),
                body.handles()
            ),
        };
        let ready = ReadyBody {
            id,
            frame: request.frame.clone(),
            body,
        };
        BuildOutcome::Ready(Box::new(ready), announcement)
    }
}

/// Lowers the calling thread's priority (nice 10), so that on a busy machine the step thread
/// wins the CPU over inference and the 60 Hz beat holds.
pub(crate) fn yield_to_stepping() {
    // SAFETY: setpriority on this thread's own id has no memory effects; a failure (no
    // permission) only leaves the priority as it was.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t, 10);
    }
}

/// The body of a request's geometry under `params`.
fn build_body(
    request: &BuildRequest,
    params: &NodeParams,
    model: &Arc<NeuralModel>,
) -> crate::Result<SoftBody> {
    let options = params.body_options()?;
    let shape = Shape::new(request.points.clone(), None, request.triangles.clone())?;
    SoftBody::build(model, &shape, &request.points, &options)
}

/// Runs until `requests` closes. When requests arrive faster than inference, only the newest
/// per frame is built.
pub fn run_builder(
    requests: Receiver<BuildRequest>,
    ready: Sender<ReadyBody>,
    params: Arc<RwLock<NodeParams>>,
    model: Arc<NeuralModel>,
    outputs: SharedOutputs,
    reserved_ids: u32,
) {
    let threads = params.read().map_or(1, |p| p.inference.threads);
    // Inference gets its own thread pool, so it cannot occupy the pool the stepper uses.
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("physskin-infer-{i}"))
        .start_handler(|_| yield_to_stepping())
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
    yield_to_stepping();
    // Ids up to `reserved_ids` belong to the scene's objects.
    let mut builder = Builder {
        next_id: reserved_ids,
        ..Builder::default()
    };
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
            let snapshot = params.read().map(|p| p.clone()).unwrap_or_default();
            let built = pool.install(|| builder.build(&request, &snapshot, &model, &outputs));
            if let BuildOutcome::Ready(body, announcement) = built {
                // The body goes to the stepper first: its first frame must not wait for the
                // (large) weight messages.
                if ready.send(*body).is_err() {
                    return;
                }
                announcement.publish(&outputs);
            }
        }
    }
}
