//! The neural skinning field: a small perceiver autoencoder in candle that predicts a shape's
//! skinning weights in one forward pass (PhysSkin, section 3).

mod field;
mod inference_ops;
mod layers;
mod model;
mod network;
mod params;

pub use field::NeuralField;
pub use model::NeuralModel;
pub use network::{ColumnNormalization, Network, NetworkConfig};

pub use layers::inverse_sqrt;
pub use model::{load_tensors, save_tensors, CONFIG_KEY};
