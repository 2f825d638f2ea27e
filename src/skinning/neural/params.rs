//! Where the network's tensors come from: fresh seeded variables (training) or a safetensors
//! file (inference), behind one builder so every layer is written once.

use std::cell::RefCell;
use std::collections::HashMap;

use candle_core::{DType, Device, Tensor, Var};
use rand::Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::{Error, Result};

/// How a fresh parameter starts.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Init {
    /// Uniform in ±sqrt(1 / fan_in) (the usual linear-layer default).
    FanIn(usize),
    /// Normal with this standard deviation (learned queries).
    Normal(f64),
    /// Every entry equal.
    Constant(f64),
}

enum Source<'a> {
    Fresh {
        rng: Box<ChaCha8Rng>,
        vars: Vec<(String, Var)>,
    },
    Stored(&'a HashMap<String, Tensor>),
}

/// Hands out named parameter tensors, named as the safetensors keys.
pub(crate) struct ParamBuilder<'a> {
    source: RefCell<Source<'a>>,
    device: Device,
}

impl<'a> ParamBuilder<'a> {
    /// New variables drawn from a seeded generator, so training starts identically every time.
    pub(crate) fn fresh(seed: u64) -> Self {
        Self {
            source: RefCell::new(Source::Fresh {
                rng: Box::new(ChaCha8Rng::seed_from_u64(seed)),
                vars: Vec::new(),
            }),
            device: Device::Cpu,
        }
    }

    /// Tensors read from a file; a missing or misshapen one is an error naming it.
    pub(crate) fn stored(tensors: &'a HashMap<String, Tensor>) -> Self {
        Self {
            source: RefCell::new(Source::Stored(tensors)),
            device: Device::Cpu,
        }
    }

    pub(crate) fn get(&self, name: &str, shape: &[usize], init: Init) -> Result<Tensor> {
        let mut source = self.source.borrow_mut();
        match &mut *source {
            Source::Fresh { rng, vars } => {
                let count: usize = shape.iter().product();
                let values: Vec<f32> = (0..count)
                    .map(|_| match init {
                        Init::FanIn(fan_in) => {
                            let bound = (1.0 / fan_in as f64).sqrt();
                            rng.random_range(-bound..bound) as f32
                        }
                        Init::Normal(std) => {
                            (std * <StandardNormal as Distribution<f64>>::sample(
                                &StandardNormal,
                                rng,
                            )) as f32
                        }
                        Init::Constant(value) => value as f32,
                    })
                    .collect();
                let tensor = Tensor::from_vec(values, shape, &self.device)?;
                let var = Var::from_tensor(&tensor)?;
                let out = var.as_tensor().clone();
                vars.push((name.to_string(), var));
                Ok(out)
            }
            Source::Stored(tensors) => {
                let tensor = tensors.get(name).ok_or_else(|| Error::Model {
                    what: "weights".into(),
                    reason: format!("the weights file has no tensor `{name}`"),
                })?;
                if tensor.dims() != shape {
                    return Err(Error::Model {
                        what: "weights".into(),
                        reason: format!(
                            "tensor `{name}` has shape {:?}, the config asks for {shape:?}",
                            tensor.dims()
                        ),
                    });
                }
                Ok(tensor.to_dtype(DType::F32)?)
            }
        }
    }

    /// The variables created so far, in creation order (empty for stored tensors).
    pub(crate) fn into_vars(self) -> Vec<(String, Var)> {
        match self.source.into_inner() {
            Source::Fresh { vars, .. } => vars,
            Source::Stored(_) => Vec::new(),
        }
    }
}
