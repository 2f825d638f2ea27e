//! Voxel inside test: voxelize the surface, close small holes, flood-fill the outside;
//! every cell the outside cannot reach is solid. Works for closed meshes, open meshes with
//! small holes and bare point clouds alike, because it never needs a consistent orientation.

use std::collections::VecDeque;

use nalgebra::Vector3;

use super::shape::Shape;

/// A regular grid of cubic cells over (a padded box around) a shape, with a solid mask.
#[derive(Clone, Debug)]
pub struct VoxelGrid {
    /// Corner of cell (0, 0, 0).
    pub origin: Vector3<f64>,
    /// Edge length of one cell.
    pub cell: f64,
    /// Cells along x, y and z.
    pub dims: [usize; 3],
    /// Cells the surface passes through (or that hold a cloud point).
    pub surface: Vec<bool>,
    /// Cells inside or on the surface.
    pub solid: Vec<bool>,
}

/// Where a grid's frame lies in the world: each axis scaled about `anchor`. A fitted grid's cells
/// are cubic in its frame and slightly longer or shorter along some axes in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stretch {
    /// The point both frames share.
    pub anchor: Vector3<f64>,
    /// World length of one grid-frame length, per axis.
    pub scale: Vector3<f64>,
}

impl Stretch {
    /// The grid frame is the world.
    pub fn identity() -> Self {
        Self {
            anchor: Vector3::zeros(),
            scale: Vector3::repeat(1.0),
        }
    }

    /// A grid-frame point in the world.
    pub fn to_world(self, p: &Vector3<f64>) -> Vector3<f64> {
        self.anchor + (p - self.anchor).component_mul(&self.scale)
    }

    /// A world point in the grid frame.
    pub fn to_grid(self, p: &Vector3<f64>) -> Vector3<f64> {
        self.anchor + (p - self.anchor).component_div(&self.scale)
    }
}

impl VoxelGrid {
    /// Voxelizes `shape` with `resolution` cells across the longest side of its bounding box.
    /// `closing_radius` cells of dilation seal holes up to about twice that width before the
    /// flood fill; `None` picks 1 for meshes and, for clouds, enough to bridge the point spacing.
    pub fn from_shape(shape: &Shape, resolution: usize, closing_radius: Option<usize>) -> Self {
        Self::voxelized(shape, resolution, closing_radius, None)
    }

    /// `from_shape` with a cell corner at `anchor` when one is given: the grid is then
    /// symmetric through it, and so is the solid of a shape symmetric through it.
    fn voxelized(
        shape: &Shape,
        resolution: usize,
        closing_radius: Option<usize>,
        anchor: Option<&Vector3<f64>>,
    ) -> Self {
        let (lo, hi) = shape.bounds();
        let cell = (hi - lo).max() / resolution.max(1) as f64;
        let radius = closing_radius.unwrap_or_else(|| default_closing_radius(shape, cell));
        let pad = (radius + 2) as f64;
        let origin = match anchor {
            Some(a) => a - (a - lo).map(|d| ((d / cell).ceil() + pad) * cell),
            None => lo - Vector3::repeat(pad * cell),
        };
        // Written from `lo` without an anchor: the same cells as ever, to the last bit.
        let start = anchor.map_or(lo, |_| origin + Vector3::repeat(pad * cell));
        let dims =
            [0, 1, 2].map(|a| ((hi[a] - start[a]) / cell).ceil() as usize + 2 * pad as usize + 1);
        let mut grid = Self {
            origin,
            cell,
            dims,
            surface: vec![false; dims[0] * dims[1] * dims[2]],
            solid: Vec::new(),
        };
        if shape.is_point_cloud() {
            for p in &shape.positions {
                let idx = grid.cell_of(p);
                let i = grid.index(idx);
                grid.surface[i] = true;
            }
        } else {
            for t in 0..shape.triangles.len() {
                grid.rasterize_triangle(&shape.triangle(t));
            }
        }
        grid.solid = grid.fill_inside(radius);
        grid.keep_largest_component();
        grid
    }

    /// The solid of `solid` (points on and inside a surface), its holes closed by the spacing
    /// of `surface`'s points: a dense fill must not shrink the closing to its own spacing.
    /// The grid has a cell corner at `centre` (see `voxelized`).
    pub fn from_filled_cloud(
        solid: &Shape,
        surface: &Shape,
        resolution: usize,
        centre: &Vector3<f64>,
    ) -> Self {
        let (lo, hi) = solid.bounds();
        let cell = (hi - lo).max() / resolution.max(1) as f64;
        let radius = default_closing_radius(surface, cell);
        let mut grid = Self::voxelized(solid, resolution, Some(radius), Some(centre));
        // Only the surface's cells are cut by it (and count half in the volume); the fill's
        // other cells are whole.
        grid.surface.iter_mut().for_each(|s| *s = false);
        for p in &surface.positions {
            let i = grid.index(grid.cell_of(p));
            grid.surface[i] = true;
        }
        grid
    }

    /// The number of cells.
    pub fn len(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Whether the grid has no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The linear index of cell (i, j, k), x fastest (the order of `surface` and `solid`).
    pub fn index(&self, [i, j, k]: [usize; 3]) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// The cell (i, j, k) of a linear index: the inverse of [`VoxelGrid::index`].
    pub fn coords(&self, index: usize) -> [usize; 3] {
        let i = index % self.dims[0];
        let j = (index / self.dims[0]) % self.dims[1];
        [i, j, index / (self.dims[0] * self.dims[1])]
    }

    /// The cell holding `p`, clamped to the grid.
    pub fn cell_of(&self, p: &Vector3<f64>) -> [usize; 3] {
        [0, 1, 2].map(|a| {
            let f = ((p[a] - self.origin[a]) / self.cell).floor();
            f.clamp(0.0, (self.dims[a] - 1) as f64) as usize
        })
    }

    /// The centre of cell (i, j, k).
    pub fn cell_center(&self, [i, j, k]: [usize; 3]) -> Vector3<f64> {
        self.origin + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * self.cell
    }

    /// The lowest corner of cell (i, j, k); indices up to `dims` give the far corners.
    pub fn cell_corner(&self, [i, j, k]: [usize; 3]) -> Vector3<f64> {
        self.origin + Vector3::new(i as f64, j as f64, k as f64) * self.cell
    }

    /// Whether `p` lies in a solid cell; points outside the grid are outside.
    pub fn contains(&self, p: &Vector3<f64>) -> bool {
        let inside_box = (0..3).all(|a| {
            let f = (p[a] - self.origin[a]) / self.cell;
            f >= 0.0 && f < self.dims[a] as f64
        });
        inside_box && self.solid[self.index(self.cell_of(p))]
    }

    /// `normal` at the surface point `p`, or its opposite, whichever leaves the solid: of the
    /// probes `cells` cells along each, the one with more outside the solid. None when both
    /// count alike (a thin part, or a point off the surface, shows no side).
    pub fn outward(
        &self,
        p: &Vector3<f64>,
        normal: &Vector3<f64>,
        cells: &[f64],
    ) -> Option<Vector3<f64>> {
        let outside = |n: Vector3<f64>| {
            (cells.iter())
                .filter(|&&s| !self.contains(&(p + n * (s * self.cell))))
                .count()
        };
        match outside(*normal).cmp(&outside(-normal)) {
            std::cmp::Ordering::Greater => Some(*normal),
            std::cmp::Ordering::Less => Some(-normal),
            std::cmp::Ordering::Equal => None,
        }
    }

    /// The number of solid cells.
    pub fn solid_count(&self) -> usize {
        self.solid.iter().filter(|&&s| s).count()
    }

    /// The mean centre of the solid cells: the solid's centre of mass at uniform density (the
    /// origin when no cell is solid).
    pub fn solid_centroid(&self) -> Vector3<f64> {
        let (sum, count) = (0..self.len())
            .filter(|&i| self.solid[i])
            .fold((Vector3::zeros(), 0usize), |(sum, count), i| {
                (sum + self.cell_center(self.coords(i)), count + 1)
            });
        sum / count.max(1) as f64
    }

    /// Volume of the solid, counting cells the surface cuts as half full.
    pub fn solid_volume(&self) -> f64 {
        let (mut full, mut cut) = (0usize, 0usize);
        for (s, f) in self.solid.iter().zip(&self.surface) {
            match (*s, *f) {
                (true, true) => cut += 1,
                (true, false) => full += 1,
                _ => {}
            }
        }
        (full as f64 + 0.5 * cut as f64) * self.cell.powi(3)
    }

    /// The boundary of the solid as a closed triangle mesh (two triangles per cell face between
    /// a solid cell and an empty one), wound so that normals point out of the solid.
    pub fn boundary_mesh(&self) -> (Vec<Vector3<f64>>, Vec<[u32; 3]>) {
        let mut corners: std::collections::HashMap<[usize; 3], u32> = Default::default();
        let mut points = Vec::new();
        let mut triangles = Vec::new();
        let mut corner = |c: [usize; 3], points: &mut Vec<Vector3<f64>>| {
            *corners.entry(c).or_insert_with(|| {
                points.push(self.cell_corner(c));
                (points.len() - 1) as u32
            })
        };
        for index in (0..self.len()).filter(|&i| self.solid[i]) {
            let cell = self.coords(index);
            for (axis, outward) in [0, 1, 2].into_iter().flat_map(|a| [(a, true), (a, false)]) {
                let mut next = cell.map(|c| c as isize);
                next[axis] += if outward { 1 } else { -1 };
                let inside = (0..3).all(|a| next[a] >= 0 && (next[a] as usize) < self.dims[a]);
                if inside && self.solid[self.index(next.map(|c| c as usize))] {
                    continue;
                }
                // The face's corners, counter-clockwise seen from outside along +axis.
                let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
                let mut quad = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(db, dc)| {
                    let mut at = cell;
                    at[axis] += outward as usize;
                    at[b] += db;
                    at[c] += dc;
                    corner(at, &mut points)
                });
                if !outward {
                    quad.reverse();
                }
                triangles.push([quad[0], quad[1], quad[2]]);
                triangles.push([quad[0], quad[2], quad[3]]);
            }
        }
        (points, triangles)
    }

    /// The same region on a grid with `resolution` cells across the longest side: a coarse cell is
    /// solid when at least half of the fine cells whose centers fall in it are solid.
    pub fn resample(&self, resolution: usize) -> VoxelGrid {
        let (lo, hi) = self.solid_bounds();
        let cell = (hi - lo).max() / resolution.max(1) as f64;
        let counts = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / cell).ceil() as usize);
        self.resample_onto(lo, cell, counts, &Stretch::identity(), 2)
    }

    /// A coarser grid whose cells tile the box (`lo`, `hi`) exactly, about `resolution` cells
    /// along its longest side, a cell solid when at least half of it is. The cells are cubic in
    /// the grid's frame and the returned stretch maps that frame onto the world, scaling each
    /// axis a little so that a whole number of cells spans the box: given a shape's own bounds,
    /// the solid ends at its extremes on every axis, so a 6 cm slab meshed with 3.3 cm cells is
    /// 6 cm thick, not 6.7. `resample` tiles the solid cells' bounds with cubic cells instead,
    /// which reach past the surface wherever a side is not a whole number of cells.
    pub fn resample_fitted(
        &self,
        lo: Vector3<f64>,
        hi: Vector3<f64>,
        resolution: usize,
    ) -> (Self, Stretch) {
        self.fitted(lo, hi, resolution, 2)
    }

    /// `resample_fitted` with each fine cell the surface cuts counted half solid in the vote:
    /// on average a cut cell is half inside, and counted whole it makes a thin part a fine cell
    /// thicker on each side (the bundled rod's fitted mesh held 1.18 to 1.29 of its volume).
    pub fn resample_fitted_half_cut(
        &self,
        lo: Vector3<f64>,
        hi: Vector3<f64>,
        resolution: usize,
    ) -> (Self, Stretch) {
        self.fitted(lo, hi, resolution, 1)
    }

    /// The fitted grid of `resample_fitted`, each cut fine cell voting `cut_vote` (of 2).
    fn fitted(
        &self,
        lo: Vector3<f64>,
        hi: Vector3<f64>,
        resolution: usize,
        cut_vote: u32,
    ) -> (Self, Stretch) {
        let cell = (hi - lo).max() / resolution.max(1) as f64;
        let counts = [0, 1, 2].map(|a| (((hi[a] - lo[a]) / cell).round() as usize).max(1));
        let scale = Vector3::from_fn(|a, _| (hi[a] - lo[a]) / (counts[a] as f64 * cell));
        let stretch = Stretch { anchor: lo, scale };
        (
            self.resample_onto(lo, cell, counts, &stretch, cut_vote),
            stretch,
        )
    }

    /// The coarse grid of cubic `cell`s whose first `counts` cells per axis start at `lo` in the
    /// grid frame (one empty cell pads each side), voted by the fine cells whose centers
    /// `stretch` places in them: a solid fine cell counts 2, one the surface cuts `cut_vote`.
    fn resample_onto(
        &self,
        lo: Vector3<f64>,
        cell: f64,
        counts: [usize; 3],
        stretch: &Stretch,
        cut_vote: u32,
    ) -> VoxelGrid {
        let dims = counts.map(|n| n + 2);
        let mut coarse = VoxelGrid {
            origin: lo - Vector3::repeat(cell),
            cell,
            dims,
            surface: vec![false; dims[0] * dims[1] * dims[2]],
            solid: vec![false; dims[0] * dims[1] * dims[2]],
        };
        let mut solid_hits = vec![0u32; coarse.len()];
        let mut total = vec![0u32; coarse.len()];
        for index in 0..self.len() {
            let center = stretch.to_grid(&self.cell_center(self.coords(index)));
            let c = coarse.index(coarse.cell_of(&center));
            total[c] += 2;
            if self.solid[index] {
                solid_hits[c] += if self.surface[index] { cut_vote } else { 2 };
            }
        }
        for c in 0..coarse.len() {
            coarse.solid[c] = total[c] > 0 && 2 * solid_hits[c] >= total[c] && solid_hits[c] > 0;
        }
        coarse.keep_largest_component();
        coarse.surface = coarse.boundary_cells();
        coarse
    }

    /// Drops every solid island but the largest. Cells count as connected when they share a
    /// corner, the connectivity of the tetrahedral mesh built on them: a second island would be
    /// a second free body, with a second null mode in every stiffness matrix.
    pub fn keep_largest_component(&mut self) {
        super::islands::keep_largest_island(self.dims, &mut self.solid);
    }

    /// Bounding box of the solid cells (whole cells).
    pub fn solid_bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for index in (0..self.len()).filter(|&i| self.solid[i]) {
            let c = self.cell_corner(self.coords(index));
            lo = lo.inf(&c);
            hi = hi.sup(&(c + Vector3::repeat(self.cell)));
        }
        (lo, hi)
    }

    /// Solid cells with at least one non-solid face neighbour.
    fn boundary_cells(&self) -> Vec<bool> {
        (0..self.len())
            .map(|index| {
                self.solid[index]
                    && self
                        .neighbours(self.coords(index))
                        .into_iter()
                        .any(|n| n.is_none_or(|n| !self.solid[self.index(n)]))
            })
            .collect()
    }

    fn neighbours(&self, [i, j, k]: [usize; 3]) -> [Option<[usize; 3]>; 6] {
        let step = |c: usize, d: isize, n: usize| {
            let v = c as isize + d;
            (v >= 0 && (v as usize) < n).then_some(v as usize)
        };
        [
            step(i, -1, self.dims[0]).map(|x| [x, j, k]),
            step(i, 1, self.dims[0]).map(|x| [x, j, k]),
            step(j, -1, self.dims[1]).map(|y| [i, y, k]),
            step(j, 1, self.dims[1]).map(|y| [i, y, k]),
            step(k, -1, self.dims[2]).map(|z| [i, j, z]),
            step(k, 1, self.dims[2]).map(|z| [i, j, z]),
        ]
    }

    fn rasterize_triangle(&mut self, tri: &[Vector3<f64>; 3]) {
        let lo = tri[0].inf(&tri[1]).inf(&tri[2]);
        let hi = tri[0].sup(&tri[1]).sup(&tri[2]);
        let [i0, j0, k0] = self.cell_of(&lo);
        let [i1, j1, k1] = self.cell_of(&hi);
        // Slightly fattened cells: a face lying exactly on a cell boundary must mark a cell on
        // at least one side despite round-off, or the flood fill leaks through it.
        let half = Vector3::repeat(self.cell * 0.5 * (1.0 + 1e-6));
        for k in k0..=k1 {
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let center = self.cell_center([i, j, k]);
                    if triangle_overlaps_box(tri, &center, &half) {
                        let index = self.index([i, j, k]);
                        self.surface[index] = true;
                    }
                }
            }
        }
    }

    /// Morphological closing of the solid: dilate the surface by `radius`, flood the outside
    /// from the grid border, then give the outside back the `radius` cells it lost.
    fn fill_inside(&self, radius: usize) -> Vec<bool> {
        let wall = self.dilate(&self.surface, radius);
        let mut outside = vec![false; self.len()];
        let mut queue = VecDeque::new();
        for index in 0..self.len() {
            let [i, j, k] = self.coords(index);
            let border = i == 0
                || j == 0
                || k == 0
                || i + 1 == self.dims[0]
                || j + 1 == self.dims[1]
                || k + 1 == self.dims[2];
            if border && !wall[index] {
                outside[index] = true;
                queue.push_back(index);
            }
        }
        while let Some(index) = queue.pop_front() {
            for n in self.face_neighbours(index) {
                if !outside[n] && !wall[n] {
                    outside[n] = true;
                    queue.push_back(n);
                }
            }
        }
        let regrown = self.dilate(&outside, radius);
        (0..self.len())
            .map(|i| self.surface[i] || !regrown[i])
            .collect()
    }

    /// Cells within `radius` steps (6-connected) of a set cell: a breadth-first search from
    /// the mask, `radius` layers deep, so each cell is visited once whatever the radius.
    fn dilate(&self, mask: &[bool], radius: usize) -> Vec<bool> {
        let mut reached = mask.to_vec();
        let mut layer: Vec<usize> = (0..self.len()).filter(|&i| mask[i]).collect();
        for _ in 0..radius {
            let mut next = Vec::new();
            for &index in &layer {
                for n in self.face_neighbours(index) {
                    if !reached[n] {
                        reached[n] = true;
                        next.push(n);
                    }
                }
            }
            layer = next;
        }
        reached
    }

    /// The indices of the (up to 6) cells sharing a face with the cell at `index`.
    fn face_neighbours(&self, index: usize) -> impl Iterator<Item = usize> {
        let [i, j, k] = self.coords(index);
        let [nx, ny, nz] = self.dims;
        let (row, slab) = (nx, nx * ny);
        [
            (i > 0, index.wrapping_sub(1)),
            (i + 1 < nx, index + 1),
            (j > 0, index.wrapping_sub(row)),
            (j + 1 < ny, index + row),
            (k > 0, index.wrapping_sub(slab)),
            (k + 1 < nz, index + slab),
        ]
        .into_iter()
        .filter_map(|(inside, n)| inside.then_some(n))
    }
}

/// For clouds: enough closing to bridge the gaps between neighbouring points. Real clouds are
/// clumpy (random samples, scan lines), so the gap is judged by the distance to the 6th nearest
/// neighbour, not the nearest; a 6-connected dilation reaches only 1/sqrt(3) of its radius
/// along diagonals, hence the margin.
fn default_closing_radius(shape: &Shape, cell: f64) -> usize {
    if !shape.is_point_cloud() {
        return 1;
    }
    let gap = super::point_index::neighbour_distance(&shape.positions, 6, 0.9);
    ((1.5 * gap / cell).ceil() as usize).clamp(1, 8)
}

/// Separating-axis test between a triangle and an axis-aligned box (center, half extents).
pub(crate) fn triangle_overlaps_box(
    tri: &[Vector3<f64>; 3],
    center: &Vector3<f64>,
    half: &Vector3<f64>,
) -> bool {
    let v = tri.map(|p| p - center);
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let separated_on = |axis: Vector3<f64>| {
        if axis.norm_squared() < 1e-30 {
            return false;
        }
        let p = v.map(|x| x.dot(&axis));
        let r = half.x * axis.x.abs() + half.y * axis.y.abs() + half.z * axis.z.abs();
        p.iter().cloned().fold(f64::INFINITY, f64::min) > r
            || p.iter().cloned().fold(f64::NEG_INFINITY, f64::max) < -r
    };
    for e in &edges {
        for a in [Vector3::x(), Vector3::y(), Vector3::z()] {
            if separated_on(a.cross(e)) {
                return false;
            }
        }
    }
    for a in [Vector3::x(), Vector3::y(), Vector3::z()] {
        if separated_on(a) {
            return false;
        }
    }
    !separated_on(edges[0].cross(&edges[1]))
}
