//! Voxel downsampling: a large cloud's shape is read from a thinned copy (the network encodes a
//! few thousand points whatever the input holds), while every input point is still deformed.

use std::collections::HashMap;

use nalgebra::Vector3;

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
    let mut cell = (sides[2].max(1e-12) / max as f64)
        .sqrt()
        .max(extent.max() * 1e-6);
    loop {
        let picked = one_per_cell(points, &lo, cell);
        if picked.len() <= max {
            return picked.into_iter().map(|i| points[i]).collect();
        }
        cell *= 1.1 * (picked.len() as f64 / max as f64).sqrt().max(1.0);
    }
}

/// Indices of the points nearest their cell's centroid, one per occupied cell, ascending.
fn one_per_cell(points: &[Vector3<f64>], lo: &Vector3<f64>, cell: f64) -> Vec<usize> {
    let key = |p: &Vector3<f64>| {
        let q = (p - lo) / cell;
        [q.x as i64, q.y as i64, q.z as i64]
    };
    let mut sums: HashMap<[i64; 3], (Vector3<f64>, usize)> = HashMap::new();
    for p in points {
        let entry = sums.entry(key(p)).or_insert((Vector3::zeros(), 0));
        entry.0 += p;
        entry.1 += 1;
    }
    let mut best: HashMap<[i64; 3], (f64, usize)> = HashMap::with_capacity(sums.len());
    for (i, p) in points.iter().enumerate() {
        let k = key(p);
        let (sum, n) = sums[&k];
        let d = (p - sum / n as f64).norm_squared();
        let slot = best.entry(k).or_insert((f64::INFINITY, i));
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
}
