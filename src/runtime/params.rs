//! Node parameters: defaults in code, overrides from a `ros__parameters` YAML file, and the
//! flat dotted names (`material.young`) that `ros2 param get/set` see.
//!
//! The parameters live as one serde struct. Loading and setting go through its JSON form, so a
//! file, a `ros2 param set` and the defaults all pass the same type checks and validation.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

use super::names::{NameError, NameResolver};
use super::shard::Shard;
pub(crate) use super::tracking_params::TrackingParams;
use crate::physics::{BulkIntegration, SimParams, Solver};
use crate::pipeline::{BodyOptions, Support};
use crate::skinning::RefineBudget;

// Lives in `crate::error` (the crate error wraps it); named here too, where it always was.
pub use crate::error::ParamError;

/// Topic names, resolved by ROS 2 name rules: `~/x` is private to the node (`/ns/node/x`), a
/// relative name lives in the node's namespace, and `--ros-args -r FROM:=TO` remaps them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Topics {
    /// sensor_msgs/PointCloud2 in. Default ~/points.
    pub points: String,
    /// shape_msgs/Mesh in (its frame is `mesh_frame`). Default ~/mesh.
    pub mesh: String,
    /// physskin/MeshStamped in. Default ~/mesh_stamped.
    pub mesh_stamped: String,
    /// physskin/Interaction in: forces, pins, releases. Default ~/interaction.
    pub interaction: String,
    /// PointCloud2 out: the deformed input points, every step. Default ~/deformed_points.
    pub deformed_points: String,
    /// PointCloud2 out: x, y, z and one float32 field w0..wK per handle, once per shape.
    /// Default ~/weights_cloud.
    pub weights_cloud: String,
    /// physskin/SkinningWeights out, once per shape. Default ~/weights.
    pub weights: String,
    /// physskin/SubspaceState out, every step. Default ~/state.
    pub state: String,
    /// physskin/Status out: accepted and rejected inputs, errors. Default ~/status.
    pub status: String,
    /// visualization_msgs/MarkerArray out: each object's deformed surface. Default ~/markers.
    pub markers: String,
}

impl Default for Topics {
    fn default() -> Self {
        let t = |name: &str| format!("~/{name}");
        Self {
            points: t("points"),
            mesh: t("mesh"),
            mesh_stamped: t("mesh_stamped"),
            interaction: t("interaction"),
            deformed_points: t("deformed_points"),
            weights_cloud: t("weights_cloud"),
            weights: t("weights"),
            state: t("state"),
            status: t("status"),
            markers: t("markers"),
        }
    }
}

impl Topics {
    /// Every name resolved for the node of `names` (fully qualified, remapped).
    pub fn resolved(&self, names: &NameResolver) -> Result<Self, NameError> {
        let r = |name: &String| names.resolve(name);
        Ok(Self {
            points: r(&self.points)?,
            mesh: r(&self.mesh)?,
            mesh_stamped: r(&self.mesh_stamped)?,
            interaction: r(&self.interaction)?,
            deformed_points: r(&self.deformed_points)?,
            weights_cloud: r(&self.weights_cloud)?,
            weights: r(&self.weights)?,
            state: r(&self.state)?,
            status: r(&self.status)?,
            markers: r(&self.markers)?,
        })
    }

    /// The names of node `physskin` in `/`, unremapped: what recordings made with the default
    /// topics hold.
    pub fn default_resolved() -> Self {
        Self::default()
            .resolved(&NameResolver::default())
            .expect("the default names are valid")
    }
}

/// Material of new shapes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaterialParams {
    /// Young's modulus, Pa. Default 2e5.
    pub young: f64,
    /// Poisson ratio. Default 0.45.
    pub poisson: f64,
    /// Density, kg/m^3. Default 1000.
    pub density: f64,
}

impl Default for MaterialParams {
    fn default() -> Self {
        Self {
            young: 2e5,
            poisson: 0.45,
            density: 1000.0,
        }
    }
}

/// Simulation of new shapes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulationParams {
    /// Gravity, m/s^2. Default [0, 0, -9.81].
    pub gravity: [f64; 3],
    /// Velocity decay rate, 1/s. Default 1.
    pub damping: f64,
    /// free, floor, pin_top or pin_bottom. Default pin_bottom.
    pub support: Support,
    /// Cubature points per shape. Default 256.
    pub cubature: usize,
    /// newton or quasi_newton. Default quasi_newton.
    pub solver: String,
    /// Coulomb friction of every contact (the floor, robot links, other objects), as scene
    /// files default to: what lets a gripper hold an object and the floor hold a landed one.
    /// Default 0.5. On a frictionless floor a tracked ball spun about its centre after
    /// landing, which its round surface cannot show (`bench track`: the dropped ball's
    /// material points 28.4773 % of its diagonal off with 2000 samples, 0.7578 % with 0.5).
    pub friction: f64,
    /// How the bulk term is integrated: points (at every cubature point) or regions (projected
    /// onto a pressure linear within each of 2K regions: closer to the FEM where a nearly
    /// incompressible body locks, at up to twice the step). Default points.
    pub bulk: BulkIntegration,
}

impl Default for SimulationParams {
    fn default() -> Self {
        Self {
            gravity: [0.0, 0.0, -9.81],
            damping: 1.0,
            support: Support::PinBottom,
            cubature: 256,
            solver: "quasi_newton".into(),
            friction: crate::scene::DEFAULT_FRICTION,
            bulk: BulkIntegration::Points,
        }
    }
}

/// Inference of new shapes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InferenceParams {
    /// Surface points the network encodes. Default 4096 (the trained count).
    pub surface_points: usize,
    /// Interior points that fix the output normalization. Default 2048.
    pub reference_points: usize,
    /// Voxels across the longest side for the inside test. Default 64.
    pub voxel_resolution: usize,
    /// Threads for inference, kept apart from the stepping thread. Default 1.
    pub threads: usize,
    /// A cloud with more points is read from a voxel-downsampled copy of this many (every point
    /// is still deformed). Default 20,000.
    pub max_build_points: usize,
    /// How long a new object's network field is refined toward the skinning eigenmodes:
    /// `off`, `full`, or a budget in milliseconds. The object starts on the network's field
    /// at once and switches to the refined one when it is ready (replay, which is offline,
    /// refines a fixed number of iterations instead, so that it stays reproducible). Default
    /// "60": with the network's ~45 ms and the tet mesh, a new shape's basis within 150 ms.
    pub refine: String,
}

impl Default for InferenceParams {
    fn default() -> Self {
        Self {
            surface_points: 4096,
            reference_points: 2048,
            voxel_resolution: 64,
            threads: 1,
            max_build_points: crate::pipeline::DEFAULT_MAX_BUILD_POINTS,
            refine: crate::skinning::DEFAULT_REFINE_MS.to_string(),
        }
    }
}

/// Which outputs are published.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PublishParams {
    /// Deformed clouds per second, at most the step rate; 0: one per step. Default 0.
    pub rate_hz: f64,
    /// Publish the deformed points. Default true.
    pub deformed_points: bool,
    /// Publish each shape's weights as physskin/SkinningWeights. Default true.
    pub weights: bool,
    /// Publish each shape's weights as a PointCloud2. Default true.
    pub weights_cloud: bool,
    /// Publish the reduced state after each step. Default true.
    pub state: bool,
}

impl Default for PublishParams {
    fn default() -> Self {
        Self {
            rate_hz: 0.0,
            deformed_points: true,
            weights: true,
            weights_cloud: true,
            state: true,
        }
    }
}

/// MCAP recording of the node's topics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RecordParams {
    /// The MCAP file to write; empty: no recording. Default "".
    pub path: String,
    /// Topics to record; empty: every input and output topic. Default [].
    pub topics: Vec<String>,
    /// Start a new file past this size, MB (files `<stem>_1.mcap`, ...); 0: never. Default 0.
    pub split_size_mb: f64,
    /// Start a new file past this much log time, s; 0: never. Default 0.
    pub split_duration_s: f64,
}

impl Default for RecordParams {
    fn default() -> Self {
        Self {
            path: String::new(),
            topics: Vec::new(),
            split_size_mb: 0.0,
            split_duration_s: 0.0,
        }
    }
}

/// Zero-copy hand-off of the deformed points and weights to local programs (iceoryx2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShmParams {
    /// Publish on iceoryx2 besides DDS. Default true.
    pub enabled: bool,
    /// Default "physskin/deformed_points".
    pub deformed_service: String,
    /// Default "physskin/weights".
    pub weights_service: String,
}

impl Default for ShmParams {
    fn default() -> Self {
        let o = crate::shm::ShmOptions::default();
        Self {
            enabled: true,
            deformed_service: o.deformed_service,
            weights_service: o.weights_service,
        }
    }
}

/// tf2: the transforms of /tf and /tf_static.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TfParams {
    /// How long dynamic transforms are kept, s. Default 10.
    pub buffer_s: f64,
    /// How long an input waits for its transform before it is refused, s. Default 0.5.
    pub timeout_s: f64,
}

impl Default for TfParams {
    fn default() -> Self {
        Self {
            buffer_s: 10.0,
            timeout_s: 0.5,
        }
    }
}

/// The deformed surfaces as RViz markers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MarkerParams {
    /// Marker arrays per second (at most the step rate); 0: none. Default 15.
    pub rate_hz: f64,
}

impl Default for MarkerParams {
    fn default() -> Self {
        Self { rate_hz: 15.0 }
    }
}

/// The robot the ROS graph describes, as robot_state_publisher publishes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RobotParams {
    /// std_msgs/String topic (transient local) carrying the robot's URDF; its links' collision
    /// shapes push and hold every object in `fixed_frame`, and a new URDF replaces the robot.
    /// "": no robot from the graph. Read-only after start. Default "robot_description".
    pub description_topic: String,
    /// sensor_msgs/JointState topic of its joints. Read-only after start. Default
    /// "joint_states".
    pub joint_states_topic: String,
    /// A link whose pose /tf gives in `fixed_frame` is placed there, not by the joints. Its
    /// root link stands where /tf puts it, or at the fixed frame's origin. Default true.
    pub links_from_tf: bool,
}

impl Default for RobotParams {
    fn default() -> Self {
        Self {
            description_topic: "robot_description".into(),
            joint_states_topic: "joint_states".into(),
            links_from_tf: true,
        }
    }
}

impl RobotParams {
    /// The topic names resolved for the node of `names` ("" stays "": no robot).
    pub fn resolved(&self, names: &NameResolver) -> Result<Self, NameError> {
        if self.description_topic.is_empty() {
            return Ok(self.clone());
        }
        Ok(Self {
            description_topic: names.resolve(&self.description_topic)?,
            joint_states_topic: names.resolve(&self.joint_states_topic)?,
            links_from_tf: self.links_from_tf,
        })
    }
}

/// The Foxglove WebSocket live view.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FoxgloveParams {
    /// ADDR:PORT the Foxglove WebSocket server listens on (`physskin node --foxglove` gives
    /// 127.0.0.1:8765); an address other than loopback is reachable from other machines.
    /// Read-only after start. Default "" (no server).
    pub address: String,
}

impl FoxgloveParams {
    /// The address to listen on; None when off, an error naming a value that is not IP:PORT.
    pub fn socket_address(&self) -> crate::Result<Option<std::net::SocketAddr>> {
        if self.address.is_empty() {
            return Ok(None);
        }
        self.address
            .parse()
            .map(Some)
            .map_err(|e| crate::Error::InvalidParameter {
                name: "foxglove.address",
                reason: format!("`{}` is not IP:PORT ({e})", self.address),
            })
    }
}

/// Objects split among instances (see [`Shard`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct InstanceParams {
    /// `"k/N"`: this instance takes the labelled objects whose id is k modulo N, and the
    /// objects of the frames whose name hashes to k modulo N; N instances take every object
    /// once. Read-only after start. Default "" (every object).
    pub shard: String,
}

/// Every node parameter, each named by its dotted ROS path (`material.young`): set one with
/// [`NodeParams::with`], a file's with [`NodeParams::from_yaml_file`], read them all with
/// [`NodeParams::flattened`]; config/physskin.yaml lists them with their defaults. The groups
/// are not public fields: a parameter is what `ros2 param` sees, checked on the way in.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NodeParams {
    /// Steps per second (of sim time when use_sim_time). Read-only after start. Default 60.
    pub(crate) rate_hz: f64,
    /// Take time from /clock. Read-only after start. Default false.
    pub(crate) use_sim_time: bool,
    /// Largest cloud or mesh accepted, points. Default 1,000,000.
    pub(crate) max_points: usize,
    /// Frame of shape_msgs/Mesh inputs, which carry none. Default "world".
    pub(crate) mesh_frame: String,
    /// With a frame here, inputs are transformed into it (tf2, at their stamp) and simulated
    /// there: gravity, the floor and the outputs are in this frame. Default "": each object
    /// lives in its input's own frame.
    pub(crate) fixed_frame: String,
    /// Height of the floor (support: floor) in the fixed frame, m. Without a fixed frame the
    /// floor is the object's lowest point. Default 0.
    pub(crate) floor_z: f64,
    /// An object whose frame (or label) sends no geometry for this long is removed, s; 0: never.
    /// Default 0.
    pub(crate) object_timeout_s: f64,
    /// The field of a cloud that splits it into objects by instance id (0: background). With
    /// the default, "instance", also `label`, `segment` or `object_id`. Default "instance".
    pub(crate) instance_field: String,
    /// The tf2 buffer and wait.
    pub(crate) tf: TfParams,
    /// RViz markers of the deformed surfaces.
    pub(crate) markers: MarkerParams,
    /// Topic names.
    pub(crate) topics: Topics,
    /// Material of new shapes.
    pub(crate) material: MaterialParams,
    /// Simulation of new shapes.
    pub(crate) simulation: SimulationParams,
    /// Inference of new shapes.
    pub(crate) inference: InferenceParams,
    /// Which outputs are published.
    pub(crate) publish: PublishParams,
    /// MCAP recording.
    pub(crate) record: RecordParams,
    /// The iceoryx2 hand-off.
    pub(crate) shm: ShmParams,
    /// Streams of clouds: later frames of a running object correct it.
    pub(crate) tracking: TrackingParams,
    /// Objects split among instances.
    pub(crate) instances: InstanceParams,
    /// The robot from `robot_description`.
    pub(crate) robot: RobotParams,
    /// The Foxglove live view.
    pub(crate) foxglove: FoxgloveParams,
    /// Scene file (config/scenes/*.yaml): its objects are built and simulated, and its robots
    /// follow their joint-state topics. Read-only after start. Default "" (none).
    pub(crate) scene: String,
}

impl Default for NodeParams {
    fn default() -> Self {
        Self {
            rate_hz: 60.0,
            use_sim_time: false,
            max_points: 1_000_000,
            mesh_frame: "world".into(),
            fixed_frame: String::new(),
            floor_z: 0.0,
            object_timeout_s: 0.0,
            instance_field: "instance".into(),
            tf: TfParams::default(),
            markers: MarkerParams::default(),
            topics: Topics::default(),
            material: MaterialParams::default(),
            simulation: SimulationParams::default(),
            inference: InferenceParams::default(),
            publish: PublishParams::default(),
            record: RecordParams::default(),
            shm: ShmParams::default(),
            tracking: TrackingParams::default(),
            instances: InstanceParams::default(),
            robot: RobotParams::default(),
            foxglove: FoxgloveParams::default(),
            scene: String::new(),
        }
    }
}

/// Parameters that only take effect at start; `ros2 param set` on them is refused.
pub(crate) const READ_ONLY: [&str; 15] = [
    "instances.",
    "foxglove.",
    "robot.description_topic",
    "robot.joint_states_topic",
    "rate_hz",
    "publish.rate_hz",
    "fixed_frame",
    "tf.",
    "markers.",
    "scene",
    "use_sim_time",
    "topics.",
    "inference.threads",
    "record.",
    "shm.",
];

impl NodeParams {
    /// A copy with one dotted parameter replaced, type-checked and validated.
    pub fn with(&self, name: &str, value: Value) -> Result<Self, ParamError> {
        let invalid = |reason: String| ParamError::Invalid {
            name: name.into(),
            reason,
        };
        let mut json = serde_json::to_value(self).expect("parameters serialize");
        let mut slot = &mut json;
        for part in name.split('.') {
            slot = slot
                .as_object_mut()
                .and_then(|o| o.get_mut(part))
                .ok_or_else(|| ParamError::Unknown { name: name.into() })?;
        }
        if slot.is_object() {
            return Err(invalid("a group of parameters, not one".into()));
        }
        *slot = value;
        let params: Self = serde_json::from_value(json).map_err(|e| invalid(e.to_string()))?;
        params.validate().map_err(|e| invalid(e.to_string()))?;
        Ok(params)
    }

    /// [`NodeParams::with`] while the node runs (`ros2 param set`, a Foxglove client): the
    /// parameters that only take effect at start are refused.
    pub(crate) fn with_while_running(&self, name: &str, value: Value) -> Result<Self, ParamError> {
        if READ_ONLY
            .iter()
            .any(|r| name == *r || (r.ends_with('.') && name.starts_with(r)))
        {
            return Err(ParamError::Invalid {
                name: name.into(),
                reason: "read-only while the node runs: set it in the parameter file".into(),
            });
        }
        self.with(name, value)
    }

    /// Checks every parameter's range, the solver's name and the simulation parameters
    /// they make. An `Error::InvalidParameter` naming the first out of range.
    pub fn validate(&self) -> crate::Result<()> {
        use crate::error::ensure;
        ensure(
            self.rate_hz > 0.0 && self.rate_hz <= 1000.0,
            "rate_hz",
            || format!("{} is outside (0, 1000] Hz", self.rate_hz),
        )?;
        ensure(self.max_points >= 4, "max_points", || {
            "must be at least 4".into()
        })?;
        ensure(
            self.simulation.cubature >= 16,
            "simulation.cubature",
            || {
                format!(
                    "{} points are too few (at least 16)",
                    self.simulation.cubature
                )
            },
        )?;
        ensure(
            (16..=256).contains(&self.inference.voxel_resolution),
            "inference.voxel_resolution",
            || format!("{} is outside 16..=256", self.inference.voxel_resolution),
        )?;
        ensure(
            self.inference.surface_points >= 64 && self.inference.reference_points >= 64,
            "inference.surface_points",
            || "surface and reference points must be at least 64".into(),
        )?;
        ensure(self.inference.threads >= 1, "inference.threads", || {
            "at least 1".into()
        })?;
        ensure(
            self.inference.max_build_points >= 200,
            "inference.max_build_points",
            || {
                format!(
                    "{} is too few to read a shape from (at least 200)",
                    self.inference.max_build_points
                )
            },
        )?;
        if let Err(reason) = self.inference.refine.parse::<RefineBudget>() {
            return Err(crate::Error::InvalidParameter {
                name: "inference.refine",
                reason,
            });
        }
        ensure(
            self.publish.rate_hz >= 0.0 && self.publish.rate_hz.is_finite(),
            "publish.rate_hz",
            || {
                format!(
                    "{} is not 0 (every step) or a positive rate",
                    self.publish.rate_hz
                )
            },
        )?;
        let shard = self.shard()?;
        ensure(
            shard.index_is_first() || self.scene.is_empty(),
            "instances.shard",
            || {
                format!("{shard} with a scene: a scene's objects are simulated by shard 0 alone, give the scene to that instance")
            },
        )?;
        ensure(!self.instance_field.is_empty(), "instance_field", || {
            "empty: name the field that holds instance ids".into()
        })?;
        ensure(
            self.record.split_size_mb >= 0.0 && self.record.split_duration_s >= 0.0,
            "record.split_size_mb",
            || "split sizes and durations are 0 (off) or positive".into(),
        )?;
        ensure(
            self.tf.buffer_s > 0.0 && self.tf.timeout_s >= 0.0 && self.tf.timeout_s.is_finite(),
            "tf.buffer_s",
            || "the buffer is positive and the timeout 0 or more seconds".into(),
        )?;
        ensure(
            self.markers.rate_hz >= 0.0 && self.markers.rate_hz.is_finite(),
            "markers.rate_hz",
            || format!("{} is not 0 (off) or a positive rate", self.markers.rate_hz),
        )?;
        ensure(
            self.object_timeout_s >= 0.0 && self.object_timeout_s.is_finite(),
            "object_timeout_s",
            || {
                format!(
                    "{} is not 0 (never) or a positive time",
                    self.object_timeout_s
                )
            },
        )?;
        ensure(self.floor_z.is_finite(), "floor_z", || "not finite".into())?;
        ensure(
            self.simulation.friction >= 0.0 && self.simulation.friction.is_finite(),
            "simulation.friction",
            || {
                format!(
                    "{} is not 0 or a positive coefficient",
                    self.simulation.friction
                )
            },
        )?;
        self.tracking.validate()?;
        self.foxglove.socket_address()?;
        self.solver()?;
        self.sim_params().validate()
    }

    /// This instance's share of the objects (`instances.shard`); an `Error::InvalidParameter`
    /// when it is not k/N.
    pub(crate) fn shard(&self) -> crate::Result<Shard> {
        Shard::parse(&self.instances.shard).map_err(|reason| crate::Error::InvalidParameter {
            name: "instances.shard",
            reason,
        })
    }

    /// The solver named by `simulation.solver`; an `Error::InvalidParameter` for another name.
    pub(crate) fn solver(&self) -> crate::Result<Solver> {
        match self.simulation.solver.as_str() {
            "newton" => Ok(Solver::Newton),
            "quasi_newton" => Ok(Solver::QuasiNewton),
            other => Err(crate::Error::InvalidParameter {
                name: "simulation.solver",
                reason: format!("`{other}` is neither newton nor quasi_newton"),
            }),
        }
    }

    /// The simulation parameters of new shapes.
    pub(crate) fn sim_params(&self) -> SimParams {
        SimParams {
            young: self.material.young,
            poisson: self.material.poisson,
            density: self.material.density,
            dt: 1.0 / self.rate_hz,
            gravity: Vector3::from(self.simulation.gravity),
            damping: self.simulation.damping,
            friction: self.simulation.friction,
            bulk: self.simulation.bulk,
            ..SimParams::default()
        }
    }

    /// How long a new object's field is refined (`inference.refine`, validated).
    pub(crate) fn refine_budget(&self) -> RefineBudget {
        self.inference.refine.parse().unwrap_or(RefineBudget::Off)
    }

    /// How new shapes are built and simulated.
    pub(crate) fn body_options(&self) -> crate::Result<BodyOptions> {
        Ok(BodyOptions {
            surface_points: self.inference.surface_points,
            reference_points: self.inference.reference_points,
            voxel_resolution: self.inference.voxel_resolution,
            cubature: self.simulation.cubature,
            sim: self.sim_params(),
            solver: self.solver()?,
            support: self.simulation.support,
            floor_z: (!self.fixed_frame.is_empty()).then_some(self.floor_z),
            // The node starts an object on the network's field and refines it on another
            // thread (`inference.refine`), so that the first deformed cloud does not wait.
            refine: RefineBudget::Off,
            ..BodyOptions::default()
        })
    }

    /// Every parameter by dotted name, with its value.
    pub fn flattened(&self) -> Vec<(String, Value)> {
        let json = serde_json::to_value(self).expect("parameters serialize");
        let Value::Object(map) = json else {
            unreachable!("a struct serializes to an object")
        };
        flatten(&map, "")
    }
}

/// Every leaf of a parameter map by dotted name.
pub(crate) fn flatten(map: &Map<String, Value>, prefix: &str) -> Vec<(String, Value)> {
    let mut out = Vec::new();
    for (key, value) in map {
        let name = format!("{prefix}{key}");
        match value {
            Value::Object(inner) => out.extend(flatten(inner, &format!("{name}."))),
            other => out.push((name, other.clone())),
        }
    }
    out
}

#[cfg(test)]
mod shipped_file {
    use super::*;
    use std::path::Path;

    /// config/physskin.yaml states the defaults: loading it changes nothing.
    #[test]
    fn shipped_parameter_file_is_the_defaults() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("config/physskin.yaml");
        let params = NodeParams::from_yaml_file(&path, "/physskin").unwrap();
        assert_eq!(params, NodeParams::default());
    }

    /// A shard that is not k/N, or another shard than 0 with a scene, is refused by name.
    #[test]
    fn a_bad_shard_is_refused_naming_it() {
        let p = NodeParams::default();
        let e = p.with("instances.shard", Value::from("2/2")).unwrap_err();
        assert!(
            e.to_string().contains("instances.shard") && e.to_string().contains("2/2"),
            "{e}"
        );
        let mut scened = p.clone();
        scened.scene = "config/scenes/press.yaml".into();
        let e = scened
            .with("instances.shard", Value::from("1/2"))
            .unwrap_err();
        assert!(e.to_string().contains("shard 0"), "{e}");
        assert!(scened.with("instances.shard", Value::from("0/2")).is_ok());
    }

    /// `simulation.bulk` reaches the bodies the node builds; another name is refused by name.
    #[test]
    fn the_bulk_term_is_chosen_by_name() {
        let p = NodeParams::default();
        assert_eq!(p.body_options().unwrap().sim.bulk, BulkIntegration::Points);
        let regions = p.with("simulation.bulk", Value::from("regions")).unwrap();
        assert_eq!(
            regions.body_options().unwrap().sim.bulk,
            BulkIntegration::Regions
        );
        let e = p
            .with("simulation.bulk", Value::from("pressure"))
            .unwrap_err();
        assert!(e.to_string().contains("bulk"), "{e}");
    }
}
