//! The QoS a topic was offered with, as the `offered_qos_profiles` YAML that rosbag2 (bag
//! metadata version 9) stores per channel and `ros2 bag play` uses to publish it again.

use serde::Serialize;

/// The policies that differ between physskin's topics; the rest are ROS 2 defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct QosProfile {
    /// Reliable delivery; false: best effort.
    pub reliable: bool,
    /// Transient-local durability (late joiners get the last `depth` messages); false: volatile.
    pub transient_local: bool,
    /// History depth (keep last).
    pub depth: u32,
}

impl QosProfile {
    /// Best effort, volatile: sensor inputs.
    pub const fn sensor(depth: u32) -> Self {
        Self {
            reliable: false,
            transient_local: false,
            depth,
        }
    }

    /// Reliable, keeping the last `depth`; transient local when `transient_local`.
    pub const fn reliable(depth: u32, transient_local: bool) -> Self {
        Self {
            reliable: true,
            transient_local,
            depth,
        }
    }

    /// A one-element YAML list, as rosbag2 writes it.
    pub fn to_yaml(&self) -> String {
        #[derive(Serialize)]
        struct Duration {
            sec: i64,
            nsec: i64,
        }
        #[derive(Serialize)]
        struct Profile {
            history: &'static str,
            depth: u32,
            reliability: &'static str,
            durability: &'static str,
            deadline: Duration,
            lifespan: Duration,
            liveliness: &'static str,
            liveliness_lease_duration: Duration,
            avoid_ros_namespace_conventions: bool,
        }
        // rmw's "infinite" duration.
        let infinite = || Duration {
            sec: 9_223_372_036,
            nsec: 854_775_807,
        };
        let profile = Profile {
            history: "keep_last",
            depth: self.depth,
            reliability: if self.reliable {
                "reliable"
            } else {
                "best_effort"
            },
            durability: if self.transient_local {
                "transient_local"
            } else {
                "volatile"
            },
            deadline: infinite(),
            lifespan: infinite(),
            liveliness: "automatic",
            liveliness_lease_duration: infinite(),
            avoid_ros_namespace_conventions: false,
        };
        serde_yaml::to_string(&[profile]).expect("plain structs serialize")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaml_names_the_policies_in_words() {
        let yaml = QosProfile::reliable(4, true).to_yaml();
        assert!(yaml.starts_with("- history: keep_last\n  depth: 4\n  reliability: reliable\n  durability: transient_local\n"), "{yaml}");
        let parsed: serde_yaml::Value = serde_yaml::from_str(&yaml).unwrap();
        assert_eq!(parsed[0]["deadline"]["sec"].as_i64(), Some(9_223_372_036));
        assert!(QosProfile::sensor(5)
            .to_yaml()
            .contains("reliability: best_effort"));
    }
}
