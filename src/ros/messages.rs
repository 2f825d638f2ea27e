//! ROS 2 message types, as plain structs whose serde layout is exactly the CDR layout of their
//! .msg files (fields in declaration order; constants are not serialized).
//!
//! Each struct is declared through `ros_message!`, which also records its fields with ROS types
//! derived from the Rust types, so a test can hold them against the .msg files in `msg/`.

use serde::{Deserialize, Serialize};

/// The ROS 2 type of a Rust field type ("uint32", "float32[]", "std_msgs/Header").
pub trait RosType {
    fn ros_type() -> String;
}

macro_rules! primitive {
    ($($rust:ty => $ros:literal),* $(,)?) => {
        $(impl RosType for $rust {
            fn ros_type() -> String {
                $ros.into()
            }
        })*
    };
}

primitive!(bool => "bool", u8 => "uint8", i8 => "int8", u16 => "uint16", i16 => "int16",
    u32 => "uint32", i32 => "int32", u64 => "uint64", i64 => "int64", f32 => "float32",
    f64 => "float64", String => "string");

impl<T: RosType> RosType for Vec<T> {
    fn ros_type() -> String {
        format!("{}[]", T::ros_type())
    }
}

impl<T: RosType, const N: usize> RosType for [T; N] {
    fn ros_type() -> String {
        format!("{}[{N}]", T::ros_type())
    }
}

/// A message type: its package, name and fields (name, ROS type) in wire order.
pub trait RosMessage:
    Serialize + for<'de> Deserialize<'de> + Send + std::fmt::Debug + 'static
{
    const PACKAGE: &'static str;
    const NAME: &'static str;
    fn fields() -> Vec<(&'static str, String)>;

    /// "pkg/msg/Name", as in MCAP schemas and `ros2 topic info`.
    fn type_name() -> String {
        format!("{}/msg/{}", Self::PACKAGE, Self::NAME)
    }
}

macro_rules! ros_message {
    ($(#[$meta:meta])* $name:ident = $pkg:literal {
        $($(#[$field_meta:meta])* $field:ident : $ty:ty),* $(,)?
    }) => {
        $(#[$meta])*
        #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
        pub struct $name {
            $($(#[$field_meta])* pub $field: $ty),*
        }

        impl RosType for $name {
            fn ros_type() -> String {
                format!("{}/{}", $pkg, stringify!($name))
            }
        }

        impl RosMessage for $name {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = stringify!($name);
            fn fields() -> Vec<(&'static str, String)> {
                vec![$((stringify!($field).trim_start_matches("r#"), <$ty as RosType>::ros_type())),*]
            }
        }
    };
}

ros_message!(
    /// builtin_interfaces/msg/Time.
    Time = "builtin_interfaces" { sec: i32, nanosec: u32 }
);

impl Time {
    pub fn from_nanos(nanos: i64) -> Self {
        Self {
            sec: nanos.div_euclid(1_000_000_000) as i32,
            nanosec: nanos.rem_euclid(1_000_000_000) as u32,
        }
    }

    pub fn nanos(&self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
}

ros_message!(
    /// rosgraph_msgs/msg/Clock: the simulated time of a replay.
    Clock = "rosgraph_msgs" { clock: Time }
);

ros_message!(
    /// std_msgs/msg/Header.
    Header = "std_msgs" { stamp: Time, frame_id: String }
);

ros_message!(
    /// geometry_msgs/msg/Point.
    Point = "geometry_msgs" { x: f64, y: f64, z: f64 }
);

ros_message!(
    /// geometry_msgs/msg/Vector3.
    Vector3 = "geometry_msgs" { x: f64, y: f64, z: f64 }
);

ros_message!(
    /// sensor_msgs/msg/PointField. Datatypes: INT8 1, UINT8 2, INT16 3, UINT16 4, INT32 5,
    /// UINT32 6, FLOAT32 7, FLOAT64 8.
    PointField = "sensor_msgs" { name: String, offset: u32, datatype: u8, count: u32 }
);

ros_message!(
    /// sensor_msgs/msg/PointCloud2: read it with `decode_cloud` (module `ros::cloud`).
    PointCloud2 = "sensor_msgs" {
        header: Header,
        height: u32,
        width: u32,
        fields: Vec<PointField>,
        is_bigendian: bool,
        point_step: u32,
        row_step: u32,
        data: Vec<u8>,
        is_dense: bool,
    }
);

ros_message!(
    /// shape_msgs/msg/MeshTriangle.
    MeshTriangle = "shape_msgs" { vertex_indices: [u32; 3] }
);

ros_message!(
    /// shape_msgs/msg/Mesh (no header: the node takes its frame from the `mesh_frame` parameter).
    Mesh = "shape_msgs" { triangles: Vec<MeshTriangle>, vertices: Vec<Point> }
);

ros_message!(
    /// physskin/msg/MeshStamped: a mesh with its frame.
    MeshStamped = "physskin" { header: Header, mesh: Mesh }
);

ros_message!(
    /// physskin/msg/SkinningWeights: points x handles, row-major.
    SkinningWeights = "physskin" {
        header: Header,
        shape_id: u32,
        point_count: u32,
        handle_count: u32,
        weights: Vec<f32>,
    }
);

ros_message!(
    /// physskin/msg/SubspaceState: the reduced state after a step.
    SubspaceState = "physskin" {
        header: Header,
        shape_id: u32,
        handle_count: u32,
        z: Vec<f64>,
        z_velocity: Vec<f64>,
        elastic_energy: f64,
        kinetic_energy: f64,
        gravity_energy: f64,
        newton_iterations: u32,
        converged: bool,
        fallback: bool,
        residual: f64,
        step_time_ms: f64,
        sleeping: bool,
        cubature_points: u32,
        decision: String,
    }
);

ros_message!(
    /// sensor_msgs/msg/JointState: joint positions (rad, m) by name; velocity and effort may be
    /// empty.
    JointState = "sensor_msgs" {
        header: Header,
        name: Vec<String>,
        position: Vec<f64>,
        velocity: Vec<f64>,
        effort: Vec<f64>,
    }
);

ros_message!(
    /// physskin/msg/Interaction: a force, pin or release (see the constants below).
    Interaction = "physskin" {
        header: Header,
        shape_id: u32,
        kind: u8,
        point: Point,
        force: Vector3,
        duration: f64,
        radius: f64,
    }
);

impl Interaction {
    pub const FORCE: u8 = 0;
    pub const PIN: u8 = 1;
    pub const RELEASE: u8 = 2;
    pub const REMOVE: u8 = 3;
}

ros_message!(
    /// physskin/msg/Status: what the node did with an input, and why.
    Status = "physskin" {
        header: Header,
        shape_id: u32,
        level: u8,
        event: String,
        message: String,
    }
);

impl Status {
    pub const INFO: u8 = 0;
    pub const WARN: u8 = 1;
    pub const ERROR: u8 = 2;
}

ros_message!(
    /// geometry_msgs/msg/Quaternion (x, y, z, w).
    Quaternion = "geometry_msgs" { x: f64, y: f64, z: f64, w: f64 }
);

ros_message!(
    /// geometry_msgs/msg/Transform: a frame's pose in its parent.
    Transform = "geometry_msgs" { translation: Vector3, rotation: Quaternion }
);

ros_message!(
    /// geometry_msgs/msg/TransformStamped: `child_frame_id` in `header.frame_id`.
    TransformStamped = "geometry_msgs" {
        header: Header,
        child_frame_id: String,
        transform: Transform,
    }
);

ros_message!(
    /// tf2_msgs/msg/TFMessage, on /tf and /tf_static.
    TFMessage = "tf2_msgs" { transforms: Vec<TransformStamped> }
);

ros_message!(
    /// diagnostic_msgs/msg/KeyValue.
    KeyValue = "diagnostic_msgs" { key: String, value: String }
);

ros_message!(
    /// diagnostic_msgs/msg/DiagnosticStatus (level: OK 0, WARN 1, ERROR 2, STALE 3).
    DiagnosticStatus = "diagnostic_msgs" {
        level: u8,
        name: String,
        message: String,
        hardware_id: String,
        values: Vec<KeyValue>,
    }
);

impl DiagnosticStatus {
    pub const OK: u8 = 0;
    pub const WARN: u8 = 1;
    pub const ERROR: u8 = 2;
}

ros_message!(
    /// diagnostic_msgs/msg/DiagnosticArray, on /diagnostics.
    DiagnosticArray = "diagnostic_msgs" { header: Header, status: Vec<DiagnosticStatus> }
);

ros_message!(
    /// geometry_msgs/msg/Pose.
    Pose = "geometry_msgs" { position: Point, orientation: Quaternion }
);

ros_message!(
    /// std_msgs/msg/ColorRGBA, each in [0, 1].
    ColorRGBA = "std_msgs" { r: f32, g: f32, b: f32, a: f32 }
);

ros_message!(
    /// builtin_interfaces/msg/Duration.
    Duration = "builtin_interfaces" { sec: i32, nanosec: u32 }
);

ros_message!(
    /// sensor_msgs/msg/CompressedImage (a Marker's texture; empty here).
    CompressedImage = "sensor_msgs" { header: Header, format: String, data: Vec<u8> }
);

ros_message!(
    /// visualization_msgs/msg/UVCoordinate.
    UVCoordinate = "visualization_msgs" { u: f32, v: f32 }
);

ros_message!(
    /// visualization_msgs/msg/MeshFile.
    MeshFile = "visualization_msgs" { filename: String, data: Vec<u8> }
);

ros_message!(
    /// visualization_msgs/msg/Marker, in its Jazzy layout (with texture and mesh_file).
    Marker = "visualization_msgs" {
        header: Header,
        ns: String,
        id: i32,
        r#type: i32,
        action: i32,
        pose: Pose,
        scale: Vector3,
        color: ColorRGBA,
        lifetime: Duration,
        frame_locked: bool,
        points: Vec<Point>,
        colors: Vec<ColorRGBA>,
        texture_resource: String,
        texture: CompressedImage,
        uv_coordinates: Vec<UVCoordinate>,
        text: String,
        mesh_resource: String,
        mesh_file: MeshFile,
        mesh_use_embedded_materials: bool,
    }
);

impl Marker {
    pub const TRIANGLE_LIST: i32 = 11;
    pub const ADD: i32 = 0;
    pub const DELETE: i32 = 2;
}

ros_message!(
    /// visualization_msgs/msg/MarkerArray.
    MarkerArray = "visualization_msgs" { markers: Vec<Marker> }
);

ros_message!(
    /// std_srvs/srv/Trigger's request: no field, so IDL gives it one placeholder byte.
    TriggerRequest = "std_srvs" { structure_needs_at_least_one_member: u8 }
);

ros_message!(
    /// std_srvs/srv/Trigger's response.
    TriggerResponse = "std_srvs" { success: bool, message: String }
);

/// Serializes a message to CDR little-endian with its 4-byte encapsulation header, as on the
/// wire and in MCAP.
pub fn to_cdr<M: Serialize>(message: &M) -> Vec<u8> {
    let mut bytes = vec![0x00, 0x01, 0x00, 0x00];
    bytes.extend(
        cdr_encoding::to_vec::<M, byteorder::LittleEndian>(message)
            .expect("plain message structs always serialize"),
    );
    bytes
}

/// `to_cdr`, with a fast path for PointCloud2, whose data serde would write byte by byte.
pub fn encode<M: RosMessage>(message: &M) -> Vec<u8> {
    match (message as &dyn std::any::Any).downcast_ref::<PointCloud2>() {
        Some(cloud) => cloud_to_cdr(cloud),
        None => to_cdr(message),
    }
}

/// CDR little-endian: primitives aligned to their size, counted from the end of the
/// encapsulation header; strings and sequences prefixed by a u32 count (strings count their NUL).
struct CdrWriter {
    bytes: Vec<u8>,
}

impl CdrWriter {
    fn align(&mut self, n: usize) {
        while (self.bytes.len() - 4) % n != 0 {
            self.bytes.push(0);
        }
    }

    fn u32(&mut self, v: u32) {
        self.align(4);
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }

    fn i32(&mut self, v: i32) {
        self.align(4);
        self.bytes.extend_from_slice(&v.to_le_bytes());
    }

    fn u8(&mut self, v: u8) {
        self.bytes.push(v);
    }

    fn string(&mut self, s: &str) {
        self.u32(s.len() as u32 + 1);
        self.bytes.extend_from_slice(s.as_bytes());
        self.bytes.push(0);
    }
}

fn cloud_to_cdr(c: &PointCloud2) -> Vec<u8> {
    let mut w = CdrWriter {
        bytes: Vec::with_capacity(c.data.len() + 256),
    };
    w.bytes.extend_from_slice(&[0x00, 0x01, 0x00, 0x00]);
    w.i32(c.header.stamp.sec);
    w.u32(c.header.stamp.nanosec);
    w.string(&c.header.frame_id);
    w.u32(c.height);
    w.u32(c.width);
    w.u32(c.fields.len() as u32);
    for f in &c.fields {
        w.string(&f.name);
        w.u32(f.offset);
        w.u8(f.datatype);
        w.u32(f.count);
    }
    w.u8(c.is_bigendian as u8);
    w.u32(c.point_step);
    w.u32(c.row_step);
    w.u32(c.data.len() as u32);
    w.bytes.extend_from_slice(&c.data);
    w.u8(c.is_dense as u8);
    w.bytes
}

/// Parses CDR with its encapsulation header (either byte order).
pub fn from_cdr<M: for<'de> Deserialize<'de>>(bytes: &[u8]) -> Result<M, String> {
    if bytes.len() < 4 {
        return Err(format!(
            "{} bytes, shorter than the CDR header",
            bytes.len()
        ));
    }
    let body = &bytes[4..];
    let parsed = match bytes[1] {
        0x00 => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        0x01 => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        other => return Err(format!("unknown CDR representation {other:#04x}")),
    };
    parsed.map(|(m, _)| m).map_err(|e| format!("bad CDR: {e}"))
}
