//! The learned skinning field of one shape, behind the same trait as the eigenmode baseline.

use std::sync::Arc;

use candle_core::{Device, Tensor};
use nalgebra::Vector3;

use super::model::NeuralModel;
use super::network::{ColumnNormalization, ShapeCode};
use crate::geometry::{Normalization, SurfaceSamples};
use crate::skinning::SkinningField;
use crate::{Error, Result};

/// Query points decoded per batch: bounds the attention scratch (heads x batch x latents floats).
const BATCH: usize = 8192;

/// Rows per block of the padded decode (see [`NeuralField::learned`]).
const ROW_BLOCK: usize = 256;

/// Skinning weights from one forward pass of the network: the shape is encoded once, then any
/// point is decoded on demand. Column 0 is the constant rigid handle, the learned columns follow.
#[derive(Clone, Debug)]
pub struct NeuralField {
    model: Arc<NeuralModel>,
    code: ShapeCode,
    head_weight: Tensor,
    columns: ColumnNormalization,
    normalization: Normalization,
}

// `NeuralModel::field` lives here, beside the type it builds, so the model does not name
// the field.
impl NeuralModel {
    /// The skinning field of one shape: `surface` samples (4096 is the trained count) and
    /// `reference` interior points fix the output normalization; everything in the normalized
    /// frame described by `normalization`.
    pub fn field(
        self: &Arc<Self>,
        surface: &SurfaceSamples,
        reference: &[Vector3<f64>],
        normalization: Normalization,
    ) -> Result<NeuralField> {
        NeuralField::new(self.clone(), surface, reference, normalization)
    }
}

impl NeuralField {
    pub(crate) fn new(
        model: Arc<NeuralModel>,
        surface: &SurfaceSamples,
        reference: &[Vector3<f64>],
        normalization: Normalization,
    ) -> Result<Self> {
        if surface.points.is_empty() || surface.points.len() != surface.normals.len() {
            return Err(Error::Geometry(format!(
                "the network needs surface points with normals (got {} points, {} normals)",
                surface.points.len(),
                surface.normals.len()
            )));
        }
        if reference.len() < 2 * model.config().handles {
            return Err(Error::Geometry(format!(
                "{} reference points cannot normalize {} weight columns",
                reference.len(),
                model.config().handles
            )));
        }
        let network = model.network();
        let code = network.encode(
            &points_tensor(&surface.points)?,
            &points_tensor(&surface.normals)?,
        )?;
        let head_weight = network.head_weight()?;
        let raw = network.decode_raw(&code, &points_tensor(reference)?, &head_weight)?;
        let columns = ColumnNormalization::from_reference(&raw, model.config().whiten)?;
        Ok(Self {
            model,
            code,
            head_weight,
            columns,
            normalization,
        })
    }

    /// The map between world units and the normalized frame the field answers in.
    pub fn normalization(&self) -> &Normalization {
        &self.normalization
    }

    /// Learned weights (without the constant column) of `points`, row-major points x learned.
    fn learned(&self, points: &[Vector3<f64>]) -> Result<Vec<f32>> {
        // The matrix products sum in another order for short batches (measured: up to 4e-4
        // apart between 1 and 3000 points); padding to whole blocks of 256 rows makes a point's
        // weights bit-identical whatever it is batched with.
        let mut padded = points.to_vec();
        padded.resize(points.len().next_multiple_of(ROW_BLOCK), Vector3::zeros());
        let tensor = points_tensor(&padded)?;
        let raw = self
            .model
            .network()
            .decode_raw(&self.code, &tensor, &self.head_weight)?;
        let weights = self.columns.apply(&raw)?.narrow(0, 0, points.len())?;
        Ok(weights.flatten_all()?.to_vec1::<f32>()?)
    }

    /// The network's own output at `points` with the column centering and scaling but without
    /// the product's whitening, constant column first (points x handles, row-major): what the
    /// paper's metrics judge.
    pub fn network_output(&self, points: &[Vector3<f64>]) -> Result<Vec<f64>> {
        let raw = self.model.network().decode_raw(
            &self.code,
            &points_tensor(points)?,
            &self.head_weight,
        )?;
        let scaled: Vec<f32> = self.columns.apply_scaling(&raw)?.flatten_all()?.to_vec1()?;
        let learned = self.model.config().handles;
        Ok(scaled
            .chunks_exact(learned)
            .flat_map(|row| std::iter::once(1.0).chain(row.iter().map(|v| *v as f64)))
            .collect())
    }

    fn evaluate_batch(
        &self,
        points: &[Vector3<f64>],
        weights: &mut [f64],
        gradients: Option<&mut [Vector3<f64>]>,
    ) -> Result<()> {
        let learned = self.model.config().handles;
        let handles = learned + 1;
        let n = points.len();
        let step = self.model.config().gradient_step;
        // Centers, then the six central-difference neighbours, decoded in one batch.
        let mut all = points.to_vec();
        if gradients.is_some() {
            for axis in 0..3 {
                for sign in [1.0, -1.0] {
                    all.extend(points.iter().map(|p| {
                        let mut q = *p;
                        q[axis] += sign * step;
                        q
                    }));
                }
            }
        }
        let values = self.learned(&all)?;
        for (i, row) in weights.chunks_exact_mut(handles).enumerate() {
            row[0] = 1.0;
            for (w, v) in row[1..]
                .iter_mut()
                .zip(&values[i * learned..(i + 1) * learned])
            {
                *w = *v as f64;
            }
        }
        if let Some(gradients) = gradients {
            for (i, row) in gradients.chunks_exact_mut(handles).enumerate() {
                row[0] = Vector3::zeros();
                for h in 0..learned {
                    let mut g = Vector3::zeros();
                    for axis in 0..3 {
                        let plus = values[((1 + 2 * axis) * n + i) * learned + h] as f64;
                        let minus = values[((2 + 2 * axis) * n + i) * learned + h] as f64;
                        g[axis] = (plus - minus) / (2.0 * step);
                    }
                    row[1 + h] = g;
                }
            }
        }
        Ok(())
    }
}

impl SkinningField for NeuralField {
    fn handle_count(&self) -> usize {
        self.model.config().handles + 1
    }

    fn evaluate(
        &self,
        points: &[Vector3<f64>],
        weights: &mut [f64],
        mut gradients: Option<&mut [Vector3<f64>]>,
    ) {
        let handles = self.handle_count();
        // Neighbour evaluations multiply the batch by 7; keep the scratch bounded.
        let batch = if gradients.is_some() {
            BATCH / 7
        } else {
            BATCH
        };
        for (start, chunk) in (0..points.len()).step_by(batch).zip(points.chunks(batch)) {
            let rows = start * handles..(start + chunk.len()) * handles;
            let grads = gradients.as_deref_mut().map(|g| &mut g[rows.clone()]);
            self.evaluate_batch(chunk, &mut weights[rows], grads)
                .expect("decoding a shape that encoded cannot fail but for allocation");
        }
    }

    fn kind(&self) -> &'static str {
        "learned"
    }
}

pub(crate) fn points_tensor(points: &[Vector3<f64>]) -> Result<Tensor> {
    let flat: Vec<f32> = points
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    Ok(Tensor::from_vec(flat, (points.len(), 3), &Device::Cpu)?)
}
