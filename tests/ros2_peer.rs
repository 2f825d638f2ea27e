//! The node against a real ROS 2 (rclpy with Fast DDS from pip), in a private network namespace:
//! rclpy publishes a PointCloud2 (float64/float32 mixed, big-endian) and a Mesh; the node must
//! answer with deformed clouds and weights clouds whose contents the peer checks. And rclpy
//! drives a scene's robot over sensor_msgs/JointState: the press it lowers dents the block the
//! node simulates.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// target/ros-venv with rclpy (Fast DDS) from pip.
fn ros_venv() -> PathBuf {
    common::venv(
        "ros-venv",
        "import rclpy, sensor_msgs.msg, shape_msgs.msg, numpy",
        &[
            "ros-rclpy",
            "ros-sensor-msgs",
            "ros-std-msgs",
            "ros-shape-msgs",
            "ros-rmw-fastrtps-cpp",
            "numpy",
        ],
    )
}

/// Runs `physskin node --domain-id <domain> <node_args>` and the Python `peer` against it in a
/// private network namespace; the node is stopped with SIGINT after the peer. Returns the
/// peer's stdout and the node's log; fails the test, with both, unless both exit 0.
fn node_with_peer(domain: u16, node_args: &str, peer: &str, log_name: &str) -> (String, String) {
    let python = ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let log_path = root.join("target").join(log_name);
    let script = format!(
        "{node} node --domain-id {domain} {node_args} > {log} 2>&1 & NODE=$!; \
         ROS_DOMAIN_ID={domain} timeout 120 {python} {peer}; RC=$?; \
         kill -INT $NODE; wait $NODE; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        log = log_path.display(),
        python = python.display(),
        peer = root.join("tests/peers").join(peer).display(),
    );
    let out = Command::new("unshare")
        .arg("-n")
        .arg(root.join("tests/peers/private_net.sh"))
        .args(["bash", "-c", &script])
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let log = std::fs::read_to_string(&log_path).unwrap_or_default();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "peer failed\nstdout:\n{stdout}\nstderr:\n{}\nnode log:\n{log}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{stdout}");
    (stdout, log)
}

#[test]
fn rclpy_peer_gets_deformed_and_weights_clouds() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bag = root.join("target/ros2-peer-node.mcap");
    let _ = std::fs::remove_file(&bag);
    let (stdout, log) = node_with_peer(
        31,
        &format!("--record {}", bag.display()),
        "ros2_peer.py",
        "ros2-peer-node.log",
    );
    assert!(stdout.contains("ok: "), "{stdout}");
    assert!(stdout.contains("set/get ok"), "parameters: {stdout}");
    assert!(log.contains("shape_ready"), "{log}");
    // The peer's bad clouds were refused, each with its reason, in the log and on the status
    // topic (recorded below).
    assert!(
        log.contains("cloud in frame `peer_bad`: PointCloud2 has no `z` field"),
        "{log}"
    );
    assert!(
        log.contains("cloud in frame `peer_short`: PointCloud2 data holds 993 bytes"),
        "{log}"
    );
    // The node recorded what it received and sent; readers nobody here wrote agree.
    let counts = &common::python_counts(&[bag])[0];
    for topic in [
        "points",
        "mesh",
        "deformed_points",
        "weights_cloud",
        "weights",
        "state",
        "status",
    ] {
        let n = counts
            .get(&format!("/physskin/{topic}"))
            .copied()
            .unwrap_or(0);
        assert!(n > 0, "nothing recorded on /physskin/{topic}: {counts:?}");
    }
}

#[test]
fn rclpy_joint_states_drive_a_scene_robot() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bag = root.join("target/ros2-press-node.mcap");
    let _ = std::fs::remove_file(&bag);
    let node_args = format!(
        "--scene {} --record {}",
        root.join("tests/data/press/press.yaml").display(),
        bag.display()
    );
    let (stdout, log) = node_with_peer(32, &node_args, "joint_peer.py", "ros2-press-node.log");
    assert!(
        stdout.contains("ok: joint states drove the press"),
        "{stdout}"
    );
    // What was decided for the block is in the log, and the unknown joint was named.
    assert!(
        log.contains("scene object `block`: 17 of 17 handles, 128 cubature points"),
        "{log}"
    );
    assert!(
        log.contains("joint_state_ignored") && log.contains("has joint elbow"),
        "{log}"
    );
    let counts = &common::python_counts(std::slice::from_ref(&bag))[0];
    // The recording replays through the same scene: the recorded joint states lower the press
    // again and the block dents again (its top middle went down about 1.1 cm above).
    let replayed = Command::new(env!("CARGO_BIN_EXE_physskin"))
        .args(["replay", "--json", "--scene"])
        .arg(root.join("tests/data/press/press.yaml"))
        .arg(&bag)
        .output()
        .unwrap();
    let json: serde_json::Value = serde_json::from_slice(&replayed.stdout).unwrap_or_else(|e| {
        panic!(
            "replay printed no JSON ({e}): {}",
            String::from_utf8_lossy(&replayed.stderr)
        )
    });
    assert_eq!(json["rejected"], 0, "{json}");
    let moved = json["scene_objects"][0]["max_displacement_m"]
        .as_f64()
        .unwrap();
    assert!(
        moved > 0.008,
        "the replayed press moved the block {moved} m at most: {json}"
    );
    for topic in [
        "/joint_states",
        "/physskin/deformed_points",
        "/physskin/state",
    ] {
        let n = counts.get(topic).copied().unwrap_or(0);
        assert!(n > 0, "nothing recorded on {topic}: {counts:?}");
    }
}
