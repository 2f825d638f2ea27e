//! The elastic Hessian over the cubature: G of every point (F = I + Z G) laid out for one
//! matrix product.

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{DMatrix, Vector3};

use super::material::Matrix9;
use super::shares::shared_out;

/// Cubature points times 4K below which a pass over the points runs on one thread: with 2
/// threads, handing half of a small pass to the other costs more than it saves (`bench
/// peer`'s small blocks). The held Hessian's refresh on 512 points x 68 is worth
/// splitting: 0.80-0.89 ms on one thread, 0.65-0.76 ms on two (printed, the poked creature).
const PARALLEL_WORK: usize = 16_384;

/// Cubature points weighed and multiplied at a time in `HessianAssembly::hessian_blocks`.
const HESSIAN_RUN: usize = 128;

/// The six (d, f) blocks of the elastic Hessian that symmetry leaves to compute: the three
/// diagonal ones, themselves symmetric, first.
const HESSIAN_BLOCKS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// How many of `HESSIAN_BLOCKS` are diagonal blocks, of which only the lower half is computed.
const DIAGONAL_BLOCKS: usize = 3;

/// Distance of the points' centre from the origin, in radii about it, up to which G is held
/// in f32 too: G's entries then reach about 1 + `NEAR_ORIGIN` times their cancelled sums, and
/// the preconditioner keeps about six digits.
const NEAR_ORIGIN: f64 = 3.0;

/// A precision the Hessian is assembled in: f64 where it is the Newton system, f32 where it only
/// preconditions quasi-Newton.
trait Precision:
    faer::traits::ComplexField
    + Copy
    + Send
    + Sync
    + std::ops::Add<Output = Self>
    + std::ops::Mul<Output = Self>
    + 'static
{
    fn of(value: f64) -> Self;
    fn wide(self) -> f64;
    /// G of every point in this precision (`HessianAssembly::g_points`'s layout).
    fn g_points(assembly: &HessianAssembly) -> &[Self];
}

impl Precision for f64 {
    fn of(value: f64) -> Self {
        value
    }
    fn wide(self) -> f64 {
        self
    }
    fn g_points(assembly: &HessianAssembly) -> &[Self] {
        &assembly.g_points
    }
}

impl Precision for f32 {
    fn of(value: f64) -> Self {
        value as f32
    }
    fn wide(self) -> f64 {
        self as f64
    }
    fn g_points(assembly: &HessianAssembly) -> &[Self] {
        assembly
            .g_points_f32
            .as_deref()
            .expect("only assembled in f32 where it holds G in f32")
    }
}

/// Volumes and G of the cubature points.
pub(crate) struct HessianAssembly {
    /// 4K: the rows of every G.
    rows: usize,
    /// Cubature volumes, m^3.
    volumes: Vec<f64>,
    /// G of every point, point by point: G_p^T (3 x 4K) row-major, so that `weigh_point` reads
    /// each of its three rows contiguously (vectorized over the 4K entries), and the whole read
    /// column-major is G_all (4K x 3 Np), the product's left factor. Laid out as the caller's
    /// `g_all` (4K x 3 Np row-major), a point's G was 4K strided reads: weighing the 512 points
    /// of the poked creature's refreshes took 0.34-0.52 ms, 0.12-0.15 ms laid out point by point
    /// (summed over threads, printed).
    g_points: Vec<f64>,
    /// `g_points` rounded to f32, where that keeps a preconditioner's digits (see `new`).
    g_points_f32: Option<Vec<f32>>,
}

impl HessianAssembly {
    /// `g_all` is G of every point side by side, (4K) x (3 Np) row-major: one 4K x 3 block per
    /// volume; `points` the points.
    ///
    /// G's rows w_i e_c^T + X_c grad w_i^T hold the points' coordinates, so an object far from
    /// the origin (a cloud in a map frame) has large entries whose products cancel in the
    /// Hessian: rounding grows with (distance / size)^2. Such a body's preconditioner is
    /// assembled in f64 too (in f32 the far-away test object's was not even definite).
    pub(crate) fn new(
        rows: usize,
        volumes: Vec<f64>,
        g_all: Vec<f64>,
        points: &[Vector3<f64>],
    ) -> Self {
        let columns = 3 * volumes.len();
        debug_assert_eq!(g_all.len(), rows * columns);
        // g_points[c * rows + a] = g_all[a * columns + c]: the transpose.
        let g_points: Vec<f64> = (0..columns * rows)
            .map(|j| g_all[(j % rows) * columns + j / rows])
            .collect();
        let single = near_origin(points).then(|| g_points.iter().map(|&g| g as f32).collect());
        Self {
            rows,
            volumes,
            g_points_f32: single,
            g_points,
        }
    }

    /// The number of points.
    pub(crate) fn len(&self) -> usize {
        self.volumes.len()
    }

    /// Whether a pass over the points is worth splitting over threads: below
    /// [`PARALLEL_WORK`] the wake-up of another thread costs more than it saves.
    fn worth_parallel(&self) -> bool {
        self.len() * self.rows >= PARALLEL_WORK
    }

    /// `elastic_hessian` for a preconditioner: summed in f32 unless the body is too far from
    /// the origin. A preconditioner needs no more digits, and the product runs faster: for
    /// the rod's poke (1024 points, 17 handles) this function took 1.96-2.02 ms a refresh
    /// against 2.85-2.92 ms in f64 (printed, session 17's machine).
    pub(crate) fn preconditioning_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        if self.g_points_f32.is_some() {
            self.assembled::<f32>(hessians)
        } else {
            self.assembled::<f64>(hessians)
        }
    }

    /// The elastic Hessian (see `assembled`) summed in f64.
    pub(crate) fn elastic_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        self.assembled::<f64>(hessians)
    }

    /// The elastic Hessian sum_p v_p J_p^T H_p J_p (12K x 12K, flat z order), where
    /// J_p = G_p^T (x) I_3 maps z to vec(F_p) and `hessians[p]` is dP/dF at point p.
    ///
    /// The Kronecker structure splits it into 3 x 3 blocks over output rows (d, f):
    /// H[(a, d), (b, f)] = sum_p G_p C_p^{df} G_p^T with C_p^{df}[e, g] = v_p dP/dF[d + 3e, f + 3g],
    /// G_all C^{df} G_all^T, and only six blocks thanks to symmetry: a sixth of the work of
    /// multiplying out J_p, whose entries are two-thirds zeros. The six are one product
    /// (4K x 3Np) (3Np x 6 4K) in faer: at 4K = 68 and Np = 1024 the six nalgebra products
    /// took 2.95-3.46 ms on 2 cores, this one 1.1-1.5 ms (printed).
    fn assembled<T: Precision>(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        let n4 = self.rows;
        let blocks = self.hessian_blocks::<T>(hessians);
        let mut hessian = DMatrix::zeros(3 * n4, 3 * n4);
        for (k, &(d, f)) in HESSIAN_BLOCKS.iter().enumerate() {
            for b in 0..n4 {
                // A diagonal block's upper half is not computed: it mirrors the lower one.
                let first = if k < DIAGONAL_BLOCKS { b } else { 0 };
                for a in first..n4 {
                    let value = blocks[(k * n4 + b) * n4 + a].wide();
                    hessian[(3 * a + d, 3 * b + f)] = value;
                    hessian[(3 * b + f, 3 * a + d)] = value;
                }
            }
        }
        hessian
    }

    /// The six blocks side by side (4K x 6 4K, column-major): G_all times the six weighted
    /// right factors, one product per run of points. Each thread takes a share of the points
    /// and a small scratch matrix that stays in cache: the whole right factor (3Np x 6 4K)
    /// would be ten megabytes of freshly mapped pages on every assembly.
    fn hessian_blocks<T: Precision>(&self, hessians: &[Matrix9]) -> Vec<T> {
        let n4 = self.rows;
        let np = self.len();
        let width = HESSIAN_BLOCKS.len() * n4;
        // G_all (4K x 3Np) column-major is g_points as it is stored.
        let g_all = MatRef::from_column_major_slice(T::g_points(self), n4, 3 * np);
        let share = |points: std::ops::Range<usize>| {
            let mut blocks = vec![T::of(0.0); n4 * width];
            let mut weighted = vec![T::of(0.0); 3 * HESSIAN_RUN * width];
            for start in points.clone().step_by(HESSIAN_RUN) {
                let len = HESSIAN_RUN.min(points.end - start);
                let rows = &mut weighted[..3 * len * width];
                for (local, point_rows) in rows.chunks_mut(3 * width).enumerate() {
                    let p = start + local;
                    self.weigh_point(p, &hessians[p], point_rows);
                }
                let left = g_all.subcols(3 * start, 3 * len);
                let right = MatRef::from_row_major_slice(rows, 3 * len, width);
                let mut out = MatMut::from_column_major_slice_mut(&mut blocks, n4, width);
                for k in 0..DIAGONAL_BLOCKS {
                    triangular::matmul(
                        out.as_mut().subcols_mut(k * n4, n4),
                        BlockStructure::TriangularLower,
                        Accum::Add,
                        left,
                        BlockStructure::Rectangular,
                        right.subcols(k * n4, n4),
                        BlockStructure::Rectangular,
                        T::of(1.0),
                        Par::Seq,
                    );
                }
                let rest = DIAGONAL_BLOCKS * n4;
                faer::linalg::matmul::matmul(
                    out.subcols_mut(rest, width - rest),
                    Accum::Add,
                    left,
                    right.subcols(rest, width - rest),
                    T::of(1.0),
                    Par::Seq,
                );
            }
            blocks
        };
        if !self.worth_parallel() {
            return share(0..np);
        }
        let mut shares = shared_out(np, share).into_iter();
        let mut blocks = shares.next().expect("at least one cubature point");
        for other in shares {
            blocks.iter_mut().zip(other).for_each(|(a, b)| *a += b);
        }
        blocks
    }

    /// Point p's rows of the weighted right factors: rows[e][k 4K + a] = sum_g C_p^{df}[e, g]
    /// G_p[a, g] for the k-th block (d, f), in the assembly's precision.
    fn weigh_point<T: Precision>(&self, p: usize, h: &Matrix9, rows: &mut [T]) {
        let n4 = self.rows;
        let width = HESSIAN_BLOCKS.len() * n4;
        let v = self.volumes[p];
        let gp = &T::g_points(self)[3 * p * n4..3 * (p + 1) * n4];
        let (g0, rest) = gp.split_at(n4);
        let (g1, g2) = rest.split_at(n4);
        for (k, &(d, f)) in HESSIAN_BLOCKS.iter().enumerate() {
            for e in 0..3 {
                let c: [T; 3] = std::array::from_fn(|g| T::of(v * h[(d + 3 * e, f + 3 * g)]));
                let out = &mut rows[e * width + k * n4..e * width + (k + 1) * n4];
                for (o, ((a0, a1), a2)) in out.iter_mut().zip(g0.iter().zip(g1).zip(g2)) {
                    *o = c[0] * *a0 + c[1] * *a1 + c[2] * *a2;
                }
            }
        }
    }
}

/// Whether the points' centre lies within `NEAR_ORIGIN` radii of the origin.
fn near_origin(points: &[Vector3<f64>]) -> bool {
    if points.is_empty() {
        return false;
    }
    let centre = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let radius = points
        .iter()
        .map(|p| (p - centre).norm())
        .fold(0.0, f64::max);
    centre.norm() <= NEAR_ORIGIN * radius
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 300 points (two whole runs and a partial one) of made-up G (as `new` takes it) and
    /// dP/dF for K = 2.
    fn made_up() -> (HessianAssembly, Vec<f64>, Vec<Matrix9>) {
        let (rows, np) = (8, 300);
        let wave = |j: usize, s: f64| (0.37 * j as f64 + s).sin();
        let g_all: Vec<f64> = (0..rows * 3 * np).map(|j| wave(j, 0.5)).collect();
        let volumes: Vec<f64> = (0..np).map(|p| 1e-3 * (1.5 + wave(p, 2.0))).collect();
        let hessians = (0..np)
            .map(|p| {
                let a = Matrix9::from_fn(|r, c| wave(81 * p + 9 * r + c, 1.0));
                a * a.transpose() * 1e5
            })
            .collect();
        let assembly = HessianAssembly::new(rows, volumes, g_all.clone(), &[Vector3::zeros()]);
        (assembly, g_all, hessians)
    }

    /// sum_p v_p J_p^T H_p J_p with J_p = G_p^T (x) I_3 multiplied out, G read from `g_all`
    /// as the caller laid it out.
    fn multiplied_out(
        assembly: &HessianAssembly,
        g_all: &[f64],
        hessians: &[Matrix9],
    ) -> DMatrix<f64> {
        let (n4, np) = (assembly.rows, assembly.len());
        let mut total = DMatrix::zeros(3 * n4, 3 * n4);
        for (p, h) in hessians.iter().enumerate() {
            // vec(F) index d + 3e (column-major F); z index 3a + d.
            let j = DMatrix::from_fn(9, 3 * n4, |row, col| {
                let (d, e, a) = (row % 3, row / 3, col / 3);
                let g = g_all[a * 3 * np + 3 * p + e];
                if col % 3 == d {
                    g
                } else {
                    0.0
                }
            });
            total += j.transpose() * h * j * assembly.volumes[p];
        }
        total
    }

    #[test]
    fn blocks_match_the_multiplied_out_sum_in_both_precisions() {
        let (assembly, g_all, hessians) = made_up();
        let expected = multiplied_out(&assembly, &g_all, &hessians);
        let relative = |h: &DMatrix<f64>| (h - &expected).norm() / expected.norm();
        let double = assembly.assembled::<f64>(&hessians);
        let single = assembly.assembled::<f32>(&hessians);
        assert!(relative(&double) < 1e-12, "f64: {:e}", relative(&double));
        // f32 keeps about seven digits of each product and of the sum over points.
        assert!(relative(&single) < 1e-5, "f32: {:e}", relative(&single));
        assert!(relative(&single) > 0.0, "f32 rounded nothing");
    }

    /// An object in a map frame, far from the origin, keeps f64: its G's entries cancel.
    #[test]
    fn only_a_body_near_the_origin_is_preconditioned_in_f32() {
        let ball = |centre: Vector3<f64>| -> Vec<Vector3<f64>> {
            (0..6)
                .map(|k| centre + Vector3::ith(k % 3, if k < 3 { 0.05 } else { -0.05 }))
                .collect()
        };
        assert!(near_origin(&ball(Vector3::new(0.1, 0.0, 0.0))));
        assert!(!near_origin(&ball(Vector3::new(20.0, 5.0, 0.0))));
        let far = HessianAssembly::new(4, vec![1.0], vec![0.0; 12], &ball(Vector3::x() * 20.0));
        assert!(far.g_points_f32.is_none());
    }
}
