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
pub mod track;
pub mod train;

/// Writes a bench's plot (SVG text), making its folder.
pub fn write_plot(path: &std::path::Path, svg: &str) -> physskin::Result<()> {
    let io = |source| physskin::Error::Io {
        path: path.to_path_buf(),
        source,
    };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    std::fs::write(path, svg).map_err(io)
}

/// Prints a report as pretty JSON on stdout (what every `--json` flag does).
pub fn print_json(report: &impl serde::Serialize) {
    println!(
        "{}",
        serde_json::to_string_pretty(report).expect("reports are plain data")
    );
}
