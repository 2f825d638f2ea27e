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
    // A subscriber that keeps up gets every frame: the replay's catch-up after a slow build
    // included.
    assert!(
        sequences.windows(2).all(|w| w[1] == w[0] + 1),
        "sequence numbers without gaps: {sequences:?}"
    );
    assert_eq!(deformed.lost(), 0);
}

/// A subscriber that falls behind is told how many frames it lost: the publisher sends more
/// than the service holds for it, and the oldest are overwritten.
#[test]
fn a_subscriber_that_falls_behind_counts_what_it_lost() {
    use physskin::shm::{ShmOptions, ShmPublisher, SUBSCRIBER_BUFFER};
    let prefix = format!("physskin_behind_{}/", std::process::id());
    let options = ShmOptions {
        deformed_service: format!("{prefix}deformed_points"),
        weights_service: format!("{prefix}weights"),
        initial_max_floats: 300,
    };
    let subscriber = ShmSubscriber::open(&options.deformed_service).unwrap();
    let publisher = ShmPublisher::create(&options).unwrap();
    let xyz = vec![0.5f32; 300];
    let sent = SUBSCRIBER_BUFFER + 36;
    for frame in 0..sent {
        publisher
            .publish_deformed(1, frame as i64, 2, &xyz)
            .unwrap();
    }
    let mut sequences = Vec::new();
    let received = subscriber
        .receive(|h, values| {
            assert_eq!(values.len(), 300);
            sequences.push(h.sequence);
        })
        .unwrap();
    assert_eq!(
        received, SUBSCRIBER_BUFFER,
        "the newest frames the service held"
    );
    assert_eq!(sequences.last(), Some(&(sent as u64 - 1)));
    // The first frame it got tells it nothing of those before; the next gap does.
    publisher.publish_deformed(1, 0, 2, &xyz).unwrap();
    assert_eq!(subscriber.receive(|_, _| {}).unwrap(), 1);
    assert_eq!(
        subscriber.lost(),
        0,
        "no gap after the first frame received"
    );
    for frame in 0..(SUBSCRIBER_BUFFER + 10) {
        publisher
            .publish_deformed(1, frame as i64, 2, &xyz)
            .unwrap();
    }
    subscriber.receive(|_, _| {}).unwrap();
    assert_eq!(subscriber.lost(), 10);
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
