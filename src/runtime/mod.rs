//! The runtime both shells share: decoded inputs in (clouds, meshes, interactions, transforms,
//! joint states), bodies built, stepped and tracked, outputs out to a `Sink`. It knows no
//! DDS and no MCAP: the node (`crate::node`) feeds it from DDS subscriptions and sinks it into
//! DDS publishers; a replay (`crate::replay`) feeds it from a recording and sinks it into one.

pub(crate) mod builder;
pub(crate) mod clock;
pub(crate) mod cloud_objects;
pub(crate) mod diagnostics;
pub(crate) mod heap;
pub(crate) mod inputs;
pub(crate) mod markers;
pub(crate) mod names;
pub(crate) mod object_key;
pub(crate) mod outputs;
pub(crate) mod param_file;
pub(crate) mod params;
pub(crate) mod qos_overrides;
pub(crate) mod refiner;
pub(crate) mod robot_on_stage;
pub(crate) mod scene_on_stage;
pub(crate) mod shard;
pub(crate) mod stage;
pub(crate) mod stepper;
pub(crate) mod tf;
pub(crate) mod tracking;
pub(crate) mod tracking_params;

#[cfg(not(fuzzing))]
pub(crate) use builder::BuildRequest;
// The fuzz targets reach these through `crate::fuzzing`, built only under `cargo fuzz`.
#[cfg(fuzzing)]
pub use builder::BuildRequest;
pub(crate) use builder::{BuildOutcome, Builder, REPLAY_REFINE};
pub(crate) use clock::NodeClock;
pub(crate) use diagnostics::Health;
pub(crate) use inputs::{Input, InputKind, InputTopics};
pub(crate) use names::{NameError, NameResolver};
pub(crate) use outputs::{topic_table, Outputs};
pub(crate) use param_file::ParamLoader;
pub use params::NodeParams;
pub(crate) use params::Topics;
pub(crate) use stage::{Stage, StageOptions};
#[cfg(not(fuzzing))]
pub(crate) use tf::TfBuffer;
#[cfg(fuzzing)]
pub use tf::TfBuffer;
