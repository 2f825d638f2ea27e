//! Where a step's solve starts: the constant-velocity prediction, or that plus the last step's
//! change of velocity, whichever the step objective is lower at.

use nalgebra::DMatrix;

use super::{objective_change, quadratic_change, Evaluation, ReducedSim, StepObjective};

/// Steps after one that needed more than its budget before the solve's guess carries the
/// change of velocity again (see `trend_guess`).
const CALM_STEPS: usize = 3;
/// The trend is tried only after a step that took this many iterations or more: it costs an
/// evaluation, which a body whose steps converge at once cannot win back. Without this gate
/// `bench peer`'s block of 11 handles and 48 points, poked (1 to 2 iterations a step), took
/// 0.0786 ms a step in one run against 0.0412 and 0.0589 ms before; with it, 0.0419 (printed).
const TREND_FROM_ITERATIONS: usize = 3;

impl ReducedSim {
    /// The constant-velocity prediction of the next state, 2 z - z_prev: where the next step's
    /// objective is centred, and (placed on the pins) where its solve starts.
    pub fn predicted(&self) -> DMatrix<f64> {
        &self.z * 2.0 - &self.z_prev
    }

    /// The constant-velocity prediction plus the last step's change of velocity, which a
    /// swinging or bending body keeps from one step to the next; None just after the state was
    /// set, for `CALM_STEPS` steps after one that needed more than its budget, and after a step
    /// of fewer than `TREND_FROM_ITERATIONS` iterations. The solve starts from it where the
    /// step objective is lower there than at the prediction: after an impulse (a landing, a
    /// poke starting or ending) the change of velocity is no trend, and always starting from it
    /// cost the demo's creature two more hard steps. A poked rod's quasi-Newton steps took 7.83
    /// iterations against 9.73, and fewer of them reached the held Hessian's refresh (median
    /// 1.321 and 1.299 ms against 5.691 and 3.926 ms, printed, two runs each of `bench sim
    /// --shape rod`, before the gate; 1.692 ms after it, one run).
    pub(super) fn trend_guess(&self, predicted: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        let before = self.z_before.as_ref()?;
        (self.calm_steps >= CALM_STEPS && self.last_iterations >= TREND_FROM_ITERATIONS)
            .then(|| predicted + (&self.z - &self.z_prev * 2.0 + before))
    }

    /// Evaluates the start `z` and, given one, `alternative` (both on the pins); leaves in `z`
    /// the one where the step objective is lower, and returns its evaluation.
    pub(super) fn better_start(
        &self,
        z: &mut DMatrix<f64>,
        alternative: Option<DMatrix<f64>>,
        objective: &StepObjective,
    ) -> Evaluation {
        let at_z = self.evaluate(z, objective);
        let Some(other) = alternative else {
            return at_z;
        };
        let at_other = self.evaluate(&other, objective);
        // Compared as the line search compares (`objective_change`): the quadratic part's
        // change exactly, not its values, which hold the pin springs' 1e8 J.
        let quadratic = quadratic_change(&at_z, &(&other - &*z), objective);
        if objective_change(&at_z, &at_other, 1.0, quadratic) < 0.0 {
            *z = other;
            return at_other;
        }
        at_z
    }
}
