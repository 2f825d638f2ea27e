//! The iceoryx2 hand-off between processes: physskin replays the demo and publishes on shared
//! memory; this test process (Rust) and a Python subscriber (pip's iceoryx2) read the frames in
//! place and check them. Each test uses its own service names, so tests can run in parallel.

mod common;

use std::collections::BTreeMap;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::root;
use physskin::shm::{FrameHeader, ShmSubscriber};

/// `physskin replay bags/demo.mcap --pace 1 --shm <prefix>` in the background.
fn publisher(prefix: &str) -> Child {
    Command::new(env!("CARGO_BIN_EXE_physskin"))
        .args(["replay", "bags/demo.mcap", "--pace", "1", "--shm", prefix])
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("physskin runs")
}

#[test]
fn a_second_rust_process_reads_frames_in_place() {
    let prefix = format!("physskin_test_{}/", std::process::id());
    // Subscribe first: the services keep no history for late joiners beyond the last frame.
    let deformed = ShmSubscriber::open(&format!("{prefix}deformed_points")).unwrap();
    let weights = ShmSubscriber::open(&format!("{prefix}weights")).unwrap();
    let mut child = publisher(&prefix);
    let mut points: BTreeMap<u32, u32> = BTreeMap::new();
    let mut sequences = Vec::new();
    let mut weight_frames = 0;
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(5) {
        deformed
            .receive(|h, xyz| {
                assert_eq!(h.kind, FrameHeader::DEFORMED);
                assert_eq!(xyz.len(), 3 * h.point_count as usize);
                assert!(xyz.iter().all(|v| v.is_finite()), "a non-finite coordinate");
                assert_eq!(h.handle_count, 17);
                points.insert(h.shape_id, h.point_count);
                sequences.push(h.sequence);
            })
            .unwrap();
        weights
            .receive(|h, w| {
                assert_eq!(h.kind, FrameHeader::WEIGHTS);
                let k = h.handle_count as usize;
                assert_eq!(w.len(), h.point_count as usize * k);
                assert!(
                    w.chunks(k).all(|row| row[0] == 1.0),
                    "w0 is the rigid handle"
                );
                weight_frames += 1;
            })
            .unwrap();
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    assert_eq!(weight_frames, 3, "one weights frame per shape");
    assert_eq!(
        points.values().copied().collect::<Vec<_>>(),
        vec![3000, 1760, 1056],
        "the demo's three shapes"
    );
    assert!(
        sequences.len() > 200,
        "{} deformed frames in 5 s",
        sequences.len()
    );
    assert!(
        sequences.windows(2).all(|w| w[1] > w[0]),
        "sequence numbers increase"
    );
}

#[test]
fn a_python_subscriber_reads_our_frames() {
    let python = common::venv(
        "shm-venv",
        "import iceoryx2, numpy",
        &["iceoryx2==0.10.0", "numpy"],
    );
    let prefix = format!("physskin_py_{}/", std::process::id());
    let peer = Command::new(python)
        .arg(root().join("tests/peers/shm_peer.py"))
        .arg(format!("{prefix}deformed_points"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Give the subscriber a moment to open the service.
    std::thread::sleep(Duration::from_secs(2));
    let mut child = publisher(&prefix);
    let out = peer.wait_with_output().unwrap();
    child.kill().unwrap();
    child.wait().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "Python subscriber failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("ok: "), "{stdout}");
    eprintln!("{stdout}");
}
