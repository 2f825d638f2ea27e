//! Physics: materials, the reduced subspace and its implicit integrator, lifting, obstacles, and
//! the full-space FEM reference.

mod assembly;
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

pub use fem::FemSim;
pub use hull::ConvexHull;
pub use lift::Lifter;
pub use material::{Material, MaterialModel, Matrix9};
pub use obstacle::{Obstacle, Penetration, Stick, STICK_SLIP};
pub use reduced::{state_projection, ObservationTerm, ReducedSim, SimSetup, Solver, StepReport};
pub use scene::{Poke, SimParams};
pub use subspace::{phi_of, sample, Subspace};
