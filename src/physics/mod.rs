//! Physics: materials, the reduced subspace and its implicit integrator, lifting, obstacles, and
//! the full-space FEM reference.

mod assembly;
mod bulk;
mod fem;
mod helper;
mod hull;
mod lift;
mod material;
mod obstacle;
mod reduced;
mod rolling;
mod scene;
mod shares;
mod strain;
mod subspace;

pub use fem::{FemElement, FemSim};
pub use lift::Lifter;
pub use material::{BulkIntegration, Material, MaterialModel};
pub use obstacle::Obstacle;
pub(crate) use obstacle::Penetration;
pub(crate) use reduced::{state_projection, SimSetup};
pub use reduced::{ObservationTerm, ReducedSim, Solver, StepReport, UnmodelledForce};
pub use scene::Poke;
pub use scene::SimParams;
pub use subspace::Subspace;
pub(crate) use subspace::{phi_of, sample};
