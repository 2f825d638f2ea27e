//! Pins as exact constraints where they dominate. A pin's penalty spring is a pin only while
//! its stiffness dwarfs every force on it: a violent push drags penalty-pinned material by
//! centimetres, and a stiffness high enough to prevent that ruins the solver's conditioning.
//! The pin energy is quadratic in Z with matrix P = sum m phi phi^T; along each eigenvector u
//! of P whose spring is much stiffer than the body's own elasticity and inertia there, Z u is
//! held exactly at the spring's minimizer and the solvers only search the other directions.
//! Directions where the spring is comparable to the body (pinned points that the subspace
//! cannot hold still without locking the body) keep the penalty.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// A direction is held exactly in every step when its pin spring is this many times stiffer
/// than the body's rest elasticity and inertia along it. Such a spring already keeps the
/// direction within a small fraction of its motion; exact, it also holds against any force.
pub(super) const DOMINANT_PINS: f64 = 10.0;

/// Directions of P below this fraction of its largest eigenvalue move no pinned material (the
/// handles whose weights vanish on every pin): round-off, never held.
const NO_PIN: f64 = 1e-9;

/// The exactly held part of the pins: Z U = C for orthonormal U (4K x r).
#[derive(Clone, Debug)]
pub(super) struct PinConstraint {
    /// Orthonormal directions held exactly (4K x r).
    basis: DMatrix<f64>,
    /// The eigenvalues of P along `basis` (kg), for the held values.
    strengths: Vec<f64>,
    /// Where Z U is held (3 x r).
    values: DMatrix<f64>,
    /// `basis` (x) I_3 in flat z order (12K x 3r): the held directions of flat z.
    flat_basis: DMatrix<f64>,
}

impl PinConstraint {
    /// The directions of `pin_phi` (P) that move pinned material and whose spring,
    /// `stiffness` P, is at least `dominance` times the Rayleigh quotient of `body` (flat
    /// 12K x 12K: rest elasticity plus inertia) along them; None when there is none. A
    /// `dominance` of 0 holds every direction that moves pinned material.
    pub fn dominant(
        pin_phi: &DMatrix<f64>,
        stiffness: f64,
        body: &DMatrix<f64>,
        dominance: f64,
    ) -> Option<Self> {
        let eigen = SymmetricEigen::new(pin_phi.clone());
        let largest = eigen.eigenvalues.amax();
        let held: Vec<usize> = (0..eigen.eigenvalues.len())
            .filter(|&j| {
                let lambda = eigen.eigenvalues[j];
                let u = eigen.eigenvectors.column(j);
                lambda > NO_PIN * largest
                    && stiffness * lambda >= dominance * rayleigh_per_axis(body, u.as_slice())
            })
            .collect();
        if held.is_empty() {
            return None;
        }
        let basis = eigen.eigenvectors.select_columns(&held);
        let strengths = held.iter().map(|&j| eigen.eigenvalues[j]).collect();
        let r = held.len();
        let mut flat_basis = DMatrix::zeros(3 * basis.nrows(), 3 * r);
        for j in 0..r {
            for a in 0..basis.nrows() {
                for d in 0..3 {
                    flat_basis[(3 * a + d, 3 * j + d)] = basis[(a, j)];
                }
            }
        }
        Some(Self {
            basis,
            strengths,
            values: DMatrix::zeros(3, r),
            flat_basis,
        })
    }

    /// Holds Z U where the pin springs are at their minimum for the targets given by
    /// `pin_offset` (B = sum m (X - T) phi^T): C = -B U diag(lambda)^-1.
    pub fn hold_for(&mut self, pin_offset: &DMatrix<f64>) {
        self.values = -(pin_offset * &self.basis);
        for (j, strength) in self.strengths.iter().enumerate() {
            self.values.column_mut(j).unscale_mut(*strength);
        }
    }

    /// Moves `z` (3 x 4K) onto the constraint: Z + (C - Z U) U^T.
    pub fn place(&self, z: &mut DMatrix<f64>) {
        let off = &self.values - &*z * &self.basis;
        z.gemm(1.0, &off, &self.basis.transpose(), 1.0);
    }

    /// Removes from `gradient` (3 x 4K) its part along the held directions: G - G U U^T.
    pub fn free_part(&self, gradient: &mut DMatrix<f64>) {
        let along = &*gradient * &self.basis;
        gradient.gemm(-1.0, &along, &self.basis.transpose(), 1.0);
    }

    /// Removes from the flat z vector `u` its part along the held directions: the vector of a
    /// term u u^T that `restrict_hessian` would leave of it, (P u)(P u)^T.
    pub fn free_vector(&self, u: &mut DVector<f64>) {
        let along = self.flat_basis.transpose() * &*u;
        u.gemv(-1.0, &self.flat_basis, &along, 1.0);
    }

    /// The Hessian restricted to the free directions, with the held ones decoupled:
    /// P H P + s (I - P), P the projector on the free directions and s the mean diagonal (any
    /// s > 0 gives the same solution for a free right-hand side: zero along the held ones).
    pub fn restrict_hessian(&self, hessian: &mut DMatrix<f64>) {
        let n = hessian.nrows();
        let scale = hessian.trace() / n as f64;
        let w = &self.flat_basis;
        // With P = I - W W^T and Y = H W - W (W^T H W) / 2 - s W / 2,
        //   P H P + s (I - P) = H - W Y^T - Y W^T,
        // one update of rank 2 x 3r: in the poked creature's refreshes, the four products it
        // was written as took 0.13-0.16 ms, this 0.08-0.15 ms (printed).
        let mut y = &*hessian * w;
        let whw = w.transpose() * &y;
        y.gemm(-0.5, w, &whw, 1.0);
        y -= w * (0.5 * scale);
        let held = w.ncols();
        // [W Y] [Y W]^T.
        let mut left = w.clone().resize_horizontally(2 * held, 0.0);
        left.columns_mut(held, held).copy_from(&y);
        let mut right = y.resize_horizontally(2 * held, 0.0);
        right.columns_mut(held, held).copy_from(w);
        hessian.gemm(-1.0, &left, &right.transpose(), 1.0);
    }

    /// How many directions of the 4K are held exactly.
    #[cfg(test)]
    pub fn held_directions(&self) -> usize {
        self.basis.ncols()
    }
}

/// u^T H u averaged over the three axes, u (4K) taken as u (x) e_d in flat z order.
fn rayleigh_per_axis(h: &DMatrix<f64>, u: &[f64]) -> f64 {
    let mut sum = 0.0;
    for d in 0..3 {
        for (a, ua) in u.iter().enumerate() {
            for (b, ub) in u.iter().enumerate() {
                sum += ua * ub * h[(3 * a + d, 3 * b + d)];
            }
        }
    }
    sum / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restricted_newton_step_moves_only_the_free_directions_and_solves_there() {
        // A random SPD Hessian over 2 handles (24 unknowns) and one held direction.
        let n = 24;
        let a = DMatrix::from_fn(n, n, |i, j| ((i * 7 + j * 13) % 11) as f64 - 5.0);
        let hessian = &a * a.transpose() + DMatrix::identity(n, n) * 3.0;
        let mut pin_phi = DMatrix::zeros(8, 8);
        pin_phi[(2, 2)] = 1.0;
        let constraint =
            PinConstraint::dominant(&pin_phi, 1e9, &DMatrix::identity(n, n), DOMINANT_PINS)
                .expect("one held");
        assert_eq!(constraint.held_directions(), 1);
        let gradient = DMatrix::from_fn(3, 8, |d, a| (d + 2 * a) as f64 - 4.0);
        let mut free = gradient.clone();
        constraint.free_part(&mut free);
        let mut restricted = hessian.clone();
        constraint.restrict_hessian(&mut restricted);
        let rhs = -nalgebra::DVector::from_column_slice(free.as_slice());
        let step = restricted.clone().cholesky().expect("SPD").solve(&rhs);
        // Nothing along the held direction (column 2 of Z: flat 6, 7, 8).
        for i in 6..9 {
            assert!(
                step[i].abs() < 1e-12,
                "held unknown {i} moved by {}",
                step[i]
            );
        }
        // The free block solved exactly: (H step + g) vanishes off the held unknowns.
        let residual = &hessian * &step - &rhs;
        for i in (0..n).filter(|i| !(6..9).contains(i)) {
            assert!(
                residual[i].abs() < 1e-9 * rhs.norm(),
                "row {i}: {}",
                residual[i]
            );
        }
    }

    /// The rank-2 x 3r update equals P H P + s (I - P) written out with the projector.
    #[test]
    fn restriction_equals_the_projector_written_out() {
        let n = 24;
        let a = DMatrix::from_fn(n, n, |i, j| ((i * 5 + j * 3) % 7) as f64 - 3.0);
        let hessian = &a * a.transpose() + DMatrix::identity(n, n);
        let mut pin_phi = DMatrix::zeros(8, 8);
        pin_phi[(1, 1)] = 1.0;
        pin_phi[(2, 2)] = 2.0;
        pin_phi[(1, 2)] = 0.5;
        pin_phi[(2, 1)] = 0.5;
        let constraint =
            PinConstraint::dominant(&pin_phi, 1e9, &DMatrix::identity(n, n), DOMINANT_PINS)
                .expect("held");
        assert_eq!(constraint.held_directions(), 2);
        let w = &constraint.flat_basis;
        let p = DMatrix::identity(n, n) - w * w.transpose();
        let scale = hessian.trace() / n as f64;
        let expected = &p * &hessian * &p + (DMatrix::identity(n, n) - &p) * scale;
        let mut restricted = hessian.clone();
        constraint.restrict_hessian(&mut restricted);
        let error = (&restricted - &expected).norm() / expected.norm();
        assert!(error < 1e-13, "relative difference {error:e}");
    }

    #[test]
    fn placing_holds_the_spring_minimum() {
        let mut pin_phi = DMatrix::zeros(4, 4);
        pin_phi[(3, 3)] = 2.0;
        let mut constraint =
            PinConstraint::dominant(&pin_phi, 1e9, &DMatrix::identity(12, 12), DOMINANT_PINS)
                .expect("held");
        // B = -m T phi^T for a point of mass 2 with phi = e_3, target offset (1, 2, 3).
        let mut offset = DMatrix::zeros(3, 4);
        offset.set_column(3, &(nalgebra::Vector3::new(1.0, 2.0, 3.0) * -2.0));
        constraint.hold_for(&offset);
        let mut z = DMatrix::from_element(3, 4, 0.5);
        constraint.place(&mut z);
        assert_eq!(z.column(3).as_slice(), &[1.0, 2.0, 3.0]);
        assert_eq!(z.column(0).as_slice(), &[0.5, 0.5, 0.5]);
    }
}
