//! Cubature: points inside the solid with volumes that add up to the object's volume.

use std::collections::HashMap;

use nalgebra::Vector3;

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

    /// About `target` points, stratified: the solid cells of `grid` are grouped into coarser
    /// blocks, and each block gives one point at the centroid of its cells, weighted by their
    /// volume. The volumes are then scaled to add up to `total_volume` (the exact volume of a
    /// closed mesh, or the grid's own estimate). The block size is searched so the count is the
    /// closest reachable to `target`.
    pub fn stratified(grid: &VoxelGrid, target: usize, total_volume: f64) -> Cubature {
        let max_blocks = grid.dims.iter().copied().max().unwrap_or(1);
        let (mut lo, mut hi) = (1usize, max_blocks);
        let mut best = group(grid, hi);
        // The count grows with the number of blocks across: bisect on it.
        while lo < hi {
            let mid = (lo + hi) / 2;
            let candidate = group(grid, mid);
            if candidate.len() >= target {
                hi = mid;
                best = candidate;
            } else {
                lo = mid + 1;
            }
        }
        if best.len() < target {
            best = group(grid, max_blocks);
        }
        let sum = best.total_volume();
        if sum > 0.0 {
            for v in &mut best.volumes {
                *v *= total_volume / sum;
            }
        }
        best
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

/// Groups solid cells into blocks of `blocks` across the longest grid side.
fn group(grid: &VoxelGrid, blocks: usize) -> Cubature {
    let longest = grid.dims.iter().copied().max().unwrap_or(1);
    let per_block = longest.div_ceil(blocks.max(1));
    let cell_volume = grid.cell.powi(3);
    let mut sums: HashMap<[usize; 3], (Vector3<f64>, usize)> = HashMap::new();
    for index in (0..grid.len()).filter(|&i| grid.solid[i]) {
        let c = grid.coords(index);
        let entry = sums
            .entry(c.map(|x| x / per_block))
            .or_insert((Vector3::zeros(), 0));
        entry.0 += grid.cell_center(c);
        entry.1 += 1;
    }
    let mut blocks: Vec<_> = sums.into_iter().collect();
    blocks.sort_by_key(|(key, _)| [key[2], key[1], key[0]]);
    Cubature {
        points: blocks.iter().map(|(_, (s, n))| s / *n as f64).collect(),
        volumes: blocks
            .iter()
            .map(|(_, (_, n))| *n as f64 * cell_volume)
            .collect(),
    }
}
