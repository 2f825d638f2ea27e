//! Deformation gradients at the cubature points and the elastic forces they give, from the
//! skinning field's own samples rather than from G.
//!
//! Row 4i + c of G is w_i e_c^T + X~_c grad w_i^T, so F = I + Z G is
//! I + sum_i (w_i A_i + u_i grad w_i^T) with A_i = Z_i's first three columns and
//! u_i = Z_i X~ the handle's displacement of X; and the force on Z_i is
//! sum_p (w_i S_p + q_i X~^T) restricted to its columns, with S_p = v_p P_p and
//! q_i = S_p grad w_i. Per point that reads the K weights and 3K gradients (and X) instead of
//! G's 12K numbers. A step's solver iterations evaluate the forces up to a dozen times; with G
//! (1.7 MB at K = 17 and 1024 points, streamed twice from the L3 cache) an evaluation of the
//! rod's poke took 0.126 ms on one thread, from the samples 0.072 ms (printed, `bench sim
//! --quick`).

use nalgebra::{DMatrix, Matrix3};

use super::material::Material;

/// Points a force evaluation takes at a time: their F and stresses (9 x 8 x 128 bytes) stay in
/// the L1 cache while every handle's samples pass over them.
const BLOCK: usize = 128;

/// Lanes of the force sums: independent accumulators the compiler keeps in one vector
/// register (floating-point sums are not reassociated on their own).
const LANES: usize = 8;

/// The skinning field at the cubature points, handle-major, with the points and volumes.
pub(crate) struct FieldSamples {
    handles: usize,
    /// w_i at point p: `weights[i * np + p]`.
    weights: Vec<f64>,
    /// d w_i / dX_e at point p: `gradients[e][i * np + p]`.
    gradients: [Vec<f64>; 3],
    /// X_e of point p: `positions[e][p]`.
    positions: [Vec<f64>; 3],
    /// Cubature volumes, m^3.
    volumes: Vec<f64>,
}

/// The nine entries of F (or of v P) at a run of points: `f[3 d + e][l]`.
pub(crate) type PointMatrices = [Vec<f64>; 9];

impl FieldSamples {
    /// `weights` and `gradients` point-major (`[p * K + i]`), as `subspace::sample` gives them.
    pub(crate) fn new(
        handles: usize,
        weights: &[f64],
        gradients: &[nalgebra::Vector3<f64>],
        points: &[nalgebra::Vector3<f64>],
        volumes: &[f64],
    ) -> Self {
        let np = points.len();
        let handle_major = |value: &dyn Fn(usize) -> f64| -> Vec<f64> {
            (0..handles * np)
                .map(|j| value((j % np) * handles + j / np))
                .collect()
        };
        Self {
            handles,
            weights: handle_major(&|k| weights[k]),
            gradients: std::array::from_fn(|e| handle_major(&|k| gradients[k][e])),
            positions: std::array::from_fn(|e| points.iter().map(|x| x[e]).collect()),
            volumes: volumes.to_vec(),
        }
    }

    /// The number of points.
    pub(crate) fn len(&self) -> usize {
        self.volumes.len()
    }

    /// Cubature volumes, m^3.
    pub(crate) fn volumes(&self) -> &[f64] {
        &self.volumes
    }

    /// F = I + Z G at the points `points`, entry by entry.
    pub(crate) fn deformation(
        &self,
        z: &DMatrix<f64>,
        points: std::ops::Range<usize>,
    ) -> PointMatrices {
        let mut f: PointMatrices = std::array::from_fn(|_| vec![0.0; points.len()]);
        self.deformation_into(z, points, &mut f);
        f
    }

    /// F = I + Z G at the points `points` into the first `points.len()` entries of `f`: one
    /// pass over the points a handle, all nine entries at once.
    fn deformation_into(
        &self,
        z: &DMatrix<f64>,
        points: std::ops::Range<usize>,
        f: &mut PointMatrices,
    ) {
        let (np, len) = (self.len(), points.len());
        // Every slice cut to `len`, so that the loops are free of bounds checks and vectorize.
        let mut f = f.each_mut().map(|entry| &mut entry[..len]);
        for (k, entry) in f.iter_mut().enumerate() {
            entry.fill(if k % 4 == 0 { 1.0 } else { 0.0 });
        }
        let [x0, x1, x2] = self.positions.each_ref().map(|c| &c[points.clone()]);
        for i in 0..self.handles {
            let run = i * np + points.start..i * np + points.end;
            let w = &self.weights[run.clone()];
            let [g0, g1, g2] = self.gradients.each_ref().map(|c| &c[run.clone()]);
            let a: [[f64; 4]; 3] =
                std::array::from_fn(|d| std::array::from_fn(|c| z[(d, 4 * i + c)]));
            for p in 0..len {
                let (x, g) = ([x0[p], x1[p], x2[p]], [g0[p], g1[p], g2[p]]);
                for (d, ad) in a.iter().enumerate() {
                    // u_d, the handle's displacement of X along d.
                    let u = ad[0] * x[0] + ad[1] * x[1] + ad[2] * x[2] + ad[3];
                    for e in 0..3 {
                        f[3 * d + e][p] += ad[e] * w[p] + u * g[e];
                    }
                }
            }
        }
    }

    /// F at every point as 3 x 3 matrices.
    pub(crate) fn deformation_gradients(&self, z: &DMatrix<f64>) -> Vec<Matrix3<f64>> {
        let f = self.deformation(z, 0..self.len());
        (0..self.len())
            .map(|p| Matrix3::from_fn(|d, e| f[3 * d + e][p]))
            .collect()
    }

    /// The elastic energy and its gradient (3 x 4K) over the points `points`, [`BLOCK`]
    /// points at a time: F, then v P over F, then the gradient, all in the L1 cache.
    pub(crate) fn forces(
        &self,
        z: &DMatrix<f64>,
        material: &Material,
        points: std::ops::Range<usize>,
    ) -> (f64, DMatrix<f64>) {
        let mut gradient = DMatrix::zeros(3, 4 * self.handles);
        let mut energy = 0.0;
        // Scratch for one block, no wider than the points: a body of tens of points steps in
        // tens of microseconds, where zeroing twelve whole blocks on every evaluation shows.
        let width = BLOCK.min(points.len());
        let mut stress: PointMatrices = std::array::from_fn(|_| vec![0.0; width]);
        let mut q: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; width]);
        for start in points.clone().step_by(BLOCK) {
            let block = start..(start + BLOCK).min(points.end);
            self.deformation_into(z, block.clone(), &mut stress);
            energy += material.weigh_stresses(&mut stress, &self.volumes[block.clone()]);
            self.add_stress_gradient(&stress, block, &mut q, &mut gradient);
        }
        (energy, gradient)
    }

    /// Adds sum_p S_p G_p^T (3 x 4K) for S = v P at the points `points` (the first
    /// `points.len()` entries of `stress`) to `gradient`. `q` is scratch.
    fn add_stress_gradient(
        &self,
        stress: &PointMatrices,
        points: std::ops::Range<usize>,
        q: &mut [Vec<f64>; 3],
        gradient: &mut DMatrix<f64>,
    ) {
        let (np, len) = (self.len(), points.len());
        let s = stress.each_ref().map(|entry| &entry[..len]);
        let x = self.positions.each_ref().map(|c| &c[points.clone()]);
        let q = q.each_mut().map(|entry| &mut entry[..len]);
        for i in 0..self.handles {
            let run = i * np + points.start..i * np + points.end;
            let w = &self.weights[run.clone()];
            let [g0, g1, g2] = self.gradients.each_ref().map(|c| &c[run.clone()]);
            // q_d = S[d, :] . grad w_i, every row in one pass.
            for p in 0..len {
                for d in 0..3 {
                    q[d][p] =
                        s[3 * d][p] * g0[p] + s[3 * d + 1][p] * g1[p] + s[3 * d + 2][p] * g2[p];
                }
            }
            for d in 0..3 {
                for c in 0..3 {
                    gradient[(d, 4 * i + c)] += dot_pair(s[3 * d + c], w, x[c], q[d]);
                }
                gradient[(d, 4 * i + 3)] += sum(q[d]);
            }
        }
    }
}

/// a . b + c . d in [`LANES`] independent lanes: a plain iterator sum is one serial dependency
/// chain (floating-point addition is not reassociated), several times slower.
fn dot_pair(a: &[f64], b: &[f64], c: &[f64], d: &[f64]) -> f64 {
    let mut lanes = [0.0; LANES];
    let chunks = |v| <[f64]>::chunks_exact(v, LANES);
    let (a8, b8, c8, d8) = (chunks(a), chunks(b), chunks(c), chunks(d));
    let tail: f64 = (a8.remainder().iter().zip(b8.remainder()))
        .zip(c8.remainder().iter().zip(d8.remainder()))
        .map(|((a, b), (c, d))| a * b + c * d)
        .sum();
    for ((a, b), (c, d)) in a8.zip(b8).zip(c8.zip(d8)) {
        for l in 0..LANES {
            lanes[l] += a[l] * b[l] + c[l] * d[l];
        }
    }
    lanes.iter().sum::<f64>() + tail
}

/// sum v in [`LANES`] independent lanes (see [`dot_pair`]).
fn sum(v: &[f64]) -> f64 {
    let mut lanes = [0.0; LANES];
    let chunks = v.chunks_exact(LANES);
    let tail: f64 = chunks.remainder().iter().sum();
    for chunk in chunks {
        for l in 0..LANES {
            lanes[l] += chunk[l];
        }
    }
    lanes.iter().sum::<f64>() + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::MaterialModel;
    use nalgebra::Vector3;

    /// 300 points (two whole blocks, a partial one, a partial lane) of a made-up 3-handle
    /// field, and a large state.
    fn samples() -> (FieldSamples, DMatrix<f64>) {
        let (k, np) = (3, 300);
        let wave = |j: usize, s: f64| (0.37 * j as f64 + s).sin();
        let weights: Vec<f64> = (0..np * k).map(|j| wave(j, 0.1)).collect();
        let gradients: Vec<Vector3<f64>> = (0..np * k)
            .map(|j| Vector3::new(wave(j, 1.0), wave(j, 2.0), wave(j, 3.0)))
            .collect();
        let points: Vec<Vector3<f64>> = (0..np)
            .map(|p| Vector3::new(wave(p, 4.0), wave(p, 5.0), wave(p, 6.0)))
            .collect();
        let volumes: Vec<f64> = (0..np).map(|p| 1e-3 * (1.5 + wave(p, 7.0))).collect();
        let z = DMatrix::from_fn(3, 4 * k, |d, a| 0.1 * wave(5 * d + 3 * a, 8.0));
        let samples = FieldSamples::new(k, &weights, &gradients, &points, &volumes);
        (samples, z)
    }

    /// G_p (4K x 3) written out from its definition.
    fn g_of(s: &FieldSamples, p: usize) -> DMatrix<f64> {
        let np = s.len();
        DMatrix::from_fn(4 * s.handles, 3, |row, e| {
            let (i, c) = (row / 4, row % 4);
            let x = if c < 3 { s.positions[c][p] } else { 1.0 };
            let identity = if c == e { s.weights[i * np + p] } else { 0.0 };
            identity + x * s.gradients[e][i * np + p]
        })
    }

    #[test]
    fn forces_match_the_sums_over_g() {
        let (s, z) = samples();
        let material = Material::from_young_poisson(MaterialModel::StableNeoHookean, 1e5, 0.4);
        let (energy, gradient) = s.forces(&z, &material, 0..s.len());
        let (mut expected_energy, mut expected) = (0.0, DMatrix::zeros(3, 4 * s.handles));
        for (p, f) in s.deformation_gradients(&z).iter().enumerate() {
            let g = g_of(&s, p);
            let direct = Matrix3::identity() + &z * &g;
            assert!((direct - f).amax() < 1e-13, "F at point {p}");
            let (psi, piola) = material.energy_and_first_piola(f);
            expected_energy += s.volumes[p] * psi;
            expected += piola * g.transpose() * s.volumes[p];
        }
        assert!((energy - expected_energy).abs() < 1e-12 * expected_energy.abs());
        assert!((&gradient - &expected).amax() < 1e-12 * expected.amax());
        // Split anywhere, the shares add up to the whole.
        let (e1, g1) = s.forces(&z, &material, 0..131);
        let (e2, g2) = s.forces(&z, &material, 131..s.len());
        assert!((e1 + e2 - energy).abs() < 1e-12 * energy.abs());
        assert!((g1 + g2 - &gradient).amax() < 1e-12 * gradient.amax());
    }
}
