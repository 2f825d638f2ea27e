//! Moving a running simulation into another subspace of the same body (a refined field that
//! arrives while the body moves). The state is carried over by least squares on the cubature
//! points, everything sampled from the field (pins, contact points, pokes) is sampled anew,
//! and what was cached for the old subspace (Hessians, preconditioner, curvature pairs) is
//! dropped; obstacles, friction anchors and the clock carry on.

use std::sync::Arc;

use nalgebra::{DMatrix, Vector3};

use super::{ReducedPoint, ReducedSim};
use crate::error::{Error, Result};
use crate::physics::subspace::Subspace;

impl ReducedSim {
    /// Continues in `subspace` from where the body is now. `points` and `masses` (kg) are the
    /// material points the state is fitted on, the cubature points with their masses: the new
    /// state is the one whose displacement of these points is closest to the current one in
    /// the mass-weighted least-squares sense (the previous state likewise, so the velocity
    /// carries over too). Rigid motions carry over exactly (both fields hold the constant).
    /// Fails when the new subspace is degenerate on `points`.
    pub fn rebase(
        &mut self,
        subspace: Arc<Subspace>,
        points: &[Vector3<f64>],
        masses: &[f64],
    ) -> Result<()> {
        let projection = projection(&self.subspace, &subspace, points, masses)?;
        let mut next = ReducedSim::new(subspace, self.params.clone(), self.solver, self.diagonal)?;
        next.z = &self.z * &projection;
        next.z_prev = &self.z_prev * &projection;
        next.time = self.time;
        next.pins = resampled(&next.subspace, &self.pins);
        for pin in &next.pins {
            next.pin_phi.ger(pin.weight, &pin.phi, &pin.phi, 1.0);
        }
        next.update_pin_offsets();
        next.contacts = resampled(&next.subspace, &self.contacts);
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
        *self = next;
        self.prepare();
        Ok(())
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

/// P (4K_old x 4K_new) such that Z_old P is the least-squares fit in the new subspace: with
/// C = sum m phi_old phi_new^T and N = sum m phi_new phi_new^T, Z_new N = Z_old C.
fn projection(
    old: &Subspace,
    new: &Subspace,
    points: &[Vector3<f64>],
    masses: &[f64],
) -> Result<DMatrix<f64>> {
    let (a, b) = (old.phis(points), new.phis(points));
    let (n_old, n_new) = (4 * old.handles(), 4 * new.handles());
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
            new.handles()
        ))
    })?;
    Ok(cholesky.solve(&cross.transpose()).transpose())
}
