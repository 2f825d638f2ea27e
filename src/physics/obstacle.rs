//! Rigid obstacles the object is pushed out of by penalty contact: an exact plane, or any
//! parry3d shape.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hash, Hasher};
use std::sync::Arc;

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use parry3d::math::{Pose, Vector};
use parry3d::shape::SharedShape;

use super::hull::ConvexHull;
use crate::linalg::tangents;

/// A static rigid obstacle in the world.
#[derive(Clone)]
pub enum Obstacle {
    /// Solid on the side opposite `normal`: points with `normal . p < offset` penetrate.
    /// Kept in f64: the floor is the most common contact and its energy feeds a line search.
    Plane {
        /// The unit normal, pointing out of the solid.
        normal: Vector3<f64>,
        /// The plane's distance from the origin along `normal`, m.
        offset: f64,
    },
    /// A parry3d shape at a pose (f32 geometry).
    Shape {
        /// The shape, in its own frame.
        shape: SharedShape,
        /// Its pose in the world.
        pose: Pose,
    },
    /// A convex hull in the world, in f64: another deformable object where it is now.
    Hull(Arc<ConvexHull>),
}

/// Penetration of a point into an obstacle: depth (> 0 inside) and the direction that pushes out.
#[derive(Clone, Copy, Debug)]
pub struct Penetration {
    /// How deep the point is inside, m (> 0 inside).
    pub depth: f64,
    /// The unit direction that pushes the point out.
    pub normal: Vector3<f64>,
}

impl Obstacle {
    /// The convex hull of `points` (world), fixed where it is: how another deformable object
    /// collides. None when the points span no volume.
    pub fn hull_of(points: &[Vector3<f64>]) -> Option<Self> {
        ConvexHull::of(points).map(|hull| Obstacle::Hull(Arc::new(hull)))
    }

    /// An obstacle that holds nothing anywhere (`ConvexHull::nowhere`).
    pub fn nowhere() -> Self {
        Obstacle::Hull(Arc::new(ConvexHull::nowhere()))
    }

    /// Whether this is [`Obstacle::nowhere`].
    pub fn is_nowhere(&self) -> bool {
        matches!(self, Obstacle::Hull(h) if h.is_empty())
    }

    /// The floor `z = height`, solid below.
    pub fn floor(height: f64) -> Self {
        Obstacle::Plane {
            normal: Vector3::z(),
            offset: height,
        }
    }

    /// The obstacle's bounding box grown by `margin` (min and max corners); `None` for a plane,
    /// which has none.
    pub fn bounds(&self, margin: f64) -> Option<(Vector3<f64>, Vector3<f64>)> {
        match self {
            Obstacle::Plane { .. } => None,
            Obstacle::Hull(hull) => Some(hull.bounds(margin)),
            Obstacle::Shape { shape, pose } => {
                let aabb = shape.compute_aabb(pose);
                let v = |c: Vector| Vector3::new(c.x as f64, c.y as f64, c.z as f64);
                let m = Vector3::repeat(margin);
                Some((v(aabb.mins) - m, v(aabb.maxs) + m))
            }
        }
    }

    /// Whether `p` is inside the obstacle or may be within `margin` of it: the broad phase's
    /// exact test, once per point and step, so that the solver's evaluations test only the
    /// points that can touch. A gripper's or a bin's bounding box holds every point of what it
    /// holds, and testing all of them against the mesh in every evaluation was most of a
    /// step's time.
    pub fn is_within(&self, p: &Vector3<f64>, margin: f64) -> bool {
        match self {
            Obstacle::Plane { normal, offset } => offset - normal.dot(p) > -margin,
            Obstacle::Hull(hull) => hull.is_within(p, margin),
            Obstacle::Shape { shape, pose } => {
                let point = Vector::new(p.x as f32, p.y as f32, p.z as f32);
                let projection = shape.project_point(pose, point, false);
                projection.is_inside || ((projection.point - point).length() as f64) < margin
            }
        }
    }

    /// Where a point at `p` fixed to this obstacle is when the obstacle has moved to `to`: how
    /// a link carries what it grips. `p` itself when `to` is not this obstacle moved (another
    /// kind of obstacle, or a plane turned).
    pub fn carry(&self, to: &Obstacle, p: &Vector3<f64>) -> Vector3<f64> {
        match (self, to) {
            (Obstacle::Shape { pose: from, .. }, Obstacle::Shape { pose: now, .. }) => {
                let at = Vector::new(p.x as f32, p.y as f32, p.z as f32);
                // The move in f32, added to the f64 point: the pose's round-off stays in the
                // move instead of in the point's position.
                let moved = now.transform_point(from.inverse_transform_point(at)) - at;
                p + Vector3::new(moved.x as f64, moved.y as f64, moved.z as f64)
            }
            (
                Obstacle::Plane { normal, offset },
                Obstacle::Plane {
                    normal: now,
                    offset: now_offset,
                },
            ) if normal == now => p + normal * (now_offset - offset),
            _ => *p,
        }
    }

    /// Penetration of `p`, or `None` when `p` is outside.
    pub fn penetration(&self, p: &Vector3<f64>) -> Option<Penetration> {
        match self {
            Obstacle::Plane { normal, offset } => {
                let depth = offset - normal.dot(p);
                (depth > 0.0).then_some(Penetration {
                    depth,
                    normal: *normal,
                })
            }
            Obstacle::Hull(hull) => hull
                .penetration(p)
                .map(|(depth, normal)| Penetration { depth, normal }),
            Obstacle::Shape { shape, pose } => {
                if let Some(exact) = primitive_penetration(shape, pose, p) {
                    return exact;
                }
                let point = Vector::new(p.x as f32, p.y as f32, p.z as f32);
                let projection = shape.project_point(pose, point, false);
                if !projection.is_inside {
                    return None;
                }
                let to_surface = projection.point - point;
                let depth = to_surface.length();
                (depth > 0.0).then(|| {
                    let n = to_surface / depth;
                    Penetration {
                        depth: depth as f64,
                        normal: Vector3::new(n.x as f64, n.y as f64, n.z as f64),
                    }
                })
            }
        }
    }
}

/// Penetration into a box, ball or capsule computed in f64 (None: another shape, left to
/// parry). Parry works in f32: its depth's round-off, about 1e-8 m, summed over the thousand
/// points a gripper squeezes, makes the contact energy noisy at the size of the solver's
/// convergence threshold, and such steps failed their line search.
fn primitive_penetration(
    shape: &SharedShape,
    pose: &Pose,
    p: &Vector3<f64>,
) -> Option<Option<Penetration>> {
    let v = |c: Vector| Vector3::new(c.x as f64, c.y as f64, c.z as f64);
    let q = pose.rotation;
    let rotation = UnitQuaternion::new_normalize(Quaternion::new(
        q.w as f64, q.x as f64, q.y as f64, q.z as f64,
    ));
    let local = rotation.inverse() * (p - v(pose.translation));
    let (gap, direction) = if let Some(cuboid) = shape.as_cuboid() {
        let h = v(cuboid.half_extents);
        // The nearest face pushes out: the axis with the least room left.
        (0..3)
            .map(|i| {
                let side = if local[i] < 0.0 { -1.0 } else { 1.0 };
                (h[i] - local[i].abs(), Vector3::ith(i, side))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .expect("three axes")
    } else if let Some(ball) = shape.as_ball() {
        outward(&local, ball.radius as f64)
    } else if let Some(capsule) = shape.as_capsule() {
        let (a, b) = (v(capsule.segment.a), v(capsule.segment.b));
        let axis = b - a;
        let t = ((local - a).dot(&axis) / axis.norm_squared().max(1e-300)).clamp(0.0, 1.0);
        outward(&(local - (a + axis * t)), capsule.radius as f64)
    } else {
        return None;
    };
    Some((gap > 0.0).then(|| Penetration {
        depth: gap,
        normal: rotation * direction,
    }))
}

/// Room left inside a ball of `radius` around the origin at offset `d`, and the way out.
fn outward(d: &Vector3<f64>, radius: f64) -> (f64, Vector3<f64>) {
    let length = d.norm();
    let direction = if length > 0.0 {
        d / length
    } else {
        Vector3::z()
    };
    (radius - length, direction)
}

/// Where obstacle `index` has carried a point at `x` since the last step. Obstacles are indexed
/// over the `statics` static ones, which carry nothing, then the moving ones (`before`: as they
/// were at the last step, `now`: now); a moving one that did not exist then carries nothing.
pub(crate) fn carried_by(
    before: &[Obstacle],
    now: &[Obstacle],
    statics: usize,
    index: usize,
    x: &Vector3<f64>,
) -> Vector3<f64> {
    let Some(link) = index.checked_sub(statics) else {
        return *x;
    };
    match (before.get(link), now.get(link)) {
        (Some(from), Some(to)) if before.len() == now.len() => from.carry(to, x),
        _ => *x,
    }
}

/// A hasher for the small integer keys of ties (indices of points, obstacles and bodies):
/// a multiply and a rotate per word. The default SipHash, made to resist crafted keys, which
/// indices are not, took a tenth of a small body's step (a 12-unknown block landing).
#[derive(Clone, Debug, Default)]
struct IndexHasher(u64);

impl Hasher for IndexHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_u64(&mut self, word: u64) {
        // The odd constant spreads consecutive indices over the high bits the table uses.
        self.0 = (self.0.rotate_left(26) ^ word).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }

    fn write_usize(&mut self, word: usize) {
        self.write_u64(word as u64);
    }
}

type IndexMap<K, V> = HashMap<K, V, BuildHasherDefault<IndexHasher>>;

/// Friction ties kept from step to step while their contact lasts: `K` names the contact (a
/// point and an obstacle, a body and an obstacle), `V` is where it is tied.
#[derive(Clone, Debug)]
pub(crate) struct Ties<K, V> {
    kept: IndexMap<K, V>,
    touching: IndexMap<K, V>,
}

impl<K, V> Default for Ties<K, V> {
    fn default() -> Self {
        Self {
            kept: IndexMap::default(),
            touching: IndexMap::default(),
        }
    }
}

impl<K: Hash + Eq, V: Copy> Ties<K, V> {
    /// Ties contact `key` this step where `make` says, given where it was tied at the last step
    /// (None: the contact is new, or its tie was not kept); with `keep`, the tie is kept for the
    /// next step.
    pub fn tie_with(&mut self, key: K, keep: bool, make: impl FnOnce(Option<&V>) -> V) -> V {
        let anchor = make(self.kept.get(&key));
        if keep {
            self.touching.insert(key, anchor);
        }
        anchor
    }

    /// After a step's ties: the contacts not tied again have let go.
    pub fn end_step(&mut self) {
        self.kept = std::mem::take(&mut self.touching);
    }
}

/// Friction anchors of touching points, kept from step to step while the point touches (on
/// moving obstacles, carried with them).
pub(crate) type Anchors = Ties<(usize, usize), Vector3<f64>>;

impl Anchors {
    /// Where the (point, obstacle) pair touching at `x` with contact normal `normal` is tied
    /// this step, and how far it slipped from its last anchor (0 for a new contact). `carry`
    /// moves a point fixed to the obstacle by the obstacle's move since the last step (the
    /// identity for a static one): a link holds what it grips from step to step, as a static
    /// obstacle holds what rests on it, instead of letting it creep by a fresh spring's give
    /// every step.
    pub fn tie(
        &mut self,
        pair: (usize, usize),
        x: &Vector3<f64>,
        normal: &Vector3<f64>,
        carry: impl Fn(&Vector3<f64>) -> Vector3<f64>,
    ) -> (Vector3<f64>, f64) {
        let mut slip = 0.0;
        let anchor = self.tie_with(pair, true, |previous| match previous {
            // The slip is measured where the obstacle was, then carried with it.
            Some(previous) => {
                let (anchor, slipped) = Stick::carried_anchor(previous, x, normal);
                slip = slipped;
                carry(&anchor)
            }
            None => carry(x),
        });
        (anchor, slip)
    }
}

/// Slip (m) at which a sticking contact's tangential spring reaches the Coulomb limit.
pub const STICK_SLIP: f64 = 1e-3;

/// Friction of one contact point over one step, lagged: the point is tied tangentially to where
/// it was at the step's start by a spring whose force reaches `friction` times the normal force
/// after a slip of [`STICK_SLIP`], and stays there beyond it (a Huber energy: quadratic, then
/// linear). It holds resting objects still, drags what a moving link presses on, and lets a
/// pushed object slide against the Coulomb limit at any speed: a spring left linear past the
/// limit resisted a block sliding at 12 cm/s with three times its friction (the slip of one
/// 60 Hz step, 2 mm, on top of the 1 mm at the limit).
#[derive(Clone, Copy, Debug)]
pub struct Stick {
    /// The contact point (or vertex) it belongs to.
    pub point: usize,
    /// Where the point is tied: where it first touched, kept while it touches (dragged along
    /// once it slips past [`STICK_SLIP`], carried with a moving obstacle).
    pub anchor: Vector3<f64>,
    /// Two unit directions across the contact normal, along which the spring pulls.
    pub tangents: [Vector3<f64>; 2],
    /// The spring's stiffness within the limit, N/m.
    pub stiffness: f64,
    /// The curvature the solvers take for it, N/m: the stiffness for a contact that held at
    /// the last step, the secant to the limit at the last step's slip for one that slid (a
    /// sliding contact's force does not grow along its slip; the full stiffness there made
    /// each Newton step a fraction of the slide).
    pub curvature: f64,
}

impl Stick {
    /// For a point at `anchor` with penetration `p`, standing for `area`; None without friction.
    pub fn new(
        point: usize,
        anchor: Vector3<f64>,
        p: &Penetration,
        area: f64,
        contact_stiffness: f64,
        friction: f64,
    ) -> Option<Self> {
        let normal_force = contact_stiffness * area * p.depth;
        let stiffness = friction * normal_force / STICK_SLIP;
        // NaN (from a NaN depth) gets no spring either.
        if stiffness.is_nan() || stiffness <= 0.0 {
            return None;
        }
        Some(Self {
            point,
            anchor,
            tangents: tangents(&p.normal),
            stiffness,
            curvature: stiffness,
        })
    }

    /// The stick of a contact that slipped `slip` (m) across its normal over the last step:
    /// past the limit it slides, and the solvers take the secant to the limit there.
    pub fn after_slip(mut self, slip: f64) -> Self {
        self.curvature = self.stiffness * STICK_SLIP / slip.max(STICK_SLIP);
        self
    }

    /// Where a contact that kept touching a static obstacle is tied now, and how far it
    /// slipped across `normal` from its previous anchor: that anchor, dragged along when the
    /// point has slipped farther than [`STICK_SLIP`] from it (the Coulomb limit: beyond it the
    /// point slides and friction stays at its limit).
    pub fn carried_anchor(
        previous: &Vector3<f64>,
        x: &Vector3<f64>,
        normal: &Vector3<f64>,
    ) -> (Vector3<f64>, f64) {
        let d = x - previous;
        let slip = d - normal * normal.dot(&d);
        let length = slip.norm();
        let anchor = if length > STICK_SLIP {
            x - slip * (STICK_SLIP / length)
        } else {
            previous - normal * normal.dot(&(previous - x))
        };
        (anchor, length)
    }

    /// Energy and gradient at `x`: with d the slip across the normal from the anchor,
    /// (k |d|^2 / 2, k d) within the limit, (F (|d| - s / 2), F d / |d|) beyond it, F = k s
    /// the Coulomb force and s [`STICK_SLIP`].
    pub fn energy_and_gradient(&self, x: &Vector3<f64>) -> (f64, Vector3<f64>) {
        let d = x - self.anchor;
        let slip: Vector3<f64> = self.tangents.iter().map(|t| t * t.dot(&d)).sum();
        let length = slip.norm();
        let k = self.stiffness;
        if length <= STICK_SLIP {
            (0.5 * k * length * length, slip * k)
        } else {
            let limit = k * STICK_SLIP;
            (limit * (length - 0.5 * STICK_SLIP), slip * (limit / length))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stick_pulls_up_to_the_coulomb_limit_and_no_further() {
        let p = Penetration {
            depth: 0.002,
            normal: Vector3::z(),
        };
        let stick = Stick::new(0, Vector3::zeros(), &p, 0.01, 1e5, 0.5).unwrap();
        let limit = 0.5 * 1e5 * 0.01 * 0.002;
        for slip in [0.2e-3, 0.9e-3, 1.5e-3, 4e-3, 2e-2] {
            let x = Vector3::new(0.6, 0.8, 0.0) * slip + Vector3::z() * 0.001;
            let (_, g) = stick.energy_and_gradient(&x);
            let expected = limit * (slip / STICK_SLIP).min(1.0);
            assert!(
                (g.norm() - expected).abs() < 1e-9 * limit,
                "{slip}: {}",
                g.norm()
            );
            assert!(g.z.abs() < 1e-12, "no pull along the normal");
            for axis in 0..3 {
                let h = 1e-7;
                let shift = Vector3::ith(axis, h);
                let (plus, _) = stick.energy_and_gradient(&(x + shift));
                let (minus, _) = stick.energy_and_gradient(&(x - shift));
                let fd = (plus - minus) / (2.0 * h);
                assert!((fd - g[axis]).abs() < 1e-5 * limit, "{slip}, axis {axis}");
            }
        }
        let slid = stick.after_slip(3e-3);
        assert!((slid.curvature - stick.stiffness / 3.0).abs() < 1e-9 * stick.stiffness);
        assert_eq!(stick.after_slip(0.5e-3).curvature, stick.stiffness);
    }

    #[test]
    fn a_moving_shape_carries_a_point_as_a_rigid_motion() {
        let shape = SharedShape::cuboid(0.1, 0.1, 0.1);
        let from = Obstacle::Shape {
            shape: shape.clone(),
            pose: Pose::new(Vector::new(0.0, 0.0, 0.5), Vector::ZERO),
        };
        // Lifted 0.2 m and turned a quarter about z.
        let to = Obstacle::Shape {
            shape,
            pose: Pose::new(
                Vector::new(0.0, 0.0, 0.7),
                Vector::new(0.0, 0.0, std::f32::consts::FRAC_PI_2),
            ),
        };
        let carried = from.carry(&to, &Vector3::new(0.1, 0.0, 0.5));
        assert!(
            (carried - Vector3::new(0.0, 0.1, 0.7)).norm() < 1e-6,
            "{carried}"
        );
        // A floor stays; a point is not carried by a different obstacle.
        let floor = Obstacle::floor(0.0);
        let p = Vector3::new(1.0, 2.0, 3.0);
        assert_eq!(floor.carry(&Obstacle::floor(0.0), &p), p);
        assert_eq!(floor.carry(&to, &p), p);
        assert_eq!(carried_by(&[], &[floor], 0, 0, &p), p);
    }

    /// The f64 box, ball and capsule agree with parry's f32 projection wherever it is inside.
    #[test]
    fn primitive_penetration_agrees_with_parry() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(5);
        let pose = Pose::new(Vector::new(0.1, -0.2, 0.3), Vector::new(0.4, -0.7, 0.2));
        for shape in [
            SharedShape::cuboid(0.1, 0.05, 0.2),
            SharedShape::ball(0.12),
            SharedShape::capsule_y(0.1, 0.05),
        ] {
            let mut inside = 0;
            for _ in 0..4000 {
                let p = Vector3::new(0.1, -0.2, 0.3)
                    + Vector3::from_fn(|_, _| rng.random_range(-0.15..0.15));
                let exact = primitive_penetration(&shape, &pose, &p).expect("a primitive");
                let point = Vector::new(p.x as f32, p.y as f32, p.z as f32);
                let projection = shape.project_point(&pose, point, false);
                let depth = (projection.point - point).length() as f64;
                match exact {
                    Some(e) if projection.is_inside => {
                        inside += 1;
                        assert!((e.depth - depth).abs() < 1e-5, "{} vs {depth}", e.depth);
                    }
                    Some(e) => assert!(e.depth < 1e-5, "parry outside, depth {}", e.depth),
                    None => assert!(!projection.is_inside || depth < 1e-5),
                }
            }
            assert!(inside > 50, "{inside} points inside");
        }
    }
}
