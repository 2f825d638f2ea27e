//! A body from what a sensor gave: a mesh as it is, a cloud read from a thinned copy, and one
//! camera's view of an object completed first. The node, the replay and `simulate --input` all
//! build this way.

use std::sync::Arc;

use nalgebra::Vector3;

use super::{BodyOptions, SoftBody};
use crate::geometry::{complete_view, voxel_downsample, Completion, Shape};
use crate::skinning::NeuralModel;
use crate::{Error, Result};

/// A cloud with more points is read from a voxel-downsampled copy of this many (the node's
/// default `inference.max_build_points`).
pub const DEFAULT_MAX_BUILD_POINTS: usize = 20_000;

/// A built body and how it was read.
pub struct SeenBody {
    /// The body.
    pub body: SoftBody,
    /// What the completion of a view did (None: the input needed none).
    pub completion: Option<Completion>,
    /// Points the shape was read from (fewer than the input's when it was thinned).
    pub read_from: usize,
}

/// The body of `points` (with `triangles`, a mesh; without, a cloud), deforming every point.
/// A cloud is read from at most `max_build_points` of its points; seen from `viewpoint`, it
/// is completed first when it is one view of its object, or refused when it cannot be. Lines
/// and planes are refused as such.
pub fn build_seen(
    model: &Arc<NeuralModel>,
    points: &[Vector3<f64>],
    triangles: &[[u32; 3]],
    viewpoint: Option<&Vector3<f64>>,
    max_build_points: usize,
    options: &BodyOptions,
) -> Result<SeenBody> {
    let is_cloud = triangles.is_empty();
    // A mesh's triangles index all its vertices, so a mesh is read whole.
    let read = if is_cloud {
        voxel_downsample(points, max_build_points)
    } else {
        points.to_vec()
    };
    let read_from = read.len();
    let shape = Shape::new(read, None, triangles.to_vec())?;
    // A line or a plane is refused as such before it is taken for one side of something.
    shape.check_solid()?;
    let view = match viewpoint.filter(|_| is_cloud) {
        Some(viewpoint) => complete_view(&shape.positions, viewpoint, options.floor_z)
            .map_err(|e| Error::Geometry(e.to_string()))?,
        None => None,
    };
    let (body, completion) = match view {
        Some(view) => (
            SoftBody::build_view(model, &view, points, options)?,
            Some(view.report),
        ),
        None => (SoftBody::build(model, &shape, points, options)?, None),
    };
    Ok(SeenBody {
        body,
        completion,
        read_from,
    })
}
