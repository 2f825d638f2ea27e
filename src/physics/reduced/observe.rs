//! What a sensor saw, as a term of the step objective: material points pulled toward the
//! places they were observed at by springs, (k/2) sum w |X + Z phi - y|^2. The term is
//! quadratic in Z, so a step minimizes inertia, elasticity, contact and the observation
//! together: the physics fills in what the sensor does not see (the hidden side, the time
//! between frames) and the observation corrects what the physics does not know (a hand, a
//! poker, a wrong stiffness), a filter whose prediction is the implicit step and whose update
//! is its data term.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::ReducedSim;
use crate::error::{Error, Result};
use crate::linalg::{add_product_transposed, symmetric_product};

/// Observed places of material points of a body, for [`ReducedSim::observe`].
#[derive(Clone, Debug)]
pub struct ObservationTerm {
    /// The material points' subspace samples side by side (4K x n).
    pub phis: DMatrix<f64>,
    /// Their rest positions (3 x n), m.
    pub rests: DMatrix<f64>,
    /// Where each was observed (3 x n), m.
    pub targets: DMatrix<f64>,
    /// The mass each correspondence stands for, kg.
    pub weights: Vec<f64>,
    /// The springs' stiffness per kg, 1/s^2: k h^2 = 1 pulls a free body halfway toward the
    /// observation in one step.
    pub stiffness: f64,
    /// This frame's share of the forces nothing modelled, added to the estimate that acts in
    /// every later step (see [`UnmodelledForce`]).
    pub unmodelled: Option<UnmodelledForce>,
}

/// A generalized force (3 x 4K, the subspace's coordinates) that the observations showed and
/// nothing modelled: a hand, a poker, a support higher than the body's bottom. Springs that
/// pull only while a frame is fresh correct the body for that step; the physics, which knows
/// no such force, then relaxes the correction before the next frame. Added up frame by frame
/// (the integral term of a controller, an augmented state of a filter), the estimate makes the
/// physics hold what the frames showed between them; it fades once frames stop showing it.
#[derive(Clone, Debug)]
pub struct UnmodelledForce {
    /// The force, N per subspace coordinate (3 x 4K).
    pub force: DMatrix<f64>,
    /// Its e-folding time once frames stop adding to it, s.
    pub memory_s: f64,
}

/// The observation as the step objective takes it: k P = k sum w phi phi^T (4K x 4K, taken
/// (x) I_3) and k B = k sum w (X - y) phi^T (3 x 4K).
pub(super) struct Observed {
    pub(super) quadratic: DMatrix<f64>,
    pub(super) offset: DMatrix<f64>,
}

impl ObservationTerm {
    fn check(&self, rows: usize) -> Result<()> {
        let n = self.weights.len();
        let shapes_agree = self.phis.shape() == (rows, n)
            && self.rests.shape() == (3, n)
            && self.targets.shape() == (3, n);
        if !shapes_agree {
            return Err(Error::InvalidParameter {
                name: "observation",
                reason: format!(
                    "phis {:?}, rests {:?}, targets {:?} for {n} weights in a {rows}-row subspace",
                    self.phis.shape(),
                    self.rests.shape(),
                    self.targets.shape()
                ),
            });
        }
        let finite = self.stiffness.is_finite()
            && self.stiffness >= 0.0
            && self.weights.iter().all(|w| w.is_finite() && *w >= 0.0)
            && self.targets.iter().all(|t| t.is_finite())
            && self.unmodelled.as_ref().is_none_or(|u| {
                u.force.shape() == (3, rows)
                    && u.force.iter().all(|f| f.is_finite())
                    && u.memory_s > 0.0
            });
        if !finite {
            return Err(Error::InvalidParameter {
                name: "observation",
                reason: "a negative or non-finite stiffness, weight or target, or an unmodelled \
                         force of another shape or without a positive memory"
                    .into(),
            });
        }
        Ok(())
    }
}

impl ReducedSim {
    /// The next steps pull the observed material points toward where they were seen, until
    /// the observation is replaced or forgotten. The held factor is made again at the next
    /// step's start with the observation's springs in it (one 12K x 12K factorization).
    pub fn observe(&mut self, term: &ObservationTerm) -> Result<()> {
        term.check(4 * self.subspace.handles())?;
        let k = term.stiffness;
        let mut weighted = term.phis.clone();
        for (mut column, w) in weighted.column_iter_mut().zip(&term.weights) {
            column *= w * k;
        }
        // Symmetric, so half the product: a frame's few hundred springs made it a fifth of the
        // correction's time.
        let quadratic = symmetric_product(&weighted, &term.phis);
        let gaps = &term.rests - &term.targets;
        let mut offset = DMatrix::zeros(3, weighted.nrows());
        add_product_transposed(&mut offset, &gaps, &weighted);
        self.observed = Some(Observed { quadratic, offset });
        if let Some(frame) = &term.unmodelled {
            match &mut self.unmodelled {
                Some(estimate) => {
                    estimate.force += &frame.force;
                    estimate.memory_s = frame.memory_s;
                }
                None => self.unmodelled = Some(frame.clone()),
            }
        }
        self.observation_changed();
        Ok(())
    }

    /// After a step: the estimate of the forces nothing modelled fades by its memory.
    pub(super) fn fade_unmodelled(&mut self) {
        if let Some(estimate) = &mut self.unmodelled {
            estimate.force *= (-self.params.dt / estimate.memory_s).exp();
        }
    }

    /// Drops the estimate of the forces nothing modelled.
    pub fn forget_unmodelled(&mut self) {
        self.unmodelled = None;
    }

    /// The steps from now on run on physics alone.
    pub fn forget_observation(&mut self) {
        if self.observed.take().is_some() {
            self.observation_changed();
        }
    }

    /// Moves the body at once by the rigid motion x -> R x + t, its previous state with it (so
    /// its velocity turns, and keeps its size): a frame that finds the body far off where the
    /// body is seen puts it there, where springs pulling it would leave it the pull's speed.
    pub fn move_rigidly(&mut self, rotation: &Matrix3<f64>, translation: &Vector3<f64>) {
        let jump = self.subspace.rigid_state(rotation, translation);
        let turn = DMatrix::from_column_slice(3, 3, rotation.as_slice());
        self.z = &jump + &turn * &self.z;
        self.z_prev = &jump + &turn * &self.z_prev;
        self.z_before = None;
    }

    /// Whether an observation pulls the body now.
    pub fn is_observed(&self) -> bool {
        self.observed.is_some()
    }

    /// The factor in place holds the old observation's springs: it is made anew (not updated,
    /// the springs are many) before the next solve, and curvature pairs measured with the old
    /// springs go.
    fn observation_changed(&mut self) {
        self.factored_contact = None;
        self.history.clear();
    }
}
