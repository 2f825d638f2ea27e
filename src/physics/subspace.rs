//! The reduced space of one object: a skinning field sampled at cubature points, and what the
//! dynamics needs from it, computed once per shape.
//!
//! With handles Z_i = [A_i | t_i] (3 x 4) and X~ = [X; 1], the displacement is
//! u(X) = sum_i w_i(X) Z_i X~ = Z phi(X), where Z = [Z_1 .. Z_K] is 3 x 4K and
//! phi = w (x) X~ (4K). The reduced state z is Z flattened column-major (z[3a + d] = Z[d, a]),
//! so each handle owns 12 consecutive numbers. The deformation gradient is F = I + Z G(X) with
//! G = d phi / dX (4K x 3): row 4i + c of G is w_i e_c^T + X~_c grad w_i^T.

use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use rayon::prelude::*;

use super::assembly::HessianAssembly;
use super::bulk::{pressure_derivative, split, volume_change, BulkRegions};
use super::material::{polar_rotation, Material, MaterialModel, Matrix9};
use super::shares::shared_out;
use super::strain::FieldSamples;

use crate::geometry::{Cubature, Normalization};
use crate::skinning::SkinningField;

/// Cubature points times 4K from which a force evaluation is split in two (`shared_out`, the
/// second half on the helper thread). Split over rayon's pool, the wake-ups made it slower at
/// 1024 points and K = 17 (98 us an evaluation against 62 us on one thread, printed); handed
/// to the helper, the rod's poke went from a median step of 0.849 and 0.873 ms to 0.590 and
/// 0.542 ms (see `helper`), at 512 points from 0.511 and 0.522 ms to 0.422 and 0.423 ms.
/// Below this, about 25 us of work (480 points at K = 17), waking a sleeping helper could cost
/// as much as its half saves.
const FORCES_PARALLEL_WORK: usize = 32_768;

/// About how many cubature points the quasi-Newton preconditioner's elastic Hessian is
/// reassembled on (see [`CubatureTerms::coarser`]). With 256 of 1024, a scanned creature's
/// hanging took 4.212 ms at its slowest step against 2.955 ms on every point, where 512 took
/// 2.778 ms (`bench real`, printed): its thin limbs keep too few points.
const PRECONDITIONER_POINTS: usize = 512;

/// Regions the bulk term of a subspace of `handles` handles (the constant one included) is
/// projected over with `BulkIntegration::Regions`, four pressures each (see `physics::bulk`):
/// two a handle. On `bench sim`'s hanging shapes at 16 handles and 1024 points (printed),
/// point by point the creature (quick mesh) had a static error of 9.835 % and the rod 0.792 %;
/// two regions a handle 8.627 and 0.303 %; one a handle 6.550 and 0.409 %, but a 0.3 m block
/// of 9 handles and 128 points (`tests/scene.rs`) then let a rigid plate 3.4 cm into its top.
fn bulk_regions(handles: usize) -> usize {
    2 * handles
}

/// The field sampled at a cubature set: its deformation gradients and forces, and its elastic
/// Hessian's assembly. A subspace holds one for its cubature and, for the quasi-Newton
/// preconditioner, one for a coarser cubature (see [`CubatureTerms::coarser`]).
struct CubatureTerms {
    samples: FieldSamples,
    assembly: HessianAssembly,
    /// For a coarser cubature, the points of the whole one it keeps (see
    /// [`CubatureTerms::coarser`]); empty for the whole one.
    kept: Vec<usize>,
    /// The regions the bulk term is projected over (see `physics::bulk`), formed on first
    /// use: a body whose bulk term is integrated point by point never needs them.
    bulk: OnceLock<BulkRegions>,
}

impl CubatureTerms {
    /// The terms at `cubature`, whose points have the K `weights` and `gradients` each and G
    /// laid out as `g_all_of` gives it.
    fn new(
        k: usize,
        weights: &[f64],
        gradients: &[Vector3<f64>],
        cubature: &Cubature,
        g_all: Vec<f64>,
        kept: Vec<usize>,
    ) -> Self {
        let (points, volumes) = (&cubature.points, &cubature.volumes);
        Self {
            samples: FieldSamples::new(k, weights, gradients, points, volumes),
            assembly: HessianAssembly::new(4 * k, volumes.clone(), g_all, points),
            kept,
            bulk: OnceLock::new(),
        }
    }

    /// The Gauss-Newton Hessian of a projected bulk term of modulus `bulk` (see
    /// `BulkRegions::add_hessian`) at these points' deformation `gradients`, added to
    /// `hessian`.
    fn add_bulk_hessian(
        &self,
        regions: &BulkRegions,
        hessian: &mut DMatrix<f64>,
        gradients: &[Matrix3<f64>],
        model: MaterialModel,
        bulk: f64,
    ) {
        let samples = &self.samples;
        let gradient_at = |p: usize, out: &mut [f64]| {
            samples.volume_change_gradient(p, &gradients[p], model, out);
        };
        regions.add_hessian(hessian, samples.volumes(), bulk, gradient_at);
    }

    /// Each point's pressure under a projected bulk term of modulus `bulk` (see
    /// `BulkRegions::energy_and_pressures`) at these points' deformation `gradients`.
    fn pressures(
        &self,
        regions: &BulkRegions,
        gradients: &[Matrix3<f64>],
        model: MaterialModel,
        bulk: f64,
    ) -> Vec<f64> {
        let changes: Vec<f64> = (gradients.iter())
            .map(|f| volume_change(model, f).0)
            .collect();
        let volumes = self.samples.volumes();
        regions.energy_and_pressures(&changes, volumes, bulk).1
    }

    /// The terms at a coarser cubature, on which the quasi-Newton solver reassembles its held
    /// elastic Hessian when a step stops making progress and nothing touches (see
    /// `reduced::refresh_use`). The assembly costs in proportion to the points, about 1 ms at
    /// 1024 points and 17 handles, most of a refreshing step; the held matrix only
    /// preconditions, and L-BFGS corrects what it misses. None where the cubature has fewer
    /// than twice [`PRECONDITIONER_POINTS`].
    fn coarser(
        k: usize,
        weights: &[f64],
        gradients: &[Vector3<f64>],
        cubature: &Cubature,
    ) -> Option<Self> {
        let stride = cubature.len() / PRECONDITIONER_POINTS;
        if stride < 2 {
            return None;
        }
        let (kept, coarse) = cubature.coarsened(stride);
        let weights = gather_points(&kept, k, weights);
        let gradients = gather_points(&kept, k, gradients);
        let g_all = g_all_of(k, &weights, &gradients, &coarse.points);
        Some(Self::new(k, &weights, &gradients, &coarse, g_all, kept))
    }
}

/// The values of points `kept` from `values` laid out K per point.
fn gather_points<T: Copy>(kept: &[usize], k: usize, values: &[T]) -> Vec<T> {
    kept.iter()
        .flat_map(|&p| values[p * k..(p + 1) * k].iter().copied())
        .collect()
}

/// A skinning subspace sampled at a cubature set (world units).
pub struct Subspace {
    field: Arc<dyn SkinningField>,
    handles: usize,
    normalization: Normalization,
    /// The field at the cubature points: deformation gradients, elastic forces and Hessian.
    all: CubatureTerms,
    /// A coarser cubature for the quasi-Newton preconditioner (see
    /// [`CubatureTerms::coarser`]); none where the cubature is small already.
    coarse: Option<CubatureTerms>,
    /// sum_p rho v_p phi_p phi_p^T (4K x 4K); the reduced mass is this (x) I_3.
    mass_phi: DMatrix<f64>,
    /// sum_p rho v_p phi_p (4K); gravity's reduced force is this (x) g.
    mass_moment: DVector<f64>,
    /// The volume-weighted mean of G (4K x 3): the body's mean deformation gradient is
    /// I + Z times this.
    mean_gradient: DMatrix<f64>,
    total_mass: f64,
    density: f64,
    /// The elastic Hessian at rest for a material, kept once assembled (see
    /// [`Subspace::rest_elastic_hessian`]).
    rest_hessian: Mutex<Option<(Material, Arc<DMatrix<f64>>)>>,
}

impl Subspace {
    /// Samples `field` at the cubature points (world units, mapped through `normalization`).
    pub fn build(
        field: Arc<dyn SkinningField>,
        normalization: Normalization,
        cubature: &Cubature,
        density: f64,
    ) -> Self {
        let k = field.handle_count();
        let np = cubature.len();
        let (weights, gradients) = sample(field.as_ref(), &normalization, &cubature.points, true);
        let gradients = gradients.expect("asked for gradients");
        let g_all = g_all_of(k, &weights, &gradients, &cubature.points);
        let mut mass_phi = DMatrix::zeros(4 * k, 4 * k);
        let mut mass_moment = DVector::zeros(4 * k);
        for p in 0..np {
            let phi = phi_of(&weights[p * k..(p + 1) * k], &cubature.points[p]);
            let m = density * cubature.volumes[p];
            mass_phi.ger(m, &phi, &phi, 1.0);
            mass_moment.axpy(m, &phi, 1.0);
        }
        let mean_gradient = mean_gradient(&g_all, &cubature.volumes, 4 * k);
        Self {
            mean_gradient,
            coarse: CubatureTerms::coarser(k, &weights, &gradients, cubature),
            all: CubatureTerms::new(k, &weights, &gradients, cubature, g_all, Vec::new()),
            field,
            handles: k,
            normalization,
            mass_phi,
            mass_moment,
            total_mass: density * cubature.total_volume(),
            density,
            rest_hessian: Mutex::new(None),
        }
    }

    /// The elastic Hessian at rest for `material`: assembled over every cubature point on first
    /// use and kept, so that a basis prepared off the stepping thread
    /// (`pipeline::BasisPlan::prepare`) brings it along and a switch to it does not assemble it
    /// between two ticks.
    pub fn rest_elastic_hessian(&self, material: &Material) -> Arc<DMatrix<f64>> {
        let mut kept = self.rest_hessian.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, hessian)) = kept.as_ref().filter(|(m, _)| m == material) {
            return hessian.clone();
        }
        let h = split(material)
            .0
            .stress_derivative(&Matrix3::identity(), true);
        let mut hessian = self.elastic_hessian(&vec![h; self.cubature_len()]);
        let rest = vec![Matrix3::identity(); self.cubature_len()];
        self.add_bulk_hessian(&mut hessian, &rest, material, false);
        let hessian = Arc::new(hessian);
        *kept = Some((*material, hessian.clone()));
        hessian
    }

    /// The skinning field sampled.
    pub fn field(&self) -> &dyn SkinningField {
        self.field.as_ref()
    }

    /// phi = w (x) [X; 1] at world points.
    pub fn phis(&self, points: &[Vector3<f64>]) -> Vec<DVector<f64>> {
        phis(self.field.as_ref(), &self.normalization, points)
    }

    /// The state that moves the object rigidly, x = R X + t: handle 0 (the constant one)
    /// carries [R - I | t], every other handle is still. Any matrix in place of R gives that
    /// affine map of the object.
    pub fn rigid_state(&self, rotation: &Matrix3<f64>, translation: &Vector3<f64>) -> DMatrix<f64> {
        let mut z = DMatrix::zeros(3, 4 * self.handles);
        let a = rotation - Matrix3::identity();
        for c in 0..3 {
            for d in 0..3 {
                z[(d, c)] = a[(d, c)];
            }
            z[(c, 3)] = translation[c];
        }
        z
    }

    /// Handles, the constant one included.
    pub fn handles(&self) -> usize {
        self.handles
    }
    /// Reduced degrees of freedom, 12 per handle.
    pub fn dofs(&self) -> usize {
        12 * self.handles
    }
    /// The number of cubature points.
    pub fn cubature_len(&self) -> usize {
        self.all.samples.len()
    }
    /// The cubature volumes, m^3.
    pub fn volumes(&self) -> &[f64] {
        self.all.samples.volumes()
    }
    /// The body's mass, kg: density times the cubature's total volume.
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }
    /// Density, kg/m^3.
    pub fn density(&self) -> f64 {
        self.density
    }
    /// The map from world units to the field's normalized frame.
    pub fn normalization(&self) -> &Normalization {
        &self.normalization
    }
    /// sum_p rho v_p phi_p phi_p^T (4K x 4K): the reduced mass is this (x) I_3.
    pub fn mass_phi(&self) -> &DMatrix<f64> {
        &self.mass_phi
    }
    /// sum_p rho v_p phi_p (4K): gravity's reduced force is this (x) g.
    pub fn mass_moment(&self) -> &DVector<f64> {
        &self.mass_moment
    }

    /// G (4K x 3) with F = I + Z G the volume-mean deformation gradient.
    pub fn mean_gradient(&self) -> &DMatrix<f64> {
        &self.mean_gradient
    }

    /// The rotation of the body as a whole at `z`: the rotation of the polar decomposition of
    /// its volume-weighted mean deformation gradient (the identity when its SVD fails).
    pub fn mean_rotation(&self, z: &DMatrix<f64>) -> Matrix3<f64> {
        let f = Matrix3::identity() + z * &self.mean_gradient;
        polar_rotation(&f).unwrap_or_else(Matrix3::identity)
    }

    /// Deformation gradients at every cubature point for the handle matrix `z` (3 x 4K), as
    /// 3 x 3 matrices.
    pub fn deformation_gradients(&self, z: &DMatrix<f64>) -> Vec<Matrix3<f64>> {
        self.all.samples.deformation_gradients(z)
    }

    /// The elastic Hessian over the cubature for dP/dF `hessians` at its points (see
    /// `HessianAssembly::elastic_hessian`).
    pub fn elastic_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        self.all.assembly.elastic_hessian(hessians)
    }

    /// `elastic_hessian` with the digits a preconditioner needs (see
    /// `HessianAssembly::preconditioning_hessian`).
    pub(crate) fn preconditioning_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        self.all.assembly.preconditioning_hessian(hessians)
    }

    /// The terms of the coarser cubature (see [`CubatureTerms::coarser`]), or of every point
    /// where there is none.
    fn coarse_or_all(&self) -> &CubatureTerms {
        self.coarse.as_ref().unwrap_or(&self.all)
    }

    /// Deformation gradients at the points of the coarser cubature (all points where there is
    /// none), in their order.
    pub(crate) fn coarse_gradients(&self, z: &DMatrix<f64>) -> Vec<Matrix3<f64>> {
        self.coarse_or_all().samples.deformation_gradients(z)
    }

    /// `preconditioning_hessian` on the coarser cubature, for dP/dF `hessians` at its points.
    pub(crate) fn coarse_preconditioning_hessian(&self, hessians: &[Matrix9]) -> DMatrix<f64> {
        self.coarse_or_all()
            .assembly
            .preconditioning_hessian(hessians)
    }

    /// Each point's pressure at the deformation `gradients` of every point (`coarse`: of the
    /// coarser cubature's), which the exact Hessian's point-by-point part needs (see
    /// `bulk::pressure_derivative`); None where the material has no bulk term.
    fn bulk_pressures(
        &self,
        gradients: &[Matrix3<f64>],
        material: &Material,
        coarse: bool,
    ) -> Option<Vec<f64>> {
        let (terms, regions, bulk) = self.projected_bulk(material, coarse)?;
        Some(terms.pressures(regions, gradients, material.model, bulk))
    }

    /// dP/dF of point p at its deformation gradient, for the point-by-point part of
    /// `material` (see `bulk::split`), `project`ed or not; unprojected, with the point's
    /// pressure times its volume change's curvature (see `bulk::pressure_derivative`), the
    /// exact Hessian's point-by-point part. `gradients` are every point's (`coarse`: of the
    /// coarser cubature's), whose pressures it needs.
    pub(crate) fn stress_derivatives(
        &self,
        gradients: &[Matrix3<f64>],
        material: &Material,
        project: bool,
        coarse: bool,
    ) -> impl Fn(usize, &Matrix3<f64>) -> Matrix9 + Sync {
        let (point, model) = (split(material).0, material.model);
        let pressures = (!project)
            .then(|| self.bulk_pressures(gradients, material, coarse))
            .flatten();
        move |p, f| {
            let h = point.stress_derivative(f, project);
            match &pressures {
                Some(q) => h + pressure_derivative(model, f, q[p]),
                None => h,
            }
        }
    }

    /// The exact elastic Hessian (12K x 12K) at `z`: point by point for the material's point
    /// part with each point's pressure, and the bulk term's (see `physics::bulk`).
    pub fn elastic_hessian_at(&self, z: &DMatrix<f64>, material: &Material) -> DMatrix<f64> {
        let gradients = self.deformation_gradients(z);
        let hessian_at = self.stress_derivatives(&gradients, material, false, false);
        let hessians: Vec<Matrix9> = (gradients.iter().enumerate())
            .map(|(p, f)| hessian_at(p, f))
            .collect();
        let mut hessian = self.elastic_hessian(&hessians);
        self.add_bulk_hessian(&mut hessian, &gradients, material, false);
        hessian
    }

    /// The bulk term's Gauss-Newton Hessian at the deformation `gradients` of every point
    /// (`coarse`: of the coarser cubature's, see [`Subspace::coarse_gradients`]) added to
    /// `hessian`, which holds the point-by-point part for `split(material).0`.
    pub(crate) fn add_bulk_hessian(
        &self,
        hessian: &mut DMatrix<f64>,
        gradients: &[Matrix3<f64>],
        material: &Material,
        coarse: bool,
    ) {
        if let Some((terms, regions, bulk)) = self.projected_bulk(material, coarse) {
            terms.add_bulk_hessian(regions, hessian, gradients, material.model, bulk);
        }
    }

    /// Whether the whole cubature's bulk regions were formed.
    #[cfg(test)]
    pub(crate) fn formed_bulk_regions(&self) -> bool {
        self.all.bulk.get().is_some()
    }

    /// The modulus of `material`'s projected bulk term with the terms of the whole cubature,
    /// or of the coarser one (`coarse`), and the regions of their points; None where the bulk
    /// term is integrated point by point, which forms no regions (their k-means is not free).
    fn projected_bulk(
        &self,
        material: &Material,
        coarse: bool,
    ) -> Option<(&CubatureTerms, &BulkRegions, f64)> {
        let bulk = split(material).1;
        (bulk != 0.0).then(|| {
            let (terms, regions) = self.bulk_terms(coarse);
            (terms, regions, bulk)
        })
    }

    /// The terms of the whole cubature, or of the coarser one (all points where there is
    /// none), with the regions of their points: the whole cubature's formed on first use,
    /// the coarser one's the same regions restricted to the points it keeps.
    fn bulk_terms(&self, coarse: bool) -> (&CubatureTerms, &BulkRegions) {
        let all = &self.all;
        let count = bulk_regions(self.handles);
        let whole = all
            .bulk
            .get_or_init(|| BulkRegions::new(&all.samples.points(), all.samples.volumes(), count));
        match self.coarse.as_ref().filter(|_| coarse) {
            Some(terms) => {
                let volumes = terms.samples.volumes();
                let gathered = || whole.gathered(&terms.kept, &terms.samples.points(), volumes);
                (terms, terms.bulk.get_or_init(gathered))
            }
            None => (all, whole),
        }
    }

    /// Elastic energy and its gradient (3 x 4K): sum_p v_p Psi(F_p) point by point, of the
    /// whole material or, where its bulk term is projected over regions (`physics::bulk`), of
    /// the rest, the projected term's pressures entering the same pass as each point's
    /// stress. Split over threads for large cubatures (see `FORCES_PARALLEL_WORK`): each
    /// thread takes a run of cubature points, forms their F, their stresses, and its share of
    /// the gradient; the shares are summed.
    pub fn elastic_forces(&self, z: &DMatrix<f64>, material: &Material) -> (f64, DMatrix<f64>) {
        let np = self.cubature_len();
        let samples = &self.all.samples;
        let parallel = np * 4 * self.handles >= FORCES_PARALLEL_WORK;
        let point = split(material).0;
        let share_out = |share: &(dyn Fn(Range<usize>) -> (f64, DMatrix<f64>) + Sync)| {
            if !parallel {
                return share(0..np);
            }
            let mut shares = shared_out(np, share).into_iter();
            let first = shares.next().expect("at least one cubature point");
            shares.fold(first, |(ea, ga), (eb, gb)| (ea + eb, ga + gb))
        };
        let Some((_, regions, bulk)) = self.projected_bulk(material, false) else {
            return share_out(&|points| samples.forces(z, &point, points, None, None));
        };
        // Two passes: F and each point's volume change, then, with the regions' pressures,
        // the stresses and the gradient from the same F. Each pass split as the forces are.
        let deformations = |points: Range<usize>| (points.start, samples.deformation(z, points));
        let held = if parallel {
            shared_out(np, deformations)
        } else {
            vec![deformations(0..np)]
        };
        let changes: Vec<f64> = (held.iter())
            .flat_map(|(_, f)| FieldSamples::volume_changes(f, material.model))
            .collect();
        let (bulk_energy, pressures) =
            regions.energy_and_pressures(&changes, samples.volumes(), bulk);
        let (energy, gradient) = share_out(&|points: Range<usize>| {
            let (offset, f) = held
                .iter()
                .find(|(start, _)| *start == points.start)
                .expect("the same split as the first pass");
            let deformations = Some((f, *offset));
            samples.forces(z, &point, points, Some(&pressures), deformations)
        });
        (energy + bulk_energy, gradient)
    }
}

/// G of every point side by side, (4K) x (3 Np) row-major (see `HessianAssembly::new`): G's
/// rows are w_i e_c^T + X_c grad w_i^T for handle i and coordinate c of [X; 1].
fn g_all_of(
    k: usize,
    weights: &[f64],
    gradients: &[Vector3<f64>],
    points: &[Vector3<f64>],
) -> Vec<f64> {
    let columns = 3 * points.len();
    let mut g_all = vec![0.0; 4 * k * columns];
    for (p, x) in points.iter().enumerate() {
        let xt = [x.x, x.y, x.z, 1.0];
        for i in 0..k {
            let w = weights[p * k + i];
            let gw = gradients[p * k + i];
            for (c, xc) in xt.iter().enumerate() {
                let row = 4 * i + c;
                for e in 0..3 {
                    let identity = if c == e { w } else { 0.0 };
                    g_all[row * columns + 3 * p + e] = identity + xc * gw[e];
                }
            }
        }
    }
    g_all
}

/// sum_p v_p G_p / sum_p v_p from G laid out as in `Subspace::g_all`.
fn mean_gradient(g_all: &[f64], volumes: &[f64], rows: usize) -> DMatrix<f64> {
    let columns = 3 * volumes.len();
    let total: f64 = volumes.iter().sum::<f64>().max(1e-300);
    DMatrix::from_fn(rows, 3, |row, e| {
        let g = &g_all[row * columns..(row + 1) * columns];
        volumes
            .iter()
            .enumerate()
            .map(|(p, v)| v * g[3 * p + e])
            .sum::<f64>()
            / total
    })
}

/// phi = w (x) [X; 1] for one point.
pub fn phi_of(weights: &[f64], x: &Vector3<f64>) -> DVector<f64> {
    let xt = [x.x, x.y, x.z, 1.0];
    DVector::from_fn(4 * weights.len(), |r, _| weights[r / 4] * xt[r % 4])
}

/// Evaluates `field` at world points: weights (points x K) and, if asked, world-space gradients.
pub fn sample(
    field: &dyn SkinningField,
    normalization: &Normalization,
    points: &[Vector3<f64>],
    with_gradients: bool,
) -> (Vec<f64>, Option<Vec<Vector3<f64>>>) {
    let k = field.handle_count();
    let normalized: Vec<_> = points
        .iter()
        .map(|p| normalization.to_normalized(p))
        .collect();
    let mut weights = vec![0.0; points.len() * k];
    let mut gradients = with_gradients.then(|| vec![Vector3::zeros(); points.len() * k]);
    // Fields evaluate point by point: split the points across threads.
    let chunk = 256;
    match gradients.as_mut() {
        Some(g) => weights
            .par_chunks_mut(chunk * k)
            .zip(g.par_chunks_mut(chunk * k))
            .zip(normalized.par_chunks(chunk))
            .for_each(|((w, g), p)| field.evaluate(p, w, Some(g))),
        None => weights
            .par_chunks_mut(chunk * k)
            .zip(normalized.par_chunks(chunk))
            .for_each(|(w, p)| field.evaluate(p, w, None)),
    }
    // Gradients with respect to world coordinates: d/dX_world = d/dX_normalized / scale.
    if let Some(g) = gradients.as_mut() {
        g.iter_mut().for_each(|v| *v /= normalization.scale);
    }
    (weights, gradients)
}

/// phi rows (4K each) for a set of world points, concatenated.
pub fn phis(
    field: &dyn SkinningField,
    normalization: &Normalization,
    points: &[Vector3<f64>],
) -> Vec<DVector<f64>> {
    let k = field.handle_count();
    let (weights, _) = sample(field, normalization, points, false);
    points
        .iter()
        .enumerate()
        .map(|(i, x)| phi_of(&weights[i * k..(i + 1) * k], x))
        .collect()
}
