//! Contact of a reduced body: the broad phase, this step's friction (point sticks and
//! rolling), and the contact and friction curvature the solvers add to their Hessians.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::curvature::Springs;
use super::factor::{point_vector, turn_vector, SpringTerm, TermKey, TermShape};
use super::point::{placed, Gathered};
use super::{ReducedPoint, ReducedSim};
use crate::linalg::{add_product_transposed, product};
use crate::physics::obstacle::{carried_by, Obstacle, Penetration, Stick};
use crate::physics::rolling::{RollingStick, ROLL_SLIP};

/// Which contact springs a factored preconditioner holds: their curvature is stiff, so a
/// factor without a spring that acts (or with one that no longer does) preconditions badly,
/// while the same springs a little further in or out change it little.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct ContactSignature {
    /// (contact, obstacle) pairs in touch.
    pub touching: Vec<(usize, usize)>,
    /// The contact points with friction springs.
    pub sticks: Vec<usize>,
    /// Rolling friction terms.
    pub rolls: usize,
}

impl ReducedSim {
    /// Surface points (rest positions, the area each stands for) that collide with obstacles.
    pub fn add_contact_points(&mut self, points: &[Vector3<f64>], areas: &[f64]) {
        let sampled = ReducedPoint::sampled(&self.subspace, points, areas, 0);
        self.contacts.extend(sampled);
        self.contacts_changed();
    }

    /// Marks the material at rest on one side of a plane (n . x <= h) as held by its pins: its
    /// contact samples no longer collide. A base pinned on the floor it stands on had them
    /// pressed into that floor, fighting its own pins: dozens of springs and a refactorization
    /// every step for material that cannot move. They still stand for the body's surface where
    /// other objects collide with it (`contact_positions`).
    pub fn hold_contacts_beyond(&mut self, normal: Vector3<f64>, height: f64) {
        self.held_side = Some((normal, height));
        self.contacts_changed();
    }

    /// Where the contact points are now (world), in the order they were added.
    pub fn contact_positions(&self) -> Vec<Vector3<f64>> {
        let positions = self.contact_positions_at(&self.z);
        positions
            .column_iter()
            .map(|x| Vector3::new(x[0], x[1], x[2]))
            .collect()
    }

    /// Indexes the contact points anew after some were added or resampled.
    pub(super) fn contacts_changed(&mut self) {
        self.held_contact = None;
        // The broad phase's gathered samples belong to the points as they were.
        self.candidates.clear();
        self.gathered_candidates = Gathered::new();
        self.gathered_sticks = Gathered::new();
        let (rows, n) = (4 * self.subspace.handles(), self.contacts.len());
        self.contact_phis = DMatrix::from_fn(rows, n, |a, i| self.contacts[i].phi[a]);
        self.contact_rests = DMatrix::from_fn(3, n, |d, i| self.contacts[i].rest[d]);
        let held = |x: &Vector3<f64>| self.held_side.is_some_and(|(n, h)| n.dot(x) <= h);
        self.contact_collides = self.contacts.iter().map(|c| !held(&c.rest)).collect();
    }

    /// Every contact point's position at `z` (3 x n), in one product: point by point, the
    /// broad phase of a body with a thousand contact points cost more than its solve.
    fn contact_positions_at(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        placed(z, &self.contact_rests, &self.contact_phis)
    }

    /// The broad phase: the (contact, obstacle) pairs to test during a step from state `z`.
    /// A point farther from an obstacle (a floor, a hull's face planes, a mesh) than a tenth of
    /// the object's size plus twice its predicted move is taken not to reach it within the
    /// step. Boxes first, then the exact test once per point: a gripper's or a bin's box holds
    /// everything it holds, and testing all of it in every evaluation was most of a step.
    pub(super) fn find_candidates(&mut self, z: &DMatrix<f64>) {
        self.candidates.clear();
        if self.contacts.is_empty() {
            return;
        }
        let moved = product(&(z - &self.z), &self.contact_phis);
        let reach = moved.column_iter().map(|d| d.norm()).fold(0.0, f64::max);
        let margin = 0.1 * self.diagonal + 2.0 * reach;
        let positions = self.contact_positions_at(z);
        let body = column_bounds(&positions);
        let mut candidates = std::mem::take(&mut self.candidates);
        for o in 0..self.obstacles.len() + self.colliders.len() {
            let obstacle = self.obstacle(o);
            let bounds = obstacle.bounds(margin);
            // The body's box first: in a cell of ten objects most obstacles are far from most
            // bodies, and testing every point against each was a quarter of a step.
            if !reaches(obstacle, bounds.as_ref(), &body, margin) {
                continue;
            }
            let colliding = positions.column_iter().enumerate();
            for (c, x) in colliding.filter(|&(c, _)| self.contact_collides[c]) {
                let x = Vector3::new(x[0], x[1], x[2]);
                let boxed =
                    bounds.is_none_or(|(lo, hi)| (0..3).all(|d| x[d] >= lo[d] && x[d] <= hi[d]));
                if boxed && obstacle.is_within(&x, margin) {
                    candidates.push((c, o));
                }
            }
        }
        // Point by point, as the sums over them have always run.
        candidates.sort_unstable();
        let points = candidates.iter().map(|&(c, _)| c).collect();
        (self.gathered_candidates).gather(points, &self.contact_rests, &self.contact_phis);
        self.candidates = candidates;
    }

    /// The candidates' positions at `z` (3 x candidates).
    pub(super) fn candidate_positions(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        self.gathered_candidates.placed(z)
    }

    /// Friction for this step: the candidate contacts that touch at its start, and the
    /// rolling friction of the body on each obstacle they touch.
    pub(super) fn find_sticks(&mut self) {
        self.sticks.clear();
        self.rolls.clear();
        let (kc, mu) = (self.params.contact_stiffness, self.params.friction);
        let rolling = self.params.rolling_friction > 0.0;
        if mu == 0.0 && !rolling {
            return;
        }
        let statics = self.obstacles.len();
        let mut pushes: Vec<(usize, Vector3<f64>)> = Vec::new();
        // Placed in one product: point by point, this loop was a fifth of a step of the cell's
        // column in its bin (a `perf` of `bench scene`, printed).
        let positions = self.candidate_positions(&self.z);
        for (&(c, o), x) in self.candidates.iter().zip(positions.column_iter()) {
            let contact = &self.contacts[c];
            let x = Vector3::new(x[0], x[1], x[2]);
            let Some(p) = self.obstacle(o).penetration(&x) else {
                continue;
            };
            if rolling {
                let push = p.normal * (kc * contact.weight * p.depth);
                match pushes.iter_mut().find(|(touched, _)| *touched == o) {
                    Some((_, force)) => *force += push,
                    None => pushes.push((o, push)),
                }
            }
            if mu > 0.0 {
                // Kept anchors hold a resting object instead of letting it creep a little
                // every step; a moving link carries what it touches along.
                let (before, now) = (&self.colliders_before, &self.colliders);
                let (anchor, slip) = self.anchors.tie((c, o), &x, &p.normal, |a| {
                    carried_by(before, now, statics, o, a)
                });
                let stick = Stick::new(c, anchor, &p, contact.weight, kc, mu);
                self.sticks.extend(stick.map(|s| s.after_slip(slip)));
            }
        }
        self.anchors.end_step();
        let points = self.sticks.iter().map(|s| s.point).collect();
        (self.gathered_sticks).gather(points, &self.contact_rests, &self.contact_phis);
        self.find_rolls(&pushes, statics);
    }

    /// Adds the sticks' forces at `z` to `gradient` (3 x 4K) and returns their energy: every
    /// stick placed in one product and its force spread in another, where point by point a
    /// gripped or resting body's hundreds of sticks cost a product each.
    pub(super) fn add_stick_forces(&self, z: &DMatrix<f64>, gradient: &mut DMatrix<f64>) -> f64 {
        if self.sticks.is_empty() {
            return 0.0;
        }
        let positions = self.gathered_sticks.placed(z);
        let mut forces = DMatrix::zeros(3, self.sticks.len());
        let mut energy = 0.0;
        for ((stick, x), mut force) in self
            .sticks
            .iter()
            .zip(positions.column_iter())
            .zip(forces.column_iter_mut())
        {
            let (e, g) = stick.energy_and_gradient(&Vector3::new(x[0], x[1], x[2]));
            energy += e;
            force.copy_from(&g);
        }
        add_product_transposed(gradient, &forces, &self.gathered_sticks.phis);
        energy
    }

    /// Rolling friction on each obstacle pushing with a total force from `pushes`.
    pub(super) fn find_rolls(&mut self, pushes: &[(usize, Vector3<f64>)], statics: usize) {
        let rho = self.params.rolling_friction;
        if rho > 0.0 && !pushes.is_empty() {
            let rotation = self.subspace.mean_rotation(&self.z);
            let lever = 0.5 * self.diagonal;
            for (o, force) in pushes {
                let n = force.norm();
                let normal = force / n;
                let anchor =
                    self.roll_anchors
                        .tie(*o, *o < statics, &rotation, &normal, ROLL_SLIP / lever);
                let gradient = self.subspace.mean_gradient();
                self.rolls
                    .extend(RollingStick::new(&anchor, &normal, n, rho, lever, gradient));
            }
        }
        self.roll_anchors.end_step();
    }

    /// The candidate (contact, obstacle) pairs in touch at `z`, with their penetration.
    pub(super) fn touching_at(&self, z: &DMatrix<f64>) -> Vec<(usize, usize, Penetration)> {
        let positions = self.candidate_positions(z);
        self.candidates
            .iter()
            .zip(positions.column_iter())
            .filter_map(|(&(c, o), x)| {
                let p = self
                    .obstacle(o)
                    .penetration(&Vector3::new(x[0], x[1], x[2]))?;
                Some((c, o, p))
            })
            .collect()
    }

    /// The contact state that decides the contact curvature: the pairs in `touching`, this
    /// step's friction.
    pub(super) fn contact_signature(
        &self,
        touching: &[(usize, usize, Penetration)],
    ) -> ContactSignature {
        ContactSignature {
            touching: touching.iter().map(|&(c, o, _)| (c, o)).collect(),
            sticks: self.sticks.iter().map(|s| s.point).collect(),
            rolls: self.rolls.len(),
        }
    }

    pub(super) fn obstacle(&self, index: usize) -> &Obstacle {
        let statics = self.obstacles.len();
        if index < statics {
            &self.obstacles[index]
        } else {
            &self.colliders[index - statics]
        }
    }

    /// The curvature of the contact and friction springs at `z` (None: nothing touches).
    pub(super) fn contact_curvature(&self, z: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        self.curvature_of(&self.touching_at(z))
    }

    /// The curvature of the springs of `touching` and of this step's friction (None: nothing
    /// touches): each touching point's spring along its normal, each stick's across it, and
    /// the rolling friction.
    pub(super) fn curvature_of(
        &self,
        touching: &[(usize, usize, Penetration)],
    ) -> Option<DMatrix<f64>> {
        let kc = self.params.contact_stiffness;
        let mut springs = Springs::default();
        for (c, _, p) in touching {
            springs.add_along(*c, kc * self.contacts[*c].weight, &p.normal);
        }
        for stick in &self.sticks {
            springs.add_across(stick.point, stick.curvature, &stick.tangents);
        }
        if springs.is_empty() && self.rolls.is_empty() {
            return None;
        }
        let mut curvature = springs.curvature(&self.contact_phis);
        for roll in &self.rolls {
            roll.add_curvature(&mut curvature);
        }
        Some(curvature)
    }
}

impl ReducedSim {
    /// The springs of `touching` and of this step's friction as the terms alpha u u^T that
    /// `curvature_of` sums: what a factor updated for them must hold (see `HeldFactor`).
    pub(super) fn spring_terms(&self, touching: &[(usize, usize, Penetration)]) -> Vec<SpringTerm> {
        let kc = self.params.contact_stiffness;
        let along = touching.iter().map(|&(c, o, ref p)| SpringTerm {
            key: TermKey::Along(c, o),
            alpha: kc * self.contacts[c].weight,
            shape: TermShape::Point(c, p.normal),
        });
        let across = self.sticks.iter().flat_map(|stick| {
            (0..2).map(move |axis| SpringTerm {
                key: TermKey::Across(stick.point, axis),
                alpha: stick.curvature,
                shape: TermShape::Point(stick.point, stick.tangents[axis]),
            })
        });
        let rolls = self.rolls.iter().enumerate().flat_map(|(r, roll)| {
            roll.directions()
                .iter()
                .enumerate()
                .map(move |(axis, d)| SpringTerm {
                    key: TermKey::Roll(r, axis),
                    alpha: roll.stiffness(),
                    shape: TermShape::Whole(DVector::from_column_slice(d.as_slice())),
                })
        });
        along.chain(across).chain(rolls).collect()
    }

    /// A term's u turned by `r` ((I (x) R) u), in flat z order, restricted to the directions
    /// the pins leave free as the factored matrix is.
    pub(super) fn term_vector(&self, term: &SpringTerm, r: &Matrix3<f64>) -> DVector<f64> {
        let mut u = match &term.shape {
            TermShape::Point(c, d) => {
                point_vector(self.contact_phis.column(*c).iter().copied(), &(r * d))
            }
            TermShape::Whole(u) => {
                let mut u = u.clone();
                turn_vector(u.as_mut_slice(), r);
                u
            }
        };
        if let Some(pinning) = self.pinning.as_ref() {
            pinning.free_vector(&mut u);
        }
        u
    }
}

/// The smallest box (lower and upper corners) holding the columns of `points` (3 x n, n > 0).
fn column_bounds(points: &DMatrix<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for x in points.column_iter() {
        for d in 0..3 {
            lo[d] = lo[d].min(x[d]);
            hi[d] = hi[d].max(x[d]);
        }
    }
    (lo, hi)
}

/// Whether any point in the box `body` may come within `margin` of `obstacle`, whose own box
/// (grown by the margin) is `bounds`: a plane is reached when the box's lowest corner is within
/// the margin above it, anything else when the boxes overlap.
fn reaches(
    obstacle: &Obstacle,
    bounds: Option<&(Vector3<f64>, Vector3<f64>)>,
    body: &(Vector3<f64>, Vector3<f64>),
    margin: f64,
) -> bool {
    let (lo, hi) = body;
    if let Obstacle::Plane { normal, .. } = obstacle {
        let lowest = Vector3::from_fn(|d, _| if normal[d] >= 0.0 { lo[d] } else { hi[d] });
        return obstacle.is_within(&lowest, margin);
    }
    bounds.is_none_or(|(min, max)| (0..3).all(|d| lo[d] <= max[d] && hi[d] >= min[d]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points spread over the box from `lo` to `hi`, corners included.
    fn spread(lo: &Vector3<f64>, hi: &Vector3<f64>) -> DMatrix<f64> {
        let steps = 6;
        let t = |i: usize| i as f64 / steps as f64;
        let mut columns = Vec::new();
        for (i, j, k) in (0..=steps)
            .flat_map(|i| (0..=steps).flat_map(move |j| (0..=steps).map(move |k| (i, j, k))))
        {
            let x = Vector3::new(t(i), t(j), t(k));
            columns.extend((lo + (hi - lo).component_mul(&x)).iter().copied());
        }
        DMatrix::from_vec(3, columns.len() / 3, columns)
    }

    /// The broad phase skips an obstacle only when no point of the body's box can reach it:
    /// floors and tilted planes above, at and below the box, and a hull beside it.
    #[test]
    fn a_body_box_is_skipped_only_when_none_of_its_points_reaches() {
        let (lo, hi) = (Vector3::new(-0.1, 0.2, 0.3), Vector3::new(0.2, 0.4, 0.5));
        let points = spread(&lo, &hi);
        let body = column_bounds(&points);
        assert!((body.0 - lo).amax() < 1e-12 && (body.1 - hi).amax() < 1e-12);
        let cube = |centre: Vector3<f64>| {
            let corners: Vec<_> = (0..8)
                .map(|k| {
                    centre
                        + Vector3::new((k & 1) as f64, ((k >> 1) & 1) as f64, (k >> 2) as f64) * 0.1
                })
                .collect();
            Obstacle::hull_of(&corners).expect("a cube spans a volume")
        };
        let tilted = |offset: f64| Obstacle::Plane {
            normal: Vector3::new(0.6, -0.48, 0.64).normalize(),
            offset,
        };
        let obstacles = [
            Obstacle::floor(0.1),
            Obstacle::floor(0.25),
            Obstacle::floor(0.31),
            tilted(-0.2),
            tilted(0.0),
            tilted(0.4),
            cube(Vector3::new(0.25, 0.3, 0.35)),
            cube(Vector3::new(0.5, 0.3, 0.35)),
            cube(Vector3::new(1.0, 1.0, 1.0)),
        ];
        let margin = 0.05;
        let (mut skipped, mut kept) = (0, 0);
        for obstacle in &obstacles {
            let bounds = obstacle.bounds(margin);
            let reached = points
                .column_iter()
                .any(|x| obstacle.is_within(&Vector3::new(x[0], x[1], x[2]), margin));
            let kept_here = reaches(obstacle, bounds.as_ref(), &body, margin);
            assert!(kept_here || !reached, "skipped an obstacle a point reaches");
            if kept_here {
                kept += 1
            } else {
                skipped += 1
            }
        }
        assert!(
            skipped >= 3 && kept >= 3,
            "{skipped} skipped, {kept} kept: the test is blind"
        );
    }
}
