//! `bench peer` against MuJoCo (pip `mujoco-core`, made into target/mujoco-venv here): the same soft
//! block in MuJoCo's three flexcomp dof variants and in physskin, dropped and poked, each
//! compared with our FEM. The bench must run MuJoCo for real (its version reported, a row per
//! variant and scenario with finite errors), and physskin's largest setting must stay close to
//! the FEM in both scenarios.

mod common;

#[test]
fn the_soft_block_runs_in_mujoco_and_physskin_against_the_fem() {
    // mujoco-core: MuJoCo's Python bindings without the viewer the `mujoco` package adds.
    let python = common::venv(
        "mujoco-venv",
        "import mujoco, numpy",
        &["mujoco-core", "numpy"],
    );
    let python = python.display().to_string();
    let plot = common::root().join("target/bench/peer-test.svg");
    let plot = plot.display().to_string();
    let report = common::physskin_json(&[
        "bench",
        "peer",
        "--json",
        "--python",
        &python,
        "--steps",
        "30",
        "--substeps",
        "1,4",
        "--plot",
        &plot,
    ]);
    assert!(
        report["mujoco_version"]
            .as_str()
            .unwrap()
            .starts_with(char::is_numeric),
        "MuJoCo said its version: {}",
        report["mujoco_version"]
    );
    let rows = report["rows"].as_array().expect("rows");
    for scenario in ["drop", "poke"] {
        for variant in ["full", "trilinear", "quadratic"] {
            let ran = rows
                .iter()
                .filter(|r| r["engine"] == "mujoco" && r["scenario"] == scenario)
                .filter(|r| r["variant"].as_str().unwrap().starts_with(variant))
                .count();
            assert_eq!(ran, 2, "{scenario}: MuJoCo {variant} at 1 and 4 substeps");
        }
        let largest = rows
            .iter()
            .find(|r| {
                r["engine"] == "physskin"
                    && r["scenario"] == scenario
                    && r["variant"] == "17 handles, 1024 cubature"
            })
            .expect("physskin's largest setting ran");
        let error = largest["error_pct"].as_f64().expect("a finite error");
        // bench peer measured 0.417 % (drop) and 0.475 % (poke) over 60 frames.
        assert!(error < 1.0, "{scenario}: physskin {error} % from the FEM");
    }
    for row in rows {
        let keys = ["engine", "variant", "step_ms", "step_ms_p99", "error_pct"];
        assert!(keys.iter().all(|k| !row[k].is_null()), "{row}: every field");
        assert!(row["step_ms"].as_f64().unwrap() > 0.0, "{row}: timed");
    }
    assert!(
        std::fs::metadata(&plot).is_ok_and(|m| m.len() > 0),
        "the plot"
    );
}
