//! The elements a [`FemSim`](super::FemSim) integrates over: which nodes each tetrahedron
//! interpolates from, the gradients of its shape functions at its quadrature points, and the
//! volume each node's lumped mass stands for.

use std::collections::HashMap;

use nalgebra::{SMatrix, Vector3};

use crate::geometry::TetMesh;
use crate::skinning::linear_gradients;

/// The tetrahedra of a mesh as elements of `N` nodes each (the mesh's vertices first, then any
/// nodes an element of higher order adds).
pub(crate) struct Elements<const N: usize> {
    /// Each element's nodes.
    pub nodes: Vec<[u32; N]>,
    /// Per quadrature point (element by element, `points_per_element` each): the gradient of
    /// each of the element's shape functions.
    pub gradients: Vec<[Vector3<f64>; N]>,
    /// Per quadrature point: the volume it stands for, m³.
    pub weights: Vec<f64>,
    pub points_per_element: usize,
    /// Per node: the volume its lumped mass stands for, m³.
    pub lumped_volumes: Vec<f64>,
    /// The nodes past the mesh's vertices, in order: the two vertices each lies halfway between.
    pub edges: Vec<[u32; 2]>,
}

impl Elements<4> {
    /// Linear tetrahedra: one point each, the deformation constant over the element.
    pub fn linear(mesh: &TetMesh) -> Self {
        let (gradients, weights) = mesh
            .tets
            .iter()
            .map(|tet| linear_gradients(&tet.map(|v| mesh.vertices[v as usize])))
            .unzip();
        Elements {
            nodes: mesh.tets.clone(),
            gradients,
            weights,
            points_per_element: 1,
            lumped_volumes: mesh.lumped_volumes(),
            edges: Vec::new(),
        }
    }
}

/// A quadratic tetrahedron's edges, as pairs of its corners: node 4 + k lies on edge k.
const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]];

/// The 4-point rule for tetrahedra, exact for quadratics (the energy of a linear strain): the
/// barycentric coordinates of the first point, the others by symmetry, each a quarter of the
/// volume.
const RULE_NEAR: f64 = 0.585_410_196_624_968_5;
const RULE_FAR: f64 = 0.138_196_601_125_010_5;

/// The lumped (HRZ) mass of a quadratic tetrahedron's corner and of its edge node, in parts of
/// its volume: the consistent mass matrix's diagonal (1/70 and 8/105), scaled to add up to the
/// element's mass. Row sums would give the corners negative masses.
const CORNER_MASS: f64 = 1.0 / 36.0;
const EDGE_MASS: f64 = 4.0 / 27.0;

impl Elements<10> {
    /// Quadratic tetrahedra (ten nodes: the four corners and a node at each edge's middle),
    /// four points each. A linear strain within each element lets a thin part bend with one
    /// or two elements through its thickness, where a linear tetrahedron's constant strain
    /// locks.
    pub fn quadratic(mesh: &TetMesh) -> Self {
        let corners = mesh.vertices.len();
        let mut lumped_volumes = vec![0.0; corners];
        let mut edge_node = HashMap::new();
        let mut edges = Vec::new();
        let mut nodes = Vec::with_capacity(mesh.tets.len());
        let mut gradients = Vec::with_capacity(4 * mesh.tets.len());
        let mut weights = Vec::with_capacity(4 * mesh.tets.len());
        for tet in &mesh.tets {
            let mut element = [0u32; 10];
            element[..4].copy_from_slice(tet);
            for (k, [i, j]) in EDGES.iter().enumerate() {
                let key = [tet[*i].min(tet[*j]), tet[*i].max(tet[*j])];
                element[4 + k] = *edge_node.entry(key).or_insert_with(|| {
                    edges.push(key);
                    lumped_volumes.push(0.0);
                    (corners + edges.len() - 1) as u32
                });
            }
            let (linear, volume) = linear_gradients(&tet.map(|v| mesh.vertices[v as usize]));
            for q in 0..4 {
                let mut lambda = [RULE_FAR; 4];
                lambda[q] = RULE_NEAR;
                gradients.push(quadratic_gradients(&linear, &lambda));
                weights.push(volume / 4.0);
            }
            for (slot, &node) in element.iter().enumerate() {
                let share = if slot < 4 { CORNER_MASS } else { EDGE_MASS };
                lumped_volumes[node as usize] += share * volume;
            }
            nodes.push(element);
        }
        Elements {
            nodes,
            gradients,
            weights,
            points_per_element: 4,
            lumped_volumes,
            edges,
        }
    }
}

/// The gradients of a quadratic tetrahedron's ten shape functions at barycentric coordinates
/// `lambda`, from the (constant) gradients `linear` of the coordinates: a corner's
/// λ(2λ − 1) and an edge's 4 λᵢ λⱼ.
fn quadratic_gradients(linear: &[Vector3<f64>; 4], lambda: &[f64; 4]) -> [Vector3<f64>; 10] {
    let mut g = [Vector3::zeros(); 10];
    for a in 0..4 {
        g[a] = linear[a] * (4.0 * lambda[a] - 1.0);
    }
    for (k, [i, j]) in EDGES.iter().enumerate() {
        g[4 + k] = (linear[*i] * lambda[*j] + linear[*j] * lambda[*i]) * 4.0;
    }
    g
}

impl<const N: usize> Elements<N> {
    /// The quadrature points of element `e`.
    pub fn points(&self, e: usize) -> std::ops::Range<usize> {
        e * self.points_per_element..(e + 1) * self.points_per_element
    }

    /// Every node's rest position, x y z per node.
    pub fn rest_positions(&self, mesh: &TetMesh) -> Vec<f64> {
        let mut x: Vec<f64> = mesh.vertices.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
        x.resize(3 * (mesh.vertices.len() + self.edges.len()), 0.0);
        self.interpolate_edges(&mut x);
        x
    }

    /// Places each node past the mesh's vertices halfway between its edge's ends in `x`.
    pub fn interpolate_edges(&self, x: &mut [f64]) {
        let first = x.len() / 3 - self.edges.len();
        for (i, [a, b]) in self.edges.iter().enumerate() {
            let (a, b, m) = (3 * *a as usize, 3 * *b as usize, 3 * (first + i));
            for d in 0..3 {
                x[m + d] = 0.5 * (x[a + d] + x[b + d]);
            }
        }
    }

    /// Fixes each node past the mesh's vertices whose edge's ends are both fixed, halfway
    /// between their targets: a pinned face stays pinned along its edges too.
    pub fn fix_edges(&self, fixed: &mut [bool], targets: &mut [f64]) {
        self.interpolate_edges(targets);
        let first = fixed.len() / 3 - self.edges.len();
        for (i, [a, b]) in self.edges.iter().enumerate() {
            let both = fixed[3 * *a as usize] && fixed[3 * *b as usize];
            fixed[3 * (first + i)..3 * (first + i) + 3].fill(both);
        }
    }
}

/// dF/dx at a quadrature point with shape-function gradients `gradients`: rows d + 3e of
/// vec(F), columns 3a + d (`D` = 3 `N`).
pub(crate) fn jacobian<const N: usize, const D: usize>(
    gradients: &[Vector3<f64>; N],
) -> SMatrix<f64, 9, D> {
    let mut j = SMatrix::<f64, 9, D>::zeros();
    for (a, g) in gradients.iter().enumerate() {
        for e in 0..3 {
            for d in 0..3 {
                j[(d + 3 * e, 3 * a + d)] = g[e];
            }
        }
    }
    j
}
