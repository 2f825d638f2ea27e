//! How a body is held: a slab of its cubature points pinned at its bottom or top, or a floor.

use nalgebra::Vector3;

use super::options::{BodyOptions, Support};
use crate::geometry::Cubature;
use crate::physics::{Obstacle, ReducedSim};

/// The pinned slab is this fraction of the body's height.
const PINNED_SLAB: f64 = 0.1;
/// At least this share of the cubature points is pinned, the slab widened until it holds them.
/// A body whose lowest part is a corner (the rclpy peer's box, seen from one camera and
/// completed standing on its corner) had one of its 256 points in the slab: pinned at one
/// point, the soft box toppled about it, its points moving 325.646 mm within 20 steps. Pinned at
/// 8, its points moved 2.261-2.415 mm, and a switch to its refined field moved one by
/// 1.374-1.950 mm; at 16, 0.942-0.971 mm and 0.290-0.527 mm (printed). A flat bottom's slab
/// holds a tenth of the points.
const MIN_PINNED_SHARE: f64 = 1.0 / 16.0;

/// Pins a slab of the cubature points or adds a floor, per `options.support`.
pub(super) fn apply_support(
    sim: &mut ReducedSim,
    options: &BodyOptions,
    cubature: &Cubature,
    surface: &[Vector3<f64>],
    areas: &[f64],
) {
    let g = options.sim.gravity;
    // "Up" is against gravity; without gravity, +z.
    let up = if g.norm() > 0.0 {
        -g.normalize()
    } else {
        Vector3::z()
    };
    let heights: Vec<f64> = cubature.points.iter().map(|p| p.dot(&up)).collect();
    let pin_where = |keep: &dyn Fn(f64) -> bool| -> (Vec<Vector3<f64>>, Vec<f64>) {
        cubature
            .points
            .iter()
            .zip(&cubature.volumes)
            .zip(&heights)
            .filter(|(_, &h)| keep(h))
            .map(|((p, v), _)| (*p, v * options.sim.density))
            .unzip()
    };
    match options.support {
        Support::Free => {}
        Support::PinTop => {
            let negated: Vec<f64> = heights.iter().map(|h| -h).collect();
            let below = -slab_top(&negated);
            let (points, masses) = pin_where(&|h| h >= below);
            sim.add_pins(&points, &masses);
        }
        Support::PinBottom => {
            let above = slab_top(&heights);
            let (points, masses) = pin_where(&|h| h <= above);
            sim.add_pins(&points, &masses);
        }
        Support::Floor => {
            let lowest = surface.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
            let floor = options.floor_z.unwrap_or(lowest);
            sim.add_contact_points(surface, areas);
            sim.add_obstacle(Obstacle::floor(floor));
        }
    }
}

/// The height up to which points are pinned from the lowest: `PINNED_SLAB` of the heights'
/// range, or as high as the lowest `MIN_PINNED_SHARE` of the points reach if that is higher.
fn slab_top(heights: &[f64]) -> f64 {
    let mut sorted = heights.to_vec();
    sorted.sort_by(f64::total_cmp);
    let (Some(&lo), Some(&hi)) = (sorted.first(), sorted.last()) else {
        return f64::NEG_INFINITY;
    };
    let wanted = (MIN_PINNED_SHARE * sorted.len() as f64).ceil() as usize;
    let enough = sorted[wanted.clamp(1, sorted.len()) - 1];
    (lo + PINNED_SLAB * (hi - lo)).max(enough)
}

#[cfg(test)]
mod tests {
    use super::slab_top;

    /// The slab is a tenth of the height, widened to hold at least a sixteenth of the points.
    #[test]
    fn the_pinned_slab_holds_at_least_a_sixteenth_of_the_points() {
        let even: Vec<f64> = (0..100).map(|i| i as f64).collect();
        assert_eq!(slab_top(&even), 9.9);
        let mut corner = vec![0.0];
        corner.extend((0..99).map(|i| 10.0 + i as f64 * 0.9));
        let top = slab_top(&corner);
        assert_eq!(corner.iter().filter(|&&h| h <= top).count(), 7);
        assert_eq!(slab_top(&[2.0, 1.0]), 1.1);
        assert_eq!(slab_top(&[]), f64::NEG_INFINITY);
    }
}
