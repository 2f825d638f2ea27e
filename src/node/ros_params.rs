//! The node's parameters as the ROS parameter services see them: declared by dotted name
//! with rcl's value types, and set by `ros2 param set` (checked like the file).

use ros2_client::ParameterValue;
use serde_json::Value;

use crate::runtime::params::ParamError;
use crate::runtime::NodeParams;

/// NodeParams through the ROS parameter services.
pub(super) trait RosParams: Sized {
    /// `with` for a value arriving from `ros2 param set`; read-only parameters are refused.
    fn with_ros(&self, name: &str, value: &ParameterValue) -> Result<Self, ParamError>;
    /// Every parameter by dotted name, as ROS declares them.
    fn to_ros(&self) -> Vec<(String, ParameterValue)>;
}

impl RosParams for NodeParams {
    /// `with` for a value arriving from `ros2 param set`; read-only parameters are refused.
    fn with_ros(&self, name: &str, value: &ParameterValue) -> Result<Self, ParamError> {
        let unchanged = self.to_ros().iter().any(|(n, v)| n == name && v == value);
        if unchanged {
            // ROS sets every declared parameter once at start; that is not a change.
            return Ok(self.clone());
        }
        self.with_while_running(name, from_ros(value))
    }

    fn to_ros(&self) -> Vec<(String, ParameterValue)> {
        self.flattened()
            .into_iter()
            .map(|(name, value)| (name, to_ros(&value)))
            .collect()
    }
}

fn to_ros(value: &Value) -> ParameterValue {
    match value {
        Value::Bool(b) => ParameterValue::Boolean(*b),
        Value::Number(n) if n.is_f64() => ParameterValue::Double(n.as_f64().unwrap_or(f64::NAN)),
        Value::Number(n) => ParameterValue::Integer(n.as_i64().unwrap_or(i64::MAX)),
        Value::String(s) => ParameterValue::String(s.clone()),
        Value::Array(items) if items.iter().all(Value::is_boolean) => {
            ParameterValue::BooleanArray(items.iter().filter_map(Value::as_bool).collect())
        }
        Value::Array(items)
            if items.iter().all(|v| v.is_i64() || v.is_u64()) && !items.is_empty() =>
        {
            ParameterValue::IntegerArray(items.iter().filter_map(Value::as_i64).collect())
        }
        Value::Array(items) if items.iter().all(Value::is_number) => {
            ParameterValue::DoubleArray(items.iter().filter_map(Value::as_f64).collect())
        }
        Value::Array(items) => ParameterValue::StringArray(
            items
                .iter()
                .map(|v| v.as_str().map_or_else(|| v.to_string(), String::from))
                .collect(),
        ),
        Value::Null | Value::Object(_) => ParameterValue::NotSet,
    }
}

fn from_ros(value: &ParameterValue) -> Value {
    use ParameterValue as P;
    match value {
        P::NotSet => Value::Null,
        P::Boolean(b) => Value::from(*b),
        P::Integer(i) => Value::from(*i),
        P::Double(d) => Value::from(*d),
        P::String(s) => Value::from(s.clone()),
        P::ByteArray(v) => Value::from(v.clone()),
        P::BooleanArray(v) => Value::from(v.clone()),
        P::IntegerArray(v) => Value::from(v.clone()),
        P::DoubleArray(v) => Value::from(v.clone()),
        P::StringArray(v) => Value::from(v.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ros_names_round_trip_and_read_only_is_refused() {
        let p = NodeParams::default();
        let declared = p.to_ros();
        assert!(declared.contains(&("material.young".into(), ParameterValue::Double(2e5))));
        assert!(declared.contains(&(
            "topics.points".into(),
            ParameterValue::String("~/points".into())
        )));
        let q = p
            .with_ros("material.young", &ParameterValue::Double(5e5))
            .unwrap();
        assert_eq!(q.material.young, 5e5);
        assert!(p
            .with_ros("topics.points", &ParameterValue::String("/x".into()))
            .is_err());
        assert!(p
            .with_ros("material.young", &ParameterValue::String("soft".into()))
            .is_err());
        assert!(p
            .with_ros("material.poisson", &ParameterValue::Double(0.5))
            .is_err());
    }
}
