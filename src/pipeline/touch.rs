//! Soft against soft: every deformable body's contact points are pushed out of the other
//! bodies' contact hulls inside its own solve. The hulls are taken where the bodies were at the
//! start of the step, so bodies stepped in parallel see each other the same way whatever the
//! order. A scene's objects and the node's objects of one frame both collide this way.

use nalgebra::Vector3;
use rayon::prelude::*;

use super::SoftBody;
use crate::physics::Obstacle;

/// Every body's contact hull where it is now (`None` where there is no body). A body far from
/// every other gets an empty hull: nothing can touch it, and its points are not hulled. A
/// sleeping body keeps `kept`, its hull of the last step: its points have not moved.
pub fn contact_hulls(
    bodies: &[Option<&SoftBody>],
    kept: &[Option<&Obstacle>],
) -> Vec<Option<Obstacle>> {
    let reach: Vec<Option<(Vector3<f64>, Vector3<f64>)>> = bodies
        .iter()
        .map(|body| {
            let (lo, hi) = (*body)?.deformed_bounds();
            let margin = Vector3::repeat(0.1 * (hi - lo).norm());
            Some((lo - margin, hi + margin))
        })
        .collect();
    let near = |i: usize, (lo, hi): (Vector3<f64>, Vector3<f64>)| {
        reach.iter().enumerate().any(|(j, other)| {
            j != i
                && other
                    .is_some_and(|(olo, ohi)| (0..3).all(|d| olo[d] <= hi[d] && ohi[d] >= lo[d]))
        })
    };
    bodies
        .par_iter()
        .enumerate()
        .map(|(i, body)| {
            let body = (*body)?;
            let hull = match kept.get(i).copied().flatten() {
                _ if !near(i, reach[i]?) => Obstacle::nowhere(),
                Some(h) if body.is_sleeping() && !body.fell_asleep() && !h.is_nowhere() => {
                    h.clone()
                }
                _ => body.contact_hull().unwrap_or_else(Obstacle::nowhere),
            };
            Some(hull)
        })
        .collect()
}
