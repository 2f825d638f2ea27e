//! Switching a running body to another field of the same shape: the network's field refined
//! toward the skinning eigenmodes, ready after the body started moving. The new field is
//! sampled off the stepping thread ([`BasisPlan`] -> [`PreparedBasis`]) and swapped in between
//! two steps ([`crate::SoftBody::switch_to`]), the state carried over by least squares.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::Vector3;

use crate::error::Result;
use crate::geometry::{Cubature, Normalization, TetMesh, VoxelGrid};
use crate::physics::{sample, Subspace};
use crate::skinning::{refine_field, RefineOptions, RefineReport, SkinningField};

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
    pub(super) density: f64,
    pub(super) grid: VoxelGrid,
}

/// A field sampled where a body needs it, ready to switch to.
pub struct PreparedBasis {
    /// The field the body ran when the plan was made: a body that has moved on since (rebuilt
    /// on new geometry) refuses the switch.
    pub(super) from: Arc<dyn SkinningField>,
    pub(super) field: Arc<dyn SkinningField>,
    pub(super) subspace: Arc<Subspace>,
    /// Weights at the body's points (points x handles, row-major).
    pub(super) weights: Vec<f64>,
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

impl BasisPlan {
    /// The body's field refined toward the skinning eigenmodes on the solid's tet mesh
    /// ([`REFINE_RESOLUTION`]), then sampled.
    pub fn refined(&self, options: &RefineOptions) -> Result<PreparedBasis> {
        let started = Instant::now();
        let mesh = TetMesh::from_grid(&self.grid.resample(REFINE_RESOLUTION));
        let refined = refine_field(self.field.as_ref(), mesh, self.map, options)?;
        let mut prepared = self.prepare(Arc::new(refined.field));
        prepared.refine = Some(refined.report);
        prepared.prepare_ms = started.elapsed().as_secs_f64() * 1e3;
        Ok(prepared)
    }

    /// `field` sampled at the body's cubature and points.
    pub fn prepare(&self, field: Arc<dyn SkinningField>) -> PreparedBasis {
        let started = Instant::now();
        let subspace = Subspace::build(field.clone(), self.map, &self.cubature, self.density);
        let (weights, _) = sample(field.as_ref(), &self.map, &self.points, false);
        PreparedBasis {
            from: self.field.clone(),
            field,
            subspace: Arc::new(subspace),
            weights,
            refine: None,
            prepare_ms: started.elapsed().as_secs_f64() * 1e3,
        }
    }
}
