//! Numerical stress: the reduced solver on the cases that break simulators (stiff to soft,
//! nearly incompressible, large steps, inverted starts, a thin shell, violent pokes), with the
//! outcome of each: NaN or not, whether the energy stayed bounded, Newton iterations, how often
//! the quasi-Newton solver fell back to full Newton, and steps that did not converge.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{Matrix3, Vector3};
use serde::Serialize;

use crate::geometry::{box_grid_mesh, bundled, Shape};
use crate::physics::{SimParams, Solver};
use crate::pipeline::{BodyOptions, SoftBody, Support};
use crate::runtime::REPLAY_REFINE;
use crate::skinning::{NeuralModel, SkinningField};
use crate::Result;

/// How a case starts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Start {
    /// At rest in its own shape.
    Rest,
    /// Mirrored through its centre plane: every element has det F = -1.
    Mirrored,
    /// Squashed to 1 % of its height: det F = 0.01.
    Flattened,
}

/// One stress case.
#[derive(Clone, Debug, Serialize)]
pub struct StressCase {
    /// The case's name, as printed.
    pub name: &'static str,
    /// "box" (bundled) or "sheet" (a 0.4 m x 4 mm x 0.4 m plate standing on its edge).
    pub shape: &'static str,
    /// Young's modulus, Pa (the baseline case's: 1e5).
    pub young: f64,
    /// Poisson's ratio (baseline 0.45).
    pub poisson: f64,
    /// Time step, s (baseline 1/60).
    pub dt: f64,
    /// How the body is held (baseline: pinned at the bottom).
    pub support: Support,
    /// Whether gravity (9.81 m/s^2 down z) acts (baseline: yes).
    pub gravity: bool,
    /// How the case starts (baseline: at rest).
    pub start: Start,
    /// A sideways push on the top, in multiples of the body's weight, held for `push_s`.
    pub push_weights: f64,
    /// How long the push acts, s (baseline 0.1).
    pub push_s: f64,
    /// Simulated seconds.
    pub seconds: f64,
}

/// What became of a case.
#[derive(Clone, Debug, Serialize)]
pub struct StressRow {
    /// The case run.
    pub case: StressCase,
    /// Steps run: `seconds` / `dt`, rounded.
    pub steps: usize,
    /// Steps after which a coordinate or an energy was NaN or infinite.
    pub non_finite_steps: usize,
    /// Total energy (elastic + kinetic + gravity + pin and contact springs, J) at its highest while the push acted or at
    /// the start, and at its highest afterwards.
    pub energy_peak_j: f64,
    /// Total energy at its highest once nothing drove the body, J (null when no finite
    /// step came after).
    pub energy_after_j: f64,
    /// Total energy after the last step: where it settled.
    pub energy_end_j: f64,
    /// The energy never rose above its peak once nothing drove the body (implicit Euler with
    /// damping only takes energy out), by more than the solver's summed stopping decrements.
    pub bounded: bool,
    /// Solver iterations per step, mean over all steps (a non-finite step counts 0).
    pub iterations_mean: f64,
    /// Most solver iterations in one step.
    pub iterations_max: usize,
    /// Steps the quasi-Newton solver handed to full Newton.
    pub fallback_steps: usize,
    /// Steps whose decrement |dz . g| stayed above the convergence threshold.
    pub unconverged_steps: usize,
    /// Steps whose solver was still descending when its budget ran out and got it again
    /// (reported, not failed: the budget adapts and says so).
    pub extended_steps: usize,
    /// Steps the pin springs lost (pinned material past `pin_tolerance`), solved again with
    /// stiffer springs.
    pub stiffened_steps: usize,
    /// Farthest any pinned point was from its pin after a step, mm (0 for a free body).
    pub pin_drift_mm: f64,
    /// Largest distance of a point from its rest position, m.
    pub max_displacement_m: f64,
    /// Mean wall time of a step, ms.
    pub step_ms_mean: f64,
}

/// All of the stress run.
#[derive(Clone, Debug, Serialize)]
pub struct StressReport {
    /// One row per case, in the order given.
    pub rows: Vec<StressRow>,
    /// Rows with any non-finite step, unbounded energy, unconverged step, or pinned material
    /// more than `PIN_HOLD_MM` from its pin.
    pub failures: usize,
}

/// How far pinned material may end a step from its pin, mm.
pub const PIN_HOLD_MM: f64 = 1.0;

fn case(name: &'static str) -> StressCase {
    StressCase {
        name,
        shape: "box",
        young: 1e5,
        poisson: 0.45,
        dt: 1.0 / 60.0,
        support: Support::PinBottom,
        gravity: true,
        start: Start::Rest,
        push_weights: 2.0,
        push_s: 0.1,
        seconds: 1.5,
    }
}

/// The cases, from the everyday one to the violent ones.
pub fn stress_cases() -> Vec<StressCase> {
    let stiffness = [
        ("soft, E = 100 Pa", 1e2),
        ("stiff, E = 1e9 Pa", 1e9),
        ("steel-stiff, E = 2e11 Pa", 2e11),
    ];
    let poisson = [
        ("nu = 0.49", 0.49),
        ("nu = 0.499", 0.499),
        ("nu = 0.4999", 0.4999),
    ];
    let mut cases = vec![case("baseline")];
    cases.extend(stiffness.map(|(name, young)| StressCase {
        young,
        ..case(name)
    }));
    cases.extend(poisson.map(|(name, poisson)| StressCase {
        poisson,
        ..case(name)
    }));
    cases.extend([
        StressCase {
            dt: 0.1,
            seconds: 3.0,
            ..case("large step, dt = 0.1 s")
        },
        StressCase {
            dt: 0.5,
            push_s: 0.5,
            seconds: 10.0,
            ..case("huge step, dt = 0.5 s")
        },
        StressCase {
            young: 1e9,
            dt: 0.5,
            push_s: 0.5,
            seconds: 10.0,
            ..case("stiff and huge step")
        },
        StressCase {
            support: Support::Free,
            gravity: false,
            start: Start::Mirrored,
            push_weights: 0.0,
            ..case("inverted start (mirrored)")
        },
        StressCase {
            support: Support::Free,
            gravity: false,
            start: Start::Flattened,
            push_weights: 0.0,
            ..case("flattened start (1 % height)")
        },
        StressCase {
            young: 1e2,
            support: Support::PinTop,
            push_weights: 0.0,
            seconds: 3.0,
            ..case("soft and hanging, E = 100 Pa")
        },
        StressCase {
            shape: "sheet",
            push_weights: 0.5,
            ..case("thin sheet (1 % thick)")
        },
        StressCase {
            push_weights: 1000.0,
            push_s: 1.0 / 60.0,
            ..case("violent poke, 1000 x weight")
        },
        StressCase {
            young: 1e3,
            push_weights: 1000.0,
            push_s: 1.0 / 60.0,
            ..case("violent poke on soft, E = 1e3 Pa")
        },
    ]);
    cases
}

fn stress_shape(name: &str) -> Result<Shape> {
    match name {
        "sheet" => Ok(box_grid_mesh(Vector3::new(0.4, 0.004, 0.4), 0.02)),
        other => bundled(other)
            .ok_or_else(|| crate::Error::Geometry(format!("no bundled shape `{other}`"))),
    }
}

/// Runs `cases` (each shape's field inferred once), reporting each row as it finishes.
pub fn run_stress(cases: &[StressCase], mut progress: impl FnMut(&str)) -> Result<StressReport> {
    let model = NeuralModel::bundled()?;
    let mut fields: Vec<(&str, Shape, Arc<dyn SkinningField>)> = Vec::new();
    let mut rows = Vec::new();
    for c in cases {
        if !fields.iter().any(|(name, _, _)| *name == c.shape) {
            let shape = stress_shape(c.shape)?;
            // Refined as a replay refines (by the iterations, never by the clock), so that runs repeat.
            let options = BodyOptions {
                refine: REPLAY_REFINE,
                ..BodyOptions::default()
            };
            let field = SoftBody::infer(&model, &shape, &options)?;
            fields.push((c.shape, shape, field));
        }
        let (_, shape, field) = fields
            .iter()
            .find(|(name, _, _)| *name == c.shape)
            .expect("inferred above");
        let row = run_case(c, shape, field.clone())?;
        progress(&format!(
            "{}: {} steps, {} non-finite, bounded {}, {:.1} iterations, {} fallbacks",
            c.name,
            row.steps,
            row.non_finite_steps,
            row.bounded,
            row.iterations_mean,
            row.fallback_steps
        ));
        rows.push(row);
    }
    let failures = rows
        .iter()
        .filter(|r| {
            r.non_finite_steps > 0
                || !r.bounded
                || r.unconverged_steps > 0
                || r.pin_drift_mm > PIN_HOLD_MM
        })
        .count();
    Ok(StressReport { rows, failures })
}

fn run_case(c: &StressCase, shape: &Shape, field: Arc<dyn SkinningField>) -> Result<StressRow> {
    let options = BodyOptions {
        sim: SimParams {
            young: c.young,
            poisson: c.poisson,
            dt: c.dt,
            gravity: if c.gravity {
                Vector3::new(0.0, 0.0, -9.81)
            } else {
                Vector3::zeros()
            },
            damping: 1.0,
            ..SimParams::default()
        },
        solver: Solver::QuasiNewton,
        support: c.support,
        ..BodyOptions::default()
    };
    let points = &shape.positions;
    let mut body = SoftBody::with_field(field, shape, points, &options)?;
    let (lo, hi) = shape.bounds();
    let center = (lo + hi) / 2.0;
    let squash = match c.start {
        Start::Rest => None,
        Start::Mirrored => Some(-1.0),
        Start::Flattened => Some(0.01),
    };
    if let Some(scale) = squash {
        // x = A X + t with A = diag(1, 1, scale), keeping the centre where it is.
        let a = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, scale));
        body.start_from_affine(&a, &(center - a * center));
    }
    let weight = body.mass() * 9.81;
    let top = Vector3::new(center.x, center.y, hi.z);
    if c.push_weights > 0.0 {
        let sideways = if c.shape == "sheet" {
            Vector3::y()
        } else {
            Vector3::x()
        };
        body.push(top, sideways * c.push_weights * weight, c.push_s);
    }
    let steps = (c.seconds / c.dt).round() as usize;
    let rest: Vec<f32> = points
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let mut row = StressRow {
        case: c.clone(),
        steps,
        non_finite_steps: 0,
        energy_peak_j: f64::NEG_INFINITY,
        energy_after_j: f64::NEG_INFINITY,
        energy_end_j: f64::NAN,
        bounded: true,
        iterations_mean: 0.0,
        iterations_max: 0,
        fallback_steps: 0,
        unconverged_steps: 0,
        extended_steps: 0,
        stiffened_steps: 0,
        pin_drift_mm: 0.0,
        max_displacement_m: 0.0,
        step_ms_mean: 0.0,
    };
    let mut seconds = 0.0;
    // What the solver may leave unresolved after the peak: its stopping decrement |dz . g|,
    // summed over the steps (J).
    let mut residual = 0.0;
    for k in 0..steps {
        // Driven: the push acts in this step (its window is compared with the simulated
        // time, which a count of steps times dt only approximates).
        let driven = body.is_pushed();
        let started = Instant::now();
        let report = *body.step();
        seconds += started.elapsed().as_secs_f64();
        let energy = report.elastic_energy
            + report.kinetic_energy
            + report.gravity_energy
            + report.constraint_energy;
        let deformed = body.deformed();
        if !energy.is_finite() || !deformed.iter().all(|v| v.is_finite()) {
            row.non_finite_steps += 1;
            continue;
        }
        row.energy_end_j = energy;
        if driven || (c.start != Start::Rest && k == 0) {
            row.energy_peak_j = row.energy_peak_j.max(energy);
        } else {
            row.energy_after_j = row.energy_after_j.max(energy);
            residual += report.decrement;
        }
        row.iterations_mean += report.iterations as f64;
        row.iterations_max = row.iterations_max.max(report.iterations);
        row.fallback_steps += report.fallback as usize;
        row.unconverged_steps += !report.converged as usize;
        row.extended_steps += (report.budget_extensions > 0) as usize;
        row.stiffened_steps += (report.pin_stiffenings > 0) as usize;
        row.pin_drift_mm = row.pin_drift_mm.max(body.pin_drift() * 1e3);
        let moved = deformed
            .chunks(3)
            .zip(rest.chunks(3))
            .map(|(x, r)| {
                let d = Vector3::new(x[0] - r[0], x[1] - r[1], x[2] - r[2]);
                d.norm() as f64
            })
            .fold(0.0, f64::max);
        row.max_displacement_m = row.max_displacement_m.max(moved);
    }
    // The start's own energy counts toward the peak (a body released from rest has 0).
    row.energy_peak_j = row.energy_peak_j.max(0.0);
    let slack = residual + 1e-9 * row.energy_peak_j.abs();
    row.bounded = row.non_finite_steps == 0 && row.energy_after_j <= row.energy_peak_j + slack;
    row.iterations_mean /= steps as f64;
    row.step_ms_mean = seconds * 1e3 / steps as f64;
    Ok(row)
}
