//! The network's building blocks, written from candle's basic ops so every one has a backward
//! pass (candle 0.11's fused softmax and LayerNorm have none: their gradients are silently zero).

use candle_core::{DType, Module, Tensor, D};
use candle_nn::Linear;

use super::inference_ops::{self, elu};
use super::params::{Init, ParamBuilder};
use crate::Result;

type CResult<T> = candle_core::Result<T>;

/// gamma(p) = (p, sin(2^k pi p), cos(2^k pi p)) for k < frequencies: 3 + 6 * frequencies values.
pub(crate) fn positional_encoding(points: &Tensor, frequencies: usize) -> CResult<Tensor> {
    let mut parts = vec![points.clone()];
    for k in 0..frequencies {
        let scaled = (points * (std::f64::consts::PI * (1u64 << k) as f64))?;
        parts.push(scaled.sin()?);
        parts.push(scaled.cos()?);
    }
    Tensor::cat(&parts, D::Minus1)
}

pub(crate) fn encoding_width(frequencies: usize) -> usize {
    3 + 6 * frequencies
}

pub(crate) fn linear(b: &ParamBuilder, name: &str, input: usize, output: usize) -> Result<Linear> {
    let weight = b.get(
        &format!("{name}.weight"),
        &[output, input],
        Init::FanIn(input),
    )?;
    let bias = b.get(&format!("{name}.bias"), &[output], Init::FanIn(input))?;
    Ok(Linear::new(weight, Some(bias)))
}

/// Layer normalization over the last dimension, from basic ops.
#[derive(Clone, Debug)]
pub(crate) struct LayerNorm {
    scale: Tensor,
    shift: Tensor,
}

impl LayerNorm {
    pub(crate) fn new(b: &ParamBuilder, name: &str, width: usize) -> Result<Self> {
        Ok(Self {
            scale: b.get(&format!("{name}.scale"), &[width], Init::Constant(1.0))?,
            shift: b.get(&format!("{name}.shift"), &[width], Init::Constant(0.0))?,
        })
    }
}

impl Module for LayerNorm {
    fn forward(&self, x: &Tensor) -> CResult<Tensor> {
        let centered = x.broadcast_sub(&x.mean_keepdim(D::Minus1)?)?;
        let variance = centered.sqr()?.mean_keepdim(D::Minus1)?;
        let normalized = centered.broadcast_div(&(variance + 1e-5)?.sqrt()?)?;
        normalized
            .broadcast_mul(&self.scale)?
            .broadcast_add(&self.shift)
    }
}

/// Keys and values of an attention layer, computed once for a fixed context (a shape's latents
/// or handle tokens) and reused for any number of queries.
#[derive(Clone, Debug)]
pub(crate) struct KeyValues {
    /// heads x context x head_width, keys pre-transposed: heads x head_width x context.
    keys_t: Tensor,
    values: Tensor,
}

/// Multi-head attention with pre-normalized queries and context.
#[derive(Clone, Debug)]
pub(crate) struct Attention {
    query_norm: LayerNorm,
    context_norm: LayerNorm,
    query: Linear,
    key: Linear,
    value: Linear,
    out: Linear,
    heads: usize,
}

impl Attention {
    pub(crate) fn new(b: &ParamBuilder, name: &str, width: usize, heads: usize) -> Result<Self> {
        Ok(Self {
            query_norm: LayerNorm::new(b, &format!("{name}.query_norm"), width)?,
            context_norm: LayerNorm::new(b, &format!("{name}.context_norm"), width)?,
            query: linear(b, &format!("{name}.query"), width, width)?,
            key: linear(b, &format!("{name}.key"), width, width)?,
            value: linear(b, &format!("{name}.value"), width, width)?,
            out: linear(b, &format!("{name}.out"), width, width)?,
            heads,
        })
    }

    pub(crate) fn key_values(&self, context: &Tensor) -> CResult<KeyValues> {
        let (count, width) = context.dims2()?;
        let head_width = width / self.heads;
        let context = self.context_norm.forward(context)?;
        let split = |t: Tensor| t.reshape((count, self.heads, head_width))?.transpose(0, 1);
        let keys = split(self.key.forward(&context)?)?;
        let values = split(self.value.forward(&context)?)?.contiguous()?;
        let keys_t = (keys.transpose(1, 2)?.contiguous()? / (head_width as f64).sqrt())?;
        Ok(KeyValues { keys_t, values })
    }

    /// queries + attention(queries, context): the residual is included.
    pub(crate) fn forward(&self, queries: &Tensor, kv: &KeyValues) -> CResult<Tensor> {
        let (count, width) = queries.dims2()?;
        let head_width = width / self.heads;
        let q = self
            .query
            .forward(&self.query_norm.forward(queries)?)?
            .reshape((count, self.heads, head_width))?
            .transpose(0, 1)?
            .contiguous()?;
        let scores = q.matmul(&kv.keys_t)?;
        let attention = inference_ops::softmax_last(&scores)?;
        let mixed = attention
            .matmul(&kv.values)?
            .transpose(0, 1)?
            .reshape((count, width))?;
        queries + self.out.forward(&mixed)?
    }
}

/// x + MLP(LayerNorm(x)), GELU inside, 4x wide.
#[derive(Clone, Debug)]
pub(crate) struct FeedForward {
    norm: LayerNorm,
    up: Linear,
    down: Linear,
}

impl FeedForward {
    pub(crate) fn new(b: &ParamBuilder, name: &str, width: usize) -> Result<Self> {
        Ok(Self {
            norm: LayerNorm::new(b, &format!("{name}.norm"), width)?,
            up: linear(b, &format!("{name}.up"), width, 2 * width)?,
            down: linear(b, &format!("{name}.down"), 2 * width, width)?,
        })
    }
}

impl Module for FeedForward {
    fn forward(&self, x: &Tensor) -> CResult<Tensor> {
        let hidden = self.up.forward(&self.norm.forward(x)?)?.gelu()?;
        x + self.down.forward(&hidden)?
    }
}

/// x + Linear(ELU(Linear(ELU(x)))): the residual block of the weight head.
#[derive(Clone, Debug)]
pub(crate) struct EluBlock {
    first: Linear,
    second: Linear,
}

impl EluBlock {
    pub(crate) fn new(b: &ParamBuilder, name: &str, width: usize) -> Result<Self> {
        Ok(Self {
            first: linear(b, &format!("{name}.first"), width, width)?,
            second: linear(b, &format!("{name}.second"), width, width)?,
        })
    }
}

impl Module for EluBlock {
    fn forward(&self, x: &Tensor) -> CResult<Tensor> {
        let hidden = elu(&self.first.forward(&elu(x)?)?)?;
        x + self.second.forward(&hidden)?
    }
}

/// The last layer: a linear map whose weight rows are made orthonormal by orthogonalization by
/// Newton iterations (ONI, Huang et al. 2020), or a plain linear map when ONI is off.
#[derive(Clone, Debug)]
pub(crate) struct OniLinear {
    raw: Tensor,
    bias: Tensor,
    iterations: Option<usize>,
}

impl OniLinear {
    pub(crate) fn new(
        b: &ParamBuilder,
        name: &str,
        input: usize,
        output: usize,
        iterations: Option<usize>,
    ) -> Result<Self> {
        Ok(Self {
            raw: b.get(
                &format!("{name}.weight"),
                &[output, input],
                Init::FanIn(input),
            )?,
            bias: b.get(&format!("{name}.bias"), &[output], Init::Constant(0.0))?,
            iterations,
        })
    }

    /// The effective weight S^{-1/2} V with V the row-centered raw weight and
    /// S = V V^T + 1e-7 I, its inverse square root by Newton iterations on S / ||S||_F. ONI's
    /// plain iteration B <- 1.5 B - 0.5 B^3 S drifts away again in f32 after about 10 steps;
    /// the coupled form (Higham: Y <- Y T, Z <- T Z, T = (3 I - Z Y) / 2) converges to the same
    /// limit and stays there.
    pub(crate) fn weight(&self) -> CResult<Tensor> {
        let Some(iterations) = self.iterations else {
            return Ok(self.raw.clone());
        };
        let v = self.raw.broadcast_sub(&self.raw.mean_keepdim(1)?)?;
        let eye = Tensor::eye(v.dim(0)?, DType::F32, v.device())?;
        let s = (v.matmul(&v.t()?)? + (&eye * 1e-7)?)?;
        inverse_sqrt(&s, iterations)?.matmul(&v)
    }

    pub(crate) fn forward_with(&self, weight: &Tensor, x: &Tensor) -> CResult<Tensor> {
        x.matmul(&weight.t()?)?.broadcast_add(&self.bias)
    }
}

/// S^{-1/2} of a symmetric positive definite matrix by coupled Newton iterations on
/// S / ||S||_F (eigenvalues in (0, 1], where the iteration converges), differentiable.
pub fn inverse_sqrt(s: &Tensor, iterations: usize) -> CResult<Tensor> {
    let eye = Tensor::eye(s.dim(0)?, DType::F32, s.device())?;
    let norm = s.sqr()?.sum_all()?.sqrt()?;
    let mut y = s.broadcast_div(&norm)?;
    let mut z = eye.clone();
    for _ in 0..iterations {
        let t = (((&eye * 3.0)? - z.matmul(&y)?)? * 0.5)?;
        y = y.matmul(&t)?;
        z = t.matmul(&z)?;
    }
    z.broadcast_div(&norm.sqrt()?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn oni_rows_are_orthonormal() {
        let builder = ParamBuilder::fresh(9);
        let layer = OniLinear::new(&builder, "out", 64, 16, Some(10)).unwrap();
        let w = layer.weight().unwrap();
        let gram = w.matmul(&w.t().unwrap()).unwrap().to_vec2::<f32>().unwrap();
        for (i, row) in gram.iter().enumerate() {
            for (j, value) in row.iter().enumerate() {
                let expected = if i == j { 1.0 } else { 0.0 };
                assert!((value - expected).abs() < 1e-5, "W W^T[{i}][{j}] = {value}");
            }
        }
    }
}
