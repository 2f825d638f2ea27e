//! Geometry in, motion out: one object from its points to a running simulation. The node, the
//! replay and embedding programs all drive this same type.

mod body;
mod seen;

pub(crate) use body::network_input;
pub use body::{BodyOptions, BuildTimings, SleepRule, SoftBody, Support};
pub use seen::{build_seen, SeenBody, DEFAULT_MAX_BUILD_POINTS};
