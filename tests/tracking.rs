//! Streams of clouds (issue 70): one camera's noisy view of a resting ball at 30 Hz replayed
//! through the node's pipeline is one object, built once and corrected by every frame; its
//! deformed cloud keeps the points it was built from; a blocked view pauses the tracking and
//! frames re-lock it; another object in the frame replaces it. The replay reproduces itself
//! byte for byte, and `tracking.enabled: false` rebuilds from every frame as before. Against
//! the FEM, `bench track`'s poked ball stays within 2 % of its diagonal (issue 70 asks for 1 %).

use physskin::bag::BagMessage;
use physskin::msg::{from_cdr, PointCloud2, Status, SubspaceState};
use physskin::replay::ReplaySummary;
use physskin::runtime::NodeParams;

mod common;

use common::scenes::{noisy_view, stream_ball, stream_block};

/// The ball at rest for 2 s at 30 Hz, no frame for 0.5 s, the ball again for 0.5 s, then a
/// box in its place for 0.5 s.
fn stream() -> Vec<(f64, PointCloud2)> {
    let (ball, block) = (stream_ball(), stream_block());
    let mut clouds = Vec::new();
    for frame in 0..105u64 {
        let t = frame as f64 / 30.0;
        if (2.0..2.5).contains(&t) {
            continue;
        }
        let object = if t < 3.0 { &ball } else { &block };
        clouds.push((t, noisy_view(object, frame)));
    }
    clouds
}

/// Replays `clouds` with `params`, recording every output.
fn replay_stream(
    name: &str,
    clouds: &[(f64, PointCloud2)],
    params: NodeParams,
) -> (ReplaySummary, Vec<BagMessage>) {
    common::replay_clouds("test-tracking", name, clouds, params, 0.3)
}

/// The statuses of `event`, each with its log time in seconds.
fn statuses(messages: &[BagMessage], event: &str) -> Vec<(f64, Status)> {
    common::statuses(messages, event)
        .into_iter()
        .map(|(t, s)| (t as f64 / 1e9, s))
        .collect()
}

#[test]
fn a_stream_is_one_object_tracked_paused_relocked_and_replaced() {
    let clouds = stream();
    let (summary, out) = replay_stream("stream", &clouds, NodeParams::default());
    let ready = statuses(&out, "shape_ready");
    for (t, s) in &ready {
        println!("{t:.3} s: {}", s.message);
    }
    assert_eq!(
        ready.len(),
        2,
        "the ball built once, then the box that replaced it"
    );
    let (ball, block) = (ready[0].1.shape_id, ready[1].1.shape_id);
    assert_ne!(ball, block);
    assert!(ready[1].0 >= 3.0, "the box builds after it appears");
    assert!(summary.observations >= 60, "{summary:?}");

    // The ball's deformed cloud keeps the points it was built from, in their order.
    let clouds_out: Vec<(u32, PointCloud2)> = out
        .iter()
        .filter(|m| m.topic == "/physskin/deformed_points")
        .map(|m| from_cdr::<PointCloud2>(&m.data).unwrap())
        .zip(
            out.iter()
                .filter(|m| m.topic == "/physskin/state")
                .map(|m| from_cdr::<SubspaceState>(&m.data).unwrap().shape_id),
        )
        .map(|(c, id)| (id, c))
        .collect();
    let ball_clouds: Vec<&PointCloud2> = clouds_out
        .iter()
        .filter(|(id, _)| *id == ball)
        .map(|(_, c)| c)
        .collect();
    assert!(
        ball_clouds.len() > 150,
        "{} deformed clouds of the ball",
        ball_clouds.len()
    );
    let sizes: std::collections::BTreeSet<usize> =
        ball_clouds.iter().map(|c| c.data.len()).collect();
    assert_eq!(
        sizes.len(),
        1,
        "one point count for as long as the ball lives: {sizes:?}"
    );

    // Its state reports the tracking residual: a few mm on a resting ball seen with noise.
    let states: Vec<SubspaceState> = out
        .iter()
        .filter(|m| m.topic == "/physskin/state")
        .map(|m| from_cdr::<SubspaceState>(&m.data).unwrap())
        .filter(|s| s.shape_id == ball && s.tracking_points > 0)
        .collect();
    assert!(states.len() > 100, "{} tracked states", states.len());
    let worst = states
        .iter()
        .map(|s| s.tracking_residual_m)
        .fold(0.0, f64::max);
    assert!(worst > 0.0 && worst < 0.005, "residual up to {worst} m");

    let of_ball = |event: &str| -> Vec<(f64, Status)> {
        statuses(&out, event)
            .into_iter()
            .filter(|(_, s)| s.shape_id == ball)
            .collect()
    };
    let (paused, resumed) = (of_ball("tracking_paused"), of_ball("tracking_resumed"));
    assert_eq!(paused.len(), 1, "{paused:?}");
    assert!(
        paused[0].0 > 2.0 && paused[0].0 < 2.5,
        "paused at {} s",
        paused[0].0
    );
    assert_eq!(resumed.len(), 1, "{resumed:?}");
    assert!(
        (resumed[0].0 - 2.5).abs() < 0.05,
        "resumed at {} s",
        resumed[0].0
    );

    let replaced = statuses(&out, "object_replaced");
    assert_eq!(replaced.len(), 1, "{replaced:?}");
    let (at, why) = &replaced[0];
    assert_eq!(why.shape_id, ball);
    assert!(*at > 3.0 && *at < ready[1].0 + 1e-9, "replaced at {at} s");
    assert!(why.message.contains("unexplained"), "{}", why.message);

    // Two replays of the stream give the same messages, byte for byte.
    let (_, again) = replay_stream("stream-again", &clouds, NodeParams::default());
    assert_eq!(again.len(), out.len());
    for (x, y) in again.iter().zip(&out) {
        assert_eq!((&x.topic, x.log_time), (&y.topic, y.log_time));
        assert!(x.data == y.data, "{} at {} differs", x.topic, x.log_time);
    }
}

#[test]
fn without_tracking_every_frame_rebuilds_the_object() {
    let clouds: Vec<_> = stream().into_iter().take(8).collect();
    let params = common::params(&[("tracking.enabled", serde_json::json!(false))]);
    let (summary, out) = replay_stream("rebuild", &clouds, params);
    // The first frame builds; each later one differs (noise) and rebuilds the object in place.
    assert_eq!(summary.observations, 0);
    let ready = statuses(&out, "shape_ready");
    assert_eq!(
        ready.len(),
        clouds.len(),
        "one build per frame without tracking"
    );
}

/// `bench track --sequence SEQUENCE --modes MODES --json`, with `extra` arguments.
fn bench_track(sequence: &str, modes: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "bench",
        "track",
        "--sequence",
        sequence,
        "--modes",
        modes,
        "--json",
    ];
    args.extend_from_slice(extra);
    common::physskin_json(&args)
}

/// The report's row of `mode` (its first, with several seeds), printed.
fn row_of(report: &serde_json::Value, mode: &str) -> serde_json::Value {
    let row = (report["rows"].as_array().unwrap().iter())
        .find(|r| r["mode"] == mode)
        .unwrap()
        .clone();
    println!("{row}");
    row
}

/// `bench track`'s poked ball for 1.5 s, uncorrected and tracked, with `extra` arguments: the
/// report, its tracked row and its uncorrected one.
fn poked_ball(extra: &[&str]) -> (serde_json::Value, serde_json::Value, serde_json::Value) {
    let mut args = vec!["--seconds", "1.5"];
    args.extend_from_slice(extra);
    let report = bench_track("ball poked", "uncorrected,tracked", &args);
    let (tracked, open) = (row_of(&report, "tracked"), row_of(&report, "uncorrected"));
    (report, tracked, open)
}

/// One build; issue 70's 1 % on the seen points and on the side never seen; a third of the
/// uncorrected body's error.
fn assert_tracked_within_one_percent(tracked: &serde_json::Value, open: &serde_json::Value) {
    assert_eq!(tracked["builds"], 1);
    let error = tracked["seen_error_pct"].as_f64().unwrap();
    let hidden = tracked["hidden_error_pct"].as_f64().unwrap();
    assert!(
        error <= 1.0,
        "tracked material-point error {error} % of the diagonal"
    );
    assert!(hidden <= 1.0, "the side never seen {hidden} %");
    assert!(error <= open["seen_error_pct"].as_f64().unwrap() / 3.0);
}

/// Over these 1.5 s the poked ball came out at 0.8359 % (printed), its unseen side 0.7654 %.
#[test]
fn the_poked_ball_of_bench_track_is_tracked_within_one_percent() {
    let (_, tracked, open) = poked_ball(&["--plot", "target/test-tracking/track.svg"]);
    assert_tracked_within_one_percent(&tracked, &open);
}

/// The same ball seen from steeper above (`--view`): a tracker tuned from one side must hold
/// from another. Over these 1.5 s it came out at 0.5250 % (printed), uncorrected 15.2311 %.
#[test]
fn the_poked_ball_is_tracked_within_one_percent_from_above_too() {
    let (report, tracked, open) = poked_ball(&[
        "--view",
        "0.5,0.3,1",
        "--plot",
        "target/test-tracking/track-above.svg",
    ]);
    let direction: Vec<f64> = (report["camera_direction"].as_array().unwrap().iter())
        .map(|c| c.as_f64().unwrap())
        .collect();
    let norm = (0.25f64 + 0.09 + 1.0).sqrt();
    for (got, want) in direction.iter().zip([0.5 / norm, 0.3 / norm, 1.0 / norm]) {
        assert!((got - want).abs() < 1e-9, "camera toward {direction:?}");
    }
    assert_tracked_within_one_percent(&tracked, &open);
}

/// A block nothing touches. Uncorrected, its body stays where the first frame put it: off by
/// that frame's noise alone, the bench's observation floor. Tracked, the frames move it (0.2307
/// % against 0.1132 % over 2.5 s, printed; docs/tracking.md says why); the test holds that error
/// to within three times the uncorrected one.
#[test]
fn a_block_at_rest_is_off_by_its_frames_noise_uncorrected_and_tracked_near_it() {
    let report = bench_track(
        "block at rest",
        "uncorrected,tracked",
        &["--plot", "target/test-tracking/rest.svg"],
    );
    let seen = |mode: &str| {
        let row = row_of(&report, mode);
        assert_eq!(row["builds"], 1);
        row["seen_error_pct"].as_f64().unwrap()
    };
    let (open, tracked) = (seen("uncorrected"), seen("tracked"));
    let floor = report["observation_floor_pct"].as_f64().unwrap();
    assert!(
        (open / floor - 1.0).abs() < 0.1,
        "uncorrected {open} % against the frames' noise {floor} %"
    );
    // Matched against a frame thinned to 500 points, edge pairs moved the block 1.5 mm a frame
    // and it came out at 2.04 times the uncorrected error; at the frame's full density, 1.17
    // (`bench track`).
    assert!(
        tracked <= 1.5 * open,
        "tracked {tracked} % against {open} %"
    );
}

/// `--seeds`: each sequence runs once per draw of the camera's noise, seed 7 as without it,
/// and the report gives each sequence and mode's spread over the draws.
#[test]
fn bench_track_runs_each_noise_seed_and_reports_the_spread() {
    let run = |seeds: Option<&str>| {
        let mut args = vec![
            "--seconds",
            "1.0",
            "--plot",
            "target/test-tracking/seeds.svg",
        ];
        if let Some(seeds) = seeds {
            args.extend(["--seeds", seeds]);
        }
        bench_track("ball poked", "tracked", &args)
    };
    let (alone, both) = (run(None), run(Some("7,8")));
    let rows = both["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0]["seed"], 7);
    assert_eq!(rows[1]["seed"], 8);
    // Seed 7 is the default: the same draw, the same errors.
    let seen = |row: &serde_json::Value| row["seen_error_pct"].as_f64().unwrap();
    assert_eq!(seen(&rows[0]), seen(&alone["rows"][0]));
    assert_ne!(seen(&rows[0]), seen(&rows[1]), "another draw of the noise");
    assert!(alone["spread"].as_array().unwrap().is_empty());
    let spread = &both["spread"][0];
    println!("{spread}");
    assert_eq!(spread["seeds"], 2);
    let (lo, hi) = (
        seen(&rows[0]).min(seen(&rows[1])),
        seen(&rows[0]).max(seen(&rows[1])),
    );
    assert_eq!(spread["seen_error_pct_min"].as_f64().unwrap(), lo);
    assert_eq!(spread["seen_error_pct_max"].as_f64().unwrap(), hi);
}

/// A view that gives no direction is refused by name.
#[test]
fn bench_track_refuses_a_view_with_no_direction() {
    let stderr =
        common::physskin_refused(&["bench", "track", "--view", "0,0,0", "--modes", "tracked"]);
    assert!(
        stderr.contains("`view`") && stderr.contains("no direction"),
        "{stderr}"
    );
}

/// A tracking option the node refuses is refused by the bench too, by its parameter's name.
#[test]
fn bench_track_refuses_what_the_node_refuses() {
    let stderr =
        common::physskin_refused(&["bench", "track", "--force-gain", "2", "--modes", "tracked"]);
    assert!(
        stderr.contains("`tracking.force_gain`") && stderr.contains("outside [0, 1]"),
        "{stderr}"
    );
}

/// bags/stream.mcap (`bench track`'s poked ball, written by `--write-stream`: clouds in the
/// camera's optical frame, the camera placed by /tf_static) replays as one object, built from
/// the first cloud and corrected by every later one, and follows the push it never heard of.
#[test]
fn the_bundled_stream_is_one_object_that_follows_the_push() {
    let root = common::root();
    let bag = root.join("bags/stream.mcap");
    let params = root.join("config/stream.yaml");
    let r = common::physskin_json(&[
        "replay",
        bag.to_str().unwrap(),
        "--params",
        params.to_str().unwrap(),
        "--json",
    ]);
    println!("{r}");
    assert_eq!(r["rejected"], 0);
    let shapes = r["shapes"].as_array().unwrap();
    assert_eq!(shapes.len(), 1, "one build for the whole stream");
    // Every cloud but the first (and the /tf_static message) is a frame of the object.
    let inputs = r["input_messages"].as_u64().unwrap();
    assert_eq!(r["observations"].as_u64().unwrap(), inputs - 2);
    let moved = shapes[0]["max_displacement_m"].as_f64().unwrap();
    assert!(
        moved > 0.1,
        "the tracked ball moved {moved} m with the push"
    );
}

/// `bench_track` with `--python PY`, PY a Python with pip `mujoco-core` in target/mujoco-venv
/// (installed here when missing).
fn mujoco_track(sequence: &str, modes: &str, extra: &[&str]) -> serde_json::Value {
    let python = common::venv(
        "mujoco-venv",
        "import mujoco, numpy",
        &["mujoco-core", "numpy"],
    );
    let mut args = vec!["--python", python.to_str().unwrap()];
    args.extend_from_slice(extra);
    bench_track(sequence, modes, &args)
}

/// `bench track` on MuJoCo's soft block (pip `mujoco-core` in target/mujoco-venv): an engine
/// physskin did not write moves the body the camera watches. Dropped tilted onto the floor,
/// the block is tracked within issue 70's 1 % of its diagonal; pushed along the floor by a
/// paddle the node never hears of, too, and within a third of the uncorrected body's error.
/// One build each.
#[test]
fn mujocos_block_is_tracked_when_dropped_and_pushed() {
    let report = mujoco_track(
        "mujoco block dropped,mujoco block pushed",
        "uncorrected,tracked",
        &["--plot", "target/test-tracking/track-mujoco.svg"],
    );
    assert!(report["mujoco_version"]
        .as_str()
        .is_some_and(|v| !v.is_empty()));
    let rows = report["rows"].as_array().unwrap();
    let row = |sequence: &str, mode: &str| {
        rows.iter()
            .find(|r| r["sequence"] == sequence && r["mode"] == mode)
            .unwrap_or_else(|| panic!("{sequence} {mode} ran"))
    };
    for sequence in ["mujoco block dropped", "mujoco block pushed"] {
        let (tracked, open) = (row(sequence, "tracked"), row(sequence, "uncorrected"));
        println!("{tracked}\n{open}");
        assert_eq!(tracked["builds"], 1, "{sequence}: one build");
        let error = tracked["seen_error_pct"].as_f64().unwrap();
        assert!(
            error <= open["seen_error_pct"].as_f64().unwrap() / 3.0,
            "{sequence}: tracked {error} %"
        );
    }
    // Printed by `bench track`: dropped 0.5726 % (uncorrected 8.0685 %), pushed 0.3733 %
    // (1.4110 % while the friction springs pulled harder the faster the block slid).
    for sequence in ["mujoco block dropped", "mujoco block pushed"] {
        let error = row(sequence, "tracked")["seen_error_pct"].as_f64().unwrap();
        assert!(error <= 1.0, "{sequence}: {error} % of its diagonal");
    }
}

/// MuJoCo's block pushed on while the view is blocked comes back into view about 6 cm from
/// where the body stopped. Over three draws of the camera's noise it is moved back and stays:
/// the frames that find it off add nothing to the kept force, and a re-lock drops it. Kept,
/// that force threw the block off again at one draw (48.8727 % over the sequence, printed;
/// 5.2334 % at most now, its blocked half 11.7103 % as the body slows when the view goes).
#[test]
fn mujocos_block_is_locked_on_again_after_a_blocked_view_at_every_noise_draw() {
    let report = mujoco_track(
        "mujoco block pushed while hidden",
        "tracked",
        &[
            "--seeds",
            "7,8,9",
            "--plot",
            "target/test-tracking/track-hidden.svg",
        ],
    );
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    for row in rows {
        println!("{row}");
        assert_eq!(row["builds"], 1);
        let error = row["seen_error_pct"].as_f64().unwrap();
        // A frame the gate explains in part re-locks too: corrected by that part, the block
        // was pulled to and fro (10.39 % at seed 8, printed).
        assert!(
            error <= 7.0,
            "seed {}: {error} % over the sequence",
            row["seed"]
        );
        assert!(row["chamfer_pct"].as_f64().unwrap() <= 3.0);
    }
}
