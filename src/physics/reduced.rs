//! Reduced-order dynamics: implicit Euler over the handle state z, each step an energy
//! minimization solved by Newton (PSD-projected Hessian, dense Cholesky) or by L-BFGS
//! preconditioned with the rest-state Hessian, factored once ("quasi-Newton"), both with an
//! Armijo backtracking line search.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::material::{Material, Matrix9};
use super::obstacle::Obstacle;
use super::scene::{Poke, SimParams};
use super::subspace::Subspace;
use crate::error::{Error, Result};
use crate::linalg::DenseCholesky;

/// How each implicit step is solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Solver {
    /// Full Newton: the projected Hessian assembled and factored every iteration.
    Newton,
    /// L-BFGS (8 pairs) whose initial Hessian is the rest-state Hessian plus inertia and pins,
    /// factored once per shape and time step.
    QuasiNewton,
}

impl Solver {
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
    pub iterations: usize,
    pub converged: bool,
    /// |dz . g| when the solver stopped (J).
    pub decrement: f64,
    pub elastic_energy: f64,
    pub kinetic_energy: f64,
    /// Gravity's potential energy relative to the rest pose (J).
    pub gravity_energy: f64,
    pub seconds: f64,
}

/// A material point of the object expressed in the subspace.
struct ReducedPoint {
    rest: Vector3<f64>,
    phi: DVector<f64>,
    /// Mass for pins (kg), area for contacts (m^2).
    weight: f64,
    target: Vector3<f64>,
}

struct Evaluation {
    energy: f64,
    elastic: f64,
    gradient: DMatrix<f64>,
}

const LBFGS_PAIRS: usize = 8;
const ARMIJO: f64 = 1e-4;

/// One deformable object simulated in its skinning subspace.
pub struct ReducedSim {
    subspace: Arc<Subspace>,
    params: SimParams,
    material: Material,
    solver: Solver,
    z: DMatrix<f64>,
    z_prev: DMatrix<f64>,
    time: f64,
    pins: Vec<ReducedPoint>,
    /// The pin energy is quadratic in Z, so it is kept in closed form whatever the number of
    /// pinned points: (k/2) [tr(Z P Z^T) + 2 <B, Z> + c] with P = sum m phi phi^T (4K x 4K),
    /// B = sum m (X - T) phi^T (3 x 4K), c = sum m |X - T|^2.
    pin_phi: DMatrix<f64>,
    pin_offset: DMatrix<f64>,
    pin_constant: f64,
    contacts: Vec<ReducedPoint>,
    obstacles: Vec<Obstacle>,
    pokes: Vec<(DVector<f64>, Poke)>,
    rest_hessian: Option<DMatrix<f64>>,
    preconditioner: Option<DenseCholesky>,
    /// Convergence threshold on |dz . g| (J), from the tolerance and the object's size.
    decrement_tolerance: f64,
    deformation: [Vec<f64>; 3],
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
            decrement_tolerance: subspace.total_mass() * length * length / (params.dt * params.dt),
            z: DMatrix::zeros(3, 4 * k),
            z_prev: DMatrix::zeros(3, 4 * k),
            time: 0.0,
            pins: Vec::new(),
            pin_phi: DMatrix::zeros(4 * k, 4 * k),
            pin_offset: DMatrix::zeros(3, 4 * k),
            pin_constant: 0.0,
            contacts: Vec::new(),
            obstacles: Vec::new(),
            pokes: Vec::new(),
            rest_hessian: None,
            preconditioner: None,
            deformation: Default::default(),
            subspace,
            params,
            solver,
        })
    }

    pub fn subspace(&self) -> &Subspace {
        &self.subspace
    }
    pub fn params(&self) -> &SimParams {
        &self.params
    }
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
    }

    /// Back to the rest pose, at rest, at time 0.
    pub fn reset(&mut self) {
        self.z.fill(0.0);
        self.z_prev.fill(0.0);
        self.time = 0.0;
    }

    /// Holds these material points (rest positions, masses in kg) at their rest positions by
    /// penalty springs.
    pub fn add_pins(&mut self, points: &[Vector3<f64>], masses: &[f64]) {
        for (phi, (x, m)) in self
            .subspace
            .phis(points)
            .into_iter()
            .zip(points.iter().zip(masses))
        {
            self.pin_phi.ger(*m, &phi, &phi, 1.0);
            self.pins.push(ReducedPoint {
                rest: *x,
                phi,
                weight: *m,
                target: *x,
            });
        }
        self.update_pin_offsets();
        self.preconditioner = None;
    }

    fn update_pin_offsets(&mut self) {
        self.pin_offset.fill(0.0);
        self.pin_constant = 0.0;
        for pin in &self.pins {
            let r = pin.rest - pin.target;
            self.pin_offset += (r * pin.weight) * pin.phi.transpose();
            self.pin_constant += pin.weight * r.norm_squared();
        }
    }

    /// Moves the pin targets (one per pinned point, in the order they were added).
    pub fn set_pin_targets(&mut self, targets: &[Vector3<f64>]) -> Result<()> {
        if targets.len() != self.pins.len() {
            return Err(Error::InvalidParameter {
                name: "pin targets",
                reason: format!("{} targets for {} pins", targets.len(), self.pins.len()),
            });
        }
        for (pin, t) in self.pins.iter_mut().zip(targets) {
            pin.target = *t;
        }
        self.update_pin_offsets();
        Ok(())
    }

    /// Surface points (rest positions, the area each stands for) that collide with obstacles.
    pub fn add_contact_points(&mut self, points: &[Vector3<f64>], areas: &[f64]) {
        for (phi, (x, a)) in self
            .subspace
            .phis(points)
            .into_iter()
            .zip(points.iter().zip(areas))
        {
            self.contacts.push(ReducedPoint {
                rest: *x,
                phi,
                weight: *a,
                target: *x,
            });
        }
    }

    pub fn add_obstacle(&mut self, obstacle: Obstacle) {
        self.obstacles.push(obstacle);
    }

    pub fn add_poke(&mut self, poke: Poke) {
        let phi = self.subspace.phis(&[poke.point]).remove(0);
        self.pokes.push((phi, poke));
    }

    /// Advances one time step.
    pub fn step(&mut self) -> StepReport {
        let started = Instant::now();
        let predicted = &self.z * 2.0 - &self.z_prev;
        let previous = self.z.clone();
        let mut z = predicted.clone();
        let mut report = StepReport::default();
        if self.solver == Solver::QuasiNewton && self.preconditioner.is_none() {
            self.preconditioner = Some(self.build_preconditioner());
        }
        let mut current = self.evaluate(&z, &predicted, &previous);
        let mut history: VecDeque<(DVector<f64>, DVector<f64>)> = VecDeque::new();
        for iteration in 0..=self.params.max_iterations {
            let gradient = flat(&current.gradient);
            let mut direction = match self.solver {
                Solver::Newton => self.newton_direction(&z, &gradient),
                Solver::QuasiNewton => self.lbfgs_direction(&gradient, &history),
            };
            let mut slope = direction.dot(&gradient);
            if !(slope < 0.0) && self.solver == Solver::QuasiNewton && !history.is_empty() {
                history.clear();
                direction = self.lbfgs_direction(&gradient, &history);
                slope = direction.dot(&gradient);
            }
            report.decrement = slope.abs();
            if report.decrement < self.decrement_tolerance || !slope.is_finite() {
                report.converged = slope.is_finite();
                break;
            }
            if iteration == self.params.max_iterations || !(slope < 0.0) {
                break;
            }
            let Some((step, next)) =
                self.line_search(&z, &direction, slope, &current, &predicted, &previous)
            else {
                break;
            };
            report.iterations += 1;
            let new_gradient = flat(&next.gradient);
            let s = &direction * step;
            let y = &new_gradient - &gradient;
            if s.dot(&y) > 1e-12 * s.norm() * y.norm() {
                history.push_back((s, y));
                if history.len() > LBFGS_PAIRS {
                    history.pop_front();
                }
            }
            z += unflat(&(&direction * step), self.subspace.handles());
            current = next;
        }
        self.z_prev = std::mem::replace(&mut self.z, z);
        self.time += self.params.dt;
        report.elastic_energy = current.elastic;
        let velocity = self.velocity();
        report.kinetic_energy = 0.5 * quadratic(&velocity, self.subspace.mass_phi());
        report.gravity_energy = -(&self.z * self.subspace.mass_moment()).dot(&self.params.gravity);
        report.seconds = started.elapsed().as_secs_f64();
        report
    }

    fn line_search(
        &mut self,
        z: &DMatrix<f64>,
        direction: &DVector<f64>,
        slope: f64,
        current: &Evaluation,
        predicted: &DMatrix<f64>,
        previous: &DMatrix<f64>,
    ) -> Option<(f64, Evaluation)> {
        let step_matrix = unflat(direction, self.subspace.handles());
        let mut step = 1.0;
        for _ in 0..40 {
            let trial = z + &step_matrix * step;
            let next = self.evaluate(&trial, predicted, previous);
            if next.energy.is_finite() && next.energy <= current.energy + ARMIJO * step * slope {
                return Some((step, next));
            }
            step *= 0.5;
        }
        None
    }

    /// The step objective, its elastic part and its gradient at `z`.
    fn evaluate(
        &mut self,
        z: &DMatrix<f64>,
        predicted: &DMatrix<f64>,
        previous: &DMatrix<f64>,
    ) -> Evaluation {
        let h = self.params.dt;
        let mass = self.subspace.mass_phi();
        let inertial = z - predicted;
        let damped = z - previous;
        let damping = self.params.damping;
        let mut energy = quadratic(&inertial, mass) / (2.0 * h * h)
            + damping * quadratic(&damped, mass) / (2.0 * h);
        let mut gradient = (&inertial * mass) / (h * h) + (&damped * mass) * (damping / h);

        let g = self.params.gravity;
        let moment = self.subspace.mass_moment();
        energy -= (z * moment).dot(&g);
        gradient -= g * moment.transpose();

        let elastic = self.add_elastic(z, &mut gradient);
        energy += elastic;

        if !self.pins.is_empty() {
            let k = self.params.pin_stiffness;
            let zp = z * &self.pin_phi;
            energy += 0.5
                * k
                * (zp.component_mul(z).sum()
                    + 2.0 * self.pin_offset.component_mul(z).sum()
                    + self.pin_constant);
            gradient += (zp + &self.pin_offset) * k;
        }
        let kc = self.params.contact_stiffness;
        for contact in &self.contacts {
            let x = contact.rest + z * &contact.phi;
            for obstacle in &self.obstacles {
                if let Some(p) = obstacle.penetration(&x) {
                    energy += 0.5 * kc * contact.weight * p.depth * p.depth;
                    gradient -=
                        (p.normal * (kc * contact.weight * p.depth)) * contact.phi.transpose();
                }
            }
        }
        for (phi, poke) in &self.pokes {
            if poke.start <= self.time && self.time < poke.end {
                energy -= poke.force.dot(&(z * phi));
                gradient -= poke.force * phi.transpose();
            }
        }
        Evaluation {
            energy,
            elastic,
            gradient,
        }
    }

    /// Adds the elastic force to `gradient`, returns the elastic energy.
    fn add_elastic(&mut self, z: &DMatrix<f64>, gradient: &mut DMatrix<f64>) -> f64 {
        let mut f = std::mem::take(&mut self.deformation);
        self.subspace.deformation_gradients(z, &mut f);
        let volumes = self.subspace.volumes();
        let material = self.material;
        let np = volumes.len();
        let mut stress: [Vec<f64>; 3] = [vec![0.0; 3 * np], vec![0.0; 3 * np], vec![0.0; 3 * np]];
        let chunk = 64;
        let energy: f64 = {
            let [s0, s1, s2] = &mut stress;
            s0.par_chunks_mut(3 * chunk)
                .zip(s1.par_chunks_mut(3 * chunk))
                .zip(s2.par_chunks_mut(3 * chunk))
                .enumerate()
                .map(|(c, ((s0, s1), s2))| {
                    let mut energy = 0.0;
                    for local in 0..s0.len() / 3 {
                        let p = c * chunk + local;
                        let fp = Matrix3::from_fn(|d, e| f[d][3 * p + e]);
                        let (psi, piola) = material.energy_and_first_piola(&fp);
                        let v = volumes[p];
                        energy += v * psi;
                        for e in 0..3 {
                            s0[3 * local + e] = v * piola[(0, e)];
                            s1[3 * local + e] = v * piola[(1, e)];
                            s2[3 * local + e] = v * piola[(2, e)];
                        }
                    }
                    energy
                })
                .sum()
        };
        *gradient += self.subspace.pull_back(&stress);
        self.deformation = f;
        energy
    }

    /// Inertia, damping and pins: the quadratic part, (4K x 4K) to be taken (x) I_3.
    fn quadratic_part(&self) -> DMatrix<f64> {
        let h = self.params.dt;
        self.subspace.mass_phi() * (1.0 / (h * h) + self.params.damping / h)
            + &self.pin_phi * self.params.pin_stiffness
    }

    fn newton_direction(&mut self, z: &DMatrix<f64>, gradient: &DVector<f64>) -> DVector<f64> {
        let mut f = std::mem::take(&mut self.deformation);
        self.subspace.deformation_gradients(z, &mut f);
        let material = self.material;
        let hessians: Vec<Matrix9> = (0..self.subspace.cubature_len())
            .into_par_iter()
            .map(|p| material.stress_derivative(&Matrix3::from_fn(|d, e| f[d][3 * p + e]), true))
            .collect();
        self.deformation = f;
        let mut hessian = self.subspace.elastic_hessian(&hessians);
        add_kron_identity(&mut hessian, &self.quadratic_part());
        let kc = self.params.contact_stiffness;
        for contact in &self.contacts {
            let x = contact.rest + z * &contact.phi;
            for obstacle in &self.obstacles {
                if let Some(p) = obstacle.penetration(&x) {
                    let a = point_jacobian(&contact.phi, &p.normal);
                    hessian.ger(kc * contact.weight, &a, &a, 1.0);
                }
            }
        }
        self.solve_or_descend(&hessian, gradient)
    }

    /// -H^-1 g, falling back to the preconditioner (or steepest descent) if H is not positive
    /// definite, which a PSD-projected Hessian plus mass should never be.
    fn solve_or_descend(
        &mut self,
        hessian: &DMatrix<f64>,
        gradient: &DVector<f64>,
    ) -> DVector<f64> {
        let mut direction = -gradient.clone();
        match DenseCholesky::new(hessian.as_slice(), hessian.nrows()) {
            Ok(chol) => chol.solve(direction.as_mut_slice()),
            Err(_) => {
                if self.preconditioner.is_none() {
                    self.preconditioner = Some(self.build_preconditioner());
                }
                if let Some(p) = &self.preconditioner {
                    p.solve(direction.as_mut_slice());
                }
            }
        }
        direction
    }

    fn build_preconditioner(&mut self) -> DenseCholesky {
        let k = self.subspace.handles();
        let rest = self.rest_hessian.get_or_insert_with(|| {
            let h = self.material.stress_derivative(&Matrix3::identity(), true);
            self.subspace
                .elastic_hessian(&vec![h; self.subspace.cubature_len()])
        });
        let mut matrix = rest.clone();
        add_kron_identity(&mut matrix, &self.quadratic_part());
        // Inertia makes it positive definite; the tiny ridge only guards round-off.
        for i in 0..12 * k {
            matrix[(i, i)] += 1e-12 * matrix[(i, i)].abs().max(1e-300);
        }
        DenseCholesky::new(matrix.as_slice(), 12 * k)
            .expect("inertia plus a PSD Hessian is positive definite")
    }

    /// The L-BFGS two-loop recursion with the factored rest Hessian as initial inverse.
    fn lbfgs_direction(
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

    /// Deformed positions of the pinned points (for reports and tests).
    pub fn pinned_positions(&self) -> Vec<Vector3<f64>> {
        self.pins
            .iter()
            .map(|p| p.rest + &self.z * &p.phi)
            .collect()
    }

    /// Deformed position of a material point given by its rest position.
    pub fn position_of(&self, rest: &Vector3<f64>) -> Vector3<f64> {
        let phi = self.subspace.phis(&[*rest]).remove(0);
        rest + &self.z * phi
    }
}

/// x^T M x summed over the three rows of a 3 x 4K matrix: tr(X M X^T).
fn quadratic(x: &DMatrix<f64>, m: &DMatrix<f64>) -> f64 {
    (x * m).component_mul(x).sum()
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

/// d(n . x)/dz for x = X + Z phi: the flat vector phi (x) n.
fn point_jacobian(phi: &DVector<f64>, n: &Vector3<f64>) -> DVector<f64> {
    DVector::from_fn(3 * phi.len(), |i, _| phi[i / 3] * n[i % 3])
}
