//! The `physskin` command line: [`main`] parses the arguments and runs the subcommand; the
//! modules here run those that are more than a call into the library.

mod app;
pub(crate) mod bag;
pub(crate) mod basis;
pub(crate) mod bench_sim;
pub(crate) mod demo;
pub(crate) mod eval;
pub(crate) mod infer;
pub(crate) mod node;
pub(crate) mod scan;
pub(crate) mod scene;
pub(crate) mod simulate;
pub(crate) mod track;
pub(crate) mod train;

pub use app::main;

/// Writes a bench's plot (SVG text), making its folder.
pub(crate) fn write_plot(path: &std::path::Path, svg: &str) -> crate::Result<()> {
    let io = |source| crate::Error::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    std::fs::write(path, svg).map_err(io)
}

/// Prints a report as pretty JSON on stdout (what every `--json` flag does).
pub(crate) fn print_json(report: &impl serde::Serialize) {
    println!(
        "{}",
        serde_json::to_string_pretty(report).expect("reports are plain data")
    );
}
