//! Files out: NumPy arrays, pictures of skinning fields, strips of simulated frames.

mod field_image;
mod npy;
mod strip;

pub(crate) use field_image::weight_colors;
pub use field_image::{render_field_png, RenderError};
pub use npy::write_npy_f32;
pub use strip::{render_strip_png, StripObject};
