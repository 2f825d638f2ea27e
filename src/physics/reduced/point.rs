//! A material point of a reduced body: its rest position and its sample of the subspace, so
//! that where it is in any state costs one small sum.

use nalgebra::{DMatrix, DVector, Vector3};

use crate::linalg::product;
use crate::physics::subspace::Subspace;

/// A material point of the object expressed in the subspace.
#[derive(Clone)]
pub(super) struct ReducedPoint {
    pub(super) rest: Vector3<f64>,
    pub(super) phi: DVector<f64>,
    /// Mass for pins (kg), area for contacts (m^2).
    pub(super) weight: f64,
    pub(super) target: Vector3<f64>,
    /// Pins moved together (an attachment); 0 for pins that stay where they were put.
    pub(super) group: u32,
}

impl ReducedPoint {
    /// The material points at `rests` sampled in `subspace`, each with its weight, held at its
    /// rest position.
    pub(super) fn sampled(
        subspace: &Subspace,
        rests: &[Vector3<f64>],
        weights: &[f64],
        group: u32,
    ) -> Vec<ReducedPoint> {
        (subspace
            .phis(rests)
            .into_iter()
            .zip(rests.iter().zip(weights)))
        .map(|(phi, (x, w))| ReducedPoint {
            rest: *x,
            phi,
            weight: *w,
            target: *x,
            group,
        })
        .collect()
    }

    /// Where the point is in state `z`: rest + Z phi, summed here without the temporaries a
    /// matrix product would allocate (pins take it for a few points; contact points are placed
    /// all at once, [`placed`]).
    pub(super) fn at(&self, z: &DMatrix<f64>) -> Vector3<f64> {
        let mut x = self.rest;
        for (column, p) in z.as_slice().chunks_exact(3).zip(self.phi.iter()) {
            x += Vector3::new(column[0], column[1], column[2]) * *p;
        }
        x
    }
}

/// Where points with rest positions `rests` (3 x n) and samples `phis` (4K x n) are in state
/// `z` (3 x n), in one product: point by point, a body in a bin (1300 contact candidates)
/// spent most of its step placing them.
pub(super) fn placed(z: &DMatrix<f64>, rests: &DMatrix<f64>, phis: &DMatrix<f64>) -> DMatrix<f64> {
    if rests.ncols() == 0 {
        return DMatrix::zeros(3, 0);
    }
    rests + product(z, phis)
}

/// Some of a body's contact points side by side, placed at a state in one product.
pub(super) struct Gathered {
    /// Which contact points, in order.
    points: Vec<usize>,
    /// Their rest positions (3 x n) and samples (4K x n).
    rests: DMatrix<f64>,
    pub(super) phis: DMatrix<f64>,
}

impl Gathered {
    pub(super) fn new() -> Self {
        Self {
            points: Vec::new(),
            rests: DMatrix::zeros(3, 0),
            phis: DMatrix::zeros(0, 0),
        }
    }

    /// Holds `points`, taken from every contact point's `rests` and `phis`, unless it holds
    /// them already: a body resting on the same points keeps them (megabytes for a column in a
    /// bin, copied in every step before).
    pub(super) fn gather(&mut self, points: Vec<usize>, rests: &DMatrix<f64>, phis: &DMatrix<f64>) {
        if points != self.points {
            self.rests = gather_columns(rests, &points);
            self.phis = gather_columns(phis, &points);
            self.points = points;
        }
    }

    /// Where they are in state `z` (3 x n).
    pub(super) fn placed(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        placed(z, &self.rests, &self.phis)
    }
}

/// The columns `columns` of `from`, in their order: a column copied at a time, where
/// nalgebra's `select_columns` copied entry by entry (8 % of the cell's step in a `perf` of
/// `bench scene`, printed).
pub(super) fn gather_columns(from: &DMatrix<f64>, columns: &[usize]) -> DMatrix<f64> {
    let rows = from.nrows();
    // Filled as it is gathered: zeroing it first was a tenth of the cell's step.
    let mut gathered = Vec::with_capacity(rows * columns.len());
    for &c in columns {
        gathered.extend_from_slice(&from.as_slice()[c * rows..(c + 1) * rows]);
    }
    DMatrix::from_vec(rows, columns.len(), gathered)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gathered_columns_are_the_named_ones_in_order() {
        let from = DMatrix::from_fn(4, 5, |r, c| (10 * c + r) as f64);
        let gathered = gather_columns(&from, &[3, 0, 3]);
        assert_eq!(gathered.shape(), (4, 3));
        for (j, c) in [3, 0, 3].into_iter().enumerate() {
            assert_eq!(gathered.column(j), from.column(c));
        }
        assert_eq!(gather_columns(&from, &[]).shape(), (4, 0));
    }
}
