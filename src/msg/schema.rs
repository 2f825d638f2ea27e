//! `ros2msg` schemas for MCAP channels: the message's definition, then every type it uses
//! (transitively), each after a line of 80 `=` and `MSG: pkg/Name` (the name as the field
//! writes it), as rosbag2 writes them.

use super::messages::{
    Clock, ColorRGBA, CompressedImage, DiagnosticArray, DiagnosticStatus, Duration, Header,
    JointState, KeyValue, Marker, MarkerArray, Mesh, MeshFile, MeshTriangle, Point, PointCloud2,
    PointField, Pose, Quaternion, RosMessage, StringMessage, TFMessage, Time, Transform,
    TransformStamped, UVCoordinate, Vector3,
};

/// The fields of a known message type ("pkg/Name", as in .msg files) and its own text.
fn definition(ros_type: &str) -> Option<String> {
    let generated = |fields: Vec<(&str, String)>| {
        fields
            .iter()
            .map(|(name, ty)| format!("{ty} {name}\n"))
            .collect::<String>()
    };
    // This package's messages keep their .msg text (constants and comments included).
    Some(match ros_type {
        "builtin_interfaces/Time" => generated(Time::fields()),
        "rosgraph_msgs/Clock" => generated(Clock::fields()),
        "std_msgs/Header" => generated(Header::fields()),
        "geometry_msgs/Point" => generated(Point::fields()),
        "geometry_msgs/Vector3" => generated(Vector3::fields()),
        "sensor_msgs/PointField" => format!(
            "uint8 INT8=1\nuint8 UINT8=2\nuint8 INT16=3\nuint8 UINT16=4\nuint8 INT32=5\nuint8 UINT32=6\nuint8 FLOAT32=7\nuint8 FLOAT64=8\n{}",
            generated(PointField::fields())
        ),
        "sensor_msgs/PointCloud2" => generated(PointCloud2::fields()),
        "sensor_msgs/JointState" => generated(JointState::fields()),
        "std_msgs/String" => generated(StringMessage::fields()),
        "diagnostic_msgs/KeyValue" => generated(KeyValue::fields()),
        // `byte` as the .msg file writes it (one unsigned byte, as uint8).
        "diagnostic_msgs/DiagnosticStatus" => format!(
            "byte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n{}",
            generated(DiagnosticStatus::fields()).replacen("uint8 level", "byte level", 1)
        ),
        "diagnostic_msgs/DiagnosticArray" => generated(DiagnosticArray::fields()),
        "shape_msgs/MeshTriangle" => generated(MeshTriangle::fields()),
        "shape_msgs/Mesh" => generated(Mesh::fields()),
        "geometry_msgs/Quaternion" => generated(Quaternion::fields()),
        "geometry_msgs/Transform" => generated(Transform::fields()),
        "geometry_msgs/TransformStamped" => generated(TransformStamped::fields()),
        "tf2_msgs/TFMessage" => generated(TFMessage::fields()),
        "geometry_msgs/Pose" => generated(Pose::fields()),
        "std_msgs/ColorRGBA" => generated(ColorRGBA::fields()),
        "builtin_interfaces/Duration" => generated(Duration::fields()),
        "sensor_msgs/CompressedImage" => generated(CompressedImage::fields()),
        "visualization_msgs/UVCoordinate" => generated(UVCoordinate::fields()),
        "visualization_msgs/MeshFile" => generated(MeshFile::fields()),
        "visualization_msgs/Marker" => format!(
            "int32 TRIANGLE_LIST=11\nint32 ADD=0\nint32 DELETE=2\n{}",
            generated(Marker::fields())
        ),
        "visualization_msgs/MarkerArray" => generated(MarkerArray::fields()),
        "physskin/MeshStamped" => include_str!("../../msg/MeshStamped.msg").into(),
        "physskin/SkinningWeights" => include_str!("../../msg/SkinningWeights.msg").into(),
        "physskin/SubspaceState" => include_str!("../../msg/SubspaceState.msg").into(),
        "physskin/Interaction" => include_str!("../../msg/Interaction.msg").into(),
        "physskin/Status" => include_str!("../../msg/Status.msg").into(),
        _ => return None,
    })
}

/// The complex types a definition refers to, in order of first use ("std_msgs/Header").
fn references(text: &str) -> Vec<String> {
    let mut found = Vec::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let Some(ty) = line.split_whitespace().next() else {
            continue;
        };
        let base = ty.split('[').next().unwrap_or(ty);
        if base.contains('/') && !found.iter().any(|f| f == base) {
            found.push(base.to_string());
        }
    }
    found
}

/// The `ros2msg` schema text of `M`, with every dependency.
pub fn schema_text<M: RosMessage>() -> String {
    let top = format!("{}/{}", M::PACKAGE, M::NAME);
    let mut text = definition(&top).unwrap_or_else(|| panic!("no definition for {top}"));
    let mut queue = references(&text);
    let mut done: Vec<String> = Vec::new();
    while let Some(ty) = queue.first().cloned() {
        queue.remove(0);
        if done.contains(&ty) {
            continue;
        }
        let body = definition(&ty).unwrap_or_else(|| panic!("no definition for {ty}"));
        if !text.ends_with('\n') {
            text.push('\n');
        }
        text.push_str(&"=".repeat(80));
        // The name as the field writes it, as rosbag2 does: Foxglove's parser finds a field's
        // type by that exact name ("std_msgs/Header", not "std_msgs/msg/Header").
        text.push_str(&format!("\nMSG: {ty}\n"));
        text.push_str(&body);
        queue.extend(references(&body));
        done.push(ty);
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::{Interaction, MeshStamped, SkinningWeights, Status, SubspaceState};

    #[test]
    fn point_cloud2_lists_every_dependency_once() {
        let text = schema_text::<PointCloud2>();
        assert!(text.starts_with("std_msgs/Header header\nuint32 height\n"));
        for dep in [
            "MSG: std_msgs/Header\n",
            "MSG: builtin_interfaces/Time\n",
            "MSG: sensor_msgs/PointField\n",
        ] {
            assert_eq!(text.matches(dep).count(), 1, "{dep} in\n{text}");
        }
        assert!(text.contains(&format!("{}\nMSG:", "=".repeat(80))));
    }

    #[test]
    fn every_recorded_type_has_a_schema() {
        for text in [
            schema_text::<Mesh>(),
            schema_text::<MeshStamped>(),
            schema_text::<SkinningWeights>(),
            schema_text::<SubspaceState>(),
            schema_text::<Interaction>(),
            schema_text::<Status>(),
            schema_text::<Clock>(),
            schema_text::<JointState>(),
            schema_text::<StringMessage>(),
            schema_text::<DiagnosticArray>(),
        ] {
            assert!(text.contains("\n") && !text.contains("MSG: physskin/Interaction"));
        }
    }
}
