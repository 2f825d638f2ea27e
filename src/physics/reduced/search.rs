//! The line search along a solver's direction: Armijo backtracking from the full step, with
//! the step objective's changes taken with its quadratic part exactly.

use nalgebra::{DMatrix, DVector};

use super::{times_symmetric, unflat, Evaluation, ReducedSim, StepObjective};

const ARMIJO: f64 = 1e-4;

impl ReducedSim {
    /// The step along `direction` (its slope at `current` is `slope`) that the Armijo rule
    /// accepts, halving from the full step, with the evaluation there; None if 40 halvings
    /// find none.
    pub(super) fn line_search(
        &self,
        z: &DMatrix<f64>,
        direction: &DVector<f64>,
        slope: f64,
        current: &Evaluation,
        objective: &StepObjective,
    ) -> Option<(f64, Evaluation)> {
        let step_matrix = unflat(direction, self.subspace.handles());
        let quadratic = quadratic_change(current, &step_matrix, objective);
        let mut step = 1.0;
        for _ in 0..40 {
            let trial = z + &step_matrix * step;
            let next = self.evaluate(&trial, objective);
            let change = objective_change(current, &next, step, quadratic);
            if change.is_finite() && change <= ARMIJO * step * slope {
                return Some((step, next));
            }
            step *= 0.5;
        }
        None
    }
}

/// The step objective's quadratic part along `d` from the state evaluated in `at`, exactly:
/// (<g_q, D>, <D Q, D>), its change over alpha D being alpha first + alpha^2/2 second.
/// Differencing its absolute values instead would cancel terms of the size of the pin springs
/// (1e8 J and more) and drown the last Newton decrements in round-off. `d` must keep the pins
/// (the gradient in `at` is restricted to the free directions).
pub(super) fn quadratic_change(
    at: &Evaluation,
    d: &DMatrix<f64>,
    objective: &StepObjective,
) -> (f64, f64) {
    let quadratic_gradient = &at.gradient - &at.nonquadratic_gradient;
    (
        quadratic_gradient.dot(d),
        times_symmetric(d, &objective.quadratic).dot(d),
    )
}

/// The step objective's change from `from` to `to`, a step `alpha` along the direction whose
/// `quadratic_change` from `from` is (linear, curvature).
pub(super) fn objective_change(
    from: &Evaluation,
    to: &Evaluation,
    alpha: f64,
    (linear, curvature): (f64, f64),
) -> f64 {
    to.nonquadratic - from.nonquadratic + alpha * linear + 0.5 * alpha * alpha * curvature
}
