//! The runtime both shells share: decoded inputs in (clouds, meshes, interactions, transforms,
//! joint states), bodies built, stepped and tracked, outputs out to a [`Sink`]. It knows no
//! DDS and no MCAP: the node (`crate::node`) feeds it from DDS subscriptions and sinks it into
//! DDS publishers; a replay (`crate::replay`) feeds it from a recording and sinks it into one.

pub(crate) mod builder;
pub(crate) mod clock;
pub(crate) mod cloud_objects;
pub(crate) mod diagnostics;
pub(crate) mod inputs;
pub(crate) mod markers;
pub(crate) mod names;
pub(crate) mod object_key;
pub(crate) mod outputs;
pub(crate) mod param_file;
pub(crate) mod params;
pub(crate) mod qos_overrides;
pub(crate) mod refiner;
pub(crate) mod stage;
pub(crate) mod stepper;
pub(crate) mod tf;
pub(crate) mod tracking;
pub(crate) mod tracking_params;

pub use builder::{
    BuildOutcome, BuildRequest, Builder, ObjectKey, ReadyBody, REPLAY_REFINE_ITERATIONS,
};
pub use clock::NodeClock;
pub use cloud_objects::{split_by_instance, CloudTemplate, InstanceError, INSTANCE_FIELDS};
pub use diagnostics::Health;
pub use inputs::{Input, InputKind, InputTopics};
pub use names::{NameError, NameResolver, Remap};
pub use outputs::{topic_table, Outputs, TF, TF_STATIC};
pub use param_file::ParamLoader;
pub use params::{NodeParams, Topics};
pub use qos_overrides::{Endpoint, QosOverrides};
pub use stage::{Stage, StageOptions};
pub use stepper::StepperStats;
pub use tf::{TfBuffer, TfError};
