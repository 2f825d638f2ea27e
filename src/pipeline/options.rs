//! How a body is built from geometry: what holds it, how many samples and handles it gets, its
//! material and solver, and when it may sleep.

use serde::{Deserialize, Serialize};

use crate::physics::{SimParams, Solver};
use crate::skinning::{RefineBudget, DEFAULT_REFINE_MS};

/// What holds an object in place.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Support {
    /// Nothing: the object falls freely.
    Free,
    /// A floor (z = the object's lowest point), penalty contact.
    Floor,
    /// The top 10% of the object (against gravity) is pinned, and at least a sixteenth of its
    /// volume (`pinned_slab_top`): it hangs.
    PinTop,
    /// The bottom 10% (along gravity) is pinned, and at least a sixteenth of its volume: it
    /// stands.
    PinBottom,
}

/// How a body is built from geometry.
#[derive(Clone, Debug)]
pub struct BodyOptions {
    /// Surface samples encoded by the network. Default 4096 (the trained count).
    pub surface_points: usize,
    /// Interior points that fix the field's output normalization. Default 2048.
    pub reference_points: usize,
    /// Voxels across the longest side for the inside test. Default 64.
    pub voxel_resolution: usize,
    /// Cubature points of the elastic energy. Default 256.
    pub cubature: usize,
    /// Material, time step, gravity, damping, penalties, friction and solver tolerances.
    pub sim: SimParams,
    /// Default quasi-Newton.
    pub solver: Solver,
    /// Default pin_bottom.
    pub support: Support,
    /// Handles kept, the constant one included: the smoothest of the field's. Default all.
    pub handles: Option<usize>,
    /// How long the network's field is refined toward the skinning eigenmodes before the body
    /// starts (toward the skinning eigenmodes). Default `DEFAULT_REFINE_MS` ms: the
    /// refined field is as accurate as the eigenmodes, the network's alone is not.
    pub refine: RefineBudget,
    /// When the body may sleep. Default never.
    pub sleep: Option<SleepRule>,
    /// Height of the floor of `Support::Floor`; None: the object's lowest point. Default None.
    pub floor_z: Option<f64>,
}

/// A body sleeps once its RMS speed has stayed below `speed` for `after` seconds with no force
/// on it; it is then not stepped until a force, a pin, a moving attachment or a collider near
/// it wakes it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SleepRule {
    /// m/s. Default 1e-3.
    #[serde(default = "default_sleep_speed")]
    pub speed: f64,
    /// s. Default 0.5.
    #[serde(default = "default_sleep_after")]
    pub after: f64,
}

fn default_sleep_speed() -> f64 {
    1e-3
}
fn default_sleep_after() -> f64 {
    0.5
}

impl Default for SleepRule {
    fn default() -> Self {
        Self {
            speed: default_sleep_speed(),
            after: default_sleep_after(),
        }
    }
}

impl Default for BodyOptions {
    fn default() -> Self {
        Self {
            surface_points: 4096,
            reference_points: 2048,
            voxel_resolution: 64,
            cubature: 256,
            sim: SimParams {
                damping: 1.0,
                young: 2e5,
                ..SimParams::default()
            },
            solver: Solver::QuasiNewton,
            support: Support::PinBottom,
            handles: None,
            refine: RefineBudget::Millis(DEFAULT_REFINE_MS),
            sleep: None,
            floor_z: None,
        }
    }
}
