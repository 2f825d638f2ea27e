//! ROS 2: message types, the PointCloud2 codec, names and the command line, parameters, tf2,
//! and the node.

mod args;
mod builder;
mod clock;
pub mod cloud_objects;
mod dds;
mod diagnostics;
mod markers;
mod names;
mod network;
mod node;
mod node_inputs;
mod object_key;
mod outputs;
mod param_file;
pub mod params;
mod qos_overrides;
mod refiner;
mod services;
mod shared;
mod stage;
mod stepper;
mod tf;
mod tracking;
mod tracking_params;

pub use args::{split_ros_args, LogLevel, RosArgs, RosArgsError};
pub use builder::{
    BuildOutcome, BuildRequest, Builder, ObjectKey, ReadyBody, REPLAY_REFINE_ITERATIONS,
};
pub use clock::NodeClock;
pub use dds::{context, publisher, qos_of, reliable_qos, sensor_qos, subscription, NodeError};
pub use diagnostics::Health;
pub use names::{NameError, NameResolver, Remap};
pub use node::{cloud_every, marker_every, run_node, NodeConfig};
pub use outputs::{topic_table, Outputs, TF, TF_STATIC};
pub use param_file::ParamLoader;
pub use params::NodeParams;
pub use qos_overrides::{Endpoint, QosOverrides};
pub use stage::{Stage, StageOptions};
pub use stepper::StepperStats;
pub use tf::{TfBuffer, TfError};
