//! A short soak of the node (the README reports the 10-minute one): changing shapes, pokes,
//! pins, bad inputs and two 30 Hz streams through DDS in a private network namespace. Bad
//! inputs are answered on the status topic while the other objects keep publishing finite
//! states, and the split
//! recording reads back complete.

use std::path::Path;
use std::process::Command;

#[test]
fn a_short_soak_keeps_serving_and_records_everything() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let record = root.join("target/test-soak/soak.mcap");
    let out = Command::new("unshare")
        .arg("-n")
        .arg(root.join("tests/peers/private_net.sh"))
        .arg(env!("CARGO_BIN_EXE_physskin"))
        .args([
            "bench",
            "soak",
            "--json",
            "--seconds",
            "40",
            "--domain-id",
            "41",
        ])
        .arg("--record")
        .arg(&record)
        .output()
        .expect("unshare runs (root is needed for a private network namespace)");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "soak failed:\n{stderr}");
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON report");
    eprintln!("{r:#}");
    let count = |key: &str| r[key].as_u64().unwrap_or(0);
    let status = |event: &str| r["statuses"][event].as_u64().unwrap_or(0);
    assert!(
        count("shapes_sent") >= 15 && count("pokes_sent") >= 300,
        "{r}"
    );
    assert!(count("ticks") >= 1000, "{r}");
    assert!(count("states_received") >= 1000, "{r}");
    assert_eq!(count("non_finite_states"), 0, "{r}");
    // Every bad cloud is refused and every NaN poke ignored, each with a status.
    let bad = count("bad_inputs_sent");
    assert!(bad >= 6, "{r}");
    assert!(status("input_rejected") >= bad / 2, "{r}");
    assert!(status("interaction_ignored") >= bad / 2, "{r}");
    assert!(status("shape_ready") >= 10, "{r}");
    // Two streamed objects, one pushed now and then, one leaving the view and coming back:
    // built once each, every later frame tracked.
    assert!(count("stream_frames_sent") >= 1000, "{r}");
    assert_eq!(count("stream_builds"), 2, "{r}");
    assert!(status("tracking_resumed") >= 3, "{r}");
    assert_eq!(r["recording_complete"], true, "{r}");
    assert!(count("recording_files") >= 1, "{r}");
    let recorded = |topic: &str| r["recorded"][topic].as_u64().unwrap_or(0);
    assert!(recorded("/physskin/state") >= 1000, "{r}");
    assert!(recorded("/physskin/points") >= count("shapes_sent"), "{r}");
    assert!(
        recorded("/physskin/status") >= status("input_rejected"),
        "{r}"
    );
}
