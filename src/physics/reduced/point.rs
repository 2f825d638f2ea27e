//! A material point of a reduced body: its rest position and its sample of the subspace, so
//! that where it is in any state costs one small sum.

use nalgebra::{DMatrix, DVector, Vector3};

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
    /// matrix product would allocate (friction and pins take it for a few points; the contact
    /// candidates are placed all at once, `candidate_positions`).
    pub(super) fn at(&self, z: &DMatrix<f64>) -> Vector3<f64> {
        self.rest + self.moved_by(z)
    }

    /// How far the point moves under a change `step` of the state: step phi.
    pub(super) fn moved_by(&self, step: &DMatrix<f64>) -> Vector3<f64> {
        let mut d = Vector3::zeros();
        for (column, p) in step.as_slice().chunks_exact(3).zip(self.phi.iter()) {
            d += Vector3::new(column[0], column[1], column[2]) * *p;
        }
        d
    }
}
