//! ROS 2 names: expanding private (`~/x`), relative and absolute topic and service names for a
//! node, and the `--ros-args -r FROM:=TO` remapping rules rcl applies to them.

/// Why a name or a rule was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NameError {
    /// The name is empty or ends with `/`.
    #[error("name `{0}` is empty or ends with `/`")]
    Empty(String),
    /// The name breaks ROS 2's rules.
    #[error("name `{name}`: {reason}")]
    Invalid {
        /// The name.
        name: String,
        /// The rule it breaks.
        reason: String,
    },
    /// A remapping rule is not `FROM:=TO` with both sides non-empty.
    #[error("remapping rule `{0}` is not FROM:=TO")]
    Rule(String),
}

/// One `-r [node:]FROM:=TO` rule.
#[derive(Clone, Debug, PartialEq)]
pub struct Remap {
    /// Only for the node of this (original) name, when given.
    pub node: Option<String>,
    /// The name remapped (or `__node`, `__name`, `__ns`).
    pub from: String,
    /// What it becomes.
    pub to: String,
}

impl Remap {
    /// Parses `FROM:=TO` or `node:FROM:=TO`.
    pub fn parse(rule: &str) -> Result<Self, NameError> {
        let (left, to) = rule
            .split_once(":=")
            .ok_or_else(|| NameError::Rule(rule.into()))?;
        // A node prefix is `name:` before FROM; `~` and `/` never appear in a node name.
        let (node, from) = match left.split_once(':') {
            Some((node, from)) if !node.contains('/') && !node.contains('~') => {
                (Some(node.to_string()), from)
            }
            _ => (None, left),
        };
        if from.is_empty() || to.is_empty() {
            return Err(NameError::Rule(rule.into()));
        }
        Ok(Self {
            node,
            from: from.into(),
            to: to.into(),
        })
    }
}

/// A node's identity after `__node:=` and `__ns:=`, and the topic and service remappings.
#[derive(Clone, Debug, PartialEq)]
pub struct NameResolver {
    /// Absolute, "/" for the root namespace.
    pub namespace: String,
    /// The node's name, after `__node:=`.
    pub node: String,
    /// The node's name before `__node:=`: rules prefixed with it apply.
    original_node: String,
    remaps: Vec<Remap>,
}

impl Default for NameResolver {
    fn default() -> Self {
        Self::new("/", "physskin")
    }
}

impl NameResolver {
    /// The node `node` in `namespace` (made absolute), without remapping rules.
    pub fn new(namespace: &str, node: &str) -> Self {
        Self {
            namespace: absolute_namespace(namespace),
            node: node.into(),
            original_node: node.into(),
            remaps: Vec::new(),
        }
    }

    /// Applies rules in order: `__node`/`__name` and `__ns` rename the node, the others remap
    /// names. Rules for another node are kept but never match.
    pub fn with_rules(mut self, rules: &[Remap]) -> Result<Self, NameError> {
        for rule in rules {
            if rule
                .node
                .as_deref()
                .is_some_and(|n| n != self.original_node)
            {
                continue;
            }
            match rule.from.as_str() {
                "__node" | "__name" => {
                    check_token(&rule.to)?;
                    self.node = rule.to.clone();
                }
                "__ns" => {
                    if !rule.to.starts_with('/') {
                        return Err(NameError::Invalid {
                            name: rule.to.clone(),
                            reason: "a namespace given by __ns must be absolute".into(),
                        });
                    }
                    self.namespace = absolute_namespace(&rule.to);
                }
                _ => self.remaps.push(rule.clone()),
            }
        }
        Ok(self)
    }

    /// `/namespace/node`.
    pub fn fully_qualified_name(&self) -> String {
        format!("{}/{}", self.namespace.trim_end_matches('/'), self.node)
    }

    /// The name expanded by ROS 2 rules: `~` is the node's fully qualified name, a relative
    /// name lives in the node's namespace, `{node}` and `{ns}` are substituted.
    pub fn expand(&self, name: &str) -> Result<String, NameError> {
        let ns = self.namespace.trim_end_matches('/');
        let substituted = name
            .replace("{node}", &self.node)
            .replace("{namespace}", ns)
            .replace("{ns}", ns);
        let expanded = if let Some(rest) = substituted.strip_prefix('~') {
            format!("{}{rest}", self.fully_qualified_name())
        } else if substituted.starts_with('/') {
            substituted
        } else {
            format!("{ns}/{substituted}")
        };
        check_name(&expanded)?;
        Ok(expanded)
    }

    /// The expanded name after the first remapping rule whose expanded FROM equals it.
    pub fn resolve(&self, name: &str) -> Result<String, NameError> {
        let expanded = self.expand(name)?;
        for rule in &self.remaps {
            if self.expand(&rule.from)? == expanded {
                return self.expand(&rule.to);
            }
        }
        Ok(expanded)
    }
}

fn absolute_namespace(namespace: &str) -> String {
    let trimmed = namespace.trim_matches('/');
    if trimmed.is_empty() {
        "/".into()
    } else {
        format!("/{trimmed}")
    }
}

/// A fully qualified name: `/` then tokens of letters, digits and `_`, none starting with a
/// digit, no empty token.
fn check_name(name: &str) -> Result<(), NameError> {
    if name.len() < 2 || name.ends_with('/') {
        return Err(NameError::Empty(name.into()));
    }
    name[1..].split('/').try_for_each(|token| {
        check_token(token).map_err(|_| NameError::Invalid {
            name: name.into(),
            reason: format!("`{token}` is not a valid name token"),
        })
    })
}

fn check_token(token: &str) -> Result<(), NameError> {
    let valid = !token.is_empty()
        && !token.starts_with(|c: char| c.is_ascii_digit())
        && token.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if valid {
        Ok(())
    } else {
        Err(NameError::Invalid {
            name: token.into(),
            reason: "letters, digits and `_` only, not starting with a digit".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rules(text: &[&str]) -> Vec<Remap> {
        text.iter().map(|r| Remap::parse(r).unwrap()).collect()
    }

    #[test]
    fn private_relative_and_absolute_names_expand_by_ros_rules() {
        let r = NameResolver::new("/cell", "skin");
        assert_eq!(r.expand("~/points").unwrap(), "/cell/skin/points");
        assert_eq!(r.expand("points").unwrap(), "/cell/points");
        assert_eq!(r.expand("/clock").unwrap(), "/clock");
        assert_eq!(r.expand("{node}/x").unwrap(), "/cell/skin/x");
        let root = NameResolver::default();
        assert_eq!(root.expand("~/points").unwrap(), "/physskin/points");
        assert_eq!(root.expand("points").unwrap(), "/points");
        assert!(root.expand("~/2d").is_err());
        assert!(root.expand("a//b").is_err());
    }

    #[test]
    fn launch_ros_rules_rename_the_node_and_remap_topics() {
        let r = NameResolver::default()
            .with_rules(&rules(&[
                "__node:=skin",
                "__ns:=/cell",
                "~/points:=/camera/points",
                "other_node:~/mesh:=/nope",
                "physskin:state:=~/reduced_state",
            ]))
            .unwrap();
        assert_eq!(r.fully_qualified_name(), "/cell/skin");
        assert_eq!(r.resolve("~/points").unwrap(), "/camera/points");
        assert_eq!(r.resolve("~/mesh").unwrap(), "/cell/skin/mesh");
        // A relative FROM is expanded in the node's namespace before matching.
        assert_eq!(r.resolve("state").unwrap(), "/cell/skin/reduced_state");
        assert_eq!(r.resolve("/tf").unwrap(), "/tf");
        // The first matching rule wins.
        let first = NameResolver::default()
            .with_rules(&rules(&["/a:=/b", "/a:=/c"]))
            .unwrap();
        assert_eq!(first.resolve("/a").unwrap(), "/b");
    }

    #[test]
    fn bad_rules_are_named() {
        assert!(Remap::parse("points").is_err());
        assert!(Remap::parse(":=x").is_err());
        let relative_ns = NameResolver::default().with_rules(&rules(&["__ns:=cell"]));
        assert!(relative_ns.is_err());
        let bad_node = NameResolver::default().with_rules(&rules(&["__node:=9lives"]));
        assert!(bad_node.is_err());
    }
}
