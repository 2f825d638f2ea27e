//! The training loop: generated shapes, the PISSL losses combined by ConFIG, Adam with warm-up
//! and cosine decay, a progress bar, JSON-lines log, and checkpoints that resume exactly.

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

use super::checkpoint::{initialize, restore, save_checkpoint, save_model};
use super::config::{Combine, TrainingConfig};
use super::losses::{self, Batch, LossOptions, Losses};
use super::optim::{config_combine, learning_rate, Adam, LossMomenta};
use super::shapes::{dataset, ShapeSample};
use crate::geometry::SurfaceSamples;
use crate::skinning::{FieldMetrics, NeuralModel, SkinningField};
use crate::{Error, Result};

/// One line of the training log (log.jsonl).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LogLine {
    /// Steps done when the line was written.
    pub step: usize,
    /// Learning rate of the line's last step.
    pub learning_rate: f64,
    /// Mean L_pot (the elastic potential loss) over the steps since the last line.
    pub potential: f64,
    /// Mean L_smooth over the steps since the last line.
    pub smooth: f64,
    /// Mean L_orth over the steps since the last line (before `orth_weight`).
    pub orth: f64,
    /// Omega_orth of the batch (learned columns).
    pub batch_omega: f64,
    /// Wall seconds since this call of the trainer started (a resumed run counts anew).
    pub seconds: f64,
    /// Held-out means, at checkpoints only.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub held_out: Option<FieldMetrics>,
}

/// What a finished (or stopped) run reports.
#[derive(Clone, Debug)]
pub struct TrainingSummary {
    /// Steps done, those of a resumed checkpoint included.
    pub steps_done: usize,
    /// Wall time of this call, s.
    pub seconds: f64,
    /// The last log line written; None when no step was taken.
    pub last: Option<LogLine>,
    /// The final model file, `model.safetensors` in the run's directory.
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
/// one with the same config; stops early, checkpointed, after `max_seconds` if given. Starts from the weights of the model file `init` (fine-tuning: a fresh optimizer
/// and schedule) unless `dir` holds a checkpoint to resume.
pub fn train_from(
    config: &TrainingConfig,
    dir: &Path,
    max_seconds: Option<f64>,
    init: Option<&Path>,
) -> Result<TrainingSummary> {
    config.network.validate()?;
    std::fs::create_dir_all(dir).map_err(io_error(dir))?;
    let (train_samples, held_samples) = sample_dataset(config);

    let (model, vars) = NeuralModel::fresh(&config.network, config.seed)?;
    let mut adam = Adam::new(vars)?;
    let loss_count = 1 + usize::from(config.smooth_loss) + usize::from(config.orth_loss);
    let mut momenta = LossMomenta::new(loss_count);
    let checkpoint = dir.join(CHECKPOINT);
    let start = starting_step(&checkpoint, init, config, &mut adam, &mut momenta)?;
    log::info!("{} parameters", adam.parameter_count());
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(LOG))
        .map_err(io_error(&dir.join(LOG)))?;
    // The fields are evaluated in the order the loop's state was set up before it was a struct:
    // the log, the best checkpoint so far, the bar, then the run's clock.
    let mut run = Run {
        config,
        dir,
        model,
        held_samples,
        adam,
        momenta,
        checkpoint,
        log,
        best: best_in_log(dir, start),
        bar: progress_bar(config.steps, start),
        run_started: Instant::now(),
        last: None,
        sums: [0.0f64; 4],
        summed: 0usize,
    };
    let mut step = start;
    while step < config.steps {
        let rate = run.optimize(&train_samples, step)?;
        step += 1;
        run.bar.set_position(step as u64);
        let out_of_time =
            max_seconds.is_some_and(|limit| run.run_started.elapsed().as_secs_f64() > limit);
        let at_checkpoint =
            step % config.checkpoint_every == 0 || step == config.steps || out_of_time;
        if step % config.log_every == 0 || at_checkpoint {
            run.write_log_line(step, rate, at_checkpoint)?;
        }
        if at_checkpoint {
            run.checkpoint_at(step)?;
        }
        if out_of_time {
            break;
        }
    }
    run.bar.finish();
    let model_path = dir.join(MODEL);
    save_model(&model_path, config, &run.adam, step)?;
    Ok(TrainingSummary {
        steps_done: step,
        seconds: run.run_started.elapsed().as_secs_f64(),
        last: run.last,
        model_path,
        best: run.best.map(|(step, _)| (step, dir.join(BEST))),
    })
}

/// Turns an I/O error on `path` into the crate's error, naming the path.
fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> Error {
    let path = path.to_path_buf();
    move |source| Error::Io { path, source }
}

/// The step a run starts from: the checkpoint's, restored into `adam` and `momenta`, when
/// there is one; else 0, from the weights of `init` when given (fine-tuning).
fn starting_step(
    checkpoint: &Path,
    init: Option<&Path>,
    config: &TrainingConfig,
    adam: &mut Adam,
    momenta: &mut LossMomenta,
) -> Result<usize> {
    let mut start = 0;
    if checkpoint.exists() {
        start = restore(checkpoint, config, adam, momenta)?;
        log::info!("resuming from {} at step {start}", checkpoint.display());
    } else if let Some(init) = init {
        initialize(init, &config.network, adam)?;
        log::info!("starting from the weights of {}", init.display());
    }
    Ok(start)
}

/// The training shapes' samples and those of the first 16 held-out shapes, each drawn from a
/// generator of its own so the samples do not depend on the number of threads.
fn sample_dataset(config: &TrainingConfig) -> (Vec<ShapeSample>, Vec<ShapeSample>) {
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
    log::info!(
        "{} training shapes, {} held out (first {} evaluated), sampled in {:.1} s",
        train_samples.len(),
        held_shapes.len(),
        held_samples.len(),
        started.elapsed().as_secs_f64()
    );
    (train_samples, held_samples)
}

/// The losses of `step`: its training shape, cubature batch and transforms all come from the
/// step's own generator.
fn step_losses(
    config: &TrainingConfig,
    model: &NeuralModel,
    train_samples: &[ShapeSample],
    step: usize,
) -> Result<Losses> {
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
    losses::compute(model.network(), &batch, &options, &mut rng)
}

/// The update of `step` from the active losses' gradients, combined as `config.combine` says
/// (M-ConFIG updates the momentum of one loss per step, in turn).
fn combined_gradient(
    config: &TrainingConfig,
    l: &Losses,
    adam: &Adam,
    momenta: &mut LossMomenta,
    step: usize,
) -> Result<Tensor> {
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
    Ok(gradient)
}

/// The step's potential, smooth and orth losses and the batch's Omega_orth, as numbers; an
/// error when one is not finite, which no later step recovers from.
fn loss_values(config: &TrainingConfig, l: &Losses, step: usize) -> Result<[f64; 4]> {
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
            reason: format!(
                "a loss is not finite at step {step}: {values:?}; the last checkpoint is intact"
            ),
        });
    }
    Ok(values)
}

/// A training run between steps: the network and its optimizer, where it writes, and the loss
/// sums of the log line in progress.
struct Run<'a> {
    config: &'a TrainingConfig,
    dir: &'a Path,
    model: NeuralModel,
    held_samples: Vec<ShapeSample>,
    adam: Adam,
    momenta: LossMomenta,
    /// The checkpoint file.
    checkpoint: PathBuf,
    log: std::fs::File,
    /// The best checkpoint so far: (step, held-out H_spec).
    best: Option<(usize, f64)>,
    bar: indicatif::ProgressBar,
    run_started: Instant,
    last: Option<LogLine>,
    /// Sums of the loss values since the last log line, and their count.
    sums: [f64; 4],
    summed: usize,
}

impl Run<'_> {
    /// One optimizer step on a training shape: the step's losses, their combined gradient and
    /// Adam's update at the scheduled rate, the losses summed for the log. Returns the rate.
    fn optimize(&mut self, train_samples: &[ShapeSample], step: usize) -> Result<f64> {
        let config = self.config;
        let l = step_losses(config, &self.model, train_samples, step)?;
        let gradient = combined_gradient(config, &l, &self.adam, &mut self.momenta, step)?;
        let rate = learning_rate(
            step,
            config.steps,
            config.peak_learning_rate,
            config.final_learning_rate,
            config.warmup_fraction,
        );
        self.adam.step(&gradient, rate)?;
        self.add(loss_values(config, &l, step)?);
        Ok(rate)
    }

    /// Adds one step's loss values to the sums of the next log line.
    fn add(&mut self, values: [f64; 4]) {
        for (s, v) in self.sums.iter_mut().zip(values) {
            *s += v;
        }
        self.summed += 1;
    }

    /// Writes the log line of `step`: the means since the last line, and the held-out metrics
    /// at a checkpoint.
    fn write_log_line(&mut self, step: usize, rate: f64, at_checkpoint: bool) -> Result<()> {
        let mean = self.sums.map(|s| s / self.summed as f64);
        let line = LogLine {
            step,
            learning_rate: rate,
            potential: mean[0],
            smooth: mean[1],
            orth: mean[2],
            batch_omega: mean[3],
            seconds: self.run_started.elapsed().as_secs_f64(),
            held_out: if at_checkpoint {
                Some(held_out_metrics(&self.model, &self.held_samples)?)
            } else {
                None
            },
        };
        let message = describe(&line);
        self.bar.set_message(message.clone());
        if !std::io::stderr().is_terminal() {
            log::info!("step {step}/{}: {message}", self.config.steps);
        }
        writeln!(
            self.log,
            "{}",
            serde_json::to_string(&line).expect("a log line serializes")
        )
        .map_err(io_error(&self.dir.join(LOG)))?;
        self.sums = [0.0; 4];
        self.summed = 0;
        self.last = Some(line);
        Ok(())
    }

    /// Keeps the weights when the last line's held-out fields are the best so far, then writes
    /// the checkpoint of `step`.
    fn checkpoint_at(&mut self, step: usize) -> Result<()> {
        // The best weights are written before the checkpoint: a run killed between the two
        // resumes from the older checkpoint, whose log lines cannot claim a best never kept.
        let h_spec = self
            .last
            .as_ref()
            .and_then(|l| l.held_out.as_ref())
            .map(|m| m.h_spec);
        if let Some(h_spec) = h_spec.filter(|h| self.best.is_none_or(|(_, b)| *h > b)) {
            save_model(&self.dir.join(BEST), self.config, &self.adam, step)?;
            self.best = Some((step, h_spec));
        }
        save_checkpoint(
            &self.checkpoint,
            self.config,
            &self.adam,
            &self.momenta,
            step,
        )
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skinning::{load_tensors, NetworkConfig};

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
        let first = train_from(
            &TrainingConfig {
                steps: 45,
                ..config.clone()
            },
            &dir,
            None,
            None,
        )
        .unwrap();
        assert_eq!(first.steps_done, 45);
        let done = train_from(&config, &dir, None, None).unwrap();
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
