//! The subcommands that are more than a call into the library.

pub mod bag;
pub mod demo;
pub mod eval;
pub mod infer;
pub mod node;
pub mod train;
