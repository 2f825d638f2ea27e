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

use nalgebra::{DMatrix, Matrix3, Vector3};
use wide::f64x8;

use super::bulk::volume_change;
use super::material::{Material, MaterialModel};

/// Points a force evaluation takes at a time: their F and stresses (9 x 8 x 128 bytes) stay in
/// the L1 cache while every handle's samples pass over them.
const BLOCK: usize = 128;

/// Points a vector register holds: F's nine entries and a handle's twelve force sums stay in
/// registers while the samples pass over them. Written out as `f64x8`: with plain arrays the
/// compiler vectorized across F's entries instead of the points, gathering and scattering
/// them (F took 193 us an evaluation at K = 17 and 1024 points).
const LANES: usize = 8;

/// The skinning field at the cubature points, handle-major, with the points and volumes.
pub(crate) struct FieldSamples {
    handles: usize,
    /// Entries between one handle's samples and the next's: the points rounded up to whole
    /// registers, and one register more, zeros past the points, so that a register's worth
    /// can be read from any point on.
    stride: usize,
    /// w_i at point p: `weights[i * stride + p]`.
    weights: Vec<f64>,
    /// d w_i / dX_e at point p: `gradients[e][i * stride + p]`.
    gradients: [Vec<f64>; 3],
    /// X_e of point p: `positions[e][p]`, zeros up to `stride`.
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
        let stride = np.next_multiple_of(LANES) + LANES;
        let handle_major = |value: &dyn Fn(usize) -> f64| -> Vec<f64> {
            (0..handles * stride)
                .map(|j| match j % stride {
                    p if p < np => value(p * handles + j / stride),
                    _ => 0.0,
                })
                .collect()
        };
        Self {
            handles,
            stride,
            weights: handle_major(&|k| weights[k]),
            gradients: std::array::from_fn(|e| handle_major(&|k| gradients[k][e])),
            positions: std::array::from_fn(|e| {
                let mut column: Vec<f64> = points.iter().map(|x| x[e]).collect();
                column.resize(stride, 0.0);
                column
            }),
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

    /// The points, m.
    pub(crate) fn points(&self) -> Vec<Vector3<f64>> {
        (0..self.len())
            .map(|p| Vector3::from_fn(|e, _| self.positions[e][p]))
            .collect()
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

    /// F = I + Z G at the points `points` into the first `points.len()` entries of `f`,
    /// [`LANES`] points at a time, every handle's samples passing over them in registers.
    /// One pass over the points a handle, adding into F in memory, took 34 us an evaluation at
    /// K = 17 and 1024 points, this way 26 us (printed, a scratch timing on one thread).
    fn deformation_into(
        &self,
        z: &DMatrix<f64>,
        points: std::ops::Range<usize>,
        f: &mut PointMatrices,
    ) {
        let z = z.as_slice();
        for start in points.clone().step_by(LANES) {
            let chunk = self.deformation_lanes(z, start);
            let (at, valid) = (start - points.start, LANES.min(points.end - start));
            for (entry, lanes) in f.iter_mut().zip(&chunk) {
                entry[at..at + valid].copy_from_slice(&lanes.as_array()[..valid]);
            }
        }
    }

    /// F's nine entries at the [`LANES`] points from `start` on (past the last point, at
    /// whatever the padding gives). `z` is Z's column-major storage: handle i's affine map is
    /// its 12 entries from 12 i on.
    #[inline(always)]
    fn deformation_lanes(&self, z: &[f64], start: usize) -> [f64x8; 9] {
        let x: [f64x8; 3] = std::array::from_fn(|c| lanes_at(&self.positions[c], start));
        let mut f = std::array::from_fn(|k| if k % 4 == 0 { f64x8::ONE } else { f64x8::ZERO });
        for i in 0..self.handles {
            let at = i * self.stride + start;
            let w = lanes_at(&self.weights, at);
            let g: [f64x8; 3] = std::array::from_fn(|e| lanes_at(&self.gradients[e], at));
            let map = &z[12 * i..12 * i + 12];
            for d in 0..3 {
                let a = |c: usize| f64x8::splat(map[3 * c + d]);
                // u_d, the handle's displacement of X along d.
                let u = a(0).mul_add(x[0], a(1).mul_add(x[1], a(2).mul_add(x[2], a(3))));
                for e in 0..3 {
                    f[3 * d + e] = a(e).mul_add(w, u.mul_add(g[e], f[3 * d + e]));
                }
            }
        }
        f
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
    /// `pressures` (one per point of the whole cubature), where given, are added to each
    /// point's dPsi/dJ (see `Material::weigh_stresses`); `deformations`, where given, are F at
    /// the points from its offset on (covering `points`), formed once for the pressures and
    /// not again.
    pub(crate) fn forces(
        &self,
        z: &DMatrix<f64>,
        material: &Material,
        points: std::ops::Range<usize>,
        pressures: Option<&[f64]>,
        deformations: Option<(&PointMatrices, usize)>,
    ) -> (f64, DMatrix<f64>) {
        let mut gradient = DMatrix::zeros(3, 4 * self.handles);
        let mut energy = 0.0;
        // Scratch for one block, no wider than the points: a body of tens of points steps in
        // tens of microseconds, where zeroing twelve whole blocks on every evaluation shows.
        // Whole registers: the last one's lanes past the points are zeroed for the sums.
        let width = BLOCK.min(points.len()).next_multiple_of(LANES);
        let mut stress: PointMatrices = std::array::from_fn(|_| vec![0.0; width]);
        for start in points.clone().step_by(BLOCK) {
            let block = start..(start + BLOCK).min(points.end);
            match deformations {
                Some((f, offset)) => {
                    for (entry, held) in stress.iter_mut().zip(f) {
                        let at = block.start - offset..block.end - offset;
                        entry[..block.len()].copy_from_slice(&held[at]);
                    }
                }
                None => self.deformation_into(z, block.clone(), &mut stress),
            }
            let block_pressures = pressures.map(|q| &q[block.clone()]);
            energy +=
                material.weigh_stresses(&mut stress, &self.volumes[block.clone()], block_pressures);
            for entry in stress.iter_mut() {
                entry[block.len()..].fill(0.0);
            }
            self.add_stress_gradient(&stress, block, &mut gradient);
        }
        (energy, gradient)
    }

    /// Each point's volume change (see `bulk::volume_change`) for the deformation gradients
    /// `f` of the points (entry by entry).
    pub(crate) fn volume_changes(f: &PointMatrices, model: MaterialModel) -> Vec<f64> {
        (0..f[0].len())
            .map(|p| volume_change(model, &Matrix3::from_fn(|d, e| f[3 * d + e][p])).0)
            .collect()
    }

    /// Point p's de/dZ = (de/dF) G_p^T (3 x 4K, column-major as the state) at its deformation
    /// gradient `f`, into `out`, written out per handle as `add_stress_gradient` does.
    pub(crate) fn volume_change_gradient(
        &self,
        p: usize,
        f: &Matrix3<f64>,
        model: MaterialModel,
        out: &mut [f64],
    ) {
        let c = volume_change(model, f).1;
        let x = [
            self.positions[0][p],
            self.positions[1][p],
            self.positions[2][p],
            1.0,
        ];
        for i in 0..self.handles {
            let at = i * self.stride + p;
            let w = self.weights[at];
            let g = Vector3::new(
                self.gradients[0][at],
                self.gradients[1][at],
                self.gradients[2][at],
            );
            for d in 0..3 {
                let q = c.row(d).transpose().dot(&g);
                for (col, xc) in x.iter().enumerate() {
                    let identity = if col < 3 { c[(d, col)] * w } else { 0.0 };
                    out[3 * (4 * i + col) + d] = identity + q * xc;
                }
            }
        }
    }

    /// Adds sum_p S_p G_p^T (3 x 4K) for S = v P at the points `points` (the first
    /// `points.len()` entries of `stress`, zeros after them up to whole registers) to
    /// `gradient`: a handle's twelve sums in one pass over the points, in registers. Twelve
    /// passes a handle (a dot product each) took 62 us an evaluation at K = 17 and 1024
    /// points, this way 24 us (printed, a scratch timing on one thread).
    fn add_stress_gradient(
        &self,
        stress: &PointMatrices,
        points: std::ops::Range<usize>,
        gradient: &mut DMatrix<f64>,
    ) {
        for i in 0..self.handles {
            let mut sums = [f64x8::ZERO; 12];
            for local in (0..points.len()).step_by(LANES) {
                let at = i * self.stride + points.start + local;
                let w = lanes_at(&self.weights, at);
                let g: [f64x8; 3] = std::array::from_fn(|e| lanes_at(&self.gradients[e], at));
                let x: [f64x8; 3] =
                    std::array::from_fn(|c| lanes_at(&self.positions[c], points.start + local));
                let s: [f64x8; 9] = std::array::from_fn(|k| lanes_at(&stress[k], local));
                for d in 0..3 {
                    // q_d = S[d, :] . grad w_i.
                    let q = s[3 * d].mul_add(g[0], s[3 * d + 1].mul_add(g[1], s[3 * d + 2] * g[2]));
                    for c in 0..3 {
                        sums[4 * d + c] = s[3 * d + c].mul_add(w, q.mul_add(x[c], sums[4 * d + c]));
                    }
                    sums[4 * d + 3] += q;
                }
            }
            for (k, sum) in sums.iter().enumerate() {
                gradient[(k / 4, 4 * i + k % 4)] += sum.reduce_add();
            }
        }
    }
}

/// The [`LANES`] entries of `v` from `at` on, bounds checked once.
#[inline(always)]
fn lanes_at(v: &[f64], at: usize) -> f64x8 {
    let lanes: [f64; LANES] = v[at..at + LANES].try_into().expect("LANES entries");
    f64x8::from(lanes)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let stride = s.stride;
        DMatrix::from_fn(4 * s.handles, 3, |row, e| {
            let (i, c) = (row / 4, row % 4);
            let x = if c < 3 { s.positions[c][p] } else { 1.0 };
            let identity = if c == e {
                s.weights[i * stride + p]
            } else {
                0.0
            };
            identity + x * s.gradients[e][i * stride + p]
        })
    }

    #[test]
    fn forces_match_the_sums_over_g() {
        let (s, z) = samples();
        let material = Material::from_young_poisson(MaterialModel::StableNeoHookean, 1e5, 0.4);
        let (energy, gradient) = s.forces(&z, &material, 0..s.len(), None, None);
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
        let (e1, g1) = s.forces(&z, &material, 0..131, None, None);
        let (e2, g2) = s.forces(&z, &material, 131..s.len(), None, None);
        assert!((e1 + e2 - energy).abs() < 1e-12 * energy.abs());
        assert!((g1 + g2 - &gradient).amax() < 1e-12 * gradient.amax());
    }
}
