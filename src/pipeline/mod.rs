//! Geometry in, motion out: one object from its points to a running simulation. The node, the
//! replay and embedding programs all drive this same type.

mod align;
mod body;
mod input;
mod options;
mod seen;
mod support;
mod switch;
mod touch;
mod track;

pub use body::{BuildTimings, SoftBody};
pub(crate) use input::network_input;
pub use options::{BodyOptions, SleepRule, Support};
pub(crate) use seen::{build_seen, SeenBody, DEFAULT_MAX_BUILD_POINTS};
pub(crate) use switch::{BasisPlan, PreparedBasis};
pub(crate) use touch::contact_hulls;
pub(crate) use track::strided;
pub(crate) use track::{FrameFit, Tracker, TrackingOptions};

#[cfg(test)]
mod tests;
