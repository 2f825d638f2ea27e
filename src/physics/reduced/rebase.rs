//! Moving a running simulation into another subspace of the same body (a refined field that
//! arrives while the body moves). The state is carried over by least squares on the cubature
//! points, everything sampled from the field (pins, contact points, pokes) is sampled anew,
//! and what was cached for the old subspace (Hessians, preconditioner, curvature pairs) is
//! dropped; obstacles, friction anchors and the clock carry on. What does not depend on the
//! state (the pins' samples and pinning, the preconditioner's factor) is prepared beforehand,
//! off the stepping thread, in a twin of the simulation.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::{ReducedPoint, ReducedSim, Solver};
use crate::error::{Error, Result};
use crate::geometry::Normalization;
use crate::physics::subspace::{phis, Subspace};
use crate::physics::SimParams;
use crate::skinning::SkinningField;

/// How a simulation is set up apart from its subspace and its state: what preparing its twin
/// in another subspace needs ([`ReducedSim::prepared_twin`]), owned, for another thread.
#[derive(Clone)]
pub struct SimSetup {
    params: SimParams,
    solver: Solver,
    diagonal: f64,
    pins: Vec<ReducedPoint>,
}

impl SimSetup {
    /// The simulation's parameters.
    pub fn params(&self) -> &SimParams {
        &self.params
    }
}

impl ReducedSim {
    /// This simulation's setup: parameters, solver, size and pins.
    pub fn setup(&self) -> SimSetup {
        SimSetup {
            params: self.params.clone(),
            solver: self.solver,
            diagonal: self.diagonal,
            pins: self.pins.clone(),
        }
    }

    /// A simulation set up as `setup` in `subspace`, at rest, with its pins sampled, their
    /// pinning found and its preconditioner factored on the rest Hessian: what
    /// [`ReducedSim::rebase`] would otherwise do on the stepping thread, done where this is
    /// called (where a refined basis is prepared). In `bench latency`'s switches that work took
    /// 0.74 to 2.98 ms of the stepping thread (printed).
    pub fn prepared_twin(subspace: Arc<Subspace>, setup: &SimSetup) -> Result<ReducedSim> {
        let mut twin = Self::set_up_in(subspace, setup)?;
        twin.prepare();
        Ok(twin)
    }

    /// A simulation at rest in `subspace`, set up as `setup` says, its pins sampled there.
    fn set_up_in(subspace: Arc<Subspace>, setup: &SimSetup) -> Result<ReducedSim> {
        let mut sim =
            ReducedSim::new(subspace, setup.params.clone(), setup.solver, setup.diagonal)?;
        sim.pins = resampled(&sim.subspace, &setup.pins);
        sim.pins_changed();
        Ok(sim)
    }

    /// Continues in `twin`'s subspace from where the body is now, the state mapped by
    /// `projection` (`state_projection`: the least-squares fit on the cubature points, so the
    /// velocity carries over too). `twin` is a [`ReducedSim::prepared_twin`] of this
    /// simulation, or any simulation in the new subspace: one set up otherwise than this one
    /// now is (its pins added or released since) is set up anew here. `contact_phis` are the
    /// contact points sampled in the new subspace, in their order
    /// ([`ReducedSim::contact_rests`]); sampled here when they do not match.
    pub fn rebase(
        &mut self,
        twin: ReducedSim,
        projection: &DMatrix<f64>,
        contact_phis: Vec<DVector<f64>>,
    ) -> Result<()> {
        let (rows, columns) = (4 * self.subspace.handles(), 4 * twin.subspace.handles());
        if projection.shape() != (rows, columns) {
            return Err(Error::LinearAlgebra(format!(
                "a {:?} state projection between {rows} and {columns} coordinates",
                projection.shape()
            )));
        }
        let mut next = self.set_up_like_this(twin)?;
        next.z = &self.z * projection;
        next.z_prev = &self.z_prev * projection;
        next.time = self.time;
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
        *self = next;
        self.prepare();
        Ok(())
    }

    /// `twin` with this simulation's setup: as it is where it was prepared with the same one
    /// (the pins' targets, which may have moved, taken over), else a new simulation in its
    /// subspace with this setup. The preconditioner holds the new subspace's rest Hessian
    /// (kept by the subspace), turned with the body: one at the state was assembled over every
    /// cubature point between two ticks, 3.0 to 7.0 ms of the node's stepping thread in
    /// `bench latency`'s switches on 2 cores (printed). A held Hessian that does not describe
    /// the state is refreshed by the steps that find it stale.
    fn set_up_like_this(&self, twin: ReducedSim) -> Result<ReducedSim> {
        let same_pins = twin.pins.len() == self.pins.len()
            && twin
                .pins
                .iter()
                .zip(&self.pins)
                .all(|(a, b)| a.rest == b.rest && a.weight == b.weight && a.group == b.group);
        let mut next = if same_pins && twin.params == self.params && twin.solver == self.solver {
            twin
        } else {
            Self::set_up_in(twin.subspace, &self.setup())?
        };
        for (pin, now) in next.pins.iter_mut().zip(&self.pins) {
            pin.target = now.target;
        }
        next.update_pin_offsets();
        if next.held.is_none() {
            next.held = Some((*next.rest_elastic_hessian()).clone());
            next.held_rotation = Matrix3::identity();
        }
        Ok(next)
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
