//! The Foxglove live view against the official client: npm's `@foxglove/ws-protocol` in
//! Node.js (tests/peers/foxglove_client.js) connects to `physskin node --foxglove`, lists the
//! channels, reads the parameters, decodes the deformed cloud and the markers, and pushes the
//! scene's block with an Interaction it publishes; it sets a parameter too. What it decoded is held against the node's
//! own recording of the same step (the recorder takes exactly what DDS publishes).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use physskin::msg::{from_cdr, schema_text, Interaction, PointCloud2};

const PACKAGES: [&str; 4] = [
    "@foxglove/ws-protocol@0.8.0",
    "@foxglove/rosmsg@5",
    "@foxglove/rosmsg2-serialization@3",
    "ws@8",
];

/// target/foxglove-npm with the official client's packages from npm (installed once).
fn npm_packages() -> PathBuf {
    let dir = common::root().join("target/foxglove-npm");
    let ready = PACKAGES.iter().all(|p| {
        let name = p.rsplit_once('@').map_or(*p, |(n, _)| n);
        dir.join("node_modules")
            .join(name)
            .join("package.json")
            .exists()
    });
    if !ready {
        std::fs::create_dir_all(&dir).unwrap();
        let installed = Command::new("npm")
            .args(["install", "--no-audit", "--no-fund", "--prefix"])
            .arg(&dir)
            .args(PACKAGES)
            .status();
        assert!(
            installed.is_ok_and(|s| s.success()),
            "npm could not install {PACKAGES:?} into {} (Node.js and npm are needed)",
            dir.display()
        );
    }
    dir
}

/// The recording's deformed clouds by stamp: (point count, the first three points).
fn recorded_clouds(path: &Path) -> Vec<(u128, usize, Vec<[f32; 3]>)> {
    let messages = physskin::bag::read_messages(&std::fs::read(path).unwrap(), "node").unwrap();
    messages
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
        .map(|m| {
            let cloud: PointCloud2 = from_cdr(&m.data).unwrap();
            let stamp =
                cloud.header.stamp.sec as u128 * 1_000_000_000 + cloud.header.stamp.nanosec as u128;
            let xyz = |i: usize| {
                let at = |o: usize| {
                    let b = &cloud.data[i * cloud.point_step as usize + o..][..4];
                    f32::from_le_bytes(b.try_into().unwrap())
                };
                [at(0), at(4), at(8)]
            };
            let count = (cloud.width * cloud.height) as usize;
            (stamp, count, (0..3.min(count)).map(xyz).collect())
        })
        .collect()
}

#[test]
fn the_official_client_sees_the_node_and_pushes_an_object() {
    let npm = npm_packages();
    let dir = common::root().join("target/foxglove");
    std::fs::create_dir_all(&dir).unwrap();
    let (out, schema, bag, log, dds) = (
        dir.join("client.json"),
        dir.join("interaction.msg"),
        dir.join("node.mcap"),
        dir.join("node.log"),
        dir.join("dds.json"),
    );
    let _ = std::fs::remove_file(&bag);
    std::fs::write(&schema, schema_text::<Interaction>()).unwrap();
    // rclpy takes the same clouds over DDS meanwhile, for the added latency.
    let script = format!(
        "{node} node --domain-id 43 --scene {scene} --foxglove 127.0.0.1:18765 --record {bag} \
         > {log} 2>&1 & NODE=$!; sleep 1; \
         ROS_DOMAIN_ID=43 {python} {peer} /physskin/deformed_points 8 {dds} & PEER=$!; \
         NODE_PATH={modules} timeout 90 node {client} ws://127.0.0.1:18765 {out} {schema} \
         /physskin; RC=$?; wait $PEER; PEER_RC=$?; kill -INT $NODE; wait $NODE; NODE_RC=$?; \
         echo node exit $NODE_RC, rclpy exit $PEER_RC; \
         exit $(( RC != 0 ? RC : (PEER_RC != 0 ? PEER_RC : NODE_RC) ))",
        python = common::ros_venv().display(),
        peer = common::root().join("tests/peers/arrival_peer.py").display(),
        dds = dds.display(),
        node = env!("CARGO_BIN_EXE_physskin"),
        scene = common::root().join("config/scenes/grasp.yaml").display(),
        bag = bag.display(),
        log = log.display(),
        modules = npm.join("node_modules").display(),
        client = common::root()
            .join("tests/peers/foxglove_client.js")
            .display(),
        out = out.display(),
        schema = schema.display(),
    );
    let run = Command::new("unshare")
        .arg("-n")
        .arg(common::root().join("tests/peers/private_net.sh"))
        .args(["bash", "-c", &script])
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let stdout = String::from_utf8_lossy(&run.stdout);
    let node_log = std::fs::read_to_string(&log).unwrap_or_default();
    assert!(
        run.status.success(),
        "client or node failed\n{stdout}\n{}\nnode log:\n{node_log}",
        String::from_utf8_lossy(&run.stderr)
    );
    println!("{stdout}");
    assert!(
        node_log.contains("Foxglove live view on ws://127.0.0.1:18765"),
        "{node_log}"
    );
    let seen: serde_json::Value = serde_json::from_slice(&std::fs::read(&out).unwrap()).unwrap();

    // The library's own name for the protocol and the SDK's are each taken, and echoed.
    let mut protocols: Vec<&str> = seen["protocols"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect();
    protocols.sort_unstable();
    assert_eq!(protocols, ["foxglove.sdk.v1", "foxglove.websocket.v1"]);

    // Every output topic, the interaction topic, /tf and /diagnostics are cdr channels with
    // their ROS 2 schemas; the parameters are there.
    let channels = seen["channels"].as_array().unwrap();
    for (topic, schema) in [
        ("/physskin/deformed_points", "sensor_msgs/msg/PointCloud2"),
        ("/physskin/markers", "visualization_msgs/msg/MarkerArray"),
        ("/physskin/state", "physskin/msg/SubspaceState"),
        ("/physskin/status", "physskin/msg/Status"),
        ("/physskin/interaction", "physskin/msg/Interaction"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
    ] {
        assert!(
            channels.iter().any(|c| c["topic"] == topic
                && c["schemaName"] == schema
                && c["encoding"] == "cdr"),
            "{topic} as {schema} in cdr among {channels:?}"
        );
    }
    let parameters = seen["parameters"].as_array().unwrap();
    assert!(parameters.iter().any(|p| p == "rate_hz"), "{parameters:?}");
    // Set as `ros2 param set` sets: material.young is taken, the read-only rate_hz is not.
    let applied = &seen["setApplied"];
    assert_eq!(
        applied,
        &serde_json::json!([["material.young", 300000]]),
        "{applied}"
    );
    assert!(seen["markers"]
        .as_array()
        .unwrap()
        .iter()
        .any(|m| m["points"].as_u64() > Some(0)));

    // Each decoded cloud is the recorded (DDS) cloud of the same stamp.
    let recorded = recorded_clouds(&bag);
    let clouds = seen["clouds"].as_array().unwrap();
    let mut matched = 0;
    for c in clouds {
        let stamp: u128 = c["stampNs"].as_str().unwrap().parse().unwrap();
        let Some((_, count, first)) = recorded.iter().find(|r| r.0 == stamp) else {
            continue;
        };
        assert_eq!(c["count"].as_u64().unwrap() as usize, *count);
        for (a, b) in c["first"].as_array().unwrap().iter().zip(first) {
            for d in 0..3 {
                assert_eq!(a[d].as_f64().unwrap() as f32, b[d], "stamp {stamp}");
            }
        }
        matched += 1;
    }
    assert!(
        matched * 10 >= clouds.len() * 9,
        "{matched} of {} clouds found in the recording",
        clouds.len()
    );

    report_added_latency(clouds, &dds);

    // The push moved the block along +y.
    let pushed: u128 = seen["pushedAtNs"].as_str().unwrap().parse().unwrap();
    let y = |c: &serde_json::Value| c["centroid"][1].as_f64().unwrap();
    let before = clouds
        .iter()
        .filter(|c| c["stampNs"].as_str().unwrap().parse::<u128>().unwrap() < pushed)
        .map(y)
        .next_back()
        .unwrap();
    let after = clouds.iter().map(y).fold(f64::MIN, f64::max);
    assert!(
        after - before > 0.005,
        "the block moved {} m along y",
        after - before
    );
}

/// Prints how much later each cloud reached the Foxglove client than rclpy's DDS subscriber
/// (the same stamps, both on this machine's wall clock). Reported, not asserted.
fn report_added_latency(clouds: &[serde_json::Value], dds: &Path) {
    let dds: serde_json::Value = serde_json::from_slice(&std::fs::read(dds).unwrap()).unwrap();
    let by_stamp: std::collections::HashMap<u64, i64> = dds["stamp_ns"]
        .as_array()
        .unwrap()
        .iter()
        .zip(dds["arrived_ns"].as_array().unwrap())
        .map(|(s, a)| (s.as_u64().unwrap(), a.as_i64().unwrap()))
        .collect();
    let mut added: Vec<f64> = clouds
        .iter()
        .filter_map(|c| {
            let stamp: u64 = c["stampNs"].as_str()?.parse().ok()?;
            let foxglove: i64 = c["arrivedNs"].as_str()?.parse().ok()?;
            Some((foxglove - by_stamp.get(&stamp)?) as f64 / 1e6)
        })
        .collect();
    assert!(
        added.len() > 50,
        "{} clouds reached both clients",
        added.len()
    );
    added.sort_by(f64::total_cmp);
    let q = |f: f64| added[((f * added.len() as f64) as usize).min(added.len() - 1)];
    println!(
        "Foxglove after DDS (rclpy), ms over {} clouds: median {:.3}, p99 {:.3}, min {:.3}",
        added.len(),
        q(0.5),
        q(0.99),
        added[0]
    );
}
