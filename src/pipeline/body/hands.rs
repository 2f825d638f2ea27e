//! What holds and pushes a body: pins, attachments that carry its material along, holds,
//! pokes.

use nalgebra::{Isometry3, Vector3};

use super::SoftBody;
use crate::physics::Poke;

impl SoftBody {
    /// Pins the material within `radius` of `rest` to where it is at rest; returns the points
    /// pinned.
    pub fn pin(&mut self, rest: &Vector3<f64>, radius: f64) -> usize {
        self.attach(rest, radius, 0)
    }

    /// Attaches the material within `radius` of `rest` to a moving frame: `move_attachment` with
    /// the same `group` (> 0) carries it along. Returns the points attached. The surface samples
    /// in the region are held with the cubature points: a few cubature points alone would
    /// leave the region free to turn about them.
    pub fn attach(&mut self, rest: &Vector3<f64>, radius: f64, group: u32) -> usize {
        let (points, masses) = self.material_within(rest, radius);
        self.sim.add_pin_group(&points, &masses, group);
        self.sim.prepare();
        self.activity.disturbed = true;
        points.len()
    }

    /// Moves attachment `group` to `motion` of its rest pose; a move wakes the body.
    pub fn move_attachment(&mut self, group: u32, motion: &Isometry3<f64>) {
        let moved = self.sim.move_pin_group(group, motion);
        // Sub-micrometre moves are joint-state noise, not motion.
        self.activity.disturbed |= moved > 1e-6;
    }

    /// A force on the material point at `rest` (world, rest frame) for `duration` seconds from now.
    pub fn push(&mut self, rest: Vector3<f64>, force: Vector3<f64>, duration: f64) {
        let start = self.sim.time();
        self.activity.disturbed = true;
        self.sim.add_poke(Poke {
            point: rest,
            force,
            start,
            end: start + duration,
        });
    }

    /// Holds the material within `radius` of `rest` where it is now; returns the points held.
    pub fn hold(&mut self, rest: &Vector3<f64>, radius: f64) -> usize {
        let (points, masses) = self.cubature_within(rest, radius);
        self.sim.hold(&points, &masses);
        self.sim.prepare();
        self.activity.disturbed = true;
        points.len()
    }

    /// Releases the pins within `radius` of `rest`; returns how many.
    pub fn release(&mut self, rest: &Vector3<f64>, radius: f64) -> usize {
        let released = self.sim.release_pins_within(rest, radius);
        self.sim.prepare();
        self.activity.disturbed |= released > 0;
        released
    }

    /// Cubature points and surface samples within `radius` of `center`, sharing the region's
    /// mass (its cubature mass, or its volume's share of the ball when no cubature point lies
    /// in it).
    fn material_within(&self, center: &Vector3<f64>, radius: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
        let (mut points, masses) = self.cubature_within(center, radius);
        let mut mass: f64 = masses.iter().sum();
        points.extend(
            self.surface
                .points
                .iter()
                .filter(|p| (*p - center).norm() <= radius),
        );
        if mass <= 0.0 {
            mass = self.sim.params().density * 2.0 * std::f64::consts::PI / 3.0 * radius.powi(3);
        }
        let each = mass / points.len().max(1) as f64;
        let masses = vec![each; points.len()];
        (points, masses)
    }

    fn cubature_within(&self, center: &Vector3<f64>, radius: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
        let density = self.sim.params().density;
        self.cubature
            .points
            .iter()
            .zip(&self.cubature.volumes)
            .filter(|(p, _)| (*p - center).norm() <= radius)
            .map(|(p, v)| (*p, v * density))
            .unzip()
    }
}
