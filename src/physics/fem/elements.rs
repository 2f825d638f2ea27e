//! The elements a [`FemSim`](super::FemSim) integrates over: which nodes each tetrahedron
//! interpolates from, the gradients of its shape functions at its quadrature points, and the
//! volume each node's lumped mass stands for.

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
