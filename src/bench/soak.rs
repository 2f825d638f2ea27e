//! `bench soak`: the node under a stream of changing shapes, pokes, pins and bad inputs for a
//! long time, in a private network namespace. It reports memory over time, ticks missed, the
//! states published (all finite?), and whether the recording reads back complete.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use ros2_client::{Context, Node, Publisher, Subscription};
use serde::Serialize;

use super::latency::{client_node, dds, open_interfaces, sample_cloud};
use crate::bag::read_messages;
use crate::msg::{
    from_cdr, Header, Interaction, Point, PointCloud2, Status, SubspaceState, Vector3,
};
use crate::node::{context, publisher, reliable_qos, subscription, NodeConfig};
use crate::runtime::Topics;
use crate::skinning::NeuralModel;
use crate::Result;

/// How long and how hard.
#[derive(Clone, Debug)]
pub struct SoakOptions {
    /// How long the client drives the node, s of wall time.
    pub seconds: f64,
    /// The DDS domain of the node and the client.
    pub domain_id: u16,
    /// Where the node records (state, status and inputs; split every minute).
    pub record: PathBuf,
}

/// One memory sample.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MemorySample {
    /// Seconds since the client started driving the node.
    pub at_s: f64,
    /// Resident memory of this process (node and client), MiB; NaN when unreadable.
    pub rss_mb: f64,
    /// What the allocator's heaps have handed out and not taken back, MiB (glibc's
    /// `mallinfo2`; NaN elsewhere). Growth here is data kept; growth of the resident memory
    /// alone is free space the heaps keep (the binary keeps it between builds:
    /// `keep_freed_memory`, `runtime::heap`).
    pub heap_in_use_mb: f64,
    /// Of the resident memory, the pages of shared memory mapped (iceoryx2's segments, the
    /// DDS transport's), MiB: they count once touched, whatever the heaps do.
    pub rss_shared_mb: f64,
}

/// What `bench soak` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct SoakReport {
    /// The soak's length, s (as asked).
    pub seconds: f64,
    /// New shapes sent, one every 2 s (counted even when publishing failed).
    pub shapes_sent: usize,
    /// Interactions published, one every 0.1 s: forces, and on each frame in turn a pin
    /// and its release.
    pub pokes_sent: usize,
    /// Bad inputs sent, one every 5 s: alternately a cloud without z and a poke with a
    /// NaN force.
    pub bad_inputs_sent: usize,
    /// Frames of the two streamed objects sent, 30 a second: one always in view and pushed
    /// every 3 s, one out of view for 1.5 s of every 10.
    pub stream_frames_sent: usize,
    /// Builds of the streamed objects (`shape_ready` in their frames): one each when their
    /// frames are tracked.
    pub stream_builds: usize,
    /// Node ticks and ticks skipped because one ran past the next one's start.
    pub ticks: u64,
    /// Ticks skipped because a tick ran past the next one's start.
    pub missed_ticks: u64,
    /// SubspaceState messages received, and those with a NaN or Inf in them.
    pub states_received: usize,
    /// Of those, states with a NaN or Inf in z, its velocity or the energies.
    pub non_finite_states: usize,
    /// Statuses by event (input_rejected, shape_ready, ...), as received.
    pub statuses: BTreeMap<String, usize>,
    /// Resident memory after the first quarter (warm: every kind of input seen), at the end,
    /// and the highest; growth is the least-squares slope over the last three quarters.
    pub rss_warm_mb: f64,
    /// Resident memory at the last sample, MiB.
    pub rss_end_mb: f64,
    /// The highest sample, MiB.
    pub rss_max_mb: f64,
    /// Least-squares slope over the last three quarters, MiB per minute.
    pub rss_growth_mb_per_min: f64,
    /// The same slope of the memory the allocator has handed out, MiB per minute.
    pub heap_growth_mb_per_min: f64,
    /// Every memory sample, one a second.
    pub memory: Vec<MemorySample>,
    /// The recording's files, read back with the strict reader, and their messages per topic.
    pub recording_files: usize,
    /// Whether the recording has files, each reads back with the strict reader and every
    /// recorded state decodes.
    pub recording_complete: bool,
    /// Messages per topic in the recording's files.
    pub recorded: BTreeMap<String, usize>,
}

/// Bytes the allocator's heaps have handed out and not taken back, MiB. Blocks mapped on
/// their own (over the 32 MB threshold) go back to the system when freed and are not counted.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn heap_in_use_mb() -> f64 {
    // SAFETY: mallinfo2 only reads the allocator's counters (under its own locks).
    let info = unsafe { libc::mallinfo2() };
    info.uordblks as f64 / (1024.0 * 1024.0)
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn heap_in_use_mb() -> f64 {
    f64::NAN
}

fn rss_mb() -> f64 {
    status_mb("VmRSS:")
}

/// A memory line of /proc/self/status, MiB (NaN when unreadable).
fn status_mb(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find_map(|l| l.strip_prefix(key))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn poke(frame: &str, kind: u8, x: f64) -> Interaction {
    Interaction {
        header: Header {
            frame_id: frame.into(),
            ..Header::default()
        },
        shape_id: 0,
        kind,
        point: Point {
            x: 0.0,
            y: 0.0,
            z: 0.1,
        },
        force: Vector3 { x, y: 0.0, z: 0.0 },
        duration: 0.1,
        radius: 0.03,
    }
}

/// The frames, shapes and point counts the client's shapes cycle through.
const FRAMES: [&str; 3] = ["soak_a", "soak_b", "soak_c"];
const SHAPES: [&str; 5] = ["creature", "sphere", "box", "rod", "plate"];
const COUNTS: [usize; 4] = [2_000, 5_000, 10_000, 20_000];

/// Runs the node in this process for `options.seconds` and a client beside it that keeps
/// changing its shapes and poking them.
pub fn run_soak(options: &SoakOptions, log: impl Fn(&str)) -> Result<SoakReport> {
    let open = open_interfaces();
    if !open.is_empty() {
        return Err(dds(format!(
            "interfaces {open:?} could carry DDS off this machine; run the soak as `unshare -n tests/peers/private_net.sh physskin bench soak`"
        )));
    }
    // Files of an earlier soak would be read back as this one's.
    for old in recording_files(&options.record) {
        let _ = std::fs::remove_file(old);
    }
    if let Some(dir) = options.record.parent() {
        let _ = std::fs::create_dir_all(dir);
    }
    let model = NeuralModel::bundled()?;
    let stop = Arc::new(AtomicBool::new(false));
    let (config, topics) = node_config(options);
    let node = {
        let stop = stop.clone();
        std::thread::spawn(move || crate::node::run_counted(config, model, stop))
    };
    let client = match connect(options.domain_id, &topics) {
        Ok(c) => c,
        Err(e) => {
            stop.store(true, Ordering::Relaxed);
            let _ = node.join();
            return Err(e);
        }
    };

    let mut report = SoakReport {
        seconds: options.seconds,
        shapes_sent: 0,
        pokes_sent: 0,
        bad_inputs_sent: 0,
        stream_frames_sent: 0,
        stream_builds: 0,
        ticks: 0,
        missed_ticks: 0,
        states_received: 0,
        non_finite_states: 0,
        statuses: BTreeMap::new(),
        rss_warm_mb: 0.0,
        rss_end_mb: 0.0,
        rss_max_mb: 0.0,
        rss_growth_mb_per_min: 0.0,
        heap_growth_mb_per_min: 0.0,
        memory: Vec::new(),
        recording_files: 0,
        recording_complete: false,
        recorded: BTreeMap::new(),
    };
    drive(options, &client, &mut report, &log);
    stop.store(true, Ordering::Relaxed);
    let stats = node
        .join()
        .map_err(|_| dds("the node thread panicked".into()))??;
    report.ticks = stats.ticks;
    report.missed_ticks = stats.missed;
    summarize_memory(&mut report);
    check_recording(&options.record, &mut report)?;
    Ok(report)
}

/// The node's config for a soak, and its topics: the default ones, with the inputs, states and
/// statuses recorded to `options.record` in files split every minute.
fn node_config(options: &SoakOptions) -> (NodeConfig, Topics) {
    let mut config = NodeConfig {
        domain_id: options.domain_id,
        ..NodeConfig::default()
    };
    let topics = config
        .params
        .topics
        .resolved(&config.names)
        .expect("the default names are valid");
    config.params.record.path = options.record.display().to_string();
    config.params.record.split_duration_s = 60.0;
    config.params.record.topics = vec![
        topics.points.clone(),
        topics.interaction.clone(),
        topics.state.clone(),
        topics.status.clone(),
    ];
    (config, topics)
}

/// The soak's client: its node and endpoints on the node's topics.
struct Client {
    // The fields drop in this order: the endpoints before the client node and its context,
    // which must outlive them (dropping them ends the client).
    statuses: Subscription<Status>,
    states: Subscription<SubspaceState>,
    pokes: Publisher<Interaction>,
    points: Publisher<PointCloud2>,
    _client: Node,
    _ctx: Context,
}

/// Starts the client in `domain_id` with its spinner, and waits up to 20 s for the node to
/// take its clouds and publish states.
fn connect(domain_id: u16, topics: &Topics) -> Result<Client> {
    let ctx = context(domain_id, false)?;
    let mut client = client_node(&ctx, "physskin_soak")?;
    let points = publisher::<PointCloud2>(&mut client, &topics.points, reliable_qos(5, false))?;
    let pokes =
        publisher::<Interaction>(&mut client, &topics.interaction, reliable_qos(10, false))?;
    let states =
        subscription::<SubspaceState>(&mut client, &topics.state, reliable_qos(100, false))?;
    let statuses = subscription::<Status>(&mut client, &topics.status, reliable_qos(50, true))?;
    let spinner = client.spinner().map_err(|e| dds(format!("{e:?}")))?;
    std::thread::spawn(move || smol::block_on(spinner.spin()));
    smol::block_on(smol::future::race(
        async {
            points.wait_for_subscription(&client).await;
            states.wait_for_publisher(&client).await;
        },
        async {
            smol::Timer::after(Duration::from_secs(20)).await;
        },
    ));
    // The node and context must outlive the endpoints: dropping them ends the client.
    Ok(Client {
        statuses,
        states,
        pokes,
        points,
        _client: client,
        _ctx: ctx,
    })
}

/// The client's side of the soak, for `options.seconds`: a new shape every 2 s, a poke every
/// 0.1 s, a bad input every 5 s and a memory sample every second, counting what comes back.
fn drive(options: &SoakOptions, client: &Client, report: &mut SoakReport, log: &dyn Fn(&str)) {
    let started = Instant::now();
    let send = |what: &str, sent: bool| {
        if !sent {
            log(&format!("publishing {what} failed"));
        }
    };
    let (mut next_shape, mut next_poke, mut next_bad, mut next_sample) = (0.0, 0.0, 1.0, 0.0);
    let views = stream_views();
    let (mut next_frame, mut next_push) = (0.0, 1.5);
    let mut n = 0usize;
    while started.elapsed().as_secs_f64() < options.seconds {
        let t = started.elapsed().as_secs_f64();
        if t >= next_shape {
            let frame = FRAMES[n % FRAMES.len()];
            let cloud = sample_cloud(
                SHAPES[n % SHAPES.len()],
                COUNTS[n % COUNTS.len()],
                frame,
                n as u64,
            );
            send("a shape", client.points.publish(cloud).is_ok());
            report.shapes_sent += 1;
            n += 1;
            next_shape += 2.0;
        }
        if t >= next_poke {
            if client
                .pokes
                .publish(scheduled_poke(report.pokes_sent))
                .is_ok()
            {
                report.pokes_sent += 1;
            }
            next_poke += 0.1;
        }
        if t >= next_frame {
            send_stream_frame(client, &views, t, report, &send);
            next_frame += 1.0 / 30.0;
        }
        if t >= next_push {
            let mut push = poke(STREAMS[0], Interaction::FORCE, 20.0);
            push.point = Point {
                x: STREAM_AT[0],
                y: STREAM_AT[1],
                z: STREAM_AT[2],
            };
            let _ = client.pokes.publish(push);
            next_push += 3.0;
        }
        if t >= next_bad {
            send_bad_input(client, report.bad_inputs_sent, &send);
            report.bad_inputs_sent += 1;
            next_bad += 5.0;
        }
        if t >= next_sample {
            sample_memory(report, t, log);
            next_sample += 1.0;
        }
        receive(client, report);
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The `k`th poke: on each frame in turn, a pin every 30 pokes and its release 15 later, and
/// forces alternating in direction between them.
fn scheduled_poke(k: usize) -> Interaction {
    let frame = FRAMES[k % FRAMES.len()];
    let (kind, x) = match k % 30 {
        0 => (Interaction::PIN, 0.0),
        15 => (Interaction::RELEASE, 0.0),
        _ => (
            Interaction::FORCE,
            if k.is_multiple_of(2) { 3.0 } else { -3.0 },
        ),
    };
    poke(frame, kind, x)
}

/// The streamed objects' frames: the first always in view, the second out of view for 1.5 s
/// of every 10 (paused, then locked on again within `tracking.relock_within_s`).
const STREAMS: [&str; 2] = ["soak_stream_a", "soak_stream_b"];
/// Where the streamed ball lies in its camera's frame, m.
const STREAM_AT: [f64; 3] = [0.0, 0.0, 1.0];

/// Ten noisy views of the bundled 0.5 m ball from a 160 x 120 camera 1 m away at its frame's
/// origin, 2 mm of depth noise at 1 m: the frames a depth camera streams of a resting object.
fn stream_views() -> Vec<Vec<f32>> {
    use crate::geometry::{bundled, scan_points, Camera};
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let ball = bundled("sphere").expect("a bundled shape");
    let camera = Camera::looking_at(&ball, nalgebra::Vector3::new(0.0, 0.0, -1.0), 1.0, 160, 120);
    let offset = nalgebra::Vector3::from(STREAM_AT) - camera.position;
    let points = scan_points(&ball, &camera).expect("the ball is a mesh");
    let unit = Normal::new(0.0, 1.0).expect("a unit normal distribution");
    (0..10)
        .map(|seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            points
                .iter()
                .flat_map(|p| {
                    let ray = p - camera.position;
                    let depth = ray.norm();
                    let q =
                        p + offset + ray / depth * unit.sample(&mut rng) * 0.002 * depth * depth;
                    [q.x as f32, q.y as f32, q.z as f32]
                })
                .collect()
        })
        .collect()
}

/// One frame of each streamed object in view at `t` (s).
fn send_stream_frame(
    client: &Client,
    views: &[Vec<f32>],
    t: f64,
    report: &mut SoakReport,
    send: &dyn Fn(&str, bool),
) {
    let view = &views[report.stream_frames_sent % views.len()];
    for (i, frame) in STREAMS.iter().enumerate() {
        if i == 1 && t % 10.0 >= 8.5 {
            continue;
        }
        let header = Header {
            frame_id: (*frame).into(),
            ..Header::default()
        };
        let cloud = crate::msg::cloud::encode_cloud(header, view, &[], &[]);
        send("a stream's frame", client.points.publish(cloud).is_ok());
    }
    report.stream_frames_sent += 1;
}

/// Sends the `k`th bad input; `send` logs a cloud that failed to go out.
fn send_bad_input(client: &Client, k: usize, send: &dyn Fn(&str, bool)) {
    // Alternately a cloud without z and a poke with a NaN force.
    if k.is_multiple_of(2) {
        let mut cloud = sample_cloud("sphere", 500, "soak_bad", 1);
        cloud.fields.retain(|f| f.name != "z");
        send("a bad cloud", client.points.publish(cloud).is_ok());
    } else {
        let _ = client
            .pokes
            .publish(poke("soak_a", Interaction::FORCE, f64::NAN));
    }
}

/// Samples the resident memory at `t` (s); every 60 samples, a progress line.
fn sample_memory(report: &mut SoakReport, t: f64, log: &dyn Fn(&str)) {
    let sample = MemorySample {
        at_s: t,
        rss_mb: rss_mb(),
        heap_in_use_mb: heap_in_use_mb(),
        rss_shared_mb: status_mb("RssShmem:"),
    };
    if (report.memory.len() + 1).is_multiple_of(60) {
        log(&format!(
            "{t:.0} s: {} shapes, {} pokes, {} states, RSS {:.1} MB (shared {:.1}), heap in use \
             {:.1} MB",
            report.shapes_sent,
            report.pokes_sent,
            report.states_received,
            sample.rss_mb,
            sample.rss_shared_mb,
            sample.heap_in_use_mb
        ));
    }
    report.memory.push(sample);
}

/// Counts the states (and those with a NaN or Inf) and the statuses received since the last call.
fn receive(client: &Client, report: &mut SoakReport) {
    while let Ok(Some((state, _))) = client.states.take() {
        report.states_received += 1;
        let finite = state
            .z
            .iter()
            .chain(&state.z_velocity)
            .chain([&state.elastic_energy, &state.kinetic_energy])
            .all(|v| v.is_finite());
        report.non_finite_states += !finite as usize;
    }
    while let Ok(Some((status, _))) = client.statuses.take() {
        let streamed = status.message.contains("soak_stream");
        report.stream_builds += usize::from(status.event == "shape_ready" && streamed);
        *report.statuses.entry(status.event).or_default() += 1;
    }
}

fn summarize_memory(report: &mut SoakReport) {
    let samples = &report.memory;
    let Some(last) = samples.last() else {
        return;
    };
    let warm_from = last.at_s / 4.0;
    let warm: Vec<&MemorySample> = samples.iter().filter(|s| s.at_s >= warm_from).collect();
    report.rss_warm_mb = warm.first().map_or(f64::NAN, |s| s.rss_mb);
    report.rss_end_mb = last.rss_mb;
    report.rss_max_mb = samples.iter().map(|s| s.rss_mb).fold(0.0, f64::max);
    report.rss_growth_mb_per_min = slope_per_minute(&warm, |s| s.rss_mb);
    report.heap_growth_mb_per_min = slope_per_minute(&warm, |s| s.heap_in_use_mb);
}

/// The least-squares slope of `value` over `samples`' times, per minute.
fn slope_per_minute(samples: &[&MemorySample], value: impl Fn(&MemorySample) -> f64) -> f64 {
    let n = samples.len() as f64;
    let mt = samples.iter().map(|s| s.at_s).sum::<f64>() / n;
    let mv = samples.iter().map(|s| value(s)).sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for s in samples {
        sxy += (s.at_s - mt) * (value(s) - mv);
        sxx += (s.at_s - mt) * (s.at_s - mt);
    }
    if sxx > 0.0 {
        60.0 * sxy / sxx
    } else {
        0.0
    }
}

/// The files of a split recording whose first file is `first` (`<stem>.mcap`, `<stem>_1.mcap`, ...).
fn recording_files(first: &Path) -> Vec<PathBuf> {
    let stem = first
        .file_stem()
        .map_or(String::new(), |s| s.to_string_lossy().into_owned());
    let dir = match first.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p.file_stem().map(|s| s.to_string_lossy().into_owned());
            p.extension().is_some_and(|e| e == "mcap")
                && name.is_some_and(|n| {
                    n == stem
                        || n.strip_prefix(&format!("{stem}_"))
                            .is_some_and(|k| k.parse::<u32>().is_ok())
                })
        })
        .collect();
    files.sort_by_key(|p| p.to_string_lossy().len());
    files
}

/// Reads every file of the split recording with the strict reader.
fn check_recording(first: &Path, report: &mut SoakReport) -> Result<()> {
    let files = recording_files(first);
    report.recording_files = files.len();
    report.recording_complete = !files.is_empty();
    for file in &files {
        let bytes = std::fs::read(file).map_err(|e| crate::Error::Io {
            path: file.clone(),
            source: e,
        })?;
        match read_messages(&bytes, &file.display().to_string()) {
            Ok(messages) => {
                for m in messages {
                    if m.topic.ends_with("/state") {
                        // Every recorded state decodes.
                        report.recording_complete &= from_cdr::<SubspaceState>(&m.data).is_ok();
                    }
                    *report.recorded.entry(m.topic).or_default() += 1;
                }
            }
            Err(_) => report.recording_complete = false,
        }
    }
    Ok(())
}
