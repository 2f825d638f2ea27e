//! Rolling friction: a body resting on an obstacle resists turning about the contact's
//! tangent axes with a torque of at most `rolling_friction` (a length, m, as in MuJoCo) times
//! the normal force.
//!
//! Why: a ball's rotation on a plane is neutral, so in the reduced model any torque, however
//! small (a contact patch whose centre is a hundredth of a millimetre off, the subspace
//! preferring some orientations of its flattened bottom), rolls a resting ball away. Real
//! objects resist rolling by their deformation's hysteresis; this is its lagged, Coulomb-limited
//! model, built like the point friction of [`super::obstacle::Stick`]: within a step the body's
//! mean rotation is tied to where it was by a spring that reaches the limit after
//! [`ROLL_SLIP`] of surface travel, and the tie is dragged along past it.

use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

use super::obstacle::{Ties, STICK_SLIP};
use crate::linalg::tangents;

/// Surface travel (m) at which rolling friction reaches its limit: the same slip as point
/// friction, turned into an angle by the body's half diagonal.
pub const ROLL_SLIP: f64 = STICK_SLIP;

/// One step's rolling friction against one obstacle. The body's turn about tangent axis `a`
/// away from the anchor rotation R is, to first order, omega_a(z) = 1/2 <F(z) R^T, [a]x> with
/// F(z) = I + z G the volume-mean deformation gradient: linear in z, so the energy
/// k/2 sum_a omega_a^2 is quadratic within the step and Newton handles it exactly.
#[derive(Clone, Debug)]
pub struct RollingStick {
    /// d omega_a / dz for both tangent axes (3 x 4K each).
    directions: [DMatrix<f64>; 2],
    /// omega_a at z = 0.
    offsets: [f64; 2],
    /// N m per radian.
    stiffness: f64,
}

impl RollingStick {
    /// Tied at rotation `anchor` on an obstacle pushing with `normal_force` (N) along
    /// `normal`; `mean_gradient` is the subspace's G (4K x 3), `lever` the body's half
    /// diagonal. None when nothing would resist.
    pub fn new(
        anchor: &Matrix3<f64>,
        normal: &Vector3<f64>,
        normal_force: f64,
        rolling_friction: f64,
        lever: f64,
        mean_gradient: &DMatrix<f64>,
    ) -> Option<Self> {
        let stiffness = rolling_friction * normal_force * lever / ROLL_SLIP;
        if stiffness.is_nan() || stiffness <= 0.0 {
            return None;
        }
        let axes = tangents(normal);
        let turn_of = |a: &Vector3<f64>| {
            let m = a.cross_matrix() * anchor;
            let direction: DMatrix<f64> = DMatrix::from_iterator(
                3,
                mean_gradient.nrows(),
                (m * mean_gradient.transpose() * 0.5).iter().copied(),
            );
            (direction, 0.5 * m.trace())
        };
        let (d0, o0) = turn_of(&axes[0]);
        let (d1, o1) = turn_of(&axes[1]);
        Some(Self {
            directions: [d0, d1],
            offsets: [o0, o1],
            stiffness,
        })
    }

    /// d omega_a / dz for both tangent axes (3 x 4K each): the Hessian is k sum_a of their
    /// outer products.
    pub fn directions(&self) -> &[DMatrix<f64>; 2] {
        &self.directions
    }

    /// N m per radian.
    pub fn stiffness(&self) -> f64 {
        self.stiffness
    }

    /// Energy and its gradient (3 x 4K) at state `z`.
    pub fn energy_and_gradient(&self, z: &DMatrix<f64>) -> (f64, DMatrix<f64>) {
        let mut energy = 0.0;
        let mut gradient = DMatrix::zeros(z.nrows(), z.ncols());
        for (direction, offset) in self.directions.iter().zip(self.offsets) {
            let omega = direction.dot(z) + offset;
            energy += 0.5 * self.stiffness * omega * omega;
            gradient += direction * (self.stiffness * omega);
        }
        (energy, gradient)
    }

    /// Adds the energy's Hessian, k sum_a vec(D_a) vec(D_a)^T, to `hessian` (12K x 12K, z
    /// flattened column by column).
    pub fn add_curvature(&self, hessian: &mut DMatrix<f64>) {
        for direction in &self.directions {
            let d = direction.as_slice();
            for (j, dj) in d.iter().enumerate() {
                let s = self.stiffness * dj;
                if s == 0.0 {
                    continue;
                }
                let mut column = hessian.column_mut(j);
                for (i, di) in d.iter().enumerate() {
                    column[i] += s * di;
                }
            }
        }
    }
}

/// Anchor rotations of a body resting on static obstacles, kept from step to step while it
/// touches them (on moving obstacles the body is tied where it is at the step's start).
pub(crate) type RollAnchors = Ties<usize, Matrix3<f64>>;

impl RollAnchors {
    /// Where the body, now at mean rotation `rotation`, is tied on `obstacle` this step.
    pub fn tie(
        &mut self,
        obstacle: usize,
        on_static: bool,
        rotation: &Matrix3<f64>,
        normal: &Vector3<f64>,
        slip_angle: f64,
    ) -> Matrix3<f64> {
        self.tie_with(obstacle, on_static, |previous| match previous {
            Some(previous) => carried_rotation(previous, rotation, normal, slip_angle),
            None => *rotation,
        })
    }
}

/// The previous anchor, dragged along when the body has rolled farther than `slip_angle` from
/// it (the limit: beyond it the body rolls and the torque stays at its limit). Turning about
/// the normal is not resisted, so the anchor follows it.
fn carried_rotation(
    previous: &Matrix3<f64>,
    rotation: &Matrix3<f64>,
    normal: &Vector3<f64>,
    slip_angle: f64,
) -> Matrix3<f64> {
    let turn = Rotation3::from_matrix(&(rotation * previous.transpose())).scaled_axis();
    let rolled = turn - normal * normal.dot(&turn);
    let angle = rolled.norm();
    let kept = if angle > slip_angle {
        rolled * (slip_angle / angle)
    } else {
        rolled
    };
    // The anchor is the current rotation turned back by what stays resisted.
    Rotation3::from_scaled_axis(-kept).matrix() * rotation
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn the_turn_is_the_rotation_about_each_tangent() {
        // A subspace of one affine handle whose mean gradient is the identity part: z's first
        // 3 x 3 block is F - I.
        let g = DMatrix::from_fn(4, 3, |r, c| if r == c { 1.0 } else { 0.0 });
        let anchor = *Rotation3::from_scaled_axis(Vector3::new(0.3, -0.2, 0.5)).matrix();
        let n = Vector3::z();
        let stick = RollingStick::new(&anchor, &n, 10.0, 1e-3, 0.1, &g).unwrap();
        let axes = tangents(&n);
        let small = Vector3::new(1e-4, -2e-4, 3e-4);
        let f = Rotation3::from_scaled_axis(small).matrix() * anchor;
        let mut z = DMatrix::zeros(3, 4);
        z.view_mut((0, 0), (3, 3))
            .copy_from(&(f - Matrix3::identity()));
        for (direction, offset, axis) in turns(&stick, &axes) {
            let omega = direction.dot(&z) + offset;
            assert!((omega - axis.dot(&small)).abs() < 1e-7, "{omega}");
        }
    }

    fn turns<'a>(
        stick: &'a RollingStick,
        axes: &'a [Vector3<f64>; 2],
    ) -> impl Iterator<Item = (&'a DMatrix<f64>, f64, &'a Vector3<f64>)> {
        stick
            .directions
            .iter()
            .zip(stick.offsets)
            .zip(axes)
            .map(|((d, o), a)| (d, o, a))
    }

    #[test]
    fn gradient_and_curvature_match_finite_differences() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let g = DMatrix::from_fn(8, 3, |_, _| rng.random_range(-1.0..1.0));
        let anchor = *Rotation3::from_scaled_axis(Vector3::new(0.1, 0.4, -0.3)).matrix();
        let n = Vector3::new(0.2, 0.1, 1.0).normalize();
        let stick = RollingStick::new(&anchor, &n, 5.0, 2e-3, 0.05, &g).unwrap();
        let z = DMatrix::from_fn(3, 8, |_, _| rng.random_range(-0.1..0.1));
        let (_, gradient) = stick.energy_and_gradient(&z);
        let mut hessian = DMatrix::zeros(24, 24);
        stick.add_curvature(&mut hessian);
        let h = 1e-6;
        for i in 0..24 {
            let mut plus = z.clone();
            plus.as_mut_slice()[i] += h;
            let mut minus = z.clone();
            minus.as_mut_slice()[i] -= h;
            let (ep, gp) = stick.energy_and_gradient(&plus);
            let (em, gm) = stick.energy_and_gradient(&minus);
            let fd = (ep - em) / (2.0 * h);
            let scale = gradient.amax().max(1e-12);
            assert!((fd - gradient.as_slice()[i]).abs() < 1e-5 * scale);
            let column = (gp - gm) / (2.0 * h);
            for j in 0..24 {
                let exact = hessian[(j, i)];
                assert!((column.as_slice()[j] - exact).abs() < 1e-5 * hessian.amax());
            }
        }
    }

    #[test]
    fn an_anchor_is_dragged_only_past_the_slip_angle() {
        let n = Vector3::z();
        let previous = Matrix3::identity();
        let within = *Rotation3::from_scaled_axis(Vector3::new(0.005, 0.0, 0.0)).matrix();
        assert!((carried_rotation(&previous, &within, &n, 0.01) - previous).amax() < 1e-12);
        let past = *Rotation3::from_scaled_axis(Vector3::new(0.05, 0.0, 0.0)).matrix();
        let carried = carried_rotation(&previous, &past, &n, 0.01);
        let left = Rotation3::from_matrix(&(past * carried.transpose())).scaled_axis();
        assert!(
            (left - Vector3::new(0.01, 0.0, 0.0)).norm() < 1e-9,
            "{left}"
        );
        // A spin about the normal is followed, not resisted.
        let spun = *Rotation3::from_scaled_axis(Vector3::new(0.0, 0.0, 0.3)).matrix();
        let carried = carried_rotation(&previous, &spun, &n, 0.01);
        assert!((carried - spun).amax() < 1e-9);
    }
}
