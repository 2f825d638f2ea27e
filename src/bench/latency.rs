//! `bench latency`: a cloud published until its first deformed cloud comes back, through DDS on
//! loopback, and the publish jitter of a running object while another shape is inferred.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::geometry::{bundled, sample_surface, SurfaceSampling, VoxelGrid};
use crate::ros::cloud::encode_cloud;
use crate::ros::messages::{Header, PointCloud2};
use crate::ros::{context, publisher, reliable_qos, run_node, subscription, NodeConfig};
use crate::skinning::NeuralModel;
use crate::{Error, Result};

#[derive(Clone, Debug, Serialize)]
pub struct LatencyReport {
    pub latency_10k_ms: f64,
    pub latency_100k_ms: f64,
    /// p99 of |interval - period| between the publish times (header stamps, taken by the step
    /// thread as it publishes) of a running shape's deformed clouds, ms.
    pub jitter_p99_ms: f64,
    pub jitter_max_ms: f64,
    /// The same between the times the client received them: DDS delivery included.
    pub receive_jitter_p99_ms: f64,
    pub receive_jitter_max_ms: f64,
    pub jitter_intervals: usize,
    pub rate_hz: f64,
}

/// `count` points on the surface of a bundled shape, as a PointCloud2 in `frame`.
pub fn sample_cloud(shape: &str, count: usize, frame: &str, seed: u64) -> PointCloud2 {
    let shape = bundled(shape).expect("a bundled shape");
    let grid = VoxelGrid::from_shape(&shape, 64, None);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let samples = sample_surface(
        &shape,
        &grid,
        &SurfaceSampling {
            count,
            ..Default::default()
        },
        &mut rng,
    );
    let xyz: Vec<f32> = samples
        .points
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    encode_cloud(
        Header {
            frame_id: frame.into(),
            ..Header::default()
        },
        &xyz,
        &[],
        &[],
    )
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

/// Runs the node in this process and a client beside it, in a private network namespace.
pub fn run_latency_bench(domain_id: u16, log: impl Fn(&str)) -> Result<LatencyReport> {
    let open = open_interfaces();
    if !open.is_empty() {
        return Err(dds(format!(
            "interfaces {open:?} could carry DDS off this machine; run the bench as `unshare -n tests/peers/private_net.sh physskin bench latency`"
        )));
    }
    let model = NeuralModel::bundled()?;
    let stop = Arc::new(AtomicBool::new(false));
    let config = NodeConfig {
        domain_id,
        ..NodeConfig::default()
    };
    let rate_hz = config.params.rate_hz;
    let topics = config
        .params
        .topics
        .resolved(&config.names)
        .expect("the default names are valid");
    let node = {
        let stop = stop.clone();
        std::thread::spawn(move || run_node(config, model, stop))
    };
    let result = (|| {
        let ctx = context(domain_id, false)?;
        let mut client = client_node(&ctx, "physskin_bench")?;
        let points = publisher::<PointCloud2>(&mut client, &topics.points, reliable_qos(5, false))?;
        let deformed = subscription::<PointCloud2>(
            &mut client,
            &topics.deformed_points,
            reliable_qos(50, false),
        )?;
        let spinner = client.spinner().map_err(|e| dds(format!("{e:?}")))?;
        std::thread::spawn(move || smol::block_on(spinner.spin()));
        // Wait for discovery both ways before timing anything.
        smol::block_on(async {
            smol::future::race(
                async {
                    points.wait_for_subscription(&client).await;
                    deformed.wait_for_publisher(&client).await;
                },
                async {
                    smol::Timer::after(Duration::from_secs(20)).await;
                },
            )
            .await
        });
        let receive = |timeout: Duration| -> Option<(PointCloud2, Instant)> {
            let deadline = Instant::now() + timeout;
            while Instant::now() < deadline {
                if let Ok(Some((m, _))) = deformed.take() {
                    return Some((m, Instant::now()));
                }
                std::thread::sleep(Duration::from_micros(200));
            }
            None
        };
        let latency = |count: usize, frame: &str, seed: u64| -> Result<f64> {
            let cloud = sample_cloud("creature", count, frame, seed);
            while deformed.take().ok().flatten().is_some() {}
            let sent = Instant::now();
            points.publish(cloud).map_err(|e| dds(format!("{e:?}")))?;
            loop {
                let (m, at) = receive(Duration::from_secs(30)).ok_or_else(|| {
                    dds(format!(
                        "no deformed cloud for the {count}-point cloud within 30 s"
                    ))
                })?;
                if m.header.frame_id == frame && m.width as usize == count {
                    return Ok((at - sent).as_secs_f64() * 1e3);
                }
            }
        };
        // A warm-up shape first: the first inference pays for allocations.
        // A warm-up shape first (the first inference pays for allocations), replaced in its
        // frame by the measured one, so one 10k shape runs during the jitter phase.
        latency(9_999, "cloud_10k", 1)?;
        let l10k = latency(10_000, "cloud_10k", 2)?;
        log(&format!(
            "10k points: first deformed cloud after {l10k:.1} ms"
        ));

        // Jitter: intervals of the 10k shape's clouds while new shapes are inferred.
        let mut arrivals = Vec::new();
        let until = Instant::now() + Duration::from_secs(4);
        let mut next_shape = Instant::now();
        let mut seed = 10;
        while Instant::now() < until {
            if Instant::now() >= next_shape {
                points
                    .publish(sample_cloud("plate", 10_000, "other", seed))
                    .map_err(|e| dds(format!("{e:?}")))?;
                seed += 1;
                next_shape += Duration::from_millis(500);
            }
            if let Some((m, at)) = receive(Duration::from_millis(50)) {
                if m.header.frame_id == "cloud_10k" {
                    arrivals.push((m.header.stamp.nanos(), at));
                }
            }
        }
        // Last, so its 100k-point frames do not load the jitter phase.
        let l100k = latency(100_000, "cloud_100k", 3)?;
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
        // (p99, max) of |interval - period| over consecutive times, ms.
        let jitter = |times_ms: Vec<f64>| -> (f64, f64) {
            let mut d: Vec<f64> = times_ms
                .windows(2)
                .map(|w| (w[1] - w[0] - period).abs())
                .collect();
            d.sort_by(f64::total_cmp);
            let p99 = d[((d.len() as f64 * 0.99).ceil() as usize).min(d.len()) - 1];
            (p99, *d.last().unwrap_or(&f64::NAN))
        };
        let start = arrivals[0].1;
        let published = jitter(
            arrivals
                .iter()
                .map(|(stamp, _)| *stamp as f64 / 1e6)
                .collect(),
        );
        let received = jitter(
            arrivals
                .iter()
                .map(|(_, at)| (*at - start).as_secs_f64() * 1e3)
                .collect(),
        );
        Ok(LatencyReport {
            latency_10k_ms: l10k,
            latency_100k_ms: l100k,
            jitter_p99_ms: published.0,
            jitter_max_ms: published.1,
            receive_jitter_p99_ms: received.0,
            receive_jitter_max_ms: received.1,
            jitter_intervals: arrivals.len() - 1,
            rate_hz,
        })
    })();
    stop.store(true, Ordering::Relaxed);
    let _ = node.join();
    result
}

pub(crate) fn dds(message: String) -> Error {
    Error::Node(crate::ros::NodeError::Dds(message))
}

/// A benchmark's own ROS 2 node (no rosout) named `name`, in `ctx`.
pub(crate) fn client_node(ctx: &ros2_client::Context, name: &str) -> Result<ros2_client::Node> {
    ctx.new_node(
        ros2_client::NodeName::new("/", name).map_err(|e| dds(format!("{e:?}")))?,
        ros2_client::NodeOptions::new().enable_rosout(false),
    )
    .map_err(|e| dds(format!("{e:?}")))
}
