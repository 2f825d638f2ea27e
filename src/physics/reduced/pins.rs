//! The pins of a reduced body: points held at targets (fixed, moved as a group, or where they
//! are now), as penalty springs whose dominant directions are held exactly (see `pinning`),
//! stiffened for the steps whose forces they would otherwise lose.

use nalgebra::{DMatrix, Isometry3, Vector3};

use super::pinning::{PinConstraint, DOMINANT_PINS};
use super::{add_kron_identity, ReducedPoint, ReducedSim};
use crate::error::{Error, Result};
use crate::linalg::product;

/// The drift, as a fraction of the body's bounding diagonal, that pins may always have.
const PIN_DRIFT_OF_SIZE: f64 = 1e-3;

/// Where a solve last placed its pins one by one, and their farthest drift there (see
/// `ReducedSim::pins_still_within`).
#[derive(Default)]
pub(super) struct PinWatch {
    placed: Option<(DMatrix<f64>, f64)>,
}

#[cfg(test)]
impl PinWatch {
    /// The state the pins were last placed at.
    pub(super) fn placed_at(&self) -> Option<&DMatrix<f64>> {
        self.placed.as_ref().map(|(z, _)| z)
    }
}

impl ReducedSim {
    /// Holds these material points (rest positions, masses in kg) at their rest positions:
    /// penalty springs, exact along the directions where they dominate the body.
    pub fn add_pins(&mut self, points: &[Vector3<f64>], masses: &[f64]) {
        self.add_pin_group(points, masses, 0);
    }

    /// Pins that move together: `move_pin_group` later carries their targets along a rigid
    /// motion (an attachment to a robot link). Group 0 is the ordinary pins.
    pub fn add_pin_group(&mut self, points: &[Vector3<f64>], masses: &[f64], group: u32) {
        let sampled = ReducedPoint::sampled(&self.subspace, points, masses, group);
        self.pins.extend(sampled);
        self.pins_changed();
    }

    /// Moves the targets of a pin group to `motion` applied to their rest positions; returns
    /// how far the farthest target moved (m).
    pub fn move_pin_group(&mut self, group: u32, motion: &Isometry3<f64>) -> f64 {
        let mut moved: f64 = 0.0;
        for pin in self.pins.iter_mut().filter(|p| p.group == group) {
            let target = motion.transform_point(&pin.rest.into()).coords;
            moved = moved.max((target - pin.target).norm());
            pin.target = target;
        }
        if moved > 0.0 {
            self.update_pin_offsets();
        }
        moved
    }

    /// Pins these material points where they are now (not at rest), e.g. a grasp.
    pub fn hold(&mut self, points: &[Vector3<f64>], masses: &[f64]) {
        let first = self.pins.len();
        self.add_pins(points, masses);
        for pin in &mut self.pins[first..] {
            pin.target = pin.at(&self.z);
        }
        self.update_pin_offsets();
    }

    /// Releases the pins whose rest positions lie within `radius` of `center`; returns how many.
    pub fn release_pins_within(&mut self, center: &Vector3<f64>, radius: f64) -> usize {
        let before = self.pins.len();
        self.pins.retain(|p| (p.rest - center).norm() > radius);
        let released = before - self.pins.len();
        if released > 0 {
            // The held elastic Hessian may be definite only with the springs just released.
            self.held = None;
            self.pins_changed();
            // Whatever pinned side was held may be free now: all of it collides again.
            if self.held_side.take().is_some() {
                self.contacts_changed();
            }
        }
        released
    }

    /// The number of pinned points.
    pub fn pin_count(&self) -> usize {
        self.pins.len()
    }

    /// Indexes the pins anew after some were added or released: their phis side by side
    /// (4K x n) and P = sum m phi phi^T; the exact directions are found again before the next
    /// step.
    pub(super) fn pins_changed(&mut self) {
        let rows = self.pin_phi.nrows();
        self.pin_phis = DMatrix::from_fn(rows, self.pins.len(), |a, i| self.pins[i].phi[a]);
        self.pin_phi.fill(0.0);
        for pin in &self.pins {
            self.pin_phi.ger(pin.weight, &pin.phi, &pin.phi, 1.0);
        }
        self.lightest_pin = self
            .pins
            .iter()
            .map(|p| p.weight)
            .fold(f64::INFINITY, f64::min);
        self.pin_reach = self
            .pin_phis
            .column_iter()
            .map(|phi| phi.norm())
            .fold(0.0, f64::max);
        self.pinning_stale = true;
        self.preconditioner = None;
        self.update_pin_offsets();
    }

    /// After the targets moved: the gaps X - T (3 x n) and B = sum m (X - T) phi^T, in two
    /// products (an attachment moves its pins every step).
    pub(super) fn update_pin_offsets(&mut self) {
        self.pin_gaps = DMatrix::from_fn(3, self.pins.len(), |d, i| {
            self.pins[i].rest[d] - self.pins[i].target[d]
        });
        let weighted = DMatrix::from_fn(3, self.pins.len(), |d, i| {
            self.pin_gaps[(d, i)] * self.pins[i].weight
        });
        self.pin_gap_sum = weighted.dot(&self.pin_gaps);
        self.pin_offset = weighted * self.pin_phis.transpose();
        if let Some(pinning) = &mut self.pinning {
            pinning.hold_for(&self.pin_offset);
        }
    }

    /// Finds the pins' directions to hold exactly, against the body at rest: elasticity,
    /// inertia and damping.
    pub(super) fn update_pinning(&mut self) {
        self.pinning_stale = false;
        self.pinning = None;
        if self.pins.is_empty() || self.params.pin_stiffness == 0.0 {
            return;
        }
        let inertia = self.inertia_part();
        let mut body = (*self.rest_elastic_hessian()).clone();
        add_kron_identity(&mut body, &inertia);
        let k = self.params.pin_stiffness;
        self.pinning = PinConstraint::dominant(&self.pin_phi, k, &body, DOMINANT_PINS);
        self.update_pin_offsets();
    }

    /// Moves the pin targets (one per pinned point, in the order they were added).
    pub fn set_pin_targets(&mut self, targets: &[Vector3<f64>]) -> Result<()> {
        if targets.len() != self.pins.len() {
            return Err(Error::InvalidParameter {
                name: "pin targets",
                reason: format!("{} targets for {} pins", targets.len(), self.pins.len()),
            });
        }
        for (pin, t) in self.pins.iter_mut().zip(targets) {
            pin.target = *t;
        }
        self.update_pin_offsets();
        Ok(())
    }

    /// Energy of the pin springs at the current state (J).
    pub(super) fn pin_energy(&self) -> f64 {
        0.5 * self.pin_stiffness() * self.pin_spring_sum(&self.z)
    }

    /// The farthest a pinned point is from its target now, m (0 without pins).
    pub fn pin_drift(&self) -> f64 {
        self.pin_drift_at(&self.z)
    }

    /// sum m |Z phi + X - T|^2 over the pins, in closed form: tr(Z P Z^T) + 2 <B, Z> + sum m
    /// |X - T|^2, a few products of the 4K-wide matrices whatever the number of pins.
    fn pin_spring_sum(&self, z: &DMatrix<f64>) -> f64 {
        let quadratic = product(z, &self.pin_phi).dot(z);
        (quadratic + 2.0 * self.pin_offset.dot(z) + self.pin_gap_sum).max(0.0)
    }

    /// Whether every pinned point is within `tolerance` of its target in state `z` (asked after
    /// each solve; its iterates ask `pins_still_within`). The closed-form sum bounds the
    /// farthest pin, m_min d_max^2 <= sum, and answers most calls; only when it cannot are the
    /// pins placed one by one.
    pub(super) fn pins_within(&self, z: &DMatrix<f64>, tolerance: f64) -> bool {
        self.pins_within_by_sum(z, tolerance) || self.pin_drift_at(z) <= tolerance
    }

    /// `pins_within` for a solve's iterates, which ask every iteration: from the drift at the
    /// state where `watch` last placed the pins one by one, a pin has moved at most
    /// |Z - Z_placed|_F |phi| since, and while that bound stays within `tolerance` they are
    /// not placed again. The poked creature's pins, placed after every iteration of its slow
    /// steps, took 0.41-0.79 ms of each (printed, `bench sim`, FEM left out).
    pub(super) fn pins_still_within(
        &self,
        z: &DMatrix<f64>,
        tolerance: f64,
        watch: &mut PinWatch,
    ) -> bool {
        if let Some((placed, drift)) = &watch.placed {
            if drift + (z - placed).norm() * self.pin_reach <= tolerance {
                return true;
            }
        }
        if self.pins_within_by_sum(z, tolerance) {
            return true;
        }
        let drift = self.pin_drift_at(z);
        watch.placed = Some((z.clone(), drift));
        drift <= tolerance
    }

    /// Whether the closed-form sum alone shows every pin within `tolerance`:
    /// m_min d_max^2 <= sum m d^2.
    fn pins_within_by_sum(&self, z: &DMatrix<f64>, tolerance: f64) -> bool {
        self.pins.is_empty() || self.pin_spring_sum(z) <= self.lightest_pin * tolerance.powi(2)
    }

    /// The farthest a pinned point is from its target in state `z`.
    fn pin_drift_at(&self, z: &DMatrix<f64>) -> f64 {
        self.pin_offsets_at(z)
            .column_iter()
            .map(|c| c.norm_squared())
            .fold(0.0, f64::max)
            .sqrt()
    }

    /// Each pinned point's offset from its target in state `z` (3 x n): Z Phi + (X - T), one
    /// product instead of a position per pin.
    fn pin_offsets_at(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        let mut offsets = product(z, &self.pin_phis);
        offsets += &self.pin_gaps;
        offsets
    }

    /// How far pinned material may drift, m: `pin_tolerance`, or a thousandth of the body's
    /// diagonal if that is more. Pins that hold an object still to a thousandth of its size
    /// are held; stiffening their springs further would only lock the body near them.
    pub fn pin_tolerance(&self) -> f64 {
        self.params
            .pin_tolerance
            .max(PIN_DRIFT_OF_SIZE * self.diagonal)
    }

    /// The pin springs' stiffness this step, 1/s^2.
    pub(super) fn pin_stiffness(&self) -> f64 {
        self.params.pin_stiffness * self.pin_boost
    }

    /// Sets the pin springs' stiffness to `boost` times `pin_stiffness`. The factored
    /// preconditioner includes them, so it is factored anew (the held elastic Hessian stays),
    /// and the curvature pairs measured with the old springs go.
    pub(super) fn set_pin_boost(&mut self, boost: f64) {
        self.pin_boost = boost;
        self.preconditioner = None;
        self.factored_contact = None;
        self.history.clear();
    }

    /// `z` moved onto the pin constraint this step holds.
    pub(super) fn placed_on_pins(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        let mut placed = z.clone();
        if let Some(pinning) = &self.pinning {
            pinning.place(&mut placed);
        }
        placed
    }

    /// Deformed positions of the pinned points (for reports and tests).
    pub fn pinned_positions(&self) -> Vec<Vector3<f64>> {
        self.pins.iter().map(|p| p.at(&self.z)).collect()
    }
}
