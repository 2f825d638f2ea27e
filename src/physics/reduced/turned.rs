//! The held elastic Hessian kept as its regions' shares, each turned by the rotation its region
//! made since the shares were assembled. A region that turns as a rigid piece changes its
//! share of the Hessian by exactly that congruence, so the turned sum follows a swinging,
//! tumbling or bending body at the cost of one small product, where assembling the Hessian
//! again costs ten times more.

use faer::{MatMut, MatRef};
use nalgebra::{DMatrix, Matrix3};

/// The shares, laid out to be turned by one product.
pub(super) struct TurnedHessian {
    /// 12K: the held matrix is n x n in 3 x 3 blocks (a, b).
    n: usize,
    /// The blocks (a, b) with a <= b, in the order of `stacked`'s rows.
    pairs: Vec<(usize, usize)>,
    /// pairs x 9R, column-major: columns 9r..9r+9 of row j are block pairs[j] of region r's
    /// share, column-major. Pairs run down the rows so that the product turning them is tall,
    /// the shape a matrix product runs fastest in (a 9-row one took a third longer).
    stacked: Vec<f64>,
    /// Each region's rotation where the shares were assembled.
    assembled_at: Vec<Matrix3<f64>>,
    /// The shares summed, unturned.
    total: DMatrix<f64>,
}

impl TurnedHessian {
    /// Holds `shares` (12K x 12K each, one per region), assembled with the regions at
    /// `rotations`. `reuse`, a held Hessian no longer needed, lends its storage: 2.7 MB
    /// freshly mapped on every refresh took a millisecond of page faults on this machine.
    pub(super) fn new(
        shares: &[DMatrix<f64>],
        rotations: Vec<Matrix3<f64>>,
        reuse: Option<TurnedHessian>,
    ) -> Self {
        let n = shares[0].nrows();
        let pairs: Vec<(usize, usize)> = (0..n / 3)
            .flat_map(|b| (0..=b).map(move |a| (a, b)))
            .collect();
        let rows = pairs.len();
        let mut stacked = reuse.map(|r| r.stacked).unwrap_or_default();
        stacked.clear();
        stacked.resize(rows * 9 * shares.len(), 0.0);
        let mut total = DMatrix::zeros(n, n);
        for (r, share) in shares.iter().enumerate() {
            total += share;
            // Straight from the share's storage: indexing entry by entry took as long as
            // assembling the shares.
            let share = share.as_slice();
            for (j, &(a, b)) in pairs.iter().enumerate() {
                for col in 0..3 {
                    let from = &share[(3 * b + col) * n + 3 * a..][..3];
                    for (row, value) in from.iter().enumerate() {
                        stacked[(9 * r + row + 3 * col) * rows + j] = *value;
                    }
                }
            }
        }
        Self {
            n,
            pairs,
            stacked,
            assembled_at: rotations,
            total,
        }
    }

    /// The regions' rotations where the shares were assembled.
    pub(super) fn assembled_at(&self) -> &[Matrix3<f64>] {
        &self.assembled_at
    }

    /// The shares summed as assembled.
    pub(super) fn unturned(&self) -> &DMatrix<f64> {
        &self.total
    }

    /// The sum of the shares, each region's turned by Q = R_now R_then^T: every 3 x 3 block
    /// B becomes Q B Q^T, whose column-major entries are (Q (x) Q) vec(B), so all regions'
    /// blocks turn in one (pairs x 9R) (9R x 9) product.
    pub(super) fn turned(&self, rotations: &[Matrix3<f64>]) -> DMatrix<f64> {
        let regions = self.assembled_at.len();
        debug_assert_eq!(rotations.len(), regions, "one rotation per region");
        let mut turns = DMatrix::zeros(9 * regions, 9);
        for (r, (now, then)) in rotations.iter().zip(&self.assembled_at).enumerate() {
            let q = now * then.transpose();
            for (l, k, j, i) in itertools_free_quads() {
                turns[(9 * r + k + 3 * l, i + 3 * j)] = q[(i, k)] * q[(j, l)];
            }
        }
        let rows = self.pairs.len();
        let mut turned = vec![0.0; rows * 9];
        faer::linalg::matmul::matmul(
            MatMut::from_column_major_slice_mut(&mut turned, rows, 9),
            faer::Accum::Replace,
            MatRef::from_column_major_slice(&self.stacked, rows, 9 * regions),
            MatRef::from_column_major_slice(turns.as_slice(), 9 * regions, 9),
            1.0,
            faer::Par::Seq,
        );
        let n = self.n;
        let mut out = DMatrix::zeros(n, n);
        let entries = out.as_mut_slice();
        for (j, &(a, b)) in self.pairs.iter().enumerate() {
            for col in 0..3 {
                for row in 0..3 {
                    let value = turned[(row + 3 * col) * rows + j];
                    entries[(3 * b + col) * n + 3 * a + row] = value;
                    entries[(3 * a + row) * n + 3 * b + col] = value;
                }
            }
        }
        out
    }

    /// Whether `rotations` differ from `turned_to` by more than `tolerance` in any entry.
    pub(super) fn moved(
        turned_to: &[Matrix3<f64>],
        rotations: &[Matrix3<f64>],
        tolerance: f64,
    ) -> bool {
        turned_to.len() != rotations.len()
            || turned_to
                .iter()
                .zip(rotations)
                .any(|(a, b)| (a - b).amax() > tolerance)
    }
}

/// Every (l, k, j, i) in 0..3 to the fourth.
fn itertools_free_quads() -> impl Iterator<Item = (usize, usize, usize, usize)> {
    (0..81).map(|n| (n / 27, n / 9 % 3, n / 3 % 3, n % 3))
}
