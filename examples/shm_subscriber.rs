//! Receives physskin's deformed points over iceoryx2 shared memory, without a copy, and prints
//! one line per frame.
//!
//! Run a publisher (`physskin node`, or `physskin replay bags/demo.mcap --shm --pace 1`), then:
//!
//!     cargo run --release --example shm_subscriber [SERVICE] [FRAMES]
//!
//! SERVICE defaults to physskin/deformed_points (physskin/weights for the weights), FRAMES to 120.

use std::time::{Duration, Instant};

use physskin::shm::{FrameHeader, ShmSubscriber};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let service = args
        .next()
        .unwrap_or_else(|| "physskin/deformed_points".into());
    let frames: usize = args.next().map_or(Ok(120), |n| n.parse())?;
    let subscriber = ShmSubscriber::open(&service)?;
    println!("listening on {service}");
    let (mut seen, started) = (0, Instant::now());
    while seen < frames && started.elapsed() < Duration::from_secs(60) {
        seen += subscriber.receive(|h: &FrameHeader, values: &[f32]| {
            // `values` is the publisher's memory: read it in place.
            let first = &values[..values.len().min(3)];
            println!(
                "shape {} frame {} at {} ns: {} points, {} handles, first values {first:?}",
                h.shape_id, h.sequence, h.stamp_ns, h.point_count, h.handle_count
            );
        })?;
        std::thread::sleep(Duration::from_millis(2));
    }
    println!("{seen} frames received, {} lost", subscriber.lost());
    Ok(())
}
