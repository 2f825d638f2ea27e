//! The reduced space of one object: a skinning field sampled at cubature points, and what the
//! dynamics needs from it, computed once per shape.
//!
//! With handles Z_i = [A_i | t_i] (3 x 4) and X~ = [X; 1], the displacement is
//! u(X) = sum_i w_i(X) Z_i X~ = Z phi(X), where Z = [Z_1 .. Z_K] is 3 x 4K and
//! phi = w (x) X~ (4K). The reduced state z is Z flattened column-major (z[3a + d] = Z[d, a]),
//! so each handle owns 12 consecutive numbers. The deformation gradient is F = I + Z G(X) with
//! G = d phi / dX (4K x 3): row 4i + c of G is w_i e_c^T + X~_c grad w_i^T.

use std::sync::Arc;

use faer::{MatMut, MatRef, Par};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;

use super::material::{polar_rotation, Material, Matrix9};

use crate::geometry::{Cubature, Normalization};
use crate::skinning::SkinningField;

/// Cubature points times 4K below which a pass over the points runs on one thread: with 2
/// threads, handing half of a small pass to the other costs more than it saves.
const PARALLEL_WORK: usize = 65_536;

/// A skinning subspace sampled at a cubature set (world units).
pub struct Subspace {
    field: Arc<dyn SkinningField>,
    handles: usize,
    normalization: Normalization,
    /// Cubature volumes, m^3.
    volumes: Vec<f64>,
    /// G of every cubature point side by side: (4K) rows x (3 Np) columns, row-major, so that
    /// F = I + Z G is a sweep of long contiguous rows.
    g_all: Vec<f64>,
    /// sum_p rho v_p phi_p phi_p^T (4K x 4K); the reduced mass is this (x) I_3.
    mass_phi: DMatrix<f64>,
    /// sum_p rho v_p phi_p (4K); gravity's reduced force is this (x) g.
    mass_moment: DVector<f64>,
    /// The volume-weighted mean of G (4K x 3): the body's mean deformation gradient is
    /// I + Z times this.
    mean_gradient: DMatrix<f64>,
    total_mass: f64,
    density: f64,
}

impl Subspace {
    /// Samples `field` at the cubature points (world units, mapped through `normalization`).
    pub fn build(
        field: Arc<dyn SkinningField>,
        normalization: Normalization,
        cubature: &Cubature,
        density: f64,
    ) -> Self {
        let k = field.handle_count();
        let np = cubature.len();
        let (weights, gradients) = sample(field.as_ref(), &normalization, &cubature.points, true);
        let gradients = gradients.expect("asked for gradients");
        let columns = 3 * np;
        let mut g_all = vec![0.0; 4 * k * columns];
        let mut mass_phi = DMatrix::zeros(4 * k, 4 * k);
        let mut mass_moment = DVector::zeros(4 * k);
        for p in 0..np {
            let x = cubature.points[p];
            let xt = [x.x, x.y, x.z, 1.0];
            for i in 0..k {
                let w = weights[p * k + i];
                let gw = gradients[p * k + i];
                for (c, xc) in xt.iter().enumerate() {
                    let row = 4 * i + c;
                    for e in 0..3 {
                        let identity = if c == e { w } else { 0.0 };
                        g_all[row * columns + 3 * p + e] = identity + xc * gw[e];
                    }
                }
            }
            let phi = phi_of(&weights[p * k..(p + 1) * k], &x);
            let m = density * cubature.volumes[p];
            mass_phi.ger(m, &phi, &phi, 1.0);
            mass_moment.axpy(m, &phi, 1.0);
        }
        let mean_gradient = mean_gradient(&g_all, &cubature.volumes, 4 * k);
        Self {
            mean_gradient,
            field,
            handles: k,
            normalization,
            volumes: cubature.volumes.clone(),
            g_all,
            mass_phi,
            mass_moment,
            total_mass: density * cubature.total_volume(),
            density,
        }
    }

    /// The skinning field sampled.
    pub fn field(&self) -> &dyn SkinningField {
        self.field.as_ref()
    }

    /// phi = w (x) [X; 1] at world points.
    pub fn phis(&self, points: &[Vector3<f64>]) -> Vec<DVector<f64>> {
        phis(self.field.as_ref(), &self.normalization, points)
    }

    /// The state that moves the object rigidly, x = R X + t: handle 0 (the constant one)
    /// carries [R - I | t], every other handle is still. Any matrix in place of R gives that
    /// affine map of the object.
    pub fn rigid_state(&self, rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> DMatrix<f64> {
        let mut z = DMatrix::zeros(3, 4 * self.handles);
        let a = rotation - Matrix3::identity();
        for c in 0..3 {
            for d in 0..3 {
                z[(d, c)] = a[(d, c)];
            }
            z[(c, 3)] = translation[c];
        }
        z
    }

    /// Handles, the constant one included.
    pub fn handles(&self) -> usize {
        self.handles
    }
    /// Reduced degrees of freedom, 12 per handle.
    pub fn dofs(&self) -> usize {
        12 * self.handles
    }
    /// The number of cubature points.
    pub fn cubature_len(&self) -> usize {
        self.volumes.len()
    }
    /// The cubature volumes, m^3.
    pub fn volumes(&self) -> &[f64] {
        &self.volumes
    }
    /// The body's mass, kg: density times the cubature's total volume.
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }
    /// Density, kg/m^3.
    pub fn density(&self) -> f64 {
        self.density
    }
    /// The map from world units to the field's normalized frame.
    pub fn normalization(&self) -> &Normalization {
        &self.normalization
    }
    /// sum_p rho v_p phi_p phi_p^T (4K x 4K): the reduced mass is this (x) I_3.
    pub fn mass_phi(&self) -> &DMatrix<f64> {
        &self.mass_phi
    }
    /// sum_p rho v_p phi_p (4K): gravity's reduced force is this (x) g.
    pub fn mass_moment(&self) -> &DVector<f64> {
        &self.mass_moment
    }

    /// G (4K x 3) with F = I + Z G the volume-mean deformation gradient.
    pub fn mean_gradient(&self) -> &DMatrix<f64> {
        &self.mean_gradient
    }

    /// The rotation of the body as a whole at `z`: the rotation of the polar decomposition of
    /// its volume-weighted mean deformation gradient (the identity when its SVD fails).
    pub fn mean_rotation(&self, z: &DMatrix<f64>) -> Matrix3<f64> {
        let f = Matrix3::identity() + z * &self.mean_gradient;
        polar_rotation(&f).unwrap_or_else(Matrix3::identity)
    }

    /// Deformation gradients at every cubature point for the handle matrix `z` (3 x 4K), as
    /// 3 x 3 matrices.
    pub fn deformation_gradients(&self, z: &DMatrix<f64>) -> Vec<Matrix3<f64>> {
        let np = self.cubature_len();
        let mut rows = [vec![0.0; 3 * np], vec![0.0; 3 * np], vec![0.0; 3 * np]];
        self.gradient_rows(z, 0..np, &mut rows);
        (0..np)
            .map(|p| Matrix3::from_fn(|d, e| rows[d][3 * p + e]))
            .collect()
    }

    /// Elastic energy sum_p v_p Psi(F_p) and its gradient sum_p v_p P_p G_p^T (3 x 4K).
    /// One parallel pass: each thread takes a run of cubature points, forms their F, their
    /// stresses, and its share of the gradient; the shares are summed.
    pub fn elastic_forces(&self, z: &DMatrix<f64>, material: &Material) -> (f64, DMatrix<f64>) {
        let np = self.cubature_len();
        if !self.worth_parallel() {
            return self.forces_on(z, material, 0..np);
        }
        let runs = rayon::current_num_threads().max(1);
        let per_run = np.div_ceil(runs).max(1);
        (0..np.div_ceil(per_run))
            .into_par_iter()
            .map(|run| self.forces_on(z, material, run * per_run..((run + 1) * per_run).min(np)))
            .reduce(
                || (0.0, DMatrix::zeros(3, 4 * self.handles)),
                |(ea, ga), (eb, gb)| (ea + eb, ga + gb),
            )
    }

    /// Whether a pass over the cubature points is worth splitting over threads: below
    /// [`PARALLEL_WORK`] the wake-up of another thread costs more than it saves.
    pub fn worth_parallel(&self) -> bool {
        self.cubature_len() * 4 * self.handles >= PARALLEL_WORK
    }

    /// The energy and gradient share of the cubature points `points`: their F, their
    /// stresses, and sum v P G^T over them.
    fn forces_on(
        &self,
        z: &DMatrix<f64>,
        material: &Material,
        points: std::ops::Range<usize>,
    ) -> (f64, DMatrix<f64>) {
        let np = self.cubature_len();
        let len = 3 * points.len();
        let mut rows = [vec![0.0; len], vec![0.0; len], vec![0.0; len]];
        self.gradient_rows(z, points.clone(), &mut rows);
        // Overwrite each F with v P (volume folded in).
        let mut energy = 0.0;
        for (local, p) in points.clone().enumerate() {
            let f = Matrix3::from_fn(|d, e| rows[d][3 * local + e]);
            let (psi, piola) = material.energy_and_first_piola(&f);
            let v = self.volumes[p];
            energy += v * psi;
            for d in 0..3 {
                for e in 0..3 {
                    rows[d][3 * local + e] = v * piola[(d, e)];
                }
            }
        }
        let columns = 3 * np;
        let offset = 3 * points.start;
        let gradient = DMatrix::from_fn(3, 4 * self.handles, |d, a| {
            let g = &self.g_all[a * columns + offset..a * columns + offset + len];
            dot(&rows[d], g)
        });
        (energy, gradient)
    }

    /// F = I + Z G for the cubature points `points`: `rows[d][3 l + e] = F_(start + l)[d, e]`.
    fn gradient_rows(
        &self,
        z: &DMatrix<f64>,
        points: std::ops::Range<usize>,
        rows: &mut [Vec<f64>; 3],
    ) {
        let columns = 3 * self.cubature_len();
        let (start, len) = (3 * points.start, 3 * points.len());
        let [f0, f1, f2] = rows;
        for (j, (a, (b, c))) in f0
            .iter_mut()
            .zip(f1.iter_mut().zip(f2.iter_mut()))
            .enumerate()
        {
            // The identity: F[d, e] with e = j % 3.
            *a = f64::from(j % 3 == 0);
            *b = f64::from(j % 3 == 1);
            *c = f64::from(j % 3 == 2);
        }
        for a in 0..4 * self.handles {
            let g = &self.g_all[a * columns + start..a * columns + start + len];
            let (z0, z1, z2) = (z[(0, a)], z[(1, a)], z[(2, a)]);
            for j in 0..len {
                f0[j] += z0 * g[j];
                f1[j] += z1 * g[j];
                f2[j] += z2 * g[j];
            }
        }
    }
}

impl Subspace {
    /// The elastic Hessian sum_p v_p J_p^T H_p J_p (12K x 12K, flat z order), where
    /// J_p = G_p^T (x) I_3 maps z to vec(F_p) and `hessians[p]` is dP/dF at point p.
    ///
    /// The Kronecker structure splits it into 3 x 3 blocks over output rows (d, f):
    /// H[(a, d), (b, f)] = sum_p G_p C_p^{df} G_p^T with C_p^{df}[e, g] = v_p dP/dF[d + 3e, f + 3g],
    /// G_all C^{df} G_all^T, and only six blocks thanks to symmetry: a sixth of the work of
    /// multiplying out J_p, whose entries are two-thirds zeros. The six are one product
    /// (4K x 3Np) (3Np x 6 4K) in faer: at 4K = 68 and Np = 1024 the six nalgebra products
    /// took 2.95-3.46 ms on 2 cores, this one 1.1-1.5 ms (printed).
    pub fn elastic_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        let n4 = 4 * self.handles;
        let blocks = self.hessian_blocks(hessians);
        let mut hessian = DMatrix::zeros(3 * n4, 3 * n4);
        for (k, &(d, f)) in HESSIAN_BLOCKS.iter().enumerate() {
            for b in 0..n4 {
                for a in 0..n4 {
                    let value = blocks[(a, k * n4 + b)];
                    hessian[(3 * a + d, 3 * b + f)] = value;
                    hessian[(3 * b + f, 3 * a + d)] = value;
                }
            }
        }
        hessian
    }

    /// The six blocks side by side (4K x 6 4K): G_all times the six weighted right factors,
    /// one product per run of points. Each thread takes a share of the points and a small
    /// scratch matrix that stays in cache: the whole right factor (3Np x 6 4K) would be ten
    /// megabytes of freshly mapped pages on every assembly.
    fn hessian_blocks(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        let n4 = 4 * self.handles;
        let np = self.cubature_len();
        let width = HESSIAN_BLOCKS.len() * n4;
        let share = |points: std::ops::Range<usize>| {
            let mut blocks = DMatrix::zeros(n4, width);
            let mut weighted = vec![0.0; 3 * HESSIAN_RUN * width];
            let mut gathered = vec![[0.0; 3]; n4];
            for start in points.clone().step_by(HESSIAN_RUN) {
                let len = HESSIAN_RUN.min(points.end - start);
                let rows = &mut weighted[..3 * len * width];
                for (local, point_rows) in rows.chunks_mut(3 * width).enumerate() {
                    let p = start + local;
                    self.weigh_point(p, &hessians[p], &mut gathered, point_rows);
                }
                faer::linalg::matmul::matmul(
                    MatMut::from_column_major_slice_mut(blocks.as_mut_slice(), n4, width),
                    faer::Accum::Add,
                    // G_all^T as a column-major (3Np x 4K) matrix is g_all's row-major storage.
                    MatRef::from_column_major_slice(&self.g_all, 3 * np, n4)
                        .subrows(3 * start, 3 * len)
                        .transpose(),
                    MatRef::from_row_major_slice(rows, 3 * len, width),
                    1.0,
                    Par::Seq,
                );
            }
            blocks
        };
        if !self.worth_parallel() {
            return share(0..np);
        }
        let per_run = np.div_ceil(rayon::current_num_threads().max(1)).max(1);
        (0..np.div_ceil(per_run))
            .into_par_iter()
            .map(|run| share(run * per_run..((run + 1) * per_run).min(np)))
            .reduce_with(|a, b| a + b)
            .expect("at least one cubature point")
    }

    /// Point p's rows of the weighted right factors: rows[e][k 4K + a] = sum_g C_p^{df}[e, g]
    /// G_p[a, g] for the k-th block (d, f). `gp` (4K entries) is scratch for G_p.
    fn weigh_point(&self, p: usize, h: &Matrix9, gp: &mut [[f64; 3]], rows: &mut [f64]) {
        let n4 = 4 * self.handles;
        let width = HESSIAN_BLOCKS.len() * n4;
        let columns = 3 * self.cubature_len();
        let v = self.volumes[p];
        let c: [[[f64; 3]; 3]; 6] = std::array::from_fn(|k| {
            let (d, f) = HESSIAN_BLOCKS[k];
            std::array::from_fn(|e| std::array::from_fn(|g| v * h[(d + 3 * e, f + 3 * g)]))
        });
        // G_p gathered into three contiguous rows, so that the loops below run over a.
        for (a, gpa) in gp.iter_mut().enumerate() {
            gpa.copy_from_slice(&self.g_all[a * columns + 3 * p..a * columns + 3 * p + 3]);
        }
        for (k, ck) in c.iter().enumerate() {
            for (e, ce) in ck.iter().enumerate() {
                let out = &mut rows[e * width + k * n4..e * width + (k + 1) * n4];
                for (o, g) in out.iter_mut().zip(gp.iter()) {
                    *o = ce[0] * g[0] + ce[1] * g[1] + ce[2] * g[2];
                }
            }
        }
    }
}

/// Cubature points weighed and multiplied at a time in `Subspace::hessian_blocks`.
const HESSIAN_RUN: usize = 128;

/// The six (d, f) blocks of the elastic Hessian that symmetry leaves to compute.
const HESSIAN_BLOCKS: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// sum_p v_p G_p / sum_p v_p from G laid out as in `Subspace::g_all`.
fn mean_gradient(g_all: &[f64], volumes: &[f64], rows: usize) -> DMatrix<f64> {
    let columns = 3 * volumes.len();
    let total: f64 = volumes.iter().sum::<f64>().max(1e-300);
    DMatrix::from_fn(rows, 3, |row, e| {
        let g = &g_all[row * columns..(row + 1) * columns];
        volumes
            .iter()
            .enumerate()
            .map(|(p, v)| v * g[3 * p + e])
            .sum::<f64>()
            / total
    })
}

/// A dot product in eight independent lanes: a plain iterator sum is one serial dependency
/// chain (floating-point addition is not reassociated), several times slower.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut lanes = [0.0; 8];
    let (a8, b8) = (a.chunks_exact(8), b.chunks_exact(8));
    let tail: f64 = a8
        .remainder()
        .iter()
        .zip(b8.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a8.zip(b8) {
        for l in 0..8 {
            lanes[l] += x[l] * y[l];
        }
    }
    lanes.iter().sum::<f64>() + tail
}

/// phi = w (x) [X; 1] for one point.
pub fn phi_of(weights: &[f64], x: &Vector3<f64>) -> DVector<f64> {
    let xt = [x.x, x.y, x.z, 1.0];
    DVector::from_fn(4 * weights.len(), |r, _| weights[r / 4] * xt[r % 4])
}

/// Evaluates `field` at world points: weights (points x K) and, if asked, world-space gradients.
pub fn sample(
    field: &dyn SkinningField,
    normalization: &Normalization,
    points: &[Vector3<f64>],
    with_gradients: bool,
) -> (Vec<f64>, Option<Vec<Vector3<f64>>>) {
    let k = field.handle_count();
    let normalized: Vec<_> = points
        .iter()
        .map(|p| normalization.to_normalized(p))
        .collect();
    let mut weights = vec![0.0; points.len() * k];
    let mut gradients = with_gradients.then(|| vec![Vector3::zeros(); points.len() * k]);
    // Fields evaluate point by point: split the points across threads.
    let chunk = 256;
    match gradients.as_mut() {
        Some(g) => weights
            .par_chunks_mut(chunk * k)
            .zip(g.par_chunks_mut(chunk * k))
            .zip(normalized.par_chunks(chunk))
            .for_each(|((w, g), p)| field.evaluate(p, w, Some(g))),
        None => weights
            .par_chunks_mut(chunk * k)
            .zip(normalized.par_chunks(chunk))
            .for_each(|(w, p)| field.evaluate(p, w, None)),
    }
    // Gradients with respect to world coordinates: d/dX_world = d/dX_normalized / scale.
    if let Some(g) = gradients.as_mut() {
        g.iter_mut().for_each(|v| *v /= normalization.scale);
    }
    (weights, gradients)
}

/// phi rows (4K each) for a set of world points, concatenated.
pub fn phis(
    field: &dyn SkinningField,
    normalization: &Normalization,
    points: &[Vector3<f64>],
) -> Vec<DVector<f64>> {
    let k = field.handle_count();
    let (weights, _) = sample(field, normalization, points, false);
    points
        .iter()
        .enumerate()
        .map(|(i, x)| phi_of(&weights[i * k..(i + 1) * k], x))
        .collect()
}
