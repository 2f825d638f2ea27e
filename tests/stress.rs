//! Numerical stress: every case of `physskin bench stress` (stiff to soft, nu toward 0.5,
//! large steps, inverted starts, a thin sheet, violent pokes) stays finite, keeps its energy
//! bounded once nothing drives it, converges every step (with its budget extended where the
//! solver still descends, which the row counts) and holds its pinned material within 1 mm.

mod common;

#[test]
fn every_stress_case_stays_finite_bounded_converged_and_pinned() {
    let report = common::physskin_json(&["bench", "stress", "--json"]);
    let rows = report["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 16, "every case ran");
    for row in rows {
        let name = row["case"]["name"].as_str().unwrap();
        assert_eq!(row["non_finite_steps"], 0, "{name}: NaN or Inf");
        assert_eq!(
            row["bounded"], true,
            "{name}: energy rose to {} J after its peak of {} J",
            row["energy_after_j"], row["energy_peak_j"]
        );
        assert_eq!(row["unconverged_steps"], 0, "{name}: unconverged steps");
        let drift = row["pin_drift_mm"].as_f64().unwrap();
        assert!(
            drift <= 1.0,
            "{name}: pinned material {drift} mm from its pin"
        );
    }
    assert_eq!(report["failures"], 0);
    // The violent pokes are what stiffening the pin springs and extending the budget are for:
    // both must have acted there (a drift within 1 mm without them would mean the pokes got
    // gentler).
    let violent = rows
        .iter()
        .find(|r| r["case"]["name"] == "violent poke on soft, E = 1e3 Pa")
        .expect("the violent poke on the soft box");
    assert!(violent["stiffened_steps"].as_u64().unwrap() > 0);
    assert!(violent["extended_steps"].as_u64().unwrap() > 0);
}
