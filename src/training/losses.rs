//! The physics-informed self-supervised losses (PISSL): elastic potential of random handle
//! transforms, smoothness and orthogonality of the weight columns.

use candle_core::{DType, Device, Tensor, D};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::skinning::{inverse_sqrt, ColumnNormalization, Network};
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
    /// Standard deviation of the random handle translations t_i.
    pub z_std: f64,
    /// Standard deviation of the random handle matrices A_i (the paper draws them like t_i).
    pub z_linear_std: f64,
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

    let code = network.encode(&batch.surface, &batch.normals)?;
    let head = network.head_weight()?;
    let raw = network.decode_raw(&code, &stencil(points, h)?, &head)?;
    // L_orth judges the centered, scaled columns (the network's own output); the elastic
    // losses see them whitened over the batch, so they depend on the span only and do not
    // fight L_orth over the basis.
    let (weights, orth_columns) = if options.normalize {
        let scaled = ColumnNormalization::from_reference(&raw.narrow(0, 0, count)?, false)?
            .apply_scaling(&raw)?;
        let centers = scaled.narrow(0, 0, count)?;
        let weights = if network.config().whiten {
            let eye = Tensor::eye(learned, DType::F32, &Device::Cpu)?;
            let gram = ((centers.t()?.matmul(&centers)? / count as f64)? + (eye * 1e-3)?)?;
            scaled.matmul(&inverse_sqrt(&gram, 15)?)?
        } else {
            scaled
        };
        (weights, centers)
    } else {
        (raw.clone(), raw.narrow(0, 0, count)?)
    };
    let w = weights.narrow(0, 0, count)?;
    let gradient = stencil_gradient(&weights, count, h)?;

    let mu = options.young / (2.0 * (1.0 + options.poisson));
    let lambda =
        options.young * options.poisson / ((1.0 + options.poisson) * (1.0 - 2.0 * options.poisson));
    let grad_sq = gradient.sqr()?.sum(D::Minus1)?; // count x learned
    let potential = {
        let linear = expected_linear_energy(points, &w, &gradient, &grad_sq, mu, lambda, options)?;
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
    let orth = orthogonality(&orth_columns)?;
    Ok(Losses {
        potential,
        smooth,
        orth,
    })
}

/// The points followed by their six central-difference neighbours (+x, -x, +y, -y, +z, -z),
/// so the network decodes all of them in one batch: 7 count x 3.
pub(crate) fn stencil(points: &Tensor, h: f64) -> Result<Tensor> {
    let mut parts = vec![points.clone()];
    for axis in 0..3 {
        let mut offset = [0f32; 3];
        for sign in [1.0f32, -1.0] {
            offset[axis] = sign * h as f32;
            let shift = Tensor::from_slice(&offset, (1, 3), &Device::Cpu)?;
            parts.push(points.broadcast_add(&shift)?);
        }
    }
    Ok(Tensor::cat(&parts, 0)?)
}

/// Central differences of values decoded on [`stencil`] points: count x columns x 3.
pub(crate) fn stencil_gradient(values: &Tensor, count: usize, h: f64) -> Result<Tensor> {
    let at = |k: usize| values.narrow(0, k * count, count);
    let axis =
        |k: usize| -> Result<Tensor> { Ok(((at(2 * k + 1)? - at(2 * k + 2)?)? / (2.0 * h))?) };
    Ok(Tensor::stack(&[axis(0)?, axis(1)?, axis(2)?], D::Minus1)?)
}

/// E_z[Psi_lin] for translations t_i ~ N(0, s_t^2 I) and matrices A_i ~ N(0, s_A^2 I), exact:
/// the energy is a quadratic form in z, so its mean is a weighted trace. Per point and handle it
/// is (2 mu + lambda / 2) (s_t^2 |grad w|^2 + s_A^2 (|X|^2 |grad w|^2 + 2 w X . grad w + 3 w^2)).
/// The translations alone give the Dirichlet energy of w, the skinning eigenmodes' objective;
/// the matrices add the energy of the field w X.
fn expected_linear_energy(
    points: &Tensor,
    w: &Tensor,
    gradient: &Tensor,
    grad_sq: &Tensor,
    mu: f64,
    lambda: f64,
    options: &LossOptions,
) -> Result<Tensor> {
    let (s_t, s_a) = (options.z_std, options.z_linear_std);
    let radius_sq = ((points.sqr()?.sum_keepdim(1)? * (s_a * s_a))? + s_t * s_t)?; // count x 1
    let x_dot_grad = gradient
        .broadcast_mul(&points.unsqueeze(1)?)?
        .sum(D::Minus1)?; // count x learned
    let per_handle = (grad_sq.broadcast_mul(&radius_sq)?
        + (((w * x_dot_grad)? * 2.0)? + (w.sqr()? * 3.0)?)? * (s_a * s_a))?;
    let trace = per_handle.sum(1)?.mean(0)?;
    Ok((trace * (2.0 * mu + 0.5 * lambda))?)
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
    let mut normal = |n: usize, std: f64| -> Vec<f32> {
        (0..n)
            .map(|_| {
                (std * <StandardNormal as Distribution<f64>>::sample(&StandardNormal, rng)) as f32
            })
            .collect()
    };
    let a = Tensor::from_vec(
        normal(samples * learned * 9, options.z_linear_std),
        (samples, learned, 3, 3),
        &Device::Cpu,
    )?;
    let t = Tensor::from_vec(
        normal(samples * learned * 3, options.z_std),
        (samples, learned, 3, 1),
        &Device::Cpu,
    )?;
    let f = deformation_gradients(points, w, gradient, &a, &t)?.reshape((count * samples, 9))?;
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

/// F = I + sum_i (w_i A_i + (A_i X + t_i) grad w_i^T) at every point for every sample of the
/// handle transforms (`a`: samples x learned x 3 x 3, `t`: samples x learned x 3 x 1):
/// count x samples x 3 x 3.
pub(crate) fn deformation_gradients(
    points: &Tensor,
    w: &Tensor,
    gradient: &Tensor,
    a: &Tensor,
    t: &Tensor,
) -> Result<Tensor> {
    let (samples, learned) = (a.dim(0)?, a.dim(1)?);
    let count = points.dim(0)?;
    // sum_i w_i A_i: count x samples x 9
    let a_by_handle = a.permute((1, 0, 2, 3))?.reshape((learned, samples * 9))?;
    let linear_part = w.matmul(&a_by_handle)?.reshape((count, samples, 3, 3))?;
    // a_i(X) = A_i X + t_i for every sample, handle and point: samples x learned x 3 x count
    let ax = a
        .reshape((samples * learned * 3, 3))?
        .matmul(&points.t()?)?
        .reshape((samples, learned, 3, count))?
        .broadcast_add(t)?;
    // sum_i a_i grad w_i^T per point: count x (samples*3) x learned @ count x learned x 3
    let ax = ax
        .permute((3, 0, 2, 1))?
        .reshape((count, samples * 3, learned))?
        .contiguous()?;
    let outer = ax
        .matmul(&gradient.contiguous()?)?
        .reshape((count, samples, 3, 3))?;
    let eye = Tensor::eye(3, candle_core::DType::F32, &Device::Cpu)?;
    Ok((linear_part + outer)?.broadcast_add(&eye)?)
}

/// sum over i != j of (What_i . What_j)^2 with What the columns scaled to unit length.
fn orthogonality(w: &Tensor) -> Result<Tensor> {
    let norms = (w.sqr()?.sum_keepdim(0)? + 1e-12)?.sqrt()?;
    let unit = w.broadcast_div(&norms)?;
    let gram = unit.t()?.matmul(&unit)?;
    let diagonal_sq = unit.sqr()?.sum(0)?.sqr()?.sum_all()?;
    Ok((gram.sqr()?.sum_all()? - diagonal_sq)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skinning::NeuralModel;
    use nalgebra::{Matrix3, Vector3};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn tensor(rows: &[[f32; 3]]) -> Tensor {
        Tensor::from_vec(rows.concat(), (rows.len(), 3), &Device::Cpu).unwrap()
    }

    #[test]
    fn finite_difference_deformation_gradients_match_an_affine_field() {
        // Two handles with affine weights w_i(X) = c_i . X + d_i: their gradients are c_i.
        let c = [Vector3::new(0.3, -0.7, 0.2), Vector3::new(-0.1, 0.4, 0.9)];
        let d = [0.25, -0.5];
        let points = [[0.1f32, -0.4, 0.3], [-0.6, 0.2, 0.8], [0.5, 0.5, -0.2]];
        let h = 5e-4;
        let stencil_points = stencil(&tensor(&points), h)
            .unwrap()
            .to_vec2::<f32>()
            .unwrap();
        let values: Vec<f32> = stencil_points
            .iter()
            .flat_map(|p| {
                let x = Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                [(c[0].dot(&x) + d[0]) as f32, (c[1].dot(&x) + d[1]) as f32]
            })
            .collect();
        let values = Tensor::from_vec(values, (stencil_points.len(), 2), &Device::Cpu).unwrap();
        let gradient = stencil_gradient(&values, points.len(), h).unwrap();
        let w = values.narrow(0, 0, points.len()).unwrap();

        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let a: Vec<f32> = (0..2 * 9).map(|_| rng.random_range(-0.3..0.3)).collect();
        let t: Vec<f32> = (0..2 * 3).map(|_| rng.random_range(-0.3..0.3)).collect();
        let a_t = Tensor::from_vec(a.clone(), (1, 2, 3, 3), &Device::Cpu).unwrap();
        let t_t = Tensor::from_vec(t.clone(), (1, 2, 3, 1), &Device::Cpu).unwrap();
        let f = deformation_gradients(&tensor(&points), &w, &gradient, &a_t, &t_t).unwrap();
        let f = f.flatten_all().unwrap().to_vec1::<f32>().unwrap();

        for (p, point) in points.iter().enumerate() {
            let x = Vector3::new(point[0] as f64, point[1] as f64, point[2] as f64);
            let mut expected = Matrix3::identity();
            for i in 0..2 {
                let a_i = Matrix3::from_row_slice(
                    &a[9 * i..9 * i + 9]
                        .iter()
                        .map(|v| *v as f64)
                        .collect::<Vec<_>>(),
                );
                let t_i = Vector3::new(t[3 * i] as f64, t[3 * i + 1] as f64, t[3 * i + 2] as f64);
                let w_i = c[i].dot(&x) + d[i];
                expected += a_i * w_i + (a_i * x + t_i) * c[i].transpose();
            }
            for k in 0..9 {
                let got = f[9 * p + k] as f64;
                let want = expected[(k / 3, k % 3)];
                assert!(
                    (got - want).abs() < 2e-3,
                    "point {p} entry {k}: {got} vs {want}"
                );
            }
        }
    }

    #[test]
    fn the_exact_linear_energy_is_the_mean_over_sampled_transforms() {
        // Any values and gradients will do: the identity holds point by point.
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (count, learned) = (4, 3);
        let mut random =
            |n: usize| -> Vec<f32> { (0..n).map(|_| rng.random_range(-1.0..1.0)).collect() };
        let points = Tensor::from_vec(random(count * 3), (count, 3), &Device::Cpu).unwrap();
        let w = Tensor::from_vec(random(count * learned), (count, learned), &Device::Cpu).unwrap();
        let gradient = Tensor::from_vec(
            random(count * learned * 3),
            (count, learned, 3),
            &Device::Cpu,
        )
        .unwrap();
        let grad_sq = gradient.sqr().unwrap().sum(D::Minus1).unwrap();
        let (mu, lambda) = (0.4, 1.3);
        for (s_t, s_a) in [(0.2, 0.2), (0.2, 0.0), (0.0, 0.3)] {
            let options = LossOptions {
                young: 1.0,
                poisson: 0.45,
                z_std: s_t,
                z_linear_std: s_a,
                z_samples: 1,
                blend: 0.0,
                normalize: true,
            };
            let exact =
                expected_linear_energy(&points, &w, &gradient, &grad_sq, mu, lambda, &options)
                    .unwrap()
                    .to_scalar::<f32>()
                    .unwrap() as f64;
            let samples = 40_000;
            let mut draw = |n: usize, std: f64| -> Tensor {
                let v: Vec<f32> = (0..n)
                    .map(|_| {
                        (std * <StandardNormal as Distribution<f64>>::sample(
                            &StandardNormal,
                            &mut rng,
                        )) as f32
                    })
                    .collect();
                Tensor::new(v, &Device::Cpu).unwrap()
            };
            let a = draw(samples * learned * 9, s_a)
                .reshape((samples, learned, 3, 3))
                .unwrap();
            let t = draw(samples * learned * 3, s_t)
                .reshape((samples, learned, 3, 1))
                .unwrap();
            let f = deformation_gradients(&points, &w, &gradient, &a, &t).unwrap();
            let f = f.flatten_all().unwrap().to_vec1::<f32>().unwrap();
            let mut sum = 0.0;
            for m in f.chunks(9) {
                let strain = |i: usize, j: usize| {
                    0.5 * (m[3 * i + j] as f64 + m[3 * j + i] as f64) - f64::from(u8::from(i == j))
                };
                let trace = strain(0, 0) + strain(1, 1) + strain(2, 2);
                let norm_sq: f64 = (0..9).map(|k| strain(k / 3, k % 3).powi(2)).sum();
                sum += mu * norm_sq + 0.5 * lambda * trace * trace;
            }
            let sampled = sum / (count * samples) as f64;
            assert!(
                (sampled - exact).abs() < 0.03 * exact,
                "s_t {s_t}, s_A {s_a}: sampled {sampled} against exact {exact}"
            );
        }
    }

    #[test]
    fn every_parameter_receives_a_gradient() {
        let config = crate::skinning::NetworkConfig {
            width: 16,
            heads: 2,
            latents: 8,
            self_blocks: 1,
            handles: 4,
            head_width: 16,
            head_blocks: 1,
            ..Default::default()
        };
        let (model, vars) = NeuralModel::fresh(&config, 3).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut random = |n: usize| {
            let v: Vec<f32> = (0..n * 3).map(|_| rng.random_range(-1.0..1.0)).collect();
            Tensor::from_vec(v, (n, 3), &Device::Cpu).unwrap()
        };
        let batch = Batch {
            surface: random(64),
            normals: random(64),
            cubature: random(32),
            volume: 1.0,
        };
        let options = LossOptions {
            young: 1.0,
            poisson: 0.45,
            z_std: 0.2,
            z_linear_std: 0.2,
            z_samples: 2,
            blend: 0.5,
            normalize: true,
        };
        let l = compute(model.network(), &batch, &options, &mut rng).unwrap();
        let total = ((l.potential + l.smooth).unwrap() + l.orth).unwrap();
        let grads = total.backward().unwrap();
        for (name, var) in &vars {
            let g = grads
                .get(var.as_tensor())
                .unwrap_or_else(|| panic!("{name} has no gradient"));
            let norm = g
                .sqr()
                .unwrap()
                .sum_all()
                .unwrap()
                .to_scalar::<f32>()
                .unwrap();
            assert!(
                norm > 0.0 && norm.is_finite(),
                "{name}: gradient norm {norm}"
            );
        }
    }
}
