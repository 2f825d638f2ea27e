//! The quasi-Newton solver's held matrix: the Hessian it keeps factored between steps, turned
//! with the body and updated with contact, and the L-BFGS direction preconditioned by it.

use std::collections::VecDeque;

use nalgebra::{DMatrix, DVector, Matrix3};

use super::contact::ContactSignature;
use super::factor::{HeldFactor, SpringTerm};
use super::hessian::{CheckedHessian, HessianUse};
use super::{
    add_kron_identity, Evaluation, ReducedSim, Solver, StepReport, REFRESH_AFTER_ITERATIONS,
    REFRESH_GRACE,
};
use crate::linalg::DenseCholesky;
use crate::physics::{helper, Penetration};

/// A turn of the body (largest entry of the rotation's change) past which the preconditioner
/// is turned with it.
const TURN_TOLERANCE: f64 = 1e-3;
/// Contact springs gained or lost, as a share of those the preconditioner holds, past which a
/// solve refactors it with those acting.
const CONTACT_CHANGE: f64 = 0.5;
/// Iterations of a converged step past which its held Hessian is refreshed for the next one
/// (see `ReducedSim::refresh_ahead`).
const REFRESH_AHEAD_ITERATIONS: usize = 7;
/// Iterations within which a solve whose budget ran out must be set to converge to go on
/// without a refresh (see `nearly_done`).
const EXTENSION_GRACE: usize = 4;
/// Iterations more than a fresh held Hessian's first step took that show it stale.
const STALE_ITERATIONS: usize = 3;

impl ReducedSim {
    /// Refactors the preconditioner for the state `z` when the body has turned or the contact
    /// springs acting (the pairs in touch, friction) differ from those it was factored with.
    /// Elasticity is invariant under a rotation of the whole body, so the held elastic Hessian
    /// turned by that rotation is the Hessian of the turned state: a tumbling body keeps an
    /// accurate preconditioner without reassembling it. Contact curvature changes from one step
    /// to the next and is added exactly. Where the factor in place holds the held matrix, a
    /// change of a few springs and a turn are low-rank updates of it (`HeldFactor`);
    /// otherwise they cost a few small products and one 12K x 12K factorization, a fraction of
    /// the elastic Hessian's assembly. Without them, a falling or landing body costs many
    /// iterations and a refresh of the whole Hessian. A body resting on
    /// the same points keeps its factor: the curvature changes only with which springs act. A
    /// body that turned on the same springs (a block spinning on a frictionless floor turns past
    /// the tolerance every other step) reuses the contact curvature held with them: that took a
    /// small body's median step from 0.040 to 0.030 ms (printed). Returns whether it refactored.
    pub(super) fn hold_at(&mut self, z: &DMatrix<f64>) -> bool {
        self.hold_with(z, false)
    }

    /// `hold_at` for a step's start `z`, where springs held that no longer act are left in the
    /// factor while the rest hold. A body bouncing on its springs after a landing starts each
    /// step lifted (a dropped plate: 33 of its 230 springs acting at the start) and is back on
    /// all of them after one iteration: refactored for the start, each such step refactored
    /// twice, 1.19-1.25 ms for two iterations (printed). Where they are lost for good, the
    /// solve's own check (`springs_changed`) refactors after its first iteration.
    pub(super) fn hold_for_step(&mut self, z: &DMatrix<f64>) -> bool {
        self.hold_with(z, true)
    }

    /// `hold_at`, leaving springs lost in the factor where `keep_lost`.
    fn hold_with(&mut self, z: &DMatrix<f64>, keep_lost: bool) -> bool {
        let touching = self.touching_at(z);
        let signature = self.contact_signature(&touching);
        self.held_matrix();
        // A pinned body does not turn as a whole: its mean rotation is bending, which turning
        // the held matrix would misdescribe.
        let turn = if self.pins.is_empty() {
            self.subspace.mean_rotation(z) * self.held_rotation.transpose()
        } else {
            Matrix3::identity()
        };
        let turned = (turn - self.factored_turn).amax() > TURN_TOLERANCE;
        let held = self.factored_contact.as_ref();
        let unchanged = held == Some(&signature)
            || (keep_lost && held.is_some_and(|held| only_lost(held, &signature)));
        if unchanged && !turned {
            return false;
        }
        let turn = if turned { turn } else { self.factored_turn };
        if self.factored_contact.is_some() && self.update_factor(&touching, &turn) {
            self.factored_contact = Some(signature);
            self.factored_turn = turn;
            return true;
        }
        let held = self.held.as_ref().expect("made above");
        let quadratic = self.quadratic_part();
        let known = self
            .held_contact
            .as_ref()
            .is_some_and(|(held, _)| *held == signature);
        // New springs' curvature is formed on the helper thread while this one turns the held
        // matrix: two passes of similar cost, four or five times in a landing step.
        let (mut matrix, curvature) = if known {
            (held_lower(held, &turn, &quadratic), None)
        } else {
            helper::join(
                || held_lower(held, &turn, &quadratic),
                || self.curvature_of(&touching),
            )
        };
        if !known {
            self.held_contact = Some((signature.clone(), curvature));
        }
        if let Some((_, Some(contact))) = self.held_contact.as_ref() {
            add_lower(&mut matrix, contact);
        }
        self.factored_contact = Some(signature);
        self.factored_turn = turn;
        let terms = self.spring_terms(&touching);
        let factor = self.factor_hessian(matrix);
        self.preconditioner = Some(HeldFactor::new(factor, turn, terms));
        self.factorizations += 1;
        true
    }

    /// Brings the factor in place to the springs of `touching` and this step's friction at the
    /// turn `turn` by low-rank updates (see `HeldFactor`); false when it must be made anew.
    fn update_factor(
        &mut self,
        touching: &[(usize, usize, Penetration)],
        turn: &Matrix3<f64>,
    ) -> bool {
        let terms = self.spring_terms(touching);
        let Some(mut factor) = self.preconditioner.take() else {
            return false;
        };
        let vector = |term: &SpringTerm, r: &Matrix3<f64>| self.term_vector(term, r);
        match factor.update_to(terms, turn, vector) {
            Some(_) => {
                self.preconditioner = Some(factor);
                self.factor_updates += 1;
                true
            }
            None => false,
        }
    }

    /// Whether the contact springs acting (`touching`) differ from those the preconditioner
    /// holds by more than half as many as it holds (and at least two), gained or lost. A body
    /// landing gains a hundred stiff springs within one step, and L-BFGS over a factor without
    /// them needs many iterations to find their curvature. A factor holding springs that no
    /// longer act gives directions far too short: a plate pushed off the floor within its step
    /// crept back over several iterations, and its drop's p99 step took 1.811-1.977 ms against
    /// 1.423-1.466 ms with lost springs counted (printed). The few that come and go as a body
    /// settles into a soft one are left to the next step: refactoring for them cost the ball
    /// on the soft slab more than it saved (p99 21.5 ms against 14.7 ms, printed).
    pub(super) fn springs_changed(&self, touching: &[(usize, usize)]) -> bool {
        self.factored_contact
            .as_ref()
            .is_some_and(|factored| changed_past_share(&factored.touching, touching))
    }

    /// The quasi-Newton initial Hessian, factored: the held elastic Hessian (at rest the
    /// rest-state one; after a hard step, the one at that state, held for the steps that
    /// follow until another hard step) plus inertia, damping and the pins as they are now.
    pub(super) fn build_preconditioner(&mut self) -> HeldFactor {
        let mut matrix = self.held_matrix().clone();
        add_kron_identity(&mut matrix, &self.quadratic_part());
        self.factored_contact = Some(ContactSignature::default());
        self.factored_turn = Matrix3::identity();
        self.factorizations += 1;
        HeldFactor::new(self.factor_hessian(matrix), Matrix3::identity(), Vec::new())
    }

    /// Holds `elastic`, the elastic Hessian at `z`, and factors it with inertia, damping, pins
    /// and the contact curvature at `z`. Where nothing touches and the pins are at their own
    /// stiffness, that is the factor formed when it was checked: a second factorization of the
    /// same matrix cost 0.12 ms of a refreshing step (printed).
    pub(super) fn hold_new(&mut self, elastic: CheckedHessian, z: &DMatrix<f64>) {
        self.held = Some(elastic.matrix);
        self.held_rotation = self.subspace.mean_rotation(z);
        // The factor in place belongs to the old matrix: `hold_at` refactors whatever touches.
        self.factored_contact = None;
        self.factored_turn = Matrix3::identity();
        if let (Some(factor), true) = (elastic.factor, self.pin_boost == 1.0) {
            let signature = self.contact_signature(&self.touching_at(z));
            if signature == ContactSignature::default() {
                self.preconditioner =
                    Some(HeldFactor::new(factor, Matrix3::identity(), Vec::new()));
                self.factored_contact = Some(signature);
                self.factorizations += 1;
                return;
            }
        }
        self.hold_at(z);
    }

    /// The held matrix, made on first use: the elastic Hessian, at rest the rest-state one,
    /// otherwise the one at the current state. Inertia, damping and pins are added when it is
    /// factored, so that pins added or stiffened later count at once and cost no reassembly.
    pub(super) fn held_matrix(&mut self) -> &DMatrix<f64> {
        if self.held.is_none() {
            let matrix = if self.z.amax() == 0.0 {
                (*self.rest_elastic_hessian()).clone()
            } else {
                self.held_elastic_at(&self.z, HessianUse::Preconditioner)
                    .matrix
            };
            self.held_rotation = self.subspace.mean_rotation(&self.z);
            self.held = Some(matrix);
        }
        self.held.as_ref().expect("made above")
    }

    /// The elastic Hessian at `z` to hold, summed as `usage` says (a preconditioner's or a
    /// refresh's): exact where inertia, damping and the pins at their own stiffness make it
    /// definite. Stiffening the pins for a step keeps it definite; releasing pins drops it.
    pub(super) fn held_elastic_at(&self, z: &DMatrix<f64>, usage: HessianUse) -> CheckedHessian {
        let base = self.inertia_part() + &self.pin_phi * self.params.pin_stiffness;
        self.smooth_elastic_at(z, &base, usage)
    }

    /// Factors `matrix`, of which only the lower triangle need be given.
    pub(super) fn factor_hessian(&self, mut matrix: DMatrix<f64>) -> DenseCholesky {
        // Inertia makes it positive definite; the tiny ridge only guards round-off. It goes
        // on before the pins' restriction, which must leave the held directions uncoupled.
        for i in 0..matrix.nrows() {
            matrix[(i, i)] += 1e-12 * matrix[(i, i)].abs().max(1e-300);
        }
        if let Some(pinning) = self.pinning.as_ref() {
            // The restriction is a product with the whole matrix.
            matrix.fill_upper_triangle_with_lower_triangle();
            pinning.restrict_hessian(&mut matrix);
        }
        let n = matrix.nrows();
        DenseCholesky::in_place(matrix.data.into(), n)
            .expect("inertia plus a PSD Hessian is positive definite")
    }

    /// Renews the held matrix where a solve at `z` (evaluated in `at`) progresses slowly: it
    /// no longer describes the state. Where the contact springs acting differ from those it
    /// was factored with (a landing's come and go within its step), or the body has turned, it
    /// is factored again as it is now: one small factorization, where a new elastic Hessian
    /// costs an assembly over the cubature points. A scanned rod's landing took 8.5 to 10.1 ms
    /// with three elastic refreshes in its step; with its springs refactored first, no step of
    /// its drop took over 2.9 ms (printed): its springs had changed, its elastic Hessian
    /// hardly had. Otherwise a new elastic Hessian is held from now on, and the curvature
    /// `history` measured against the old one, which would pull it back, is dropped. It
    /// outlives a refactor for springs: it holds the elasticity's curvature the factor still
    /// lacks. Dropped there too, the creature's landing steps slowed after it (step lengths of
    /// a half and a quarter) and ran into their budget: slowest step 5.764 ms, 23 iterations
    /// and two elastic refreshes in its drop, against 2.383 ms, 17 and none with it kept
    /// (printed, FEM left out).
    pub(super) fn refresh_held(
        &mut self,
        z: &DMatrix<f64>,
        at: &Evaluation,
        report: &mut StepReport,
        history: &mut VecDeque<(DVector<f64>, DVector<f64>)>,
    ) {
        if !self.hold_at(z) {
            self.hold_new(self.held_elastic_at(z, refresh_use(at)), z);
            report.refreshes += 1;
            history.clear();
        }
    }

    /// Keeps count of how a held Hessian fares, and asks the next step to refresh it where the
    /// step that `report`s ending in `end` shows it stale (see `refresh_ahead`). `ahead`: the
    /// refreshes this step made before its solve, which start a fresh Hessian's count.
    pub(super) fn refresh_if_stale(&mut self, end: &Evaluation, report: &StepReport, ahead: usize) {
        if report.refreshes > ahead || report.fallback {
            self.fresh_iterations = None;
        } else if self.refresh_ahead(report, end) {
            self.refresh_due = true;
            self.fresh_iterations = None;
        } else {
            self.fresh_iterations.get_or_insert(report.iterations);
        }
    }

    /// The refresh a slow step asked for, made by `prepare` between the steps or at the start
    /// of the next one, at the state the next step starts from (constant velocity, placed on
    /// the pins), paid by a step whose solve it makes short (or, made between the steps, by
    /// none). The Hessian of a swinging body changes within a step: made at the state the slow
    /// step ended in instead, the poked creature took 10.1 iterations a step against 8.6, the
    /// poked plate 7.1 against 5.6, the poked rod 8.6 against 8.1 and the hanging rows 3.3,
    /// 4.2 and 4.3 against 3.0, 4.1 and 4.0 (plate, rod, creature; `bench sim` at 16 handles
    /// and 1024 points, FEM left out, printed). Made at the end of the slow step, that step
    /// paid both: the pinned rod's hanging took 1.65-2.09 ms in its refreshing steps, 7
    /// iterations and a refresh; ahead of the next, 1.34-2.18 ms, 3 or 4 iterations and a
    /// refresh. Over alternating runs (FEM left out, 2 cores; printed) the p99 step of `bench
    /// sim`'s hanging rows went from
    /// 2.534 to 2.323 ms on average for the rod (8 runs each), 2.489 to 2.039 ms for the plate
    /// (6), 3.439 to 3.135 ms for the creature (4); the rod's poke, 3.715 and 3.831 ms (6), and
    /// the medians stayed within the runs' spread. Returns the refreshes made (0 or 1).
    pub(super) fn refresh_if_due(&mut self) -> usize {
        if !std::mem::take(&mut self.refresh_due) {
            return 0;
        }
        if self.pinning_stale {
            self.update_pinning();
        }
        let z = self.placed_on_pins(&self.predicted());
        self.hold_new(self.held_elastic_at(&z, HessianUse::Refresh), &z);
        self.history.clear();
        1
    }

    /// Whether a quasi-Newton step that `report`s ending in `end` should refresh its held
    /// elastic Hessian before the next step: one that converged without a refresh, with nothing
    /// touching, in `REFRESH_AHEAD_ITERATIONS` or more, `STALE_ITERATIONS` more than the first
    /// step over the held Hessian took. A bending or swinging body's held Hessian goes stale
    /// step by step: a pinned rod's steps took 4, 5, 6, 7, 9 iterations, and the next one 11
    /// with a refresh within it (2.5 ms, printed). Refreshed ahead of the next step instead
    /// (`refresh_if_due`), no step pays both a stale solve's iterations and the refresh. Where
    /// a fresh Hessian is no faster (a poked rod's steps took 7 to 9 iterations after a refresh too),
    /// refreshing ahead only cost time: its median step went from 0.584 to 1.401 ms (printed).
    /// In contact, iterations come from springs coming and going, not from a stale Hessian.
    fn refresh_ahead(&self, report: &StepReport, end: &Evaluation) -> bool {
        self.solver == Solver::QuasiNewton
            && report.converged
            && report.iterations >= REFRESH_AHEAD_ITERATIONS
            && end.touching.is_empty()
            && self
                .fresh_iterations
                .is_some_and(|fresh| report.iterations >= fresh + STALE_ITERATIONS)
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

/// Whether a solve whose budget has run out, its decrements (one per iteration since the last
/// refresh) falling fast enough to reach `tolerance` within `EXTENSION_GRACE` iterations, goes
/// on over the matrix it holds: a refresh there buys one or two iterations. The poked
/// creature's slowest steps had refreshed at iteration 11, ran out at 20 and refreshed again
/// for their last two iterations; going on instead took its slowest step from 8.138 to
/// 4.731-5.512 ms (printed, FEM left out). A solve not nearly done is refreshed: the violent
/// poke on `bench stress`'s soft box needs it to converge.
pub(super) fn nearly_done(decrements: &[f64], tolerance: f64) -> bool {
    converging_within(decrements, tolerance, EXTENSION_GRACE)
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

/// Whether the springs of `now` are those `held` less some pairs in touch.
fn only_lost(held: &ContactSignature, now: &ContactSignature) -> bool {
    held.sticks == now.sticks
        && held.rolls == now.rolls
        && now
            .touching
            .iter()
            .all(|pair| held.touching.binary_search(pair).is_ok())
}

/// Whether the pairs in `touching` gained or lost against those `held` (both sorted, as the
/// broad phase lists them) number at least two and more than `CONTACT_CHANGE` of those held.
fn changed_past_share(held: &[(usize, usize)], touching: &[(usize, usize)]) -> bool {
    // A binary search, where a hash set of the held pairs cost an allocation and a hash per
    // pair in every iteration.
    debug_assert!(held.windows(2).all(|w| w[0] < w[1]), "held pairs sorted");
    let gained = touching
        .iter()
        .filter(|pair| held.binary_search(pair).is_err())
        .count();
    // Held pairs not in touch: those held, less those of `touching` held too.
    let lost = held.len() - (touching.len() - gained);
    let past = |changed: usize| changed >= 2 && changed as f64 > CONTACT_CHANGE * held.len() as f64;
    past(gained) || past(lost)
}

/// The lower block triangle (blocks (a, b), a >= b: what a factor reads) of
/// (I (x) R) H (I (x) R^T) + Q (x) I in flat z order, the held elastic Hessian H turned by R
/// and the quadratic part Q added, in one pass; the blocks above are left zero. A clone turned
/// as a whole, then Q added in a second pass, took 61-123 us of each of a landing's four or
/// five refactors (printed).
pub(super) fn held_lower(h: &DMatrix<f64>, r: &Matrix3<f64>, q: &DMatrix<f64>) -> DMatrix<f64> {
    let blocks = h.nrows() / 3;
    let turned = *r != Matrix3::identity();
    let mut out = DMatrix::zeros(h.nrows(), h.ncols());
    for b in 0..blocks {
        for a in b..blocks {
            let mut block: Matrix3<f64> = h.fixed_view::<3, 3>(3 * a, 3 * b).into_owned();
            if turned {
                block = r * block * r.transpose();
            }
            for d in 0..3 {
                block[(d, d)] += q[(a, b)];
            }
            out.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(&block);
        }
    }
    out
}

/// Adds the lower triangle of `addend` to that of `matrix` (both square, of one size).
fn add_lower(matrix: &mut DMatrix<f64>, addend: &DMatrix<f64>) {
    let n = matrix.nrows();
    for c in 0..n {
        let column = &mut matrix.as_mut_slice()[c * n + c..(c + 1) * n];
        let added = &addend.as_slice()[c * n + c..(c + 1) * n];
        column.iter_mut().zip(added).for_each(|(m, a)| *m += a);
    }
}

/// (I (x) R) H (I (x) R^T) in flat z order: every 3 x 3 block of H turned by R.
#[cfg(test)]
pub(super) fn turn_blocks(h: &DMatrix<f64>, r: &Matrix3<f64>) -> DMatrix<f64> {
    let blocks = h.nrows() / 3;
    let mut out = DMatrix::zeros(h.nrows(), h.ncols());
    for b in 0..blocks {
        for a in 0..blocks {
            let block: Matrix3<f64> = h.fixed_view::<3, 3>(3 * a, 3 * b).into_owned();
            out.fixed_view_mut::<3, 3>(3 * a, 3 * b)
                .copy_from(&(r * block * r.transpose()));
        }
    }
    out
}

/// How a held elastic Hessian reassembled within a step at the state evaluated in `at` is
/// summed: on the coarser cubature while nothing touches (a bending or swinging body), on every
/// point in contact. Coarse, a pinned rod's slowest steps (`bench real`, scanned, hanging) took
/// 1.829 and 1.927 ms against 2.679 and 2.742 ms (printed); in contact, the scanned rod's
/// landing took 9.586 ms coarse against 7.249 ms on every point (printed): where the springs
/// hold the stiff directions, the soft ones left to elasticity need its Hessian's digits.
fn refresh_use(at: &Evaluation) -> HessianUse {
    if at.touching.is_empty() {
        HessianUse::Refresh
    } else {
        HessianUse::Preconditioner
    }
}

#[cfg(test)]
mod tests {
    use super::{changed_past_share, nearly_done, EXTENSION_GRACE};

    /// A solve whose decrements fall tenfold an iteration, 10^EXTENSION_GRACE above the
    /// tolerance less a little, goes on without a refresh; one a little further off, or one
    /// falling slowly, or with too few decrements to tell, does not.
    #[test]
    fn nearly_done_when_the_decrements_reach_the_tolerance_within_the_grace() {
        let tolerance = 1e-4;
        let falling = |last: f64| [last * 100.0, last * 10.0, last];
        let within = tolerance * 10f64.powi(EXTENSION_GRACE as i32) * 0.9;
        assert!(nearly_done(&falling(within), tolerance));
        assert!(!nearly_done(&falling(within * 1.2), tolerance));
        assert!(!nearly_done(&[1e-3, 0.9e-3, 0.8e-3], tolerance), "slow");
        assert!(!nearly_done(&[within], tolerance), "one decrement");
    }

    fn pairs(points: std::ops::Range<usize>) -> Vec<(usize, usize)> {
        points.map(|c| (c, 0)).collect()
    }

    /// Springs gained and springs lost both count, past half of those held; a few coming and
    /// going do not.
    #[test]
    fn springs_gained_or_lost_past_half_refactor() {
        let held = pairs(0..100);
        assert!(!changed_past_share(&held, &held));
        assert!(
            !changed_past_share(&held, &pairs(10..110)),
            "10 gained, 10 lost"
        );
        assert!(changed_past_share(&held, &pairs(0..151)), "51 gained");
        assert!(!changed_past_share(&held, &pairs(0..150)), "50 gained");
        assert!(changed_past_share(&held, &pairs(51..100)), "51 lost");
        assert!(!changed_past_share(&held, &pairs(50..100)), "50 lost");
        assert!(
            changed_past_share(&held, &pairs(60..160)),
            "60 gained, 60 lost"
        );
        assert!(changed_past_share(&[], &pairs(0..2)), "2 gained on none");
        assert!(!changed_past_share(&[], &pairs(0..1)), "1 gained on none");
        assert!(changed_past_share(&pairs(0..3), &[]), "all 3 lost");
    }
}
