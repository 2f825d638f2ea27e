//! Self-supervised training of the neural skinning field (PISSL) on shapes generated in code.

mod losses;
mod optim;
mod shapes;
mod trainer;

pub use shapes::{dataset, DatasetSpec, GeneratedShape, ShapeFamily, ShapeSample};
pub use trainer::{train, train_from, Combine, LogLine, TrainingConfig, TrainingSummary};
