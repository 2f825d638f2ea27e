//! Cubature: points inside the solid with volumes that add up to the object's volume.

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::voxel::VoxelGrid;

#[derive(Clone, Debug, Default)]
pub struct Cubature {
    pub points: Vec<Vector3<f64>>,
    pub volumes: Vec<f64>,
}

impl Cubature {
    pub fn len(&self) -> usize {
        self.points.len()
    }
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
    pub fn total_volume(&self) -> f64 {
        self.volumes.iter().sum()
    }

    /// `target` points (or every sub-cell, if fewer), stratified along a space-filling curve:
    /// every solid cell of `grid` is split into 2 x 2 x 2 sub-cells, the sub-cells are sorted in
    /// Morton (Z) order, the order is cut into `target` runs of equal length, and each run gives
    /// one of its sub-cell centers, drawn at random (seeded), weighted by the run's volume. The
    /// volumes are then scaled to add up to `total_volume` (the exact volume of a closed mesh,
    /// or the grid's own estimate).
    ///
    /// A random member rather than the run's centroid: on a thin part, centroids of runs
    /// spanning its thickness all lie on the mid-surface, where bending causes no strain, and the
    /// subspace would bend for free.
    pub fn stratified(grid: &VoxelGrid, target: usize, total_volume: f64) -> Cubature {
        let mut subcells: Vec<(u64, [usize; 3])> = Vec::new();
        for index in (0..grid.len()).filter(|&i| grid.solid[i]) {
            let c = grid.coords(index);
            for s in 0..8 {
                let sub = [
                    2 * c[0] + (s & 1),
                    2 * c[1] + ((s >> 1) & 1),
                    2 * c[2] + (s >> 2),
                ];
                subcells.push((morton(sub), sub));
            }
        }
        subcells.sort_unstable_by_key(|(key, _)| *key);
        let runs = target.clamp(1, subcells.len().max(1));
        let sub_volume = grid.cell.powi(3) / 8.0;
        let mut rng = ChaCha8Rng::seed_from_u64(subcells.len() as u64);
        let mut cubature = Cubature::default();
        for r in 0..runs {
            let run = &subcells[r * subcells.len() / runs..(r + 1) * subcells.len() / runs];
            if run.is_empty() {
                continue;
            }
            let sub = run[rng.random_range(0..run.len())].1;
            cubature.points.push(
                grid.origin
                    + Vector3::new(
                        sub[0] as f64 + 0.5,
                        sub[1] as f64 + 0.5,
                        sub[2] as f64 + 0.5,
                    ) * (grid.cell / 2.0),
            );
            cubature.volumes.push(run.len() as f64 * sub_volume);
        }
        let sum = cubature.total_volume();
        if sum > 0.0 {
            for v in &mut cubature.volumes {
                *v *= total_volume / sum;
            }
        }
        cubature
    }

    /// One point per solid cell of `grid`, at its center, with the cell's volume.
    pub fn every_cell(grid: &VoxelGrid) -> Cubature {
        let volume = grid.cell.powi(3);
        let points: Vec<_> = (0..grid.len())
            .filter(|&i| grid.solid[i])
            .map(|i| grid.cell_center(grid.coords(i)))
            .collect();
        let volumes = vec![volume; points.len()];
        Cubature { points, volumes }
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
