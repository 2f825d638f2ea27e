//! Which object a piece of geometry belongs to.

/// One object: the frame its geometry comes in, and its instance id when the frame's clouds are
/// labelled. Objects are replaced, kept alive and removed by key.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObjectKey {
    /// The frame its geometry comes in.
    pub frame: String,
    /// Its instance id in the frame's labelled clouds; None: the frame's one object.
    pub label: Option<i64>,
}

impl std::fmt::Display for ObjectKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.label {
            Some(label) => write!(f, "frame `{}`, instance {label}", self.frame),
            None => write!(f, "frame `{}`", self.frame),
        }
    }
}
