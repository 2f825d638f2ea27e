//! `qos_overrides.<topic>.<publisher|subscription>.<policy>` parameters, as rclcpp offers them:
//! read once at start and applied to the endpoint of that fully qualified topic.

use std::collections::BTreeMap;

use serde_json::Value;

use super::params::ParamError;
use crate::msg::QosProfile;

/// Which side of a topic an override is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Endpoint {
    /// The node's publisher on the topic.
    Publisher,
    /// The node's subscription to the topic.
    Subscription,
}

/// The overrides found in the parameter sources, by (topic, endpoint).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct QosOverrides {
    entries: BTreeMap<(String, Endpoint), Vec<(String, Value)>>,
}

impl QosOverrides {
    /// Takes `qos_overrides.<topic>.<endpoint>.<policy>` (the prefix already removed: `rest` is
    /// `<topic>.<endpoint>.<policy>`); a mistake names the parameter.
    pub fn insert(&mut self, rest: &str, value: Value) -> Result<(), ParamError> {
        let name = format!("qos_overrides.{rest}");
        let invalid = |reason: &str| ParamError::Invalid {
            name: name.clone(),
            reason: reason.into(),
        };
        let mut parts = rest.rsplitn(3, '.');
        let (Some(policy), Some(endpoint), Some(topic)) =
            (parts.next(), parts.next(), parts.next())
        else {
            return Err(invalid(
                "expected qos_overrides.<topic>.<publisher|subscription>.<policy>",
            ));
        };
        if !topic.starts_with('/') {
            return Err(invalid("the topic must be fully qualified (start with /)"));
        }
        let endpoint = match endpoint {
            "publisher" => Endpoint::Publisher,
            "subscription" => Endpoint::Subscription,
            _ => return Err(invalid("the endpoint is `publisher` or `subscription`")),
        };
        // Checked now, so a typo stops the node at start rather than when the topic is made.
        apply_one(&mut QosProfile::sensor(1), policy, &value).map_err(|r| invalid(&r))?;
        self.entries
            .entry((topic.to_string(), endpoint))
            .or_default()
            .push((policy.to_string(), value));
        Ok(())
    }

    /// `base` with the overrides of `topic` (fully qualified) on `endpoint`.
    pub fn apply(&self, topic: &str, endpoint: Endpoint, base: QosProfile) -> QosProfile {
        let mut profile = base;
        for (policy, value) in self
            .entries
            .get(&(topic.to_string(), endpoint))
            .into_iter()
            .flatten()
        {
            // Every entry was checked when it was inserted.
            let _ = apply_one(&mut profile, policy, value);
        }
        profile
    }

    /// The overridden topics, for the node's start-up line.
    pub fn topics(&self) -> Vec<String> {
        self.entries.keys().map(|(t, _)| t.clone()).collect()
    }
}

fn apply_one(profile: &mut QosProfile, policy: &str, value: &Value) -> Result<(), String> {
    let text = value.as_str().unwrap_or_default();
    match (policy, text) {
        ("reliability", "reliable") => profile.reliable = true,
        ("reliability", "best_effort") => profile.reliable = false,
        ("durability", "volatile") => profile.transient_local = false,
        ("durability", "transient_local") => profile.transient_local = true,
        ("reliability" | "durability" | "history", "system_default") => {}
        ("history", "keep_last") => {}
        ("history", "keep_all") => {
            return Err(
                "keep_all is not offered: the node keeps every history bounded \
                        (use keep_last with a depth)"
                    .into(),
            )
        }
        ("depth", _) => match value.as_u64() {
            Some(depth @ 1..=10_000) => profile.depth = depth as u32,
            _ => return Err(format!("depth {value} is not an integer in 1..=10000")),
        },
        ("reliability", _) => {
            return Err(format!(
                "{value} is none of reliable, best_effort, system_default"
            ))
        }
        ("durability", _) => {
            return Err(format!(
                "{value} is none of volatile, transient_local, system_default"
            ))
        }
        ("history", _) => return Err(format!("{value} is neither keep_last nor system_default")),
        _ => {
            return Err(format!(
                "unknown policy `{policy}` (reliability, durability, history, depth)"
            ))
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_apply_to_their_topic_and_side_only() {
        let mut o = QosOverrides::default();
        o.insert(
            "/cell/skin/points.subscription.reliability",
            "reliable".into(),
        )
        .unwrap();
        o.insert("/cell/skin/points.subscription.depth", 20.into())
            .unwrap();
        let base = QosProfile::sensor(5);
        let got = o.apply("/cell/skin/points", Endpoint::Subscription, base);
        assert_eq!(got, QosProfile::reliable(20, false));
        assert_eq!(
            o.apply("/cell/skin/points", Endpoint::Publisher, base),
            base
        );
        assert_eq!(o.apply("/other", Endpoint::Subscription, base), base);
    }

    #[test]
    fn mistakes_name_the_parameter() {
        let mut o = QosOverrides::default();
        for (rest, value) in [
            ("/a.subscription.reliability", Value::from("sometimes")),
            ("/a.reader.depth", Value::from(3)),
            ("a.publisher.depth", Value::from(3)),
            ("/a.publisher.depth", Value::from(-1)),
            ("/a.publisher.history", Value::from("keep_all")),
            ("/a.publisher.lifespan", Value::from(3)),
        ] {
            let e = o.insert(rest, value).unwrap_err().to_string();
            assert!(e.contains(&format!("qos_overrides.{rest}")), "{e}");
        }
    }
}
