//! The neural skinning field autoencoder: a perceiver encoder of surface points, handle tokens,
//! and a point decoder whose head gives each query point its weights.

use candle_core::{Module, Tensor, D};
use candle_nn::Linear;
use serde::{Deserialize, Serialize};

use super::inference_ops;
use super::layers::{
    encoding_width, linear, positional_encoding, Attention, EluBlock, FeedForward, KeyValues,
    OniLinear,
};
use super::params::{Init, ParamBuilder};
use crate::error::ensure;
use crate::Result;

type CResult<T> = candle_core::Result<T>;

/// Sizes of the network; stored as JSON beside the weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NetworkConfig {
    /// Positional-encoding octaves (sin and cos of 2^k pi p for k below this). Default 4: the
    /// paper's 8 let a small network meet the orthogonality loss with high-frequency noise
    /// (measured: mean squared weight gradient 46x higher after about 300 steps).
    pub frequencies: usize,
    /// Token width of the encoder and the decoder's attention. Default 64.
    pub width: usize,
    /// Attention heads. Default 4.
    pub heads: usize,
    /// Learned latent queries that summarize the shape. Default 64.
    pub latents: usize,
    /// Self-attention blocks over the latents. Default 2.
    pub self_blocks: usize,
    /// Learned handles, the constant rigid one not counted. Default 16.
    pub handles: usize,
    /// Width of the ELU residual head. Default 64.
    pub head_width: usize,
    /// ELU residual blocks in the head. Default 3.
    pub head_blocks: usize,
    /// Newton iterations of the ONI last layer; 0 turns ONI off. Default 10: the paper's 4 or 5
    /// leave rows orthogonal only to about 1e-2 when the raw weight's singular values spread.
    pub oni_iterations: usize,
    /// Central finite-difference step for weight gradients, normalized units. Default 5e-4.
    pub gradient_step: f64,
    /// Orthonormalize the normalized columns over the shape's reference points (training:
    /// the elastic losses see the whitened columns, L_orth the unwhitened). Default true.
    pub whiten: bool,
}

impl Default for NetworkConfig {
    fn default() -> Self {
        Self {
            frequencies: 4,
            width: 64,
            heads: 4,
            latents: 64,
            self_blocks: 2,
            handles: 16,
            head_width: 64,
            head_blocks: 3,
            oni_iterations: 10,
            gradient_step: 5e-4,
            whiten: true,
        }
    }
}

impl NetworkConfig {
    /// Checks that the sizes fit together. An `Error::InvalidParameter` naming the first
    /// that does not.
    pub fn validate(&self) -> Result<()> {
        ensure(
            self.width > 0 && self.heads > 0 && self.width.is_multiple_of(self.heads),
            "width",
            || {
                format!(
                    "{} must be a positive multiple of heads ({})",
                    self.width, self.heads
                )
            },
        )?;
        ensure(self.latents > 0, "latents", || "must be positive".into())?;
        ensure(self.handles > 0, "handles", || "must be positive".into())?;
        ensure(self.head_width >= self.handles, "head_width", || {
            format!(
                "{} must be at least handles ({}) for the last layer's rows to be orthonormal",
                self.head_width, self.handles
            )
        })?;
        ensure(self.frequencies <= 16, "frequencies", || {
            format!("{} octaves would alias in f32", self.frequencies)
        })?;
        ensure(
            self.gradient_step > 0.0 && self.gradient_step < 0.1,
            "gradient_step",
            || format!("{} is outside (0, 0.1)", self.gradient_step),
        )
    }
}

/// The encoded shape: keys and values of its handle tokens, computed once per shape and reused
/// for every query point. Query points attend to the handle tokens only (as in the paper); the
/// reference code's extra attention to all shape latents cost 40% of decoding time here.
#[derive(Clone, Debug)]
pub struct ShapeCode {
    handles: KeyValues,
}

/// The network. Cheap to clone (tensors are reference counted).
#[derive(Clone, Debug)]
pub struct Network {
    config: NetworkConfig,
    point_embed: Linear,
    latent_queries: Tensor,
    latent_cross: Attention,
    latent_cross_ff: FeedForward,
    self_blocks: Vec<(Attention, FeedForward)>,
    handle_queries: Tensor,
    handle_cross: Attention,
    handle_ff: FeedForward,
    query_embed: Linear,
    query_to_handles: Attention,
    head_in: Linear,
    head_blocks: Vec<EluBlock>,
    head_out: OniLinear,
}

impl Network {
    pub(crate) fn build(config: &NetworkConfig, b: &ParamBuilder) -> Result<Self> {
        config.validate()?;
        let (w, heads) = (config.width, config.heads);
        let enc = encoding_width(config.frequencies);
        let self_blocks = (0..config.self_blocks)
            .map(|i| {
                Ok((
                    Attention::new(b, &format!("encoder.self{i}.attention"), w, heads)?,
                    FeedForward::new(b, &format!("encoder.self{i}.ff"), w)?,
                ))
            })
            .collect::<Result<_>>()?;
        let head_blocks = (0..config.head_blocks)
            .map(|i| EluBlock::new(b, &format!("head.block{i}"), config.head_width))
            .collect::<Result<_>>()?;
        let oni = (config.oni_iterations > 0).then_some(config.oni_iterations);
        Ok(Self {
            config: config.clone(),
            point_embed: linear(b, "encoder.point_embed", enc + 3, w)?,
            latent_queries: b.get(
                "encoder.latent_queries",
                &[config.latents, w],
                Init::Normal(0.5),
            )?,
            latent_cross: Attention::new(b, "encoder.cross", w, heads)?,
            latent_cross_ff: FeedForward::new(b, "encoder.cross_ff", w)?,
            self_blocks,
            handle_queries: b.get("handles.queries", &[config.handles, w], Init::Normal(0.5))?,
            handle_cross: Attention::new(b, "handles.cross", w, heads)?,
            handle_ff: FeedForward::new(b, "handles.ff", w)?,
            query_embed: linear(b, "decoder.query_embed", enc, w)?,
            query_to_handles: Attention::new(b, "decoder.to_handles", w, heads)?,
            head_in: linear(b, "head.in", w + enc, config.head_width)?,
            head_blocks,
            head_out: OniLinear::new(b, "head.out", config.head_width, config.handles, oni)?,
        })
    }

    /// The architecture it was built with.
    pub fn config(&self) -> &NetworkConfig {
        &self.config
    }

    /// Encodes surface points and their unit normals (both N x 3, normalized frame).
    pub fn encode(&self, points: &Tensor, normals: &Tensor) -> CResult<ShapeCode> {
        let features = Tensor::cat(
            &[
                positional_encoding(points, self.config.frequencies)?,
                normals.clone(),
            ],
            D::Minus1,
        )?;
        let tokens = self.point_embed.forward(&features)?;
        let point_kv = self.latent_cross.key_values(&tokens)?;
        let mut latents = self.latent_cross.forward(&self.latent_queries, &point_kv)?;
        latents = self.latent_cross_ff.forward(&latents)?;
        for (attention, ff) in &self.self_blocks {
            let kv = attention.key_values(&latents)?;
            latents = ff.forward(&attention.forward(&latents, &kv)?)?;
        }
        let latent_kv = self.handle_cross.key_values(&latents)?;
        let handles = self.handle_ff.forward(
            &self
                .handle_cross
                .forward(&self.handle_queries, &latent_kv)?,
        )?;
        Ok(ShapeCode {
            handles: self.query_to_handles.key_values(&handles)?,
        })
    }

    /// The last layer's effective weight; compute once and pass to [`Network::decode_raw`] when
    /// decoding several batches.
    pub fn head_weight(&self) -> CResult<Tensor> {
        self.head_out.weight()
    }

    /// Raw (unnormalized) learned weights of query points (Q x 3) -> Q x handles.
    pub fn decode_raw(
        &self,
        code: &ShapeCode,
        points: &Tensor,
        head_weight: &Tensor,
    ) -> CResult<Tensor> {
        let encoded = positional_encoding(points, self.config.frequencies)?;
        let mut query = self.query_embed.forward(&encoded)?;
        query = self.query_to_handles.forward(&query, &code.handles)?;
        let mut hidden = self
            .head_in
            .forward(&Tensor::cat(&[query, encoded], D::Minus1)?)?;
        for block in &self.head_blocks {
            hidden = block.forward(&hidden)?;
        }
        self.head_out
            .forward_with(head_weight, &inference_ops::elu(&hidden)?)
    }
}

/// The output normalization: each learned column centered and scaled to unit root mean square
/// over a shape's reference points, computed once per shape. Any point is then evaluated with
/// the same map, so its weights do not depend on which or how many points are queried with it
/// (the reference code divides by the norm over the current query batch instead).
///
/// With `whitening`, the product then also orthonormalizes the columns over the reference
/// points (W C^{-1/2}, C = W^T W / R: symmetric, so the nearest orthonormal basis of the same
/// span). The span, and so the simulation, is unchanged; the metrics are reported both ways.
#[derive(Clone, Debug)]
pub struct ColumnNormalization {
    pub(crate) mean: Tensor,
    pub(crate) inverse_rms: Tensor,
    pub(crate) whitening: Option<Tensor>,
}

impl ColumnNormalization {
    /// From raw outputs at the reference points (R x handles).
    pub fn from_reference(raw: &Tensor, whiten: bool) -> CResult<Self> {
        let mean = raw.mean_keepdim(0)?;
        let centered = raw.broadcast_sub(&mean)?;
        let rms = (centered.sqr()?.mean_keepdim(0)? + 1e-12)?.sqrt()?;
        // A column the network left (nearly) constant would be scaled up into float noise;
        // its scale is floored at 1e-3 of the median column's, so it stays a weak handle.
        let mut sorted: Vec<f32> = rms.flatten_all()?.to_vec1()?;
        sorted.sort_by(f32::total_cmp);
        let floor = 1e-3 * sorted[sorted.len() / 2] as f64;
        let rms = rms.maximum(floor.max(1e-12))?;
        let mut normalization = Self {
            mean,
            inverse_rms: rms.recip()?,
            whitening: None,
        };
        if whiten {
            let scaled = normalization.apply(raw)?;
            normalization.whitening = Some(exact_whitening(&scaled)?);
        }
        Ok(normalization)
    }

    /// Centered and scaled, and whitened when the normalization has a whitening.
    pub fn apply(&self, raw: &Tensor) -> CResult<Tensor> {
        let scaled = self.apply_scaling(raw)?;
        match &self.whitening {
            Some(w) => scaled.matmul(w),
            None => Ok(scaled),
        }
    }

    /// Centered and scaled only: the network's own output as the metrics judge it.
    pub fn apply_scaling(&self, raw: &Tensor) -> CResult<Tensor> {
        raw.broadcast_sub(&self.mean)?
            .broadcast_mul(&self.inverse_rms)
    }
}

/// (C + 1e-3 I)^{-1/2} for C = W^T W / rows (unit diagonal), in f64 by a symmetric
/// eigen-decomposition. The ridge is the training's: a near-dependent direction is amplified
/// at most 31x, not into float noise.
fn exact_whitening(scaled: &Tensor) -> CResult<Tensor> {
    let rows = scaled.dim(0)? as f64;
    let gram = scaled
        .t()?
        .matmul(scaled)?
        .to_dtype(candle_core::DType::F64)?;
    let m = gram.dim(0)?;
    let values: Vec<f64> = gram.flatten_all()?.to_vec1()?;
    let c = nalgebra::DMatrix::from_row_slice(m, m, &values) / rows;
    let eigen = c.symmetric_eigen();
    let inv_sqrt = eigen.eigenvalues.map(|l| 1.0 / (l.max(0.0) + 1e-3).sqrt());
    let w = &eigen.eigenvectors
        * nalgebra::DMatrix::from_diagonal(&inv_sqrt)
        * eigen.eigenvectors.transpose();
    let flat: Vec<f32> = w.transpose().iter().map(|v| *v as f32).collect();
    Tensor::from_vec(flat, (m, m), scaled.device())
}
