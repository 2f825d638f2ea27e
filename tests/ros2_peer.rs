//! The node against a real ROS 2 (rclpy with Fast DDS from pip), in a private network namespace:
//! rclpy publishes a PointCloud2 (float64/float32 mixed, big-endian) and a Mesh; the node must
//! answer with deformed clouds and weights clouds whose contents the peer checks.

use std::path::{Path, PathBuf};
use std::process::Command;

/// target/ros-venv with rclpy, made on first use. Fails loudly when it cannot be made.
fn ros_venv() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let venv = root.join("target/ros-venv");
    let python = venv.join("bin/python");
    let ready = Command::new(&python)
        .args(["-c", "import rclpy, sensor_msgs.msg, shape_msgs.msg, numpy"])
        .status()
        .is_ok_and(|s| s.success());
    if !ready {
        let status = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status();
        assert!(
            status.is_ok_and(|s| s.success()),
            "python3 -m venv {} failed",
            venv.display()
        );
        let status = Command::new(venv.join("bin/pip"))
            .args([
                "install",
                "-q",
                "ros-rclpy",
                "ros-sensor-msgs",
                "ros-std-msgs",
                "ros-shape-msgs",
                "ros-rmw-fastrtps-cpp",
                "numpy",
            ])
            .status();
        assert!(
            status.is_ok_and(|s| s.success()),
            "pip could not install rclpy (ros-rclpy from PyPI)"
        );
    }
    python
}

#[test]
fn rclpy_peer_gets_deformed_and_weights_clouds() {
    let python = ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let script = format!(
        "{node} node --domain-id 31 > {log} 2>&1 & NODE=$!; \
         ROS_DOMAIN_ID=31 timeout 120 {python} {peer}; RC=$?; \
         kill -INT $NODE; wait $NODE; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        log = root.join("target/ros2-peer-node.log").display(),
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
    assert!(log.contains("shape_ready"), "{log}");
}
