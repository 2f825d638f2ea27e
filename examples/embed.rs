//! physskin embedded in a program: a shape in, stepped at the program's own 60 Hz, the weights
//! and deformed points read in place every frame and, with `--shm`, handed to other local
//! programs over iceoryx2 (run `cargo run --release --example shm_subscriber` beside it).
//!
//!     cargo run --release --example embed [-- --shm]

use std::time::{Duration, Instant};

use nalgebra::Vector3;
use physskin::geometry::bundled;
use physskin::shm::{ShmOptions, ShmPublisher};
use physskin::{BodyOptions, SoftBody};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let shm = std::env::args().any(|a| a == "--shm");
    // The bundled creature's mesh vertices stand in for a sensor's cloud.
    let creature = bundled("creature").expect("a bundled shape");
    let points: Vec<f32> = creature
        .positions
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let started = Instant::now();
    let mut body = SoftBody::from_points(&points, &creature.triangles, &BodyOptions::default())?;
    println!(
        "{} points, {} handles, built in {:.1} ms",
        body.point_count(),
        body.handles(),
        started.elapsed().as_secs_f64() * 1e3
    );
    let publisher = shm
        .then(|| ShmPublisher::create(&ShmOptions::default()))
        .transpose()?;
    if let Some(p) = &publisher {
        p.publish_weights(1, 0, body.handles(), body.weights())?;
    }
    let period = Duration::from_secs_f64(1.0 / 60.0);
    let clock = Instant::now();
    let mut worst_step = 0.0f64;
    for frame in 0..120u32 {
        if frame == 30 {
            // Push the head sideways for 0.2 s.
            body.push(
                Vector3::new(0.55, 0.0, 0.35),
                Vector3::new(0.0, 300.0, 0.0),
                0.2,
            );
        }
        let report = body.step();
        worst_step = worst_step.max(report.seconds * 1e3);
        let deformed: &[f32] = body.deformed(); // borrowed from the body, no copy
        if let Some(p) = &publisher {
            let stamp = clock.elapsed().as_nanos() as i64;
            p.publish_deformed(1, stamp, body.handles(), deformed)?;
        }
        if frame % 30 == 29 {
            let moved = deformed
                .chunks(3)
                .zip(points.chunks(3))
                .map(|(x, r)| {
                    ((x[0] - r[0]).powi(2) + (x[1] - r[1]).powi(2) + (x[2] - r[2]).powi(2)).sqrt()
                })
                .fold(0.0f32, f32::max);
            println!("frame {:3}: largest displacement {moved:.4} m", frame + 1);
        }
        // What the next step would begin with (a held Hessian's refresh), in the frame's spare
        // time rather than in the next step.
        body.prepare();
        if let Some(wait) = (period * (frame + 1)).checked_sub(clock.elapsed()) {
            std::thread::sleep(wait);
        }
    }
    println!("2 s at 60 Hz; slowest step {worst_step:.3} ms");
    Ok(())
}
