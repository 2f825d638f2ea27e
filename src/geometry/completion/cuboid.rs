//! Where a box's centre lies. A convex object shows each face it turns to the camera whole, and
//! a box's face spans the box's whole extent along both of its edges: with two faces in view,
//! every extent of the box is seen, and the bounding box of the points in the box's own axes is
//! the box. The rim's centroid knows none of that: a box turned from the camera's axes was made
//! 0.66 to 1.59 of its volume (printed). With one face in view (seen square to it), its depth
//! is not seen and nothing is fitted.

use nalgebra::{Matrix3, Vector3};

use super::super::point_index::{neighbourhood_plane, PointIndex};
use super::super::voxel_downsample;
use super::quantile_span;

/// Normals are estimated at about this many of the points.
const SAMPLED: usize = 1500;
/// The points are thinned to at most this many (one per voxel) before their normals are
/// estimated, so that a neighbourhood spans about the same part of a face whatever the image
/// size: a camera's depth noise does not shrink with its pixels. With depth noise of 2 mm at
/// 1 m (a scratch run of `bench views`, printed), three of the bundled box's scans at 240 x 180
/// kept 143 to 252 flat normals of 1500 and were not fitted, the one from (1, 0.1, 0.2)
/// completed to 0.63 of its volume, the long box from there to 0.64; thinned to 2000 points,
/// 0.95 and 0.96 (to 3000, 0.94 and 0.98 in that run, but 0.63 again for the box with the noise
/// `bench views` draws). The clean scans' volumes moved by at most 0.016 (`bench views`).
const FIT_POINTS: usize = 2000;
/// Neighbours in a normal's plane fit.
const NEIGHBOURS: usize = 12;
/// A neighbourhood is flat (on a face, not across an edge) where its smallest spread, against
/// its middle one, is below this.
const FLAT: f64 = 0.01;
/// A normal supports a direction within this angle's cosine.
const ALIGNED: f64 = 0.99;
/// A face must hold this share of the flat normals (and `FACE_FROM` of them) to count as seen.
const FACE_SHARE: f64 = 0.02;
const FACE_FROM: usize = 20;
/// The three axes must hold this share of the flat normals: else the flat parts are no box's.
/// A block with rounded edges (`bench views`' golf club head seen from (-0.7, 1, 0.5) at 240 x
/// 180) kept 0.86 of them on its axes (printed), and at 0.9 it was completed round across its
/// long axis, 1.52 times its volume.
const EXPLAINED: f64 = 0.85;
/// This share of the points must lie within `tolerance` of the fitted box's surface.
const ON_FACES: f64 = 0.95;
/// The extents are read at this quantile of the points and its complement, so that a few
/// stray pixels do not move them.
const EXTENT_QUANTILE: f64 = 0.002;

/// The centre of the box whose faces `points` sample, where at least two faces are seen and
/// `ON_FACES` of the points lie within `tolerance` (m) of the box's surface; None for anything
/// else (a ball, an animal, a cylinder's side, a box seen square to one face).
pub(super) fn box_centre(points: &[Vector3<f64>], tolerance: f64) -> Option<Vector3<f64>> {
    let normals = flat_normals(&voxel_downsample(points, FIT_POINTS));
    let axes = box_axes(&normals)?;
    let (lo, hi) = extents(points, &axes);
    let centre = axes * ((lo + hi) / 2.0);
    let half = (hi - lo) / 2.0;
    let on_faces = points
        .iter()
        .filter(|p| {
            let local = axes.transpose() * (*p - centre);
            (0..3)
                .map(|a| (half[a] - local[a].abs()).abs())
                .fold(f64::INFINITY, f64::min)
                <= tolerance
        })
        .count();
    (on_faces as f64 >= ON_FACES * points.len() as f64).then_some(centre)
}

/// Unit normals (either sign) of the flat neighbourhoods of about `SAMPLED` of the points.
fn flat_normals(points: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let index = PointIndex::for_surface(points);
    let stride = (points.len() / SAMPLED).max(1);
    (0..points.len())
        .step_by(stride)
        .filter_map(|i| {
            let near = index.nearest(&points[i], NEIGHBOURS, None);
            let plane = neighbourhood_plane(points, &near)?;
            (plane.spread[0] < FLAT * plane.spread[1]).then_some(plane.normal)
        })
        .collect()
}

/// The box's axes (the columns of a rotation) from its faces' normals: the direction most
/// normals share, then the one most share across it; None unless two faces are seen and the
/// three axes hold `EXPLAINED` of the normals.
fn box_axes(normals: &[Vector3<f64>]) -> Option<Matrix3<f64>> {
    let needed = FACE_FROM.max((FACE_SHARE * normals.len() as f64).ceil() as usize);
    let first = refined(normals, &dominant(normals, |_| true)?)?;
    let across = |n: &Vector3<f64>| n.dot(&first).abs() < (1.0 - ALIGNED * ALIGNED).sqrt();
    let second = dominant(normals, across)?;
    let second = (second - first * second.dot(&first)).try_normalize(1e-9)?;
    let second = refined(normals, &second)?;
    let second = (second - first * second.dot(&first)).try_normalize(1e-9)?;
    let third = first.cross(&second);
    let support = |a: &Vector3<f64>| normals.iter().filter(|n| n.dot(a).abs() >= ALIGNED).count();
    let explained = support(&first) + support(&second) + support(&third);
    let seen = support(&first) >= needed && support(&second) >= needed;
    (seen && explained as f64 >= EXPLAINED * normals.len() as f64)
        .then(|| Matrix3::from_columns(&[first, second, third]))
}

/// The normal (among those `eligible`) that the most normals lie within `ALIGNED` of.
fn dominant(
    normals: &[Vector3<f64>],
    eligible: impl Fn(&Vector3<f64>) -> bool,
) -> Option<Vector3<f64>> {
    let candidates: Vec<&Vector3<f64>> = normals.iter().filter(|n| eligible(n)).collect();
    let stride = (candidates.len() / 200).max(1);
    candidates
        .iter()
        .step_by(stride)
        .map(|c| {
            let support = normals.iter().filter(|n| n.dot(c).abs() >= ALIGNED).count();
            (support, **c)
        })
        .max_by_key(|&(support, _)| support)
        .map(|(_, c)| c)
}

/// The mean direction of the normals within `ALIGNED` of `guess` (the principal axis of their
/// scatter, which takes either sign alike).
fn refined(normals: &[Vector3<f64>], guess: &Vector3<f64>) -> Option<Vector3<f64>> {
    let scatter = normals
        .iter()
        .filter(|n| n.dot(guess).abs() >= ALIGNED)
        .map(|n| n * n.transpose())
        .sum::<Matrix3<f64>>();
    let eigen = scatter.symmetric_eigen();
    let axis = eigen
        .eigenvectors
        .column(eigen.eigenvalues.imax())
        .into_owned();
    axis.try_normalize(1e-12)
}

/// The points' extents along each of `axes` (low and high), at `EXTENT_QUANTILE`.
fn extents(points: &[Vector3<f64>], axes: &Matrix3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let mut lo = Vector3::zeros();
    let mut hi = Vector3::zeros();
    for a in 0..3 {
        let along = points.iter().map(|p| p.dot(&axes.column(a)));
        (lo[a], hi[a]) = quantile_span(along, EXTENT_QUANTILE);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// Points on the faces of a turned box that face `towards` (a grid on each).
    fn seen_faces(
        half: Vector3<f64>,
        turn: &Rotation3<f64>,
        towards: Vector3<f64>,
    ) -> Vec<Vector3<f64>> {
        let centre = Vector3::new(0.3, -0.2, 1.1);
        let mut points = Vec::new();
        for a in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut normal = Vector3::zeros();
                normal[a] = sign;
                if (turn * normal).dot(&towards) <= 0.0 {
                    continue;
                }
                let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                for i in 0..=40 {
                    for j in 0..=40 {
                        let mut local = normal.component_mul(&half);
                        local[b] = half[b] * (i as f64 / 20.0 - 1.0);
                        local[c] = half[c] * (j as f64 / 20.0 - 1.0);
                        points.push(centre + turn * local);
                    }
                }
            }
        }
        points
    }

    #[test]
    fn a_box_seen_from_two_or_three_sides_gives_its_centre() {
        let turn = Rotation3::from_euler_angles(0.4, -0.3, 0.7);
        let half = Vector3::new(0.12, 0.08, 0.05);
        for towards in [Vector3::new(1.0, 0.6, 0.8), Vector3::new(-0.7, 1.0, 0.1)] {
            let points = seen_faces(half, &turn, towards);
            let centre = box_centre(&points, 0.003).expect("a box");
            let truth = Vector3::new(0.3, -0.2, 1.1);
            assert!((centre - truth).norm() < 1e-3, "{centre} against {truth}");
        }
    }

    #[test]
    fn one_face_a_ball_and_a_cylinder_are_no_box() {
        let turn = Rotation3::identity();
        let half = Vector3::new(0.12, 0.08, 0.05);
        let one_face = seen_faces(half, &turn, Vector3::x());
        assert!(box_centre(&one_face, 0.003).is_none());
        let cap: Vec<Vector3<f64>> = (0..2000)
            .map(|k| {
                let (u, v) = ((k % 50) as f64 / 50.0, (k / 50) as f64 / 40.0);
                let (polar, around) = (u * 1.4, v * std::f64::consts::TAU);
                Vector3::new(
                    polar.sin() * around.cos(),
                    polar.sin() * around.sin(),
                    polar.cos(),
                ) * 0.1
            })
            .collect();
        assert!(box_centre(&cap, 0.003).is_none());
        // A cylinder's side and one cap: one flat face, the rest curved.
        let mut cylinder: Vec<Vector3<f64>> = (0..2000)
            .map(|k| {
                let (t, z) = ((k % 50) as f64 / 50.0 * 3.0, (k / 50) as f64 / 40.0 * 0.2);
                Vector3::new(0.05 * t.cos(), 0.05 * t.sin(), z)
            })
            .collect();
        cylinder.extend((0..900).map(|k| {
            let (x, y) = (
                (k % 30) as f64 / 30.0 * 0.07 - 0.035,
                (k / 30) as f64 / 30.0 * 0.07 - 0.035,
            );
            Vector3::new(x, y, 0.2)
        }));
        assert!(box_centre(&cylinder, 0.003).is_none());
    }
}
