//! Skinning weight fields: the `SkinningField` trait and its implementations.

mod eigenmodes;
mod metrics;
mod neural;
pub(crate) mod refine;
mod truncated;

pub(crate) use eigenmodes::linear_gradients;
pub use eigenmodes::{EigenmodeField, EigenmodeOptions};
pub(crate) use metrics::FieldMetrics;
pub(crate) use neural::{inverse_sqrt, load_tensors, save_tensors, CONFIG_KEY};
pub(crate) use neural::{ColumnNormalization, Network, NetworkConfig};
pub use neural::{NeuralField, NeuralModel};
pub use refine::RefineBudget;
pub(crate) use refine::{refine_field, refine_field_until, Refined, DEFAULT_REFINE_MS};
pub(crate) use refine::{RefineOptions, RefineReport};
pub(crate) use truncated::TruncatedField;

use nalgebra::Vector3;

/// Continuous skinning weights W(X) (one column per handle, the constant rigid column included)
/// and their spatial gradients, evaluated at any points of the shape's normalized frame
/// ([-1, 1]^3, see [`crate::geometry::Normalization`]).
///
/// Contract: column 0 is the rigid handle, equal to 1 everywhere, so any rigid motion of the
/// object is exactly the state that moves handle 0 alone.
pub trait SkinningField: Send + Sync {
    /// Number of handles, the constant one included.
    fn handle_count(&self) -> usize;

    /// Writes the weights at `points` into `weights` (row-major, points x handles) and, when
    /// asked, their gradients with respect to normalized coordinates into `gradients`
    /// (points x handles, one vector each).
    fn evaluate(
        &self,
        points: &[Vector3<f64>],
        weights: &mut [f64],
        gradients: Option<&mut [Vector3<f64>]>,
    );

    /// A short name for tables and logs ("eigen", "learned").
    fn kind(&self) -> &'static str;
}
