//! A round long object's axis, found from the surface seen across its middle: a circle fitted
//! to those points seen along the axis. Every point of a round object's visible half lies on
//! that circle, wherever the object is tilted, so its centre holds the information of every
//! point; the outline's width holds that of its two outermost pixels only, and over the sine of
//! the tilt (how deep the axis lies behind the ridge) their pitch's shortfall is magnified.
//! A section that is no circle (a turned ellipsoid's) is fitted with an ellipse instead, whose
//! centre lies midway between where it turns away from the camera on either side.

use nalgebra::{Matrix3, Vector2, Vector3};

use super::quadric::{Quadric, ACROSS_BOUNDS, DEPTH_BOUNDS};

use crate::linalg::tangents;

/// Fewer points than this do not fit a circle to trust.
const FITTED_FROM: usize = 12;
/// The fitted circle's radius, against half the outline's width across the axis, must lie
/// within these bounds: a section that is no circle (a ring, a flattened body) fits one far off.
/// A circle fits half an ellipse with little misfit (within 0.018 of its radius for ratios of
/// its axes from 0.3 to 0.9, 20 points), but not with the radius its outline shows: 1.22 and
/// 2.03 times its half-width for one 0.6 as broad as it is long, seen across either axis.
const RADIUS_BOUNDS: (f64, f64) = (0.85, 1.2);
/// The points must lie this close to the fitted circle (root mean square, against its radius)
/// for the section to be taken as round. `bench views`' rods and capsules fitted within 0.005
/// to 0.015 of their radius, its turned ellipsoid 0.029 to 0.043, a creature and a torus taken
/// as long 0.053 and 0.45 (printed).
const ROUNDNESS: f64 = 0.02;

/// The axis of the round object whose surface `points` sample, given its unit direction `axis`:
/// the centre of the circle fitted to them seen along it (see `fit_circle`), as the axis's
/// point in the plane through `near` across the axis. None with fewer than `FITTED_FROM`
/// points, a degenerate fit, a radius out of `RADIUS_BOUNDS` of `half_width` (half the
/// outline's width across the axis), or points off the circle by more than `ROUNDNESS`.
pub(super) fn round_axis(
    points: &[Vector3<f64>],
    axis: &Vector3<f64>,
    near: &Vector3<f64>,
    half_width: f64,
) -> Option<Vector3<f64>> {
    if points.len() < FITTED_FROM {
        return None;
    }
    let [first, second] = tangents(axis);
    let flat: Vec<Vector2<f64>> = points
        .iter()
        .map(|p| Vector2::new((p - near).dot(&first), (p - near).dot(&second)))
        .collect();
    let (middle, radius, misfit) = fit_circle(&flat)?;
    let (low, high) = RADIUS_BOUNDS;
    let plausible = radius >= low * half_width && radius <= high * half_width;
    (plausible && misfit <= ROUNDNESS * radius).then(|| near + first * middle.x + second * middle.y)
}

/// The axis of the long object whose surface across its middle `points` sample, where that
/// section is an ellipse rather than a circle (a turned ellipsoid's, a flattened bottle's): the
/// centre of the ellipse fitted to them seen along `axis` (see `Quadric::fit`), as the axis's
/// point in the plane through `near` across the axis. `forward` is the view's direction. A
/// centrally symmetric section's centre lies midway between the two points where it turns away
/// from the camera, which the last pixels before the outline miss; the ellipse through the
/// whole visible half finds them. None with fewer than `FITTED_FROM` points, a fit that is no
/// ellipse, an extent across the view out of `ACROSS_BOUNDS` of `half_width`, a depth out of
/// `DEPTH_BOUNDS` of it, or points off the ellipse by more than `ROUNDNESS` of its smaller
/// semi-axis.
pub(super) fn elliptic_axis(
    points: &[Vector3<f64>],
    axis: &Vector3<f64>,
    near: &Vector3<f64>,
    half_width: f64,
    forward: &Vector3<f64>,
) -> Option<Vector3<f64>> {
    if points.len() < FITTED_FROM {
        return None;
    }
    // The section's own axes: along the view (in the plane across the object's axis) and across.
    let deep = (forward - axis * forward.dot(axis)).try_normalize(1e-9)?;
    let across = axis.cross(&deep);
    let flat: Vec<Vector2<f64>> = points
        .iter()
        .map(|p| Vector2::new((p - near).dot(&across), (p - near).dot(&deep)))
        .collect();
    let ellipse = Quadric::fit(&flat)?;
    let wide = ellipse.half_extent(&Vector2::x()) / half_width;
    let deep_extent = ellipse.half_extent(&Vector2::y()) / half_width;
    let plausible = ACROSS_BOUNDS.contains(&wide) && DEPTH_BOUNDS.contains(&deep_extent);
    (plausible && ellipse.misfit <= ROUNDNESS * ellipse.minor())
        .then(|| near + across * ellipse.centre.x + deep * ellipse.centre.y)
}

/// The circle (centre, radius) that best fits `points` in the algebraic sense (Kasa's fit: the
/// least squares of x^2 + y^2 + D x + E y + F over the points), which is exact for points on a
/// circle and needs no starting guess, and the points' root-mean-square distance from it; None
/// where the points lie on a line.
fn fit_circle(points: &[Vector2<f64>]) -> Option<(Vector2<f64>, f64, f64)> {
    // About their mean, so that the sums do not lose the circle's digits to its offset.
    let mean = points.iter().sum::<Vector2<f64>>() / points.len() as f64;
    let mut normal = Matrix3::zeros();
    let mut right = Vector3::zeros();
    for p in points {
        let q = p - mean;
        let row = Vector3::new(q.x, q.y, 1.0);
        normal += row * row.transpose();
        right -= row * q.norm_squared();
    }
    let [d, e, f] = normal.cholesky()?.solve(&right).into();
    let centre = Vector2::new(-d / 2.0, -e / 2.0);
    let squared = centre.norm_squared() - f;
    if !(squared > 0.0 && squared.is_finite()) {
        return None;
    }
    let radius = squared.sqrt();
    let misfit = points
        .iter()
        .map(|p| ((p - mean - centre).norm() - radius).powi(2))
        .sum::<f64>()
        / points.len() as f64;
    Some((mean + centre, radius, misfit.sqrt()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on half a circle around an axis tilted from every coordinate axis, spread along
    /// it: the fit finds the axis's point in the plane through the guess.
    #[test]
    fn a_half_cylinder_fits_its_axis() {
        let axis = Vector3::new(1.0, 0.6, 0.8).normalize();
        let first = axis.cross(&Vector3::z()).normalize();
        let second = axis.cross(&first);
        let on_axis = Vector3::new(0.3, -0.2, 1.1);
        let points: Vec<Vector3<f64>> = (0..40)
            .map(|k| {
                let angle = std::f64::consts::PI * k as f64 / 39.0;
                let along = 0.02 * ((k * 7) % 11) as f64 - 0.1;
                on_axis + axis * along + (first * angle.cos() + second * angle.sin()) * 0.05
            })
            .collect();
        let near = on_axis + axis * 0.3 + first * 0.01;
        let centre = round_axis(&points, &axis, &near, 0.05).expect("fits");
        let expected = on_axis + axis * 0.3;
        assert!((centre - expected).norm() < 1e-9, "{centre}");
    }

    /// Points on a quarter of a circle off the origin give back its centre and radius, with no
    /// misfit; half an ellipse fits a circle closely, but a larger one.
    #[test]
    fn an_arc_gives_its_circle() {
        let arc = |rx: f64, ry: f64| -> Vec<Vector2<f64>> {
            (0..30)
                .map(|k| {
                    let a = std::f64::consts::FRAC_PI_2 * k as f64 / 29.0;
                    Vector2::new(2.0 + rx * a.cos(), -1.0 + ry * a.sin())
                })
                .collect()
        };
        let (centre, radius, misfit) = fit_circle(&arc(0.3, 0.3)).expect("fits");
        assert!((centre - Vector2::new(2.0, -1.0)).norm() < 1e-9, "{centre}");
        assert!((radius - 0.3).abs() < 1e-9, "{radius}");
        assert!(misfit < 1e-9, "{misfit}");
        // Half an ellipse 0.6 as broad as it is long fits a circle 1.22 times its half-length.
        let half: Vec<Vector2<f64>> = (0..20)
            .map(|k| {
                let a = std::f64::consts::PI * k as f64 / 20.0;
                Vector2::new(0.05 * a.cos(), 0.03 * a.sin())
            })
            .collect();
        let (_, radius, misfit) = fit_circle(&half).expect("fits");
        assert!((radius / 0.05 - 1.22).abs() < 0.01, "{radius}");
        assert!(misfit < ROUNDNESS * radius, "{misfit} against {radius}");
    }

    /// Points on half of a turned ellipse (axes 0.09 and 0.05, turned 0.6 rad from the view),
    /// their section seen along an axis tilted from every coordinate axis: the fit finds the
    /// object's axis, which the circle fit refuses.
    #[test]
    fn a_half_elliptic_section_fits_its_axis() {
        let axis = Vector3::new(1.0, 0.6, 0.8).normalize();
        let forward = Vector3::new(0.2, -1.0, 0.1).normalize();
        let deep = (forward - axis * forward.dot(&axis)).normalize();
        let across = axis.cross(&deep);
        let on_axis = Vector3::new(0.3, -0.2, 1.1);
        let (a, b, turn) = (0.09_f64, 0.05_f64, 0.6_f64);
        let (u, v) = (
            across * turn.cos() + deep * turn.sin(),
            deep * turn.cos() - across * turn.sin(),
        );
        // The visible half: where the outward normal faces the camera (against `forward`).
        let points: Vec<Vector3<f64>> = (0..400)
            .filter_map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 400.0;
                let normal = u * (t.cos() / a) + v * (t.sin() / b);
                let along = 0.02 * ((k * 7) % 11) as f64 - 0.1;
                (normal.dot(&forward) < 0.0)
                    .then(|| on_axis + axis * along + u * (a * t.cos()) + v * (b * t.sin()))
            })
            .collect();
        let half_width = {
            let spread: Vec<f64> = points.iter().map(|p| (p - on_axis).dot(&across)).collect();
            (spread.iter().cloned().fold(f64::MIN, f64::max)
                - spread.iter().cloned().fold(f64::MAX, f64::min))
                / 2.0
        };
        let near = on_axis + axis * 0.3 + across * 0.01 - deep * 0.02;
        assert!(round_axis(&points, &axis, &near, half_width).is_none());
        let centre = elliptic_axis(&points, &axis, &near, half_width, &forward).expect("fits");
        let expected = on_axis + axis * 0.3;
        assert!(
            (centre - expected).norm() < 1e-9,
            "{centre} against {expected}"
        );
    }

    /// In the section's own axes (across = x, deep = y): a half ellipse 4 times as deep as wide
    /// is refused, and so is one whose width is not the outline's, or too few points.
    #[test]
    fn implausible_elliptic_sections_are_refused() {
        let arc = |rx: f64, ry: f64| -> Vec<Vector3<f64>> {
            (0..40)
                .map(|k| {
                    let t = std::f64::consts::PI * (1.0 + k as f64 / 39.0);
                    Vector3::new(-rx * t.cos(), ry * t.sin(), 0.0)
                })
                .collect()
        };
        let (axis, forward, near) = (Vector3::z(), Vector3::y(), Vector3::zeros());
        let deep = arc(0.02, 0.08);
        assert!(elliptic_axis(&deep, &axis, &near, 0.02, &forward).is_none());
        let fair = arc(0.05, 0.08);
        assert!(elliptic_axis(&fair, &axis, &near, 0.05, &forward).is_some());
        assert!(elliptic_axis(&fair, &axis, &near, 0.08, &forward).is_none());
        assert!(elliptic_axis(&fair[..FITTED_FROM - 1], &axis, &near, 0.05, &forward).is_none());
    }

    /// Too few points, points on a line, a radius far from the outline's (half an ellipse seen
    /// across either axis among them) are refused.
    #[test]
    fn degenerate_or_implausible_sections_are_refused() {
        let axis = Vector3::z();
        let near = Vector3::zeros();
        let half = |n: usize, rx: f64, ry: f64| -> Vec<Vector3<f64>> {
            (0..n)
                .map(|k| {
                    let a = std::f64::consts::PI * k as f64 / n as f64;
                    Vector3::new(rx * a.cos(), ry * a.sin(), 0.0)
                })
                .collect()
        };
        assert!(round_axis(&half(FITTED_FROM - 1, 0.05, 0.05), &axis, &near, 0.05).is_none());
        let line: Vec<_> = (0..20).map(|k| Vector3::new(k as f64, 0.0, 0.0)).collect();
        assert!(round_axis(&line, &axis, &near, 0.05).is_none());
        assert!(round_axis(&half(20, 0.05, 0.05), &axis, &near, 0.1).is_none());
        assert!(round_axis(&half(20, 0.05, 0.03), &axis, &near, 0.05).is_none());
        assert!(round_axis(&half(20, 0.05, 0.03), &axis, &near, 0.03).is_none());
        assert!(round_axis(&half(20, 0.05, 0.05), &axis, &near, 0.05).is_some());
    }
}
