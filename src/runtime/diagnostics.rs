//! The node's health for /diagnostics: the stepper and the build thread count, once a second
//! a DiagnosticArray says how it went (WARN when ticks were missed, ERROR when the recording
//! failed).

use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::Mutex;

use crate::bag::RecorderHealth;
use crate::msg::{DiagnosticArray, DiagnosticStatus, Header, KeyValue};

/// Counters shared by the threads of the node.
#[derive(Default)]
pub struct Health {
    /// Geometry handed to the build thread and not yet built or refused.
    pub builds_queued: AtomicI64,
    missed_total: AtomicU64,
    window: Mutex<Window>,
    /// Frames of streams since start, and the last window's residuals.
    tracking: Mutex<super::tracking::TrackingWindow>,
}

/// What happened since the last report.
#[derive(Default)]
struct Window {
    objects: usize,
    awake: usize,
    missed: u64,
    step_ms: Vec<f64>,
}

impl Health {
    /// After each tick: the objects on stage, those awake, the tick's step time.
    pub fn tick(&self, objects: usize, awake: usize, step_ms: f64) {
        if let Ok(mut w) = self.window.lock() {
            w.objects = objects;
            w.awake = awake;
            w.step_ms.push(step_ms);
        }
    }

    /// After each tick: what the streams' frames did since the last.
    pub fn track(&self, window: super::tracking::TrackingWindow) {
        if let Ok(mut t) = self.tracking.lock() {
            t.tracked = window.tracked;
            t.frames_used += window.frames_used;
            t.frames_skipped += window.frames_skipped;
            t.residuals_m.extend(window.residuals_m);
        }
    }

    /// Counts ticks the stepper skipped because it was behind schedule.
    pub fn missed(&self, ticks: u64) {
        self.missed_total.fetch_add(ticks, Ordering::Relaxed);
        if let Ok(mut w) = self.window.lock() {
            w.missed += ticks;
        }
    }

    /// The report of the last window (which then starts anew).
    /// `dropped`: publications DDS refused so far (readers too far behind).
    pub fn report(
        &self,
        header: Header,
        node: &str,
        recording: Option<RecorderHealth>,
        dropped: u64,
    ) -> DiagnosticArray {
        let window = self
            .window
            .lock()
            .map(|mut w| {
                let objects = (w.objects, w.awake);
                let taken = std::mem::take(&mut *w);
                (w.objects, w.awake) = objects;
                taken
            })
            .unwrap_or_default();
        let mut times = window.step_ms.clone();
        times.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            if times.is_empty() {
                0.0
            } else {
                times[((times.len() as f64 * q) as usize).min(times.len() - 1)]
            }
        };
        let mut values = vec![
            kv("objects", window.objects),
            kv("awake_objects", window.awake),
            kv("missed_ticks", self.missed_total.load(Ordering::Relaxed)),
            kv("missed_ticks_last_second", window.missed),
            kv("ticks_last_second", times.len()),
            kv("step_ms_p50", format!("{:.3}", quantile(0.5))),
            kv("step_ms_p99", format!("{:.3}", quantile(0.99))),
            kv(
                "builds_queued",
                self.builds_queued.load(Ordering::Relaxed).max(0),
            ),
            kv("publications_dropped", dropped),
        ];
        values.extend(self.tracking_values());
        let rec = recording.clone().unwrap_or_default();
        values.extend([
            kv("recording_path", rec.path),
            kv("recording_messages", rec.messages),
            kv("recording_bytes", rec.bytes),
            kv("recording_dropped", rec.dropped),
        ]);
        let (level, message) = match (&rec.failure, window.missed) {
            (Some(e), _) => (DiagnosticStatus::ERROR, format!("recording failed: {e}")),
            (None, 0) => (DiagnosticStatus::OK, "stepping on time".to_string()),
            (None, n) => (
                DiagnosticStatus::WARN,
                format!("{n} ticks missed in the last second"),
            ),
        };
        DiagnosticArray {
            header,
            status: vec![DiagnosticStatus {
                level,
                name: format!("physskin: {node}"),
                message,
                hardware_id: node.into(),
                values,
            }],
        }
    }
}

impl Health {
    /// Objects tracked, frames used and skipped since start, and the residual's p50 and p99
    /// over the frames since the last report (mm; 0 without frames).
    fn tracking_values(&self) -> Vec<KeyValue> {
        let Ok(mut t) = self.tracking.lock() else {
            return Vec::new();
        };
        let mut residuals = std::mem::take(&mut t.residuals_m);
        residuals.sort_by(f64::total_cmp);
        let quantile = |q: f64| {
            residuals
                .get(((residuals.len() as f64 * q) as usize).min(residuals.len().max(1) - 1))
                .map_or(0.0, |r| r * 1e3)
        };
        vec![
            kv("objects_tracked", t.tracked),
            kv("frames_used", t.frames_used),
            kv("frames_skipped", t.frames_skipped),
            kv("tracking_residual_mm_p50", format!("{:.3}", quantile(0.5))),
            kv("tracking_residual_mm_p99", format!("{:.3}", quantile(0.99))),
        ]
    }
}

fn kv(key: &str, value: impl ToString) -> KeyValue {
    KeyValue {
        key: key.into(),
        value: value.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value<'a>(a: &'a DiagnosticArray, key: &str) -> &'a str {
        let v = a.status[0].values.iter().find(|v| v.key == key);
        &v.unwrap_or_else(|| panic!("no {key}")).value
    }

    #[test]
    fn a_window_reports_its_ticks_then_starts_anew() {
        let h = Health::default();
        for ms in 1..=100 {
            h.tick(2, 1, ms as f64);
        }
        let a = h.report(Header::default(), "/cell/skin", None, 0);
        assert_eq!(a.status[0].level, DiagnosticStatus::OK);
        assert_eq!(value(&a, "objects"), "2");
        assert_eq!(value(&a, "awake_objects"), "1");
        assert_eq!(value(&a, "step_ms_p50"), "51.000");
        assert_eq!(value(&a, "step_ms_p99"), "100.000");
        h.missed(3);
        let b = h.report(Header::default(), "/cell/skin", None, 0);
        assert_eq!(b.status[0].level, DiagnosticStatus::WARN);
        assert_eq!(value(&b, "ticks_last_second"), "0");
        assert_eq!(value(&b, "objects"), "2");
        let failed = RecorderHealth {
            failure: Some("disk full".into()),
            ..Default::default()
        };
        let c = h.report(Header::default(), "/cell/skin", Some(failed), 0);
        assert_eq!(c.status[0].level, DiagnosticStatus::ERROR);
        assert_eq!(value(&c, "missed_ticks"), "3");
    }
}
