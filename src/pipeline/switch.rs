//! Switching a running body to another field of the same shape: the network's field refined
//! toward the skinning eigenmodes, ready after the body started moving. The new field is
//! sampled off the stepping thread ([`BasisPlan`] -> [`PreparedBasis`]) and swapped in between
//! two steps ([`crate::SoftBody::switch_to`]), the state carried over by least squares.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, DVector, Vector3};

use crate::error::{Error, Result};
use crate::geometry::{Cubature, Normalization, TetMesh, VoxelGrid};
use crate::physics::{sample, state_projection, Lifter, ReducedSim, SimSetup, Subspace};
use crate::skinning::{refine_field_until, RefineOptions, RefineReport, Refined, SkinningField};

/// Tet mesh cells across the solid's longest side for the refinement: the eigenmodes' own
/// problem at the resolution `eval` and `bench basis` measure it on.
pub const REFINE_RESOLUTION: usize = 24;

/// What preparing a switch needs from a body, owned, so another thread can do it.
#[derive(Clone)]
pub struct BasisPlan {
    pub(super) field: Arc<dyn SkinningField>,
    pub(super) map: Normalization,
    pub(super) cubature: Cubature,
    pub(super) points: Vec<Vector3<f64>>,
    /// The simulation's contact points (rest positions, in its order).
    pub(super) contacts: Vec<Vector3<f64>>,
    /// The simulation's setup (its density among its parameters), for its twin in the new
    /// subspace.
    pub(super) setup: SimSetup,
    pub(super) grid: VoxelGrid,
}

/// A field sampled where a body needs it, ready to switch to.
pub struct PreparedBasis {
    /// The field the body ran when the plan was made: a body that has moved on since (rebuilt
    /// on new geometry) refuses the switch.
    pub(super) from: Arc<dyn SkinningField>,
    pub(super) field: Arc<dyn SkinningField>,
    /// The simulation in the new subspace, set up as the body's was when the plan was made.
    pub(super) twin: ReducedSim,
    /// The state's map from the old subspace to the new ([`state_projection`]).
    pub(super) projection: DMatrix<f64>,
    /// The contact points in the new subspace.
    pub(super) contact_phis: Vec<DVector<f64>>,
    /// Weights at the body's points (points x handles, row-major), as the body keeps them.
    pub(super) weights: Vec<f32>,
    /// The body's points bound to the new field.
    pub(super) lifter: Lifter,
    /// How the refinement went (None for a field given as is).
    pub refine: Option<RefineReport>,
    /// Refinement and sampling, ms.
    pub prepare_ms: f64,
}

/// What a switch did.
#[derive(Clone, Debug, Default)]
pub struct SwitchReport {
    /// The largest distance between a point's position before and after the switch, m.
    pub max_jump_m: f64,
    /// Handles of the new field, the constant one included.
    pub handles: usize,
}

/// `field` refined toward the skinning eigenmodes of `grid`'s solid, on its tet mesh at
/// [`REFINE_RESOLUTION`]; `stop` ends the iterations early. An `Error::Geometry` when the
/// solid is too thin for that mesh to hold the field's handles (a sheet thinner than a cell).
pub(super) fn refine_on_solid(
    field: &dyn SkinningField,
    grid: &VoxelGrid,
    map: Normalization,
    options: &RefineOptions,
    stop: &dyn Fn() -> bool,
) -> Result<Refined> {
    let mesh = TetMesh::from_grid(&grid.resample(REFINE_RESOLUTION));
    if mesh.vertices.len() <= field.handle_count() {
        return Err(Error::Geometry(format!(
            "too thin to refine: its tet mesh at {REFINE_RESOLUTION} cells across has {} vertices \
             for {} handles",
            mesh.vertices.len(),
            field.handle_count()
        )));
    }
    refine_field_until(field, mesh, map, options, stop)
}

impl BasisPlan {
    /// Where the state is carried over, with weights: the cubature points by mass (the body's
    /// volume, its physics) and the body's own points with as much weight again, shared evenly
    /// (what a consumer sees). Fitted on the cubature points alone, the points on the surface,
    /// which the interior cubature does not reach, were left to the new field's extrapolation:
    /// a soft creature sagging 60 to 170 mm jumped 51 to 66 mm at the switch, 1.9 to 4.1 mm
    /// fitted on both (printed).
    fn fit_samples(&self, density: f64) -> (Vec<Vector3<f64>>, Vec<f64>) {
        let mut points = self.cubature.points.clone();
        let mut weights: Vec<f64> = self.cubature.volumes.iter().map(|v| density * v).collect();
        let each = weights.iter().sum::<f64>() / self.points.len().max(1) as f64;
        points.extend_from_slice(&self.points);
        weights.resize(points.len(), each);
        (points, weights)
    }

    /// The body's field refined toward the skinning eigenmodes on the solid's tet mesh
    /// ([`REFINE_RESOLUTION`]), then sampled.
    pub fn refined(&self, options: &RefineOptions) -> Result<PreparedBasis> {
        self.refined_until(options, &|| false)
    }

    /// [`BasisPlan::refined`], stopping early (with what it has) once `stop` says so.
    pub fn refined_until(
        &self,
        options: &RefineOptions,
        stop: &dyn Fn() -> bool,
    ) -> Result<PreparedBasis> {
        let started = Instant::now();
        let refined = refine_on_solid(self.field.as_ref(), &self.grid, self.map, options, stop)?;
        let mut prepared = self.prepare(Arc::new(refined.field))?;
        prepared.refine = Some(refined.report);
        prepared.prepare_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok(prepared)
    }

    /// `field` sampled where the body needs it, and the simulation's twin in its subspace with
    /// the pins as they were when the plan was made (see `ReducedSim::prepared_twin`; a switch
    /// after they changed sets them up anew), so that the switch itself costs little on the
    /// stepping thread. Fails when the new field is degenerate on the cubature points.
    pub fn prepare(&self, field: Arc<dyn SkinningField>) -> Result<PreparedBasis> {
        let started = Instant::now();
        let density = self.setup.params().density;
        let subspace = Arc::new(Subspace::build(
            field.clone(),
            self.map,
            &self.cubature,
            density,
        ));
        let twin = ReducedSim::prepared_twin(subspace.clone(), &self.setup)?;
        let (fit_points, fit_weights) = self.fit_samples(density);
        let projection = state_projection(
            self.field.as_ref(),
            field.as_ref(),
            &self.map,
            &fit_points,
            &fit_weights,
        )?;
        let (weights, _) = sample(field.as_ref(), &self.map, &self.points, false);
        Ok(PreparedBasis {
            from: self.field.clone(),
            contact_phis: subspace.phis(&self.contacts),
            lifter: Lifter::from_weights(field.handle_count(), &weights, &self.points),
            field,
            twin,
            projection,
            weights: weights.iter().map(|&w| w as f32).collect(),
            refine: None,
            prepare_ms: started.elapsed().as_secs_f64() * 1e3,
        })
    }
}
