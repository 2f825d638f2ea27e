//! What acts on an object besides its own elasticity: gravity, pinned regions, a floor, pokes,
//! damping. Shared by the reduced simulator and the full-space reference so both see the same
//! physics.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::material::MaterialModel;

/// Material and integration parameters (SI units).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimParams {
    /// Young's modulus, Pa. Default 1e5.
    pub young: f64,
    /// Poisson ratio. Default 0.45.
    pub poisson: f64,
    /// Density, kg/m^3. Default 1000.
    pub density: f64,
    /// Constitutive model. Default stable Neo-Hookean.
    pub model: MaterialModel,
    /// How the reduced body integrates the bulk term: `points` (default) or `regions`
    /// (see `physics::bulk`).
    #[serde(default)]
    pub bulk: super::material::BulkIntegration,
    /// Time step, s. Default 1/60.
    pub dt: f64,
    /// Gravity, m/s^2. Default (0, 0, -9.81).
    pub gravity: Vector3<f64>,
    /// Mass-proportional damping rate, 1/s (velocity decays as exp(-rate t)). Default 0.
    pub damping: f64,
    /// Pin penalty, 1/s^2 per unit mass (pinned points act like springs of this squared
    /// angular frequency). Default 1e8.
    pub pin_stiffness: f64,
    /// How far pinned material may drift from its pin, m, at least (objects over 1 m long may
    /// drift a thousandth of their bounding diagonal): a step whose pin springs let it go
    /// farther is solved again with stiffer springs. Default 1e-3.
    #[serde(default = "default_pin_tolerance")]
    pub pin_tolerance: f64,
    /// Floor penalty, N/m^3 (pressure per metre of penetration). Default 1e7.
    pub contact_stiffness: f64,
    /// Coulomb friction coefficient of contacts (lagged stick friction, see `Stick`). Default 0.
    #[serde(default)]
    pub friction: f64,
    /// Rolling friction, m: a body resting on an obstacle resists rolling with a torque of up
    /// to this length times the normal force (see `physics::rolling`). Default 0.
    #[serde(default)]
    pub rolling_friction: f64,
    /// Newton stops when the step's mass-weighted RMS length is below this fraction of the
    /// bounding-box diagonal. Default 1e-5.
    pub tolerance: f64,
    /// Iterations per step before the solver gives up (quasi-Newton then hands the step to
    /// full Newton, which gets as many again). Default 20.
    pub max_iterations: usize,
}

impl Default for SimParams {
    fn default() -> Self {
        Self {
            young: 1e5,
            poisson: 0.45,
            density: 1000.0,
            model: MaterialModel::StableNeoHookean,
            bulk: Default::default(),
            dt: 1.0 / 60.0,
            gravity: Vector3::new(0.0, 0.0, -9.81),
            damping: 0.0,
            pin_stiffness: 1e8,
            pin_tolerance: default_pin_tolerance(),
            contact_stiffness: 1e7,
            friction: 0.0,
            rolling_friction: 0.0,
            tolerance: 1e-5,
            max_iterations: 20,
        }
    }
}

fn default_pin_tolerance() -> f64 {
    1e-3
}

impl SimParams {
    /// Checks every parameter's range. An `Error::InvalidParameter` naming the first out of
    /// range.
    pub fn validate(&self) -> crate::Result<()> {
        use crate::error::ensure;
        ensure(self.young.is_finite() && self.young > 0.0, "young", || {
            format!("must be a positive number of pascals, got {}", self.young)
        })?;
        ensure(
            self.poisson.is_finite() && self.poisson > -1.0 && self.poisson < 0.5,
            "poisson",
            || format!("must lie in (-1, 0.5), got {}", self.poisson),
        )?;
        ensure(
            self.density.is_finite() && self.density > 0.0,
            "density",
            || format!("must be positive, got {}", self.density),
        )?;
        ensure(self.dt.is_finite() && self.dt > 0.0, "dt", || {
            format!("must be a positive number of seconds, got {}", self.dt)
        })?;
        ensure(
            self.gravity.iter().all(|g| g.is_finite()),
            "gravity",
            || "must be finite".into(),
        )?;
        ensure(
            self.damping.is_finite() && self.damping >= 0.0,
            "damping",
            || format!("must be >= 0, got {}", self.damping),
        )?;
        ensure(
            self.pin_stiffness.is_finite() && self.pin_stiffness >= 0.0,
            "pin_stiffness",
            || format!("must be >= 0, got {}", self.pin_stiffness),
        )?;
        ensure(
            self.pin_tolerance.is_finite() && self.pin_tolerance > 0.0,
            "pin_tolerance",
            || {
                format!(
                    "must be a positive number of metres, got {}",
                    self.pin_tolerance
                )
            },
        )?;
        ensure(
            self.contact_stiffness.is_finite() && self.contact_stiffness >= 0.0,
            "contact_stiffness",
            || format!("must be >= 0, got {}", self.contact_stiffness),
        )?;
        ensure(
            self.friction.is_finite() && self.friction >= 0.0,
            "friction",
            || format!("must be >= 0, got {}", self.friction),
        )?;
        ensure(
            self.rolling_friction.is_finite() && self.rolling_friction >= 0.0,
            "rolling_friction",
            || format!("must be >= 0 m, got {}", self.rolling_friction),
        )?;
        ensure(self.tolerance > 0.0, "tolerance", || {
            "must be positive".into()
        })?;
        ensure(self.max_iterations > 0, "max_iterations", || {
            "must be at least 1".into()
        })
    }

    /// The material of `model`, `young` and `poisson`.
    pub fn material(&self) -> super::material::Material {
        super::material::Material {
            bulk: self.bulk,
            ..super::material::Material::from_young_poisson(self.model, self.young, self.poisson)
        }
    }
}

/// A force on one material point for a time window.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct Poke {
    /// Rest position of the point (world units).
    pub point: Vector3<f64>,
    /// Force, N.
    pub force: Vector3<f64>,
    /// Active for start <= t < end, s.
    pub start: f64,
    /// End of the window, s.
    pub end: f64,
}
