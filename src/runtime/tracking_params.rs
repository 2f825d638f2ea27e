//! `tracking.*`: how later frames of a running cloud object correct it.

use serde::{Deserialize, Serialize};

use crate::error::ensure;
use crate::pipeline::TrackingOptions;

/// How a stream of clouds is tracked (see [`crate::pipeline::Tracker`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TrackingParams {
    /// A cloud for a frame (or label) that already runs an object corrects it instead of
    /// rebuilding it; false rebuilds the object from every cloud. Default true.
    pub enabled: bool,
    /// How hard a frame pulls the object, as k h^2: 1 moves a free body halfway toward what
    /// was seen in one step. Default 1.
    pub stiffness: f64,
    /// The camera's depth noise (standard deviation) at 1 m, m; it grows with the square of
    /// the depth. Default 0.002.
    pub noise_m: f64,
    /// Correspondences farther than the larger of 4 noise deviations and this share of the
    /// object's diagonal are outliers. Default 0.05.
    pub gate_fraction: f64,
    /// A frame with more than this share of its points beyond the gate is unexplained: it
    /// corrects nothing. Default 0.5.
    pub unexplained_share: f64,
    /// After this many unexplained frames in a row the object is replaced (`object_replaced`)
    /// and the next cloud builds a new one. Default 5.
    pub replace_after_frames: u32,
    /// With no frame for this long the object runs on physics alone (`tracking_paused`) until
    /// frames return (`tracking_resumed`), s. Default 0.2.
    pub pause_after_s: f64,
    /// Frames that return within this long lock on again, pulled back with the wider gate if
    /// the object moved unseen; a cloud after a longer gap (clouds sent now and then, not a
    /// stream) builds the object anew, as without tracking, s. Default 2.
    pub relock_within_s: f64,
    /// Points of a frame matched, at most (a cloud's pixels thinned evenly); an even 500 of
    /// them pull the object. Default 2000.
    pub max_points: usize,
    /// Surface samples of the object matched against a frame. Default 2000.
    pub samples: usize,
    /// How long a frame pulls the object, s. Default 1/60 (one step at 60 Hz).
    pub hold_s: f64,
    /// Share of a frame's miss along the seen normals kept as a force nothing modelled (a
    /// hand, a poker), acting between frames; 0 corrects only while a frame pulls.
    /// Default 0.15.
    pub force_gain: f64,
    /// How long that force lasts once frames stop showing it (e-folding time), s. Default 0.5.
    pub force_memory_s: f64,
}

impl Default for TrackingParams {
    fn default() -> Self {
        let options = TrackingOptions::default();
        Self {
            enabled: true,
            stiffness: options.stiffness,
            noise_m: options.noise_m,
            gate_fraction: options.gate_fraction,
            unexplained_share: options.unexplained_share,
            replace_after_frames: 5,
            pause_after_s: 0.2,
            relock_within_s: 2.0,
            max_points: 2000,
            samples: options.samples,
            hold_s: options.hold_s,
            force_gain: options.force_gain,
            force_memory_s: options.force_memory_s,
        }
    }
}

impl TrackingParams {
    /// The tracker's options.
    pub fn options(&self) -> TrackingOptions {
        TrackingOptions {
            stiffness: self.stiffness,
            noise_m: self.noise_m,
            gate_fraction: self.gate_fraction,
            unexplained_share: self.unexplained_share,
            hold_s: self.hold_s,
            samples: self.samples,
            force_gain: self.force_gain,
            force_memory_s: self.force_memory_s,
        }
    }

    /// Checks each range; an `Error::InvalidParameter` naming the first out of range.
    pub fn validate(&self) -> crate::Result<()> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        ensure(
            positive(self.stiffness) && self.stiffness <= 1e3,
            "tracking.stiffness",
            || format!("{} is outside (0, 1000]", self.stiffness),
        )?;
        ensure(
            self.noise_m.is_finite() && self.noise_m >= 0.0,
            "tracking.noise_m",
            || format!("{} is not a depth noise (m, at least 0)", self.noise_m),
        )?;
        ensure(
            positive(self.gate_fraction) && self.gate_fraction <= 1.0,
            "tracking.gate_fraction",
            || format!("{} is outside (0, 1]", self.gate_fraction),
        )?;
        ensure(
            (0.0..=1.0).contains(&self.unexplained_share),
            "tracking.unexplained_share",
            || format!("{} is outside [0, 1]", self.unexplained_share),
        )?;
        ensure(
            self.replace_after_frames >= 1,
            "tracking.replace_after_frames",
            || "at least 1".into(),
        )?;
        ensure(
            positive(self.pause_after_s),
            "tracking.pause_after_s",
            || format!("{} s is not a positive time", self.pause_after_s),
        )?;
        ensure(
            self.relock_within_s.is_finite() && self.relock_within_s >= self.pause_after_s,
            "tracking.relock_within_s",
            || {
                format!(
                    "{} s is not a time of at least pause_after_s",
                    self.relock_within_s
                )
            },
        )?;
        ensure(self.max_points >= 16, "tracking.max_points", || {
            format!(
                "{} points are too few to match (at least 16)",
                self.max_points
            )
        })?;
        ensure(self.samples >= 64, "tracking.samples", || {
            format!("{} samples are too few (at least 64)", self.samples)
        })?;
        ensure(positive(self.hold_s), "tracking.hold_s", || {
            format!("{} s is not a positive time", self.hold_s)
        })?;
        ensure(
            self.force_gain.is_finite() && (0.0..=1.0).contains(&self.force_gain),
            "tracking.force_gain",
            || format!("{} is outside [0, 1]", self.force_gain),
        )?;
        ensure(
            positive(self.force_memory_s),
            "tracking.force_memory_s",
            || format!("{} s is not a positive time", self.force_memory_s),
        )
    }
}
