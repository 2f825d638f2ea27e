//! The curvature of contact and friction springs, sum_i (phi_i phi_i^T) (x) S_i over the
//! points they act on, S_i = sum s n n^T over point i's springs (stiffness s, direction n).
//!
//! A landing body's springs mostly share one direction: every point on a floor pushes along
//! its normal, and its friction pulls across it, s (I - n n^T). Grouped by direction, the sum
//! is (Phi diag(a) Phi^T) (x) I + sum_k (Phi diag(b_k) Phi^T) (x) n_k n_k^T: one 4K x 4K
//! product per direction (and one for the isotropic part) where six, one per pair of axes,
//! serve springs pointing anywhere.

use nalgebra::{DMatrix, Matrix3, Vector3};

use crate::linalg::symmetric_product;

/// Directions closer than this (largest entry) are taken as one: a friction spring's normal,
/// the cross product of its tangents, differs from the contact normal in the last bits.
const SAME_DIRECTION: f64 = 1e-12;
/// Distinct directions past which the six products by pairs of axes cost less.
const MOST_DIRECTIONS: usize = 4;

/// A spring direction and the (point, stiffness) of each term along it.
pub(super) type DirectionGroup = (Vector3<f64>, Vec<(usize, f64)>);

/// The springs acting on contact points, gathered before their curvature is formed.
#[derive(Default)]
pub(super) struct Springs {
    /// (point, stiffness) of each isotropic term s I.
    isotropic: Vec<(usize, f64)>,
    /// (point, stiffness, direction) of each term s n n^T.
    along: Vec<(usize, f64, Vector3<f64>)>,
}

impl Springs {
    /// A spring of stiffness `s` on `point` pulling along the unit vector `n`.
    pub fn add_along(&mut self, point: usize, s: f64, n: &Vector3<f64>) {
        self.along.push((point, s, *n));
    }

    /// Springs of stiffness `s` on `point` pulling along both unit tangents `t` (orthogonal),
    /// that is, across their normal: s (I - n n^T).
    pub fn add_across(&mut self, point: usize, s: f64, t: &[Vector3<f64>; 2]) {
        self.isotropic.push((point, s));
        self.along.push((point, -s, t[0].cross(&t[1])));
    }

    pub fn is_empty(&self) -> bool {
        self.isotropic.is_empty() && self.along.is_empty()
    }

    /// The springs' curvature (12K x 12K, flat z order) for points whose weights are the
    /// columns of `phis` (4K x points).
    pub fn curvature(&self, phis: &DMatrix<f64>) -> DMatrix<f64> {
        let n4 = phis.nrows();
        let Some(groups) = self.by_direction() else {
            let (touched, blocks) = self.blocks(phis);
            return kronecker_blocks(&touched, &blocks);
        };
        let mut out = DMatrix::zeros(3 * n4, 3 * n4);
        if !self.isotropic.is_empty() {
            add_kronecker(
                &mut out,
                &weighted_gram(phis, &self.isotropic),
                &Matrix3::identity(),
            );
        }
        for (n, terms) in &groups {
            add_kronecker(&mut out, &weighted_gram(phis, terms), &(n * n.transpose()));
        }
        out
    }

    /// The directional terms grouped by direction, None past `MOST_DIRECTIONS` of them.
    pub(super) fn by_direction(&self) -> Option<Vec<DirectionGroup>> {
        let mut groups: Vec<DirectionGroup> = Vec::new();
        for &(point, s, n) in &self.along {
            let same = groups
                .iter()
                .position(|(m, _)| (m - n).amax() <= SAME_DIRECTION);
            match same {
                Some(g) => groups[g].1.push((point, s)),
                None if groups.len() < MOST_DIRECTIONS => groups.push((n, vec![(point, s)])),
                None => return None,
            }
        }
        Some(groups)
    }

    /// The weights (4K x touched points) and 3 x 3 block of every point a spring acts on.
    fn blocks(&self, phis: &DMatrix<f64>) -> (DMatrix<f64>, Vec<Matrix3<f64>>) {
        let mut blocks: Vec<Option<Matrix3<f64>>> = vec![None; phis.ncols()];
        for &(point, s) in &self.isotropic {
            *blocks[point].get_or_insert_with(Matrix3::zeros) += Matrix3::identity() * s;
        }
        for &(point, s, n) in &self.along {
            *blocks[point].get_or_insert_with(Matrix3::zeros) += n * n.transpose() * s;
        }
        let touched: Vec<usize> = (0..blocks.len()).filter(|&i| blocks[i].is_some()).collect();
        let gathered = DMatrix::from_fn(phis.nrows(), touched.len(), |a, j| phis[(a, touched[j])]);
        (gathered, blocks.into_iter().flatten().collect())
    }
}

/// Phi diag(s) Phi^T over the (point, s) `terms`, Phi the points' columns of `phis`.
fn weighted_gram(phis: &DMatrix<f64>, terms: &[(usize, f64)]) -> DMatrix<f64> {
    let n4 = phis.nrows();
    let gathered = DMatrix::from_fn(n4, terms.len(), |a, j| phis[(a, terms[j].0)]);
    let weighted = DMatrix::from_fn(n4, terms.len(), |a, j| gathered[(a, j)] * terms[j].1);
    symmetric_product(&gathered, &weighted)
}

/// out += gram (x) block in flat z order (entry (3a + d, 3b + e) = gram[a, b] block[d, e]).
fn add_kronecker(out: &mut DMatrix<f64>, gram: &DMatrix<f64>, block: &Matrix3<f64>) {
    let n4 = gram.nrows();
    for b in 0..n4 {
        for a in 0..n4 {
            let g = gram[(a, b)];
            for e in 0..3 {
                for d in 0..3 {
                    out[(3 * a + d, 3 * b + e)] += g * block[(d, e)];
                }
            }
        }
    }
}

/// sum_i (phi_i phi_i^T) (x) S_i in flat z order, phi_i the columns of `phis` (4K x points)
/// and S_i symmetric 3 x 3, as six (4K x 4K) products over the points, one per pair of axes,
/// instead of a (12K)^2 update per point.
fn kronecker_blocks(phis: &DMatrix<f64>, blocks: &[Matrix3<f64>]) -> DMatrix<f64> {
    let n4 = phis.nrows();
    let mut out = DMatrix::zeros(3 * n4, 3 * n4);
    for d in 0..3 {
        for e in d..3 {
            let mut weighted = phis.clone();
            for (i, block) in blocks.iter().enumerate() {
                weighted.column_mut(i).scale_mut(block[(d, e)]);
            }
            let block = symmetric_product(phis, &weighted);
            for b in 0..n4 {
                for a in 0..n4 {
                    out[(3 * a + d, 3 * b + e)] = block[(a, b)];
                    out[(3 * a + e, 3 * b + d)] = block[(a, b)];
                }
            }
        }
    }
    out
}
