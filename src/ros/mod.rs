//! ROS 2: message types, the PointCloud2 codec, parameters, and the node.

mod builder;
mod clock;
pub mod cloud;
pub mod messages;
mod node;
mod outputs;
pub mod params;
mod stepper;

pub use builder::{BuildOutcome, BuildRequest, Builder, ReadyBody};
pub use clock::NodeClock;
pub use node::{
    context, publisher, qos_of, reliable_qos, run_node, sensor_qos, subscription, NodeConfig,
    NodeError,
};
pub use outputs::{topic_table, Outputs};
pub use params::NodeParams;
pub use stepper::{Stage, StepperStats};
