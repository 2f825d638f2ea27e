//! A trained network with its config in one safetensors file, and the bundled default.

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, OnceLock};

use candle_core::{Device, Tensor, Var};

use super::network::{Network, NetworkConfig};
use super::params::ParamBuilder;
use crate::{Error, Result};

/// The model shipped in the repository, trained by the command in the README.
const BUNDLED_WEIGHTS: &[u8] = include_bytes!("../../../config/model/physskin.safetensors");

/// Key of the safetensors metadata entry holding the [`NetworkConfig`] as JSON.
pub const CONFIG_KEY: &str = "physskin.network_config";

/// A network ready to infer skinning fields for new shapes.
#[derive(Clone, Debug)]
pub struct NeuralModel {
    network: Network,
}

impl NeuralModel {
    /// The bundled model (decoded once per process).
    pub fn bundled() -> Result<Arc<NeuralModel>> {
        static BUNDLED: OnceLock<std::result::Result<Arc<NeuralModel>, String>> = OnceLock::new();
        BUNDLED
            .get_or_init(|| {
                NeuralModel::from_bytes(BUNDLED_WEIGHTS)
                    .map(Arc::new)
                    .map_err(|e| e.to_string())
            })
            .clone()
            .map_err(|reason| Error::Model {
                what: "bundled".into(),
                reason,
            })
    }

    /// Loads a model file (safetensors with its config in the metadata). An `Error::Io` when
    /// the file cannot be read, otherwise the errors of [`NeuralModel::from_bytes`] (a
    /// `Error::Model` then names the path).
    pub fn load(path: &Path) -> Result<NeuralModel> {
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&bytes).map_err(|e| match e {
            Error::Model { reason, .. } => Error::Model {
                what: path.display().to_string(),
                reason,
            },
            other => other,
        })
    }

    /// A model from the bytes of a safetensors file. An `Error::Model` when they are not
    /// safetensors, the config entry is missing or unreadable, or a tensor the config needs is
    /// missing or misshapen; an `Error::InvalidParameter` when the config's sizes do not fit.
    pub fn from_bytes(bytes: &[u8]) -> Result<NeuralModel> {
        let config = read_config(bytes)?;
        let tensors = candle_core::safetensors::load_buffer(bytes, &Device::Cpu).map_err(|e| {
            Error::Model {
                what: "weights".into(),
                reason: e.to_string(),
            }
        })?;
        let network = Network::build(&config, &ParamBuilder::stored(&tensors))?;
        Ok(NeuralModel { network })
    }

    /// A freshly initialized model and its trainable variables (named as in the file).
    pub fn fresh(config: &NetworkConfig, seed: u64) -> Result<(NeuralModel, Vec<(String, Var)>)> {
        let builder = ParamBuilder::fresh(seed);
        let network = Network::build(config, &builder)?;
        Ok((NeuralModel { network }, builder.into_vars()))
    }

    /// The network.
    pub fn network(&self) -> &Network {
        &self.network
    }

    /// The network's architecture.
    pub fn config(&self) -> &NetworkConfig {
        self.network.config()
    }
}

fn read_config(bytes: &[u8]) -> Result<NetworkConfig> {
    let bad = |reason: String| Error::Model {
        what: "weights".into(),
        reason,
    };
    let (_, metadata) = safetensors::SafeTensors::read_metadata(bytes)
        .map_err(|e| bad(format!("not a safetensors file: {e}")))?;
    let json = metadata
        .metadata()
        .as_ref()
        .and_then(|m| m.get(CONFIG_KEY))
        .ok_or_else(|| bad(format!("no `{CONFIG_KEY}` entry in the metadata")))?;
    let config: NetworkConfig =
        serde_json::from_str(json).map_err(|e| bad(format!("bad network config: {e}")))?;
    config.validate()?;
    Ok(config)
}

/// Writes named tensors and the config into one safetensors file (atomically: a temporary file
/// renamed over the target, so a killed writer never leaves half a model).
pub fn save_tensors(
    path: &Path,
    config: &NetworkConfig,
    tensors: &[(String, Tensor)],
    extra_metadata: &[(&str, String)],
) -> Result<()> {
    let mut metadata = HashMap::new();
    metadata.insert(
        CONFIG_KEY.to_string(),
        serde_json::to_string(config).expect("a config serializes"),
    );
    for (key, value) in extra_metadata {
        metadata.insert(key.to_string(), value.clone());
    }
    let io = |source| Error::Io {
        path: path.to_path_buf(),
        source,
    };
    let tmp = path.with_extension("safetensors.tmp");
    let views = tensors.iter().map(|(name, t)| (name.clone(), t));
    safetensors::serialize_to_file(views, Some(metadata), &tmp)
        .map_err(|e| io(std::io::Error::other(e.to_string())))?;
    std::fs::rename(&tmp, path).map_err(io)
}

/// Reads the tensors and the extra metadata of a file written by [`save_tensors`].
pub fn load_tensors(path: &Path) -> Result<(HashMap<String, Tensor>, HashMap<String, String>)> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let (_, metadata) =
        safetensors::SafeTensors::read_metadata(&bytes).map_err(|e| Error::Model {
            what: path.display().to_string(),
            reason: e.to_string(),
        })?;
    let tensors = candle_core::safetensors::load_buffer(&bytes, &Device::Cpu)?;
    Ok((tensors, metadata.metadata().clone().unwrap_or_default()))
}
