//! The bulk term of the elastic energy (lambda/2 times the squared volume change) projected
//! onto a pressure that is linear within each of a few regions of the body, as mixed finite
//! elements do.
//!
//! Why: a skinning subspace of K handles has 12K unknowns. Integrated point by point, a nearly
//! incompressible material (Poisson's ratio 0.45: lambda is 9 mu) asks each of a thousand
//! cubature points to keep its own volume, far more constraints than the subspace can meet
//! while it bends, and the body locks: stiffer than the FEM it is measured against, and
//! stiffer the more cubature points it has (issue 74). Projected onto 4 functions a region
//! (1, x, y, z), the volume change meets 4R constraints. A constant a region is too few: a
//! bent rod's volume change varies linearly across it, and with one pressure a region it went
//! unresisted (the rod as soft as a material of Poisson's ratio 0).
//!
//! With y~ = [1, (X - c_r) / s_r] at a point of region r, A_r = sum_p v_p y~ y~^T and
//! b_r = sum_p v_p y~ e_p, the bulk energy is sum_r lambda/2 b_r^T A_r^+ b_r, the L2
//! projection's; a point's pressure is lambda y~^T A_r^+ b_r, its share of the gradient.

use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{DMatrix, Matrix3, Matrix4, Vector3, Vector4};

use crate::geometry::nearest_point;

use super::material::{
    cofactor, cofactor_derivative, BulkIntegration, Material, MaterialModel, Matrix9,
};

/// Lloyd iterations of the regions' k-means: the regions only need to be compact.
const LLOYD_ITERATIONS: usize = 12;

/// Eigenvalues of A_r below this fraction of its largest are dropped from its inverse: a
/// region of a thin plate may hold a single layer of points, on which a pressure varying
/// across the plate is not defined.
const PSEUDO_INVERSE_CUTOFF: f64 = 1e-9;

/// The cubature points' regions and their pressure spaces.
#[derive(Clone, Debug)]
pub(crate) struct BulkRegions {
    /// The region of each cubature point.
    region_of: Vec<usize>,
    /// Each point's y~ in its region's frame.
    local: Vec<Vector4<f64>>,
    /// Each region's A_r^+.
    inverses: Vec<Matrix4<f64>>,
}

impl BulkRegions {
    /// `count` compact regions of the points (volume-weighted k-means from a farthest-point
    /// start, deterministic), none empty.
    pub(crate) fn new(points: &[Vector3<f64>], volumes: &[f64], count: usize) -> Self {
        let count = count.clamp(1, points.len().max(1));
        let mut centres = farthest_points(points, count);
        let mut region_of = vec![0; points.len()];
        for _ in 0..LLOYD_ITERATIONS {
            for (region, p) in region_of.iter_mut().zip(points) {
                *region = nearest(&centres, p);
            }
            let mut sums = vec![(Vector3::zeros(), 0.0); centres.len()];
            for ((&r, p), &v) in region_of.iter().zip(points).zip(volumes) {
                sums[r].0 += p * v;
                sums[r].1 += v;
            }
            for (centre, (sum, volume)) in centres.iter_mut().zip(sums) {
                if volume > 0.0 {
                    *centre = sum / volume;
                }
            }
        }
        Self::from_assignment(region_of, points, volumes)
    }

    /// The regions of the points `kept` of `points`, whose cubature volumes are now `volumes`
    /// (a coarser cubature's, see `Cubature::coarsened`).
    pub(crate) fn gathered(
        &self,
        kept: &[usize],
        points: &[Vector3<f64>],
        volumes: &[f64],
    ) -> Self {
        let region_of = kept.iter().map(|&p| self.region_of[p]).collect();
        Self::from_assignment(region_of, points, volumes)
    }

    /// Regions renumbered to those that hold points, with their frames and A_r^+.
    fn from_assignment(
        mut region_of: Vec<usize>,
        points: &[Vector3<f64>],
        volumes: &[f64],
    ) -> Self {
        let mut renumber = vec![usize::MAX; region_of.iter().max().map_or(0, |r| r + 1)];
        let mut count = 0;
        for r in region_of.iter_mut() {
            if renumber[*r] == usize::MAX {
                renumber[*r] = count;
                count += 1;
            }
            *r = renumber[*r];
        }
        let mut centres = vec![(Vector3::zeros(), 0.0); count];
        for ((&r, p), &v) in region_of.iter().zip(points).zip(volumes) {
            centres[r].0 += p * v;
            centres[r].1 += v;
        }
        let centres: Vec<Vector3<f64>> = centres
            .iter()
            .map(|(sum, v)| sum / v.max(f64::MIN_POSITIVE))
            .collect();
        let mut scales = vec![f64::MIN_POSITIVE; count];
        for (&r, p) in region_of.iter().zip(points) {
            scales[r] = scales[r].max((p - centres[r]).norm());
        }
        let local: Vec<Vector4<f64>> = (region_of.iter().zip(points))
            .map(|(&r, p)| {
                let y = (p - centres[r]) / scales[r];
                Vector4::new(1.0, y.x, y.y, y.z)
            })
            .collect();
        let mut moments = vec![Matrix4::zeros(); count];
        for ((&r, y), &v) in region_of.iter().zip(&local).zip(volumes) {
            moments[r] += y * y.transpose() * v;
        }
        Self {
            region_of,
            local,
            inverses: moments.iter().map(pseudo_inverse).collect(),
        }
    }

    /// The number of regions.
    pub(crate) fn len(&self) -> usize {
        self.inverses.len()
    }

    /// The bulk energy for the points' volume `changes` (see [`volume_change`]) and each
    /// point's pressure, its share of the gradient: the gradient is sum_p v_p p_p de_p/dz.
    pub(crate) fn energy_and_pressures(
        &self,
        changes: &[f64],
        point_volumes: &[f64],
        lambda: f64,
    ) -> (f64, Vec<f64>) {
        let mut moments = vec![Vector4::zeros(); self.len()];
        for (((&r, y), &e), &v) in self
            .region_of
            .iter()
            .zip(&self.local)
            .zip(changes)
            .zip(point_volumes)
        {
            moments[r] += y * (v * e);
        }
        let mut energy = 0.0;
        let mut fits = Vec::with_capacity(self.len());
        for (b, inverse) in moments.iter().zip(&self.inverses) {
            let fit = inverse * b;
            energy += 0.5 * lambda * b.dot(&fit);
            fits.push(fit);
        }
        let pressures = (self.region_of.iter().zip(&self.local))
            .map(|(&r, y)| lambda * y.dot(&fits[r]))
            .collect();
        (energy, pressures)
    }

    /// Adds the bulk term's Gauss-Newton Hessian B^T W B to `hessian` (12K x 12K, the state's
    /// column-major order): B (4R x 12K) has for region r the rows sum_p v_p y~_k de_p/dz,
    /// with each point's volume change's gradient de_p/dz (12K, `point_gradient(p)`), and W is
    /// lambda A_r^+ block by block, taken in one matrix product rather than as a rank-4 update
    /// a region. The term in the second derivatives of e it leaves out is zero at rest (the
    /// exact Hessian adds it point by point, see [`pressure_derivative`]).
    pub(crate) fn add_hessian(
        &self,
        hessian: &mut DMatrix<f64>,
        volumes: &[f64],
        lambda: f64,
        mut point_gradient: impl FnMut(usize, &mut [f64]),
    ) {
        let n = hessian.nrows();
        let rows = 4 * self.len();
        // Column-major: a region's four rows side by side in each column.
        let mut b = vec![0.0; rows * n];
        let mut de = vec![0.0; n];
        for (p, (&r, y)) in self.region_of.iter().zip(&self.local).enumerate() {
            point_gradient(p, &mut de);
            let scaled = y * volumes[p];
            for (column, d) in b.chunks_exact_mut(rows).zip(&de) {
                for (out, s) in column[4 * r..4 * r + 4].iter_mut().zip(scaled.iter()) {
                    *out += s * d;
                }
            }
        }
        let mut w = vec![0.0; rows * n];
        for (w_column, b_column) in w.chunks_exact_mut(rows).zip(b.chunks_exact(rows)) {
            for (r, inverse) in self.inverses.iter().enumerate() {
                let at = 4 * r..4 * r + 4;
                let fit = inverse * Vector4::from_column_slice(&b_column[at.clone()]) * lambda;
                w_column[at].copy_from_slice(fit.as_slice());
            }
        }
        let b = MatRef::from_column_major_slice(&b, rows, n);
        let w = MatRef::from_column_major_slice(&w, rows, n);
        let out = MatMut::from_column_major_slice_mut(hessian.as_mut_slice(), n, n);
        matmul(out, Accum::Add, b.transpose(), w, 1.0, Par::Seq);
    }
}

/// A^+ of a symmetric positive semi-definite A, eigenvalues under [`PSEUDO_INVERSE_CUTOFF`]
/// of the largest dropped.
fn pseudo_inverse(a: &Matrix4<f64>) -> Matrix4<f64> {
    let eigen = a.symmetric_eigen();
    let largest = eigen.eigenvalues.amax();
    let mut inverse = Matrix4::zeros();
    for (k, &value) in eigen.eigenvalues.iter().enumerate() {
        if value > PSEUDO_INVERSE_CUTOFF * largest {
            let v = eigen.eigenvectors.column(k);
            inverse += v * v.transpose() / value;
        }
    }
    inverse
}

/// `material` split in two: the part integrated point by point and the bulk modulus of the
/// term this module projects (0 with [`BulkIntegration::Points`]), kappa/2 (J - 1)^2
/// (lambda/2 tr(eps)^2 for the small-strain model). The point part keeps kappa = mu for the
/// Neo-Hookean forms, where it makes the rest Hessian definite; the reference Neo-Hookean
/// gives up lambda - mu.
pub(crate) fn split(material: &Material) -> (Material, f64) {
    if material.bulk == BulkIntegration::Points {
        return (*material, 0.0);
    }
    let kept = match material.model {
        MaterialModel::NeoHookean => material.mu.min(material.lambda),
        _ => 0.0,
    };
    let point = Material {
        lambda: kept,
        ..*material
    };
    (point, material.lambda - kept)
}

/// A point's volume change e and de/dF: J - 1 and cof F, or for the small-strain model
/// tr F - 3 and I (its bulk term is lambda/2 tr(eps)^2).
pub(crate) fn volume_change(model: MaterialModel, f: &Matrix3<f64>) -> (f64, Matrix3<f64>) {
    match model {
        MaterialModel::Linear => (f.trace() - 3.0, Matrix3::identity()),
        _ => {
            let cof = cofactor(f);
            (f.column(0).dot(&cof.column(0)) - 1.0, cof)
        }
    }
}

/// The second derivative of a point's volume change times its `pressure`, d2e/dF2 p: the part
/// of the exact Hessian the Gauss-Newton term leaves out (zero for the small-strain model).
pub(crate) fn pressure_derivative(
    model: MaterialModel,
    f: &Matrix3<f64>,
    pressure: f64,
) -> Matrix9 {
    match model {
        MaterialModel::Linear => Matrix9::zeros(),
        _ => cofactor_derivative(f) * pressure,
    }
}

/// `count` of `points`, each the farthest from those before, the first the nearest to their
/// mean.
fn farthest_points(points: &[Vector3<f64>], count: usize) -> Vec<Vector3<f64>> {
    if points.is_empty() {
        return Vec::new();
    }
    let mean = points.iter().sum::<Vector3<f64>>() / points.len() as f64;
    let start = points[nearest(points, &mean)];
    let mut distance: Vec<f64> = points.iter().map(|p| (p - start).norm_squared()).collect();
    let mut chosen = vec![start];
    while chosen.len() < count {
        let far = (0..points.len())
            .max_by(|&a, &b| distance[a].total_cmp(&distance[b]))
            .unwrap_or(0);
        let next = points[far];
        for (d, p) in distance.iter_mut().zip(points) {
            *d = d.min((p - next).norm_squared());
        }
        chosen.push(next);
    }
    chosen
}

/// The index of the point of `among` nearest to `p` (0 when there is none).
fn nearest(among: &[Vector3<f64>], p: &Vector3<f64>) -> usize {
    nearest_point(among, p).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nalgebra::{DMatrix, Vector3};

    use super::BulkRegions;
    use crate::geometry::{box_mesh, Cubature, TetMesh, VoxelGrid};
    use crate::physics::{BulkIntegration, Material, MaterialModel, Subspace};
    use crate::skinning::{EigenmodeField, EigenmodeOptions};

    /// A 0.4 x 0.2 x 0.1 m box's subspace: 4 eigenmode handles and the constant, 200 points.
    fn small_box() -> Subspace {
        let shape = box_mesh(Vector3::new(0.4, 0.2, 0.1));
        let grid = VoxelGrid::from_shape(&shape, 64, None).resample(8);
        let mesh = TetMesh::from_grid(&grid);
        let options = EigenmodeOptions {
            modes: 4,
            ..Default::default()
        };
        let field = EigenmodeField::compute(mesh.clone(), shape.normalization(), &options).unwrap();
        let cubature = Cubature::stratified(&grid, 200, mesh.volume());
        Subspace::build(Arc::new(field), shape.normalization(), &cubature, 1000.0)
    }

    /// A deformed state: every handle's map moved by a few per cent.
    fn bent(subspace: &Subspace) -> DMatrix<f64> {
        let wave = |j: usize| (0.61 * j as f64 + 0.3).sin();
        DMatrix::from_fn(3, 4 * subspace.handles(), |d, a| 0.04 * wave(7 * a + d))
    }

    fn materials() -> [Material; 3] {
        [
            MaterialModel::StableNeoHookean,
            MaterialModel::NeoHookean,
            MaterialModel::Linear,
        ]
        .map(|model| Material {
            bulk: BulkIntegration::Regions,
            ..Material::from_young_poisson(model, 1e5, 0.45)
        })
    }

    /// The regions' k-means runs only for a body whose bulk term is projected: point by point,
    /// its rest Hessian, forces and exact Hessian never form them.
    #[test]
    fn regions_are_formed_only_for_a_projected_bulk_term() {
        for bulk in [BulkIntegration::Points, BulkIntegration::Regions] {
            let subspace = small_box();
            let material = Material {
                bulk,
                ..Material::from_young_poisson(MaterialModel::StableNeoHookean, 1e5, 0.45)
            };
            let z = bent(&subspace);
            subspace.rest_elastic_hessian(&material);
            subspace.elastic_forces(&z, &material);
            subspace.elastic_hessian_at(&z, &material);
            let projected = bulk == BulkIntegration::Regions;
            assert_eq!(subspace.formed_bulk_regions(), projected, "{bulk:?}");
        }
    }

    #[test]
    fn the_elastic_gradient_is_the_energys_with_the_bulk_averaged_over_regions() {
        let subspace = small_box();
        let z = bent(&subspace);
        let direction = DMatrix::from_fn(3, z.ncols(), |d, a| ((3 * a + d) as f64).cos());
        for material in materials() {
            let (_, gradient) = subspace.elastic_forces(&z, &material);
            let h = 1e-6;
            let energy = |s: f64| subspace.elastic_forces(&(&z + &direction * s), &material).0;
            let numeric = (energy(h) - energy(-h)) / (2.0 * h);
            let analytic = gradient.dot(&direction);
            let err = (numeric - analytic).abs() / analytic.abs();
            assert!(err < 1e-6, "{:?}: gradient off by {err:e}", material.model);
        }
    }

    #[test]
    fn at_rest_the_held_hessian_is_the_gradients_derivative() {
        let subspace = small_box();
        let zero = DMatrix::zeros(3, 4 * subspace.handles());
        for material in materials() {
            let hessian = subspace.rest_elastic_hessian(&material);
            for a in [0, 5, 13, 4 * subspace.handles() - 1] {
                let mut step = zero.clone();
                step[(a % 3, a)] = 1e-6;
                let (_, plus) = subspace.elastic_forces(&step, &material);
                let (_, minus) = subspace.elastic_forces(&(-&step), &material);
                let numeric = (plus - minus) / 2e-6;
                let analytic = hessian.column(3 * a + a % 3);
                let err = (numeric.as_slice().iter().zip(analytic.iter()))
                    .map(|(n, h)| (n - h).abs())
                    .fold(0.0, f64::max)
                    / analytic.amax();
                assert!(
                    err < 1e-6,
                    "{:?} column {a}: off by {err:e}",
                    material.model
                );
            }
        }
    }

    #[test]
    fn one_region_per_point_is_the_bulk_term_point_by_point() {
        let subspace = small_box();
        let z = bent(&subspace);
        let volumes = subspace.volumes().to_vec();
        let points: Vec<Vector3<f64>> = (0..volumes.len())
            .map(|p| Vector3::new(p as f64, 0.0, 0.0))
            .collect();
        let alone = BulkRegions::new(&points, &volumes, volumes.len());
        assert_eq!(alone.len(), volumes.len());
        for material in materials() {
            let changes: Vec<f64> = subspace
                .deformation_gradients(&z)
                .iter()
                .map(|f| super::volume_change(material.model, f).0)
                .collect();
            let (bulk, _) =
                alone.energy_and_pressures(&changes, &volumes, super::split(&material).1);
            let pointwise: f64 = (subspace.deformation_gradients(&z).iter().zip(&volumes))
                .map(|(f, v)| v * material.energy_density(f))
                .sum();
            let shear: f64 = (subspace.deformation_gradients(&z).iter().zip(&volumes))
                .map(|(f, v)| v * super::split(&material).0.energy_density(f))
                .sum();
            let err = (shear + bulk - pointwise).abs() / pointwise.abs();
            assert!(err < 1e-12, "{:?}: energy off by {err:e}", material.model);
        }
    }

    #[test]
    fn regions_are_compact_and_a_change_linear_in_each_is_kept_whole() {
        // A 20 x 10 x 5 lattice over a 0.4 x 0.2 x 0.1 m box.
        let points: Vec<Vector3<f64>> = (0..1000)
            .map(|j| Vector3::new((j % 20) as f64, (j / 20 % 10) as f64, (j / 200) as f64) * 0.02)
            .collect();
        let volumes = vec![8e-6; points.len()];
        let regions = BulkRegions::new(&points, &volumes, 5);
        assert_eq!(regions.len(), 5);
        // Along the box's long side: each region spans well under its length.
        for r in 0..regions.len() {
            let xs = (points.iter().zip(&regions.region_of))
                .filter(|(_, &q)| q == r)
                .map(|(p, _)| p.x);
            let (lo, hi) = xs.fold((f64::MAX, f64::MIN), |(a, b), x| (a.min(x), b.max(x)));
            assert!(hi - lo < 0.2, "region {r} spans {:.3} m of 0.4", hi - lo);
        }
        // A bend's volume change, linear across the box, is resisted in full; one that
        // varies within a region is resisted only in its linear part.
        let lambda = 9.0;
        for (name, change, whole) in [
            (
                "linear",
                (|p: &Vector3<f64>| 0.01 * (p.z - 0.05) + 0.002 * p.x) as fn(&_) -> f64,
                true,
            ),
            (
                "rippled",
                |p: &Vector3<f64>| 0.01 * (60.0 * p.x).sin() * (40.0 * p.y).sin(),
                false,
            ),
        ] {
            let changes: Vec<f64> = points.iter().map(change).collect();
            let (energy, pressures) = regions.energy_and_pressures(&changes, &volumes, lambda);
            let pointwise: f64 = changes.iter().map(|e| 0.5 * lambda * 8e-6 * e * e).sum();
            if whole {
                assert!(
                    (energy - pointwise).abs() < 1e-9 * pointwise,
                    "{name}: {energy:e}"
                );
                for (q, e) in pressures.iter().zip(&changes) {
                    assert!((q - lambda * e).abs() < 1e-9 * lambda * 0.01, "{name}");
                }
            } else {
                assert!(
                    energy < 0.5 * pointwise,
                    "{name}: {energy:e} of {pointwise:e}"
                );
            }
        }
        // A coarser cubature's points keep their regions.
        let kept: Vec<usize> = (0..1000).step_by(10).collect();
        let coarse_points: Vec<_> = kept.iter().map(|&p| points[p]).collect();
        let coarse = regions.gathered(&kept, &coarse_points, &vec![8e-5; kept.len()]);
        for (a, &p) in kept.iter().enumerate() {
            for (b, &q) in kept.iter().enumerate() {
                let together = regions.region_of[p] == regions.region_of[q];
                assert_eq!(coarse.region_of[a] == coarse.region_of[b], together);
            }
        }
    }
}
