//! The non-learned baseline: skinning eigenmodes (Benchekroun et al. 2023). The smallest
//! generalized eigenvectors of the volume-weighted Dirichlet Laplacian of a tetrahedral mesh
//! against its lumped mass. For an isotropic linear material the sum of the three diagonal
//! blocks of the rest elastic Hessian is (4 mu + lambda) times this Laplacian, so the modes are
//! the same. The first mode is the constant.

use nalgebra::{DMatrix, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::SkinningField;
use crate::error::{Error, Result};
use crate::geometry::{Normalization, TetMesh};
use crate::linalg::{ElementPattern, SparseCholesky};

/// How the modes are computed.
#[derive(Clone, Copy, Debug)]
pub struct EigenmodeOptions {
    /// Non-constant modes wanted (the constant one is added). Default 16.
    pub modes: usize,
    /// Relative residual at which a mode counts as converged. Default 1e-6.
    pub tolerance: f64,
    /// Subspace iterations before giving up. Default 500.
    pub max_iterations: usize,
}

impl Default for EigenmodeOptions {
    fn default() -> Self {
        Self {
            modes: 16,
            tolerance: 1e-6,
            max_iterations: 500,
        }
    }
}

/// Eigenmode weights stored at the vertices of a tetrahedral mesh, interpolated linearly.
pub struct EigenmodeField {
    mesh: TetMesh,
    /// `mesh` grown by a layer of cells, where the field is looked up ([`TetMesh::dilated`]).
    lookup: TetMesh,
    normalization: Normalization,
    /// Row-major, `lookup`'s vertices x handles (`mesh`'s vertices first); column 0 is the
    /// constant 1, each other column is scaled to a largest magnitude of 1 on `mesh`, and the
    /// added layer continues them.
    nodal: Vec<f64>,
    handles: usize,
    /// Generalized eigenvalues (1/m^2), the constant's 0 first.
    pub eigenvalues: Vec<f64>,
    /// Subspace iterations the solve took.
    pub iterations: usize,
    /// The name [`SkinningField::kind`] gives: "eigen", or "refined" for a refined field.
    kind: &'static str,
}

impl EigenmodeField {
    /// Computes the modes of `mesh` (world units); the field answers in the frame of `normalization`.
    pub fn compute(
        mesh: TetMesh,
        normalization: Normalization,
        options: &EigenmodeOptions,
    ) -> Result<Self> {
        let n = mesh.vertices.len();
        if options.modes + 1 > n {
            return Err(Error::InvalidParameter {
                name: "modes",
                reason: format!(
                    "{} modes need more than the mesh's {n} vertices",
                    options.modes
                ),
            });
        }
        let problem = ModeProblem::assemble(&mesh);
        let solve = smallest_modes(&problem, options)?;
        Ok(Self::from_modes(
            mesh,
            normalization,
            &solve.vectors,
            &solve.values,
            solve.iterations,
            "eigen",
        ))
    }

    /// The field of given non-constant vertex columns (`columns`: vertices x m, one column per
    /// mode, any scale), e.g. modes solved elsewhere: the constant is put first and each column
    /// is scaled as [`EigenmodeField::compute`] scales its modes. `values` are the columns'
    /// Rayleigh quotients (1/m^2); `iterations` is kept as the solve's count.
    pub fn from_columns(
        mesh: TetMesh,
        normalization: Normalization,
        columns: &DMatrix<f64>,
        values: &[f64],
        iterations: usize,
    ) -> Result<Self> {
        let n = mesh.vertices.len();
        if columns.nrows() != n || values.len() != columns.ncols() {
            return Err(Error::InvalidParameter {
                name: "columns",
                reason: format!(
                    "{} x {} columns with {} values for a mesh of {n} vertices",
                    columns.nrows(),
                    columns.ncols(),
                    values.len()
                ),
            });
        }
        Ok(Self::from_modes(
            mesh,
            normalization,
            columns,
            values,
            iterations,
            "eigen",
        ))
    }

    /// The field of `vectors` (vertices x modes, checked by the callers), under `kind`.
    pub(super) fn from_modes(
        mesh: TetMesh,
        normalization: Normalization,
        vectors: &DMatrix<f64>,
        values: &[f64],
        iterations: usize,
        kind: &'static str,
    ) -> Self {
        let n = mesh.vertices.len();
        let handles = vectors.ncols() + 1;
        let mut nodal = vec![0.0; n * handles];
        for v in 0..n {
            nodal[v * handles] = 1.0;
        }
        for h in 1..handles {
            let column = vectors.column(h - 1);
            let largest = column.amax().max(1e-300);
            // Sign convention so that reruns give identical fields: the largest entry is positive.
            let sign = if column[column.iamax()] < 0.0 {
                -1.0
            } else {
                1.0
            };
            for v in 0..n {
                nodal[v * handles + h] = sign * column[v] / largest;
            }
        }
        let mut eigenvalues = vec![0.0];
        eigenvalues.extend_from_slice(values);
        let lookup = mesh.dilated();
        lookup.extend_nodal(n, &mut nodal, handles);
        Self {
            mesh,
            lookup,
            normalization,
            nodal,
            handles,
            eigenvalues,
            iterations,
            kind,
        }
    }

    /// The same field with only the first `modes` non-constant modes (eigenmodes are nested:
    /// the m smallest are a prefix of the m' > m smallest).
    pub fn truncated(&self, modes: usize) -> Self {
        let handles = (modes + 1).min(self.handles);
        let n = self.lookup.vertices.len();
        let mut nodal = Vec::with_capacity(n * handles);
        for v in 0..n {
            nodal.extend_from_slice(&self.vertex_weights(v)[..handles]);
        }
        Self {
            mesh: self.mesh.clone(),
            lookup: self.lookup.clone(),
            normalization: self.normalization,
            nodal,
            handles,
            eigenvalues: self.eigenvalues[..handles].to_vec(),
            iterations: self.iterations,
            kind: self.kind,
        }
    }

    /// The map between world units and the normalized frame the field answers in.
    pub fn normalization(&self) -> &Normalization {
        &self.normalization
    }

    /// The tetrahedral mesh the modes are stored on (world units).
    pub fn mesh(&self) -> &TetMesh {
        &self.mesh
    }

    /// The weights at mesh vertex `v` (exact nodal values, no interpolation; indices past
    /// the mesh's vertices are those of the layer around it).
    pub fn vertex_weights(&self, v: usize) -> &[f64] {
        &self.nodal[v * self.handles..(v + 1) * self.handles]
    }
}

impl SkinningField for EigenmodeField {
    fn handle_count(&self) -> usize {
        self.handles
    }

    fn evaluate(
        &self,
        points: &[Vector3<f64>],
        weights: &mut [f64],
        mut gradients: Option<&mut [Vector3<f64>]>,
    ) {
        let k = self.handles;
        for (i, p) in points.iter().enumerate() {
            let location = self.lookup.locate(&self.normalization.to_world(p));
            let row = &mut weights[i * k..(i + 1) * k];
            row.iter_mut().for_each(|w| *w = 0.0);
            for (corner, &v) in location.vertices.iter().enumerate() {
                let nodal = self.vertex_weights(v as usize);
                for h in 0..k {
                    row[h] += location.barycentric[corner] * nodal[h];
                }
            }
            if let Some(gradients) = gradients.as_deref_mut() {
                let row = &mut gradients[i * k..(i + 1) * k];
                row.iter_mut().for_each(|g| *g = Vector3::zeros());
                for (corner, &v) in location.vertices.iter().enumerate() {
                    let nodal = self.vertex_weights(v as usize);
                    // d/dX_normalized = scale * d/dX_world.
                    let g = location.gradients[corner] * self.normalization.scale;
                    for h in 0..k {
                        row[h] += g * nodal[h];
                    }
                }
            }
        }
    }

    fn kind(&self) -> &'static str {
        self.kind
    }
}

/// Gradients of the four linear basis functions of a tetrahedron, and its volume.
pub(crate) fn linear_gradients(p: &[Vector3<f64>; 4]) -> ([Vector3<f64>; 4], f64) {
    let d = nalgebra::Matrix3::from_columns(&[p[1] - p[0], p[2] - p[0], p[3] - p[0]]);
    let volume = d.determinant().abs() / 6.0;
    let inv_t = d
        .try_inverse()
        .expect("tetrahedra of a voxel mesh are not degenerate")
        .transpose();
    let g1 = inv_t.column(0).into_owned();
    let g2 = inv_t.column(1).into_owned();
    let g3 = inv_t.column(2).into_owned();
    ([-(g1 + g2 + g3), g1, g2, g3], volume)
}

struct ModeSolve {
    values: Vec<f64>,
    vectors: DMatrix<f64>,
    iterations: usize,
}

/// The discrete problem the modes solve, shared with [`super::refine`]: the volume-weighted
/// Dirichlet Laplacian L of a tetrahedral mesh (upper triangle on `pattern`) and its lumped
/// mass M (diagonal). L's null space is the constant, removed M-orthogonally by `deflate`.
pub(crate) struct ModeProblem {
    pub pattern: ElementPattern,
    pub laplacian: Vec<f64>,
    pub mass: Vec<f64>,
    total_mass: f64,
}

impl ModeProblem {
    /// L and M of `mesh` (world units).
    pub fn assemble(mesh: &TetMesh) -> Self {
        let n = mesh.vertices.len();
        let pattern = ElementPattern::new(n, 1, &mesh.tets);
        let mut laplacian = pattern.zeros();
        for (e, tet) in mesh.tets.iter().enumerate() {
            let (gradients, volume) = linear_gradients(&tet.map(|v| mesh.vertices[v as usize]));
            let mut local = [0.0; 16];
            for a in 0..4 {
                for b in 0..4 {
                    local[a * 4 + b] = volume * gradients[a].dot(&gradients[b]);
                }
            }
            pattern.add_element(&mut laplacian, e, &local);
        }
        let mass = mesh.lumped_volumes();
        let total_mass = mass.iter().sum();
        Self {
            pattern,
            laplacian,
            mass,
            total_mass,
        }
    }

    /// The number of unknowns (mesh vertices).
    pub fn size(&self) -> usize {
        self.mass.len()
    }

    /// Removes from `x` its M-weighted mean, the part along the constant.
    pub fn deflate(&self, x: &mut [f64]) {
        let c: f64 = x.iter().zip(&self.mass).map(|(a, m)| a * m).sum::<f64>() / self.total_mass;
        x.iter_mut().for_each(|a| *a -= c);
    }

    /// [`ModeProblem::deflate`] on every column.
    pub fn deflate_columns(&self, x: &mut DMatrix<f64>) {
        for mut column in x.column_iter_mut() {
            self.deflate(column.as_mut_slice());
        }
    }

    /// M x.
    pub fn mass_times(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let mut y = x.clone();
        for mut column in y.column_iter_mut() {
            column.iter_mut().zip(&self.mass).for_each(|(a, m)| *a *= m);
        }
        y
    }

    /// L x, the columns in parallel.
    pub fn laplacian_times(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let n = self.size();
        let mut y = DMatrix::<f64>::zeros(n, x.ncols());
        if n > 0 {
            y.as_mut_slice()
                .par_chunks_mut(n)
                .zip(x.as_slice().par_chunks(n))
                .for_each(|(out, column)| self.pattern.multiply(&self.laplacian, column, out));
        }
        y
    }

    /// The sparse Cholesky of L + sigma M, with a sigma small enough not to blur the low
    /// spectrum (1e-8 of mean(L_ii / M_ii), the scale of the largest eigenvalues) that makes
    /// it positive definite.
    pub fn shifted_cholesky(&self) -> Result<SparseCholesky> {
        let diagonal = self.pattern.diagonal(&self.laplacian);
        let scale = diagonal
            .iter()
            .zip(&self.mass)
            .map(|(l, m)| l / m)
            .sum::<f64>()
            / self.size() as f64;
        let sigma = 1e-8 * scale;
        let mut shifted = self.laplacian.to_vec();
        for (i, m) in self.mass.iter().enumerate() {
            self.pattern.add_diagonal(&mut shifted, i, sigma * m);
        }
        let mut cholesky = self.pattern.cholesky()?;
        cholesky.factor(&self.pattern, &shifted)?;
        Ok(cholesky)
    }

    /// Y = (L + sigma M)^-1 M X with `cholesky` from [`ModeProblem::shifted_cholesky`], kept
    /// orthogonal to the constant.
    pub fn inverse_iterate(&self, cholesky: &SparseCholesky, x: &DMatrix<f64>) -> DMatrix<f64> {
        let mut y = self.mass_times(x);
        cholesky.solve(y.as_mut_slice(), self.size());
        self.deflate_columns(&mut y);
        y
    }
}

/// The `options.modes` smallest nonzero generalized eigenpairs of L v = lambda M v (M diagonal),
/// by shift-invert subspace iteration with Rayleigh-Ritz, in the M-orthogonal complement of the
/// constant (L's null space, deflated exactly so it cannot swamp the block).
fn smallest_modes(problem: &ModeProblem, options: &EigenmodeOptions) -> Result<ModeSolve> {
    let n = problem.size();
    let want = options.modes;
    let block = (want + want.max(10)).min(n - 1);
    let cholesky = problem.shifted_cholesky()?;

    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut x = DMatrix::<f64>::from_fn(n, block, |_, _| rng.random::<f64>() - 0.5);
    let mut values = vec![0.0; block];
    let mut worst = f64::INFINITY;
    for iteration in 1..=options.max_iterations {
        // Y = (L + sigma M)^-1 M X, kept orthogonal to the constant; Rayleigh-Ritz on span(Y).
        let y = problem.inverse_iterate(&cholesky, &x);
        let ly = problem.laplacian_times(&y);
        let my = problem.mass_times(&y);
        let reduced_l = y.transpose() * &ly;
        let reduced_m = y.transpose() * &my;
        let reduced_m = (&reduced_m + reduced_m.transpose()) * 0.5;
        let chol = reduced_m.cholesky().ok_or_else(|| {
            Error::LinearAlgebra("eigen-solve: the iterated block lost rank".into())
        })?;
        let l_inv = chol
            .l()
            .try_inverse()
            .ok_or_else(|| Error::LinearAlgebra("eigen-solve: singular block".into()))?;
        let c = &l_inv * reduced_l * l_inv.transpose();
        let c = (&c + c.transpose()) * 0.5;
        let eig = c.symmetric_eigen();
        let mut order: Vec<usize> = (0..block).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
        let q = DMatrix::from_fn(block, block, |r, c| eig.eigenvectors[(r, order[c])]);
        values = order.iter().map(|&i| eig.eigenvalues[i]).collect();
        let coefficients = l_inv.transpose() * q;
        x = &y * &coefficients;
        let lxs = &ly * &coefficients;
        let mxs = &my * &coefficients;
        worst = (0..want)
            .map(|j| {
                let residual = (lxs.column(j) - mxs.column(j) * values[j]).norm();
                residual / ((values[j] + values[want - 1]) * mxs.column(j).norm()).max(1e-300)
            })
            .fold(0.0, f64::max);
        if worst < options.tolerance {
            return Ok(ModeSolve {
                values: values[..want].to_vec(),
                vectors: x.columns(0, want).into_owned(),
                iterations: iteration,
            });
        }
    }
    Err(Error::EigenNotConverged {
        converged: 0,
        wanted: want,
        iterations: options.max_iterations,
        residual: worst,
    })
}
