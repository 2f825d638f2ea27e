//! Parameter sources in rcl's order: `--params-file` files (node, `/ns/node`, nested namespace
//! or wildcard sections), then `-p NAME:=VALUE` overrides, a later source winning.
//!
//! As in rclcpp, a parameter the node does not declare is an error in a section written for
//! this node, and a warning in a shared wildcard section (`/**`), which other nodes read too.

use std::path::Path;

use serde_json::{Map, Value};

use super::params::{flatten, NodeParams, ParamError};
use super::qos_overrides::QosOverrides;

/// Parameters built up from their sources, with the QoS overrides and what was ignored.
#[derive(Clone, Debug, Default)]
pub struct ParamLoader {
    /// The parameters: defaults, then each source applied in order.
    pub params: NodeParams,
    /// The `qos_overrides.*` parameters found.
    pub qos: QosOverrides,
    /// Parameters of shared sections this node does not have, one line each.
    pub warnings: Vec<String>,
}

const QOS_PREFIX: &str = "qos_overrides.";

impl ParamLoader {
    /// Applies the sections of the file at `path` that match `fully_qualified_name`.
    pub fn apply_file(
        &mut self,
        path: &Path,
        fully_qualified_name: &str,
    ) -> Result<(), ParamError> {
        let text = std::fs::read_to_string(path).map_err(|e| ParamError::File {
            path: path.display().to_string(),
            reason: e.to_string(),
        })?;
        self.apply_yaml(&text, fully_qualified_name)
            .map_err(|e| match e {
                ParamError::Format { reason, .. } => ParamError::Format {
                    path: path.display().to_string(),
                    reason,
                },
                other => other,
            })
    }

    /// Parses the ROS 2 parameter file format: `node: ros__parameters: {...}` where the node
    /// key may be a name, `/namespace/name`, nested namespace keys, or a `/**` or `*` wildcard.
    /// Later matching sections override earlier ones.
    pub fn apply_yaml(&mut self, text: &str, fully_qualified_name: &str) -> Result<(), ParamError> {
        let format = |reason: String| ParamError::Format {
            path: "<text>".into(),
            reason,
        };
        let yaml: serde_yaml::Value =
            serde_yaml::from_str(text).map_err(|e| format(e.to_string()))?;
        let json = serde_json::to_value(yaml).map_err(|e| format(e.to_string()))?;
        let Value::Object(top) = json else {
            return Err(format(
                "the top level must map node names to sections".into(),
            ));
        };
        let mut sections = Vec::new();
        collect_sections(&top, "", &mut sections).map_err(format)?;
        let mut matched = false;
        for (pattern, section) in sections {
            if node_matches(&pattern, fully_qualified_name) {
                matched = true;
                self.apply_section(&section, pattern.contains('*'))?;
            }
        }
        if !matched {
            return Err(format(format!(
                "no section applies to node {fully_qualified_name} (use its name or /**)"
            )));
        }
        Ok(())
    }

    /// `-p NAME:=VALUE`, VALUE typed as YAML (`30.0` a double, `30` an integer, `true` a bool).
    /// rcl hands such overrides to every node of the process: an unknown name is a warning.
    pub fn apply_override(&mut self, name: &str, yaml: &str) -> Result<(), ParamError> {
        let value: serde_yaml::Value =
            serde_yaml::from_str(yaml).map_err(|e| ParamError::Invalid {
                name: name.into(),
                reason: format!("`{yaml}` is not a YAML value: {e}"),
            })?;
        let value = serde_json::to_value(value).map_err(|e| ParamError::Invalid {
            name: name.into(),
            reason: e.to_string(),
        })?;
        self.apply_one(name, value, true)
    }

    fn apply_section(
        &mut self,
        section: &Map<String, Value>,
        shared: bool,
    ) -> Result<(), ParamError> {
        for (name, value) in flatten(section, "") {
            self.apply_one(&name, value, shared)?;
        }
        if !shared {
            let known = serde_json::to_value(&self.params).unwrap_or_default();
            let own: Map<String, Value> = section
                .iter()
                .filter(|(k, _)| k.as_str() != "qos_overrides")
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect();
            check_groups(&own, &known, "")?;
        }
        Ok(())
    }

    fn apply_one(&mut self, name: &str, value: Value, shared: bool) -> Result<(), ParamError> {
        if let Some(rest) = name.strip_prefix(QOS_PREFIX) {
            return self.qos.insert(rest, value);
        }
        match self.params.with(name, value) {
            Ok(params) => self.params = params,
            Err(ParamError::Unknown { name }) if shared => self.warnings.push(format!(
                "parameter `{name}` is not one of this node's: ignored"
            )),
            Err(e) => return Err(e),
        }
        Ok(())
    }
}

impl NodeParams {
    /// Defaults overridden by the entries of `path` that apply to the node `/namespace/name`.
    pub fn from_yaml_file(path: &Path, fully_qualified_name: &str) -> Result<Self, ParamError> {
        let mut loader = ParamLoader::default();
        loader.apply_file(path, fully_qualified_name)?;
        Ok(loader.params)
    }

    /// Defaults overridden by the sections of `text` that apply to the node.
    pub fn from_yaml(text: &str, fully_qualified_name: &str) -> Result<Self, ParamError> {
        let mut loader = ParamLoader::default();
        loader.apply_yaml(text, fully_qualified_name)?;
        Ok(loader.params)
    }
}

/// (node pattern, its ros__parameters) for every section, nested namespaces joined with '/'.
fn collect_sections(
    map: &Map<String, Value>,
    prefix: &str,
    out: &mut Vec<(String, Map<String, Value>)>,
) -> Result<(), String> {
    for (key, value) in map {
        let Value::Object(inner) = value else {
            return Err(format!("`{prefix}{key}` must be a mapping"));
        };
        let path = format!("{prefix}/{}", key.trim_matches('/'));
        match inner.get("ros__parameters") {
            Some(Value::Object(params)) => out.push((path.clone(), params.clone())),
            Some(_) => return Err(format!("`{path}: ros__parameters` must be a mapping")),
            None => collect_sections(inner, &path, out)?,
        }
    }
    Ok(())
}

/// ROS 2 node-name matching: `/**` matches everything, `*` one name segment, a pattern without
/// a leading namespace matches that node name in the root namespace.
fn node_matches(pattern: &str, name: &str) -> bool {
    fn matches(p: &[&str], n: &[&str]) -> bool {
        match (p.first(), n.first()) {
            (None, None) => true,
            (Some(&"**"), _) => (0..=n.len()).any(|i| matches(&p[1..], &n[i..])),
            (Some(&"*"), Some(_)) => matches(&p[1..], &n[1..]),
            (Some(a), Some(b)) if a == b => matches(&p[1..], &n[1..]),
            _ => false,
        }
    }
    let split = |s: &str| -> Vec<String> {
        s.split('/')
            .filter(|x| !x.is_empty())
            .map(String::from)
            .collect()
    };
    let (p, n) = (split(pattern), split(name));
    let p: Vec<&str> = p.iter().map(String::as_str).collect();
    let n: Vec<&str> = n.iter().map(String::as_str).collect();
    matches(&p, &n)
}

/// Refuses groups of a parameter file that name nothing (an empty `materiel: {}` flattens to
/// no parameter at all, so `with` never sees it).
fn check_groups(map: &Map<String, Value>, known: &Value, prefix: &str) -> Result<(), ParamError> {
    for (key, value) in map {
        let name = format!("{prefix}{key}");
        // A dotted key (`material.young: 1.0`, as launch_ros writes them) is a path.
        let slot = key.split('.').try_fold(known, |slot, part| slot.get(part));
        let Some(slot) = slot else {
            return Err(ParamError::Unknown { name });
        };
        if let Value::Object(inner) = value {
            check_groups(inner, slot, &format!("{name}."))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Support;

    #[test]
    fn wildcard_namespaced_and_nested_sections_apply_in_order() {
        let yaml = r#"
/**:
  ros__parameters:
    rate_hz: 30.0
    material: {young: 1.0e6}
/robots:
  physskin:
    ros__parameters:
      material:
        poisson: 0.3
      simulation: {support: floor, gravity: [0.0, -9.81, 0.0]}
other_node:
  ros__parameters:
    rate_hz: 5.0
"#;
        let p = NodeParams::from_yaml(yaml, "/robots/physskin").unwrap();
        assert_eq!(p.rate_hz, 30.0);
        assert_eq!(p.material.young, 1e6);
        assert_eq!(p.material.poisson, 0.3);
        assert_eq!(p.simulation.support, Support::Floor);
        assert_eq!(p.simulation.gravity, [0.0, -9.81, 0.0]);
        // The namespaced section does not apply to /physskin in the root namespace.
        let root = NodeParams::from_yaml(yaml, "/physskin").unwrap();
        assert_eq!(root.material.poisson, 0.45);
    }

    #[test]
    fn bad_files_name_the_parameter() {
        let typo = "physskin:\n  ros__parameters:\n    material: {yung: 3.0}\n";
        let e = NodeParams::from_yaml(typo, "/physskin")
            .unwrap_err()
            .to_string();
        assert!(e.contains("material.yung"), "{e}");
        let negative = "/**:\n  ros__parameters:\n    material: {young: -1.0}\n";
        let e = NodeParams::from_yaml(negative, "/physskin")
            .unwrap_err()
            .to_string();
        assert!(e.contains("material.young") && e.contains("young"), "{e}");
        let wrong_type = "/**:\n  ros__parameters:\n    rate_hz: fast\n";
        let e = NodeParams::from_yaml(wrong_type, "/physskin")
            .unwrap_err()
            .to_string();
        assert!(e.contains("rate_hz"), "{e}");
        let nobody = "someone_else:\n  ros__parameters: {rate_hz: 5.0}\n";
        assert!(NodeParams::from_yaml(nobody, "/physskin").is_err());
    }

    #[test]
    fn shared_sections_warn_about_foreign_parameters_and_later_sources_win() {
        let shared = "/**:\n  ros__parameters:\n    camera_fps: 30\n    rate_hz: 20.0\n    \
                      qos_overrides:\n      /physskin/points:\n        subscription:\n          \
                      reliability: reliable\n";
        let own = "/cell/skin:\n  ros__parameters:\n    rate_hz: 25.0\n    material.poisson: 0.4\n";
        let mut loader = ParamLoader::default();
        loader.apply_yaml(shared, "/cell/skin").unwrap();
        loader.apply_yaml(own, "/cell/skin").unwrap();
        loader.apply_override("material.young", "1.0e5").unwrap();
        loader.apply_override("someone.else", "3").unwrap();
        assert_eq!(loader.params.rate_hz, 25.0);
        assert_eq!(loader.params.material.poisson, 0.4);
        assert_eq!(loader.params.material.young, 1e5);
        assert_eq!(loader.warnings.len(), 2, "{:?}", loader.warnings);
        assert!(loader.warnings[0].contains("camera_fps"));
        assert_eq!(loader.qos.topics(), vec!["/physskin/points".to_string()]);
        // An override of the wrong type is refused by name.
        let e = loader.apply_override("rate_hz", "fast").unwrap_err();
        assert!(e.to_string().contains("rate_hz"), "{e}");
    }
}
