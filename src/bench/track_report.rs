//! What `bench track` reports: a row per sequence, mode and seed of the camera's noise, and
//! with several seeds each sequence and mode's errors over them. One draw's row can hang on it
//! (a camera moved by a rounding moved a row by 61 %, docs/tracking.md); the spread says how
//! far a row can be trusted.

use serde::Serialize;

/// What one mode did on one sequence.
#[derive(Clone, Debug, Serialize)]
pub struct TrackRow {
    /// The sequence.
    pub sequence: String,
    /// `rebuild`, `uncorrected` or `tracked`.
    pub mode: String,
    /// The seed of the camera's noise.
    pub seed: u64,
    /// Bodies built.
    pub builds: usize,
    /// Frames the camera sent.
    pub frames: usize,
    /// RMS distance of the observed material points to their true places over the sequence,
    /// % of the object's diagonal.
    pub seen_error_pct: f64,
    /// The same for the surface the first frame did not see.
    pub hidden_error_pct: f64,
    /// The seen points' error while the view was blocked (sequences with a blocked view).
    pub blocked_error_pct: Option<f64>,
    /// Tracked: the seen points' error of the best state the body's subspace has (least squares
    /// against the truth, step by step), what no correction can go below.
    pub subspace_fit_pct: Option<f64>,
    /// Symmetric Chamfer distance between the body's whole deformed surface and the FEM's,
    /// mean over the sequence, % of the diagonal.
    pub chamfer_pct: f64,
    /// Correction (matching and data term) per frame, ms: median and 99th percentile.
    pub correction_ms_median: f64,
    pub correction_ms_p99: f64,
    /// Reduced step, ms: median and 99th percentile.
    pub step_ms_median: f64,
    pub step_ms_p99: f64,
    /// Builds, corrections and steps over the sequence's duration: the share of one core the
    /// node would spend on this object.
    pub cpu_share: f64,
    /// Material-point error over time (s, %), for the plot.
    #[serde(skip)]
    pub over_time: Vec<(f64, f64)>,
}

/// What `bench track` reports.
#[derive(Clone, Debug, Serialize)]
pub struct TrackReport {
    /// The observation's own error: the noisy points' RMS distance to their true places, % of
    /// the diagonal (what no tracker can go below on the seen points of one frame).
    pub observation_floor_pct: f64,
    /// One row per sequence and mode.
    pub rows: Vec<TrackRow>,
    /// MuJoCo's version, when MuJoCo made sequences.
    pub mujoco_version: Option<String>,
    /// Direction from the object toward the camera, unit.
    pub camera_direction: [f64; 3],
    /// With several seeds: each sequence and mode's errors over them.
    pub spread: Vec<TrackSpread>,
}

/// One sequence and mode over the seeds it ran with.
#[derive(Clone, Debug, Serialize)]
pub struct TrackSpread {
    /// The sequence.
    pub sequence: String,
    /// `rebuild`, `uncorrected` or `tracked`.
    pub mode: String,
    /// Seeds it ran with.
    pub seeds: usize,
    /// The seen points' error (`TrackRow::seen_error_pct`): mean, least and largest over the
    /// seeds, % of the diagonal.
    pub seen_error_pct_mean: f64,
    pub seen_error_pct_min: f64,
    pub seen_error_pct_max: f64,
    /// The largest error while the view was blocked, where it was.
    pub blocked_error_pct_max: Option<f64>,
    /// The largest Chamfer error.
    pub chamfer_pct_max: f64,
}

/// Each sequence and mode of `rows`, in the order they first ran, over its seeds.
pub fn spread_over_seeds(rows: &[TrackRow]) -> Vec<TrackSpread> {
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for row in rows {
        let key = (row.sequence.as_str(), row.mode.as_str());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys.into_iter()
        .map(|(sequence, mode)| {
            let group: Vec<&TrackRow> = (rows.iter())
                .filter(|r| r.sequence == sequence && r.mode == mode)
                .collect();
            let seen: Vec<f64> = group.iter().map(|r| r.seen_error_pct).collect();
            TrackSpread {
                sequence: sequence.into(),
                mode: mode.into(),
                seeds: group.len(),
                seen_error_pct_mean: seen.iter().sum::<f64>() / seen.len() as f64,
                seen_error_pct_min: seen.iter().copied().fold(f64::INFINITY, f64::min),
                seen_error_pct_max: seen.iter().copied().fold(f64::NEG_INFINITY, f64::max),
                blocked_error_pct_max: (group.iter())
                    .filter_map(|r| r.blocked_error_pct)
                    .reduce(f64::max),
                chamfer_pct_max: group.iter().map(|r| r.chamfer_pct).fold(0.0, f64::max),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(sequence: &str, mode: &str, seed: u64, seen: f64, blocked: Option<f64>) -> TrackRow {
        TrackRow {
            sequence: sequence.into(),
            mode: mode.into(),
            seed,
            builds: 1,
            frames: 10,
            seen_error_pct: seen,
            hidden_error_pct: 0.0,
            blocked_error_pct: blocked,
            subspace_fit_pct: None,
            chamfer_pct: seen / 2.0,
            correction_ms_median: 0.0,
            correction_ms_p99: 0.0,
            step_ms_median: 0.0,
            step_ms_p99: 0.0,
            cpu_share: 0.0,
            over_time: Vec::new(),
        }
    }

    /// Rows of one sequence and mode are gathered over their seeds, in the order they ran.
    #[test]
    fn the_spread_gathers_each_sequence_and_mode_over_its_seeds() {
        let rows = [
            row("ball", "tracked", 7, 0.3, None),
            row("block", "tracked", 7, 1.0, Some(2.0)),
            row("ball", "tracked", 8, 0.5, None),
            row("block", "tracked", 8, 3.0, Some(1.0)),
            row("ball", "tracked", 9, 0.4, None),
        ];
        let spread = spread_over_seeds(&rows);
        assert_eq!(spread.len(), 2);
        let ball = &spread[0];
        assert_eq!((ball.sequence.as_str(), ball.seeds), ("ball", 3));
        assert!((ball.seen_error_pct_mean - 0.4).abs() < 1e-12);
        assert_eq!(
            (ball.seen_error_pct_min, ball.seen_error_pct_max),
            (0.3, 0.5)
        );
        assert_eq!(ball.blocked_error_pct_max, None);
        assert_eq!(ball.chamfer_pct_max, 0.25);
        let block = &spread[1];
        assert_eq!((block.seeds, block.blocked_error_pct_max), (2, Some(2.0)));
        assert_eq!(block.seen_error_pct_max, 3.0);
    }
}
