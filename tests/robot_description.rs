//! The robot the ROS graph describes: a URDF on `robot_description` and its joints on
//! `/joint_states` move links that push and hold the objects built from clouds, in a replay
//! (the same runtime as the node's; `ros2_peer.rs` drives the node itself from rclpy).

mod common;

use physskin::bag::{BagMessage, BagWriter, RecordOptions};
use physskin::msg::{
    from_cdr, to_cdr, Header, JointState, PointCloud2, QosProfile, StringMessage, TFMessage, Time,
    TopicInfo, Transform, TransformStamped,
};
use physskin::replay::{replay, ReplayOptions};
use physskin::runtime::NodeParams;
use serde_json::json;

const POINTS: &str = "/physskin/points";
const DESCRIPTION: &str = "/robot_description";
const JOINTS: &str = "/joint_states";

/// The bundled two-finger gripper (config/robots/gripper.urdf): fingers 0.14 m apart when
/// open, hanging from a palm 0.1 m above the floor.
fn gripper_urdf() -> String {
    std::fs::read_to_string(common::root().join("config/robots/gripper.urdf")).unwrap()
}

/// A 0.1 m cube's surface on the floor in `world`, 11 x 11 points a face.
fn block_cloud() -> PointCloud2 {
    let n = 11;
    let at = |i: usize| -0.05 + 0.1 * i as f32 / (n - 1) as f32;
    let mut xyz = Vec::new();
    for axis in 0..3 {
        for side in [-0.05f32, 0.05] {
            for i in 0..n {
                for j in 0..n {
                    let mut p = [0.0f32; 3];
                    p[axis] = side;
                    p[(axis + 1) % 3] = at(i);
                    p[(axis + 2) % 3] = at(j);
                    xyz.extend([p[0], p[1], p[2] + 0.05]);
                }
            }
        }
    }
    let header = Header {
        frame_id: "world".into(),
        ..Default::default()
    };
    physskin::msg::cloud::encode_cloud(header, &xyz, &[], &[])
}

/// The grasp of config/scenes/grasp.yaml: the fingers close 0.025 m each from 0.3 s to 1 s,
/// the palm lifts 0.2 m from 1.5 s to 2.5 s. (lift, finger) at `t` s.
fn grasp(t: f64) -> (f64, f64) {
    let ramp = |from: f64, to: f64| ((t - from) / (to - from)).clamp(0.0, 1.0);
    (0.2 * ramp(1.5, 2.5), 0.025 * ramp(0.3, 1.0))
}

/// Writes `messages` (log time s, topic, CDR bytes) to an MCAP with the input topics.
fn write_bag(path: &std::path::Path, messages: &[(f64, &str, Vec<u8>)]) {
    let mut writer = BagWriter::create(RecordOptions {
        path: path.into(),
        ..Default::default()
    })
    .unwrap();
    let topics = [
        TopicInfo::of::<PointCloud2>(POINTS, QosProfile::sensor(5)),
        TopicInfo::of::<StringMessage>(DESCRIPTION, QosProfile::reliable(1, true)),
        TopicInfo::of::<JointState>(JOINTS, QosProfile::sensor(5)),
        TopicInfo::of::<TFMessage>("/tf_static", QosProfile::reliable(100, true)),
    ];
    for topic in topics {
        writer.add_topic(topic).unwrap();
    }
    for (t, topic, bytes) in messages {
        let ns = (t * 1e9) as i64;
        writer.write(topic, ns, ns, bytes).unwrap();
    }
    writer.finish().unwrap();
}

/// The gripper's URDF (`urdf`), a block's cloud and `seconds` of the grasp's joint states at
/// 60 Hz, replayed with the block on the floor of `world`: every output message.
fn replay_grasp(name: &str, urdf: &str, seconds: f64, params: NodeParams) -> Vec<BagMessage> {
    replay_grasp_with(name, urdf, seconds, params, Vec::new(), true)
}

/// [`replay_grasp`] with `more` messages among the inputs, and the block's cloud if `cloud`.
fn replay_grasp_with(
    name: &str,
    urdf: &str,
    seconds: f64,
    params: NodeParams,
    more: Vec<(f64, &str, Vec<u8>)>,
    cloud: bool,
) -> Vec<BagMessage> {
    let dir = common::root().join("target/robot-description");
    std::fs::create_dir_all(&dir).unwrap();
    let (input, output) = (
        dir.join(format!("{name}-in.mcap")),
        dir.join(format!("{name}-out.mcap")),
    );
    let description = StringMessage { data: urdf.into() };
    let mut messages = vec![(0.0, DESCRIPTION, to_cdr(&description))];
    if cloud {
        messages.push((0.001, POINTS, to_cdr(&block_cloud())));
    }
    messages.extend(more);
    for tick in 0..(seconds * 60.0) as usize {
        let t = 0.002 + tick as f64 / 60.0;
        let (lift, finger) = grasp(t);
        let state = JointState {
            header: Header {
                stamp: Time::from_nanos((t * 1e9) as i64),
                ..Default::default()
            },
            name: vec!["lift".into(), "left".into(), "right".into()],
            position: vec![lift, finger, finger],
            ..Default::default()
        };
        messages.push((t, JOINTS, to_cdr(&state)));
    }
    write_bag(&input, &messages);
    let options = ReplayOptions {
        params,
        record: Some(RecordOptions {
            path: output.clone(),
            ..Default::default()
        }),
        tail_s: 0.1,
        ..Default::default()
    };
    let model = physskin::skinning::NeuralModel::bundled().unwrap();
    let summary = replay(
        &std::fs::read(&input).unwrap(),
        name,
        &model,
        &options,
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(summary.rejected, 0, "{summary:?}");
    physskin::bag::read_messages(&std::fs::read(&output).unwrap(), "output").unwrap()
}

/// The block on the floor of `world`, every contact with friction 0.5 (a grip holds by it).
fn on_the_floor() -> NodeParams {
    on_the_floor_with(&[])
}

/// [`on_the_floor`] with more parameters set by name.
fn on_the_floor_with(more: &[(&str, serde_json::Value)]) -> NodeParams {
    let mut settings = vec![
        ("fixed_frame", json!("world")),
        ("simulation.support", json!("floor")),
        ("simulation.friction", json!(0.5)),
    ];
    settings.extend(more.iter().cloned());
    common::params(&settings)
}

/// (log time s, centroid) of every deformed cloud.
fn centroids(messages: &[BagMessage]) -> Vec<(f64, [f64; 3])> {
    messages
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
        .map(|m| {
            let cloud: PointCloud2 = from_cdr(&m.data).unwrap();
            let points = physskin::msg::cloud::decode_cloud(&cloud, usize::MAX)
                .unwrap()
                .points;
            let c = points.iter().sum::<nalgebra::Vector3<f64>>() / points.len() as f64;
            (m.log_time as f64 / 1e9, [c.x, c.y, c.z])
        })
        .collect()
}

/// The messages of every status of `event`.
fn said(messages: &[BagMessage], event: &str) -> Vec<String> {
    common::statuses(messages, event)
        .into_iter()
        .map(|(_, s)| s.message)
        .collect()
}

/// The issue's test, in a replay: the gripper closes on the block, lifts it 0.2 m, and the
/// block stays in the grip for 5 s (drift under 1 mm).
#[test]
fn a_described_gripper_lifts_a_block_from_a_cloud_and_holds_it() {
    let messages = replay_grasp("grasp", &gripper_urdf(), 7.5, on_the_floor());
    let ready = said(&messages, "robot_ready");
    assert!(
        ready.iter().any(|s| s
            .starts_with("robot `gripper` from robot_description: 4 links, 3 collision shapes")),
        "{ready:#?}"
    );
    let c = centroids(&messages);
    let at = |t: f64| {
        c.iter()
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .unwrap()
            .1
    };
    let (before, lifted) = (at(0.25), at(2.6));
    let rise = lifted[2] - before[2];
    let drift = c
        .iter()
        .filter(|(t, _)| *t >= 2.6)
        .map(|(_, p)| {
            (0..3)
                .map(|d| (p[d] - lifted[d]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .fold(0.0, f64::max);
    println!("rose {rise:.4} m; drift over 5 s {:.3} mm", drift * 1e3);
    assert!(
        (0.18..0.205).contains(&rise),
        "the block rose {rise} m: {c:?}"
    );
    assert!(drift < 1e-3, "the block moved {drift} m in the grip");
}

/// A collision mesh nobody can find is reported once, and the link collides as its visual
/// box; a robot without a fixed frame is refused by name (it would have nowhere to stand).
#[test]
fn a_missing_mesh_stands_in_as_the_visual_box_and_no_fixed_frame_is_named() {
    let urdf = gripper_urdf().replace(
        r#"<link name="left_finger">
    <collision><origin xyz="0 0 -0.05"/><geometry><box size="0.02 0.12 0.1"/></geometry></collision>"#,
        r#"<link name="left_finger">
    <visual><origin xyz="0 0 -0.05"/><geometry><box size="0.02 0.12 0.1"/></geometry></visual>
    <collision><geometry><mesh filename="package://gripper_description/meshes/finger.stl"/></geometry></collision>"#,
    );
    assert_ne!(urdf, gripper_urdf(), "the finger's collision was replaced");
    let messages = replay_grasp("missing-mesh", &urdf, 2.6, on_the_floor());
    let missing = said(&messages, "robot_mesh_missing");
    assert_eq!(missing.len(), 1, "{missing:#?}");
    assert!(
        missing[0].contains("link `left_finger`")
            && missing[0].contains("package://gripper_description/meshes/finger.stl")
            && missing[0].contains("visual"),
        "{}",
        missing[0]
    );
    // The visual box is the old collision box: the grip still lifts the block.
    let c = centroids(&messages);
    let rise = c.last().unwrap().1[2] - c[15].1[2];
    assert!(rise > 0.15, "the block rose {rise} m");

    let messages = replay_grasp(
        "no-fixed-frame",
        &gripper_urdf(),
        0.5,
        NodeParams::default(),
    );
    let ignored = said(&messages, "robot_ignored");
    assert!(
        ignored.iter().any(|s| s.contains("set fixed_frame")),
        "{ignored:#?}"
    );
}

/// A URDF that is not one is refused by name; the replay goes on.
#[test]
fn a_broken_description_is_refused_by_name() {
    let broken = StringMessage {
        data: "<robot name=\"x\"><link name=\"a\"/><link name=\"a\"/></robot>".into(),
    };
    let dir = common::root().join("target/robot-description");
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("broken-in.mcap");
    write_bag(
        &input,
        &[
            (0.0, DESCRIPTION, to_cdr(&broken)),
            (0.01, POINTS, to_cdr(&block_cloud())),
        ],
    );
    let model = physskin::skinning::NeuralModel::bundled().unwrap();
    let summary = replay(
        &std::fs::read(&input).unwrap(),
        "broken",
        &model,
        &ReplayOptions::default(),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(summary.rejected, 1, "{summary:?}");
    assert_eq!(
        summary.shapes.len(),
        1,
        "the cloud still built: {summary:?}"
    );
}

/// /tf places the links it knows: with the gripper's root 1 m along x, it closes on nothing
/// and the block stays on the floor.
#[test]
fn the_root_link_stands_where_tf_puts_it() {
    let mut aside = TransformStamped {
        child_frame_id: "base".into(),
        transform: Transform::default(),
        ..Default::default()
    };
    aside.header.frame_id = "world".into();
    aside.transform.translation.x = 1.0;
    aside.transform.rotation.w = 1.0;
    let tf = TFMessage {
        transforms: vec![aside],
    };
    let more = vec![(0.0, "/tf_static", to_cdr(&tf))];
    let messages = replay_grasp_with("aside", &gripper_urdf(), 2.6, on_the_floor(), more, true);
    let c = centroids(&messages);
    let rise = c.last().unwrap().1[2] - c[15].1[2];
    assert!(
        rise.abs() < 1e-3,
        "the block moved {rise} m up with the gripper 1 m away"
    );
}

/// A scene file's block (no robot of its own) in `world`, the fixed frame: the described
/// gripper lifts it as it lifts a block built from a cloud.
#[test]
fn the_described_robot_lifts_a_scene_object_too() {
    let dir = common::root().join("target/robot-description");
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("block.yaml");
    std::fs::write(
        &scene,
        "rate_hz: 60\ngravity: [0, 0, -9.81]\nfloor: 0.0\ndamping: 1.0\nfriction: 0.5\nsleep: null\n\
         objects:\n  - name: block\n    shape: {box: [0.1, 0.1, 0.1]}\n    position: [0.0, 0.0, 0.05]\n\
         \x20   material: {young: 2.0e5, poisson: 0.45, density: 500}\n    support: floor\n\
         \x20   handles: 9\n    cubature: 256\n",
    )
    .unwrap();
    let params = on_the_floor_with(&[("scene", json!(scene.display().to_string()))]);
    // No cloud: the scene's block is the only object.
    let messages = replay_grasp_with("scene", &gripper_urdf(), 2.6, params, Vec::new(), false);
    let c = centroids(&messages);
    let rise = c.last().unwrap().1[2] - c[15].1[2];
    assert!(rise > 0.18, "the scene's block rose {rise} m");
}
