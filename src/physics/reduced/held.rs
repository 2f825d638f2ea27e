//! The quasi-Newton solver's held matrix: the Hessian it keeps factored between steps, turned
//! with the body and updated with contact, and the L-BFGS direction preconditioned by it.

use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector, Matrix3};
use rayon::prelude::*;

use super::contact::ContactSignature;
use super::turned::TurnedHessian;
use super::{add_kron_identity, ReducedSim, REFRESH_AFTER_ITERATIONS, REFRESH_GRACE};
use crate::linalg::DenseCholesky;

/// A turn of the body (largest entry of the rotation's change) past which the preconditioner
/// is turned with it.
const TURN_TOLERANCE: f64 = 1e-3;
/// A turn of a region within a slow solve (largest entry of its rotation's change) past which
/// the held Hessian is renewed by turning its shares rather than assembled again. A body
/// landing bends without turning: its slow solves need the Hessian assembled, and turning it
/// first cost the demo two steps of more than their budget.
const RENEW_BY_TURNING: f64 = 1e-2;
/// New contact springs, as a share of those the preconditioner holds, past which a solve
/// refactors it with those acting.
const CONTACT_GAIN: f64 = 0.5;

impl ReducedSim {
    /// Refactors the preconditioner for the state `z` when a region of the body has turned or
    /// the contact springs acting (the pairs in touch, friction) differ from those it was
    /// factored with. Elasticity is invariant under rotation, so a region that turns as a rigid
    /// piece turns its share of the held Hessian by the same rotation: the turned shares follow
    /// a tumbling, swinging or bending body without reassembling the Hessian (see
    /// [`TurnedHessian`]). Contact curvature changes from one step to the next and is added
    /// exactly. Both cost a few small products and one 12K x 12K factorization, a fraction of
    /// the elastic Hessian's assembly. A body resting on the same points keeps its factor: the
    /// curvature changes only with which springs act.
    pub(super) fn hold_at(&mut self, z: &DMatrix<f64>) {
        let signature = self.contact_signature(z);
        self.held_matrix();
        let rotations = self.subspace.region_rotations(z);
        let turned = TurnedHessian::moved(&self.factored_rotations, &rotations, TURN_TOLERANCE);
        if self.factored_contact.as_ref() == Some(&signature) && !turned {
            return;
        }
        let held = self.held.as_ref().expect("made above");
        let quadratic = self.quadratic_part();
        let contact = self.contact_curvature(z);
        let with_rest = |mut matrix: DMatrix<f64>| {
            add_kron_identity(&mut matrix, &quadratic);
            if let Some(contact) = contact.as_ref() {
                matrix += contact;
            }
            matrix
        };
        // Shares held at a strained state may turn apart into an indefinite sum: then the
        // unturned one, definite as it was checked, is factored instead.
        let factor = self
            .try_factor(with_rest(held.turned(&rotations)))
            .unwrap_or_else(|| self.factor_hessian(with_rest(held.unturned().clone())));
        self.factored_contact = Some(signature);
        self.factored_rotations = rotations;
        self.preconditioner = Some(factor);
        self.factorizations += 1;
    }

    /// Renews the held Hessian within a slow solve, which shows it no longer describes the
    /// state: first its regions' shares are turned to where they are at `z` (a swinging,
    /// bending body: a few tenths of a millisecond); if that was done already since the last
    /// assembly (`turned_already`), or nothing turned, it is assembled again at `z` and held
    /// from now on. Returns whether it was assembled.
    pub(super) fn renew_held(&mut self, z: &DMatrix<f64>, turned_already: bool) -> bool {
        if !turned_already && self.regions_turned(z) {
            self.hold_at(z);
            return false;
        }
        let old = self.held.take();
        let held = self.held_elastic_at(z, old);
        self.hold_new(held, z);
        true
    }

    /// Whether a region has turned at `z`, since the preconditioner was factored, by more
    /// than `RENEW_BY_TURNING` (an entry of its rotation).
    pub(super) fn regions_turned(&self, z: &DMatrix<f64>) -> bool {
        let rotations = self.subspace.region_rotations(z);
        TurnedHessian::moved(&self.factored_rotations, &rotations, RENEW_BY_TURNING)
    }

    /// Whether the contact springs acting (`touching`) include more that the preconditioner
    /// lacks than half as many as it holds (and at least two): a body landing gains a hundred
    /// stiff springs within one step, and L-BFGS over a factor without them needs many
    /// iterations to find their curvature. Springs lost, and the few that come and go as a
    /// body settles into a soft one, are left to the next step: refactoring for them cost the
    /// ball on the soft slab more than it saved (p99 21.5 ms against 14.7 ms, printed).
    pub(super) fn contacts_gained(&self, touching: &[(usize, usize)]) -> bool {
        let Some(factored) = self.factored_contact.as_ref() else {
            return false;
        };
        // Both lists follow the sorted broad phase: a binary search, where a hash set of the
        // held pairs cost an allocation and a hash per pair in every iteration.
        let held = &factored.touching;
        debug_assert!(held.windows(2).all(|w| w[0] < w[1]), "held pairs sorted");
        let gained = touching
            .iter()
            .filter(|pair| held.binary_search(pair).is_err())
            .count();
        gained >= 2 && gained as f64 > CONTACT_GAIN * held.len() as f64
    }

    /// The quasi-Newton initial Hessian, factored: the held elastic Hessian (at rest the
    /// rest-state one; after a hard step, the one at that state, held for the steps that
    /// follow until another hard step) plus inertia, damping and the pins as they are now.
    pub(super) fn build_preconditioner(&mut self) -> DenseCholesky {
        let held = self.held_matrix();
        let mut matrix = held.unturned().clone();
        self.factored_rotations = held.assembled_at().to_vec();
        add_kron_identity(&mut matrix, &self.quadratic_part());
        self.factored_contact = Some(ContactSignature::default());
        self.factorizations += 1;
        self.factor_hessian(matrix)
    }

    /// Holds `matrix`, the elastic Hessian at `z`, and factors it with inertia, damping, pins
    /// and the contact curvature at `z`.
    pub(super) fn hold_new(&mut self, held: TurnedHessian, z: &DMatrix<f64>) {
        self.held = Some(held);
        // The factor in place belongs to the old matrix: `hold_at` refactors whatever touches.
        self.factored_contact = None;
        self.factored_rotations.clear();
        self.hold_at(z);
    }

    /// The held elastic Hessian, made on first use: at rest the rest-state one, otherwise the
    /// one at the current state. Inertia, damping and pins are added when it is factored, so
    /// that pins added or stiffened later count at once and cost no reassembly.
    pub(super) fn held_matrix(&mut self) -> &TurnedHessian {
        if self.held.is_none() {
            let held = if self.z.amax() == 0.0 {
                let rest = self.material.stress_derivative(&Matrix3::identity(), true);
                let shares = self
                    .subspace
                    .region_hessians(&vec![rest; self.subspace.cubature_len()]);
                TurnedHessian::new(&shares, self.subspace.region_rotations(&self.z), None)
            } else {
                self.held_elastic_at(&self.z, None)
            };
            self.held = Some(held);
        }
        self.held.as_ref().expect("made above")
    }

    /// The elastic Hessian at `z` to hold, as its regions' shares: exact where inertia,
    /// damping and the pins at their own stiffness make it definite (on the directions the pins
    /// leave free), else PSD-projected. Stiffening the pins for a step keeps it definite;
    /// releasing pins drops it. `reuse` lends its storage (see `TurnedHessian::new`).
    pub(super) fn held_elastic_at(
        &self,
        z: &DMatrix<f64>,
        reuse: Option<TurnedHessian>,
    ) -> TurnedHessian {
        let base = self.inertia_part() + &self.pin_phi * self.params.pin_stiffness;
        let gradients = self.subspace.deformation_gradients(z);
        let rotations = self.subspace.region_rotations(z);
        let shares_of = |project: bool, reuse: Option<TurnedHessian>| {
            let hessians: Vec<_> = gradients
                .par_iter()
                .map(|f| self.material.stress_derivative(f, project))
                .collect();
            let shares = self.subspace.region_hessians(&hessians);
            TurnedHessian::new(&shares, rotations.clone(), reuse)
        };
        let exact = shares_of(false, reuse);
        if self.factorable(exact.unturned(), &base, true) {
            return exact;
        }
        shares_of(true, Some(exact))
    }

    /// The Cholesky factor of `matrix` as the preconditioner is factored (see
    /// `factor_hessian`), or None where it is not positive definite.
    fn try_factor(&self, mut matrix: DMatrix<f64>) -> Option<DenseCholesky> {
        for i in 0..matrix.nrows() {
            matrix[(i, i)] += 1e-12 * matrix[(i, i)].abs().max(1e-300);
        }
        if let Some(pinning) = self.pinning.as_ref() {
            pinning.restrict_hessian(&mut matrix);
        }
        DenseCholesky::new(matrix.as_slice(), matrix.nrows()).ok()
    }

    pub(super) fn factor_hessian(&self, mut matrix: DMatrix<f64>) -> DenseCholesky {
        // Inertia makes it positive definite; the tiny ridge only guards round-off. It goes
        // on before the pins' restriction, which must leave the held directions uncoupled.
        for i in 0..matrix.nrows() {
            matrix[(i, i)] += 1e-12 * matrix[(i, i)].abs().max(1e-300);
        }
        if let Some(pinning) = self.pinning.as_ref() {
            pinning.restrict_hessian(&mut matrix);
        }
        DenseCholesky::new(matrix.as_slice(), matrix.nrows())
            .expect("inertia plus a PSD Hessian is positive definite")
    }

    /// The L-BFGS two-loop recursion with the factored rest Hessian as initial inverse.
    pub(super) fn lbfgs_direction(
        &self,
        gradient: &DVector<f64>,
        history: &VecDeque<(DVector<f64>, DVector<f64>)>,
    ) -> DVector<f64> {
        let mut q = -gradient.clone();
        let mut alphas = Vec::with_capacity(history.len());
        for (s, y) in history.iter().rev() {
            let rho = 1.0 / y.dot(s);
            let alpha = rho * s.dot(&q);
            q.axpy(-alpha, y, 1.0);
            alphas.push((alpha, rho));
        }
        self.preconditioner
            .as_ref()
            .expect("built before the first step")
            .solve(q.as_mut_slice());
        for ((s, y), (alpha, rho)) in history.iter().zip(alphas.into_iter().rev()) {
            let beta = rho * y.dot(&q);
            q.axpy(alpha - beta, s, 1.0);
        }
        q
    }
}

/// Whether a quasi-Newton solve `since` iterations after its last refresh should refresh the
/// held Hessian now: after `REFRESH_AFTER_ITERATIONS`, unless its decrements (one per
/// iteration since the refresh) fall fast enough to reach `tolerance` within `REFRESH_GRACE`
/// more; after the grace in any case. A poked rod's steps reached the refresh with the
/// decrement a few times above the tolerance and falling tenfold an iteration: the refresh
/// (an assembly, 1.1-1.5 ms) cost more than the one or two iterations it saved.
pub(super) fn refresh_due(since: usize, decrements: &[f64], tolerance: f64) -> bool {
    if since == REFRESH_AFTER_ITERATIONS + REFRESH_GRACE {
        return true;
    }
    since == REFRESH_AFTER_ITERATIONS && !converging_within(decrements, tolerance, REFRESH_GRACE)
}

/// Whether the decrements, falling at their rate over the last two iterations, reach
/// `tolerance` within `iterations` more.
fn converging_within(decrements: &[f64], tolerance: f64, iterations: usize) -> bool {
    let [.., older, _, last] = decrements else {
        return false;
    };
    let rate = (last / older).sqrt();
    rate < 1.0 && last * rate.powi(iterations as i32) < tolerance
}
