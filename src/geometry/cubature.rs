//! Cubature: points inside the solid with volumes that add up to the object's volume.

use nalgebra::{DMatrix, DVector, SVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::voxel::VoxelGrid;

/// Points inside a solid, each with the volume it stands for: integrals over the solid
/// become weighted sums over the points.
#[derive(Clone, Debug, Default)]
pub struct Cubature {
    /// The points, in the frame of the grid they were drawn from.
    pub points: Vec<Vector3<f64>>,
    /// The volume of each point, in that frame's units cubed.
    pub volumes: Vec<f64>,
}

impl Cubature {
    /// The number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }
    /// Whether there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
    /// The sum of the volumes.
    pub fn total_volume(&self) -> f64 {
        self.volumes.iter().sum()
    }

    /// `target` points (or every sub-cell, if fewer), stratified along a space-filling curve:
    /// every solid cell of `grid` is split into 2 x 2 x 2 sub-cells, the sub-cells are sorted in
    /// Morton (Z) order, the order is cut into `target` runs of equal length, and each run gives
    /// one of its sub-cell centers, drawn at random (seeded), weighted by the run's volume. The
    /// weights are reweighted to the solid's exact centroid and second moments
    /// (`match_moments`), then scaled to add up to `total_volume` (the exact volume of a closed mesh,
    /// or the grid's own estimate).
    ///
    /// A random member rather than the run's centroid: on a thin part, centroids of runs
    /// spanning its thickness all lie on the mid-surface, where bending causes no strain, and the
    /// subspace would bend for free.
    pub fn stratified(grid: &VoxelGrid, target: usize, total_volume: f64) -> Cubature {
        let (centers, weights, cell) = sub_cells(grid, target);
        let (chosen, mut volumes) = stratified_subset(&centers, &weights, cell, target);
        let points: Vec<_> = chosen.iter().map(|&i| centers[i]).collect();
        match_moments(&points, &mut volumes, &centers, &weights);
        let sum: f64 = volumes.iter().sum();
        if sum > 0.0 {
            volumes.iter_mut().for_each(|v| *v *= total_volume / sum);
        }
        Cubature { points, volumes }
    }

    /// One point of every run of `stride` consecutive points (the middle one), standing for the
    /// run: its volume is the run's, reweighted to the whole set's volume, centroid and second
    /// moments. Stratified points run along a space-filling curve, so a run is a compact region.
    /// Returns the indices kept and the coarser set.
    pub fn coarsened(&self, stride: usize) -> (Vec<usize>, Cubature) {
        let stride = stride.max(1);
        let runs: Vec<_> = (0..self.len()).step_by(stride).collect();
        let kept: Vec<usize> = runs
            .iter()
            .map(|&start| (start + stride / 2).min(self.len() - 1))
            .collect();
        let mut volumes: Vec<f64> = runs
            .iter()
            .map(|&start| {
                self.volumes[start..(start + stride).min(self.len())]
                    .iter()
                    .sum()
            })
            .collect();
        let points: Vec<_> = kept.iter().map(|&i| self.points[i]).collect();
        match_moments(&points, &mut volumes, &self.points, &self.volumes);
        (kept, Cubature { points, volumes })
    }

    /// The points of [`Cubature::stratified`] alone, for callers that need no volumes (the
    /// network's reference points): matching the moments of 4096 points costs milliseconds.
    pub fn stratified_points(grid: &VoxelGrid, target: usize) -> Vec<Vector3<f64>> {
        let (centers, weights, cell) = sub_cells(grid, target);
        let (chosen, _) = stratified_subset(&centers, &weights, cell, target);
        chosen.iter().map(|&i| centers[i]).collect()
    }
}

/// The candidates for `target` cubature points: the centres of the solid cells, or of their
/// 2 x 2 x 2 sub-cells on small grids, with their volumes and the cell size they are on.
fn sub_cells(grid: &VoxelGrid, target: usize) -> (Vec<Vector3<f64>>, Vec<f64>, f64) {
    let half = grid.cell / 2.0;
    let solid: Vec<usize> = (0..grid.len()).filter(|&i| grid.solid[i]).collect();
    // Eight sub-cells per voxel make small grids fine enough to choose from; on large grids
    // the voxels alone are plenty, and sorting 8x as many candidates only costs time.
    let (centers, cell) = if solid.len() >= 16 * target {
        let centers: Vec<_> = solid
            .iter()
            .map(|&i| grid.cell_center(grid.coords(i)))
            .collect();
        (centers, grid.cell)
    } else {
        let mut centers = Vec::with_capacity(8 * solid.len());
        for &index in &solid {
            let corner = grid.cell_corner(grid.coords(index));
            for s in 0..8 {
                let offset = Vector3::new((s & 1) as f64, ((s >> 1) & 1) as f64, (s >> 2) as f64);
                centers.push(corner + (offset + Vector3::repeat(0.5)) * half);
            }
        }
        (centers, half)
    };
    let weights = vec![cell.powi(3); centers.len()];
    (centers, weights, cell)
}

/// Monomials up to degree two of a point, centred at `c` and scaled by `s`: 1, x, y, z, then
/// the six products. Their weighted sums are the volume, centroid and inertia of a point set.
fn monomials(p: &Vector3<f64>, c: &Vector3<f64>, s: f64) -> SVector<f64, 10> {
    let q = (p - c) / s;
    SVector::from([
        1.0,
        q.x,
        q.y,
        q.z,
        q.x * q.x,
        q.x * q.y,
        q.x * q.z,
        q.y * q.y,
        q.y * q.z,
        q.z * q.z,
    ])
}

/// Reweights a subset's `volumes` so that its volume, centroid and second moments equal those
/// of all `candidates` (with their `weights`), by the least change in relative entropy.
/// A random member per run puts a few dozen points' centroid millimetres off the solid's: a
/// ball then has its centre of mass off its centre and rolls away from rest, and a body's
/// inertia is off by as much. Falls back to the volume and centroid alone, or to no change,
/// when matching more would change a volume more than five-fold.
fn match_moments(
    points: &[Vector3<f64>],
    volumes: &mut [f64],
    candidates: &[Vector3<f64>],
    weights: &[f64],
) {
    let total: f64 = weights.iter().sum();
    if points.len() < 10 || total <= 0.0 {
        return;
    }
    let centre = candidates
        .iter()
        .zip(weights)
        .map(|(p, w)| p * *w)
        .sum::<Vector3<f64>>()
        / total;
    let scale = candidates
        .iter()
        .map(|p| (p - centre).amax())
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let target: SVector<f64, 10> = candidates
        .iter()
        .zip(weights)
        .map(|(p, w)| monomials(p, &centre, scale) * *w)
        .sum();
    let rows: Vec<SVector<f64, 10>> = points
        .iter()
        .map(|p| monomials(p, &centre, scale))
        .collect();
    for moments in [10, 4] {
        if let Some(corrected) = corrected_volumes(&rows, volumes, &target, moments) {
            volumes.copy_from_slice(&corrected);
            return;
        }
    }
}

/// v_i exp(m_i . lambda) with lambda such that the first `moments` moments reach `target`
/// (the reweighting closest to `volumes` in relative entropy, always positive), found by
/// Newton's method on its convex dual; None when it does not converge or a volume would
/// change by more than a factor of five.
fn corrected_volumes(
    rows: &[SVector<f64, 10>],
    volumes: &[f64],
    target: &SVector<f64, 10>,
    moments: usize,
) -> Option<Vec<f64>> {
    let target = target.rows(0, moments).into_owned();
    let weighted = |lambda: &DVector<f64>| -> Vec<f64> {
        rows.iter()
            .zip(volumes)
            .map(|(m, v)| v * m.rows(0, moments).dot(lambda).min(50.0).exp())
            .collect()
    };
    let dual = |w: &[f64], lambda: &DVector<f64>| w.iter().sum::<f64>() - lambda.dot(&target);
    let mut lambda = DVector::zeros(moments);
    let mut w = weighted(&lambda);
    for _ in 0..50 {
        let mut gradient = -target.clone();
        let mut hessian = DMatrix::zeros(moments, moments);
        for (m, wi) in rows.iter().zip(&w) {
            let m = m.rows(0, moments);
            gradient += m * *wi;
            hessian += m * m.transpose() * *wi;
        }
        if gradient.norm() <= 1e-13 * target[0] {
            let ratios_ok = w
                .iter()
                .zip(volumes)
                .all(|(c, v)| *c >= 0.2 * v && *c <= 5.0 * v);
            return ratios_ok.then_some(w);
        }
        let step = hessian.cholesky()?.solve(&gradient);
        let mut t = 1.0;
        let before = dual(&w, &lambda);
        loop {
            let trial = &lambda - &step * t;
            let trial_w = weighted(&trial);
            if dual(&trial_w, &trial) <= before || t < 1e-6 {
                (lambda, w) = (trial, trial_w);
                break;
            }
            t *= 0.5;
        }
    }
    None
}

/// `count` of `points` (all of them, if fewer), spread evenly: the points are sorted in Morton
/// (Z) order of their positions quantized to `cell`, the order is cut into `count` runs of
/// equal length, and each run gives one member drawn at random (seeded) that carries the
/// run's summed weight. Returns the chosen indices and their weights.
pub fn stratified_subset(
    points: &[Vector3<f64>],
    weights: &[f64],
    cell: f64,
    count: usize,
) -> (Vec<usize>, Vec<f64>) {
    let Some(lo) = points.iter().copied().reduce(|a, b| a.inf(&b)) else {
        return (Vec::new(), Vec::new());
    };
    let mut order: Vec<(u64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            (
                morton(((p - lo) / cell).map(|x| x.max(0.0) as usize).into()),
                i,
            )
        })
        .collect();
    radix_sort(&mut order);
    let runs = count.clamp(1, points.len());
    let mut rng = ChaCha8Rng::seed_from_u64(points.len() as u64);
    (0..runs)
        .map(|r| {
            let run = &order[r * points.len() / runs..(r + 1) * points.len() / runs];
            let chosen = run[rng.random_range(0..run.len())].1;
            (chosen, run.iter().map(|&(_, i)| weights[i]).sum::<f64>())
        })
        .unzip()
}

/// Sorts by key, then index (as `sort_unstable` would): least significant digit first, 11 bits
/// a pass, as many passes as the largest key needs. The cubature sorts every solid cell of a
/// voxel grid several times per new shape, where a comparison sort cost milliseconds each.
fn radix_sort(order: &mut Vec<(u64, usize)>) {
    const BITS: u32 = 11;
    let largest = order.iter().map(|&(key, _)| key).max().unwrap_or(0);
    let passes = (u64::BITS - largest.leading_zeros()).div_ceil(BITS);
    // The input is in index order, and every pass is stable: ties keep that order.
    let mut buffer = vec![(0u64, 0usize); order.len()];
    for pass in 0..passes {
        let digit = |key: u64| ((key >> (pass * BITS)) & ((1 << BITS) - 1)) as usize;
        let mut starts = vec![0usize; (1 << BITS) + 1];
        for &(key, _) in order.iter() {
            starts[digit(key) + 1] += 1;
        }
        for d in 0..1 << BITS {
            starts[d + 1] += starts[d];
        }
        for &entry in order.iter() {
            let d = digit(entry.0);
            buffer[starts[d]] = entry;
            starts[d] += 1;
        }
        std::mem::swap(order, &mut buffer);
    }
}

/// Interleaves the bits of three coordinates (21 bits each): nearby cells get nearby keys.
fn morton(c: [usize; 3]) -> u64 {
    let spread = |v: usize| {
        let mut x = v as u64 & 0x1f_ffff;
        x = (x | x << 32) & 0x1f00000000ffff;
        x = (x | x << 16) & 0x1f0000ff0000ff;
        x = (x | x << 8) & 0x100f00f00f00f00f;
        x = (x | x << 4) & 0x10c30c30c30c30c3;
        (x | x << 2) & 0x1249249249249249
    };
    spread(c[0]) | spread(c[1]) << 1 | spread(c[2]) << 2
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_few_points_carry_the_solids_volume_centroid_and_inertia() {
        let shape = crate::geometry::primitives::capsule_mesh(0.3, 0.1);
        let grid = VoxelGrid::from_shape(&shape, 32, None);
        let cell = grid.cell;
        let solid: Vec<_> = (0..grid.len())
            .filter(|&i| grid.solid[i])
            .map(|i| grid.cell_center(grid.coords(i)))
            .collect();
        let n = solid.len() as f64;
        let centroid = solid.iter().sum::<Vector3<f64>>() / n;
        let inertia = |points: &[Vector3<f64>], volumes: &[f64]| {
            points
                .iter()
                .zip(volumes)
                .map(|(p, v)| (p - centroid) * (p - centroid).transpose() * *v)
                .sum::<nalgebra::Matrix3<f64>>()
        };
        let exact = inertia(&solid, &vec![cell.powi(3); solid.len()]);
        for target in [40, 64, 256] {
            let c = Cubature::stratified(&grid, target, grid.solid_volume());
            let volume = c.total_volume();
            let got = c
                .points
                .iter()
                .zip(&c.volumes)
                .map(|(p, v)| p * *v)
                .sum::<Vector3<f64>>()
                / volume;
            assert!(
                (got - centroid).norm() < 1e-9,
                "{target} points: centroid {got:?}"
            );
            let scale = volume / (n * cell.powi(3));
            let error = (inertia(&c.points, &c.volumes) - exact * scale).norm() / exact.norm();
            assert!(error < 1e-9, "{target} points: inertia off by {error:e}");
            assert!(c.volumes.iter().all(|&v| v > 0.0));
        }
    }

    /// The coarser set keeps one point of each run, with the whole set's volume, centroid and
    /// second moments.
    #[test]
    fn a_coarsened_cubature_keeps_the_volume_centroid_and_inertia() {
        let shape = crate::geometry::primitives::capsule_mesh(0.3, 0.1);
        let grid = VoxelGrid::from_shape(&shape, 32, None);
        let fine = Cubature::stratified(&grid, 1024, grid.solid_volume());
        let moments = |c: &Cubature| {
            let volume = c.total_volume();
            let centroid = c.points.iter().zip(&c.volumes).map(|(p, v)| p * *v).sum();
            let second: nalgebra::Matrix3<f64> = c
                .points
                .iter()
                .zip(&c.volumes)
                .map(|(p, v)| p * p.transpose() * *v)
                .sum();
            (volume, centroid, second)
        };
        let (volume, centroid, second): (f64, Vector3<f64>, _) = moments(&fine);
        // Every other point keeps all three; one in four, the volume and centroid (matching
        // its inertia too would change a volume more than five-fold on this small capsule).
        for stride in [2, 4] {
            let (kept, coarse) = fine.coarsened(stride);
            assert_eq!(kept.len(), fine.len().div_ceil(stride));
            assert!(kept.iter().enumerate().all(|(run, &i)| i / stride == run));
            assert!(kept
                .iter()
                .zip(&coarse.points)
                .all(|(&i, p)| fine.points[i] == *p));
            let (v, c, s) = moments(&coarse);
            assert!(
                (v - volume).abs() < 1e-9 * volume,
                "stride {stride}: volume {v}"
            );
            assert!(
                (c - centroid).norm() < 1e-9 * volume,
                "stride {stride}: centroid"
            );
            assert!(
                stride > 2 || (s - second).norm() < 1e-9 * second.norm(),
                "stride {stride}: inertia"
            );
            assert!(coarse.volumes.iter().all(|&v| v > 0.0));
        }
    }

    #[test]
    fn the_radix_sort_orders_as_a_comparison_sort_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for bits in [1u32, 11, 12, 33, 64] {
            let keys = (0..5000).map(|_| rng.random::<u64>() >> (64 - bits));
            let mut order: Vec<(u64, usize)> = keys.enumerate().map(|(i, k)| (k, i)).collect();
            let mut expected = order.clone();
            expected.sort_unstable();
            radix_sort(&mut order);
            assert_eq!(order, expected, "{bits}-bit keys");
        }
    }
}
