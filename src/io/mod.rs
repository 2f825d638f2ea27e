//! Files out: NumPy arrays, pictures of skinning fields, strips of simulated frames with their
//! words (a small bitmap font), and SVG line plots.

mod field_image;
mod font;
mod npy;
mod plot;
mod strip;

pub use field_image::render_field_png;
pub(crate) use field_image::weight_colors;
pub use npy::write_npy_f32;
pub use plot::{line_plot_svg, svg_header, LineSeries, Panel};
pub use strip::{render_strip_png, StripFrame, StripMark, StripObject, StripStyle};
