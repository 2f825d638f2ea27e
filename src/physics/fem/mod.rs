//! The full-space reference: tetrahedra of the same voxelized interior, the same material,
//! forces and implicit Euler objective as the reduced simulator, solved by Newton with a
//! PSD-projected Hessian and faer's sparse Cholesky. Pins here are exact (Dirichlet).

mod elements;

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{Matrix3, SMatrix, Vector3};
use rayon::prelude::*;

use self::elements::{jacobian, Elements};
use super::material::Material;
use super::obstacle::{carried_by, Anchors, Obstacle, Penetration, Stick};
use super::reduced::{is_descent, StepReport};
use super::scene::{Poke, SimParams};
use crate::error::Result;
use crate::geometry::TetMesh;
use crate::linalg::{ElementPattern, SparseCholesky};

/// The full-space reference simulation: every node of a tetrahedral mesh free (3 numbers
/// each), stepped by implicit Euler with the same physics as [`ReducedSim`](super::ReducedSim),
/// to measure the reduced simulation's error against. `N` nodes per element (`D` = 3 `N`
/// unknowns): the mesh's linear tetrahedra ([`FemSim::new`]) or quadratic ones
/// ([`FemSim::quadratic`]).
pub struct FemSim<const N: usize = 4, const D: usize = 12> {
    mesh: Arc<TetMesh>,
    params: SimParams,
    material: Material,
    elements: Elements<N>,
    masses: Vec<f64>,
    x: Vec<f64>,
    x_prev: Vec<f64>,
    rest: Vec<f64>,
    time: f64,
    fixed: Vec<bool>,
    /// Where the fixed coordinates are held: their rest positions unless moved.
    targets: Vec<f64>,
    obstacles: Vec<Obstacle>,
    /// Moving obstacles (robot links), replaced before each step.
    colliders: Vec<Obstacle>,
    /// The moving obstacles at the last step (friction carries what a link touches).
    colliders_before: Vec<Obstacle>,
    /// This step's friction: boundary vertices touching at its start.
    sticks: Vec<Stick>,
    /// Friction anchors of vertices resting on static obstacles.
    anchors: Anchors,
    pokes: Vec<(usize, Poke)>,
    pattern: ElementPattern,
    cholesky: SparseCholesky,
    decrement_tolerance: f64,
}

struct Evaluation {
    energy: f64,
    elastic: f64,
    gradient: Vec<f64>,
}

const ELEMENT_CHUNK: usize = 4096;
/// The elastic gradient is summed over this many chunks of tetrahedra, whatever the threads:
/// the same sums in the same order on every machine and run.
const GRADIENT_CHUNKS: usize = 32;

/// The element a [`FemSim`] is built of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FemElement {
    /// Linear tetrahedra ([`FemSim::new`]).
    #[default]
    Linear,
    /// Quadratic tetrahedra ([`FemSim::quadratic`]).
    Quadratic,
}

impl FemSim<4, 12> {
    /// A simulation of `mesh` (world units, m) at rest, on its linear tetrahedra. An error when
    /// `params` are out of range (`Error::InvalidParameter`) or the sparse pattern cannot be
    /// analysed (`Error::LinearAlgebra`).
    pub fn new(mesh: Arc<TetMesh>, params: SimParams) -> Result<Self> {
        let elements = Elements::linear(&mesh);
        Self::with_elements(mesh, params, elements)
    }
}

impl FemSim<10, 30> {
    /// A simulation of `mesh` (world units, m) at rest, on quadratic tetrahedra: a node at each
    /// edge's middle besides the mesh's vertices. It bends where linear tetrahedra lock (a thin
    /// part with few cells through it), for some seven times the unknowns. Contacts and pokes
    /// act on the mesh's vertices. Errors as [`FemSim::new`].
    pub fn quadratic(mesh: Arc<TetMesh>, params: SimParams) -> Result<Self> {
        let elements = Elements::quadratic(&mesh);
        Self::with_elements(mesh, params, elements)
    }
}

impl<const N: usize, const D: usize> FemSim<N, D> {
    fn with_elements(mesh: Arc<TetMesh>, params: SimParams, elements: Elements<N>) -> Result<Self> {
        assert_eq!(D, 3 * N, "three unknowns per node");
        params.validate()?;
        let masses: Vec<f64> = elements
            .lumped_volumes
            .iter()
            .map(|v| v * params.density)
            .collect();
        let rest = elements.rest_positions(&mesh);
        let pattern = ElementPattern::new(masses.len(), 3, &elements.nodes);
        let cholesky = pattern.cholesky()?;
        let diagonal = {
            let (lo, hi) = mesh.bounds();
            (hi - lo).norm()
        };
        let length = params.tolerance * diagonal;
        let total_mass: f64 = masses.iter().sum();
        Ok(Self {
            material: params.material(),
            decrement_tolerance: total_mass * length * length / (params.dt * params.dt),
            elements,
            masses,
            x: rest.clone(),
            x_prev: rest.clone(),
            fixed: vec![false; rest.len()],
            targets: rest.clone(),
            rest,
            time: 0.0,
            obstacles: Vec::new(),
            colliders: Vec::new(),
            colliders_before: Vec::new(),
            sticks: Vec::new(),
            anchors: Anchors::default(),
            pokes: Vec::new(),
            pattern,
            cholesky,
            mesh,
            params,
        })
    }

    /// The tetrahedral mesh simulated.
    pub fn mesh(&self) -> &TetMesh {
        &self.mesh
    }
    /// The parameters it was made with.
    pub fn params(&self) -> &SimParams {
        &self.params
    }
    /// Simulated time, s (`dt` per step).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// The mesh's vertex positions, x y z per vertex.
    pub fn positions(&self) -> &[f64] {
        &self.x[..3 * self.mesh.vertices.len()]
    }
    /// Nodes simulated: the mesh's vertices and any between them.
    pub fn nodes(&self) -> usize {
        self.masses.len()
    }
    /// Lumped mass per node (the mesh's vertices first), kg.
    pub fn vertex_masses(&self) -> &[f64] {
        &self.masses
    }

    /// Starts from these vertex positions (x y z per vertex of the mesh; nodes between vertices
    /// halfway between them), at rest velocity.
    pub fn set_positions(&mut self, positions: &[f64]) {
        let vertices = positions.len();
        assert_eq!(
            vertices,
            3 * self.mesh.vertices.len(),
            "one position per vertex"
        );
        self.x[..vertices].copy_from_slice(positions);
        self.elements.interpolate_edges(&mut self.x);
        self.x_prev.copy_from_slice(&self.x);
    }

    /// Fixes these vertices at their rest positions.
    pub fn pin_vertices(&mut self, vertices: &[usize]) {
        for &v in vertices {
            for d in 0..3 {
                self.fixed[3 * v + d] = true;
            }
        }
        self.elements.fix_edges(&mut self.fixed, &mut self.targets);
    }

    /// Holds these vertices at `motion` applied to their rest positions (and fixes them).
    pub fn move_pinned(&mut self, vertices: &[usize], motion: &nalgebra::Isometry3<f64>) {
        for &v in vertices {
            let target = motion.transform_point(&self.mesh.vertices[v].into());
            self.targets[3 * v..3 * v + 3].copy_from_slice(target.coords.as_slice());
        }
        self.pin_vertices(vertices);
    }

    /// Adds a static obstacle.
    pub fn add_obstacle(&mut self, obstacle: Obstacle) {
        self.obstacles.push(obstacle);
    }

    /// Replaces the moving obstacles for the next step.
    pub fn set_colliders(&mut self, colliders: Vec<Obstacle>) {
        self.colliders = colliders;
    }

    /// Applies the poke at the vertex nearest its point.
    pub fn add_poke(&mut self, poke: Poke) {
        let nearest = (0..self.mesh.vertices.len())
            .min_by(|&a, &b| {
                let da = (self.mesh.vertices[a] - poke.point).norm_squared();
                let db = (self.mesh.vertices[b] - poke.point).norm_squared();
                da.total_cmp(&db)
            })
            .expect("a mesh has vertices");
        self.pokes.push((nearest, poke));
    }

    /// Advances one implicit Euler step of `dt`. An error when the sparse Cholesky
    /// factorization of a Newton step fails.
    pub fn step(&mut self) -> Result<StepReport> {
        let started = Instant::now();
        let predicted: Vec<f64> = self
            .x
            .iter()
            .zip(&self.x_prev)
            .map(|(a, b)| 2.0 * a - b)
            .collect();
        let previous = self.x.clone();
        let mut x: Vec<f64> = predicted
            .iter()
            .zip(&self.targets)
            .zip(&self.fixed)
            .map(|((p, t), f)| if *f { *t } else { *p })
            .collect();
        let mut report = StepReport::default();
        self.find_sticks();
        let mut current = self.evaluate(&x, &predicted, &previous);
        for iteration in 0..=self.params.max_iterations {
            let mut direction: Vec<f64> = current.gradient.iter().map(|g| -g).collect();
            let values = self.hessian(&x);
            self.cholesky.factor(&self.pattern, &values)?;
            self.cholesky.solve(&mut direction, self.x.len());
            let slope: f64 = direction
                .iter()
                .zip(&current.gradient)
                .map(|(d, g)| d * g)
                .sum();
            report.decrement = slope.abs();
            if report.decrement < self.decrement_tolerance {
                report.converged = true;
                break;
            }
            if iteration == self.params.max_iterations || !is_descent(slope) {
                break;
            }
            let mut step = 1.0;
            let mut accepted = None;
            for _ in 0..40 {
                let trial: Vec<f64> = x
                    .iter()
                    .zip(&direction)
                    .map(|(a, d)| a + step * d)
                    .collect();
                let next = self.evaluate(&trial, &predicted, &previous);
                if next.energy.is_finite() && next.energy <= current.energy + 1e-4 * step * slope {
                    accepted = Some((trial, next));
                    break;
                }
                step *= 0.5;
            }
            let Some((trial, next)) = accepted else { break };
            report.iterations += 1;
            x = trial;
            current = next;
        }
        self.x_prev = std::mem::replace(&mut self.x, x);
        self.colliders_before = self.colliders.clone();
        self.time += self.params.dt;
        let h = self.params.dt;
        report.elastic_energy = current.elastic;
        report.kinetic_energy = (0..self.x.len())
            .map(|i| 0.5 * self.masses[i / 3] * ((self.x[i] - self.x_prev[i]) / h).powi(2))
            .sum();
        report.gravity_energy = -(0..self.x.len())
            .map(|i| self.masses[i / 3] * self.params.gravity[i % 3] * (self.x[i] - self.rest[i]))
            .sum::<f64>();
        report.seconds = started.elapsed().as_secs_f64();
        Ok(report)
    }

    /// The deformation gradient at quadrature point `q` of element `e`.
    fn deformation(&self, e: usize, q: usize, x: &[f64]) -> Matrix3<f64> {
        let mut f = Matrix3::zeros();
        for (&v, g) in self.elements.nodes[e]
            .iter()
            .zip(&self.elements.gradients[q])
        {
            let v = 3 * v as usize;
            f += Vector3::new(x[v], x[v + 1], x[v + 2]) * g.transpose();
        }
        f
    }

    /// Adds element `e`'s elastic force term to `gradient`; its elastic energy.
    fn add_elastic_gradient(&self, e: usize, x: &[f64], gradient: &mut [f64]) -> f64 {
        let mut energy = 0.0;
        for q in self.elements.points(e) {
            let (psi, piola) = self
                .material
                .energy_and_first_piola(&self.deformation(e, q, x));
            let weight = self.elements.weights[q];
            for (&v, g) in self.elements.nodes[e]
                .iter()
                .zip(&self.elements.gradients[q])
            {
                let force = piola * g * weight;
                for d in 0..3 {
                    gradient[3 * v as usize + d] += force[d];
                }
            }
            energy += weight * psi;
        }
        energy
    }

    fn evaluate(&self, x: &[f64], predicted: &[f64], previous: &[f64]) -> Evaluation {
        let h = self.params.dt;
        let n = x.len();
        // Fixed chunks, summed in order: rayon's fold splits by work stealing, and its sums
        // in whatever order made the reference's last digits (and `bench track`'s) differ
        // from run to run.
        let elements = self.elements.nodes.len();
        let chunk = elements.div_ceil(GRADIENT_CHUNKS).max(1);
        let partials: Vec<(f64, Vec<f64>)> = (0..elements.div_ceil(chunk))
            .into_par_iter()
            .map(|c| {
                let mut gradient = vec![0.0; n];
                let mut energy = 0.0;
                for e in c * chunk..((c + 1) * chunk).min(elements) {
                    energy += self.add_elastic_gradient(e, x, &mut gradient);
                }
                (energy, gradient)
            })
            .collect();
        let mut elastic = 0.0;
        let mut gradient = vec![0.0; n];
        for (energy, part) in &partials {
            elastic += energy;
            gradient.iter_mut().zip(part).for_each(|(a, b)| *a += b);
        }
        let mut energy = elastic;
        let g = self.params.gravity;
        for i in 0..n {
            let m = self.masses[i / 3];
            let inertial = x[i] - predicted[i];
            let damped = x[i] - previous[i];
            energy += m * inertial * inertial / (2.0 * h * h)
                + self.params.damping * m * damped * damped / (2.0 * h)
                - m * g[i % 3] * (x[i] - self.rest[i]);
            gradient[i] +=
                m * inertial / (h * h) + self.params.damping * m * damped / h - m * g[i % 3];
        }
        let kc = self.params.contact_stiffness;
        for (v, area, pen) in self.contacts(x) {
            energy += 0.5 * kc * area * pen.depth * pen.depth;
            for d in 0..3 {
                gradient[3 * v + d] -= kc * area * pen.depth * pen.normal[d];
            }
        }
        for stick in &self.sticks {
            let v = stick.point;
            let (e, g) =
                stick.energy_and_gradient(&Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2]));
            energy += e;
            for d in 0..3 {
                gradient[3 * v + d] += g[d];
            }
        }
        for (v, poke) in &self.pokes {
            if poke.start <= self.time && self.time < poke.end {
                for d in 0..3 {
                    energy -= poke.force[d] * (x[3 * v + d] - self.rest[3 * v + d]);
                    gradient[3 * v + d] -= poke.force[d];
                }
            }
        }
        for (g, fixed) in gradient.iter_mut().zip(&self.fixed) {
            if *fixed {
                *g = 0.0;
            }
        }
        Evaluation {
            energy,
            elastic,
            gradient,
        }
    }

    /// Friction for this step, as the reduced simulator does it: anchors kept on static
    /// obstacles while a vertex touches, carried by the move of moving ones.
    fn find_sticks(&mut self) {
        self.sticks.clear();
        let (kc, mu) = (self.params.contact_stiffness, self.params.friction);
        if mu == 0.0 {
            return;
        }
        let statics = self.obstacles.len();
        let mut sticks = Vec::new();
        for (&v, &area) in self
            .mesh
            .boundary_vertices
            .iter()
            .zip(&self.mesh.boundary_areas)
        {
            let v = v as usize;
            let x = Vector3::new(self.x[3 * v], self.x[3 * v + 1], self.x[3 * v + 2]);
            for (o, obstacle) in self.obstacles.iter().chain(&self.colliders).enumerate() {
                let Some(p) = obstacle.penetration(&x) else {
                    continue;
                };
                let (before, now) = (&self.colliders_before, &self.colliders);
                let (anchor, slip) = self.anchors.tie((v, o), &x, &p.normal, |a| {
                    carried_by(before, now, statics, o, a)
                });
                sticks.extend(Stick::new(v, anchor, &p, area, kc, mu).map(|s| s.after_slip(slip)));
            }
        }
        self.sticks = sticks;
        self.anchors.end_step();
    }

    /// Boundary vertices inside an obstacle at positions `x`: (vertex, area, penetration).
    fn contacts<'a>(
        &'a self,
        x: &'a [f64],
    ) -> impl Iterator<Item = (usize, f64, Penetration)> + 'a {
        let boundary = self
            .mesh
            .boundary_vertices
            .iter()
            .zip(&self.mesh.boundary_areas);
        boundary.flat_map(move |(&v, &area)| {
            let v = v as usize;
            let p = Vector3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2]);
            self.obstacles
                .iter()
                .chain(&self.colliders)
                .filter_map(move |o| o.penetration(&p))
                .map(move |pen| (v, area, pen))
        })
    }

    /// Element `e`'s elastic Hessian, each point's projected to be positive semi-definite.
    fn element_hessian(&self, e: usize, x: &[f64]) -> SMatrix<f64, D, D> {
        let mut local = SMatrix::<f64, D, D>::zeros();
        for q in self.elements.points(e) {
            let h9 = self
                .material
                .stress_derivative(&self.deformation(e, q, x), true);
            let j = jacobian::<N, D>(&self.elements.gradients[q]);
            local += j.transpose() * (h9 * j) * self.elements.weights[q];
        }
        local
    }

    /// The projected Hessian of the step objective (upper triangle values of the pattern).
    fn hessian(&self, x: &[f64]) -> Vec<f64> {
        let mut values = self.pattern.zeros();
        let elements = self.elements.nodes.len();
        for start in (0..elements).step_by(ELEMENT_CHUNK) {
            let end = (start + ELEMENT_CHUNK).min(elements);
            let locals: Vec<SMatrix<f64, D, D>> = (start..end)
                .into_par_iter()
                .map(|e| self.element_hessian(e, x))
                .collect();
            for (offset, local) in locals.iter().enumerate() {
                // Local matrices are symmetric, so column-major storage reads as row-major.
                self.pattern
                    .add_element(&mut values, start + offset, local.as_slice());
            }
        }
        let h = self.params.dt;
        for i in 0..x.len() {
            let m = self.masses[i / 3];
            self.pattern
                .add_diagonal(&mut values, i, m / (h * h) + self.params.damping * m / h);
        }
        let kc = self.params.contact_stiffness;
        for (v, area, pen) in self.contacts(x) {
            for d in 0..3 {
                for f in d..3 {
                    let value = kc * area * pen.normal[d] * pen.normal[f];
                    self.pattern
                        .add_at(&mut values, 3 * v + d, 3 * v + f, value);
                }
            }
        }
        for stick in &self.sticks {
            let v = stick.point;
            for d in 0..3 {
                for f in d..3 {
                    let value: f64 = stick
                        .tangents
                        .iter()
                        .map(|t| stick.curvature * t[d] * t[f])
                        .sum();
                    self.pattern
                        .add_at(&mut values, 3 * v + d, 3 * v + f, value);
                }
            }
        }
        self.pattern.constrain(&mut values, &self.fixed);
        values
    }
}

#[cfg(test)]
mod tests;
