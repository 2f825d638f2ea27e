//! The ROS 2 node: a thin shell around the runtime. DDS subscriptions decode and forward
//! inputs, DDS publications take its outputs; parameters, names and the command line follow
//! ROS 2's conventions.

mod args;
mod dds;
mod logger;
mod network;
mod node;
mod node_inputs;
mod publishers;
mod ros_params;
mod send;
mod services;
mod shared;

pub use args::{split_ros_args, LogLevel, RosArgs, RosArgsError};
pub use dds::{context, publisher, qos_of, reliable_qos, sensor_qos, subscription, NodeError};
pub use logger::install_logger;
pub use node::{run_node, NodeConfig};
pub use send::{send_recording, SendOptions, SendSummary};
