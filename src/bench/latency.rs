//! `bench latency`: a cloud published until its first deformed cloud comes back, through DDS on
//! loopback, and the publish jitter of a running object while another shape is inferred.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::geometry::{bundled, sample_surface, SurfaceSampling, VoxelGrid};
use crate::msg::cloud::encode_cloud;
use crate::msg::{Header, PointCloud2};
use crate::node::{context, publisher, reliable_qos, subscription, NodeConfig};
use crate::runtime::Topics;
use crate::skinning::NeuralModel;
use crate::{Error, Result};

/// What `bench latency` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct LatencyReport {
    /// The node's `inference.refine` in this run.
    pub refine: String,
    /// From publishing a new 10,000-point cloud to its first deformed cloud at the
    /// in-process client, ms.
    pub latency_10k_ms: f64,
    /// The same for a new 100,000-point cloud, ms.
    pub latency_100k_ms: f64,
    /// One depth camera's organized scans of the bundled box, in its optical frame, five
    /// times (180 down to 176 pixels wide): points seen, the latency of each, and their median
    /// and largest. The view is completed before inference.
    pub scan_points: Vec<usize>,
    /// Each scan's latency to its first deformed cloud, ms.
    pub scan_latencies_ms: Vec<f64>,
    /// Median of the scans' latencies, ms.
    pub latency_scan_ms: f64,
    /// Largest of the scans' latencies, ms.
    pub latency_scan_max_ms: f64,
    /// The same 10k-point cloud from rclpy (Fast DDS) to an rclpy subscriber; absent when the
    /// bench was not given a Python with rclpy.
    pub rclpy: Option<RclpyLatency>,
    /// p99 of |interval - period| between the publish times (header stamps, taken by the step
    /// thread as it publishes) of a running shape's deformed clouds, ms.
    pub jitter_p99_ms: f64,
    /// Largest |interval - period| between those publish times, ms.
    pub jitter_max_ms: f64,
    /// The same between the times the client received them: DDS delivery included.
    pub receive_jitter_p99_ms: f64,
    /// Largest |interval - period| between those arrival times, ms.
    pub receive_jitter_max_ms: f64,
    /// Intervals the jitter figures are taken over: the running shape's deformed clouds
    /// received in the 4 s jitter phase, less one.
    pub jitter_intervals: usize,
    /// The node's publish rate, Hz; its period is the one the jitter is measured against.
    pub rate_hz: f64,
    /// Instances running: 2 when a second one (`--shards`, a process of its own) stepped its
    /// own 10k-point object beside the measured one, each taking its shard of the frames.
    pub instances: u32,
    /// Deformed clouds of the second instance's object received in the jitter phase (0 with
    /// one instance): it was stepping all along.
    pub second_instance_clouds: usize,
}

/// tests/peers/latency_peer.py's figures: each repeat a new ~10k-point cloud published once
/// rclpy's publisher and subscription had both matched the node's and the running object's
/// deformed clouds were arriving.
#[derive(Clone, Debug, Serialize)]
pub struct RclpyLatency {
    /// The first repeat, ms.
    pub first_ms: f64,
    /// Median of the repeats, ms (the upper middle one for an even count).
    pub median_ms: f64,
    /// Largest of the repeats, ms.
    pub max_ms: f64,
    /// Every repeat, ms.
    pub latencies_ms: Vec<f64>,
    /// From the peer's start until rclpy counted the node's endpoints both ways, ms.
    pub match_ms: f64,
    /// From then until the running object's first deformed cloud reached rclpy, ms: the node's
    /// writer matches rclpy's reader later than rclpy's counts say.
    pub first_data_ms: f64,
}

/// The bundled box seen by one camera 1.5 diagonals away, about 6,000 points of a `width` x 135
/// image (width about 180), as a depth camera driver publishes it (organized, NaN where
/// nothing is seen, with colours), in `frame`.
fn box_scan(frame: &str, width: usize) -> PointCloud2 {
    use crate::msg::camera_cloud::{camera_cloud, SeenObject};
    let shape = crate::geometry::bundled("box").expect("the bundled box");
    let camera = crate::geometry::Camera::looking_at(
        &shape,
        nalgebra::Vector3::new(1.0, 0.6, 0.8),
        1.5,
        width,
        135,
    );
    let header = Header {
        frame_id: frame.into(),
        ..Header::default()
    };
    let object = [SeenObject {
        shape: &shape,
        instance: 1,
        rgb: [200, 120, 40],
    }];
    let mut cloud = camera_cloud(&object, &camera, header).expect("the box's scan");
    // Unlabelled: the frame's one object, which the next shape in the frame replaces.
    cloud.fields.retain(|f| f.name != "instance");
    cloud
}

/// Points of a cloud with a finite x (float32 at offset 0).
fn scan_point_count(cloud: &PointCloud2) -> usize {
    cloud
        .data
        .chunks_exact(cloud.point_step as usize)
        .filter(|p| f32::from_le_bytes([p[0], p[1], p[2], p[3]]).is_finite())
        .count()
}

/// `count` points sampled (with `seed`) on the surface of the bundled shape named
/// `shape`, as an unordered float32 x, y, z cloud in `frame`. Panics on a name
/// that is not bundled.
pub fn sample_cloud(shape: &str, count: usize, frame: &str, seed: u64) -> PointCloud2 {
    encode_cloud(
        Header {
            frame_id: frame.into(),
            ..Header::default()
        },
        &sample_xyz(shape, count, seed),
        &[],
        &[],
    )
}

/// `count` points on the surface of a bundled shape, x, y, z after each other.
fn sample_xyz(shape: &str, count: usize, seed: u64) -> Vec<f32> {
    let shape = bundled(shape).expect("a bundled shape");
    let grid = VoxelGrid::from_shape(&shape, 64, None);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let sampling = SurfaceSampling {
        count,
        ..Default::default()
    };
    let samples = sample_surface(&shape, &grid, &sampling, &mut rng);
    samples
        .points
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect()
}

/// Network interfaces that would let DDS traffic leave this machine, if any. The bench runs only
/// in a private namespace (tests/peers/private_net.sh), where lo and a closed veth pair exist.
pub(crate) fn open_interfaces() -> Vec<String> {
    // /proc/self/net follows the network namespace (/sys/class/net does not without a remount).
    std::fs::read_to_string("/proc/self/net/dev")
        .unwrap_or_default()
        .lines()
        .skip(2)
        .filter_map(|l| l.split(':').next().map(|n| n.trim().to_string()))
        .filter(|n| !matches!(n.as_str(), "lo" | "physskin0" | "physskin1"))
        .collect()
}

/// Runs the node in this process and a client beside it, in a private network namespace; with
/// `rclpy_python` (a Python that imports rclpy and sensor_msgs), also an rclpy peer.
pub fn run_latency_bench(
    domain_id: u16,
    rclpy_python: Option<&Path>,
    refine: Option<String>,
    shards: bool,
    log: impl Fn(&str),
) -> Result<LatencyReport> {
    refuse_open_interfaces()?;
    let model = NeuralModel::bundled()?;
    let stop = Arc::new(AtomicBool::new(false));
    let config = measured_node(domain_id, refine, shards);
    let refine = config.params.inference.refine.clone();
    let rate_hz = config.params.rate_hz;
    let topics = config
        .params
        .topics
        .resolved(&config.names)
        .expect("the default names are valid");
    let second = shards
        .then(|| second_instance(domain_id, &topics))
        .transpose()?;
    let node = {
        let stop = stop.clone();
        std::thread::spawn(move || crate::node::run(config, model, stop))
    };
    let result = (|| {
        let client = Client::start(domain_id, &topics, shards)?;
        // A warm-up shape first (the first inference pays for allocations), replaced in its
        // frame by the measured one, so one 10k shape runs during the jitter phase.
        client.latency(&sample_cloud("creature", 9_999, "cloud_10k", 1))?;
        // The scan replaces the warm-up shape in its frame, and is replaced by the measured
        // 10k shape: its large organized clouds must not load the phases after it.
        // Five scans, one pixel narrower each time, so each is new geometry and its answer
        // can be told apart by its width.
        let mut scan_points = Vec::new();
        let mut scan_ms = Vec::new();
        for width in (176..=180).rev() {
            let scan = box_scan("cloud_10k", width);
            scan_points.push(scan_point_count(&scan));
            scan_ms.push(client.latency(&scan)?);
        }
        log(&format!(
            "{scan_points:?}-point scans: first deformed cloud after {scan_ms:.1?} ms"
        ));
        let l10k = client.latency(&sample_cloud("creature", 10_000, "cloud_10k", 2))?;
        log(&format!(
            "10k points: first deformed cloud after {l10k:.1} ms"
        ));
        let rclpy = match rclpy_python {
            Some(python) => {
                let r = rclpy_latency(python, &topics, domain_id, "cloud_10k", 2)?;
                log(&format!(
                    "rclpy, ~10k points: first deformed cloud after {:.1} ms (median of {} {:.1} ms)",
                    r.first_ms,
                    r.latencies_ms.len(),
                    r.median_ms
                ));
                Some(r)
            }
            None => None,
        };
        if shards {
            // The second instance's own object, stepping through the jitter phase.
            client.publish(sample_cloud("creature", 10_000, SECOND_FRAME, 7))?;
            std::thread::sleep(Duration::from_secs(2));
        }
        let (arrivals, second_clouds) = client.arrivals_while_inferring(Duration::from_secs(4))?;
        if shards && second_clouds == 0 {
            return Err(dds(
                "the second instance published nothing in the jitter phase".into(),
            ));
        }
        // Last, so its 100k-point frames do not load the jitter phase.
        let l100k = client.latency(&sample_cloud("creature", 100_000, "cloud_100k", 3))?;
        log(&format!(
            "100k points: first deformed cloud after {l100k:.1} ms"
        ));
        if arrivals.len() < 10 {
            return Err(dds(format!(
                "only {} deformed clouds arrived in 4 s",
                arrivals.len()
            )));
        }
        let period = 1e3 / rate_hz;
        let start = arrivals[0].1;
        let stamps = arrivals.iter().map(|(stamp, _)| *stamp as f64 / 1e6);
        let received = arrivals
            .iter()
            .map(|(_, at)| (*at - start).as_secs_f64() * 1e3);
        let published = jitter(stamps.collect(), period);
        let received = jitter(received.collect(), period);
        Ok(LatencyReport {
            refine: refine.clone(),
            latency_10k_ms: l10k,
            latency_100k_ms: l100k,
            latency_scan_ms: super::stats::median(&scan_ms),
            latency_scan_max_ms: scan_ms.iter().cloned().fold(f64::NAN, f64::max),
            scan_points,
            scan_latencies_ms: scan_ms,
            rclpy,
            jitter_p99_ms: published.0,
            jitter_max_ms: published.1,
            receive_jitter_p99_ms: received.0,
            receive_jitter_max_ms: received.1,
            jitter_intervals: arrivals.len() - 1,
            rate_hz,
            instances: if shards { 2 } else { 1 },
            second_instance_clouds: second_clouds,
        })
    })();
    stop.store(true, Ordering::Relaxed);
    let _ = node.join();
    if let Some(second) = second {
        stop_instance(second);
    }
    result
}

/// An error when DDS could leave this machine (an interface other than loopback is up).
fn refuse_open_interfaces() -> Result<()> {
    let open = open_interfaces();
    if open.is_empty() {
        return Ok(());
    }
    Err(dds(format!(
        "interfaces {open:?} could carry DDS off this machine; run the bench as `unshare -n tests/peers/private_net.sh physskin bench latency`"
    )))
}

/// Stops a node process with SIGINT, as a launch file stops it, and waits for its exit.
fn stop_instance(mut child: std::process::Child) {
    // SAFETY: kill(2) only sends a signal; the pid is our child's, not reaped before the wait.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let _ = child.wait();
}

/// The measured node's configuration: `refine` as asked, no tracking, shard 1 of 2 with
/// `shards`.
fn measured_node(domain_id: u16, refine: Option<String>, shards: bool) -> NodeConfig {
    let mut config = NodeConfig {
        domain_id,
        ..NodeConfig::default()
    };
    if let Some(refine) = refine {
        config.params.inference.refine = refine;
    }
    // Each measured cloud is a new object in the one frame "cloud_10k" (so that the large ones
    // do not stay and load the phases after them): a cloud replaces the frame's object, as it
    // did before streams were tracked. Tracked, it would be a frame of the running object.
    config.params.tracking.enabled = false;
    if shards {
        // Every frame measured here hashes to shard 1 of 2; the second instance takes 0.
        config.params.instances.shard = "1/2".into();
    }
    config
}

/// The frame of the second instance's object (it hashes to shard 0 of 2).
const SECOND_FRAME: &str = "shard_load";
/// The second instance's name: its deformed clouds come on /SECOND_NAME/deformed_points.
const SECOND_NAME: &str = "physskin_shard0";

/// A second node, a process of its own as `config/launch/shards.launch.py` starts one: shard 0
/// of 2, hearing the measured node's input topic, it builds and steps the objects of the frames
/// that hash to it (`SECOND_FRAME`), as a second instance splitting one camera's objects would,
/// on the same 2 cores.
fn second_instance(domain_id: u16, topics: &Topics) -> Result<std::process::Child> {
    let exe = std::env::current_exe().map_err(|e| dds(format!("this program's path: {e}")))?;
    let remap = format!("~/points:={}", topics.points);
    let domain = domain_id.to_string();
    std::process::Command::new(exe)
        .args([
            "node",
            "--domain-id",
            &domain,
            "--name",
            SECOND_NAME,
            "--ros-args",
        ])
        .args([
            "-p",
            "instances.shard:=0/2",
            "-p",
            "tracking.enabled:=false",
        ])
        // Its own iceoryx2 services would share the first's names.
        .args(["-p", "shm.enabled:=false", "-r", &remap])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .map_err(|e| dds(format!("the second instance did not start: {e}")))
}

/// (p99, max) of |interval - period| over consecutive times, ms.
fn jitter(times_ms: Vec<f64>, period: f64) -> (f64, f64) {
    let mut d: Vec<f64> = times_ms
        .windows(2)
        .map(|w| (w[1] - w[0] - period).abs())
        .collect();
    d.sort_by(f64::total_cmp);
    let p99 = d[((d.len() as f64 * 0.99).ceil() as usize).min(d.len()) - 1];
    (p99, *d.last().unwrap_or(&f64::NAN))
}

/// The bench's own ros2-client node: a points publisher and a deformed-points subscription.
struct Client {
    /// Kept alive for as long as its endpoints are used.
    _node: ros2_client::Node,
    points: ros2_client::Publisher<PointCloud2>,
    deformed: ros2_client::Subscription<PointCloud2>,
    /// The second instance's deformed clouds, when there is one.
    second: Option<ros2_client::Subscription<PointCloud2>>,
}

impl Client {
    /// Both directions matched with the node (or 20 s gone).
    fn start(domain_id: u16, topics: &Topics, shards: bool) -> Result<Self> {
        let ctx = context(domain_id, false)?;
        let mut node = client_node(&ctx, "physskin_bench")?;
        let points = publisher::<PointCloud2>(&mut node, &topics.points, reliable_qos(5, false))?;
        let deformed = subscription::<PointCloud2>(
            &mut node,
            &topics.deformed_points,
            reliable_qos(50, false),
        )?;
        let second_topic = format!("/{SECOND_NAME}/deformed_points");
        let second = shards
            .then(|| subscription::<PointCloud2>(&mut node, &second_topic, reliable_qos(50, false)))
            .transpose()?;
        let spinner = node.spinner().map_err(|e| dds(format!("{e:?}")))?;
        std::thread::spawn(move || smol::block_on(spinner.spin()));
        smol::block_on(async {
            smol::future::race(
                async {
                    points.wait_for_subscription(&node).await;
                    deformed.wait_for_publisher(&node).await;
                },
                async {
                    smol::Timer::after(Duration::from_secs(20)).await;
                },
            )
            .await
        });
        Ok(Self {
            _node: node,
            points,
            deformed,
            second,
        })
    }

    fn publish(&self, cloud: PointCloud2) -> Result<()> {
        self.points
            .publish(cloud)
            .map_err(|e| dds(format!("{e:?}")))
    }

    fn receive(&self, timeout: Duration) -> Option<(PointCloud2, Instant)> {
        let deadline = Instant::now() + timeout;
        while Instant::now() < deadline {
            if let Ok(Some((m, _))) = self.deformed.take() {
                return Some((m, Instant::now()));
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        None
    }

    /// ms from publishing `cloud` to its first deformed cloud (told by frame and width).
    fn latency(&self, cloud: &PointCloud2) -> Result<f64> {
        while self.deformed.take().ok().flatten().is_some() {}
        let sent = Instant::now();
        self.publish(cloud.clone())?;
        loop {
            let (m, at) = self.receive(Duration::from_secs(30)).ok_or_else(|| {
                dds(format!(
                    "no deformed cloud for the {}-point cloud within 30 s",
                    cloud.width
                ))
            })?;
            if m.header.frame_id == cloud.header.frame_id && m.width == cloud.width {
                return Ok((at - sent).as_secs_f64() * 1e3);
            }
        }
    }

    /// (stamp ns, arrival) of the "cloud_10k" shape's deformed clouds for `span`, while a new
    /// 10k-point shape is published every 500 ms in another frame; and how many deformed
    /// clouds the second instance sent meanwhile.
    fn arrivals_while_inferring(&self, span: Duration) -> Result<(Vec<(i64, Instant)>, usize)> {
        // Clouds queued while the rclpy case ran would arrive back to back.
        while self.deformed.take().ok().flatten().is_some() {}
        let mut arrivals = Vec::new();
        let until = Instant::now() + span;
        let mut next_shape = Instant::now();
        let mut seed = 10;
        let mut second = 0;
        while Instant::now() < until {
            while let Some(Ok(Some(_))) = self.second.as_ref().map(|s| s.take()) {
                second += 1;
            }
            if Instant::now() >= next_shape {
                self.publish(sample_cloud("plate", 10_000, "other", seed))?;
                seed += 1;
                next_shape += Duration::from_millis(500);
            }
            if let Some((m, at)) = self.receive(Duration::from_millis(50)) {
                if m.header.frame_id == "cloud_10k" {
                    arrivals.push((m.header.stamp.nanos(), at));
                }
            }
        }
        Ok((arrivals, second))
    }
}

/// Runs tests/peers/latency_peer.py with `python` on the bench's 10k-point cloud (seed), sent in
/// `frame` where the in-process case left an object of 10,000 points.
fn rclpy_latency(
    python: &Path,
    topics: &Topics,
    domain_id: u16,
    frame: &str,
    seed: u64,
) -> Result<RclpyLatency> {
    let peer = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/peers/latency_peer.py");
    let file = std::env::temp_dir().join(format!("physskin-latency-{}.f32", std::process::id()));
    let xyz = sample_xyz("creature", 10_000, seed);
    let bytes: Vec<u8> = xyz.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(&file, bytes).map_err(|e| dds(format!("{}: {e}", file.display())))?;
    let out = std::process::Command::new(python)
        .arg(&peer)
        .args([&topics.points, &topics.deformed_points])
        .arg(&file)
        .args([frame, "7"])
        .env("ROS_DOMAIN_ID", domain_id.to_string())
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .output();
    let _ = std::fs::remove_file(&file);
    let out = out.map_err(|e| dds(format!("{} {}: {e}", python.display(), peer.display())))?;
    if !out.status.success() {
        return Err(dds(format!(
            "the rclpy peer failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    #[derive(serde::Deserialize)]
    struct PeerOutput {
        latency_ms: Vec<f64>,
        match_ms: f64,
        first_data_ms: f64,
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout.lines().last().unwrap_or_default();
    let peer: PeerOutput = serde_json::from_str(line)
        .map_err(|e| dds(format!("the rclpy peer printed {line:?}: {e}")))?;
    let mut sorted = peer.latency_ms.clone();
    sorted.sort_by(f64::total_cmp);
    Ok(RclpyLatency {
        first_ms: peer.latency_ms[0],
        median_ms: sorted[sorted.len() / 2],
        max_ms: *sorted.last().expect("seven repeats"),
        latencies_ms: peer.latency_ms,
        match_ms: peer.match_ms,
        first_data_ms: peer.first_data_ms,
    })
}

pub(crate) fn dds(message: String) -> Error {
    Error::Node(crate::node::NodeError::Dds(message))
}

/// A benchmark's own ROS 2 node (no rosout) named `name`, in `ctx`.
pub(crate) fn client_node(ctx: &ros2_client::Context, name: &str) -> Result<ros2_client::Node> {
    ctx.new_node(
        ros2_client::NodeName::new("/", name).map_err(|e| dds(format!("{e:?}")))?,
        ros2_client::NodeOptions::new().enable_rosout(false),
    )
    .map_err(|e| dds(format!("{e:?}")))
}
