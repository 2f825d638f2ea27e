//! A body from what a sensor gave: a mesh as it is, a cloud read from a thinned copy, and one
//! camera's view of an object completed first. The node, the replay and `simulate --input` all
//! build this way.

use std::sync::Arc;

use nalgebra::Vector3;

use super::{BodyOptions, SoftBody};
use crate::geometry::{complete_view, view_downsample, voxel_downsample, Completion, Shape};
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
    let read = match (is_cloud, viewpoint) {
        (false, _) => points.to_vec(),
        (true, Some(viewpoint)) => view_downsample(points, viewpoint, max_build_points),
        (true, None) => voxel_downsample(points, max_build_points),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{bundled, scan_points, Camera};
    use crate::pipeline::Support;

    /// A VGA depth camera's view (40,000 points of the bundled sphere) is thinned to the build
    /// cap before it is completed. The completion read the thinned cloud's pixel pitch as its
    /// median neighbour distance, which a thinned raster no longer has: most of its rim bins
    /// came out empty, side walls ran through the solid, and the body held 0.65 of the volume.
    #[test]
    fn a_vga_scan_thinned_to_the_cap_keeps_its_volume() {
        let model = Arc::new(NeuralModel::bundled().unwrap());
        let options = BodyOptions {
            support: Support::Free,
            ..BodyOptions::default()
        };
        let sphere = bundled("sphere").unwrap();
        let truth = sphere.closed_volume().unwrap();
        let camera = Camera::looking_at(&sphere, Vector3::new(1.0, 0.6, 0.8), 1.5, 640, 480);
        let points = scan_points(&sphere, &camera).unwrap();
        assert!(
            points.len() > 2 * DEFAULT_MAX_BUILD_POINTS - 1000,
            "{} points",
            points.len()
        );
        let seen = build_seen(
            &model,
            &points,
            &[],
            Some(&camera.position),
            DEFAULT_MAX_BUILD_POINTS,
            &options,
        )
        .unwrap();
        assert!(seen.completion.is_some(), "the view is completed");
        assert!(
            seen.read_from <= DEFAULT_MAX_BUILD_POINTS,
            "read from {}",
            seen.read_from
        );
        let ratio = seen.body.volume() / truth;
        assert!(
            (ratio - 1.0).abs() < 0.1,
            "the completed sphere holds {ratio:.3} of its volume"
        );
    }
}
