//! Where a smooth compact object's centre lies behind its silhouette. Seen in perspective, a
//! smooth convex surface turns away from the camera before its widest section: an ellipsoid's
//! silhouette lies in the camera's polar plane, whose section is centred a^2 / D in front of the
//! centre (a the radius along the view, D the centre's distance), while the surface lies a in
//! front of it. The rim's centroid then stands in front of the centre: 1.5 to 4.5 cm for
//! `bench views`' turned ellipsoid, which came out 0.54 to 0.68 of its volume from four sides.
//! A box's silhouette is its back edges and its rim's centroid lies at its centre: the
//! correction is made only where the surface rises towards the outline as a smooth cap does.
//! Where the points seen lie on an ellipsoid, its centre is fitted instead (`ellipsoid_centre`),
//! and the correction is left to smooth objects that are no ellipsoid.

use nalgebra::{Vector2, Vector3};

use super::quadric::{Quadric, ACROSS_BOUNDS, DEPTH_BOUNDS};

/// Sectors around the centre in the image, each with its own reach to the outline.
const SECTORS: usize = 36;
/// Points this far from the centre towards the outline (as a share of the sector's reach) show
/// the depth profile.
const HALFWAY: std::ops::Range<f64> = 0.4..0.6;
/// A surface whose points halfway to the outline lie less than this share of the way from the
/// surface in front of the centre to the rim's depth is taken as a smooth cap. A sphere's lie
/// about 0.13 of the way, a cone's half of it. In `bench views` (printed): the sphere 0.135 to
/// 0.143, the turned ellipsoid 0.042 to 0.202, the box 0.220 to 0.361 from the sides where its
/// rim is right and 0.097 to 0.177 seen low (its rim then in front too), the creature 0.148 to
/// 0.280.
const SMOOTH_PROFILE: f64 = 0.2;

/// The points must lie this close to the fitted ellipsoid (root mean square, against its
/// smallest semi-axis) for the object to be taken as one.
const ELLIPSOIDAL: f64 = 0.02;

/// The centre of the ellipsoid fitted to the points seen (see `Quadric::fit`), where they lie
/// on one within `ELLIPSOIDAL` and it spans the outline: `axes` are the outline's two axes
/// across the view, with half its extent along each, and `forward` the view's direction. The
/// ellipsoid's centre holds the information of every point of the visible half; the rim's, of
/// the outline's last pixels, which fall short of where the surface turns away. None for a
/// box, an animal, a ring: anything the visible half of no ellipsoid describes.
pub(super) fn ellipsoid_centre(
    points: &[Vector3<f64>],
    axes: [(Vector3<f64>, f64); 2],
    forward: &Vector3<f64>,
) -> Option<Vector3<f64>> {
    let fitted = Quadric::fit(points)?;
    let spans = axes
        .iter()
        .all(|(axis, half)| ACROSS_BOUNDS.contains(&(fitted.half_extent(axis) / half)));
    let breadth = axes[0].1.min(axes[1].1);
    let deep = DEPTH_BOUNDS.contains(&(fitted.half_extent(forward) / breadth));
    (spans && deep && fitted.misfit <= ELLIPSOIDAL * fitted.minor()).then_some(fitted.centre)
}

/// The centre's depth behind a rim centroid at depth `rim`, whose image position is `centre`,
/// with the surface in front of it at depth `front`: moved back as an ellipsoid's would be when
/// the points (`image`, `depths`) rise as a smooth cap does, else `rim`.
pub(super) fn depth_behind_rim(
    image: &[Vector2<f64>],
    depths: &[f64],
    centre: &Vector2<f64>,
    rim: f64,
    front: f64,
) -> f64 {
    // The ellipsoid's: rim = D - a^2 / D and front = D - a give D = front^2 / (2 front - rim).
    let behind = front.is_finite() && front < rim && 2.0 * front > rim;
    match profile_share(image, depths, centre, rim, front) {
        Some(share) if behind && share < SMOOTH_PROFILE => front * front / (2.0 * front - rim),
        _ => rim,
    }
}

/// The median share of the way from `front` to `rim` at which the points halfway from `centre`
/// to the outline lie (None when none do).
fn profile_share(
    image: &[Vector2<f64>],
    depths: &[f64],
    centre: &Vector2<f64>,
    rim: f64,
    front: f64,
) -> Option<f64> {
    let polar: Vec<(usize, f64)> = image
        .iter()
        .map(|q| {
            let d = q - centre;
            let turn = (d.y.atan2(d.x) + std::f64::consts::PI) / std::f64::consts::TAU;
            (
                ((turn * SECTORS as f64) as usize).min(SECTORS - 1),
                d.norm(),
            )
        })
        .collect();
    let mut reach = [0.0f64; SECTORS];
    for &(sector, r) in &polar {
        reach[sector] = reach[sector].max(r);
    }
    let mut shares: Vec<f64> = polar
        .iter()
        .zip(depths)
        .filter(|((sector, r), _)| HALFWAY.contains(&(r / reach[*sector].max(1e-300))))
        .map(|(_, &z)| (z - front) / (rim - front))
        .collect();
    if shares.is_empty() {
        return None;
    }
    shares.sort_by(f64::total_cmp);
    Some(shares[shares.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cap of a ball of radius `r` centred `d` from a camera at the origin looking along z:
    /// its visible points' images and depths, a fine grid over the image.
    fn ball_cap(r: f64, d: f64) -> (Vec<Vector2<f64>>, Vec<f64>) {
        let (mut image, mut depths) = (Vec::new(), Vec::new());
        let n = 120;
        for i in 0..=n {
            for j in 0..=n {
                let q = Vector2::new(i as f64 / n as f64 - 0.5, j as f64 / n as f64 - 0.5) * 0.5;
                // The ray (q, 1) meets the ball where |t (q, 1) - (0, 0, d)| = r, nearest t.
                let (a, b) = (q.norm_squared() + 1.0, d);
                let disc = b * b - a * (d * d - r * r);
                if disc >= 0.0 {
                    image.push(q);
                    depths.push((b - disc.sqrt()) / a);
                }
            }
        }
        (image, depths)
    }

    #[test]
    fn a_balls_centre_is_found_behind_its_silhouette_and_a_cones_is_not_moved() {
        let (r, d) = (0.1, 0.5);
        let (image, depths) = ball_cap(r, d);
        // The silhouette's circle lies r^2 / d in front of the centre, the surface r.
        let (rim, front) = (d - r * r / d, d - r);
        let found = depth_behind_rim(&image, &depths, &Vector2::zeros(), rim, front);
        assert!((found - d).abs() < 1e-12, "{found}");
        // A cone with its tip towards the camera: depth rising linearly to the outline.
        let outline = r / (d * d - r * r).sqrt();
        let cone: Vec<f64> = image
            .iter()
            .map(|q| front + (rim - front) * (q.norm() / outline).min(1.0))
            .collect();
        assert_eq!(
            depth_behind_rim(&image, &cone, &Vector2::zeros(), rim, front),
            rim
        );
    }
}
