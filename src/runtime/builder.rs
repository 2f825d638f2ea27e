//! The build thread: new geometry in, a ready body out, off the stepping thread so running
//! objects never wait for inference.

use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, Mutex, RwLock};

use nalgebra::{Isometry3, Point3, Vector3};

use super::cloud_objects::{instance_field as instance_field_of, split_by_instance, CloudTemplate};
use super::markers::MarkerSurface;
pub use super::object_key::ObjectKey;
use super::outputs::{Outputs, SharedOutputs};
use super::params::NodeParams;
use super::refiner::RefineJob;
pub use super::refiner::RefinedField;
use super::tf::{TfBuffer, TfError};
use super::tracking::{Observation, TrackState};
use crate::msg::cloud::{decode_cloud, DecodedCloud};
use crate::msg::{Mesh, PointCloud2, Status};
use crate::pipeline::{build_seen, SeenBody, SoftBody};
use crate::skinning::{NeuralModel, RefineBudget};

/// New geometry for the object in `frame` (with `label`, one of the frame's labelled objects).
#[derive(Clone, Debug)]
pub struct BuildRequest {
    /// The frame_id the geometry arrived in.
    pub frame: String,
    /// The object's instance id in a labelled cloud; None: the frame's one object.
    pub label: Option<i64>,
    /// "cloud" or "mesh", for messages.
    pub source: &'static str,
    /// The cloud's points or the mesh's vertices, in `frame` (or the fixed frame once
    /// moved there), m.
    pub points: Vec<Vector3<f64>>,
    /// The mesh's triangles; empty for a cloud.
    pub triangles: Vec<[u32; 3]>,
    /// Points dropped while decoding (NaN or Inf).
    pub dropped: usize,
    /// The input's stamp, ns (0 when it has none: the latest transform is used).
    pub stamp_ns: i64,
    /// The frame the points are in once transformed into the fixed frame; None: `frame`.
    pub fixed_frame: Option<String>,
    /// Where the sensor saw the points from, in the points' frame: a cloud's frame is its
    /// sensor's, so its origin. None for meshes (not one view).
    pub viewpoint: Option<Vector3<f64>>,
    /// The input cloud's layout, which the deformed clouds keep (None for meshes).
    pub template: Option<CloudTemplate>,
}

/// How a replay's builds refine: by `bench basis`, 5 to 8 iterations bring the error to the
/// eigenmodes' own on the bench's shapes; full convergence can take ten times longer on
/// symmetric shapes (a ball), whose near-equal eigenvalues converge slowly, but their span
/// settles in 5 to 7 on the demo's bodies (`RefineBudget::Settled`), which is where a replay
/// stops.
pub const REPLAY_REFINE: RefineBudget = RefineBudget::Settled(8);

/// What the build thread hands the stepper.
pub enum Built {
    /// A new body, on the network's field.
    Body(ReadyBody),
    /// The refined field of a running object, to switch to.
    Refined(RefinedField),
    /// A later frame of a running object, to correct it.
    Observed(Observation),
}

/// A built body on its way to the stepper.
pub struct ReadyBody {
    /// The object's id (`shape_id` in its messages).
    pub id: u32,
    /// The input's frame.
    pub frame: String,
    /// Which object it is: its frame, or its frame and instance id.
    pub key: ObjectKey,
    /// The layout its deformed clouds go out in (None: x, y, z only).
    pub template: Option<CloudTemplate>,
    /// The frame its outputs are in: the fixed frame, or `frame`.
    pub output_frame: String,
    /// The body.
    pub body: SoftBody,
    /// Its surface for ~/markers (None when markers are off).
    pub surface: Option<MarkerSurface>,
    /// What the frames of its stream did to it.
    pub tracking: TrackState,
}

impl BuildRequest {
    /// The objects of a cloud (its frame from the header): one, or one per instance id when
    /// the cloud has `instance_field` (0 is background: a cloud of background only gives none);
    /// why not, naming the problem.
    pub fn from_cloud(
        cloud: &PointCloud2,
        max_points: usize,
        instance_field: &str,
    ) -> Result<Vec<Self>, String> {
        let frame = cloud.header.frame_id.clone();
        if frame.is_empty() {
            return Err(
                "cloud with an empty header.frame_id: its frame says where the object is".into(),
            );
        }
        let bad = |e: &dyn std::fmt::Display| format!("cloud in frame `{frame}`: {e}");
        let decoded = decode_cloud(cloud, max_points).map_err(|e| bad(&e))?;
        // In a labelled cloud the dropped (NaN) points are nobody's: not reported per object.
        let dropped = decoded.dropped;
        let field = instance_field_of(cloud, instance_field);
        let labelled = field.is_some();
        let objects: Vec<(Option<i64>, DecodedCloud)> = match field {
            Some(field) => split_by_instance(cloud, field, decoded)
                .map_err(|e| bad(&e))?
                .into_iter()
                .map(|(label, object)| (Some(label), object))
                .collect(),
            None => vec![(None, decoded)],
        };
        let pixels = objects.iter().map(|(_, o)| o.pixels.clone()).collect();
        let templates = CloudTemplate::for_objects(cloud, pixels, labelled);
        Ok(objects
            .into_iter()
            .zip(templates)
            .map(|((label, object), template)| Self {
                frame: frame.clone(),
                label,
                source: "cloud",
                points: object.points,
                triangles: Vec::new(),
                dropped: if label.is_some() { 0 } else { dropped },
                stamp_ns: cloud.header.stamp.nanos(),
                fixed_frame: None,
                viewpoint: Some(Vector3::zeros()),
                template: Some(template),
            })
            .collect())
    }

    /// The object this request builds.
    pub fn key(&self) -> ObjectKey {
        ObjectKey {
            frame: self.frame.clone(),
            label: self.label,
        }
    }

    /// The geometry of a mesh in `frame`, stamped `stamp_ns` (0: none).
    pub fn from_mesh(
        mesh: &Mesh,
        frame: &str,
        stamp_ns: i64,
        max_points: usize,
    ) -> Result<Self, String> {
        if frame.is_empty() {
            return Err("mesh with an empty frame: its frame says where the object is".into());
        }
        if mesh.vertices.len() > max_points {
            return Err(format!(
                "mesh in frame `{frame}`: {} vertices, more than max_points = {max_points}",
                mesh.vertices.len()
            ));
        }
        Ok(Self {
            frame: frame.into(),
            label: None,
            template: None,
            source: "mesh",
            points: mesh
                .vertices
                .iter()
                .map(|v| Vector3::new(v.x, v.y, v.z))
                .collect(),
            triangles: mesh.triangles.iter().map(|t| t.vertex_indices).collect(),
            dropped: 0,
            stamp_ns,
            fixed_frame: None,
            viewpoint: None,
        })
    }

    fn content_hash(&self) -> u64 {
        crate::geometry::content_hash(&self.points, &self.triangles)
    }

    /// Moves the points into `fixed` by `transform` (points of `frame` into `fixed`).
    pub fn transform_into(&mut self, fixed: &str, transform: &Isometry3<f64>) {
        for p in &mut self.points {
            *p = (transform * Point3::from(*p)).coords;
        }
        if let Some(v) = &mut self.viewpoint {
            *v = (transform * Point3::from(*v)).coords;
        }
        self.fixed_frame = Some(fixed.into());
    }

    /// Moves it into the parameters' fixed frame (when one is set) through `tf`, or says why
    /// not.
    pub fn move_to_fixed_frame(
        &mut self,
        params: &NodeParams,
        tf: &TfBuffer,
    ) -> Result<(), String> {
        if params.fixed_frame.is_empty() {
            return Ok(());
        }
        let transform = tf
            .lookup(&params.fixed_frame, &self.frame, self.stamp_ns)
            .map_err(|e| self.no_transform(&params.fixed_frame, &e))?;
        self.transform_into(&params.fixed_frame.clone(), &transform);
        Ok(())
    }

    /// The refusal of an input whose frame cannot be placed in `fixed`.
    fn no_transform(&self, fixed: &str, e: &TfError) -> String {
        format!(
            "{} in frame `{}`: no transform from `{}` to `{fixed}` at {:.3} s: {e}",
            self.source,
            self.frame,
            self.frame,
            self.stamp_ns as f64 / 1e9
        )
    }
}

/// Which geometry each object runs, and its id, shared with the stepper so that a removed
/// object builds again when the same geometry comes back.
#[derive(Clone, Default)]
pub struct BuiltRegistry(Arc<Mutex<HashMap<ObjectKey, Running>>>);

/// What an object runs: its geometry's hash, its id, and when a cloud last named it.
#[derive(Clone, Copy)]
struct Running {
    hash: u64,
    id: u32,
    last_ns: i64,
}

impl BuiltRegistry {
    /// Forgets what `key` runs (None: every object).
    pub fn forget(&self, key: Option<&ObjectKey>) {
        if let Ok(mut built) = self.0.lock() {
            match key {
                Some(key) => {
                    built.remove(key);
                }
                None => built.clear(),
            }
        }
    }

    /// The id of the object `key` when it runs (whatever its geometry), and whether its
    /// geometry is `hash`.
    fn lookup(&self, key: &ObjectKey, hash: u64) -> Option<(u32, bool)> {
        let built = self.0.lock().ok()?;
        built.get(key).map(|r| (r.id, r.hash == hash))
    }

    /// The id of the object `key` when it runs and a cloud named it at most `within_ns`
    /// before `now_ns`; the cloud of `now_ns` is noted either way.
    fn streaming(&self, key: &ObjectKey, now_ns: i64, within_ns: i64) -> Option<u32> {
        let mut built = self.0.lock().ok()?;
        let running = built.get_mut(key)?;
        let recent = now_ns - running.last_ns <= within_ns;
        running.last_ns = now_ns;
        recent.then_some(running.id)
    }

    fn insert(&self, key: ObjectKey, hash: u64, id: u32, now_ns: i64) {
        if let Ok(mut built) = self.0.lock() {
            let last_ns = now_ns;
            built.insert(key, Running { hash, id, last_ns });
        }
    }
}

/// Turns requests into bodies: numbers them, skips geometry identical to what its frame already
/// runs, reports failures. The node runs it on its build thread; a replay calls it in line.
#[derive(Default)]
pub struct Builder {
    built: BuiltRegistry,
    next_id: u32,
    /// Refine within the build (replay) rather than after it (the node).
    refine_in_build: bool,
}

impl Builder {
    /// Refines each field within its build (`REPLAY_REFINE`: up to 8 iterations), when
    /// `inference.refine` is on: a replay is offline and must reproduce itself, which a time
    /// budget would not.
    pub fn refine_in_build(&mut self) {
        self.refine_in_build = true;
    }

    /// Ids up to `reserved` belong to others (a scene's objects): new ids follow them.
    pub fn reserve_ids(&mut self, reserved: u32) {
        self.next_id = self.next_id.max(reserved);
    }

    /// The frames' geometry, for whoever removes objects.
    pub fn registry(&self) -> BuiltRegistry {
        self.built.clone()
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
    /// Publishes the body's weights (on the weights topics, and over iceoryx2 when it is on)
    /// and its `shape_ready` status.
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
    /// Built: the body for the stepper, and what to announce once the stepper has it.
    Ready(Box<ReadyBody>, Announcement),
    /// The frame already runs this geometry.
    Unchanged,
    /// The object runs: the cloud is an observation of it (`tracking.enabled`).
    Observed(Observation),
    /// Refused; the reason went out on the status topic.
    Rejected,
}

impl Builder {
    /// The body of `request`, or the observation it makes of the running object it is a frame of.
    pub fn build(
        &mut self,
        request: &BuildRequest,
        params: &NodeParams,
        model: &Arc<NeuralModel>,
        outputs: &Outputs,
    ) -> BuildOutcome {
        let now = outputs.clock.now_nanos().unwrap_or(0);
        match self.observation(request, &request.key(), params, now) {
            Some(observed) => BuildOutcome::Observed(observed),
            None => self.build_new(request, params, model, outputs),
        }
    }

    /// Builds the body of `request`, which is no frame of a running object's stream.
    fn build_new(
        &mut self,
        request: &BuildRequest,
        params: &NodeParams,
        model: &Arc<NeuralModel>,
        outputs: &Outputs,
    ) -> BuildOutcome {
        let hash = request.content_hash();
        let key = request.key();
        let now = outputs.clock.now_nanos().unwrap_or(0);
        let shard = params.shard().unwrap_or_default();
        // A running object keeps its id when its geometry changes: it is the same object.
        let id = match self.built.lookup(&key, hash) {
            Some((_, true)) => return BuildOutcome::Unchanged,
            Some((id, false)) => id,
            // Instances that split the objects number theirs apart (see `Shard`).
            None => {
                self.next_id = shard.id_after(self.next_id);
                self.next_id
            }
        };
        let SeenBody {
            body,
            completion,
            read_from,
        } = match build_body(request, params, model, self.refine_in_build) {
            Ok(built) => built,
            Err(e) => {
                let message = format!("{} in {key}: {e}", request.source);
                outputs.report(Status::ERROR, id, "input_rejected", message);
                return BuildOutcome::Rejected;
            }
        };
        self.built.insert(key.clone(), hash, id, now);
        let output_frame = request
            .fixed_frame
            .clone()
            .unwrap_or_else(|| request.frame.clone());
        let t = body.timings();
        let thinned = if read_from < request.points.len() {
            format!(" (its shape read from a voxel-downsampled {read_from})")
        } else {
            String::new()
        };
        let dropped = if request.dropped > 0 {
            format!(", {} NaN or Inf points dropped", request.dropped)
        } else {
            String::new()
        };
        let timings = if outputs.timings {
            let completed = completion
                .as_ref()
                .map_or(String::new(), |c| format!("completion {:.1}, ", c.ms));
            format!(
                "; built in {:.1} ms ({completed}voxels {:.1}, inference {:.1}, subspace {:.1}, weights {:.1})",
                t.total_ms, t.voxelize_ms, t.infer_ms, t.subspace_ms, t.weights_ms
            )
        } else {
            String::new()
        };
        let completion = match completion {
            Some(c) => format!(
                ", completed one view ({}, prior {}): observed {:.1} % of the surface, volume {:.3e} m^3",
                c.method,
                c.prior.name(),
                100.0 * c.observed_fraction,
                body.volume()
            ),
            None => String::new(),
        };
        let announcement = Announcement {
            id,
            frame: output_frame.clone(),
            rest: request
                .points
                .iter()
                .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect(),
            weights: body.weights().to_vec(),
            handles: body.handles(),
            message: format!(
                "{} in {key}{}: {} points{thinned}, {} handles{dropped}{completion}{timings}",
                request.source,
                if shard.is_split() {
                    format!(" (shard {shard})")
                } else {
                    String::new()
                },
                body.point_count(),
                body.handles()
            ),
        };
        let surface =
            (params.markers.rate_hz > 0.0).then(|| MarkerSurface::of(&body, &request.triangles));
        let ready = ReadyBody {
            id,
            frame: request.frame.clone(),
            key,
            template: request.template.clone(),
            output_frame,
            body,
            surface,
            tracking: TrackState::default(),
        };
        BuildOutcome::Ready(Box::new(ready), announcement)
    }
}

impl Builder {
    /// The observation a cloud arriving at node time `now_ns` makes of the object it names,
    /// when tracking is on, that object runs and a cloud named it within
    /// `tracking.relock_within_s`. A cloud after a longer gap (clouds sent now and then, not a
    /// stream) builds, as without tracking.
    fn observation(
        &self,
        request: &BuildRequest,
        key: &ObjectKey,
        params: &NodeParams,
        now_ns: i64,
    ) -> Option<Observation> {
        let tracking = &params.tracking;
        if !tracking.enabled {
            return None;
        }
        let within = (tracking.relock_within_s * 1e9) as i64;
        let id = self.built.streaming(key, now_ns, within)?;
        // A mesh is not one camera's view: it builds.
        Some(Observation {
            key: key.clone(),
            id,
            points: crate::pipeline::strided(&request.points, tracking.max_points),
            viewpoint: request.viewpoint?,
            params: tracking.clone(),
        })
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

/// The body of a request's geometry under `params` (see [`build_seen`]).
fn build_body(
    request: &BuildRequest,
    params: &NodeParams,
    model: &Arc<NeuralModel>,
    refine: bool,
) -> crate::Result<SeenBody> {
    let mut options = params.body_options()?;
    if refine && params.refine_budget() != RefineBudget::Off {
        options.refine = REPLAY_REFINE;
    }
    build_seen(
        model,
        &request.points,
        &request.triangles,
        request.viewpoint.as_ref(),
        params.inference.max_build_points,
        &options,
    )
}

/// What the build thread shares with the rest of the node.
pub struct BuildContext {
    /// The node's parameters, as they are now.
    pub params: Arc<RwLock<NodeParams>>,
    /// The network that infers skinning fields.
    pub model: Arc<NeuralModel>,
    /// Where statuses and weights go.
    pub outputs: SharedOutputs,
    /// The transforms into the fixed frame.
    pub tf: Arc<RwLock<TfBuffer>>,
    /// Counters for /diagnostics (the queued builds).
    pub health: Arc<super::diagnostics::Health>,
    /// Which geometry each object runs, shared with the stepper.
    pub registry: BuiltRegistry,
    /// Ids up to this belong to the scene's objects.
    pub reserved_ids: u32,
}

/// Runs until `requests` closes. When requests arrive faster than inference, only the newest
/// per frame is built.
pub fn run_builder(requests: Receiver<BuildRequest>, ready: Sender<Built>, cx: BuildContext) {
    let (refine, jobs) = std::sync::mpsc::channel();
    let (refined, outputs) = (ready.clone(), cx.outputs.clone());
    let deliver = move |r| refined.send(Built::Refined(r)).is_ok();
    // Set while a build runs: the refinement gives way.
    let building = Arc::new(AtomicBool::new(false));
    let flag = building.clone();
    let spawned = std::thread::Builder::new()
        .name("physskin-refine".into())
        .spawn(move || super::refiner::run_refiner(jobs, deliver, outputs, flag));
    if let Err(e) = spawned {
        let message = format!("no refinement thread: {e}");
        cx.outputs.report(Status::WARN, 0, "refine_failed", message);
    }
    let threads = cx.params.read().map_or(1, |p| p.inference.threads);
    // Inference gets its own thread pool, so it cannot occupy the pool the stepper uses.
    let pool = match rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("physskin-infer-{i}"))
        .start_handler(|_| yield_to_stepping())
        .build()
    {
        Ok(pool) => pool,
        Err(e) => {
            let message = format!("no inference threads: {e}");
            cx.outputs.report(Status::ERROR, 0, "node_error", message);
            return;
        }
    };
    yield_to_stepping();
    let mut builder = Builder {
        next_id: cx.reserved_ids,
        built: cx.registry.clone(),
        refine_in_build: false,
    };
    while let Ok(first) = requests.recv() {
        let mut newest: Vec<BuildRequest> = vec![first];
        for request in requests.try_iter() {
            cx.health.builds_queued.fetch_sub(1, Ordering::Relaxed);
            if let Some(i) = newest.iter().position(|r| r.key() == request.key()) {
                newest[i] = request;
            } else {
                newest.push(request);
            }
        }
        for mut request in newest {
            cx.health.builds_queued.fetch_sub(1, Ordering::Relaxed);
            let snapshot = cx.params.read().map(|p| p.clone()).unwrap_or_default();
            if let Err(problem) = wait_for_fixed_frame(&mut request, &snapshot, &cx.tf) {
                cx.outputs
                    .report(Status::ERROR, 0, "input_rejected", problem);
                continue;
            }
            // A frame of a running object is no build: the refinement does not give way to it.
            let now = cx.outputs.clock.now_nanos().unwrap_or(0);
            if let Some(observed) = builder.observation(&request, &request.key(), &snapshot, now) {
                if ready.send(Built::Observed(observed)).is_err() {
                    return;
                }
                continue;
            }
            building.store(true, Ordering::Relaxed);
            let built =
                pool.install(|| builder.build_new(&request, &snapshot, &cx.model, &cx.outputs));
            // Until the next build, refinement may run.
            building.store(false, Ordering::Relaxed);
            if let BuildOutcome::Ready(body, announcement) = built {
                let budget = snapshot.refine_budget();
                let plan = (budget != RefineBudget::Off).then(|| body.body.basis_plan());
                let (id, key) = (body.id, body.key.clone());
                // The body goes to the stepper first: its first frame must not wait for the
                // (large) weight messages; the refinement runs on a thread of its own.
                if ready.send(Built::Body(*body)).is_err() {
                    return;
                }
                announcement.publish(&cx.outputs);
                if let Some(plan) = plan {
                    let job = RefineJob {
                        id,
                        key,
                        plan,
                        budget,
                    };
                    if refine.send(job).is_err() {
                        return;
                    }
                }
                super::heap::release_free_heap();
            }
        }
    }
}

/// Moves a request into the fixed frame, waiting up to `tf.timeout_s` for its transform (a
/// camera's cloud often arrives before the transform of its stamp).
fn wait_for_fixed_frame(
    request: &mut BuildRequest,
    params: &NodeParams,
    tf: &RwLock<TfBuffer>,
) -> Result<(), String> {
    let deadline =
        std::time::Instant::now() + std::time::Duration::from_secs_f64(params.tf.timeout_s);
    loop {
        let buffer = tf
            .read()
            .map_err(|_| "the tf buffer is poisoned".to_string())?;
        match request.move_to_fixed_frame(params, &buffer) {
            Ok(()) => return Ok(()),
            Err(problem) if std::time::Instant::now() >= deadline => return Err(problem),
            Err(_) => {}
        }
        drop(buffer);
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
}
