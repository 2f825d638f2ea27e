//! The physics-informed self-supervised losses (PISSL): elastic potential of random handle
//! transforms, smoothness and orthogonality of the weight columns.

use candle_core::{Device, Tensor, D};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::skinning::{ColumnNormalization, Network};
use crate::Result;

/// One training sample: a shape's encoder input and its cubature points (normalized frame).
pub(crate) struct Batch {
    pub surface: Tensor,
    pub normals: Tensor,
    pub cubature: Tensor,
    /// Solid volume in normalized units.
    pub volume: f64,
}

/// What the losses depend on besides the network.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LossOptions {
    pub young: f64,
    pub poisson: f64,
    /// Standard deviation of the random handle transforms.
    pub z_std: f64,
    /// Transforms drawn per step for the Neo-Hookean part (the linear part is exact).
    pub z_samples: usize,
    /// Blend from linear (0) to Neo-Hookean (1) elasticity: the training progress.
    pub blend: f64,
    /// Normalize the columns (center, unit RMS over the cubature points); off for an ablation.
    pub normalize: bool,
}

/// The three losses (scalar tensors, differentiable) and the batch's orthogonality metric.
pub(crate) struct Losses {
    pub potential: Tensor,
    pub smooth: Tensor,
    pub orth: Tensor,
}

pub(crate) fn compute(
    network: &Network,
    batch: &Batch,
    options: &LossOptions,
    rng: &mut impl Rng,
) -> Result<Losses> {
    let h = network.config().gradient_step;
    let points = &batch.cubature;
    let count = points.dim(0)?;
    let learned = network.config().handles;

    // Centers and their six neighbours in one decode.
    let mut stencil = vec![points.clone()];
    for axis in 0..3 {
        let mut offset = [0f32; 3];
        for sign in [1.0f32, -1.0] {
            offset[axis] = sign * h as f32;
            let shift = Tensor::from_slice(&offset, (1, 3), &Device::Cpu)?;
            stencil.push(points.broadcast_add(&shift)?);
        }
    }
    let code = network.encode(&batch.surface, &batch.normals)?;
    let head = network.head_weight()?;
    let raw = network.decode_raw(&code, &Tensor::cat(&stencil, 0)?, &head)?;
    let weights = if options.normalize {
        ColumnNormalization::from_reference(&raw.narrow(0, 0, count)?)?.apply(&raw)?
    } else {
        raw
    };
    let at = |k: usize| weights.narrow(0, k * count, count);
    let w = at(0)?;
    let gradient = Tensor::stack(
        &[
            ((at(1)? - at(2)?)? / (2.0 * h))?,
            ((at(3)? - at(4)?)? / (2.0 * h))?,
            ((at(5)? - at(6)?)? / (2.0 * h))?,
        ],
        D::Minus1,
    )?; // count x learned x 3

    let mu = options.young / (2.0 * (1.0 + options.poisson));
    let lambda =
        options.young * options.poisson / ((1.0 + options.poisson) * (1.0 - 2.0 * options.poisson));
    let grad_sq = gradient.sqr()?.sum(D::Minus1)?; // count x learned
    let potential = {
        let linear =
            expected_linear_energy(points, &w, &gradient, &grad_sq, mu, lambda, options.z_std)?;
        let blend = options.blend.clamp(0.0, 1.0);
        let energy = if blend > 0.0 {
            let neo =
                sampled_neo_hookean(points, &w, &gradient, mu, lambda, options, learned, rng)?;
            ((linear * (1.0 - blend))? + (neo * blend)?)?
        } else {
            linear
        };
        (energy * batch.volume)?
    };
    let smooth = grad_sq.sum(1)?.mean(0)?;
    let orth = orthogonality(&w)?;
    Ok(Losses {
        potential,
        smooth,
        orth,
    })
}

/// E_z[Psi_lin] for z ~ N(0, s^2 I) over the learned handles, exact: the energy is a quadratic
/// form in z, so its mean is s^2 times the form's trace. Per point and handle the trace is
/// (2 mu + lambda / 2) ((|X|^2 + 1) |grad w|^2 + 2 w X . grad w + 3 w^2).
fn expected_linear_energy(
    points: &Tensor,
    w: &Tensor,
    gradient: &Tensor,
    grad_sq: &Tensor,
    mu: f64,
    lambda: f64,
    z_std: f64,
) -> Result<Tensor> {
    let radius_sq = (points.sqr()?.sum_keepdim(1)? + 1.0)?; // count x 1
    let x_dot_grad = gradient
        .broadcast_mul(&points.unsqueeze(1)?)?
        .sum(D::Minus1)?; // count x learned
    let per_handle =
        ((grad_sq.broadcast_mul(&radius_sq)? + ((w * x_dot_grad)? * 2.0)?)? + (w.sqr()? * 3.0)?)?;
    let trace = per_handle.sum(1)?.mean(0)?;
    Ok((trace * ((2.0 * mu + 0.5 * lambda) * z_std * z_std))?)
}

/// Mean Neo-Hookean energy (the reference code's form, defined for inverted elements too) over
/// random handle transforms: F = I + sum_i (w_i A_i + (A_i X + t_i) grad w_i^T).
#[allow(clippy::too_many_arguments)]
fn sampled_neo_hookean(
    points: &Tensor,
    w: &Tensor,
    gradient: &Tensor,
    mu: f64,
    lambda: f64,
    options: &LossOptions,
    learned: usize,
    rng: &mut impl Rng,
) -> Result<Tensor> {
    let samples = options.z_samples.max(1);
    let count = points.dim(0)?;
    let mut normal = |n: usize| -> Vec<f32> {
        (0..n)
            .map(|_| {
                (options.z_std
                    * <StandardNormal as Distribution<f64>>::sample(&StandardNormal, rng))
                    as f32
            })
            .collect()
    };
    let a = Tensor::from_vec(
        normal(samples * learned * 9),
        (samples, learned, 3, 3),
        &Device::Cpu,
    )?;
    let t = Tensor::from_vec(
        normal(samples * learned * 3),
        (samples, learned, 3, 1),
        &Device::Cpu,
    )?;
    // sum_i w_i A_i: count x samples x 9
    let a_by_handle = a.permute((1, 0, 2, 3))?.reshape((learned, samples * 9))?;
    let linear_part = w.matmul(&a_by_handle)?.reshape((count, samples, 3, 3))?;
    // a_i(X) = A_i X + t_i for every sample, handle and point: samples x learned x 3 x count
    let ax = a
        .reshape((samples * learned * 3, 3))?
        .matmul(&points.t()?)?
        .reshape((samples, learned, 3, count))?
        .broadcast_add(&t)?;
    // sum_i a_i grad w_i^T per point: count x (samples*3) x learned @ count x learned x 3
    let ax = ax
        .permute((3, 0, 2, 1))?
        .reshape((count, samples * 3, learned))?
        .contiguous()?;
    let outer = ax
        .matmul(&gradient.contiguous()?)?
        .reshape((count, samples, 3, 3))?;
    let eye = Tensor::eye(3, candle_core::DType::F32, &Device::Cpu)?;
    let f = (linear_part + outer)?
        .broadcast_add(&eye)?
        .reshape((count * samples, 9))?;
    let c = |i: usize| f.narrow(1, i, 1);
    let minor = |a: usize, b: usize, c_: usize, d: usize| (c(a)? * c(b)?)? - (c(c_)? * c(d)?)?;
    let det = (((c(0)? * minor(4, 8, 5, 7)?)? - (c(1)? * minor(3, 8, 5, 6)?)?)?
        + (c(2)? * minor(3, 7, 4, 6)?)?)?;
    let trace_c = f.sqr()?.sum_keepdim(1)?;
    let j_minus_one = (det - 1.0)?;
    let psi = (((trace_c - 3.0)? * (mu / 2.0))? - (&j_minus_one * mu)?)?
        + (j_minus_one.sqr()? * (lambda / 2.0))?;
    Ok(psi?.mean_all()?)
}

/// sum over i != j of (What_i . What_j)^2 with What the columns scaled to unit length.
fn orthogonality(w: &Tensor) -> Result<Tensor> {
    let norms = (w.sqr()?.sum_keepdim(0)? + 1e-12)?.sqrt()?;
    let unit = w.broadcast_div(&norms)?;
    let gram = unit.t()?.matmul(&unit)?;
    let diagonal_sq = unit.sqr()?.sum(0)?.sqr()?.sum_all()?;
    Ok((gram.sqr()?.sum_all()? - diagonal_sq)?)
}
