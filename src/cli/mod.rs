//! The subcommands that are more than a call into the library.

pub mod bag;
pub mod basis;
pub mod demo;
pub mod eval;
pub mod infer;
pub mod node;
pub mod scan;
pub mod scene;
pub mod simulate;
pub mod train;

/// Prints a report as pretty JSON on stdout (what every `--json` flag does).
pub fn print_json(report: &impl serde::Serialize) {
    println!(
        "{}",
        serde_json::to_string_pretty(report).expect("reports are plain data")
    );
}
