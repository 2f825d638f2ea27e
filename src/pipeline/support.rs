//! How a body is held: a slab of its cubature points pinned at its bottom or top (the slab its
//! FEM reference pins, `pinned_slab_top`; its surface there collides with nothing), or a floor.

use nalgebra::Vector3;

use super::options::{BodyOptions, Support};
use crate::geometry::{pinned_slab_top, ContactSamples, Cubature};
use crate::physics::{Obstacle, ReducedSim};

/// Pins a slab of the cubature points or adds a floor, per `options.support`. On a floor, the
/// surface samples within `flat` of it are put on it (`lay_on_floor`).
pub(super) fn apply_support(
    sim: &mut ReducedSim,
    options: &BodyOptions,
    cubature: &Cubature,
    surface: &mut ContactSamples,
    flat: f64,
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
            let lowest = (surface.points.iter())
                .map(|p| p.z)
                .fold(f64::INFINITY, f64::min);
            let floor = options.floor_z.unwrap_or(lowest);
            lay_on_floor(&mut surface.points, floor, flat);
            sim.add_contact_points(&surface.points, &surface.areas);
            sim.add_obstacle(Obstacle::floor(floor));
        }
    }
}

/// An object standing on a floor rests on it with its whole bottom, flat: the surface points
/// within `flat` of `floor` are put on it. The bottom of a solid completed from one view
/// is as uneven as the voxels it was made of (a block's spread over 1.5 mm above its lowest
/// point); resting on the few lowest points, the block sank 0.8 mm into the floor before enough
/// of them carried its weight, where the FEM's flat bottom sank 0.13 mm (`bench track`).
fn lay_on_floor(points: &mut [Vector3<f64>], floor: f64, flat: f64) {
    for p in points.iter_mut().filter(|p| (p.z - floor).abs() < flat) {
        p.z = floor;
    }
}
