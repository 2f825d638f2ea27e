//! The ROS 2 messages physskin speaks, below both the node and the recordings: their types in
//! CDR field order, the PointCloud2 codec, the `ros2msg` schema text of each type, and what a
//! topic is (name, type, QoS). Nothing here knows DDS or MCAP.

pub mod camera_cloud;
pub mod cloud;
mod messages;
mod qos;
mod schema;
mod sink;
mod topic;

pub use messages::*;
pub use qos::QosProfile;
pub use schema::schema_text;
#[cfg(test)]
pub(crate) use sink::Collector;
pub(crate) use sink::{Output, Sink};
pub use topic::TopicInfo;
