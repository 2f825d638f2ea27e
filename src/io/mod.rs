//! Files out: NumPy arrays and pictures of skinning fields.

mod field_image;
mod npy;

pub use field_image::{render_field_png, RenderError};
pub use npy::write_npy_f32;
