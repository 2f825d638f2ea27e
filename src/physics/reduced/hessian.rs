//! The step objective's Hessian for Newton's directions and the quasi-Newton solver's held
//! matrix: elasticity exact where the whole is definite, else projected; inertia, damping and
//! pins; contact.

use nalgebra::{DMatrix, DVector, Matrix3};

use super::{add_kron_identity, ReducedSim};
use crate::linalg::DenseCholesky;
use crate::physics::material::Matrix9;
use crate::physics::shares::shared_out;

/// Points from which their stress derivatives are formed on several threads: a point's takes
/// about 70 ns, so the wake-up of another thread outweighs the split of a thousand of them. On
/// 2 threads 512 points took 0.09 ms against 0.03 ms on one, 1024 points 0.076 ms against
/// 0.071 ms (printed, a scratch timing of `bench sim` on the rod).
const PARALLEL_STRESS_DERIVATIVES: usize = 8192;
/// The same for projected stress derivatives, each an SVD and an eigensystem: the poked
/// creature's 512 points took 0.66-0.73 ms on one thread, 0.38-0.42 ms on two in most of its
/// refreshes (0.8-1.3 ms where the other thread was slow to wake; printed).
const PARALLEL_PROJECTED_DERIVATIVES: usize = 256;

/// What an elastic Hessian is for, which decides the digits it is summed with.
#[derive(Clone, Copy)]
pub(super) enum HessianUse {
    /// The Newton system: f64.
    Newton,
    /// The quasi-Newton preconditioner: f32 where that keeps its digits.
    Preconditioner,
    /// The quasi-Newton preconditioner reassembled within a step: as `Preconditioner`, on
    /// the coarser cubature (see `Subspace::coarse_gradients`).
    Refresh,
}

/// An elastic Hessian (12K x 12K) and, where it was factored to check that it is definite,
/// that factor: of it plus the quadratic part it was checked with, on the pins' free directions.
pub(super) struct CheckedHessian {
    pub matrix: DMatrix<f64>,
    pub factor: Option<DenseCholesky>,
}

impl ReducedSim {
    /// Newton's direction at `z`: -H^-1 g with the step objective's Hessian, restricted to the
    /// directions the pins leave free.
    pub(super) fn newton_direction(
        &mut self,
        z: &DMatrix<f64>,
        gradient: &DVector<f64>,
    ) -> DVector<f64> {
        let mut hessian = self.hessian_at(z);
        if let Some(pinning) = self.pinning.as_ref() {
            pinning.restrict_hessian(&mut hessian);
        }
        self.solve_or_descend(&hessian, gradient)
    }

    /// The Hessian of the step objective at `z`: elasticity (see `smooth_elastic_at`),
    /// inertia, damping, pins and contact.
    fn hessian_at(&self, z: &DMatrix<f64>) -> DMatrix<f64> {
        let quadratic = self.quadratic_part();
        let mut hessian = self
            .smooth_elastic_at(z, &quadratic, HessianUse::Newton)
            .matrix;
        add_kron_identity(&mut hessian, &quadratic);
        if let Some(contact) = self.contact_curvature(z) {
            hessian += contact;
        }
        hessian
    }

    /// The elastic Hessian at `z`: the exact one where, with `quadratic` (4K x 4K, taken
    /// (x) I_3) added, it is positive definite, else the PSD-projected one. Inertia keeps the
    /// exact one definite in most states, and there Newton converges quadratically; with the
    /// projection it converges only linearly wherever the material is compressed (a rod's poke
    /// took 4.0 Newton iterations a step, 2.4 without).
    ///
    /// A preconditioner's, summed in f32, is kept only where it can be factored as the held
    /// matrix is (pinned directions restricted away: their stiff springs would hide the rest),
    /// else it is summed again in f64: f32's rounding, about 1e-7 of the stiffest entries, can
    /// outweigh the inertia of a stiff, light body's softest directions.
    pub(super) fn smooth_elastic_at(
        &self,
        z: &DMatrix<f64>,
        quadratic: &DMatrix<f64>,
        usage: HessianUse,
    ) -> CheckedHessian {
        // Every point's deformation gradients are formed once, and only where they are used.
        let gradients = match usage {
            HessianUse::Newton => self.subspace.deformation_gradients(z),
            HessianUse::Preconditioner => {
                let gradients = self.subspace.deformation_gradients(z);
                if let Some(single) = self.factorable_single(&gradients, quadratic, usage) {
                    return single;
                }
                gradients
            }
            HessianUse::Refresh => {
                let coarse = self.subspace.coarse_gradients(z);
                if let Some(single) = self.factorable_single(&coarse, quadratic, usage) {
                    return single;
                }
                self.subspace.deformation_gradients(z)
            }
        };
        let exact = self.elastic_hessian_of(&gradients, false, HessianUse::Newton);
        let matrix = if self.factored(&exact, quadratic, false).is_some() {
            exact
        } else {
            self.elastic_hessian_of(&gradients, true, HessianUse::Newton)
        };
        CheckedHessian {
            matrix,
            factor: None,
        }
    }

    /// The preconditioner's Hessian at `gradients` (the points `usage` says), exact or else
    /// projected, summed in f32 where that keeps its digits: the first that factors as the held
    /// matrix is (see `smooth_elastic_at`), with that factor; None when neither does.
    fn factorable_single(
        &self,
        gradients: &[Matrix3<f64>],
        quadratic: &DMatrix<f64>,
        usage: HessianUse,
    ) -> Option<CheckedHessian> {
        [false, true].into_iter().find_map(|project| {
            let matrix = self.elastic_hessian_of(gradients, project, usage);
            let factor = self.factored(&matrix, quadratic, true)?;
            Some(CheckedHessian {
                matrix,
                factor: Some(factor),
            })
        })
    }

    /// `elastic` plus `quadratic` (x) I_3, on the free directions only when `restricted`,
    /// factored; None where it is not positive definite.
    fn factored(
        &self,
        elastic: &DMatrix<f64>,
        quadratic: &DMatrix<f64>,
        restricted: bool,
    ) -> Option<DenseCholesky> {
        let mut total = elastic.clone();
        add_kron_identity(&mut total, quadratic);
        if let (true, Some(pinning)) = (restricted, self.pinning.as_ref()) {
            pinning.restrict_hessian(&mut total);
        }
        let n = total.nrows();
        DenseCholesky::in_place(total.data.into(), n).ok()
    }

    fn elastic_hessian_of(
        &self,
        gradients: &[Matrix3<f64>],
        project: bool,
        usage: HessianUse,
    ) -> DMatrix<f64> {
        let coarse = matches!(usage, HessianUse::Refresh);
        let hessian_at =
            self.subspace
                .stress_derivatives(gradients, &self.material, project, coarse);
        let parallel_from = if project {
            PARALLEL_PROJECTED_DERIVATIVES
        } else {
            PARALLEL_STRESS_DERIVATIVES
        };
        let hessians: Vec<Matrix9> = if gradients.len() >= parallel_from {
            let run_of = |run: std::ops::Range<usize>| -> Vec<Matrix9> {
                run.map(|p| hessian_at(p, &gradients[p])).collect()
            };
            shared_out(gradients.len(), run_of).concat()
        } else {
            (gradients.iter().enumerate())
                .map(|(p, f)| hessian_at(p, f))
                .collect()
        };
        let mut hessian = match usage {
            HessianUse::Newton => self.subspace.elastic_hessian(&hessians),
            HessianUse::Preconditioner => self.subspace.preconditioning_hessian(&hessians),
            HessianUse::Refresh => self.subspace.coarse_preconditioning_hessian(&hessians),
        };
        self.subspace
            .add_bulk_hessian(&mut hessian, gradients, &self.material, coarse);
        hessian
    }

    /// -H^-1 g, falling back to the preconditioner (or steepest descent) if H is not positive
    /// definite, which a Hessian made definite before contact (PSD) is added should never be.
    fn solve_or_descend(
        &mut self,
        hessian: &DMatrix<f64>,
        gradient: &DVector<f64>,
    ) -> DVector<f64> {
        let mut direction = -gradient.clone();
        match DenseCholesky::new(hessian.as_slice(), hessian.nrows()) {
            Ok(chol) => chol.solve(direction.as_mut_slice()),
            Err(_) => {
                if self.preconditioner.is_none() {
                    self.preconditioner = Some(self.build_preconditioner());
                }
                if let Some(p) = &self.preconditioner {
                    p.solve(direction.as_mut_slice());
                }
            }
        }
        direction
    }
}
