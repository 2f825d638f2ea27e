//! Moving a running simulation into another subspace of the same body (a refined field that
//! arrives while the body moves). The state is carried over by least squares on the cubature
//! points, everything sampled from the field (pins, contact points, pokes) is sampled anew,
//! and what was cached for the old subspace (Hessians, preconditioner, curvature pairs) is
//! dropped; obstacles, friction anchors and the clock carry on.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::{ReducedPoint, ReducedSim};
use crate::error::{Error, Result};
use crate::geometry::Normalization;
use crate::physics::subspace::{phis, Subspace};
use crate::skinning::SkinningField;

impl ReducedSim {
    /// Continues in `subspace` from where the body is now, the state mapped by `projection`
    /// ([`state_projection`]: the least-squares fit on the cubature points, so the velocity
    /// carries over too). `contact_phis` are the contact points sampled in the new subspace,
    /// in their order ([`ReducedSim::contact_rests`]); sampled here when they do not match.
    pub fn rebase(
        &mut self,
        subspace: Arc<Subspace>,
        projection: &DMatrix<f64>,
        contact_phis: Vec<DVector<f64>>,
    ) -> Result<()> {
        let (rows, columns) = (4 * self.subspace.handles(), 4 * subspace.handles());
        if projection.shape() != (rows, columns) {
            return Err(Error::LinearAlgebra(format!(
                "a {:?} state projection between {rows} and {columns} coordinates",
                projection.shape()
            )));
        }
        let mut next = ReducedSim::new(subspace, self.params.clone(), self.solver, self.diagonal)?;
        next.z = &self.z * projection;
        next.z_prev = &self.z_prev * projection;
        next.time = self.time;
        next.pins = resampled(&next.subspace, &self.pins);
        next.pins_changed();
        next.contacts = if contact_phis.len() == self.contacts.len() {
            (self.contacts.iter().zip(contact_phis))
                .map(|(p, phi)| ReducedPoint { phi, ..p.clone() })
                .collect()
        } else {
            resampled(&next.subspace, &self.contacts)
        };
        next.contacts_changed();
        let pokes: Vec<_> = self.pokes.iter().map(|(_, poke)| *poke).collect();
        let phis = next
            .subspace
            .phis(&pokes.iter().map(|p| p.point).collect::<Vec<_>>());
        next.pokes = phis.into_iter().zip(pokes).collect();
        next.obstacles = std::mem::take(&mut self.obstacles);
        next.colliders = std::mem::take(&mut self.colliders);
        next.colliders_before = std::mem::take(&mut self.colliders_before);
        next.anchors = std::mem::take(&mut self.anchors);
        next.roll_anchors = std::mem::take(&mut self.roll_anchors);
        // The preconditioner holds the new subspace's rest Hessian (assembled where the basis
        // was prepared), turned with the body. One at the state was assembled over every
        // cubature point between two ticks: `prepare` below took 3.0 to 7.0 ms of the node's
        // stepping thread in `bench latency`'s switches on 2 cores, 0.74 to 2.98 ms without
        // (printed). A held Hessian that does not describe the state is refreshed by the steps
        // that find it stale.
        next.held = Some((*next.rest_elastic_hessian()).clone());
        next.held_rotation = Matrix3::identity();
        *self = next;
        self.prepare();
        Ok(())
    }
}

impl ReducedSim {
    /// The rest positions of the contact points, in their order.
    pub fn contact_rests(&self) -> Vec<Vector3<f64>> {
        self.contacts.iter().map(|p| p.rest).collect()
    }
}

/// The same material points sampled in `subspace`.
fn resampled(subspace: &Subspace, points: &[ReducedPoint]) -> Vec<ReducedPoint> {
    let rests: Vec<Vector3<f64>> = points.iter().map(|p| p.rest).collect();
    subspace
        .phis(&rests)
        .into_iter()
        .zip(points)
        .map(|(phi, p)| ReducedPoint {
            phi,
            rest: p.rest,
            weight: p.weight,
            target: p.target,
            group: p.group,
        })
        .collect()
}

/// P (4K_old x 4K_new) such that Z_old P is the least-squares fit in `new`'s subspace of the
/// displacement of `points` (masses in kg) under `old`'s: with C = sum m phi_old phi_new^T and
/// N = sum m phi_new phi_new^T, Z_new N = Z_old C. Fails when `new` is degenerate on `points`.
pub fn state_projection(
    old: &dyn SkinningField,
    new: &dyn SkinningField,
    normalization: &Normalization,
    points: &[Vector3<f64>],
    masses: &[f64],
) -> Result<DMatrix<f64>> {
    let (a, b) = (
        phis(old, normalization, points),
        phis(new, normalization, points),
    );
    let (n_old, n_new) = (4 * old.handle_count(), 4 * new.handle_count());
    let mut cross = DMatrix::zeros(n_old, n_new);
    let mut gram = DMatrix::zeros(n_new, n_new);
    for ((phi_old, phi_new), &m) in a.iter().zip(&b).zip(masses) {
        cross.ger(m, phi_old, phi_new, 1.0);
        gram.ger(m, phi_new, phi_new, 1.0);
    }
    let cholesky = gram.cholesky().ok_or_else(|| {
        Error::LinearAlgebra(format!(
            "the new subspace is degenerate on {} points ({} handles)",
            points.len(),
            new.handle_count()
        ))
    })?;
    Ok(cholesky.solve(&cross.transpose()).transpose())
}
