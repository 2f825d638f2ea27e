//! Self-supervised training of the neural skinning field (PISSL) on shapes generated in code.

mod checkpoint;
mod config;
mod families;
mod losses;
mod optim;
mod sdf;
mod shapes;
mod trainer;

pub use config::{Combine, TrainingConfig};
pub use shapes::dataset;
pub use trainer::train_from;
