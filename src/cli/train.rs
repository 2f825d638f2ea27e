//! `physskin train`: self-supervised training of the neural skinning field.

use std::path::{Path, PathBuf};

use crate::training::{train_from, Combine, TrainingConfig};
use crate::{Error, Result};

#[derive(clap::Args)]
pub struct TrainArgs {
    /// Training config (JSON); defaults to the shipped model's, config/training.json.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Output directory: checkpoint.safetensors, log.jsonl, model.safetensors (the last step)
    /// and best.safetensors (the checkpoint with the best held-out fields). A checkpoint there
    /// is resumed.
    #[arg(long, default_value = "target/train")]
    out: PathBuf,
    /// Start from this model's weights (fine-tuning: a fresh optimizer and schedule); ignored
    /// when the output directory holds a checkpoint to resume.
    #[arg(long)]
    init: Option<PathBuf>,
    /// Override the number of steps.
    #[arg(long)]
    steps: Option<usize>,
    /// Stop (checkpointed) after this many minutes; run again to resume.
    #[arg(long)]
    max_minutes: Option<f64>,
    /// Ablation: no output normalization.
    #[arg(long)]
    no_normalization: bool,
    /// Ablation: a plain last layer instead of ONI.
    #[arg(long)]
    no_oni: bool,
    /// Ablation: the weighted sum of the losses instead of ConFIG.
    #[arg(long)]
    no_config: bool,
    /// Ablation: without L_orth.
    #[arg(long)]
    no_orth: bool,
    /// Ablation: without L_smooth.
    #[arg(long)]
    no_smooth: bool,
}

pub fn run(args: TrainArgs) -> Result<()> {
    let mut config = match &args.config {
        Some(path) => read_config(path)?,
        None => TrainingConfig::shipped(),
    };
    if let Some(steps) = args.steps {
        config.steps = steps;
    }
    config.normalize &= !args.no_normalization;
    if args.no_oni {
        config.network.oni_iterations = 0;
    }
    if args.no_config {
        config.combine = Combine::WeightedSum;
    }
    config.orth_loss &= !args.no_orth;
    config.smooth_loss &= !args.no_smooth;
    let summary = train_from(
        &config,
        &args.out,
        args.max_minutes.map(|m| m * 60.0),
        args.init.as_deref(),
    )?;
    println!(
        "{} of {} steps in {:.0} s; model: {}",
        summary.steps_done,
        config.steps,
        summary.seconds,
        summary.model_path.display()
    );
    if let Some((step, path)) = &summary.best {
        println!(
            "best held-out fields (highest H_spec) at step {step}: {}",
            path.display()
        );
    }
    if let Some(last) = summary.last {
        println!(
            "{}",
            serde_json::to_string(&last).expect("a log line serializes")
        );
    }
    Ok(())
}

fn read_config(path: &Path) -> Result<TrainingConfig> {
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|e| Error::InvalidParameter {
        name: "config",
        reason: format!("{}: {e}", path.display()),
    })
}
