//! The node against a real ROS 2 (rclpy with Fast DDS from pip), in a private network namespace:
//! rclpy publishes a PointCloud2 (float64/float32 mixed, big-endian) and a Mesh; the node must
//! answer with deformed clouds and weights clouds whose contents the peer checks. And rclpy
//! drives a scene's robot over sensor_msgs/JointState: the press it lowers dents the block the
//! node simulates.

mod common;

use std::path::Path;
use std::process::Command;

/// Runs `physskin node --domain-id <domain> <node_args>` and the Python `peer` against it in a
/// private network namespace; the node is stopped with SIGINT after the peer. Returns the
/// peer's stdout and the node's log; fails the test, with both, unless both exit 0.
fn node_with_peer(domain: u16, node_args: &str, peer: &str, log_name: &str) -> (String, String) {
    let python = common::ros_venv();
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

/// The statuses of `event` in a node's recording, in their order.
fn statuses_of(messages: &[physskin::bag::BagMessage], event: &str) -> Vec<physskin::msg::Status> {
    common::statuses(messages, event)
        .into_iter()
        .map(|(_, s)| s)
        .collect()
}

/// Runs a bash `script` in a private network namespace; fails the test, with its output and
/// the named logs, unless it exits 0. Returns its stdout.
fn in_private_net(script: &str, logs: &[&Path]) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new("unshare")
        .arg("-n")
        .arg(root.join("tests/peers/private_net.sh"))
        .args(["bash", "-c", script])
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let logs: String = logs
        .iter()
        .map(|p| {
            format!(
                "--- {}:\n{}\n",
                p.display(),
                std::fs::read_to_string(p).unwrap_or_default()
            )
        })
        .collect();
    assert!(
        out.status.success(),
        "failed\nstdout:\n{stdout}\nstderr:\n{}\n{logs}",
        String::from_utf8_lossy(&out.stderr)
    );
    eprintln!("{stdout}");
    stdout
}

/// Two instances started as launch_ros starts a Node action (`--ros-args -r __node:=skin
/// -r __ns:=/cell --params-file ... -p rate_hz:=30.0 -r ~/points:=/camera/points`), and one in
/// /cell2: rclpy lists and reads them, gets deformed clouds at 30 Hz, /rosout, /diagnostics,
/// markers, and calls ~/reset and ~/clear; /cell2 hears nothing of /cell; SIGINT exits 0.
#[test]
fn launch_ros_argv_names_rosout_diagnostics_services_and_markers() {
    let python = common::ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = root.join("target");
    // What launch_ros writes for `parameters=[{'material.young': 3e5}]`: the node's full name,
    // dotted keys; and a shared file with a parameter of another node.
    let dict = target.join("launch_params_graph.yaml");
    std::fs::write(
        &dict,
        "/cell/skin:\n  ros__parameters:\n    material.young: 300000.0\n",
    )
    .unwrap();
    let shared = target.join("graph-shared.yaml");
    std::fs::write(
        &shared,
        "/**:\n  ros__parameters:\n    camera_fps: 30\n    markers:\n      rate_hz: 15.0\n",
    )
    .unwrap();
    let (log_a, log_b) = (
        target.join("graph-cell.log"),
        target.join("graph-cell2.log"),
    );
    let node = env!("CARGO_BIN_EXE_physskin");
    let script = format!(
        "{node} node --domain-id 33 --ros-args -r __node:=skin -r __ns:=/cell \
           --params-file {dict} --params-file {shared} -p rate_hz:=30.0 \
           -r '~/points:=/camera/points' > {a} 2>&1 & A=$!; \
         {node} node --domain-id 33 --ros-args -r __node:=skin -r __ns:=/cell2 \
           -p shm.enabled:=false > {b} 2>&1 & B=$!; \
         ROS_DOMAIN_ID=33 timeout 200 {python} {peer}; RC=$?; \
         kill -INT $A $B; wait $A; RA=$?; wait $B; RB=$?; \
         echo node exits $RA $RB; exit $(( RC != 0 ? RC : (RA != 0 ? RA : RB) ))",
        dict = dict.display(),
        shared = shared.display(),
        a = log_a.display(),
        b = log_b.display(),
        python = python.display(),
        peer = root.join("tests/peers/graph_peer.py").display(),
    );
    let stdout = in_private_net(&script, &[&log_a, &log_b]);
    assert!(stdout.contains("ok: graph"), "{stdout}");
    assert!(stdout.contains("node exits 0 0"), "{stdout}");
    let log = std::fs::read_to_string(&log_a).unwrap();
    // The shared section's parameter of another node is a warning, not a stop.
    assert!(
        log.contains("camera_fps") && log.contains("ignored"),
        "{log}"
    );
    assert!(
        log.contains("/cell/skin listening on /camera/points"),
        "{log}"
    );
}

/// A mesh published once (reliable, transient local) before the node starts is built.
#[test]
fn a_mesh_published_before_the_node_starts_is_built() {
    let python = common::ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let log = root.join("target/late-mesh-node.log");
    let script = format!(
        "ROS_DOMAIN_ID=34 timeout 120 {python} {peer} & P=$!; sleep 3; \
         {node} node --domain-id 34 > {log} 2>&1 & N=$!; \
         wait $P; RC=$?; kill -INT $N; wait $N; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        python = python.display(),
        peer = root.join("tests/peers/late_mesh_peer.py").display(),
        log = log.display(),
    );
    let stdout = in_private_net(&script, &[&log]);
    assert!(stdout.contains("ok: late mesh"), "{stdout}");
}

/// tf2 with a bag written by the official MCAP writer: /tf_static puts an optical frame 0.5 m
/// above world, looking along world +x; a box cloud in that frame, replayed with
/// `fixed_frame: world` and `support: free`, falls along world -z (checked by the official
/// reader).
#[test]
fn a_cloud_in_an_optical_frame_falls_along_world_minus_z() {
    let python = common::venv(
        "bag-venv",
        "import mcap, mcap_ros2, rosbags, yaml",
        &["mcap", "mcap-ros2-support", "rosbags", "pyyaml"],
    );
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (bag, out) = (
        root.join("target/tf-input.mcap"),
        root.join("target/tf-replayed.mcap"),
    );
    let peer = root.join("tests/peers/tf_bag.py");
    let run = |args: &[&std::ffi::OsStr], what: &str| {
        let o = Command::new(&python)
            .arg(&peer)
            .args(args)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            o.status.success(),
            "{what}: {text}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        text
    };
    run(&["write".as_ref(), bag.as_os_str()], "writing the bag");
    let (bag_path, out_path) = (bag.display().to_string(), out.display().to_string());
    let json = common::physskin_json(&[
        "replay",
        &bag_path,
        "--out",
        &out_path,
        "--json",
        "--ros-args",
        "-p",
        "fixed_frame:=world",
        "-p",
        "simulation.support:=free",
    ]);
    assert_eq!(json["rejected"], 0, "{json}");
    let checked = run(&["check".as_ref(), out.as_os_str()], "checking the replay");
    assert!(checked.contains("ok: tf2"), "{checked}");
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

/// rclpy sends a segmenting camera's organized, coloured, labelled cloud in its optical frame
/// (a ball, a box, the table as background) and reads both objects back with their colours in
/// place; the node's recording shows two builds and the same two shape ids throughout.
#[test]
fn rclpy_labelled_coloured_scan_in_an_optical_frame_becomes_two_objects() {
    use physskin::msg::{from_cdr, to_cdr, SubspaceState};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scan = root.join("target/labelled-scan.cdr");
    std::fs::write(&scan, to_cdr(&common::scenes::table_scene(160, 120))).unwrap();
    let bag = root.join("target/labelled-scan-node.mcap");
    let _ = std::fs::remove_file(&bag);
    let (stdout, log) = node_with_peer(
        34,
        &format!("--record {}", bag.display()),
        &format!("labelled_scan_peer.py {}", scan.display()),
        "labelled-scan-node.log",
    );
    assert!(stdout.contains("ok: labelled scan"), "{stdout}");
    let messages =
        physskin::bag::read_messages(&std::fs::read(&bag).unwrap(), "node recording").unwrap();
    let statuses = |event: &str| statuses_of(&messages, event);
    let ready = statuses("shape_ready");
    assert_eq!(ready.len(), 2, "one build per object: {ready:?}\n{log}");
    // Each object started on the network's field and switched to its refinement while it ran,
    // no point jumping a millimetre.
    let refined = statuses("field_refined");
    assert_eq!(
        refined.len(),
        2,
        "one switch per object: {refined:?}\n{log}"
    );
    for status in &refined {
        let jump_mm: f64 = status
            .message
            .split("largest jump at the switch ")
            .nth(1)
            .and_then(|rest| rest.trim_end_matches(" mm").parse().ok())
            .unwrap_or_else(|| panic!("no jump in {status:?}"));
        assert!(jump_mm < 1.0, "{status:?}");
    }
    let ids: std::collections::BTreeSet<u32> = messages
        .iter()
        .filter(|m| m.topic == "/physskin/state")
        .map(|m| from_cdr::<SubspaceState>(&m.data).unwrap().shape_id)
        .collect();
    assert_eq!(ids.len(), 2, "two objects, their ids kept: {ids:?}");
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

/// rclpy streams one camera's noisy view of a resting ball at 30 Hz for 5 s, then another
/// object in the same frame, then nothing: the node builds the ball once, switches it to its
/// refined field, keeps its point count, reports the tracking residual, replaces it when the
/// other object appears (`object_replaced`, a new build) and pauses tracking when the stream
/// stops (`tracking_paused`).
#[test]
fn rclpy_stream_is_one_object_kept_replaced_and_paused() {
    use physskin::msg::{from_cdr, to_cdr, SubspaceState};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = root.join("target/stream-frames");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (ball, other) = (
        common::scenes::stream_ball(),
        common::scenes::stream_block(),
    );
    for i in 0..30u64 {
        let cloud = common::scenes::noisy_view(&ball, i);
        std::fs::write(dir.join(format!("ball_{i:02}.cdr")), to_cdr(&cloud)).unwrap();
    }
    for i in 0..5u64 {
        let cloud = common::scenes::noisy_view(&other, 100 + i);
        std::fs::write(dir.join(format!("other_{i:02}.cdr")), to_cdr(&cloud)).unwrap();
    }
    let bag = root.join("target/stream-node.mcap");
    let _ = std::fs::remove_file(&bag);
    let (stdout, log) = node_with_peer(
        35,
        &format!("--record {}", bag.display()),
        &format!("stream_peer.py {}", dir.display()),
        "stream-node.log",
    );
    assert!(stdout.contains("ok: stream tracked"), "{stdout}");
    let messages =
        physskin::bag::read_messages(&std::fs::read(&bag).unwrap(), "node recording").unwrap();
    let statuses = |event: &str| statuses_of(&messages, event);
    let ready = statuses("shape_ready");
    assert_eq!(
        ready.len(),
        2,
        "the ball once, then the other object: {ready:?}\n{log}"
    );
    let ball_id = ready[0].shape_id;
    let refined = statuses("field_refined");
    assert!(
        refined.iter().any(|s| s.shape_id == ball_id),
        "the ball's refined field is switched in while frames arrive: {refined:?}\n{log}"
    );
    assert!(statuses("refine_skipped").is_empty(), "{log}");
    let replaced = statuses("object_replaced");
    assert_eq!(replaced.len(), 1, "{replaced:?}\n{log}");
    assert_eq!(replaced[0].shape_id, ball_id);
    let paused = statuses("tracking_paused");
    assert!(
        paused.iter().any(|s| s.shape_id == ready[1].shape_id),
        "the stream's end pauses the tracking: {paused:?}\n{log}"
    );
    let tracked: Vec<SubspaceState> = messages
        .iter()
        .filter(|m| m.topic == "/physskin/state")
        .map(|m| from_cdr::<SubspaceState>(&m.data).unwrap())
        .filter(|s| s.shape_id == ball_id && s.tracking_points > 0)
        .collect();
    assert!(
        tracked.len() > 100,
        "{} tracked states of the ball",
        tracked.len()
    );
    let worst = tracked
        .iter()
        .map(|s| s.tracking_residual_m)
        .fold(0.0, f64::max);
    assert!(worst > 0.0 && worst < 0.005, "residual up to {worst} m");
}

/// `physskin replay bags/demo.mcap --publish` feeds a running node: the demo's three shapes
/// (a cloud, a mesh, a stamped mesh) are built by the node from the recording's inputs, and its
/// pokes arrive as interactions.
#[test]
fn replay_publish_feeds_a_running_node() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let log = root.join("target/publish-node.log");
    let script = format!(
        "{node} node --domain-id 35 > {log} 2>&1 & N=$!; \
         {node} replay {bag} --publish --pace 2 --domain-id 35; RC=$?; sleep 1; \
         kill -INT $N; wait $N; NODE_RC=$?; \
         echo node exit $NODE_RC; exit $(( RC != 0 ? RC : NODE_RC ))",
        node = env!("CARGO_BIN_EXE_physskin"),
        bag = root.join("bags/demo.mcap").display(),
        log = log.display(),
    );
    let stdout = in_private_net(&script, &[&log]);
    let text = std::fs::read_to_string(&log).unwrap();
    let built = text.matches("shape_ready").count();
    assert_eq!(built, 3, "the node built {built} shapes\n{stdout}\n{text}");
    assert!(
        stdout.contains("messages on /physskin/interaction"),
        "{stdout}"
    );
    assert!(!text.contains("input_rejected"), "{text}");
}

/// Two instances in one namespace, started as launch_ros starts config/launch/shards.launch.py's
/// (`-r __node:=skin_k -r __ns:=/cell -p instances.shard:=k/2`, the camera topic remapped),
/// split rclpy's labelled cloud of eight objects four each: rclpy receives every object's
/// deformed cloud from exactly one of them, and each names its shard on /diagnostics and in its
/// builds (tests/peers/shards_peer.py).
#[test]
fn two_instances_split_a_labelled_cloud_of_eight_objects() {
    use physskin::msg::to_cdr;
    let python = common::ros_venv();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let target = root.join("target");
    let scan = target.join("shards-scan.cdr");
    std::fs::write(
        &scan,
        to_cdr(&common::scenes::objects_on_a_table(8, 320, 240)),
    )
    .unwrap();
    let logs = [0, 1].map(|k| target.join(format!("shards-{k}.log")));
    let node = env!("CARGO_BIN_EXE_physskin");
    let instance = |k: usize| {
        format!(
            "{node} node --domain-id 41 --ros-args -r __node:=skin_{k} -r __ns:=/cell \
               -p instances.shard:={k}/2 -p shm.deformed_service:=physskin/skin_{k}/deformed_points \
               -p shm.weights_service:=physskin/skin_{k}/weights \
               -r '~/points:=/camera/points' > {log} 2>&1",
            log = logs[k].display()
        )
    };
    let script = format!(
        "{a} & A=$!; {b} & B=$!; \
         ROS_DOMAIN_ID=41 timeout 200 {python} {peer} {scan}; RC=$?; \
         kill -INT $A $B; wait $A; RA=$?; wait $B; RB=$?; \
         echo node exits $RA $RB; exit $(( RC != 0 ? RC : (RA != 0 ? RA : RB) ))",
        a = instance(0),
        b = instance(1),
        python = python.display(),
        peer = root.join("tests/peers/shards_peer.py").display(),
        scan = scan.display(),
    );
    let stdout = in_private_net(&script, &[&logs[0], &logs[1]]);
    assert!(stdout.contains("ok: shards"), "{stdout}");
    assert!(stdout.contains("node exits 0 0"), "{stdout}");
    for (k, log) in logs.iter().enumerate() {
        let log = std::fs::read_to_string(log).unwrap();
        let ready = log.lines().filter(|l| l.contains("shape_ready")).count();
        assert_eq!(ready, 4, "one build per object of shard {k}:\n{log}");
        assert!(log.contains(&format!("(shard {k}/2)")), "{log}");
    }
}

/// The robot the ROS way: rclpy publishes the gripper's URDF on robot_description (transient
/// local) and its joints on /joint_states; the gripper closes on a soft block that arrived as a
/// cloud, lifts it 0.2 m, and holds it (tests/peers/gripper_peer.py).
#[test]
fn rclpy_robot_description_gripper_lifts_a_cloud_block() {
    let (stdout, log) = node_with_peer(
        42,
        "--ros-args -p fixed_frame:=world -p simulation.support:=floor -p simulation.friction:=0.5",
        "gripper_peer.py",
        "ros2-gripper-node.log",
    );
    assert!(
        stdout.contains("ok: robot_description gripper lifted the block"),
        "{stdout}"
    );
    assert!(
        log.contains("robot `gripper` from robot_description: 4 links, 3 collision shapes"),
        "{log}"
    );
}
