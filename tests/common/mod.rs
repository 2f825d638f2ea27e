//! What several integration tests share: Python peers in virtual environments under target/,
//! made on first use, failing loudly when they cannot be made.

#[allow(dead_code)] // only some test binaries make scenes
pub mod scenes;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The node's parameters with `settings` set by their ROS names, as `ros2 param set` or a
/// parameter file would; a refused one fails the test with the node's reason.
#[allow(dead_code)] // only the tests that replay with parameters
pub fn params(settings: &[(&str, serde_json::Value)]) -> physskin::runtime::NodeParams {
    let defaults = physskin::runtime::NodeParams::default();
    settings.iter().fold(defaults, |params, (name, value)| {
        params
            .with(name, value.clone())
            .unwrap_or_else(|e| panic!("{name} = {value}: {e}"))
    })
}

/// Every .rs file below `dir`, for the house rules' checks.
#[allow(dead_code)] // only the house rules read the sources
pub fn rust_sources(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            found.extend(rust_sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            found.push(path);
        }
    }
    found
}

/// `physskin ARGS`, the command a user runs, its JSON output read back; panics with its
/// stderr when it fails.
#[allow(dead_code)] // only some test binaries run the command line
pub fn physskin_json(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_physskin"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "physskin {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `physskin ARGS` refused: fails the test unless the command exits non-zero; its stderr, the
/// reason the user reads.
#[allow(dead_code)] // only some test binaries check refusals
pub fn physskin_refused(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_physskin"))
        .args(args)
        .output()
        .unwrap();
    assert!(!out.status.success(), "physskin {args:?} was not refused");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// `physskin scene PATH --reference --json` for `seconds` of motion after exactly
/// `settle_steps` steps: the scene's run with each deformable object's error against the FEM.
#[allow(dead_code)] // only the scene tests run scenes
pub fn scene_against_fem(path: &Path, seconds: f64, settle_steps: usize) -> serde_json::Value {
    let path = path.display().to_string();
    let (seconds, settle_steps) = (seconds.to_string(), settle_steps.to_string());
    physskin_json(&[
        "scene",
        &path,
        "--reference",
        "--json",
        "--seconds",
        &seconds,
        "--settle-steps",
        &settle_steps,
    ])
}

pub fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// target/<name> with `packages` from pip; `check` is a Python statement that succeeds once
/// they are installed. Returns the venv's python.
pub fn venv(name: &str, check: &str, packages: &[&str]) -> PathBuf {
    // Tests of one binary run in parallel: one makes the venv, the others wait for it.
    static MAKING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _making = MAKING.lock().unwrap_or_else(|e| e.into_inner());
    let venv = root().join("target").join(name);
    let python = venv.join("bin/python");
    let ready = Command::new(&python)
        .args(["-c", check])
        .status()
        .is_ok_and(|s| s.success());
    if !ready {
        let made = Command::new("python3")
            .args(["-m", "venv"])
            .arg(&venv)
            .status();
        assert!(
            made.is_ok_and(|s| s.success()),
            "python3 -m venv {} failed",
            venv.display()
        );
        let installed = Command::new(venv.join("bin/pip"))
            .args(["install", "-q"])
            .args(packages)
            .status();
        assert!(
            installed.is_ok_and(|s| s.success()),
            "pip could not install {packages:?} into {}",
            venv.display()
        );
    }
    python
}

/// Runs tests/peers/mcap_peer.py (the official MCAP reader with its ROS 2 decoder, and
/// rosbags) on `files`; returns each file's message count per topic.
#[allow(dead_code)] // not every test binary reads recordings
pub fn python_counts(files: &[PathBuf]) -> Vec<BTreeMap<String, u64>> {
    let python = venv(
        "bag-venv",
        "import mcap, mcap_ros2, rosbags, yaml",
        &["mcap", "mcap-ros2-support", "rosbags", "pyyaml"],
    );
    let out = Command::new(python)
        .arg(root().join("tests/peers/mcap_peer.py"))
        .args(files)
        .output()
        .expect("python runs");
    assert!(
        out.status.success(),
        "the Python readers refused a recording:\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|line| {
            let v: serde_json::Value = serde_json::from_str(line).unwrap();
            assert_eq!(v["mcap_counts"], v["rosbags_counts"]);
            serde_json::from_value(v["mcap_counts"].clone()).unwrap()
        })
        .collect()
}

/// Records `clouds` (log time in s, cloud) on /physskin/points to `target/DIR/NAME-in.mcap`,
/// replays it through the node's pipeline with `params`, stepping `tail_s` past the last, and
/// records every output to `target/DIR/NAME-out.mcap`; fails unless no input was refused.
/// Returns the replay's summary and the recorded outputs.
#[allow(dead_code)] // only the tests that replay clouds
pub fn replay_clouds(
    dir: &str,
    name: &str,
    clouds: &[(f64, physskin::msg::PointCloud2)],
    params: physskin::runtime::NodeParams,
    tail_s: f64,
) -> (
    physskin::replay::ReplaySummary,
    Vec<physskin::bag::BagMessage>,
) {
    use physskin::bag::{read_messages, BagWriter, RecordOptions};
    use physskin::msg::{to_cdr, PointCloud2, QosProfile, Time, TopicInfo};
    use physskin::replay::{replay, ReplayOptions};
    const TOPIC: &str = "/physskin/points";
    let dir = root().join("target").join(dir);
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join(format!("{name}-in.mcap"));
    let output = dir.join(format!("{name}-out.mcap"));
    let mut writer = BagWriter::create(RecordOptions {
        path: input.clone(),
        ..Default::default()
    })
    .unwrap();
    writer
        .add_topic(TopicInfo::of::<PointCloud2>(TOPIC, QosProfile::sensor(5)))
        .unwrap();
    for (t, cloud) in clouds {
        let ns = (t * 1e9) as i64;
        let mut cloud = cloud.clone();
        cloud.header.stamp = Time::from_nanos(ns);
        writer.write(TOPIC, ns, ns, &to_cdr(&cloud)).unwrap();
    }
    writer.finish().unwrap();
    let options = ReplayOptions {
        params,
        record: Some(RecordOptions {
            path: output.clone(),
            ..Default::default()
        }),
        tail_s,
        ..Default::default()
    };
    let model = physskin::skinning::NeuralModel::bundled().unwrap();
    let bytes = std::fs::read(&input).unwrap();
    let summary = replay(&bytes, name, &model, &options, &mut |_| {}).unwrap();
    assert_eq!(summary.rejected, 0, "{summary:?}");
    let messages = read_messages(&std::fs::read(&output).unwrap(), "output").unwrap();
    (summary, messages)
}

/// The statuses of `event` on /physskin/status in a recording, with their log times (ns), in
/// their order.
#[allow(dead_code)] // only the tests that read statuses
pub fn statuses(
    messages: &[physskin::bag::BagMessage],
    event: &str,
) -> Vec<(i64, physskin::msg::Status)> {
    use physskin::msg::{from_cdr, Status};
    messages
        .iter()
        .filter(|m| m.topic == "/physskin/status")
        .map(|m| (m.log_time, from_cdr::<Status>(&m.data).unwrap()))
        .filter(|(_, s)| s.event == event)
        .collect()
}

/// target/ros-venv with rclpy (Fast DDS) from pip, for the tests that run a ROS 2 peer.
#[allow(dead_code)] // only the ROS 2 peer tests run rclpy
pub fn ros_venv() -> PathBuf {
    venv(
        "ros-venv",
        "import rclpy, sensor_msgs.msg, shape_msgs.msg, std_srvs.srv, diagnostic_msgs.msg, \
         visualization_msgs.msg, geometry_msgs.msg, rcl_interfaces.msg, numpy",
        &[
            "ros-rclpy",
            "ros-sensor-msgs",
            "ros-std-msgs",
            "ros-shape-msgs",
            "ros-rmw-fastrtps-cpp",
            "ros-std-srvs",
            "ros-diagnostic-msgs",
            "ros-visualization-msgs",
            "ros-geometry-msgs",
            "numpy",
        ],
    )
}
