//! How a body is held: a slab of its cubature points pinned at its bottom or top (the slab its
//! FEM reference pins, `pinned_slab_top`; its surface there collides with nothing), or a floor.

use nalgebra::Vector3;

use super::options::{BodyOptions, Support};
use crate::geometry::{pinned_slab_top, Cubature};
use crate::physics::{Obstacle, ReducedSim};

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
            let below = -pinned_slab_top(&negated, &cubature.volumes);
            let (points, masses) = pin_where(&|h| h >= below);
            sim.add_pins(&points, &masses);
            sim.hold_contacts_beyond(-up, -below);
        }
        Support::PinBottom => {
            let above = pinned_slab_top(&heights, &cubature.volumes);
            let (points, masses) = pin_where(&|h| h <= above);
            sim.add_pins(&points, &masses);
            sim.hold_contacts_beyond(up, above);
        }
        Support::Floor => {
            let lowest = surface.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
            let floor = options.floor_z.unwrap_or(lowest);
            sim.add_contact_points(surface, areas);
            sim.add_obstacle(Obstacle::floor(floor));
        }
    }
}
