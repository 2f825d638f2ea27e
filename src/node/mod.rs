//! The ROS 2 node: a thin shell around the runtime. DDS subscriptions decode and forward
//! inputs, DDS publications take its outputs; parameters, names and the command line follow
//! ROS 2's conventions.

mod args;
mod dds;
mod foxglove;
mod logger;
mod node;
mod node_inputs;
mod publishers;
mod ros_params;
mod send;
mod services;
mod shared;

pub use args::LogLevel;
pub(crate) use args::{split_ros_args, RosArgs, RosArgsError};
pub use dds::NodeError;
pub(crate) use dds::{context, publisher, reliable_qos, subscription};
pub(crate) use logger::install_logger;
pub(crate) use node::run_counted;
pub use node::{run, NodeConfig};
pub(crate) use send::{send_recording, SendOptions};
