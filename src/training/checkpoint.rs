//! Checkpoints and model files of a training run: the network's weights, Adam's moments and
//! the loss momenta written at a step, and read back so a resumed run continues exactly.

use std::collections::HashMap;
use std::path::Path;

use candle_core::Tensor;

use super::config::TrainingConfig;
use super::optim::{Adam, LossMomenta};
use crate::skinning::{load_tensors, save_tensors, NetworkConfig, CONFIG_KEY};
use crate::{Error, Result};

/// The network's weights after `step` steps, loadable as a model.
pub(super) fn save_model(
    path: &Path,
    config: &TrainingConfig,
    adam: &Adam,
    step: usize,
) -> Result<()> {
    let params: Vec<(String, Tensor)> = adam
        .vars
        .iter()
        .map(|(name, var)| (name.clone(), var.as_tensor().detach()))
        .collect();
    save_tensors(
        path,
        &config.network,
        &params,
        &[("physskin.training_steps", step.to_string())],
    )
}

pub(super) fn save_checkpoint(
    path: &Path,
    config: &TrainingConfig,
    adam: &Adam,
    momenta: &LossMomenta,
    step: usize,
) -> Result<()> {
    let mut tensors = Vec::new();
    for (i, m) in momenta.values.iter().enumerate() {
        if let Some(m) = m {
            tensors.push((format!("momentum.{i}"), m.clone()));
        }
    }
    for (i, (name, var)) in adam.vars.iter().enumerate() {
        tensors.push((name.clone(), var.as_tensor().detach()));
        tensors.push((format!("adam.first.{name}"), adam.first[i].clone()));
        tensors.push((format!("adam.second.{name}"), adam.second[i].clone()));
    }
    save_tensors(
        path,
        &config.network,
        &tensors,
        &[
            ("physskin.step", step.to_string()),
            ("physskin.adam_steps", adam.steps.to_string()),
            (
                "physskin.momentum_updates",
                serde_json::to_string(&momenta.updates).expect("counts serialize"),
            ),
            (
                "physskin.training_config",
                serde_json::to_string(config).expect("a config serializes"),
            ),
        ],
    )
}

/// Sets every variable from a model file with the same network config.
pub(super) fn initialize(path: &Path, network: &NetworkConfig, adam: &Adam) -> Result<()> {
    let (tensors, metadata) = load_tensors(path)?;
    let bad = |reason: String| Error::Model {
        what: path.display().to_string(),
        reason,
    };
    let saved: Option<NetworkConfig> = metadata
        .get(CONFIG_KEY)
        .and_then(|json| serde_json::from_str(json).ok());
    if saved.as_ref() != Some(network) {
        return Err(bad(
            "its network config differs from the training config's".into()
        ));
    }
    for (name, var) in &adam.vars {
        var.set(&tensor_like(&tensors, name, var.as_tensor()).map_err(bad)?)?;
    }
    Ok(())
}

/// The tensor `name` of a loaded file, which must have the shape of `like`; else why not.
fn tensor_like(
    tensors: &HashMap<String, Tensor>,
    name: &str,
    like: &Tensor,
) -> std::result::Result<Tensor, String> {
    let t = tensors
        .get(name)
        .ok_or_else(|| format!("no tensor `{name}`"))?;
    if t.dims() != like.dims() {
        return Err(format!("tensor `{name}` has the wrong shape"));
    }
    Ok(t.clone())
}

/// Loads a checkpoint into `adam`; its config must match the run's except for the step count
/// and logging, so a run can be extended.
pub(super) fn restore(
    path: &Path,
    config: &TrainingConfig,
    adam: &mut Adam,
    momenta: &mut LossMomenta,
) -> Result<usize> {
    let (tensors, metadata) = load_tensors(path)?;
    let bad = |reason: String| Error::Model {
        what: path.display().to_string(),
        reason,
    };
    let saved: TrainingConfig = metadata
        .get("physskin.training_config")
        .and_then(|json| serde_json::from_str(json).ok())
        .ok_or_else(|| bad("no training config in the checkpoint".into()))?;
    let comparable = |c: &TrainingConfig| TrainingConfig {
        steps: 0,
        checkpoint_every: 0,
        log_every: 0,
        ..c.clone()
    };
    if comparable(&saved) != comparable(config) {
        return Err(bad("the checkpoint was trained with another config (only steps and logging may change); train into another directory".into()));
    }
    let number = |key: &str| -> Result<usize> {
        metadata
            .get(key)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| bad(format!("no `{key}` in the checkpoint")))
    };
    let get = |name: &str, like: &Tensor| tensor_like(&tensors, name, like).map_err(bad);
    for (i, (name, var)) in adam.vars.iter().enumerate() {
        var.set(&get(name, var.as_tensor())?)?;
        adam.first[i] = get(&format!("adam.first.{name}"), var.as_tensor())?;
        adam.second[i] = get(&format!("adam.second.{name}"), var.as_tensor())?;
    }
    adam.steps = number("physskin.adam_steps")?;
    momenta.updates = metadata
        .get("physskin.momentum_updates")
        .and_then(|v| serde_json::from_str(v).ok())
        .filter(|u: &Vec<usize>| u.len() == momenta.values.len())
        .ok_or_else(|| bad("no momentum counts in the checkpoint".into()))?;
    for (i, m) in momenta.values.iter_mut().enumerate() {
        *m = tensors.get(&format!("momentum.{i}")).cloned();
    }
    number("physskin.step")
}
