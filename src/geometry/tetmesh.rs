//! A tetrahedral mesh of a voxel grid's solid cells: each cube split into the six Kuhn
//! tetrahedra around its main diagonal, which match across neighbouring cubes.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::voxel::{Stretch, VoxelGrid};

/// The six axis orders; tetrahedron p of a cube runs corner 000 -> +e[p0] -> +e[p1] -> 111.
const KUHN_ORDERS: [[usize; 3]; 6] = [
    [0, 1, 2],
    [0, 2, 1],
    [1, 0, 2],
    [1, 2, 0],
    [2, 0, 1],
    [2, 1, 0],
];

/// A conforming tetrahedral mesh of a voxel grid's solid cells (six tetrahedra per cell),
/// in the grid's frame.
#[derive(Clone, Debug)]
pub struct TetMesh {
    /// The cell corners that solid cells use.
    pub vertices: Vec<Vector3<f64>>,
    /// Positively oriented tetrahedra.
    pub tets: Vec<[u32; 4]>,
    /// Vertices on the boundary, with the boundary area each stands for.
    pub boundary_vertices: Vec<u32>,
    /// The boundary area each of `boundary_vertices` stands for.
    pub boundary_areas: Vec<f64>,
    grid: VoxelGrid,
    /// Where the grid's frame lies in the world (identity unless made from a fitted grid).
    stretch: Stretch,
    /// Corner (i, j, k) of the grid to vertex index.
    corner_vertex: HashMap<[usize; 3], u32>,
}

/// Where a point falls: four vertices, their barycentric weights and the gradients of those
/// weights (constant over the tetrahedron).
#[derive(Clone, Copy, Debug)]
pub struct TetLocation {
    /// The tetrahedron's vertices.
    pub vertices: [u32; 4],
    /// The point's barycentric weights of those vertices (they add up to 1).
    pub barycentric: [f64; 4],
    /// The gradient of each weight with respect to position.
    pub gradients: [Vector3<f64>; 4],
}

impl TetMesh {
    /// The mesh of `grid`'s solid cells; it keeps a copy of the grid.
    pub fn from_grid(grid: &VoxelGrid) -> TetMesh {
        Self::numbered(grid, Stretch::identity(), HashMap::new(), Vec::new())
    }

    /// The mesh of a fitted grid's solid cells, its vertices placed in the world by `stretch`
    /// (as [`VoxelGrid::resample_fitted`] returns them).
    pub fn from_fitted_grid(grid: &VoxelGrid, stretch: Stretch) -> TetMesh {
        Self::numbered(grid, stretch, HashMap::new(), Vec::new())
    }

    /// The mesh of `grid`'s solid cells, its vertices numbered after `vertices` (the corners
    /// `corner_vertex` already names keep their numbers).
    fn numbered(
        grid: &VoxelGrid,
        stretch: Stretch,
        mut corner_vertex: HashMap<[usize; 3], u32>,
        mut vertices: Vec<Vector3<f64>>,
    ) -> TetMesh {
        let mut tets = Vec::new();
        for index in (0..grid.len()).filter(|&i| grid.solid[i]) {
            let c = grid.coords(index);
            let mut vertex = |corner: [usize; 3]| {
                *corner_vertex.entry(corner).or_insert_with(|| {
                    vertices.push(stretch.to_world(&grid.cell_corner(corner)));
                    (vertices.len() - 1) as u32
                })
            };
            for order in KUHN_ORDERS {
                let mut corner = c;
                let mut tet = [vertex(corner); 4];
                for (slot, &axis) in order.iter().enumerate() {
                    corner[axis] += 1;
                    tet[slot + 1] = vertex(corner);
                }
                tets.push(tet);
            }
        }
        for tet in &mut tets {
            let [a, b, c, d] = tet.map(|v| vertices[v as usize]);
            if (b - a).dot(&(c - a).cross(&(d - a))) < 0.0 {
                tet.swap(2, 3);
            }
        }
        let (boundary_vertices, boundary_areas) = boundary(grid, &stretch, &corner_vertex);
        TetMesh {
            vertices,
            tets,
            boundary_vertices,
            boundary_areas,
            grid: grid.clone(),
            stretch,
            corner_vertex,
        }
    }

    /// This mesh grown by one layer of cells (every cell touching a solid one, corners
    /// included), its vertices numbered as here first, then the new ones. A field stored on
    /// this mesh and extended to the layer ([`TetMesh::extend_nodal`]) interpolates at points
    /// just outside the voxelized solid (a surface point in a cell the voxelization left out)
    /// instead of snapping them to a nearest cell, whose choice jumps where two cells are
    /// equally near: the same point, moved by round-off, would get other weights.
    pub fn dilated(&self) -> TetMesh {
        let g = &self.grid;
        let mut grid = g.clone();
        for index in (0..g.len()).filter(|&i| g.solid[i]) {
            let c = g.coords(index);
            for n in corner_neighbourhood(c, g.dims) {
                let i = grid.index(n);
                grid.solid[i] = true;
            }
        }
        Self::numbered(
            &grid,
            self.stretch,
            self.corner_vertex.clone(),
            self.vertices.clone(),
        )
    }

    /// Extends `nodal` (`width` values per vertex, row-major, for this mesh's first `known`
    /// vertices) to every vertex: each new vertex takes the mean of the known ones among its
    /// 26 neighbouring corners, in rounds until all have values. On [`TetMesh::dilated`] this
    /// continues a field one layer out without changing it inside.
    pub fn extend_nodal(&self, known: usize, nodal: &mut Vec<f64>, width: usize) {
        let n = self.vertices.len();
        let mut corners = vec![[0usize; 3]; n];
        for (&corner, &v) in &self.corner_vertex {
            corners[v as usize] = corner;
        }
        let vertex_dims = self.grid.dims.map(|d| d + 1);
        let mut valued: Vec<bool> = (0..n).map(|v| v < known).collect();
        nodal.resize(n * width, 0.0);
        while valued.iter().any(|&v| !v) {
            let mut round = Vec::new();
            for v in (known..n).filter(|&v| !valued[v]) {
                let neighbours: Vec<usize> = corner_neighbourhood(corners[v], vertex_dims)
                    .filter_map(|c| self.corner_vertex.get(&c).map(|&u| u as usize))
                    .filter(|&u| valued[u])
                    .collect();
                if neighbours.is_empty() {
                    continue;
                }
                let mut mean = vec![0.0; width];
                for &u in &neighbours {
                    for (m, x) in mean.iter_mut().zip(&nodal[u * width..(u + 1) * width]) {
                        *m += x / neighbours.len() as f64;
                    }
                }
                round.push((v, mean));
            }
            assert!(!round.is_empty(), "every vertex of a mesh is connected");
            for (v, mean) in round {
                nodal[v * width..(v + 1) * width].copy_from_slice(&mean);
                valued[v] = true;
            }
        }
    }

    /// The grid the mesh was made from, in its own frame (the world's unless the mesh was made
    /// from a fitted grid).
    pub fn grid(&self) -> &VoxelGrid {
        &self.grid
    }

    /// The bounding box of the solid, in the world.
    pub fn bounds(&self) -> (Vector3<f64>, Vector3<f64>) {
        let (lo, hi) = self.grid.solid_bounds();
        (self.stretch.to_world(&lo), self.stretch.to_world(&hi))
    }

    /// The world volume of one cell.
    fn cell_volume(&self) -> f64 {
        self.grid.cell.powi(3) * self.stretch.scale.product()
    }

    /// The solid's volume: solid cells times the cell volume.
    pub fn volume(&self) -> f64 {
        self.grid.solid_count() as f64 * self.cell_volume()
    }

    /// Lumped mass per vertex for unit density: a quarter of each adjacent tetrahedron's volume.
    pub fn lumped_volumes(&self) -> Vec<f64> {
        let mut lumped = vec![0.0; self.vertices.len()];
        let tet_volume = self.cell_volume() / 6.0;
        for tet in &self.tets {
            for &v in tet {
                lumped[v as usize] += tet_volume / 4.0;
            }
        }
        lumped
    }

    /// The tetrahedron holding `p` and the linear interpolation weights there. Points outside the
    /// solid use the nearest solid cell, with the point moved to its closest spot in that cell, so
    /// a field is extended as a constant along the outward direction.
    pub fn locate(&self, world: &Vector3<f64>) -> TetLocation {
        let g = &self.grid;
        let p = &self.stretch.to_grid(world);
        let mut cell = g.cell_of(p);
        if !g.solid[g.index(cell)] {
            cell = self.nearest_solid_cell(p);
        }
        let corner = g.cell_corner(cell);
        let local = ((p - corner) / g.cell).map(|x| x.clamp(0.0, 1.0));
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| local[b].total_cmp(&local[a]));
        let mut vertices = [0u32; 4];
        let mut c = cell;
        vertices[0] = self.corner_vertex[&c];
        for (slot, &axis) in order.iter().enumerate() {
            c[axis] += 1;
            vertices[slot + 1] = self.corner_vertex[&c];
        }
        let u = order.map(|a| local[a]);
        let e = order.map(|a| Vector3::ith(a, 1.0 / (g.cell * self.stretch.scale[a])));
        TetLocation {
            vertices,
            barycentric: [1.0 - u[0], u[0] - u[1], u[1] - u[2], u[2]],
            gradients: [-e[0], e[0] - e[1], e[1] - e[2], e[2]],
        }
    }

    fn nearest_solid_cell(&self, p: &Vector3<f64>) -> [usize; 3] {
        let g = &self.grid;
        let center = g.cell_of(p);
        let mut best = None;
        let mut best_distance = f64::INFINITY;
        let max_ring = g.dims.iter().copied().max().unwrap_or(1);
        for ring in 1..=max_ring {
            let r = ring as isize;
            for dz in -r..=r {
                for dy in -r..=r {
                    for dx in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        let c = [
                            center[0] as isize + dx,
                            center[1] as isize + dy,
                            center[2] as isize + dz,
                        ];
                        if (0..3).any(|a| c[a] < 0 || c[a] as usize >= g.dims[a]) {
                            continue;
                        }
                        let c = c.map(|x| x as usize);
                        if g.solid[g.index(c)] {
                            let lo = g.cell_corner(c);
                            let closest = p.sup(&lo).inf(&(lo + Vector3::repeat(g.cell)));
                            let d = (closest - p).norm();
                            if d < best_distance {
                                best_distance = d;
                                best = Some(c);
                            }
                        }
                    }
                }
            }
            // A cell in a later ring is at least `ring` cells away.
            if best.is_some() && best_distance <= (ring as f64) * g.cell {
                break;
            }
        }
        best.expect("a tet mesh has at least one solid cell")
    }
}

/// The cells (or corners) within one step of `c` along each axis, `c` left out, inside `dims`.
fn corner_neighbourhood(c: [usize; 3], dims: [usize; 3]) -> impl Iterator<Item = [usize; 3]> {
    (0..27).filter(|&s| s != 13).filter_map(move |s| {
        let step = [s % 3, (s / 3) % 3, s / 9];
        let mut n = [0usize; 3];
        for a in 0..3 {
            n[a] = (c[a] + step[a]).checked_sub(1).filter(|&x| x < dims[a])?;
        }
        Some(n)
    })
}

/// Vertices on cube faces between solid and empty cells; each such face gives a quarter of its
/// area to each of its four corners.
fn boundary(
    grid: &VoxelGrid,
    stretch: &Stretch,
    corner_vertex: &HashMap<[usize; 3], u32>,
) -> (Vec<u32>, Vec<f64>) {
    let mut area: HashMap<u32, f64> = HashMap::new();
    for index in (0..grid.len()).filter(|&i| grid.solid[i]) {
        let c = grid.coords(index);
        for axis in 0..3 {
            for side in [0usize, 1] {
                let mut n = c.map(|x| x as isize);
                n[axis] += if side == 1 { 1 } else { -1 };
                let open = n[axis] < 0
                    || n[axis] as usize >= grid.dims[axis]
                    || !grid.solid[grid.index(n.map(|x| x as usize))];
                if !open {
                    continue;
                }
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let face_area = grid.cell * grid.cell * stretch.scale[u] * stretch.scale[v];
                for (du, dv) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    let mut corner = c;
                    corner[axis] += side;
                    corner[u] += du;
                    corner[v] += dv;
                    *area.entry(corner_vertex[&corner]).or_insert(0.0) += face_area / 4.0;
                }
            }
        }
    }
    let mut pairs: Vec<_> = area.into_iter().collect();
    pairs.sort_by_key(|(v, _)| *v);
    pairs.into_iter().unzip()
}
