//! The node against a real ROS 2 (rclpy with Fast DDS from pip), in a private network namespace:
//! rclpy publishes a PointCloud2 (float64/float32 mixed, big-endian) and a Mesh; the node must
//! answer with deformed clouds and weights clouds whose contents the peer checks.

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

#[test]
fn rclpy_peer_gets_deformed_and_weights_clouds() {
    let python = ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bag = root.join("target/ros2-peer-node.mcap");
    let _ = std::fs::remove_file(&bag);
    let script = format!(
        "{node} node --domain-id 31 --record {bag} > {log} 2>&1 & NODE=$!; \
         ROS_DOMAIN_ID=31 timeout 120 {python} {peer}; RC=$?; \
         kill -INT $NODE; wait $NODE; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        log = root.join("target/ros2-peer-node.log").display(),
        bag = bag.display(),
        python = python.display(),
        peer = root.join("tests/peers/ros2_peer.py").display(),
    );
    let out = Command::new("unshare")
        .arg("-n")
        .arg(root.join("tests/peers/private_net.sh"))
        .args(["bash", "-c", &script])
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let log = std::fs::read_to_string(root.join("target/ros2-peer-node.log")).unwrap_or_default();
    assert!(
        out.status.success(),
        "peer failed\nstdout:\n{}\nstderr:\n{}\nnode log:\n{log}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("ok: "), "{stdout}");
    assert!(stdout.contains("set/get ok"), "parameters: {stdout}");
    eprintln!("{stdout}");
    assert!(log.contains("shape_ready"), "{log}");
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
    let python = ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let bag = root.join("target/ros2-press-node.mcap");
    let log_path = root.join("target/ros2-press-node.log");
    let _ = std::fs::remove_file(&bag);
    let script = format!(
        "{node} node --domain-id 32 --scene {scene} --record {bag} > {log} 2>&1 & NODE=$!; \
         ROS_DOMAIN_ID=32 timeout 120 {python} {peer}; RC=$?; \
         kill -INT $NODE; wait $NODE; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        scene = root.join("tests/data/press/press.yaml").display(),
        log = log_path.display(),
        bag = bag.display(),
        python = python.display(),
        peer = root.join("tests/peers/joint_peer.py").display(),
    );
    let out = Command::new("unshare")
        .arg("-n")
        .arg(root.join("tests/peers/private_net.sh"))
        .args(["bash", "-c", &script])
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let log = std::fs::read_to_string(&log_path).unwrap_or_default();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("ok: joint states drove the press"),
        "peer failed\nstdout:\n{stdout}\nstderr:\n{}\nnode log:\n{log}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{stdout}");
    // What was decided for the block is in the log, and the unknown joint was named.
    assert!(
        log.contains("scene object `block`: 17 of 17 handles, 128 cubature points"),
        "{log}"
    );
    assert!(
        log.contains("joint_state_ignored") && log.contains("no joint elbow"),
        "{log}"
    );
    let counts = &common::python_counts(&[bag])[0];
    for topic in [
        "/joint_states",
        "/physskin/deformed_points",
        "/physskin/state",
    ] {
        let n = counts.get(topic).copied().unwrap_or(0);
        assert!(n > 0, "nothing recorded on {topic}: {counts:?}");
    }
}
