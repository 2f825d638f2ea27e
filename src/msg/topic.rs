//! A topic as both shells declare it: its name, its message type and the QoS it is offered
//! with (what DDS offers and what a recording says was offered).

use super::messages::RosMessage;
use super::qos::QosProfile;
use super::schema::schema_text;

/// A recorded topic: its name, type and the QoS it was offered with.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicInfo {
    /// The topic's resolved name.
    pub name: String,
    /// "pkg/msg/Type".
    pub type_name: String,
    /// The `ros2msg` schema text.
    pub schema: String,
    /// The QoS it was offered with, kept for `ros2 bag play`.
    pub qos: QosProfile,
}

impl TopicInfo {
    /// The topic `name` carrying messages of type `M`, offered with `qos`.
    pub fn of<M: RosMessage>(name: &str, qos: QosProfile) -> Self {
        Self {
            name: name.into(),
            type_name: M::type_name(),
            schema: schema_text::<M>(),
            qos,
        }
    }
}
