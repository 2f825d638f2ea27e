//! `bench track`'s sequences made by an engine physskin did not write: MuJoCo's soft block
//! (`benches/peers/mujoco_track.py`, flex elasticity on its own tetrahedra, its own contact)
//! pushed along the floor by a paddle, squeezed between two, dropped tilted. The node's
//! default material is given to MuJoCo, whose model of it (Saint Venant-Kirchhoff on linear
//! tetrahedra, soft constraints for contact) is not the node's: the tracker meets a body that
//! moves as something else computed it, as it would meet a real one.

use std::path::Path;
use std::process::Command;

use nalgebra::Vector3;
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::runtime::NodeParams;

use super::peer::script_json;
use super::track_truth::{Occluder, Truth};

/// MuJoCo substeps within each of the node's steps: its discrete integrator stays stable at
/// a soft block's contacts with these.
const SUBSTEPS: usize = 8;

/// What the script prints.
#[derive(Deserialize)]
struct MujocoTrack {
    mujoco_version: String,
    surface: Vec<[u32; 3]>,
    positions: Vec<Vec<[f64; 3]>>,
    occluders: Vec<Vec<Vec<[f64; 3]>>>,
}

/// MuJoCo's run of `scenario` (pushed, squeezed, dropped) for `seconds` at the node's step,
/// with the node's material and friction; `python` imports mujoco. Also returns MuJoCo's
/// version.
pub(super) fn run_mujoco_truth(
    python: &Path,
    scenario: &str,
    params: &NodeParams,
    seconds: f64,
) -> Result<(Truth, String)> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/peers/mujoco_track.py");
    let sim = params.sim_params();
    let run: MujocoTrack = script_json(
        Command::new(python)
            .arg(&script)
            .args(["--scenario", scenario])
            .args(["--seconds", &seconds.to_string()])
            .args(["--dt", &sim.dt.to_string()])
            .args(["--substeps", &SUBSTEPS.to_string()])
            .args(["--young", &sim.young.to_string()])
            .args(["--poisson", &sim.poisson.to_string()])
            .args(["--density", &sim.density.to_string()])
            .args(["--friction", &sim.friction.to_string()]),
        "the MuJoCo track script",
    )?;
    Ok((truth_of(&run)?, run.mujoco_version))
}

/// The script's run as a truth, checked: every step holds every vertex, every triangle names
/// one, every occluder has eight corners.
fn truth_of(run: &MujocoTrack) -> Result<Truth> {
    let invalid = |what: String| Error::Peer(format!("the MuJoCo track script's output: {what}"));
    let vertices = run.positions.first().map_or(0, Vec::len);
    if vertices == 0 || run.positions.iter().any(|p| p.len() != vertices) {
        return Err(invalid("steps with different vertex counts".into()));
    }
    if let Some(t) = run
        .surface
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= vertices))
    {
        return Err(invalid(format!("triangle {t:?} past {vertices} vertices")));
    }
    let point = |p: &[f64; 3]| Vector3::new(p[0], p[1], p[2]);
    let occluder = |corners: &Vec<[f64; 3]>| -> Result<Occluder> {
        let corners: Vec<Vector3<f64>> = corners.iter().map(point).collect();
        corners
            .try_into()
            .map_err(|c: Vec<_>| invalid(format!("an occluder of {} corners", c.len())))
    };
    let positions: Vec<Vec<Vector3<f64>>> = (run.positions.iter())
        .map(|step| step.iter().map(point).collect())
        .collect();
    let occluders = (run.occluders.iter())
        .map(|step| step.iter().map(occluder).collect::<Result<Vec<_>>>())
        .collect::<Result<Vec<_>>>()?;
    if occluders.len() != positions.len() {
        return Err(invalid("occluders for a different number of steps".into()));
    }
    let (lo, hi) = positions[0].iter().fold(
        (
            Vector3::repeat(f64::INFINITY),
            Vector3::repeat(f64::NEG_INFINITY),
        ),
        |(lo, hi), p| (lo.inf(p), hi.sup(p)),
    );
    Ok(Truth {
        surface: run.surface.clone(),
        positions,
        diagonal: (hi - lo).norm(),
        occluders,
    })
}
