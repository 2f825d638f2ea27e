//! Hyperelastic energy densities, first Piola–Kirchhoff stresses and stress derivatives.
//!
//! Conventions: `F` is a `Matrix3<f64>` and `vec(F)` is column-major (index `row + 3 * col`,
//! the order of `F.as_slice()`). A [`Matrix9`] holds `d vec(P) / d vec(F)` in that order.

use std::f64::consts::FRAC_1_SQRT_2;

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use serde::{Deserialize, Serialize};

/// `d vec(P) / d vec(F)`, with `vec` column-major.
pub type Matrix9 = SMatrix<f64, 9, 9>;

type Vector9 = SVector<f64, 9>;

/// Iteration cap for the 3x3 SVD and eigen-solves; they converge in a handful of sweeps for
/// finite input, so the cap only stops non-finite input from looping.
const MAX_ITERATIONS: usize = 100;
/// Convergence threshold of nalgebra's own `svd` / `symmetric_eigen`.
const EPSILON: f64 = 5.0 * f64::EPSILON;

/// The constitutive model: how strain energy depends on the deformation gradient.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModel {
    /// Small-strain linear elasticity (not rotation invariant).
    Linear,
    /// `mu/2 (I_C - 3) - mu (J - 1) + lambda/2 (J - 1)^2`, without a log so inverted `F` is fine.
    NeoHookean,
    /// Stable Neo-Hookean (Smith, de Goes, Kim 2018) without its log term.
    StableNeoHookean,
}

/// How a reduced body integrates its material's bulk term.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BulkIntegration {
    /// At every cubature point, as the rest of the energy.
    #[default]
    Points,
    /// Projected onto a pressure linear within each of 2K regions (`physics::bulk`).
    Regions,
}

/// A constitutive model with its Lamé parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// The constitutive model.
    pub model: MaterialModel,
    /// The shear modulus mu (Lamé's second parameter), Pa.
    pub mu: f64,
    /// Lamé's first parameter lambda, Pa.
    pub lambda: f64,
    /// How a reduced body integrates the bulk term (the FEM: at every element).
    pub bulk: BulkIntegration,
}

/// Points whose energies `Material::weigh_stresses` holds at a time.
const WEIGHED_AT_ONCE: usize = 128;

impl Material {
    /// Converts Young's modulus and Poisson's ratio to Lamé parameters.
    pub fn from_young_poisson(model: MaterialModel, young: f64, poisson: f64) -> Self {
        Self {
            model,
            mu: young / (2.0 * (1.0 + poisson)),
            lambda: young * poisson / ((1.0 + poisson) * (1.0 - 2.0 * poisson)),
            bulk: BulkIntegration::Points,
        }
    }

    /// Energy density `Psi(F)`; zero at rest for every model.
    pub fn energy_density(&self, f: &Matrix3<f64>) -> f64 {
        self.energy_and_first_piola(f).0
    }

    /// First Piola–Kirchhoff stress `P = dPsi/dF`.
    pub fn first_piola(&self, f: &Matrix3<f64>) -> Matrix3<f64> {
        self.energy_and_first_piola(f).1
    }

    /// sum_p v_p Psi(F_p) over a run of points given entry by entry (`f[3 d + e][p]`), each
    /// F overwritten with v_p P(F_p): `energy_and_first_piola` written out per entry, so that
    /// the loop over points vectorizes (point by point, as 3 x 3 matrices, it did not).
    /// `pressures`, where given, are added to each point's dPsi/dJ (for the small-strain model,
    /// to dPsi/d tr F): the bulk term projected over regions (`physics::bulk`), whose energy
    /// the caller adds.
    pub(crate) fn weigh_stresses(
        &self,
        f: &mut [Vec<f64>; 9],
        volumes: &[f64],
        pressures: Option<&[f64]>,
    ) -> f64 {
        let mut total = 0.0;
        // A run at a time, its energies on the stack: this runs for every block of points in
        // every force evaluation, and a small body's evaluation takes microseconds.
        let mut energies = [0.0; WEIGHED_AT_ONCE];
        for (run, run_volumes) in volumes.chunks(WEIGHED_AT_ONCE).enumerate() {
            let points = run * WEIGHED_AT_ONCE..run * WEIGHED_AT_ONCE + run_volumes.len();
            let mut entries = f.each_mut().map(|entry| &mut entry[points.clone()]);
            let energies = &mut energies[..run_volumes.len()];
            for (p, energy) in energies.iter_mut().enumerate() {
                let a: [f64; 9] = std::array::from_fn(|k| entries[k][p]);
                let pressure = pressures.map_or(0.0, |q| q[points.start + p]);
                let (psi, stress) = match self.form() {
                    Form::SmallStrain(m) => m.entrywise(&a, pressure),
                    Form::NeoHookean(m) => m.entrywise(&a, pressure),
                };
                *energy = run_volumes[p] * psi;
                for (entry, s) in entries.iter_mut().zip(stress) {
                    entry[p] = run_volumes[p] * s;
                }
            }
            // Summed after the loop: a running sum would chain every point to the last.
            total += energies.iter().sum::<f64>();
        }
        total
    }

    /// `(Psi(F), P(F))`, sharing the work between the two.
    pub fn energy_and_first_piola(&self, f: &Matrix3<f64>) -> (f64, Matrix3<f64>) {
        match self.form() {
            Form::SmallStrain(m) => m.energy_and_first_piola(f),
            Form::NeoHookean(m) => m.energy_and_first_piola(f),
        }
    }

    /// d vec(P)/d vec(F); with `project` true, the nearest positive semi-definite matrix (negative eigenvalues clamped to 0).
    ///
    /// The projection uses the analytic eigensystem of isotropic energies, so it needs one 3x3
    /// SVD and no 9x9 eigen-solve. Non-finite `F` gives a non-finite result.
    pub fn stress_derivative(&self, f: &Matrix3<f64>, project: bool) -> Matrix9 {
        match self.form() {
            // Constant, and PSD whenever mu >= 0 and 3 lambda + 2 mu >= 0, so nothing to project.
            Form::SmallStrain(m) => m.hessian(),
            Form::NeoHookean(m) if project => m
                .projected_hessian(f)
                .unwrap_or_else(|| Matrix9::from_element(f64::NAN)),
            Form::NeoHookean(m) => m.hessian(f),
        }
    }

    fn form(&self) -> Form {
        let (mu, lambda) = (self.mu, self.lambda);
        match self.model {
            MaterialModel::Linear => Form::SmallStrain(SmallStrain { mu, lambda }),
            MaterialModel::NeoHookean => Form::NeoHookean(NeoHookeanForm { mu, kappa: lambda }),
            // SNH without the log: mu/2 (I_C - 3) + lambda'/2 (J - alpha)^2 with lambda' = lambda + mu,
            // alpha = 1 + mu/lambda'. Expanding about J = 1,
            //   lambda'/2 (J - alpha)^2 = lambda'/2 (J - 1)^2 - mu (J - 1) + mu^2 / (2 lambda'),
            // i.e. the reference Neo-Hookean form with lambda -> lambda' plus a constant. The
            // constant is dropped: with it Psi(I) = mu^2 / (2 lambda') instead of 0. This form
            // also avoids dividing by lambda'.
            MaterialModel::StableNeoHookean => Form::NeoHookean(NeoHookeanForm {
                mu,
                kappa: lambda + mu,
            }),
        }
    }
}

/// The two energy families behind the three models.
enum Form {
    SmallStrain(SmallStrain),
    NeoHookean(NeoHookeanForm),
}

/// `Psi = mu |eps|^2 + lambda/2 tr(eps)^2` with `eps = (F + F^T)/2 - I`.
#[derive(Clone, Copy)]
struct SmallStrain {
    mu: f64,
    lambda: f64,
}

impl SmallStrain {
    fn strain(f: &Matrix3<f64>) -> Matrix3<f64> {
        (f + f.transpose()) * 0.5 - Matrix3::identity()
    }

    fn energy_and_first_piola(self, f: &Matrix3<f64>) -> (f64, Matrix3<f64>) {
        let eps = Self::strain(f);
        let trace = eps.trace();
        let energy = self.mu * eps.norm_squared() + 0.5 * self.lambda * trace.powi(2);
        let stress = eps * (2.0 * self.mu) + Matrix3::from_diagonal_element(self.lambda * trace);
        (energy, stress)
    }

    /// `energy_and_first_piola` on F's entries, row by row (`a[3 d + e]`), `pressure` added
    /// to dPsi/d tr F.
    fn entrywise(self, a: &[f64; 9], pressure: f64) -> (f64, [f64; 9]) {
        let eps: [f64; 9] =
            std::array::from_fn(|k| 0.5 * (a[k] + a[3 * (k % 3) + k / 3]) - f64::from(k % 4 == 0));
        let trace = eps[0] + eps[4] + eps[8];
        let norm: f64 = eps.iter().map(|e| e * e).sum();
        let energy = self.mu * norm + 0.5 * self.lambda * trace * trace;
        let stress = std::array::from_fn(|k| {
            2.0 * self.mu * eps[k]
                + if k % 4 == 0 {
                    self.lambda * trace + pressure
                } else {
                    0.0
                }
        });
        (energy, stress)
    }

    /// `P = mu (F + F^T) + lambda tr(F) I + const`, so `dP/dF = mu (I9 + T) + lambda vec(I) vec(I)^T`
    /// with `T` the permutation taking `vec(F)` to `vec(F^T)`.
    fn hessian(self) -> Matrix9 {
        let mut h = Matrix9::identity() * self.mu;
        for r in 0..3 {
            for c in 0..3 {
                // P_rc depends on F_cr through the transpose.
                h[(r + 3 * c, c + 3 * r)] += self.mu;
                // vec(I) is one at the diagonal indices 0, 4, 8.
                h[(4 * r, 4 * c)] += self.lambda;
            }
        }
        h
    }
}

/// `Psi = mu/2 (I_C - 3) - mu (J - 1) + kappa/2 (J - 1)^2`: the reference Neo-Hookean for
/// `kappa = lambda`, the log-free Stable Neo-Hookean for `kappa = lambda + mu`.
#[derive(Clone, Copy)]
struct NeoHookeanForm {
    mu: f64,
    kappa: f64,
}

impl NeoHookeanForm {
    /// `dPsi/dJ`; `d2Psi/dJ2` is the constant `kappa`.
    fn d_energy_d_j(self, j: f64) -> f64 {
        self.kappa * (j - 1.0) - self.mu
    }

    fn energy_and_first_piola(self, f: &Matrix3<f64>) -> (f64, Matrix3<f64>) {
        let cof = cofactor(f);
        let j = f.column(0).dot(&cof.column(0));
        let energy = 0.5 * self.mu * (f.norm_squared() - 3.0) - self.mu * (j - 1.0)
            + 0.5 * self.kappa * (j - 1.0).powi(2);
        (energy, f * self.mu + cof * self.d_energy_d_j(j))
    }

    /// `energy_and_first_piola` on F's entries, row by row (`a[3 d + e]`), `pressure` added
    /// to dPsi/dJ.
    fn entrywise(self, a: &[f64; 9], pressure: f64) -> (f64, [f64; 9]) {
        let [f00, f01, f02, f10, f11, f12, f20, f21, f22] = *a;
        // cof F, row by row: column e is the cross product of F's other two columns.
        let cof = [
            f11 * f22 - f21 * f12,
            f12 * f20 - f22 * f10,
            f10 * f21 - f20 * f11,
            f21 * f02 - f01 * f22,
            f22 * f00 - f02 * f20,
            f20 * f01 - f00 * f21,
            f01 * f12 - f11 * f02,
            f02 * f10 - f12 * f00,
            f00 * f11 - f10 * f01,
        ];
        let j = f00 * cof[0] + f10 * cof[3] + f20 * cof[6];
        let norm: f64 = a.iter().map(|x| x * x).sum();
        let energy = 0.5 * self.mu * (norm - 3.0) - self.mu * (j - 1.0)
            + 0.5 * self.kappa * (j - 1.0) * (j - 1.0);
        let h = self.d_energy_d_j(j) + pressure;
        (energy, std::array::from_fn(|k| self.mu * a[k] + h * cof[k]))
    }

    /// `mu I9 + kappa vec(cof) vec(cof)^T + dPsi/dJ * d vec(cof)/d vec(F)`.
    fn hessian(self, f: &Matrix3<f64>) -> Matrix9 {
        let cof = cofactor(f);
        let j = f.column(0).dot(&cof.column(0));
        let g = Vector9::from_column_slice(cof.as_slice());
        // `g * g^T` (rather than a rank-1 update) keeps the result exactly symmetric.
        Matrix9::identity() * self.mu
            + g * g.transpose() * self.kappa
            + cofactor_derivative(f) * self.d_energy_d_j(j)
    }

    /// Nearest PSD Hessian from the analytic eigensystem (Smith, de Goes, Kim 2019).
    ///
    /// With the rotation-variant SVD `F = U diag(s) V^T`, `Psi = mu/2 |s|^2 + h(J)` with
    /// `J = s0 s1 s2`, so `dPsi/ds_i = mu s_i + h'(J) s_j s_k`. The nine eigenpairs are three
    /// scaling modes (from the 3x3 Hessian in `s`) and, for each pair `(i, j)` with third index
    /// `k`, a skew ("twist") and a symmetric ("flip") mode. Their eigenvalues
    ///   skew:      (dPsi/ds_i + dPsi/ds_j) / (s_i + s_j) = mu + h'(J) s_k
    ///   symmetric: (dPsi/ds_i - dPsi/ds_j) / (s_i - s_j) = mu - h'(J) s_k
    /// simplify exactly, so repeated or opposite singular values need no special case. The skew
    /// modes contain the infinitesimal rotations, whose eigenvalue `mu + h'(1) = 0` at rest.
    ///
    /// `None` only when an iterative 3x3 solve fails, i.e. for non-finite `F`.
    fn projected_hessian(self, f: &Matrix3<f64>) -> Option<Matrix9> {
        let RotationSvd { u, s, v } = RotationSvd::new(f)?;
        let dpsi_dj = self.d_energy_d_j(s.product());
        let dj_ds = Vector3::new(s[1] * s[2], s[2] * s[0], s[0] * s[1]);
        let d2j_ds2 = Matrix3::new(0.0, s[2], s[1], s[2], 0.0, s[0], s[1], s[0], 0.0);
        let d2psi_ds2 = Matrix3::from_diagonal_element(self.mu)
            + dj_ds * dj_ds.transpose() * self.kappa
            + d2j_ds2 * dpsi_dj;
        let scaling = d2psi_ds2.try_symmetric_eigen(EPSILON, MAX_ITERATIONS)?;

        let mut h = Matrix9::zeros();
        for (eigenvalue, e) in scaling
            .eigenvalues
            .iter()
            .zip(scaling.eigenvectors.column_iter())
        {
            add_clamped_mode(
                &mut h,
                *eigenvalue,
                &(u * Matrix3::from_diagonal(&e) * v.transpose()),
            );
        }
        for (i, j, k) in [(1, 2, 0), (2, 0, 1), (0, 1, 2)] {
            let uv_ij = u.column(i) * v.column(j).transpose();
            let uv_ji = u.column(j) * v.column(i).transpose();
            let twist = (uv_ij - uv_ji) * FRAC_1_SQRT_2;
            let flip = (uv_ij + uv_ji) * FRAC_1_SQRT_2;
            add_clamped_mode(&mut h, self.mu + dpsi_dj * s[k], &twist);
            add_clamped_mode(&mut h, self.mu - dpsi_dj * s[k], &flip);
        }
        h.fill_upper_triangle_with_lower_triangle();
        Some(h)
    }
}

/// Adds `max(eigenvalue, 0) vec(Q) vec(Q)^T` to the lower triangle of `h`.
fn add_clamped_mode(h: &mut Matrix9, eigenvalue: f64, q: &Matrix3<f64>) {
    // Not `> 0.0`: a NaN eigenvalue (from non-finite F) must poison the result, not vanish.
    if eigenvalue <= 0.0 {
        return;
    }
    let q = Vector9::from_column_slice(q.as_slice());
    h.syger(eigenvalue, &q, &q, 1.0);
}

/// `cof(F) = J F^{-T}`, written with cross products of the columns of `F` so that it stays
/// defined (and smooth) for singular `F`.
pub(crate) fn cofactor(f: &Matrix3<f64>) -> Matrix3<f64> {
    let [f0, f1, f2] = columns(f);
    Matrix3::from_columns(&[f1.cross(&f2), f2.cross(&f0), f0.cross(&f1)])
}

/// `d vec(cof F) / d vec(F)`. Column `a` of `cof F` is `f_b x f_c` with `(a, b, c)` cyclic, and
/// `d(f_b x f_c) = -[f_c]x df_b + [f_b]x df_c`, where `[v]x` is the cross-product matrix of `v`.
/// The 3x3 block `(a, b)` is the derivative of column `a` of `cof F` w.r.t. column `b` of `F`:
///
/// ```text
/// [    0     -[f2]x   [f1]x ]
/// [  [f2]x     0     -[f0]x ]
/// [ -[f1]x   [f0]x     0    ]
/// ```
pub(crate) fn cofactor_derivative(f: &Matrix3<f64>) -> Matrix9 {
    let cross = columns(f).map(|c| c.cross_matrix());
    let mut h = Matrix9::zeros();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        h.fixed_view_mut::<3, 3>(3 * a, 3 * b).copy_from(&-cross[c]);
        h.fixed_view_mut::<3, 3>(3 * a, 3 * c).copy_from(&cross[b]);
    }
    h
}

fn columns(f: &Matrix3<f64>) -> [Vector3<f64>; 3] {
    [0, 1, 2].map(|c| f.column(c).into_owned())
}

/// Rotation-variant SVD `F = U diag(s) V^T` with `det U = det V = +1`. A reflection is absorbed
/// by negating the smallest singular value, so an inverted `F` has exactly one negative `s_i`.
struct RotationSvd {
    u: Matrix3<f64>,
    s: Vector3<f64>,
    v: Matrix3<f64>,
}

/// The rotation of the polar decomposition of `f` (a reflection absorbed as in
/// [`RotationSvd`]); None when the SVD does not converge.
pub(crate) fn polar_rotation(f: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    RotationSvd::new(f).map(|r| r.u * r.v.transpose())
}

impl RotationSvd {
    fn new(f: &Matrix3<f64>) -> Option<Self> {
        let svd = f.try_svd(true, true, EPSILON, MAX_ITERATIONS)?;
        let mut s = svd.singular_values;
        let mut u = svd.u?;
        let mut v = svd.v_t?.transpose();
        let smallest = s.imin();
        // Negating matching columns of U (or V) and the singular value leaves U diag(s) V^T unchanged.
        for m in [&mut u, &mut v] {
            if m.determinant() < 0.0 {
                m.column_mut(smallest).neg_mut();
                s[smallest] = -s[smallest];
            }
        }
        Some(Self { u, s, v })
    }
}

#[cfg(test)]
mod tests {
    use super::MaterialModel::{Linear, NeoHookean, StableNeoHookean};
    use super::*;
    use nalgebra::{Rotation3, SymmetricEigen};
    use std::hint::black_box;
    use std::time::Instant;

    /// Central-difference step; balances truncation (~STEP^2) against round-off (~eps/STEP).
    const STEP: f64 = 1e-5;

    /// Every model at a moderate and at a nearly incompressible Poisson ratio.
    fn materials() -> Vec<Material> {
        [Linear, NeoHookean, StableNeoHookean]
            .into_iter()
            .flat_map(|model| [0.3, 0.49].map(|nu| Material::from_young_poisson(model, 1e5, nu)))
            .collect()
    }

    /// SplitMix64, uniform in [-1, 1); deterministic so failures reproduce.
    struct Rng(u64);

    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }

        fn matrix(&mut self) -> Matrix3<f64> {
            Matrix3::from_fn(|_, _| self.uniform())
        }

        fn rotation(&mut self) -> Matrix3<f64> {
            rotation(Vector3::from_fn(|_, _| 2.0 * self.uniform()))
        }
    }

    fn rotation(scaled_axis: Vector3<f64>) -> Matrix3<f64> {
        Rotation3::new(scaled_axis).into_inner()
    }

    /// `U diag(s) V^T` with fixed generic rotations, to place singular values exactly.
    fn with_singular_values(s: [f64; 3]) -> Matrix3<f64> {
        rotation(Vector3::new(0.3, -0.5, 0.9))
            * Matrix3::from_diagonal(&Vector3::from(s))
            * rotation(Vector3::new(-1.1, 0.2, 0.4)).transpose()
    }

    fn deformations() -> Vec<(&'static str, Matrix3<f64>)> {
        let perturbation = Matrix3::new(0.3, -0.2, 0.5, 0.1, -0.4, 0.2, -0.3, 0.6, 0.1);
        vec![
            ("near identity", Matrix3::identity() + perturbation * 0.01),
            (
                "large stretch",
                Matrix3::new(2.5, 0.2, -0.1, 0.3, 1.8, 0.2, -0.2, 0.1, 1.4),
            ),
            (
                "shear",
                Matrix3::new(1.0, 0.8, 0.0, 0.0, 1.0, 0.5, 0.0, 0.0, 1.0),
            ),
            (
                "compression",
                Matrix3::new(0.5, 0.05, 0.02, -0.03, 0.6, 0.04, 0.01, -0.02, 0.4),
            ),
            (
                "reflection",
                Matrix3::new(1.1, 0.2, 0.0, 0.1, 0.9, 0.2, 0.0, 0.1, -0.8),
            ),
            ("nearly singular", with_singular_values([1.2, 0.9, 1e-4])),
            ("rotation", rotation(Vector3::new(0.4, -0.8, 1.2))),
        ]
    }

    /// Stress of 0.1% strain: the floor for relative stress errors, since P is exactly 0 at a
    /// rotation (where a finite difference can only reproduce it to round-off).
    fn stress_floor(m: &Material) -> f64 {
        1e-3 * (m.mu + m.lambda)
    }

    /// Frobenius norm of `a - reference` relative to `max(|reference|, floor)`.
    fn rel_err<const R: usize, const C: usize>(
        a: &SMatrix<f64, R, C>,
        reference: &SMatrix<f64, R, C>,
        floor: f64,
    ) -> f64 {
        (a - reference).norm() / reference.norm().max(floor)
    }

    fn perturbed(f: &Matrix3<f64>, k: usize, delta: f64) -> Matrix3<f64> {
        let mut g = *f;
        g[k] += delta;
        g
    }

    fn fd_first_piola(m: &Material, f: &Matrix3<f64>) -> Matrix3<f64> {
        Matrix3::from_fn(|r, c| {
            let k = r + 3 * c;
            (m.energy_density(&perturbed(f, k, STEP)) - m.energy_density(&perturbed(f, k, -STEP)))
                / (2.0 * STEP)
        })
    }

    fn fd_stress_derivative(m: &Material, f: &Matrix3<f64>) -> Matrix9 {
        let mut h = Matrix9::zeros();
        for k in 0..9 {
            let dp = (m.first_piola(&perturbed(f, k, STEP))
                - m.first_piola(&perturbed(f, k, -STEP)))
                / (2.0 * STEP);
            h.set_column(k, &Vector9::from_column_slice(dp.as_slice()));
        }
        h
    }

    /// Reference projection: full 9x9 eigen-solve, negative eigenvalues clamped to zero.
    fn numeric_projection(h: &Matrix9) -> Matrix9 {
        let eigen = SymmetricEigen::new(*h);
        let clamped = eigen.eigenvalues.map(|l| l.max(0.0));
        eigen.eigenvectors * Matrix9::from_diagonal(&clamped) * eigen.eigenvectors.transpose()
    }

    /// Asserts every property of the projected Hessian at `f`; returns whether the unprojected
    /// Hessian was indefinite (so callers can check both branches were exercised).
    fn check_projection(m: &Material, f: &Matrix3<f64>, name: &str) -> bool {
        let exact = m.stress_derivative(f, false);
        let projected = m.stress_derivative(f, true);
        let context = format!(
            "{:?} lambda/mu {:.1} {name} F={f}",
            m.model,
            m.lambda / m.mu
        );

        assert_eq!(projected, projected.transpose(), "not symmetric: {context}");
        let eigenvalues = projected.symmetric_eigenvalues();
        assert!(
            eigenvalues.min() >= -1e-9 * eigenvalues.amax(),
            "not PSD, eigenvalues {eigenvalues}: {context}"
        );
        let err = rel_err(&projected, &numeric_projection(&exact), 0.0);
        assert!(
            err < 1e-7,
            "differs from numeric projection by {err:e}: {context}"
        );

        // Exactly-zero eigenvalues (rotation modes at rest, skew modes of Linear) come out as
        // round-off of either sign; they do not make the Hessian indefinite.
        let exact_eigenvalues = exact.symmetric_eigenvalues();
        let indefinite = exact_eigenvalues.min() < -1e-12 * exact_eigenvalues.amax();
        if !indefinite {
            let err = rel_err(&projected, &exact, 0.0);
            assert!(err < 1e-8, "PSD Hessian changed by {err:e}: {context}");
        }
        indefinite
    }

    #[test]
    fn stresses_entry_by_entry_match_the_matrix_form() {
        for m in materials() {
            let cases = deformations();
            let mut entries: [Vec<f64>; 9] =
                std::array::from_fn(|k| cases.iter().map(|(_, f)| f[(k / 3, k % 3)]).collect());
            let volumes: Vec<f64> = (0..cases.len()).map(|p| 1.0 + p as f64).collect();
            let energy = m.weigh_stresses(&mut entries, &volumes, None);
            let mut expected = 0.0;
            for (p, (name, f)) in cases.iter().enumerate() {
                let (psi, piola) = m.energy_and_first_piola(f);
                expected += volumes[p] * psi;
                let got = Matrix3::from_fn(|d, e| entries[3 * d + e][p] / volumes[p]);
                let err = rel_err(&got, &piola, stress_floor(&m));
                assert!(err < 1e-12, "{:?} {name}: stress off by {err:e}", m.model);
            }
            let err = (energy - expected).abs() / expected.abs().max(1e-300);
            assert!(err < 1e-12, "{:?}: energy off by {err:e}", m.model);
        }
    }

    #[test]
    fn first_piola_matches_finite_differences() {
        for m in materials() {
            for (name, f) in deformations() {
                let err = rel_err(
                    &fd_first_piola(&m, &f),
                    &m.first_piola(&f),
                    stress_floor(&m),
                );
                assert!(err < 1e-6, "{:?} {name}: relative error {err:e}", m.model);
            }
        }
    }

    #[test]
    fn stress_derivative_matches_finite_differences() {
        for m in materials() {
            for (name, f) in deformations() {
                let exact = m.stress_derivative(&f, false);
                let err = rel_err(&fd_stress_derivative(&m, &f), &exact, 0.0);
                assert!(err < 1e-5, "{:?} {name}: relative error {err:e}", m.model);
            }
        }
    }

    #[test]
    fn energy_and_stress_vanish_at_rest() {
        for m in materials() {
            let (energy, stress) = m.energy_and_first_piola(&Matrix3::identity());
            let scale = m.mu + m.lambda;
            assert!(
                energy.abs() <= 1e-12 * scale,
                "{:?}: Psi(I) = {energy:e}",
                m.model
            );
            assert!(
                stress.norm() <= 1e-12 * scale,
                "{:?}: P(I) = {stress}",
                m.model
            );
        }
    }

    #[test]
    fn rotations_are_stress_free_for_neo_hookean_forms() {
        let mut rng = Rng(3);
        for m in materials().into_iter().filter(|m| m.model != Linear) {
            let scale = m.mu + m.lambda;
            for r in (0..50).map(|_| rng.rotation()) {
                let (energy, stress) = m.energy_and_first_piola(&r);
                assert!(
                    energy.abs() <= 1e-12 * scale,
                    "{:?}: Psi(R) = {energy:e}",
                    m.model
                );
                assert!(
                    stress.norm() <= 1e-12 * scale,
                    "{:?}: P(R) = {stress}",
                    m.model
                );
            }
        }
    }

    #[test]
    fn projected_hessian_on_random_deformations() {
        let mut rng = Rng(7);
        for m in materials() {
            let (mut inverted, mut indefinite) = (0, 0);
            for n in 0..300 {
                // Alternate mild deformations with arbitrary ones, about half of which are inverted.
                let f = if n % 2 == 0 {
                    Matrix3::identity() + rng.matrix() * 0.5
                } else {
                    rng.matrix() * 1.5
                };
                inverted += usize::from(f.determinant() < 0.0);
                indefinite += usize::from(check_projection(&m, &f, "random"));
            }
            assert!(inverted >= 50, "only {inverted} inverted samples");
            // Linear is PSD everywhere; the Neo-Hookean forms must exercise the clamping.
            match m.model {
                Linear => assert_eq!(indefinite, 0),
                _ => assert!(indefinite >= 50, "{:?}: {indefinite} indefinite", m.model),
            }
        }
    }

    #[test]
    fn projected_hessian_at_degenerate_deformations() {
        let r = rotation(Vector3::new(0.4, -0.8, 1.2));
        let cases = [
            ("uniform stretch", r * 2.0),
            ("uniform compression", r * 0.6),
            (
                "diagonal, repeated",
                Matrix3::from_diagonal(&Vector3::new(1.5, 0.5, 1.5)),
            ),
            ("repeated large pair", with_singular_values([1.5, 1.5, 0.5])),
            ("repeated small pair", with_singular_values([1.2, 0.5, 0.5])),
            (
                "mirror",
                Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0)),
            ),
            (
                "inverted, |s| repeated",
                with_singular_values([1.0, 1.0, -1.0]),
            ),
            ("point reflection", -Matrix3::identity()),
            (
                "inverted compression",
                with_singular_values([0.3, 0.3, -0.3]),
            ),
            ("inverted stretch", with_singular_values([2.0, 1.5, -0.5])),
            (
                "two negative singular values",
                with_singular_values([-0.8, -1.2, 0.9]),
            ),
            ("nearly singular", with_singular_values([1.2, 0.9, 1e-4])),
            (
                "one zero singular value",
                with_singular_values([1.3, 0.6, 0.0]),
            ),
            (
                "two zero singular values",
                with_singular_values([1.1, 0.0, 0.0]),
            ),
            ("zero", Matrix3::zeros()),
        ];
        for m in materials() {
            for rest in [Matrix3::identity(), r] {
                let indefinite = check_projection(&m, &rest, "rest");
                assert!(!indefinite, "{:?}: indefinite at rest", m.model);
            }
            for (name, f) in &cases {
                check_projection(&m, f, name);
            }
        }
    }

    #[test]
    fn linear_hessian_is_constant_and_unaffected_by_projection() {
        let mut rng = Rng(5);
        for m in materials().into_iter().filter(|m| m.model == Linear) {
            let at_rest = m.stress_derivative(&Matrix3::identity(), false);
            for f in (0..20).map(|_| rng.matrix() * 2.0) {
                assert_eq!(m.stress_derivative(&f, false), at_rest);
                assert_eq!(m.stress_derivative(&f, true), at_rest);
            }
        }
    }

    #[test]
    fn non_finite_input_gives_non_finite_output() {
        let f = Matrix3::from_element(f64::NAN);
        for m in materials().into_iter().filter(|m| m.model != Linear) {
            assert!(m.stress_derivative(&f, true).iter().any(|x| x.is_nan()));
        }
    }

    #[test]
    fn lame_parameters_from_young_poisson() {
        let m = Material::from_young_poisson(NeoHookean, 1e5, 0.3);
        assert!((m.mu - 1e5 / 2.6).abs() <= 1e-12 * m.mu, "mu = {}", m.mu);
        assert!(
            (m.lambda - 3e4 / 0.52).abs() <= 1e-12 * m.lambda,
            "lambda = {}",
            m.lambda
        );
        assert_eq!(m.model, NeoHookean);

        // Nearly incompressible: lambda / mu = 2 nu / (1 - 2 nu) = 49.
        let m = Material::from_young_poisson(StableNeoHookean, 1e5, 0.49);
        assert!((m.mu - 1e5 / 2.98).abs() <= 1e-12 * m.mu, "mu = {}", m.mu);
        assert!(
            (m.lambda / m.mu - 49.0).abs() <= 1e-10,
            "ratio = {}",
            m.lambda / m.mu
        );
    }

    #[test]
    fn model_names_are_snake_case() {
        use serde::de::value::{Error, StrDeserializer};
        use serde::de::IntoDeserializer;
        for (name, model) in [
            ("linear", Linear),
            ("neo_hookean", NeoHookean),
            ("stable_neo_hookean", StableNeoHookean),
        ] {
            let de: StrDeserializer<Error> = name.into_deserializer();
            assert_eq!(MaterialModel::deserialize(de).unwrap(), model);
        }
    }

    /// Prints the cost of one projected Hessian; no assertion, timings vary with the machine.
    #[test]
    fn timing_projected_hessian() {
        let m = Material::from_young_poisson(StableNeoHookean, 1e5, 0.45);
        let mut rng = Rng(11);
        let deformations: Vec<_> = (0..1000).map(|_| rng.matrix() * 1.2).collect();
        for project in [false, true] {
            let repeats = 20;
            let start = Instant::now();
            let mut checksum = 0.0;
            for _ in 0..repeats {
                for f in &deformations {
                    checksum += black_box(m.stress_derivative(black_box(f), project))[(0, 0)];
                }
            }
            let calls = (repeats * deformations.len()) as f64;
            let micros = start.elapsed().as_secs_f64() * 1e6 / calls;
            println!("stress_derivative(project = {project}): {micros:.3} us/call ({checksum:e})");
        }
    }
}
