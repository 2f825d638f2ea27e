//! The cubature split into regions that turn as one, by k-means over the points' rest
//! positions. Each region's rotation and its share of the elastic Hessian let the quasi-Newton
//! solver's held matrix follow a body that bends (a swinging rod, a poked arm) by turning the
//! shares, a few small products, instead of assembling the Hessian again.

use nalgebra::{DMatrix, Matrix3, Vector3};

use super::assembly::HessianAssembly;
use super::material::{polar_rotation, Matrix9};

/// Most regions a body is split into.
const MAX_REGIONS: usize = 16;
/// Fewest cubature points a region holds on average: fewer would make regions cost more to
/// turn than they describe.
const POINTS_PER_REGION: usize = 32;
/// Lloyd iterations of the k-means.
const LLOYD_ITERATIONS: usize = 8;

/// One region: its points' G, gathered, and their mean.
struct Region {
    /// The region's share of the assembly.
    assembly: HessianAssembly,
    /// Volume-weighted mean G of its points (4K x 3): its mean F is I + Z times this.
    mean_gradient: DMatrix<f64>,
    /// Its points, indices into the cubature.
    points: Vec<usize>,
}

/// The cubature's regions.
pub(crate) struct Regions {
    regions: Vec<Region>,
}

impl Regions {
    /// Splits the points of `assembly` (at rest positions `points`) into up to
    /// `MAX_REGIONS` regions of at least `POINTS_PER_REGION` points on average.
    pub(crate) fn new(assembly: &HessianAssembly, points: &[Vector3<f64>]) -> Self {
        let count = (points.len() / POINTS_PER_REGION).clamp(1, MAX_REGIONS);
        let regions = k_means(points, count)
            .into_iter()
            .map(|members| {
                let part = assembly.subset(&members);
                Region {
                    mean_gradient: part.mean_gradient(),
                    assembly: part,
                    points: members,
                }
            })
            .collect();
        Self { regions }
    }

    /// Each region's rotation at `z`: that of the polar decomposition of its mean F (the
    /// identity where the SVD fails).
    pub(crate) fn rotations(&self, z: &DMatrix<f64>) -> Vec<Matrix3<f64>> {
        self.regions
            .iter()
            .map(|r| {
                let f = Matrix3::identity() + z * &r.mean_gradient;
                polar_rotation(&f).unwrap_or_else(Matrix3::identity)
            })
            .collect()
    }

    /// Each region's share of the elastic Hessian for dP/dF `hessians` at every point, with
    /// the digits a preconditioner needs (see `HessianAssembly::preconditioning_parts`).
    pub(crate) fn hessians(&self, hessians: &[Matrix9]) -> Vec<DMatrix<f64>> {
        let parts: Vec<_> = self
            .regions
            .iter()
            .map(|r| (&r.assembly, r.points.iter().map(|&p| hessians[p]).collect()))
            .collect();
        HessianAssembly::preconditioning_parts(&parts)
    }
}

/// `count` clusters of `points` (none empty), by Lloyd's k-means from centres spread by
/// farthest-point sampling: deterministic, so a body's regions do not change between runs.
fn k_means(points: &[Vector3<f64>], count: usize) -> Vec<Vec<usize>> {
    let mut centres = spread_centres(points, count);
    let mut members = Vec::new();
    for _ in 0..LLOYD_ITERATIONS {
        members = vec![Vec::new(); centres.len()];
        for (p, x) in points.iter().enumerate() {
            members[nearest(&centres, x)].push(p);
        }
        members.retain(|m| !m.is_empty());
        centres = members
            .iter()
            .map(|m| m.iter().map(|&p| points[p]).sum::<Vector3<f64>>() / m.len() as f64)
            .collect();
    }
    members
}

/// `count` of `points`, each the farthest from those taken before, the first the farthest
/// from their centroid.
fn spread_centres(points: &[Vector3<f64>], count: usize) -> Vec<Vector3<f64>> {
    if points.is_empty() {
        return Vec::new();
    }
    let centroid = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let farthest = |distance: &[f64]| {
        (0..distance.len())
            .max_by(|&a, &b| distance[a].total_cmp(&distance[b]))
            .expect("points")
    };
    let from_centroid: Vec<f64> = points.iter().map(|x| (x - centroid).norm()).collect();
    let first = points[farthest(&from_centroid)];
    let mut distance: Vec<f64> = points.iter().map(|x| (x - first).norm()).collect();
    let mut centres = vec![first];
    while centres.len() < count.min(points.len()) {
        let next = points[farthest(&distance)];
        centres.push(next);
        for (d, x) in distance.iter_mut().zip(points) {
            *d = d.min((x - next).norm());
        }
    }
    centres
}

fn nearest(centres: &[Vector3<f64>], x: &Vector3<f64>) -> usize {
    let distance = |c: usize| (centres[c] - x).norm_squared();
    (0..centres.len())
        .min_by(|&a, &b| distance(a).total_cmp(&distance(b)))
        .expect("centres")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rod of points along x: its regions cover every point once, are deterministic, and lie
    /// along the rod, each a run of neighbours.
    #[test]
    fn regions_split_a_rod_into_runs_of_neighbours() {
        let points: Vec<Vector3<f64>> = (0..512)
            .map(|i| {
                Vector3::new(
                    i as f64 * 0.01,
                    (i % 4) as f64 * 0.001,
                    (i % 3) as f64 * 0.001,
                )
            })
            .collect();
        let regions = k_means(&points, 16);
        assert_eq!(regions, k_means(&points, 16), "deterministic");
        assert_eq!(regions.len(), 16);
        let mut seen: Vec<usize> = regions.iter().flatten().copied().collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..512).collect::<Vec<_>>(), "every point once");
        for region in &regions {
            let (lo, hi) = (region.iter().min().unwrap(), region.iter().max().unwrap());
            assert_eq!(hi - lo + 1, region.len(), "a run of neighbours: {region:?}");
        }
    }
}
