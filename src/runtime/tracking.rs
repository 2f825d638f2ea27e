//! Streams in the runtime: a cloud for an object that already runs is an observation of it.
//! The stage hands it to the object's tracker, replaces the object when frames stop
//! explaining it, and pauses and resumes tracking as frames stop and return.

use nalgebra::Vector3;

use super::object_key::ObjectKey;
use super::tracking_params::TrackingParams;
use crate::pipeline::{FrameFit, SoftBody, Tracker};

/// A frame of a running object, in the frame the object is simulated in.
#[derive(Clone, Debug)]
pub struct Observation {
    /// The object.
    pub key: ObjectKey,
    /// The id of the object the builder matched it to.
    pub id: u32,
    /// The frame's points, thinned to `tracking.max_points`.
    pub points: Vec<Vector3<f64>>,
    /// Where the camera was.
    pub viewpoint: Vector3<f64>,
    /// The tracking parameters when the frame arrived.
    pub params: TrackingParams,
}

/// What a frame did to its object.
pub enum Verdict {
    /// It corrected the object (after a pause: `resumed` says for how long frames had stopped).
    Used { resumed: Option<f64> },
    /// It did not explain the object, not yet for long enough to replace it.
    Skipped,
    /// Frames have not explained the object for `tracking.replace_after_frames` in a row: the
    /// reason, for `object_replaced`.
    Replace(String),
}

/// One object's tracking.
#[derive(Default)]
pub struct TrackState {
    tracker: Option<Tracker>,
    /// Node time of the last frame, ns.
    last_frame_ns: Option<i64>,
    pause_after_ns: i64,
    paused: bool,
    unexplained_run: u32,
    /// The last frame's fit.
    pub last: Option<FrameFit>,
}

impl TrackState {
    /// Takes `frame`, arrived at node time `now_ns`, for `body`:
    /// `tracking.replace_after_frames` unexplained frames in a row replace the object.
    pub fn observe(&mut self, body: &mut SoftBody, frame: &Observation, now_ns: i64) -> Verdict {
        let params = &frame.params;
        let options = params.options();
        let tracker = match &mut self.tracker {
            Some(t) if *t.options() == options => t,
            slot => slot.insert(Tracker::new(body, &options)),
        };
        let resumed = self
            .last_frame_ns
            .filter(|_| self.paused)
            .map(|t| (now_ns - t) as f64 / 1e9);
        self.pause_after_ns = (params.pause_after_s * 1e9) as i64;
        self.last_frame_ns = Some(now_ns);
        self.paused = false;
        let fit = match tracker.observe(body, &frame.points, &frame.viewpoint) {
            Ok(fit) => fit,
            Err(e) => {
                // No fit of this frame: the last one is not counted again.
                self.last = None;
                return Verdict::Replace(format!("its frame could not be matched: {e}"));
            }
        };
        let applied = fit.applied;
        let why = format!(
            "{:.1} % of the frame's {} points unexplained (gate: {} noise at 1 m, {} of the \
             diagonal), residual {:.2} mm",
            100.0 * fit.unexplained_share,
            fit.observed,
            params.noise_m,
            params.gate_fraction,
            fit.residual_m * 1e3
        );
        self.last = Some(fit);
        if applied {
            self.unexplained_run = 0;
            return Verdict::Used { resumed };
        }
        self.unexplained_run += 1;
        if self.unexplained_run >= params.replace_after_frames {
            let frames = self.unexplained_run;
            return Verdict::Replace(format!(
                "{frames} frames in a row not explained; the last: {why}"
            ));
        }
        Verdict::Skipped
    }

    /// After a step: the observation's hold runs out.
    pub fn stepped(&mut self, body: &mut SoftBody) {
        if let Some(tracker) = &mut self.tracker {
            tracker.stepped(body);
        }
    }

    /// At node time `now_ns`: with no frame for `tracking.pause_after_s`, the object runs on
    /// physics alone; returns for how long frames have stopped when it pauses now.
    pub fn pause_if_stopped(&mut self, body: &mut SoftBody, now_ns: i64) -> Option<f64> {
        let last = self.last_frame_ns?;
        if self.paused || now_ns - last <= self.pause_after_ns {
            return None;
        }
        self.paused = true;
        if let Some(tracker) = &mut self.tracker {
            tracker.pause(body);
        }
        Some((now_ns - last) as f64 / 1e9)
    }

    /// Whether frames have corrected the object and still arrive.
    pub fn is_tracking(&self) -> bool {
        self.last_frame_ns.is_some() && !self.paused
    }

    /// The body's subspace changed (a refined field): its samples are taken again at the next
    /// frame.
    pub fn rebased(&mut self) {
        self.tracker = None;
    }
}

/// What the frames of every stream did over a while, for /diagnostics.
#[derive(Clone, Debug, Default)]
pub struct TrackingWindow {
    /// Objects whose frames still arrive.
    pub tracked: usize,
    /// Frames that corrected their object, and those that did not.
    pub frames_used: u64,
    pub frames_skipped: u64,
    /// Each frame's residual, m.
    pub residuals_m: Vec<f64>,
}

impl TrackingWindow {
    /// Counts one frame's fit.
    pub fn take(&mut self, fit: &FrameFit) {
        if fit.applied {
            self.frames_used += 1;
            self.residuals_m.push(fit.residual_m);
        } else {
            self.frames_skipped += 1;
        }
    }
}
