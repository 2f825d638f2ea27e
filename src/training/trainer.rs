//! The training loop: generated shapes, the PISSL losses combined by ConFIG, Adam with warm-up
//! and cosine decay, a progress bar, JSON-lines log, and checkpoints that resume exactly.

use std::collections::HashMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use candle_core::{Device, Tensor};
use nalgebra::Vector3;
use rand::seq::IndexedRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::losses::{self, Batch, LossOptions};
use super::optim::{config_combine, learning_rate, Adam, LossMomenta};
use super::shapes::{dataset, DatasetSpec, ShapeSample};
use crate::geometry::SurfaceSamples;
use crate::skinning::{
    load_tensors, save_tensors, FieldMetrics, NetworkConfig, NeuralModel, SkinningField, CONFIG_KEY,
};
use crate::{Error, Result};

/// How the loss gradients become one update.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Combine {
    /// ConFIG: a direction with equal cosine to every loss gradient (one backward pass per loss
    /// and step).
    Config,
    /// M-ConFIG: one loss's gradient per step in turn, each kept as a momentum, the momenta
    /// combined by ConFIG. One backward pass per step: 2.5x faster per step on this machine.
    MomentumConfig,
    /// The weighted sum of the losses (the ablation).
    WeightedSum,
}

/// Everything a training run depends on; saved in every checkpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrainingConfig {
    pub network: NetworkConfig,
    /// Seed of the initialization, the dataset and every step's draws. Default 7.
    pub seed: u64,
    /// Optimizer steps (one shape each). Default 6000.
    pub steps: usize,
    /// Peak learning rate after warm-up. Default 5e-4.
    pub peak_learning_rate: f64,
    /// Learning rate at the end of the cosine decay. Default 5e-5.
    pub final_learning_rate: f64,
    /// Share of the steps spent warming up linearly. Default 0.01.
    pub warmup_fraction: f64,
    /// Generated shapes, training and held-out together. Default 384.
    pub shapes: usize,
    /// Every this many shapes of a family is held out. Default 8.
    pub held_out_every: usize,
    /// Surface points the encoder sees. Default 4096.
    pub surface_points: usize,
    /// Cubature points per step (three quarters inside, one quarter on the surface). Default 512.
    pub cubature_points: usize,
    /// Young's modulus and Poisson ratio of the training energy (normalized units). Defaults 1, 0.45.
    pub young: f64,
    pub poisson: f64,
    /// Standard deviation of the random handle translations. Default 0.2.
    pub z_std: f64,
    /// Standard deviation of the random handle matrices; `None` (the default, the paper's
    /// choice) draws them like the translations. 0 trains on the Dirichlet energy of the weights
    /// alone, the objective of the skinning eigenmodes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z_linear_std: Option<f64>,
    /// The Neo-Hookean share of the energy at the last step; it grows linearly from 0 over the
    /// run. Default 1 (the paper: linear to Neo-Hookean).
    pub final_blend: f64,
    /// Transforms drawn per step for the Neo-Hookean part. Default 4.
    pub z_samples: usize,
    /// Combine the loss gradients by ConFIG (default) or a weighted sum.
    pub combine: Combine,
    /// Weights of the weighted sum (ConFIG only uses the directions). Defaults 1, 1e-3, 1e3.
    pub potential_weight: f64,
    pub smooth_weight: f64,
    pub orth_weight: f64,
    /// Ablation switches, all on by default.
    pub normalize: bool,
    pub smooth_loss: bool,
    pub orth_loss: bool,
    /// Steps between checkpoints (and held-out evaluations). Default 250.
    pub checkpoint_every: usize,
    /// Steps between log lines. Default 25.
    pub log_every: usize,
}

impl Default for TrainingConfig {
    fn default() -> Self {
        Self {
            network: NetworkConfig::default(),
            seed: 7,
            steps: 6000,
            peak_learning_rate: 5e-4,
            final_learning_rate: 5e-5,
            warmup_fraction: 0.01,
            shapes: 384,
            held_out_every: 8,
            surface_points: 4096,
            cubature_points: 512,
            young: 1.0,
            poisson: 0.45,
            z_std: 0.2,
            z_linear_std: None,
            final_blend: 1.0,
            z_samples: 4,
            combine: Combine::MomentumConfig,
            potential_weight: 1.0,
            smooth_weight: 1e-3,
            orth_weight: 1e3,
            normalize: true,
            smooth_loss: true,
            orth_loss: true,
            checkpoint_every: 250,
            log_every: 25,
        }
    }
}

impl TrainingConfig {
    /// The config the bundled model was trained with (config/training.json).
    pub fn shipped() -> TrainingConfig {
        serde_json::from_str(include_str!("../../config/training.json"))
            .expect("the shipped training config parses")
    }

    pub fn dataset(&self) -> DatasetSpec {
        DatasetSpec {
            seed: self.seed,
            count: self.shapes,
            held_out_every: self.held_out_every,
        }
    }
}

/// One line of the training log (log.jsonl).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LogLine {
    pub step: usize,
    pub learning_rate: f64,
    pub potential: f64,
    pub smooth: f64,
    pub orth: f64,
    /// Omega_orth of the batch (learned columns).
    pub batch_omega: f64,
    pub seconds: f64,
    /// Held-out means, at checkpoints only.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub held_out: Option<FieldMetrics>,
}

/// What a finished (or stopped) run reports.
#[derive(Clone, Debug)]
pub struct TrainingSummary {
    pub steps_done: usize,
    pub seconds: f64,
    pub last: Option<LogLine>,
    pub model_path: PathBuf,
    /// The checkpoint with the highest held-out H_spec so far, and its step.
    pub best: Option<(usize, PathBuf)>,
}

const CHECKPOINT: &str = "checkpoint.safetensors";
const MODEL: &str = "model.safetensors";
/// The weights of the checkpoint whose held-out fields were best (highest H_spec): a long run's
/// last step need not be its best (a 14,000-step run degenerated a column past mid-blend).
const BEST: &str = "best.safetensors";
const LOG: &str = "log.jsonl";

/// Trains into `dir` (checkpoint, log, final model), resuming from its checkpoint when there is
/// one with the same config. Stops early, checkpointed, after `max_seconds` if given.
pub fn train(
    config: &TrainingConfig,
    dir: &Path,
    max_seconds: Option<f64>,
) -> Result<TrainingSummary> {
    train_from(config, dir, max_seconds, None)
}

/// [`train`], starting from the weights of the model file `init` (fine-tuning: a fresh optimizer
/// and schedule) unless `dir` holds a checkpoint to resume.
pub fn train_from(
    config: &TrainingConfig,
    dir: &Path,
    max_seconds: Option<f64>,
    init: Option<&Path>,
) -> Result<TrainingSummary> {
    config.network.validate()?;
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let (train_shapes, held_shapes) = dataset(&config.dataset());
    let started = Instant::now();
    let sample = |(i, shape): (usize, &super::shapes::GeneratedShape)| {
        let mut rng = ChaCha8Rng::seed_from_u64(config.seed ^ (0x5eed_0000 + i as u64));
        shape.sample(config.surface_points, 8192, &mut rng)
    };
    let train_samples: Vec<ShapeSample> = train_shapes.par_iter().enumerate().map(sample).collect();
    let held_samples: Vec<ShapeSample> = held_shapes
        .par_iter()
        .take(16)
        .enumerate()
        .map(sample)
        .collect();
    eprintln!(
        "{} training shapes, {} held out (first {} evaluated), sampled in {:.1} s",
        train_samples.len(),
        held_shapes.len(),
        held_samples.len(),
        started.elapsed().as_secs_f64()
    );

    let (model, vars) = NeuralModel::fresh(&config.network, config.seed)?;
    let mut adam = Adam::new(vars)?;
    let loss_count = 1 + usize::from(config.smooth_loss) + usize::from(config.orth_loss);
    let mut momenta = LossMomenta::new(loss_count);
    let checkpoint = dir.join(CHECKPOINT);
    let mut start = 0;
    if checkpoint.exists() {
        start = restore(&checkpoint, config, &mut adam, &mut momenta)?;
        eprintln!("resuming from {} at step {start}", checkpoint.display());
    } else if let Some(init) = init {
        initialize(init, &config.network, &adam)?;
        eprintln!("starting from the weights of {}", init.display());
    }
    eprintln!("{} parameters", adam.parameter_count());
    let mut log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(LOG))
        .map_err(io(&dir.join(LOG)))?;
    let mut best = best_in_log(dir, start);
    let bar = progress_bar(config.steps, start);
    let run_started = Instant::now();
    let mut last = None;
    let mut sums = [0.0f64; 4];
    let mut summed = 0usize;
    let mut step = start;
    while step < config.steps {
        let mut rng = step_rng(config.seed, step);
        let shape = train_samples
            .choose(&mut rng)
            .expect("the dataset has training shapes");
        let batch = batch_of(shape, config.cubature_points, &mut rng)?;
        let options = LossOptions {
            young: config.young,
            poisson: config.poisson,
            z_std: config.z_std,
            z_linear_std: config.z_linear_std.unwrap_or(config.z_std),
            z_samples: config.z_samples,
            blend: config.final_blend * step as f64 / config.steps.max(1) as f64,
            normalize: config.normalize,
        };
        let l = losses::compute(model.network(), &batch, &options, &mut rng)?;
        let mut active = vec![l.potential.clone()];
        if config.smooth_loss {
            active.push(l.smooth.clone());
        }
        if config.orth_loss {
            active.push((&l.orth * config.orth_weight)?);
        }
        let gradient = match config.combine {
            Combine::Config => {
                let parts = active
                    .iter()
                    .map(|loss| adam.flat_gradient(loss))
                    .collect::<Result<Vec<_>>>()?;
                config_combine(&parts)?
            }
            Combine::MomentumConfig => {
                let turn = step % active.len();
                let gradient = adam.flat_gradient(&active[turn])?;
                momenta.update(turn, &gradient)?;
                config_combine(&momenta.corrected()?)?
            }
            Combine::WeightedSum => {
                let mut total = (&l.potential * config.potential_weight)?;
                if config.smooth_loss {
                    total = (total + (&l.smooth * config.smooth_weight)?)?;
                }
                if config.orth_loss {
                    total = (total + (&l.orth * config.orth_weight)?)?;
                }
                adam.flat_gradient(&total)?
            }
        };
        let rate = learning_rate(
            step,
            config.steps,
            config.peak_learning_rate,
            config.final_learning_rate,
            config.warmup_fraction,
        );
        adam.step(&gradient, rate)?;
        let k = config.network.handles as f64;
        let values = [
            l.potential.to_scalar::<f32>()? as f64,
            l.smooth.to_scalar::<f32>()? as f64,
            l.orth.to_scalar::<f32>()? as f64,
            l.orth.to_scalar::<f32>()? as f64 / (k * (k - 1.0)),
        ];
        if values.iter().any(|v| !v.is_finite()) {
            return Err(Error::Model {
                what: "training".into(),
                reason: format!("a loss is not finite at step {step}: {values:?}; the last checkpoint is intact"),
            });
        }
        for (s, v) in sums.iter_mut().zip(values) {
            *s += v;
        }
        summed += 1;
        step += 1;
        bar.set_position(step as u64);
        let out_of_time =
            max_seconds.is_some_and(|limit| run_started.elapsed().as_secs_f64() > limit);
        let at_checkpoint =
            step % config.checkpoint_every == 0 || step == config.steps || out_of_time;
        if step % config.log_every == 0 || at_checkpoint {
            let mean = sums.map(|s| s / summed as f64);
            let line = LogLine {
                step,
                learning_rate: rate,
                potential: mean[0],
                smooth: mean[1],
                orth: mean[2],
                batch_omega: mean[3],
                seconds: run_started.elapsed().as_secs_f64(),
                held_out: if at_checkpoint {
                    Some(held_out_metrics(&model, &held_samples)?)
                } else {
                    None
                },
            };
            let message = describe(&line);
            bar.set_message(message.clone());
            if !std::io::stderr().is_terminal() {
                eprintln!("step {step}/{}: {message}", config.steps);
            }
            writeln!(
                log,
                "{}",
                serde_json::to_string(&line).expect("a log line serializes")
            )
            .map_err(io(&dir.join(LOG)))?;
            sums = [0.0; 4];
            summed = 0;
            last = Some(line);
        }
        if at_checkpoint {
            // The best weights are written before the checkpoint: a run killed between the two
            // resumes from the older checkpoint, whose log lines cannot claim a best never kept.
            let h_spec = last
                .as_ref()
                .and_then(|l| l.held_out.as_ref())
                .map(|m| m.h_spec);
            if let Some(h_spec) = h_spec.filter(|h| best.is_none_or(|(_, b)| *h > b)) {
                save_model(&dir.join(BEST), config, &adam, step)?;
                best = Some((step, h_spec));
            }
            save_checkpoint(&checkpoint, config, &adam, &momenta, step)?;
        }
        if out_of_time {
            break;
        }
    }
    bar.finish();
    let model_path = dir.join(MODEL);
    save_model(&model_path, config, &adam, step)?;
    Ok(TrainingSummary {
        steps_done: step,
        seconds: run_started.elapsed().as_secs_f64(),
        last,
        model_path,
        best: best.map(|(step, _)| (step, dir.join(BEST))),
    })
}

/// The network's weights after `step` steps, loadable as a model.
fn save_model(path: &Path, config: &TrainingConfig, adam: &Adam, step: usize) -> Result<()> {
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

/// The best checkpoint (step, held-out H_spec) up to `start` that the log records, when its
/// weights were kept: a resumed run keeps comparing against it.
fn best_in_log(dir: &Path, start: usize) -> Option<(usize, f64)> {
    if !dir.join(BEST).exists() {
        return None;
    }
    let text = std::fs::read_to_string(dir.join(LOG)).ok()?;
    text.lines()
        .filter_map(|line| serde_json::from_str::<LogLine>(line).ok())
        .filter(|line| line.step <= start)
        .filter_map(|line| Some((line.step, line.held_out?.h_spec)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

fn describe(line: &LogLine) -> String {
    let mut text = format!(
        "lr {:.2e} pot {:.4e} smooth {:.3e} orth {:.3e} omega {:.2e}",
        line.learning_rate, line.potential, line.smooth, line.orth, line.batch_omega
    );
    if let Some(m) = &line.held_out {
        text += &format!(
            " | held-out omega {:.3e} kappa {:.4} h {:.5}",
            m.omega_orth, m.kappa_log, m.h_spec
        );
    }
    text
}

fn progress_bar(total: usize, start: usize) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:30} {pos}/{len} [{elapsed_precise}<{eta_precise}] {msg}",
        )
        .expect("a valid template"),
    );
    bar.set_position(start as u64);
    bar
}

/// Each step's draws come from its own generator, so a resumed run repeats them exactly.
fn step_rng(seed: u64, step: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ step as u64)
}

fn batch_of(shape: &ShapeSample, count: usize, rng: &mut impl Rng) -> Result<Batch> {
    let inside = count * 3 / 4;
    let mut cubature: Vec<Vector3<f32>> = shape
        .interior_points
        .choose_multiple(rng, inside)
        .copied()
        .collect();
    cubature.extend(
        shape
            .surface_points
            .choose_multiple(rng, count - inside)
            .copied(),
    );
    let tensor = |points: &[Vector3<f32>]| {
        let flat: Vec<f32> = points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        Tensor::from_vec(flat, (points.len(), 3), &Device::Cpu)
    };
    Ok(Batch {
        surface: tensor(&shape.surface_points)?,
        normals: tensor(&shape.surface_normals)?,
        cubature: tensor(&cubature)?,
        volume: shape.volume,
    })
}

/// Mean metrics of the network's output (before the product's whitening) on held-out shapes: normalized over the first half of
/// the interior points, measured on the second half (points the normalization never saw).
fn held_out_metrics(model: &NeuralModel, shapes: &[ShapeSample]) -> Result<FieldMetrics> {
    let model = Arc::new(model.clone());
    let mut sum = [0.0; 3];
    for shape in shapes {
        let (field, points) = field_of_sample(&model, shape)?;
        let m = FieldMetrics::of(&field.network_output(&points)?, field.handle_count());
        sum[0] += m.omega_orth;
        sum[1] += m.kappa_log;
        sum[2] += m.h_spec;
    }
    let n = shapes.len().max(1) as f64;
    Ok(FieldMetrics {
        omega_orth: sum[0] / n,
        kappa_log: sum[1] / n,
        h_spec: sum[2] / n,
    })
}

/// The learned field of a generated sample and the evaluation points it was not normalized on.
pub(crate) fn field_of_sample(
    model: &Arc<NeuralModel>,
    shape: &ShapeSample,
) -> Result<(crate::skinning::NeuralField, Vec<Vector3<f64>>)> {
    let to64 = |p: &Vector3<f32>| p.cast::<f64>();
    let surface = SurfaceSamples {
        points: shape.surface_points.iter().map(to64).collect(),
        normals: shape.surface_normals.iter().map(to64).collect(),
        areas: Vec::new(),
    };
    let half = shape.interior_points.len() / 2;
    let reference: Vec<Vector3<f64>> = shape.interior_points[..half].iter().map(to64).collect();
    let points: Vec<Vector3<f64>> = shape.interior_points[half..].iter().map(to64).collect();
    let field = model.field(&surface, &reference, shape.normalization)?;
    Ok((field, points))
}

fn save_checkpoint(
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
fn initialize(path: &Path, network: &NetworkConfig, adam: &Adam) -> Result<()> {
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
fn restore(
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skinning::NetworkConfig;

    #[test]
    fn the_fine_tuning_configs_parse_and_fit_the_shipped_network() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/fine_tune");
        let mut count = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            let config: TrainingConfig =
                serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(
                config.network,
                TrainingConfig::shipped().network,
                "{}",
                path.display()
            );
            count += 1;
        }
        assert_eq!(count, 4);
    }

    /// The three losses of `model` on fixed held-out batches, linear elasticity only (so the
    /// training's blend towards Neo-Hookean does not move the goalposts).
    fn fixed_losses(model: &NeuralModel, shapes: &[ShapeSample]) -> [f64; 3] {
        let mut sums = [0.0; 3];
        for (i, shape) in shapes.iter().enumerate() {
            let mut rng = ChaCha8Rng::seed_from_u64(100 + i as u64);
            let batch = batch_of(shape, 256, &mut rng).unwrap();
            let options = LossOptions {
                young: 1.0,
                poisson: 0.45,
                z_std: 0.2,
                z_linear_std: 0.2,
                z_samples: 1,
                blend: 0.0,
                normalize: true,
            };
            let l = losses::compute(model.network(), &batch, &options, &mut rng).unwrap();
            for (s, t) in sums.iter_mut().zip([&l.potential, &l.smooth, &l.orth]) {
                *s += t.to_scalar::<f32>().unwrap() as f64;
            }
        }
        sums
    }

    #[test]
    fn a_short_run_lowers_every_loss_and_resumes() {
        let config = TrainingConfig {
            network: NetworkConfig {
                width: 32,
                latents: 16,
                self_blocks: 1,
                handles: 6,
                head_width: 32,
                head_blocks: 2,
                ..Default::default()
            },
            steps: 90,
            shapes: 16,
            held_out_every: 2,
            surface_points: 512,
            cubature_points: 256,
            checkpoint_every: 45,
            log_every: 15,
            ..Default::default()
        };
        let dir = std::env::temp_dir().join(format!("physskin-train-test-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let (_, held) = dataset(&config.dataset());
        let held: Vec<ShapeSample> = held
            .iter()
            .take(4)
            .map(|s| s.sample(512, 1024, &mut ChaCha8Rng::seed_from_u64(1)))
            .collect();
        let (fresh, _) = NeuralModel::fresh(&config.network, config.seed).unwrap();
        let before = fixed_losses(&fresh, &held);

        // Stopped after the first checkpoint, then resumed to the end.
        let first = train(
            &TrainingConfig {
                steps: 45,
                ..config.clone()
            },
            &dir,
            None,
        )
        .unwrap();
        assert_eq!(first.steps_done, 45);
        let done = train(&config, &dir, None).unwrap();
        assert_eq!(done.steps_done, 90);
        let trained = NeuralModel::load(&done.model_path).unwrap();
        let after = fixed_losses(&trained, &held);
        for (name, (b, a)) in ["potential", "smooth", "orth"]
            .iter()
            .zip(before.iter().zip(&after))
        {
            assert!(a < b, "{name}: {b} before, {a} after training");
        }
        // The kept best is the checkpoint (of both runs) with the highest held-out H_spec.
        let held_out: Vec<(usize, f64)> = std::fs::read_to_string(dir.join(LOG))
            .unwrap()
            .lines()
            .map(|l| serde_json::from_str::<LogLine>(l).unwrap())
            .filter_map(|l| Some((l.step, l.held_out?.h_spec)))
            .collect();
        assert_eq!(held_out.iter().map(|c| c.0).collect::<Vec<_>>(), [45, 90]);
        let top = held_out.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        let (best_step, best_path) = done.best.expect("a best checkpoint");
        assert_eq!(best_step, top.0, "{held_out:?}");
        NeuralModel::load(&best_path).expect("the best checkpoint loads");
        let steps_of = |path: &Path| {
            let bytes = std::fs::read(path).unwrap();
            let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
            meta.metadata().as_ref().unwrap()["physskin.training_steps"].clone()
        };
        assert_eq!(steps_of(&best_path), best_step.to_string());

        // A fine-tuning run starts from the trained weights, not from a fresh initialization:
        // with no steps to take it ends with exactly them.
        let tune_dir = dir.join("fine-tune");
        let tuned = train_from(
            &TrainingConfig {
                steps: 0,
                ..config.clone()
            },
            &tune_dir,
            None,
            Some(&done.model_path),
        )
        .unwrap();
        let weights = |path: &Path| load_tensors(path).unwrap().0;
        let (start, end) = (weights(&done.model_path), weights(&tuned.model_path));
        assert_eq!(start.len(), end.len());
        for (name, t) in &start {
            let difference = (t - &end[name]).unwrap().abs().unwrap().max_all().unwrap();
            assert_eq!(difference.to_scalar::<f32>().unwrap(), 0.0, "{name}");
        }
        // Weights of another network are refused by name.
        let other = TrainingConfig {
            network: NetworkConfig {
                handles: 5,
                ..config.network.clone()
            },
            steps: 0,
            ..config.clone()
        };
        let refused = train_from(&other, &dir.join("other"), None, Some(&done.model_path))
            .unwrap_err()
            .to_string();
        assert!(refused.contains("network config differs"), "{refused}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
