//! Reduced-order dynamics: implicit Euler over the handle state z, each step an energy
//! minimization solved by Newton (the exact Hessian where it is definite, else PSD-projected;
//! dense Cholesky) or by L-BFGS preconditioned with the rest-state Hessian, factored once
//! ("quasi-Newton"), both with an Armijo backtracking line search. A step still descending
//! when its budget runs out gets it again (and says so); pins are exact where they dominate
//! the body and springs elsewhere, stiffened for a step whose forces they would lose.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

mod contact;
mod curvature;
mod factor;
mod guess;
mod held;
mod hessian;
mod observe;
mod pinning;
mod pins;
mod point;
mod rebase;
mod search;

pub use observe::{ObservationTerm, UnmodelledForce};
pub use rebase::{state_projection, SimSetup};

use super::material::Material;
use super::obstacle::{Anchors, Obstacle, Stick};
use super::rolling::{RollAnchors, RollingStick};
use super::scene::{Poke, SimParams};
use super::subspace::Subspace;
use crate::error::Result;
use crate::linalg::product;
use contact::ContactSignature;
use factor::HeldFactor;
use held::{nearly_done, refresh_due};
use pinning::PinConstraint;
use pins::PinWatch;
use point::{Gathered, ReducedPoint};
use search::{objective_change, quadratic_change};

/// How each implicit step is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Solver {
    /// Full Newton: the Hessian (exact where definite, else projected) assembled and factored
    /// every iteration.
    Newton,
    /// L-BFGS (32 pairs, kept across steps) over a held, factored Hessian: the rest-state one
    /// at first, refactored at the current state whenever a step has taken 11 iterations. A step
    /// still descending when its budget runs out gets it again, over a refreshed Hessian unless
    /// it is nearly done; one it cannot descend in, or still cannot finish, is handed to full
    /// Newton.
    QuasiNewton,
}

impl Solver {
    /// The solver's name in parameters and reports: "newton" or "quasi_newton".
    pub fn name(&self) -> &'static str {
        match self {
            Solver::Newton => "newton",
            Solver::QuasiNewton => "quasi_newton",
        }
    }
}

/// What one step did.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct StepReport {
    /// Solver iterations taken (line-search steps accepted), the Newton fallback's included.
    pub iterations: usize,
    /// Whether the decrement |dz . g| fell below the convergence threshold.
    pub converged: bool,
    /// The quasi-Newton solver found no descent, or ran out of its budget and every extension
    /// of it, and full Newton finished the step.
    pub fallback: bool,
    /// Times the quasi-Newton solver reassembled its held elastic Hessian during the step.
    pub refreshes: usize,
    /// Factorizations of the quasi-Newton solver's preconditioner during the step (a refresh,
    /// a turn of the body, a change of the contact springs acting); 0 for a body that keeps
    /// resting on the same points.
    #[serde(default)]
    pub factorizations: usize,
    /// Low-rank updates of the quasi-Newton solver's factored preconditioner during the step,
    /// each for springs gained or lost or a turn of the body, where a factorization would
    /// otherwise have been made.
    #[serde(default)]
    pub factor_updates: usize,
    /// Times the last solver's budget (`max_iterations`) was given again because the step
    /// was still descending when it ran out; 0 for a step that converged within its budget.
    #[serde(default)]
    pub budget_extensions: usize,
    /// Times the pin springs were made 10 times stiffer for this step and it was solved again,
    /// because they let pinned material drift past its tolerance (`SimParams::pin_tolerance`);
    /// 0 for most steps. `pin_spring_boost` gives the stiffness it ended with.
    #[serde(default)]
    pub pin_stiffenings: usize,
    /// Contact points inside an obstacle at the end of the step.
    pub contacts: usize,
    /// |dz . g| when the solver stopped (J).
    pub decrement: f64,
    /// Elastic energy at the end of the step, J.
    pub elastic_energy: f64,
    /// Kinetic energy at the end of the step, J.
    pub kinetic_energy: f64,
    /// Gravity's potential energy relative to the rest pose (J).
    pub gravity_energy: f64,
    /// Energy held by the penalty springs of pins, contacts and friction (J): with the three
    /// above, what implicit Euler may only lose once nothing drives the body.
    #[serde(default)]
    pub constraint_energy: f64,
    /// Wall-clock time of the step, s.
    pub seconds: f64,
}

impl StepReport {
    /// How many times stiffer than `pin_stiffness` the pin springs ended the step.
    pub fn pin_spring_boost(&self) -> f64 {
        STIFFENING.powi(self.pin_stiffenings as i32)
    }
}

/// Refreshes of the held Hessian, and the factorizations they made, that `prepare` made
/// between two steps.
#[derive(Clone, Copy, Debug, Default)]
struct AheadWork {
    refreshes: usize,
    factorizations: usize,
}

/// The part of one step's objective that is quadratic or linear in z.
struct StepObjective {
    quadratic: DMatrix<f64>,
    linear: DMatrix<f64>,
}

/// The step objective at one z. Only its non-quadratic part (elasticity, contact) is kept as a
/// value: the line search needs energy differences, and the quadratic part's are exact.
struct Evaluation {
    nonquadratic: f64,
    elastic: f64,
    nonquadratic_gradient: DMatrix<f64>,
    gradient: DMatrix<f64>,
    /// (contact, obstacle) pairs in touch.
    touching: Vec<(usize, usize)>,
}

/// Curvature pairs L-BFGS keeps, carried over from step to step. A bending body's held
/// Hessian goes stale within a few steps; pairs from the steps since describe what changed.
/// The poked creature (16 handles, 1024 points) took a median step of 1.471-1.645 ms with 8,
/// 1.438 ms with 16, 0.822 ms with 32, 0.926 ms with 64 (printed, `bench sim`, FEM left out);
/// the rod's and the plate's rows stayed within their runs' spread.
const LBFGS_PAIRS: usize = 32;
/// After this many quasi-Newton iterations in one step, the held Hessian is refreshed, unless
/// the solve is converging fast enough to finish within `REFRESH_GRACE` more. A refresh costs
/// about ten iterations. `bench sim` at 16 handles and 1024 points (FEM left out, printed): the
/// poked creature refreshed 37 times in 60 steps after 8, median 2.243 ms and slowest step
/// 11.236 ms; after 11, 25 times, 1.397-1.418 ms and 4.995-5.280 ms. The poked rod's mean went
/// from 1.300 to 1.131 ms; the poked plate's median from 0.753-0.809 to 0.808-1.069 ms, its
/// slowest step from 2.887-2.956 to 3.168-4.004 ms. `bench stress` converges every step after
/// 8, 10 or 11, not after 9 (the violent poke on the soft box) or 12 (the mirrored start).
const REFRESH_AFTER_ITERATIONS: usize = 11;
const REFRESH_GRACE: usize = 2;
/// How many times a step's last solver may get its budget again while it still descends.
const BUDGET_EXTENSIONS: usize = 10;
/// Pinned material this many pin tolerances away during a solve means the springs have lost
/// it: the solve stops and the step is solved again with stiffer springs.
const STIFFEN_AT_ONCE: f64 = 10.0;
/// Each stiffening multiplies the pin springs by this; at most `MAX_STIFFENINGS` per step.
const STIFFENING: f64 = 10.0;
const MAX_STIFFENINGS: usize = 6;

/// One deformable object simulated in its skinning subspace.
pub struct ReducedSim {
    subspace: Arc<Subspace>,
    params: SimParams,
    material: Material,
    solver: Solver,
    z: DMatrix<f64>,
    z_prev: DMatrix<f64>,
    /// The state before `z_prev`, for the solve's starting guess; None after the state is set.
    z_before: Option<DMatrix<f64>>,
    /// Steps since the last that needed more than its budget.
    calm_steps: usize,
    /// Iterations the last step took.
    last_iterations: usize,
    /// Iterations of the first step solved wholly over the held elastic Hessian (None until
    /// one has been): what it costs while fresh (see `refresh_ahead`).
    fresh_iterations: Option<usize>,
    /// A slow step found the held Hessian stale: the next step refreshes it first (see
    /// `ReducedSim::refresh_if_due`).
    refresh_due: bool,
    /// What `prepare` did ahead of the next step, for its report.
    ahead: AheadWork,
    time: f64,
    pins: Vec<ReducedPoint>,
    /// The pin energy is quadratic in Z, so it is kept in closed form whatever the number of
    /// pinned points: (k/2) [tr(Z P Z^T) + 2 <B, Z>] + const with P = sum m phi phi^T
    /// (4K x 4K) and B = sum m (X - T) phi^T (3 x 4K).
    pin_phi: DMatrix<f64>,
    pin_offset: DMatrix<f64>,
    /// The pins' phis side by side (4K x n) and their gaps X - T (3 x n): Z Phi + gaps is how
    /// far each is from its target.
    pin_phis: DMatrix<f64>,
    pin_gaps: DMatrix<f64>,
    /// sum m |X - T|^2, the pin energy's constant (over k/2), and the smallest pin mass.
    pin_gap_sum: f64,
    lightest_pin: f64,
    /// The largest |phi| of a pin: how far a change of Z can move a pin, per unit of its norm.
    pin_reach: f64,
    /// The pins' directions held exactly; out of date after pins are added or released.
    pinning: Option<PinConstraint>,
    /// The pin springs' stiffness over `pin_stiffness` this step: 1 but in steps they lose.
    pin_boost: f64,
    pinning_stale: bool,
    contacts: Vec<ReducedPoint>,
    /// The contact points' phis side by side (4K x n) and rest positions (3 x n): where they
    /// all are, X + Z Phi, is one product.
    contact_phis: DMatrix<f64>,
    contact_rests: DMatrix<f64>,
    /// Pinned material (rest positions x with n . x <= h) whose contact samples do not collide.
    held_side: Option<(Vector3<f64>, f64)>,
    /// Whether each contact sample collides: not in `held_side`.
    contact_collides: Vec<bool>,
    obstacles: Vec<Obstacle>,
    /// Obstacles that move (robot links), replaced before each step.
    colliders: Vec<Obstacle>,
    /// The moving obstacles as they were at the last step: friction carries what a link
    /// touches by the link's move since.
    colliders_before: Vec<Obstacle>,
    /// This step's broad phase: (contact, obstacle) pairs close enough to touch, obstacles
    /// indexed over `obstacles` then `colliders`.
    candidates: Vec<(usize, usize)>,
    /// The candidates' points, gathered once a step so that an evaluation places them all in
    /// one product; the sticks' points, likewise.
    gathered_candidates: Gathered,
    gathered_sticks: Gathered,
    /// This step's friction: contact points touching at its start.
    sticks: Vec<Stick>,
    /// Friction anchors of contacts resting on static obstacles.
    anchors: Anchors,
    /// This step's rolling friction: one per obstacle touched at its start.
    rolls: Vec<RollingStick>,
    roll_anchors: RollAnchors,
    /// The object's bounding-box diagonal, m.
    diagonal: f64,
    pokes: Vec<(DVector<f64>, Poke)>,
    /// What a sensor saw, pulling the observed material points (see `observe`).
    observed: Option<observe::Observed>,
    /// The forces observations showed that nothing modelled (see `observe`).
    unmodelled: Option<observe::UnmodelledForce>,
    /// What the quasi-Newton preconditioner holds besides contact: elasticity (at rest, or at
    /// the state of the last refresh) plus inertia, damping and pins.
    held: Option<DMatrix<f64>>,
    /// The body's mean rotation where `held` was assembled.
    held_rotation: Matrix3<f64>,
    /// The contact the factored preconditioner includes; None when the factor does not match
    /// the held matrix and must be redone.
    factored_contact: Option<ContactSignature>,
    /// The rotation, from `held_rotation`, that the factored preconditioner was turned by.
    factored_turn: Matrix3<f64>,
    /// The contact curvature last added to the preconditioner and the contact it was made for:
    /// a body that only turned is refactored with it instead of making it again.
    held_contact: Option<(ContactSignature, Option<DMatrix<f64>>)>,
    history: VecDeque<(DVector<f64>, DVector<f64>)>,
    preconditioner: Option<HeldFactor>,
    /// Convergence threshold on |dz . g| (J), from the tolerance and the object's size.
    decrement_tolerance: f64,
    /// Preconditioner factorizations so far.
    factorizations: usize,
    /// Low-rank updates of the preconditioner's factor so far (see `HeldFactor`).
    factor_updates: usize,
}

impl ReducedSim {
    /// `diagonal` is the object's bounding-box diagonal (m), the length the tolerance refers to.
    pub fn new(
        subspace: Arc<Subspace>,
        params: SimParams,
        solver: Solver,
        diagonal: f64,
    ) -> Result<Self> {
        params.validate()?;
        let k = subspace.handles();
        let length = params.tolerance * diagonal;
        Ok(Self {
            material: params.material(),
            factorizations: 0,
            factor_updates: 0,
            decrement_tolerance: subspace.total_mass() * length * length / (params.dt * params.dt),
            z: DMatrix::zeros(3, 4 * k),
            z_prev: DMatrix::zeros(3, 4 * k),
            z_before: None,
            calm_steps: 0,
            fresh_iterations: None,
            refresh_due: false,
            ahead: AheadWork::default(),
            last_iterations: 0,
            time: 0.0,
            pins: Vec::new(),
            pin_phi: DMatrix::zeros(4 * k, 4 * k),
            pin_offset: DMatrix::zeros(3, 4 * k),
            pin_phis: DMatrix::zeros(4 * k, 0),
            pin_gaps: DMatrix::zeros(3, 0),
            pin_gap_sum: 0.0,
            lightest_pin: 0.0,
            pin_reach: 0.0,
            pinning: None,
            pin_boost: 1.0,
            pinning_stale: true,
            contacts: Vec::new(),
            contact_phis: DMatrix::zeros(4 * k, 0),
            contact_rests: DMatrix::zeros(3, 0),
            held_side: None,
            contact_collides: Vec::new(),
            obstacles: Vec::new(),
            colliders: Vec::new(),
            colliders_before: Vec::new(),
            candidates: Vec::new(),
            gathered_candidates: Gathered::new(),
            gathered_sticks: Gathered::new(),
            sticks: Vec::new(),
            anchors: Anchors::default(),
            rolls: Vec::new(),
            roll_anchors: RollAnchors::default(),
            diagonal,
            pokes: Vec::new(),
            observed: None,
            unmodelled: None,
            held: None,
            held_rotation: Matrix3::identity(),
            factored_contact: None,
            factored_turn: Matrix3::identity(),
            held_contact: None,
            history: VecDeque::new(),
            preconditioner: None,
            subspace,
            params,
            solver,
        })
    }

    /// The subspace the body is simulated in.
    pub fn subspace(&self) -> &Subspace {
        &self.subspace
    }

    /// The subspace, shared: another simulation of the same body (a benchmark's scenario).
    pub fn shared_subspace(&self) -> Arc<Subspace> {
        self.subspace.clone()
    }
    /// The simulation parameters.
    pub fn params(&self) -> &SimParams {
        &self.params
    }
    /// Simulated time, s (`dt` per step).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// The handle matrix Z (3 x 4K); flattened column-major it is z.
    pub fn state(&self) -> &DMatrix<f64> {
        &self.z
    }
    /// The reduced velocity (z_t - z_{t-1}) / h.
    pub fn velocity(&self) -> DMatrix<f64> {
        (&self.z - &self.z_prev) / self.params.dt
    }

    /// Starts from state `z` at rest velocity, or with the given previous state.
    pub fn set_state(&mut self, z: DMatrix<f64>, previous: Option<DMatrix<f64>>) {
        self.z_prev = previous.unwrap_or_else(|| z.clone());
        self.z = z;
        self.z_before = None;
    }

    /// Back to the rest pose, at rest, at time 0.
    pub fn reset(&mut self) {
        self.z.fill(0.0);
        self.z_prev.fill(0.0);
        self.z_before = None;
        self.time = 0.0;
        self.refresh_due = false;
        self.ahead = AheadWork::default();
        self.forget_observation();
        self.unmodelled = None;
    }

    /// The elastic Hessian at rest (PSD-projected), kept by the subspace.
    fn rest_elastic_hessian(&self) -> Arc<DMatrix<f64>> {
        self.subspace.rest_elastic_hessian(&self.material)
    }

    /// Adds a static obstacle; contact points collide with it.
    pub fn add_obstacle(&mut self, obstacle: Obstacle) {
        self.obstacles.push(obstacle);
    }

    /// Replaces the moving obstacles (robot links at their current poses) for the next step.
    pub fn set_colliders(&mut self, colliders: Vec<Obstacle>) {
        self.colliders = colliders;
    }

    /// Bounds of the moving obstacles, in their order (`None` for a plane).
    pub fn collider_bounds(&self) -> Vec<Option<(Vector3<f64>, Vector3<f64>)>> {
        self.colliders.iter().map(|c| c.bounds(0.0)).collect()
    }

    /// Drops every force in progress.
    pub fn clear_pokes(&mut self) {
        self.pokes.clear();
    }

    /// Whether a poke acts now or will later (its window has not ended).
    pub fn has_active_pokes(&self) -> bool {
        self.pokes.iter().any(|(_, p)| p.end > self.time)
    }

    /// Whether contact points were added.
    pub fn has_contact_points(&self) -> bool {
        !self.contacts.is_empty()
    }

    /// Adds a force on the material point at `poke.point` (rest position) over the poke's
    /// window of simulated time; pokes already over are dropped.
    pub fn add_poke(&mut self, poke: Poke) {
        // Finished pokes are dropped here, so a long stream of them costs nothing.
        let now = self.time;
        self.pokes.retain(|(_, p)| p.end > now);
        let phi = self.subspace.phis(&[poke.point]).remove(0);
        self.pokes.push((phi, poke));
    }

    /// Does now the work the next step would otherwise begin with: the pins' exact directions
    /// after pins were added, the rest Hessian and its factorization before the first
    /// quasi-Newton step, the springs back to their own stiffness after a step that stiffened
    /// them, and the held Hessian's refresh that a slow step asked for (see `refresh_if_due`).
    /// Call it after adding pins, and after each step once its outputs are out: the refresh,
    /// an assembly over the coarser cubature (1-2 ms at 16 handles), then no longer holds up
    /// the step that needs it. Steps are the same either way; the refresh is counted in the
    /// next step's report.
    pub fn prepare(&mut self) {
        if self.pin_boost != 1.0 {
            self.set_pin_boost(1.0);
        }
        let factorizations = self.factorizations;
        if self.refresh_if_due() > 0 {
            self.ahead.refreshes += 1;
            self.ahead.factorizations += self.factorizations - factorizations;
        }
        if self.pinning_stale {
            self.update_pinning();
        }
        if self.solver == Solver::QuasiNewton && self.preconditioner.is_none() {
            self.preconditioner = Some(self.build_preconditioner());
        }
    }

    /// Advances one time step.
    pub fn step(&mut self) -> StepReport {
        let started = Instant::now();
        // What `prepare` did for this step, since the last one or now, counts in its report:
        // its factorizations between the steps here, those made now by the count below.
        let factorizations = self.factorizations - self.ahead.factorizations;
        let factor_updates = self.factor_updates;
        let predicted = self.predicted();
        let previous = self.z.clone();
        let mut report = StepReport::default();
        self.prepare();
        let ahead = std::mem::take(&mut self.ahead).refreshes;
        report.refreshes += ahead;
        let mut z = self.placed_on_pins(&predicted);
        self.find_candidates(&z);
        self.find_sticks();
        let trend = self
            .trend_guess(&predicted)
            .map(|g| self.placed_on_pins(&g));
        let mut current = self.solve_from(&mut z, trend, &predicted, &previous, &mut report);
        while !self.pins_within(&z, self.pin_tolerance())
            && report.pin_stiffenings < MAX_STIFFENINGS
        {
            // A force the pin springs cannot hold: solve the step again with stiffer ones.
            // Only this step's: stiff springs condition the solve badly.
            report.pin_stiffenings += 1;
            self.set_pin_boost(self.pin_boost * STIFFENING);
            z = self.placed_on_pins(&predicted);
            current = self.solve_from(&mut z, None, &predicted, &previous, &mut report);
        }
        // A step that needed the Newton fallback means the held Hessian no longer describes the
        // state: refactor it at the new state before the next step.
        if self.solver == Solver::QuasiNewton && report.fallback {
            self.preconditioner = None;
            self.held = None;
            self.history.clear();
        }
        self.refresh_if_stale(&current, &report, ahead);
        let before = std::mem::replace(&mut self.z_prev, std::mem::replace(&mut self.z, z));
        // A step that needed more than its budget met an impulse (a landing, a poke's start):
        // the changes of velocity around it are no trend. Carried into the next steps' guesses
        // they cost the demo's creature a second hard step (28 iterations, then 21 two steps
        // on), so the guess goes back to constant velocity for a few steps.
        let hard = report.budget_extensions > 0 || report.fallback;
        self.calm_steps = if hard { 0 } else { self.calm_steps + 1 };
        self.last_iterations = report.iterations;
        self.z_before = Some(before);
        self.colliders_before = self.colliders.clone();
        self.time += self.params.dt;
        self.fade_unmodelled();
        report.elastic_energy = current.elastic;
        report.constraint_energy = current.nonquadratic - current.elastic + self.pin_energy();
        report.contacts = current.touching.len();
        report.factorizations = self.factorizations - factorizations;
        report.factor_updates = self.factor_updates - factor_updates;
        let velocity = self.velocity();
        report.kinetic_energy = 0.5 * quadratic(&velocity, self.subspace.mass_phi());
        report.gravity_energy = -(&self.z * self.subspace.mass_moment()).dot(&self.params.gravity);
        report.seconds = started.elapsed().as_secs_f64();
        report
    }

    /// Solves the step from `z` (placed on the pins) with the springs as they are now: the
    /// preconditioner held at `z`, this step's objective, then `solve`.
    fn solve_from(
        &mut self,
        z: &mut DMatrix<f64>,
        alternative: Option<DMatrix<f64>>,
        predicted: &DMatrix<f64>,
        previous: &DMatrix<f64>,
        report: &mut StepReport,
    ) -> Evaluation {
        // Pairs measured before a refactor would take back what it added: a landing's first
        // step kept the free fall's pairs over a factor holding the new springs, and their
        // curvature along the fall undid the springs'. The rod's landing took 17 iterations
        // and 2.7 ms that way, 9 and 1.2 ms with the pairs dropped (printed).
        if self.solver == Solver::QuasiNewton && self.hold_for_step(z) {
            self.history.clear();
        }
        let objective = self.step_objective(predicted, previous);
        let start = self.better_start(z, alternative, &objective);
        self.solve(z, &objective, start, report)
    }

    /// Minimizes the step objective from `z` (on the pins), leaving the minimizer in `z` and
    /// returning its evaluation. Quasi-Newton hands a step it cannot finish to full Newton; a
    /// solver still descending when its budget runs out gets it again, up to
    /// `BUDGET_EXTENSIONS` times, and the report counts them.
    fn solve(
        &mut self,
        z: &mut DMatrix<f64>,
        objective: &StepObjective,
        start: Evaluation,
        report: &mut StepReport,
    ) -> Evaluation {
        let mut current = start;
        // Curvature pairs carry over from the previous steps: the Hessian changes little between
        // steps, so they make a better start than the rest Hessian alone.
        let mut history = std::mem::take(&mut self.history);
        let mut mode = self.solver;
        let mut budget = self.params.max_iterations;
        let mut extensions = 0;
        let mut newton_tried = false;
        let mut since_refresh = 0;
        // The decrements since the last refresh: whether a slow solve is nearly done.
        let mut decrements = Vec::new();
        // A step solved again (stiffer pin springs) starts unconverged, whatever the last solve
        // said.
        report.converged = false;
        // Springs losing their pins show it early: such a solve stops for stiffer springs.
        let watch_pins = self.pinning.is_some() && report.pin_stiffenings < MAX_STIFFENINGS;
        let mut pin_watch = PinWatch::default();
        loop {
            if mode == Solver::QuasiNewton
                && refresh_due(since_refresh, &decrements, self.decrement_tolerance)
            {
                self.refresh_held(z, &current, report, &mut history);
                since_refresh = 0;
                decrements.clear();
            }
            let gradient = flat(&current.gradient);
            let mut direction = match mode {
                Solver::Newton => self.newton_direction(z, &gradient),
                Solver::QuasiNewton => self.lbfgs_direction(&gradient, &history),
            };
            let mut slope = direction.dot(&gradient);
            if !is_descent(slope) && mode == Solver::QuasiNewton && !history.is_empty() {
                history.clear();
                direction = self.lbfgs_direction(&gradient, &history);
                slope = direction.dot(&gradient);
            }
            report.decrement = slope.abs();
            decrements.push(report.decrement);
            if report.decrement < self.decrement_tolerance || !slope.is_finite() {
                report.converged = slope.is_finite();
                break;
            }
            let searched = if budget > 0 && is_descent(slope) {
                self.line_search(z, &direction, slope, &current, objective)
            } else {
                None
            };
            let Some((step, next)) = searched else {
                // A solver still descending when its budget runs out gets it again, as
                // L-BFGS over a Hessian refreshed here unless it is nearly done: it converges
                // in a few iterations after the refresh, where full Newton would assemble a
                // Hessian for each of its own (a plate's impact took 36 ms that way).
                // Quasi-Newton hands a step it cannot descend in, or still cannot finish, to
                // full Newton once. Otherwise the step ends unconverged.
                if budget == 0 && extensions < BUDGET_EXTENSIONS {
                    extensions += 1;
                    budget = self.params.max_iterations;
                    let tolerance = self.decrement_tolerance;
                    if mode == Solver::Newton || !nearly_done(&decrements, tolerance) {
                        // Refreshed at once: the held matrix is what holds it back.
                        mode = Solver::QuasiNewton;
                        since_refresh = REFRESH_AFTER_ITERATIONS;
                        decrements.clear();
                    }
                    continue;
                }
                if mode == Solver::QuasiNewton && !newton_tried {
                    newton_tried = true;
                    mode = Solver::Newton;
                    budget = self.params.max_iterations;
                    report.fallback |= self.solver == Solver::QuasiNewton;
                    continue;
                }
                break;
            };
            budget -= 1;
            since_refresh += 1;
            report.iterations += 1;
            if mode == Solver::QuasiNewton {
                let s = &direction * step;
                let y = flat(&next.gradient) - &gradient;
                if s.dot(&y) > 1e-12 * s.norm() * y.norm() {
                    history.push_back((s, y));
                    if history.len() > LBFGS_PAIRS {
                        history.pop_front();
                    }
                }
            }
            *z += unflat(&(&direction * step), self.subspace.handles());
            current = next;
            // A landing, or a lift-off within the step: springs the factor lacks, or holds
            // while they no longer act, would cost many iterations.
            if mode == Solver::QuasiNewton && self.springs_changed(&current.touching) {
                self.hold_at(z);
                history.clear();
            }
            let limit = STIFFEN_AT_ONCE * self.pin_tolerance();
            if watch_pins && !self.pins_still_within(z, limit, &mut pin_watch) {
                break;
            }
        }
        self.history = history;
        report.budget_extensions += extensions;
        current
    }

    /// The step objective's non-quadratic value (elasticity, contact), the elastic part, and
    /// the gradients at `z`. Inertia, damping, pins, gravity and pokes are quadratic or linear
    /// in z: their gradient Z Q - L costs one small product.
    fn evaluate(&self, z: &DMatrix<f64>, objective: &StepObjective) -> Evaluation {
        let (elastic, mut gradient) = self.subspace.elastic_forces(z, &self.material);
        let mut energy = elastic;
        let kc = self.params.contact_stiffness;
        let touching_now = self.touching_at(z);
        for (c, _, p) in &touching_now {
            let contact = &self.contacts[*c];
            energy += 0.5 * kc * contact.weight * p.depth * p.depth;
            // In place: an outer product per touching point would allocate, and a resting
            // body has hundreds of them in every evaluation.
            gradient.ger(-kc * contact.weight * p.depth, &p.normal, &contact.phi, 1.0);
        }
        let touching = touching_now.iter().map(|&(c, o, _)| (c, o)).collect();
        energy += self.add_stick_forces(z, &mut gradient);
        for roll in &self.rolls {
            let (e, g) = roll.energy_and_gradient(z);
            energy += e;
            gradient += g;
        }
        let mut total = &gradient + times_symmetric(z, &objective.quadratic) - &objective.linear;
        if let Some(pinning) = self.pinning.as_ref() {
            pinning.free_part(&mut total);
        }
        Evaluation {
            nonquadratic: energy,
            elastic,
            nonquadratic_gradient: gradient,
            gradient: total,
            touching,
        }
    }

    /// The quadratic and linear terms of this step's objective.
    fn step_objective(&self, predicted: &DMatrix<f64>, previous: &DMatrix<f64>) -> StepObjective {
        let h = self.params.dt;
        let c = self.params.damping;
        let k = self.pin_stiffness();
        let mass = self.subspace.mass_phi();
        let gravity: DMatrix<f64> = DMatrix::from_fn(3, mass.ncols(), |d, a| {
            self.params.gravity[d] * self.subspace.mass_moment()[a]
        });
        let mut linear = times_symmetric(predicted, mass) / (h * h)
            + times_symmetric(previous, mass) * (c / h)
            - &self.pin_offset * k
            + gravity;
        for (phi, poke) in &self.pokes {
            if poke.start <= self.time && self.time < poke.end {
                for (a, p) in phi.iter().enumerate() {
                    for d in 0..3 {
                        linear[(d, a)] += poke.force[d] * p;
                    }
                }
            }
        }
        if let Some(observed) = &self.observed {
            linear -= &observed.offset;
        }
        if let Some(unmodelled) = &self.unmodelled {
            linear += &unmodelled.force;
        }
        StepObjective {
            quadratic: self.quadratic_part(),
            linear,
        }
    }

    /// Inertia, damping, pins and the observation: the quadratic part, (4K x 4K) to be taken
    /// (x) I_3.
    fn quadratic_part(&self) -> DMatrix<f64> {
        let mut quadratic = self.inertia_part() + &self.pin_phi * self.pin_stiffness();
        if let Some(observed) = &self.observed {
            quadratic += &observed.quadratic;
        }
        quadratic
    }

    /// Inertia and damping: the part of `quadratic_part` that pins never change.
    fn inertia_part(&self) -> DMatrix<f64> {
        let h = self.params.dt;
        self.subspace.mass_phi() * (1.0 / (h * h) + self.params.damping / h)
    }

    /// Deformed position of a material point given by its rest position.
    pub fn position_of(&self, rest: &Vector3<f64>) -> Vector3<f64> {
        let phi = self.subspace.phis(&[*rest]).remove(0);
        rest + &self.z * phi
    }
}

/// x^T M x summed over the three rows of a 3 x 4K matrix: tr(X M X^T).
fn quadratic(x: &DMatrix<f64>, m: &DMatrix<f64>) -> f64 {
    times_symmetric(x, m).dot(x)
}

/// X M for a 3 x n matrix X and a symmetric M.
fn times_symmetric(x: &DMatrix<f64>, m: &DMatrix<f64>) -> DMatrix<f64> {
    product(x, m)
}

/// Flat z (column-major) of a 3 x 4K matrix.
fn flat(m: &DMatrix<f64>) -> DVector<f64> {
    DVector::from_column_slice(m.as_slice())
}

fn unflat(v: &DVector<f64>, handles: usize) -> DMatrix<f64> {
    DMatrix::from_column_slice(3, 4 * handles, v.as_slice())
}

/// H += Q (x) I_3 in flat z order (index 3a + d).
fn add_kron_identity(h: &mut DMatrix<f64>, q: &DMatrix<f64>) {
    for b in 0..q.ncols() {
        for a in 0..q.nrows() {
            for d in 0..3 {
                h[(3 * a + d, 3 * b + d)] += q[(a, b)];
            }
        }
    }
}

/// Whether a search direction with this slope (d . g) goes downhill; NaN does not.
pub(crate) fn is_descent(slope: f64) -> bool {
    slope < 0.0
}

#[cfg(test)]
mod tests;
