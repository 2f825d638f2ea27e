//! The node on loopback-only hosts, against a real ROS 2 peer (rclpy with Fast DDS from pip):
//! in a network namespace where only `lo` is up, plainly, under `ROS_LOCALHOST_ONLY=1` and under
//! `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, rclpy's cloud and mesh reach the node and the
//! node's deformed clouds, weights and parameter answers reach rclpy (tests/peers/ros2_peer.py
//! checks what comes back). RustDDS needed a patch for it: vendor/rustdds/README.physskin.md.

mod common;

use std::path::Path;
use std::process::Command;

/// Runs the node and tests/peers/ros2_peer.py in a private namespace, both with the environment
/// `env` (`NAME=VALUE ...`): with only `lo` up, or (`beside`) with a veth pair up too, as a host
/// with a network has; fails with both outputs unless both exit 0. Returns the node's log.
fn on_loopback(domain: u16, env: &str, beside: bool, log_name: &str) -> String {
    let python = common::ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let log = root.join("target").join(log_name);
    let check = if beside {
        ""
    } else {
        "[ $(ip -o link show up | grep -vc ' lo:') -eq 0 ] || { echo not loopback-only; exit 3; }; "
    };
    let script = format!(
        "ip link set lo up; export {env} ROS_DOMAIN_ID={domain}; {check}\
         {node} node > {log} 2>&1 & NODE=$!; \
         timeout 120 {python} {peer}; RC=$?; \
         kill -INT $NODE; wait $NODE; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        log = log.display(),
        python = python.display(),
        peer = root.join("tests/peers/ros2_peer.py").display(),
    );
    let mut command = Command::new("unshare");
    command.arg("-n");
    if beside {
        command.arg(root.join("tests/peers/private_net.sh"));
    }
    let out = command
        .args(["bash", "-c", &script])
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let text = std::fs::read_to_string(&log).unwrap_or_default();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "loopback-only ({env}) failed\nstdout:\n{stdout}\nstderr:\n{}\nnode log:\n{text}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("ok: ") && stdout.contains("set/get ok"),
        "{stdout}"
    );
    assert!(text.contains("shape_ready"), "{text}");
    assert!(
        !text.contains("loopback"),
        "no warning about loopback any more:\n{text}"
    );
    text
}

#[test]
fn both_ways_with_only_loopback_up() {
    on_loopback(36, "PHYSSKIN_TEST=1", false, "loopback-plain-node.log");
}

#[test]
fn both_ways_under_ros_localhost_only() {
    let env = "ROS_LOCALHOST_ONLY=1";
    on_loopback(37, env, false, "loopback-localhost-only-node.log");
}

#[test]
fn both_ways_under_automatic_discovery_range_localhost() {
    let env = "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST";
    on_loopback(38, env, false, "loopback-range-node.log");
}

/// On a host with a network, the environment keeps both the peer and the node (which reads it
/// as rmw does) on loopback, and they still talk.
#[test]
fn both_ways_under_localhost_range_beside_a_network() {
    let env = "ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST";
    on_loopback(39, env, true, "loopback-beside-node.log");
}
