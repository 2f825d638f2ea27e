//! A voxel solid's largest island, found on runs of solid cells along x rather than cell by
//! cell: a grid of 64 cells across holds a few thousand runs against a few hundred thousand
//! cells, and each run meets only the runs of the four rows before it that touch it.

/// A run of solid cells along x: cells `first..=last` of one row.
struct Run {
    row: usize,
    first: usize,
    last: usize,
}

/// Clears every solid cell of `solid` (x fastest over `dims`) outside its largest island, cells
/// connected when they share at least a corner. Of islands equally large, the one whose first
/// cell (in index order) comes last is kept.
pub(super) fn keep_largest_island(dims: [usize; 3], solid: &mut [bool]) {
    let [nx, ny, nz] = dims;
    let (runs, row_starts) = runs(dims, solid);
    let mut parent: Vec<usize> = (0..runs.len()).collect();
    for k in 0..nz {
        for j in 0..ny {
            let row = j + ny * k;
            // The rows before this one among its eight neighbours: the rest come later.
            let earlier = [(j > 0).then(|| row - 1), (k > 0).then(|| row - ny)]
                .into_iter()
                .chain([
                    (j > 0 && k > 0).then(|| row - ny - 1),
                    (j + 1 < ny && k > 0).then(|| row - ny + 1),
                ])
                .flatten();
            for other in earlier {
                join_touching(&runs, &row_starts, row, other, &mut parent);
            }
        }
    }
    let roots: Vec<usize> = (0..runs.len()).map(|r| find(&mut parent, r)).collect();
    let mut size = vec![0usize; runs.len()];
    for (run, &root) in runs.iter().zip(&roots) {
        size[root] += run.last - run.first + 1;
    }
    // Runs come in index order, so an island's first run names it in the order of its first cell.
    let (mut keep, mut seen) = (None, vec![false; runs.len()]);
    for &root in &roots {
        if !std::mem::replace(&mut seen[root], true)
            && keep.is_none_or(|k: usize| size[root] >= size[k])
        {
            keep = Some(root);
        }
    }
    for (run, &root) in runs.iter().zip(&roots) {
        if Some(root) != keep {
            let start = nx * run.row;
            solid[start + run.first..=start + run.last].fill(false);
        }
    }
}

/// The runs of every row in index order, and where each row's runs start (one past the end last).
fn runs([nx, ny, nz]: [usize; 3], solid: &[bool]) -> (Vec<Run>, Vec<usize>) {
    let mut runs = Vec::new();
    let mut row_starts = Vec::with_capacity(ny * nz + 1);
    for row in 0..ny * nz {
        row_starts.push(runs.len());
        let cells = &solid[nx * row..nx * (row + 1)];
        let mut i = 0;
        while i < nx {
            if !cells[i] {
                i += 1;
                continue;
            }
            let first = i;
            while i < nx && cells[i] {
                i += 1;
            }
            runs.push(Run {
                row,
                first,
                last: i - 1,
            });
        }
    }
    row_starts.push(runs.len());
    (runs, row_starts)
}

/// Joins each run of `row` with the runs of `other` it touches (their x ranges overlap or meet
/// at a corner).
fn join_touching(
    runs: &[Run],
    row_starts: &[usize],
    row: usize,
    other: usize,
    parent: &mut [usize],
) {
    let theirs = row_starts[other]..row_starts[other + 1];
    for a in row_starts[row]..row_starts[row + 1] {
        for b in theirs.clone() {
            if runs[b].first <= runs[a].last + 1 && runs[a].first <= runs[b].last + 1 {
                let (ra, rb) = (find(parent, a), find(parent, b));
                parent[ra.max(rb)] = ra.min(rb);
            }
        }
    }
}

fn find(parent: &mut [usize], mut r: usize) -> usize {
    while parent[r] != r {
        parent[r] = parent[parent[r]];
        r = parent[r];
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The island rule cell by cell: a search over the 26 cells around each solid cell, islands
    /// numbered by their first cell, the last of the largest kept.
    fn keep_largest_by_cells(dims: [usize; 3], solid: &mut [bool]) {
        let [nx, ny, nz] = dims;
        let mut label = vec![usize::MAX; solid.len()];
        let mut sizes = Vec::new();
        for seed in 0..solid.len() {
            if !solid[seed] || label[seed] != usize::MAX {
                continue;
            }
            let (id, mut stack) = (sizes.len(), vec![seed]);
            label[seed] = id;
            sizes.push(0);
            while let Some(c) = stack.pop() {
                sizes[id] += 1;
                let (i, j, k) = (c % nx, (c / nx) % ny, c / (nx * ny));
                for (di, dj, dk) in (0..27).map(|o| (o % 3, (o / 3) % 3, o / 9)) {
                    let (x, y, z) = (i + di, j + dj, k + dk);
                    if x == 0 || y == 0 || z == 0 || x > nx || y > ny || z > nz {
                        continue;
                    }
                    let n = (x - 1) + nx * ((y - 1) + ny * (z - 1));
                    if solid[n] && label[n] == usize::MAX {
                        label[n] = id;
                        stack.push(n);
                    }
                }
            }
        }
        let largest = (0..sizes.len()).max_by_key(|&i| sizes[i]);
        for (s, l) in solid.iter_mut().zip(&label) {
            *s = *s && Some(*l) == largest;
        }
    }

    #[test]
    fn runs_keep_the_same_island_as_a_search_cell_by_cell() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for trial in 0..300 {
            let dims = [1 + trial % 9, 1 + (trial / 3) % 7, 1 + (trial / 7) % 6];
            let fill = [0.1, 0.3, 0.5][trial % 3];
            let cells = dims.iter().product();
            let solid: Vec<bool> = (0..cells).map(|_| rng.random::<f64>() < fill).collect();
            let (mut ours, mut theirs) = (solid.clone(), solid);
            keep_largest_island(dims, &mut ours);
            keep_largest_by_cells(dims, &mut theirs);
            assert_eq!(ours, theirs, "dims {dims:?}, trial {trial}");
        }
    }
}
