//! A uniform grid over points for nearest-neighbour queries: the points sorted by cell, each
//! cell's run found by offset (no hashing on the query path).
//! Also a cloud's spacing statistics measured with it (`neighbour_distance`, `median_spacing`)
//! and the plane through a neighbourhood it found (`neighbourhood_plane`).

use nalgebra::{Matrix3, Vector3};

/// At most this many cells per point (and at least 2^16 allowed): a cell asked for smaller
/// than that is widened, so sparse outliers cannot make the grid huge.
const CELLS_PER_POINT: usize = 8;

/// A uniform grid over borrowed points for k-nearest-neighbour queries.
pub struct PointIndex<'a> {
    points: &'a [Vector3<f64>],
    cell: f64,
    origin: Vector3<f64>,
    dims: [i64; 3],
    /// `order[starts[c]..starts[c + 1]]`: the points in cell `c`.
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl<'a> PointIndex<'a> {
    /// `cell` is best near the typical neighbour spacing.
    pub fn new(points: &'a [Vector3<f64>], cell: f64) -> Self {
        let (lo, hi) = bounds(points);
        let extent = hi - lo;
        let limit = (CELLS_PER_POINT * points.len()).max(1 << 16) as f64;
        let mut cell = cell.max(extent.max() * 1e-9).max(1e-300);
        let cells = |cell: f64| {
            extent
                .iter()
                .map(|e| (e / cell).floor() + 1.0)
                .product::<f64>()
        };
        if cells(cell) > limit {
            cell *= (cells(cell) / limit).cbrt() * 1.01;
        }
        let dims = [0, 1, 2].map(|a| (extent[a] / cell).floor() as i64 + 1);
        let mut index = Self {
            points,
            cell,
            origin: lo,
            dims,
            starts: Vec::new(),
            order: Vec::new(),
        };
        index.sort_into_cells();
        index
    }

    /// For points spread over a surface: a cell holding a handful of points.
    pub fn for_surface(points: &'a [Vector3<f64>]) -> Self {
        let (lo, hi) = bounds(points);
        let diagonal = (hi - lo).norm().max(1e-12);
        Self::new(
            points,
            2.0 * diagonal / (points.len() as f64).sqrt().max(1.0),
        )
    }

    /// A counting sort of the points by cell.
    fn sort_into_cells(&mut self) {
        let count = self.dims.iter().product::<i64>() as usize;
        let cell_of: Vec<usize> = self
            .points
            .iter()
            .map(|p| self.linear(self.key(p)).unwrap_or(0))
            .collect();
        let mut starts = vec![0u32; count + 1];
        for &c in &cell_of {
            starts[c + 1] += 1;
        }
        for c in 0..count {
            starts[c + 1] += starts[c];
        }
        let mut next = starts.clone();
        let mut order = vec![0u32; self.points.len()];
        for (i, &c) in cell_of.iter().enumerate() {
            order[next[c] as usize] = i as u32;
            next[c] += 1;
        }
        self.starts = starts;
        self.order = order;
    }

    /// Indices of the `k` nearest points to `query` (fewer if there are fewer points), nearest
    /// first (ties by index), skipping `exclude`.
    pub fn nearest(&self, query: &Vector3<f64>, k: usize, exclude: Option<usize>) -> Vec<usize> {
        let wanted = k.min(self.points.len() - usize::from(exclude.is_some()));
        if wanted == 0 {
            return Vec::new();
        }
        let center = self.key(query);
        let last_ring = self.last_ring(center);
        let margin = self.depth_in_cell(query, center);
        // The best `wanted` so far, sorted: callers ask for a handful, thousands of times (a
        // tracker's normals), and keeping every visited point to select from cost more than
        // the search.
        let mut best: Vec<(f64, usize)> = Vec::with_capacity(wanted + 1);
        for ring in 0..=last_ring {
            self.visit_ring(center, ring, |i| {
                if Some(i) == exclude {
                    return;
                }
                let entry = ((self.points[i] - query).norm_squared(), i);
                let worse = |a: &(f64, usize)| a.0.total_cmp(&entry.0).then(a.1.cmp(&entry.1));
                if best.len() == wanted && worse(&best[wanted - 1]).is_lt() {
                    return;
                }
                let at = best.partition_point(|a| worse(a).is_lt());
                best.insert(at, entry);
                best.truncate(wanted);
            });
            // Every point not yet seen is at least `ring` whole cells and the margin away.
            let reach = ring as f64 * self.cell + margin;
            if best.len() == wanted && best[wanted - 1].0.sqrt() < reach {
                break;
            }
        }
        best.into_iter().map(|(_, i)| i).collect()
    }

    /// The nearest point to `query` and its distance (None without points): `nearest` for one
    /// point, without its allocations, for callers that ask thousands of times a frame.
    pub fn closest(&self, query: &Vector3<f64>) -> Option<(usize, f64)> {
        if self.points.is_empty() {
            return None;
        }
        let center = self.key(query);
        let last_ring = self.last_ring(center);
        let margin = self.depth_in_cell(query, center);
        let mut best = (usize::MAX, f64::INFINITY);
        for ring in 0..=last_ring {
            self.visit_ring(center, ring, |i| {
                let d = (self.points[i] - query).norm_squared();
                if d < best.1 || (d == best.1 && i < best.0) {
                    best = (i, d);
                }
            });
            if best.0 != usize::MAX && best.1.sqrt() < ring as f64 * self.cell + margin {
                break;
            }
        }
        Some((best.0, best.1.sqrt()))
    }

    /// The ring around `center` past which every cell of the grid has been seen.
    fn last_ring(&self, center: [i64; 3]) -> i64 {
        (0..3)
            .map(|a| center[a].abs().max((self.dims[a] - 1 - center[a]).abs()))
            .max()
            .unwrap_or(0)
    }

    /// Calls `visit` with every point in the cells `ring` cells (Chebyshev) from `center`. Cells
    /// are sorted x fastest, so a row of cells is one run of `order`: rows on the ring's faces are
    /// visited whole, the other rows at their two ends.
    fn visit_ring(&self, center: [i64; 3], ring: i64, mut visit: impl FnMut(usize)) {
        let [nx, ny, nz] = self.dims;
        for k in (center[2] - ring).max(0)..=(center[2] + ring).min(nz - 1) {
            for j in (center[1] - ring).max(0)..=(center[1] + ring).min(ny - 1) {
                let row = nx * (j + ny * k);
                let on_face = (k - center[2]).abs() == ring || (j - center[1]).abs() == ring;
                let (first, last) = (center[0] - ring, center[0] + ring);
                if on_face {
                    let (first, last) = (first.max(0), last.min(nx - 1));
                    if first <= last {
                        self.visit_run((row + first) as usize, (row + last) as usize, &mut visit);
                    }
                } else {
                    for i in [first, last].into_iter().filter(|i| (0..nx).contains(i)) {
                        self.visit_run((row + i) as usize, (row + i) as usize, &mut visit);
                    }
                }
            }
        }
    }

    /// Calls `visit` with every point in the cells `first..=last` (linear indices).
    fn visit_run(&self, first: usize, last: usize, visit: &mut impl FnMut(usize)) {
        let run = self.starts[first] as usize..self.starts[last + 1] as usize;
        self.order[run].iter().for_each(|&i| visit(i as usize));
    }

    /// How far `p` lies inside its own cell: every point of a cell `ring + 1` cells away is at
    /// least `ring` cells plus this far.
    fn depth_in_cell(&self, p: &Vector3<f64>, key: [i64; 3]) -> f64 {
        (0..3)
            .map(|a| {
                let lo = self.origin[a] + key[a] as f64 * self.cell;
                (p[a] - lo).min(lo + self.cell - p[a])
            })
            .fold(f64::INFINITY, f64::min)
            .max(0.0)
    }

    fn key(&self, p: &Vector3<f64>) -> [i64; 3] {
        [0, 1, 2].map(|a| ((p[a] - self.origin[a]) / self.cell).floor() as i64)
    }

    /// The cell's position in `starts`, or None outside the grid.
    fn linear(&self, [i, j, k]: [i64; 3]) -> Option<usize> {
        let inside = (0..3).all(|a| (0..self.dims[a]).contains(&[i, j, k][a]));
        inside.then(|| (i + self.dims[0] * (j + self.dims[1] * k)) as usize)
    }
}

/// The `quantile` of the distance from a point to its `k`-th nearest neighbour (over at most
/// 2000 points).
pub fn neighbour_distance(points: &[Vector3<f64>], k: usize, quantile: f64) -> f64 {
    if points.len() < 2 {
        return 0.0;
    }
    let index = PointIndex::for_surface(points);
    let stride = (points.len() / 2000).max(1);
    let mut d: Vec<f64> = (0..points.len())
        .step_by(stride)
        .filter_map(|i| {
            let n = index.nearest(&points[i], k, Some(i));
            n.last().map(|&j| (points[j] - points[i]).norm())
        })
        .collect();
    d.sort_by(f64::total_cmp);
    d[((d.len() as f64 * quantile) as usize).min(d.len() - 1)]
}

/// The plane fitted through a neighbourhood of points (principal components of their scatter).
pub(crate) struct NeighbourhoodPlane {
    /// Unit normal, of either sign: the direction of least spread.
    pub normal: Vector3<f64>,
    /// The scatter's eigenvalues, smallest first: the neighbourhood is flat where the first
    /// is small beside the second.
    pub spread: [f64; 3],
}

/// The plane through `points[neighbours]`; None for fewer than three points, which fix none.
pub(crate) fn neighbourhood_plane(
    points: &[Vector3<f64>],
    neighbours: &[usize],
) -> Option<NeighbourhoodPlane> {
    if neighbours.len() < 3 {
        return None;
    }
    let mean =
        neighbours.iter().map(|&j| points[j]).sum::<Vector3<f64>>() / neighbours.len() as f64;
    let mut scatter = Matrix3::zeros();
    for &j in neighbours {
        let d = points[j] - mean;
        scatter += d * d.transpose();
    }
    let eigen = scatter.symmetric_eigen();
    let mut order = [0, 1, 2];
    order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
    Some(NeighbourhoodPlane {
        normal: eigen.eigenvectors.column(order[0]).into_owned(),
        spread: order.map(|i| eigen.eigenvalues[i]),
    })
}

/// The index of the point of `among` nearest to `p`, by looking at each (for a few points or a
/// single query, where an index does not pay); None when `among` is empty.
pub(crate) fn nearest_point(among: &[Vector3<f64>], p: &Vector3<f64>) -> Option<usize> {
    (0..among.len()).min_by(|&a, &b| {
        (among[a] - p)
            .norm_squared()
            .total_cmp(&(among[b] - p).norm_squared())
    })
}

fn bounds(points: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let first = points.first().copied().unwrap_or_else(Vector3::zeros);
    points
        .iter()
        .fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Against a brute-force search, on clumpy points with far outliers and queries outside.
    #[test]
    fn nearest_matches_a_brute_force_search() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let mut points: Vec<Vector3<f64>> = (0..3000)
            .map(|_| Vector3::new(rng.random(), rng.random(), 0.01 * rng.random::<f64>()))
            .collect();
        points.push(Vector3::new(1e4, -3e3, 7.0));
        for cell in [1e-6, 0.02, 0.3, 10.0] {
            let index = PointIndex::new(&points, cell);
            for q in 0..200 {
                let query = Vector3::new(rng.random::<f64>() * 1.4 - 0.2, rng.random(), 0.5);
                let exclude = (q % 2 == 0).then_some(q);
                let mut brute: Vec<(f64, usize)> = (0..points.len())
                    .filter(|&i| Some(i) != exclude)
                    .map(|i| ((points[i] - query).norm_squared(), i))
                    .collect();
                brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let expected: Vec<usize> = brute.iter().take(7).map(|x| x.1).collect();
                assert_eq!(index.nearest(&query, 7, exclude), expected, "cell {cell}");
            }
        }
        assert_eq!(
            PointIndex::for_surface(&points)
                .nearest(&points[3000], 1, Some(3000))
                .len(),
            1
        );
    }
}
