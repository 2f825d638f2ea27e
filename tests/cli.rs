//! The binary as a user runs it: the README's main command and the quick simulation bench.

use std::process::Command;

fn physskin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_physskin"))
}

#[test]
fn simulate_prints_a_summary_with_the_error_against_the_reference() {
    let out = physskin()
        .args(["simulate", "--steps", "10", "--resolution", "24"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for line in [
        "shape            rod",
        "reduced step",
        "FEM step",
        "error vs FEM",
    ] {
        assert!(stdout.contains(line), "missing {line:?} in:\n{stdout}");
    }
}

#[test]
fn simulate_refuses_unknown_shapes_by_name() {
    let out = physskin()
        .args(["simulate", "--shape", "teapot"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("teapot") && stderr.contains("creature"),
        "{stderr}"
    );
}

#[test]
fn quick_sim_bench_reports_every_row_with_speed_next_to_error() {
    let plot = std::env::temp_dir().join(format!("physskin-sim-{}.svg", std::process::id()));
    let out = physskin()
        .args(["bench", "sim", "--quick", "--json", "--plot"])
        .arg(&plot)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let rows = report["rows"].as_array().expect("rows");
    assert!(!rows.is_empty());
    for row in rows {
        for key in ["shape", "scenario", "field", "solver"] {
            assert!(row[key].is_string(), "{key} in {row}");
        }
        for key in ["vertices", "handles", "cubature"] {
            assert!(row[key].as_u64().is_some_and(|v| v > 0), "{key} in {row}");
        }
        for key in ["step_ms", "fem_step_ms", "error_pct"] {
            let v = row[key].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v >= 0.0, "{key} in {row}");
        }
        // The reduced model tracks the reference: a few percent of the diagonal at most.
        assert!(row["error_pct"].as_f64().unwrap() < 15.0, "{row}");
    }
    let shapes: std::collections::BTreeSet<_> =
        rows.iter().map(|r| r["shape"].as_str().unwrap()).collect();
    assert_eq!(shapes.len(), 3, "three shapes: {shapes:?}");
    // Every fast-solver row sits beside a full Newton row of the same configuration, with an
    // error within 1.5x of it.
    for fast in rows.iter().filter(|r| r["solver"] == "quasi_newton") {
        let newton = rows
            .iter()
            .find(|r| {
                r["solver"] == "newton"
                    && ["shape", "scenario", "handles", "cubature"]
                        .iter()
                        .all(|k| r[*k] == fast[*k])
            })
            .expect("a newton row beside each quasi-Newton row");
        let (e_fast, e_newton) = (
            fast["error_pct"].as_f64().unwrap(),
            newton["error_pct"].as_f64().unwrap(),
        );
        assert!(e_fast <= 1.5 * e_newton + 1e-3, "{fast} vs {newton}");
    }
    assert!(report["lift_100k_ms"]
        .as_f64()
        .is_some_and(|v| v.is_finite() && v > 0.0));
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("<circle"));
    std::fs::remove_file(&plot).ok();
}
