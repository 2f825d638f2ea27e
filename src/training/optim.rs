//! Gradient combination (ConFIG), Adam, and the learning-rate schedule.

use candle_core::{Tensor, Var};
use nalgebra::{DMatrix, DVector};

use crate::Result;

/// ConFIG (Liu et al. 2024): the update direction u has equal positive cosine with every loss
/// gradient (u solves U u = 1 in least squares for the rows U of unit gradients, then is made
/// unit), and its length is the sum of the gradients' projections on it. `gradients` are
/// flattened, one per loss; zero gradients take no part.
pub(crate) fn config_combine(gradients: &[Tensor]) -> Result<Tensor> {
    let stacked = Tensor::stack(gradients, 0)?;
    let gram: Vec<Vec<f32>> = stacked.matmul(&stacked.t()?)?.to_vec2()?;
    let active: Vec<usize> = (0..gradients.len()).filter(|&i| gram[i][i] > 0.0).collect();
    if active.is_empty() {
        return Ok(gradients[0].zeros_like()?);
    }
    let k = active.len();
    let norm: Vec<f64> = active.iter().map(|&i| (gram[i][i] as f64).sqrt()).collect();
    let unit_gram = DMatrix::from_fn(k, k, |a, b| {
        gram[active[a]][active[b]] as f64 / (norm[a] * norm[b])
    });
    // Minimum-norm least squares: u = U^T c with (U U^T) c = 1.
    let c = unit_gram
        .clone()
        .pseudo_inverse(1e-10)
        .expect("a symmetric matrix has an SVD")
        * DVector::repeat(k, 1.0);
    let length = (c.transpose() * &unit_gram * &c)[(0, 0)].sqrt();
    if length <= 0.0 || !length.is_finite() {
        return Ok(gradients[0].zeros_like()?);
    }
    // Projection of each gradient on u, summed: g_i . u = sum_j c_j (g_i . g_j) / |g_j| / length.
    let magnitude: f64 = (0..k)
        .map(|a| {
            (0..k)
                .map(|b| c[b] * gram[active[a]][active[b]] as f64 / norm[b])
                .sum::<f64>()
                / length
        })
        .sum();
    let mut combined = gradients[0].zeros_like()?;
    for (b, &i) in active.iter().enumerate() {
        combined = (combined + (&gradients[i] * (magnitude * c[b] / (norm[b] * length)))?)?;
    }
    Ok(combined)
}

/// Linear warm-up to `peak` over the first `warmup` of the steps, cosine decay to `last`.
pub(crate) fn learning_rate(step: usize, total: usize, peak: f64, last: f64, warmup: f64) -> f64 {
    let warm_steps = ((total as f64 * warmup).ceil() as usize).max(1);
    if step < warm_steps {
        return peak * (step + 1) as f64 / warm_steps as f64;
    }
    let progress = (step - warm_steps) as f64 / (total.saturating_sub(warm_steps)).max(1) as f64;
    last + 0.5 * (peak - last) * (1.0 + (std::f64::consts::PI * progress.min(1.0)).cos())
}

/// Adam with its moments as tensors beside each variable, so a checkpoint can save them.
pub(crate) struct Adam {
    pub vars: Vec<(String, Var)>,
    pub first: Vec<Tensor>,
    pub second: Vec<Tensor>,
    pub steps: usize,
}

const BETA1: f64 = 0.9;
const BETA2: f64 = 0.999;
const EPSILON: f64 = 1e-8;

impl Adam {
    pub(crate) fn new(vars: Vec<(String, Var)>) -> Result<Self> {
        let zeros = |(_, v): &(String, Var)| v.as_tensor().zeros_like();
        Ok(Self {
            first: vars.iter().map(zeros).collect::<candle_core::Result<_>>()?,
            second: vars.iter().map(zeros).collect::<candle_core::Result<_>>()?,
            vars,
            steps: 0,
        })
    }

    /// Number of scalars over all variables.
    pub(crate) fn parameter_count(&self) -> usize {
        self.vars.iter().map(|(_, v)| v.elem_count()).sum()
    }

    /// One update from a flattened gradient (the variables' order, concatenated).
    pub(crate) fn step(&mut self, gradient: &Tensor, rate: f64) -> Result<()> {
        self.steps += 1;
        let bias1 = 1.0 - BETA1.powi(self.steps as i32);
        let bias2 = 1.0 - BETA2.powi(self.steps as i32);
        let mut offset = 0;
        for (i, (_, var)) in self.vars.iter().enumerate() {
            let n = var.elem_count();
            let g = gradient.narrow(0, offset, n)?.reshape(var.shape())?;
            offset += n;
            self.first[i] = ((&self.first[i] * BETA1)? + (&g * (1.0 - BETA1))?)?;
            self.second[i] = ((&self.second[i] * BETA2)? + (g.sqr()? * (1.0 - BETA2))?)?;
            let update = (&self.first[i] / bias1)?
                .div(&(((&self.second[i] / bias2)?.sqrt()? + EPSILON)?))?;
            var.set(&(var.as_tensor() - (update * rate)?)?)?;
        }
        Ok(())
    }

    /// The flattened gradient of `loss` over the variables (zeros where it does not reach).
    pub(crate) fn flat_gradient(&self, loss: &Tensor) -> Result<Tensor> {
        let grads = loss.backward()?;
        let parts = self
            .vars
            .iter()
            .map(|(_, var)| match grads.get(var.as_tensor()) {
                Some(g) => g.flatten_all(),
                None => var.as_tensor().zeros_like()?.flatten_all(),
            })
            .collect::<candle_core::Result<Vec<_>>>()?;
        Ok(Tensor::cat(&parts, 0)?)
    }
}

/// The per-loss gradient momenta of M-ConFIG, bias-corrected like Adam's first moment.
pub(crate) struct LossMomenta {
    pub values: Vec<Option<Tensor>>,
    pub updates: Vec<usize>,
}

const MOMENTUM: f64 = 0.9;

impl LossMomenta {
    pub(crate) fn new(losses: usize) -> Self {
        Self {
            values: vec![None; losses],
            updates: vec![0; losses],
        }
    }

    pub(crate) fn update(&mut self, loss: usize, gradient: &Tensor) -> Result<()> {
        let scaled = (gradient * (1.0 - MOMENTUM))?;
        self.values[loss] = Some(match &self.values[loss] {
            Some(m) => ((m * MOMENTUM)? + scaled)?,
            None => scaled,
        });
        self.updates[loss] += 1;
        Ok(())
    }

    /// The bias-corrected momenta of the losses seen so far.
    pub(crate) fn corrected(&self) -> Result<Vec<Tensor>> {
        self.values
            .iter()
            .zip(&self.updates)
            .filter_map(|(m, &n)| m.as_ref().map(|m| (m, n)))
            .map(|(m, n)| Ok((m / (1.0 - MOMENTUM.powi(n as i32)))?))
            .collect()
    }
}
