//! Voxel downsampling: a large cloud's shape is read from a thinned copy (the network encodes a
//! few thousand points whatever the input holds), while every input point is still deformed.
//! A camera's view is thinned on a grid aligned with the camera, so that it stays a raster.

use std::collections::HashMap;

use nalgebra::Vector3;

use crate::linalg::tangents;

/// A camera-aligned cell's depth over its width (see `view_downsample`).
const DEPTH_CELLS: f64 = 8.0;

/// At most `max` of `points`: the one nearest each occupied cell's centroid, in input order, on
/// the finest cubic grid that leaves no more than `max` cells. All of them when they fit.
pub fn voxel_downsample(points: &[Vector3<f64>], max: usize) -> Vec<Vector3<f64>> {
    if points.len() <= max || points.is_empty() || max == 0 {
        return points.to_vec();
    }
    let (lo, hi) = points
        .iter()
        .fold((points[0], points[0]), |(lo, hi), p| (lo.inf(p), hi.sup(p)));
    let extent = hi - lo;
    // A surface of area A sampled at cell h leaves about A / h^2 cells: start from the box's
    // largest face, then widen the cells until the count fits.
    let mut sides = [
        extent.x * extent.y,
        extent.y * extent.z,
        extent.x * extent.z,
    ];
    sides.sort_by(f64::total_cmp);
    let cell = (sides[2].max(1e-12) / max as f64)
        .sqrt()
        .max(extent.max() * 1e-6);
    thinned_on_grid(points, points, &lo, cell, &Vector3::repeat(1.0), max)
}

/// At most `max` of `points`, seen from `viewpoint`: the one nearest each occupied cell's
/// centroid, in input order, on the finest grid of the camera's image plane and log depth that
/// leaves no more than `max` cells. Thinned on a grid aligned with the world's axes, a camera's
/// cloud is no longer a raster: a slanted surface keeps rows of points at one spacing and drops
/// others, and the completion, which reads the view ray by ray, finds holes and a short hidden
/// side. `bench views`' short capsule seen by a 640 x 480 camera completed to 0.48 to 0.79 of
/// its volume thinned that way, 0.73 to 1.14 thinned here, 0.82 to 1.12 whole (printed). A
/// camera sees one surface per ray, so the cells are `DEPTH_CELLS` times deeper than wide: a
/// slanted surface keeps one point per image cell (0.59 to 0.82 with cells as deep as wide),
/// and two surfaces far apart on one ray (two cameras' clouds) keep both. Every point must lie
/// in front of the viewpoint; otherwise the cloud is thinned as `voxel_downsample` does.
pub fn view_downsample(
    points: &[Vector3<f64>],
    viewpoint: &Vector3<f64>,
    max: usize,
) -> Vec<Vector3<f64>> {
    if points.len() <= max || max == 0 {
        return points.to_vec();
    }
    let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let Some(forward) = (centroid - viewpoint).try_normalize(1e-12) else {
        return voxel_downsample(points, max);
    };
    let [right, up] = tangents(&forward);
    let image: Vec<Vector3<f64>> = points
        .iter()
        .map(|p| {
            let d = p - viewpoint;
            let z = d.dot(&forward);
            Vector3::new(d.dot(&right) / z, d.dot(&up) / z, z.ln())
        })
        .collect();
    if image.iter().any(|q| !q.iter().all(|c| c.is_finite())) {
        return voxel_downsample(points, max);
    }
    let (lo, hi) = image
        .iter()
        .fold((image[0], image[0]), |(lo, hi), q| (lo.inf(q), hi.sup(q)));
    // One point per pixel of an image of `max` pixels, widened until the count fits.
    let cell = ((hi.x - lo.x) * (hi.y - lo.y) / max as f64)
        .sqrt()
        .max(1e-9);
    let shape = Vector3::new(1.0, 1.0, DEPTH_CELLS);
    thinned_on_grid(points, &image, &lo, cell, &shape, max)
}

/// At most `max` of `points`, one per occupied cell of a grid over their `coords` (from `lo`),
/// cells `cell` wide times `shape` per axis, starting at `cell` and widened until the count
/// fits; see `one_per_cell`.
fn thinned_on_grid(
    points: &[Vector3<f64>],
    coords: &[Vector3<f64>],
    lo: &Vector3<f64>,
    mut cell: f64,
    shape: &Vector3<f64>,
    max: usize,
) -> Vec<Vector3<f64>> {
    loop {
        let keys: Vec<[i64; 3]> = coords
            .iter()
            .map(|q| {
                let c = ((q - lo) / cell).component_div(shape);
                [c.x as i64, c.y as i64, c.z as i64]
            })
            .collect();
        let picked = one_per_cell(points, &keys);
        if picked.len() <= max {
            return picked.into_iter().map(|i| points[i]).collect();
        }
        cell *= 1.1 * (picked.len() as f64 / max as f64).sqrt().max(1.0);
    }
}

/// Indices of the points nearest their cell's centroid (`keys[i]` is point i's cell), one per
/// occupied cell, ascending.
fn one_per_cell(points: &[Vector3<f64>], keys: &[[i64; 3]]) -> Vec<usize> {
    let mut sums: HashMap<[i64; 3], (Vector3<f64>, usize)> = HashMap::new();
    for (p, k) in points.iter().zip(keys) {
        let entry = sums.entry(*k).or_insert((Vector3::zeros(), 0));
        entry.0 += p;
        entry.1 += 1;
    }
    let mut best: HashMap<[i64; 3], (f64, usize)> = HashMap::with_capacity(sums.len());
    for (i, (p, k)) in points.iter().zip(keys).enumerate() {
        let (sum, n) = sums[k];
        let d = (p - sum / n as f64).norm_squared();
        let slot = best.entry(*k).or_insert((f64::INFINITY, i));
        if d < slot.0 {
            *slot = (d, i);
        }
    }
    let mut picked: Vec<usize> = best.into_values().map(|(_, i)| i).collect();
    picked.sort_unstable();
    picked
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thins_to_the_cap_and_keeps_the_extent() {
        // A 300 x 300 grid on a 1 m square, 90,000 points.
        let points: Vec<Vector3<f64>> = (0..300 * 300)
            .map(|i| Vector3::new((i % 300) as f64 / 299.0, (i / 300) as f64 / 299.0, 0.0))
            .collect();
        let thin = voxel_downsample(&points, 5000);
        assert!(thin.len() <= 5000 && thin.len() > 2500, "{}", thin.len());
        let max_x = thin.iter().map(|p| p.x).fold(f64::MIN, f64::max);
        let min_y = thin.iter().map(|p| p.y).fold(f64::MAX, f64::min);
        assert!(
            max_x > 0.97 && min_y < 0.03,
            "the thinned copy spans the square"
        );
        assert_eq!(
            voxel_downsample(&points[..100], 5000).len(),
            100,
            "small clouds stay whole"
        );
    }

    /// A camera's raster of two surfaces on the same rays (a front plate 1 m away and a back
    /// plate 0.5 m behind it): thinned to the cap, every image cell keeps a point of each.
    #[test]
    fn a_view_thins_on_its_image_and_keeps_both_surfaces_of_a_ray() {
        let raster = |depth: f64| {
            (0..200 * 200).map(move |i| {
                let (u, v) = (
                    (i % 200) as f64 / 199.0 - 0.5,
                    (i / 200) as f64 / 199.0 - 0.5,
                );
                Vector3::new(u * 0.4 * depth, v * 0.4 * depth, depth)
            })
        };
        let points: Vec<Vector3<f64>> = raster(1.0).chain(raster(1.5)).collect();
        let thin = view_downsample(&points, &Vector3::zeros(), 20_000);
        assert!(
            thin.len() <= 20_000 && thin.len() > 15_000,
            "{}",
            thin.len()
        );
        let front = thin.iter().filter(|p| p.z < 1.25).count();
        assert!(
            (front as f64 / thin.len() as f64 - 0.5).abs() < 0.05,
            "{front} of {} in front",
            thin.len()
        );
    }
}
