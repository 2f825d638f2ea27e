//! What a training run depends on: the network, the dataset, the losses and their
//! combination, the optimizer's schedule and the checkpoint and log cadence. Saved in every
//! checkpoint, so a resumed run can check it trains the same thing.

use serde::{Deserialize, Serialize};

use super::shapes::DatasetSpec;
use crate::skinning::NetworkConfig;

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
    /// The network's sizes. Default `NetworkConfig::default()`.
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
    /// Poisson ratio of the training energy. Default 0.45.
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
    /// Weight of L_smooth in the weighted sum. Default 1e-3.
    pub smooth_weight: f64,
    /// Weight of L_orth in the weighted sum; L_orth is also scaled by it before ConFIG
    /// combines the gradients. Default 1e3.
    pub orth_weight: f64,
    /// Ablation switches, all on by default.
    pub normalize: bool,
    /// Train with L_smooth, the smoothness of the weight columns. Default true.
    pub smooth_loss: bool,
    /// Train with L_orth, the orthogonality of the weight columns. Default true.
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

    /// The dataset this config trains on: its `seed`, `shapes` and `held_out_every`.
    pub fn dataset(&self) -> DatasetSpec {
        DatasetSpec {
            seed: self.seed,
            count: self.shapes,
            held_out_every: self.held_out_every,
        }
    }
}
