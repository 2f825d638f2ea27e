//! The reduced space of one object: a skinning field sampled at cubature points, and what the
//! dynamics needs from it, computed once per shape.
//!
//! With handles Z_i = [A_i | t_i] (3 x 4) and X~ = [X; 1], the displacement is
//! u(X) = sum_i w_i(X) Z_i X~ = Z phi(X), where Z = [Z_1 .. Z_K] is 3 x 4K and
//! phi = w (x) X~ (4K). The reduced state z is Z flattened column-major (z[3a + d] = Z[d, a]),
//! so each handle owns 12 consecutive numbers. The deformation gradient is F = I + Z G(X) with
//! G = d phi / dX (4K x 3): row 4i + c of G is w_i e_c^T + X~_c grad w_i^T.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector, Vector3};
use rayon::prelude::*;

use super::material::Matrix9;

use crate::geometry::{Cubature, Normalization};
use crate::skinning::SkinningField;

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
        Self {
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

    pub fn field(&self) -> &dyn SkinningField {
        self.field.as_ref()
    }

    /// phi = w (x) [X; 1] at world points.
    pub fn phis(&self, points: &[Vector3<f64>]) -> Vec<DVector<f64>> {
        phis(self.field.as_ref(), &self.normalization, points)
    }

    /// Handles, the constant one included.
    pub fn handles(&self) -> usize {
        self.handles
    }
    /// Reduced degrees of freedom, 12 per handle.
    pub fn dofs(&self) -> usize {
        12 * self.handles
    }
    pub fn cubature_len(&self) -> usize {
        self.volumes.len()
    }
    pub fn volumes(&self) -> &[f64] {
        &self.volumes
    }
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }
    pub fn density(&self) -> f64 {
        self.density
    }
    pub fn normalization(&self) -> &Normalization {
        &self.normalization
    }
    pub fn mass_phi(&self) -> &DMatrix<f64> {
        &self.mass_phi
    }
    pub fn mass_moment(&self) -> &DVector<f64> {
        &self.mass_moment
    }
    /// G of cubature point `p` as (4K x 3), copied out (for tests and assembly).
    pub fn g_of(&self, p: usize) -> DMatrix<f64> {
        let columns = 3 * self.cubature_len();
        DMatrix::from_fn(4 * self.handles, 3, |r, e| {
            self.g_all[r * columns + 3 * p + e]
        })
    }

    /// Deformation gradients at every cubature point for the handle matrix `z` (3 x 4K):
    /// `out[d][3p + e] = F_p[d, e]`.
    pub fn deformation_gradients(&self, z: &DMatrix<f64>, out: &mut [Vec<f64>; 3]) {
        let columns = 3 * self.cubature_len();
        for row in out.iter_mut() {
            row.clear();
            row.resize(columns, 0.0);
        }
        let [r0, r1, r2] = out;
        let chunk = columns
            .div_ceil(rayon::current_num_threads().max(1))
            .div_ceil(3)
            * 3;
        r0.par_chunks_mut(chunk)
            .zip(r1.par_chunks_mut(chunk))
            .zip(r2.par_chunks_mut(chunk))
            .enumerate()
            .for_each(|(c, ((f0, f1), f2))| {
                let start = c * chunk;
                let len = f0.len();
                for a in 0..4 * self.handles {
                    let g = &self.g_all[a * columns + start..a * columns + start + len];
                    let (z0, z1, z2) = (z[(0, a)], z[(1, a)], z[(2, a)]);
                    for j in 0..len {
                        f0[j] += z0 * g[j];
                        f1[j] += z1 * g[j];
                        f2[j] += z2 * g[j];
                    }
                }
                for j in 0..len {
                    // Add the identity: F[d, e] with e = j % 3.
                    match (start + j) % 3 {
                        0 => f0[j] += 1.0,
                        1 => f1[j] += 1.0,
                        _ => f2[j] += 1.0,
                    }
                }
            });
    }

    /// Reduced elastic force pullback: returns sum_p P_p G_p^T (3 x 4K), where
    /// `stress[d][3p + e]` holds v_p P_p[d, e] (volume already folded in).
    pub fn pull_back(&self, stress: &[Vec<f64>; 3]) -> DMatrix<f64> {
        let columns = 3 * self.cubature_len();
        let rows: Vec<[f64; 3]> = (0..4 * self.handles)
            .into_par_iter()
            .map(|a| {
                let g = &self.g_all[a * columns..(a + 1) * columns];
                let mut acc = [0.0; 3];
                for (d, s) in stress.iter().enumerate() {
                    acc[d] = s.iter().zip(g).map(|(x, y)| x * y).sum();
                }
                acc
            })
            .collect();
        DMatrix::from_fn(3, 4 * self.handles, |d, a| rows[a][d])
    }
}

impl Subspace {
    /// The elastic Hessian sum_p v_p J_p^T H_p J_p (12K x 12K, flat z order), where
    /// J_p = G_p^T (x) I_3 maps z to vec(F_p) and `hessians[p]` is dP/dF at point p.
    /// Assembled as dense products over blocks of points, in parallel.
    pub fn elastic_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        let n = self.dofs();
        let np = self.cubature_len();
        let block = 32;
        (0..np.div_ceil(block))
            .into_par_iter()
            .map(|b| {
                let points = (b * block)..((b + 1) * block).min(np);
                let rows = 9 * points.len();
                let mut jacobian = DMatrix::<f64>::zeros(rows, n);
                let mut weighted = DMatrix::<f64>::zeros(rows, n);
                for (local, p) in points.clone().enumerate() {
                    let g = self.g_of(p);
                    for e in 0..3 {
                        for d in 0..3 {
                            let r = 9 * local + d + 3 * e;
                            for a in 0..4 * self.handles {
                                jacobian[(r, 3 * a + d)] = g[(a, e)];
                            }
                        }
                    }
                    let j = jacobian.rows(9 * local, 9);
                    let h = hessians[p] * self.volumes[p];
                    weighted.rows_mut(9 * local, 9).copy_from(&(h * j));
                }
                jacobian.transpose() * weighted
            })
            .reduce(|| DMatrix::zeros(n, n), |a, b| a + b)
    }
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
