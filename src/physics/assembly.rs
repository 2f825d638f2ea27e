//! The elastic Hessian over the cubature: G of every point (F = I + Z G) laid out for one
//! matrix product.

use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::DMatrix;
use rayon::prelude::*;

use super::material::Matrix9;

/// Cubature points times 4K below which a pass over the points runs on one thread: with 2
/// threads, handing half of a small pass to the other costs more than it saves.
const PARALLEL_WORK: usize = 65_536;

/// Cubature points weighed and multiplied at a time in `HessianAssembly::hessian_blocks`.
const HESSIAN_RUN: usize = 128;

/// The six (d, f) blocks of the elastic Hessian that symmetry leaves to compute: the three
/// diagonal ones, themselves symmetric, first.
const HESSIAN_BLOCKS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// How many of `HESSIAN_BLOCKS` are diagonal blocks, of which only the lower half is computed.
const DIAGONAL_BLOCKS: usize = 3;

/// Volumes and G of the cubature points.
pub(crate) struct HessianAssembly {
    /// 4K: the rows of every G.
    rows: usize,
    /// Cubature volumes, m^3.
    volumes: Vec<f64>,
    /// G of every point side by side: (4K) rows x (3 Np) columns, row-major, which read
    /// column-major is the product's left factor G_all^T (3 Np x 4K).
    g_all: Vec<f64>,
}

impl HessianAssembly {
    /// `g_all` is G of every point side by side, (4K) x (3 Np) row-major: one 4K x 3 block per
    /// volume.
    pub(crate) fn new(rows: usize, volumes: Vec<f64>, g_all: Vec<f64>) -> Self {
        debug_assert_eq!(g_all.len(), rows * 3 * volumes.len());
        Self {
            rows,
            volumes,
            g_all,
        }
    }

    /// The number of points.
    pub(crate) fn len(&self) -> usize {
        self.volumes.len()
    }

    /// Whether a pass over the points is worth splitting over threads: below
    /// [`PARALLEL_WORK`] the wake-up of another thread costs more than it saves.
    pub(crate) fn worth_parallel(&self) -> bool {
        self.len() * self.rows >= PARALLEL_WORK
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
    pub(crate) fn elastic_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        let n4 = self.rows;
        let blocks = self.hessian_blocks(hessians);
        let mut hessian = DMatrix::zeros(3 * n4, 3 * n4);
        for (k, &(d, f)) in HESSIAN_BLOCKS.iter().enumerate() {
            for b in 0..n4 {
                // A diagonal block's upper half is not computed: it mirrors the lower one.
                let first = if k < DIAGONAL_BLOCKS { b } else { 0 };
                for a in first..n4 {
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
        let n4 = self.rows;
        let np = self.len();
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
                // G_all^T as a column-major (3Np x 4K) matrix is g_all's row-major storage.
                let left = MatRef::from_column_major_slice(&self.g_all, 3 * np, n4)
                    .subrows(3 * start, 3 * len)
                    .transpose();
                let right = MatRef::from_row_major_slice(rows, 3 * len, width);
                let mut out = MatMut::from_column_major_slice_mut(blocks.as_mut_slice(), n4, width);
                for k in 0..DIAGONAL_BLOCKS {
                    let columns = k * n4..(k + 1) * n4;
                    triangular::matmul(
                        out.as_mut().subcols_mut(columns.start, n4),
                        BlockStructure::TriangularLower,
                        Accum::Add,
                        left,
                        BlockStructure::Rectangular,
                        right.subcols(columns.start, n4),
                        BlockStructure::Rectangular,
                        1.0,
                        Par::Seq,
                    );
                }
                let rest = DIAGONAL_BLOCKS * n4;
                faer::linalg::matmul::matmul(
                    out.subcols_mut(rest, width - rest),
                    Accum::Add,
                    left,
                    right.subcols(rest, width - rest),
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
        let n4 = self.rows;
        let width = HESSIAN_BLOCKS.len() * n4;
        let columns = 3 * self.len();
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
