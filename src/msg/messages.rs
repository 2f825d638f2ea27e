//! ROS 2 message types, as plain structs whose serde layout is exactly the CDR layout of their
//! .msg files (fields in declaration order; constants are not serialized).
//!
//! Each struct is declared through `ros_message!`, which also records its fields with ROS types
//! derived from the Rust types, so a test can hold them against the .msg files in `msg/`.

use serde::{Deserialize, Serialize};

/// The ROS 2 type of a Rust field type ("uint32", "float32[]", "std_msgs/Header").
pub(crate) trait RosType {
    /// The type as a .msg file writes it.
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
    /// The package ("sensor_msgs").
    const PACKAGE: &'static str;
    /// The message's name ("PointCloud2").
    const NAME: &'static str;
    /// The fields in wire order: (name, ROS type).
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
    Time = "builtin_interfaces" {
        /// Whole seconds.
        sec: i32,
        /// Nanoseconds past `sec`, below 1e9.
        nanosec: u32,
    }
);

impl Time {
    /// The time `nanos` nanoseconds from 0 (before 0, `sec` rounds down and `nanosec` stays
    /// positive).
    pub fn from_nanos(nanos: i64) -> Self {
        Self {
            sec: nanos.div_euclid(1_000_000_000) as i32,
            nanosec: nanos.rem_euclid(1_000_000_000) as u32,
        }
    }

    /// The time in nanoseconds.
    pub fn nanos(&self) -> i64 {
        self.sec as i64 * 1_000_000_000 + self.nanosec as i64
    }
}

ros_message!(
    /// rosgraph_msgs/msg/Clock: the simulated time of a replay.
    Clock = "rosgraph_msgs" {
        /// The simulated time.
        clock: Time,
    }
);

ros_message!(
    /// std_msgs/msg/Header.
    Header = "std_msgs" {
        /// When the data was taken or made.
        stamp: Time,
        /// The frame the data is in.
        frame_id: String,
    }
);

ros_message!(
    /// geometry_msgs/msg/Point.
    Point = "geometry_msgs" {
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
        /// z, m.
        z: f64,
    }
);

ros_message!(
    /// geometry_msgs/msg/Vector3.
    Vector3 = "geometry_msgs" {
        /// x component.
        x: f64,
        /// y component.
        y: f64,
        /// z component.
        z: f64,
    }
);

ros_message!(
    /// sensor_msgs/msg/PointField. Datatypes: INT8 1, UINT8 2, INT16 3, UINT16 4, INT32 5,
    /// UINT32 6, FLOAT32 7, FLOAT64 8.
    PointField = "sensor_msgs" {
        /// The field's name ("x", "rgb", "instance", ...).
        name: String,
        /// Where the field starts in a point's record, bytes.
        offset: u32,
        /// The type of its values (the numbers above).
        datatype: u8,
        /// Values in the field (1 for a scalar).
        count: u32,
    }
);

ros_message!(
    /// sensor_msgs/msg/PointCloud2: read it with `decode_cloud` (module `msg::cloud`).
    PointCloud2 = "sensor_msgs" {
        /// The sensor's frame and the time of the scan.
        header: Header,
        /// Rows; 1 for an unorganized cloud.
        height: u32,
        /// Points per row.
        width: u32,
        /// What each point's record holds, and where.
        fields: Vec<PointField>,
        /// Byte order of the values in `data`.
        is_bigendian: bool,
        /// Bytes per point record.
        point_step: u32,
        /// Bytes per row.
        row_step: u32,
        /// `height` rows of `row_step` bytes.
        data: Vec<u8>,
        /// True when no point is invalid (NaN).
        is_dense: bool,
    }
);

ros_message!(
    /// shape_msgs/msg/MeshTriangle.
    MeshTriangle = "shape_msgs" {
        /// The corners, as indices into the mesh's vertices.
        vertex_indices: [u32; 3],
    }
);

ros_message!(
    /// shape_msgs/msg/Mesh (no header: the node takes its frame from the `mesh_frame` parameter).
    Mesh = "shape_msgs" {
        /// The triangles.
        triangles: Vec<MeshTriangle>,
        /// The vertices, m.
        vertices: Vec<Point>,
    }
);

ros_message!(
    /// physskin/msg/MeshStamped: a mesh with its frame.
    MeshStamped = "physskin" {
        /// The mesh's frame and stamp.
        header: Header,
        /// The mesh.
        mesh: Mesh,
    }
);

ros_message!(
    /// physskin/msg/SkinningWeights: points x handles, row-major.
    SkinningWeights = "physskin" {
        /// The shape's output frame and the time the weights were published.
        header: Header,
        /// The shape.
        shape_id: u32,
        /// Rows: the shape's input points (NaN points dropped).
        point_count: u32,
        /// Columns: handles, the rigid one included.
        handle_count: u32,
        /// point_count x handle_count, row-major; column 0 is the rigid handle, 1 everywhere.
        weights: Vec<f32>,
    }
);

ros_message!(
    /// physskin/msg/SubspaceState: the reduced state after a step.
    SubspaceState = "physskin" {
        /// The shape's output frame and the time of the step.
        header: Header,
        /// The shape.
        shape_id: u32,
        /// Handles, the rigid one included.
        handle_count: u32,
        /// The handle matrix Z (3 x 4 handle_count), row-major.
        z: Vec<f64>,
        /// dZ/dt, same layout, 1/s.
        z_velocity: Vec<f64>,
        /// Elastic energy after the step, J.
        elastic_energy: f64,
        /// Kinetic energy after the step, J.
        kinetic_energy: f64,
        /// Gravity's potential energy relative to the rest pose, J.
        gravity_energy: f64,
        /// Solver iterations the step took.
        newton_iterations: u32,
        /// Whether the step's solve met its tolerance.
        converged: bool,
        /// True when the quasi-Newton step was handed to full Newton.
        fallback: bool,
        /// Newton decrement |dz . g| at the last iteration, J.
        residual: f64,
        /// Wall-clock time of the step, ms (0 when timings are left out, as in replays).
        step_time_ms: f64,
        /// True while the shape sleeps (at rest and not stepped).
        sleeping: bool,
        /// Cubature points of the shape's subspace.
        cubature_points: u32,
        /// What was chosen for the shape (handles, cubature points) and why.
        decision: String,
        /// A tracked stream's last frame: RMS distance of its explained points to the surface
        /// before its correction, m (0 when not tracked).
        tracking_residual_m: f64,
        /// Surface samples that frame pulled (0 when not tracked).
        tracking_points: u32,
        /// Time of its correction, ms (0 when timings are left out, as in replays).
        tracking_ms: f64,
    }
);

ros_message!(
    /// sensor_msgs/msg/JointState: joint positions (rad, m) by name; velocity and effort may be
    /// empty.
    JointState = "sensor_msgs" {
        /// The time of the state.
        header: Header,
        /// Joint names.
        name: Vec<String>,
        /// Positions, rad or m, in the order of `name`.
        position: Vec<f64>,
        /// Velocities, rad/s or m/s; may be empty.
        velocity: Vec<f64>,
        /// Efforts, N m or N; may be empty.
        effort: Vec<f64>,
    }
);

/// std_msgs/msg/String: one string, as `robot_description` carries a URDF. (Named apart from
/// Rust's `String`, which `ros_message!` would have to shadow.)
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMessage {
    /// The text.
    pub data: String,
}

impl RosType for StringMessage {
    fn ros_type() -> String {
        "std_msgs/String".into()
    }
}

impl RosMessage for StringMessage {
    const PACKAGE: &'static str = "std_msgs";
    const NAME: &'static str = "String";
    fn fields() -> Vec<(&'static str, String)> {
        vec![("data", String::ros_type())]
    }
}

ros_message!(
    /// physskin/msg/Interaction: a force, pin or release (see the constants below).
    Interaction = "physskin" {
        /// Frame of `point` and `force` (empty: the frame of every shape) and stamp.
        header: Header,
        /// The shape to act on; 0: every shape whose frame matches.
        shape_id: u32,
        /// FORCE, PIN, RELEASE or REMOVE.
        kind: u8,
        /// FORCE: the rest position of the material point pushed; PIN, RELEASE: the region's
        /// centre.
        point: Point,
        /// FORCE only, N.
        force: Vector3,
        /// FORCE only: how long the force acts, s.
        duration: f64,
        /// PIN, RELEASE: the region's radius, m.
        radius: f64,
    }
);

impl Interaction {
    /// `kind`: a force on one material point for `duration`.
    pub const FORCE: u8 = 0;
    /// `kind`: the material within `radius` of `point` held where it is now.
    pub const PIN: u8 = 1;
    /// `kind`: pins within `radius` of `point` let go.
    pub const RELEASE: u8 = 2;
    /// `kind`: the shape (`shape_id`, or every shape of the frame) removed.
    pub const REMOVE: u8 = 3;
}

ros_message!(
    /// physskin/msg/Status: what the node did with an input, and why.
    Status = "physskin" {
        /// The time of the report.
        header: Header,
        /// The shape it concerns; 0 when none.
        shape_id: u32,
        /// INFO, WARN or ERROR.
        level: u8,
        /// A short machine-readable word: shape_ready, input_rejected, ...
        event: String,
        /// What happened, in words.
        message: String,
    }
);

impl Status {
    /// `level`: information.
    pub const INFO: u8 = 0;
    /// `level`: something was ignored or is not as it should be.
    pub const WARN: u8 = 1;
    /// `level`: an input or operation failed.
    pub const ERROR: u8 = 2;
}

ros_message!(
    /// geometry_msgs/msg/Quaternion (x, y, z, w).
    Quaternion = "geometry_msgs" {
        /// x.
        x: f64,
        /// y.
        y: f64,
        /// z.
        z: f64,
        /// w (1 for the identity).
        w: f64,
    }
);

ros_message!(
    /// geometry_msgs/msg/Transform: a frame's pose in its parent.
    Transform = "geometry_msgs" {
        /// The frame's origin in the parent, m.
        translation: Vector3,
        /// The frame's orientation in the parent.
        rotation: Quaternion,
    }
);

ros_message!(
    /// geometry_msgs/msg/TransformStamped: `child_frame_id` in `header.frame_id`.
    TransformStamped = "geometry_msgs" {
        /// The parent frame and the time of the transform.
        header: Header,
        /// The frame placed.
        child_frame_id: String,
        /// The child frame's pose in the parent.
        transform: Transform,
    }
);

ros_message!(
    /// tf2_msgs/msg/TFMessage, on /tf and /tf_static.
    TFMessage = "tf2_msgs" {
        /// The transforms.
        transforms: Vec<TransformStamped>,
    }
);

ros_message!(
    /// diagnostic_msgs/msg/KeyValue.
    KeyValue = "diagnostic_msgs" {
        /// The value's name.
        key: String,
        /// The value, as text.
        value: String,
    }
);

ros_message!(
    /// diagnostic_msgs/msg/DiagnosticStatus (level: OK 0, WARN 1, ERROR 2, STALE 3).
    DiagnosticStatus = "diagnostic_msgs" {
        /// OK, WARN, ERROR or STALE.
        level: u8,
        /// What is reported on.
        name: String,
        /// The state, in words.
        message: String,
        /// The hardware it runs on; may be empty.
        hardware_id: String,
        /// Measured values, by name.
        values: Vec<KeyValue>,
    }
);

impl DiagnosticStatus {
    /// `level`: all is well.
    pub const OK: u8 = 0;
    /// `level`: a warning.
    pub const WARN: u8 = 1;
    /// `level`: an error.
    pub const ERROR: u8 = 2;
}

ros_message!(
    /// diagnostic_msgs/msg/DiagnosticArray, on /diagnostics.
    DiagnosticArray = "diagnostic_msgs" {
        /// The time of the report.
        header: Header,
        /// One status per component.
        status: Vec<DiagnosticStatus>,
    }
);

ros_message!(
    /// geometry_msgs/msg/Pose.
    Pose = "geometry_msgs" {
        /// Position, m.
        position: Point,
        /// Orientation.
        orientation: Quaternion,
    }
);

ros_message!(
    /// std_msgs/msg/ColorRGBA, each in [0, 1].
    ColorRGBA = "std_msgs" {
        /// Red.
        r: f32,
        /// Green.
        g: f32,
        /// Blue.
        b: f32,
        /// Opacity (1: opaque).
        a: f32,
    }
);

ros_message!(
    /// builtin_interfaces/msg/Duration.
    Duration = "builtin_interfaces" {
        /// Whole seconds.
        sec: i32,
        /// Nanoseconds past `sec`, below 1e9.
        nanosec: u32,
    }
);

ros_message!(
    /// sensor_msgs/msg/CompressedImage (a Marker's texture; empty here).
    CompressedImage = "sensor_msgs" {
        /// The image's frame and stamp.
        header: Header,
        /// The encoding ("png", "jpeg"); empty here.
        format: String,
        /// The encoded image.
        data: Vec<u8>,
    }
);

ros_message!(
    /// visualization_msgs/msg/UVCoordinate.
    UVCoordinate = "visualization_msgs" {
        /// Horizontal texture coordinate.
        u: f32,
        /// Vertical texture coordinate.
        v: f32,
    }
);

ros_message!(
    /// visualization_msgs/msg/MeshFile.
    MeshFile = "visualization_msgs" {
        /// The mesh file's name.
        filename: String,
        /// The file's bytes.
        data: Vec<u8>,
    }
);

ros_message!(
    /// visualization_msgs/msg/Marker, in its Jazzy layout (with texture and mesh_file).
    Marker = "visualization_msgs" {
        /// The marker's frame and stamp.
        header: Header,
        /// Namespace: with `id`, what identifies the marker.
        ns: String,
        /// The marker's id in its namespace.
        id: i32,
        /// Its shape (TRIANGLE_LIST, ...).
        r#type: i32,
        /// What to do with the marker (ADD, DELETE, ...).
        action: i32,
        /// Its pose in the header's frame.
        pose: Pose,
        /// Scale along x, y, z.
        scale: Vector3,
        /// Colour of the whole marker, used when `colors` is empty.
        color: ColorRGBA,
        /// How long it stays; 0: until replaced or deleted.
        lifetime: Duration,
        /// Whether it moves with its frame after it was received.
        frame_locked: bool,
        /// Points of the shape (for TRIANGLE_LIST, three per triangle), m.
        points: Vec<Point>,
        /// One colour per point; empty: `color`.
        colors: Vec<ColorRGBA>,
        /// URI of a texture; empty: none.
        texture_resource: String,
        /// An embedded texture.
        texture: CompressedImage,
        /// Texture coordinates, one per point.
        uv_coordinates: Vec<UVCoordinate>,
        /// Text of a TEXT_VIEW_FACING marker.
        text: String,
        /// URI of a mesh of a MESH_RESOURCE marker.
        mesh_resource: String,
        /// An embedded mesh file.
        mesh_file: MeshFile,
        /// Whether a mesh resource keeps its own materials.
        mesh_use_embedded_materials: bool,
    }
);

impl Marker {
    /// `type`: triangles, three points each.
    pub const TRIANGLE_LIST: i32 = 11;
    /// `action`: add or replace the marker.
    pub const ADD: i32 = 0;
    /// `action`: delete the marker.
    pub const DELETE: i32 = 2;
}

ros_message!(
    /// visualization_msgs/msg/MarkerArray.
    MarkerArray = "visualization_msgs" {
        /// The markers.
        markers: Vec<Marker>,
    }
);

ros_message!(
    /// std_srvs/srv/Trigger's request: no field, so IDL gives it one placeholder byte.
    TriggerRequest = "std_srvs" {
        /// The placeholder byte; unused.
        structure_needs_at_least_one_member: u8,
    }
);

ros_message!(
    /// std_srvs/srv/Trigger's response.
    TriggerResponse = "std_srvs" {
        /// Whether the request was carried out.
        success: bool,
        /// What was done, or why not.
        message: String,
    }
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
pub(crate) fn encode<M: RosMessage>(message: &M) -> Vec<u8> {
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
        while !(self.bytes.len() - 4).is_multiple_of(n) {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::cloud::encode_cloud;

    #[test]
    fn the_fast_point_cloud_encoder_writes_what_serde_writes() {
        for (frame, points, channels) in [
            ("", 0usize, 0usize),
            ("a", 1, 0),
            ("lidar_top", 257, 3),
            ("abc", 10, 17),
        ] {
            let xyz: Vec<f32> = (0..3 * points).map(|i| i as f32 * 0.37 - 5.0).collect();
            let names: Vec<String> = (0..channels).map(|i| format!("w{i}")).collect();
            let values: Vec<f32> = (0..points * channels).map(|i| i as f32).collect();
            let header = Header {
                stamp: Time {
                    sec: -3,
                    nanosec: 999,
                },
                frame_id: frame.into(),
            };
            let mut cloud = encode_cloud(header, &xyz, &names, &values);
            cloud.is_dense = points % 2 == 0;
            assert_eq!(
                encode(&cloud),
                to_cdr(&cloud),
                "frame {frame:?}, {points} points"
            );
        }
    }
}
