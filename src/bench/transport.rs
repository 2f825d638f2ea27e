//! `bench transport`: a 100k-point deformed cloud (1.2 MB) delivered every frame to a local
//! subscriber, over iceoryx2 shared memory and over DDS (ros2-client, in a private network
//! namespace). Latency is from the publisher's call until the subscriber holds the frame.

use std::time::{Duration, Instant};

use serde::Serialize;

use super::latency::{client_node, dds, open_interfaces, sample_cloud};
use super::stats::median;
use crate::msg::cloud::decode_cloud;
use crate::msg::{PointCloud2, Time};
use crate::node::{context, publisher, reliable_qos, subscription};
use crate::shm::{ShmOptions, ShmPublisher, ShmSubscriber};
use crate::Result;

/// What `bench transport` reports (serialized for `--json`).
#[derive(Clone, Debug, Serialize)]
pub struct TransportReport {
    /// Points per frame (100,000).
    pub points: usize,
    /// Bytes of float32 x, y, z per frame.
    pub bytes: usize,
    /// Frames sent over each transport (200).
    pub frames: usize,
    /// Median iceoryx2 latency, from the publisher's call until the subscriber holds
    /// the frame, ms.
    pub iceoryx2_median_ms: f64,
    /// 99th-percentile iceoryx2 latency, ms.
    pub iceoryx2_p99_ms: f64,
    /// Median DDS latency (a reliable PointCloud2), ms.
    pub dds_median_ms: f64,
    /// 99th-percentile DDS latency, ms.
    pub dds_p99_ms: f64,
    /// Frames the DDS subscriber received of those sent.
    pub dds_received: usize,
    /// Frames streamed over iceoryx2 at 60 Hz to a subscriber polling every 2 ms.
    pub iceoryx2_stream_frames: usize,
    /// Of those, frames the subscriber received.
    pub iceoryx2_stream_received: usize,
    /// Of those, frames the subscriber counted lost (gaps in the sequence numbers).
    pub iceoryx2_stream_lost: u64,
}

const POINTS: usize = 100_000;
const FRAMES: usize = 200;
/// Frames of the 60 Hz stream (2 s).
const STREAM_FRAMES: usize = 120;

fn p99(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[((v.len() as f64 * 0.99).ceil() as usize).clamp(1, v.len()) - 1]
}

/// Runs both; `domain_id` keeps the DDS run apart from others on this machine.
pub fn run_transport_bench(domain_id: u16, log: impl Fn(&str)) -> Result<TransportReport> {
    let open = open_interfaces();
    if !open.is_empty() {
        return Err(dds(format!(
            "interfaces {open:?} could carry DDS off this machine; run the bench as `unshare -n tests/peers/private_net.sh physskin bench transport`"
        )));
    }
    let cloud = sample_cloud("creature", POINTS, "bench", 3);
    let xyz = decode_cloud(&cloud, POINTS)
        .map_err(|e| dds(e.to_string()))?
        .points
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect::<Vec<f32>>();
    let epoch = Instant::now();
    let now_ns = || epoch.elapsed().as_nanos() as i64;

    // iceoryx2: the publisher copies the frame into a loaned sample once; the subscriber reads
    // it in place.
    let prefix = format!("physskin_bench_{}/", std::process::id());
    let options = ShmOptions {
        deformed_service: format!("{prefix}deformed_points"),
        weights_service: format!("{prefix}weights"),
        ..Default::default()
    };
    let subscriber = ShmSubscriber::open(&options.deformed_service)?;
    let shm = ShmPublisher::create(&options)?;
    let mut shm_ms = Vec::with_capacity(FRAMES);
    for frame in 0..FRAMES {
        let sent = now_ns();
        shm.publish_deformed(1, sent, 17, &xyz)?;
        let mut got = false;
        let deadline = Instant::now() + Duration::from_secs(1);
        while !got && Instant::now() < deadline {
            subscriber.receive(|h, values| {
                // Touch the last value, as a consumer would read the frame.
                if h.sequence == frame as u64 && values.last().is_some() {
                    shm_ms.push((now_ns() - h.stamp_ns) as f64 / 1e6);
                    got = true;
                }
            })?;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    log(&format!(
        "iceoryx2: {} frames, median {:.4} ms",
        shm_ms.len(),
        median(&shm_ms)
    ));
    let (received, lost) = stream_at_60_hz(&shm, &options, &xyz)?;
    log(&format!(
        "iceoryx2 at 60 Hz: {received} of {STREAM_FRAMES} frames received, {lost} lost"
    ));

    // DDS: the same frame as a PointCloud2, through RustDDS, reliable.
    let ctx = context(domain_id, false)?;
    let mut node = client_node(&ctx, "physskin_transport_bench")?;
    let topic = "/physskin_bench/deformed_points";
    let writer = publisher::<PointCloud2>(&mut node, topic, reliable_qos(2, false))?;
    let reader = subscription::<PointCloud2>(&mut node, topic, reliable_qos(2, false))?;
    let spinner = node.spinner().map_err(|e| dds(format!("{e:?}")))?;
    std::thread::spawn(move || smol::block_on(spinner.spin()));
    smol::block_on(async {
        smol::future::race(
            async {
                writer.wait_for_subscription(&node).await;
            },
            async {
                smol::Timer::after(Duration::from_secs(10)).await;
            },
        )
        .await
    });
    let mut dds_ms = Vec::with_capacity(FRAMES);
    for _ in 0..FRAMES {
        let mut message = cloud.clone();
        let sent = now_ns();
        message.header.stamp = Time::from_nanos(sent);
        writer.publish(message).map_err(|e| dds(format!("{e:?}")))?;
        let deadline = Instant::now() + Duration::from_secs(1);
        while Instant::now() < deadline {
            if let Ok(Some((m, _))) = reader.take() {
                if m.header.stamp.nanos() == sent {
                    dds_ms.push((now_ns() - sent) as f64 / 1e6);
                    break;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    log(&format!(
        "DDS: {} of {FRAMES} frames, median {:.3} ms",
        dds_ms.len(),
        median(&dds_ms)
    ));
    if shm_ms.is_empty() || dds_ms.is_empty() {
        return Err(dds(format!(
            "frames received: iceoryx2 {}, DDS {}",
            shm_ms.len(),
            dds_ms.len()
        )));
    }
    Ok(TransportReport {
        points: POINTS,
        bytes: xyz.len() * 4,
        frames: FRAMES,
        iceoryx2_median_ms: median(&shm_ms),
        iceoryx2_p99_ms: p99(shm_ms),
        dds_median_ms: median(&dds_ms),
        dds_received: dds_ms.len(),
        dds_p99_ms: p99(dds_ms),
        iceoryx2_stream_frames: STREAM_FRAMES,
        iceoryx2_stream_received: received,
        iceoryx2_stream_lost: lost,
    })
}

/// Streams `xyz` at 60 Hz to a new subscriber that polls every 2 ms between frames, as a
/// local consumer would; returns the frames it received and those it counted lost.
fn stream_at_60_hz(shm: &ShmPublisher, options: &ShmOptions, xyz: &[f32]) -> Result<(usize, u64)> {
    let subscriber = ShmSubscriber::open(&options.deformed_service)?;
    let (start, period) = (Instant::now(), Duration::from_secs_f64(1.0 / 60.0));
    let mut received = 0;
    for frame in 0..STREAM_FRAMES {
        shm.publish_deformed(2, frame as i64, 17, xyz)?;
        while start.elapsed() < period * (frame as u32 + 1) {
            // Shape 2 only: a new subscriber first gets the service's history (the last frame
            // of the latency run).
            subscriber.receive(|h, values| {
                received += usize::from(h.shape_id == 2);
                std::hint::black_box(values.last());
            })?;
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    subscriber.receive(|h, _| received += usize::from(h.shape_id == 2))?;
    Ok((received, subscriber.lost()))
}
