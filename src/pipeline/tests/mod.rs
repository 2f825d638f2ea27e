//! The pipeline's tests that need a whole body or the shipped network: one camera's view
//! completed to the right solid, the network's outputs against their golden record, and a
//! field refined while its body moves.

mod moved;
mod neural;
mod partial_views;
mod refine;
