//! Geometry in, motion out: one object from its points to a running simulation. The node, the
//! replay and embedding programs all drive this same type.

mod body;
mod input;
mod options;
mod seen;
mod support;
mod switch;
mod touch;
mod track;

pub use body::{BuildTimings, SoftBody};
pub use input::network_input;
pub use options::{BodyOptions, SleepRule, Support};
pub use seen::{build_seen, SeenBody, DEFAULT_MAX_BUILD_POINTS};
pub use switch::{BasisPlan, PreparedBasis, SwitchReport, REFINE_RESOLUTION};
pub use touch::contact_hulls;
pub use track::{strided, FrameFit, Tracker, TrackingOptions};
