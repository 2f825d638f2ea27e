//! Which prior placed a completed view's centre: it is reported, and it decides how closely
//! the hidden side follows the reflection.

use serde::Serialize;

/// The prior that placed the hidden side's centre (and how it was followed).
#[derive(Clone, Copy, Debug, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Prior {
    /// The ellipsoid fitted to what was seen; followed pixel by pixel.
    Ellipsoid,
    /// The box two or three faces in view give; followed pixel by pixel.
    Box,
    /// A long object's axis, through the circle or ellipse fitted across its middle.
    LongAxis,
    /// A long object's axis, as deep as a round rod's would be.
    Long,
    /// Another compact object: at least half its breadth deep, a generous fill.
    Compact,
    /// A compact object whose outline sprawls (limbs): as `Compact`, but no deeper behind each
    /// pixel than the rim's mid-surface puts its hidden side (see `midsurface`).
    Limbs,
}

impl Prior {
    /// Whether the completion follows the reflection pixel by pixel and is made symmetric about
    /// its centre: every prior but `Compact`'s and `Limbs`'.
    pub(super) fn symmetric(self) -> bool {
        !matches!(self, Prior::Compact | Prior::Limbs)
    }

    /// The name reported, as serialized.
    pub fn name(self) -> &'static str {
        match self {
            Prior::Ellipsoid => "ellipsoid",
            Prior::Box => "box",
            Prior::LongAxis => "long_axis",
            Prior::Long => "long",
            Prior::Compact => "compact",
            Prior::Limbs => "limbs",
        }
    }
}
