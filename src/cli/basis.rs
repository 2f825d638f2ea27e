//! `physskin bench basis`: error against time to a basis, per shape (see `bench::basis`).

use std::path::PathBuf;

use crate::bench::{basis_plot, run_basis_bench, BasisOptions, BasisReport};
use crate::Result;

#[derive(clap::Args)]
pub struct BasisArgs {
    /// Bundled shape names or mesh files (comma-separated). Default plate, rod, creature and
    /// config/samples/bunny.obj.
    #[arg(long, value_delimiter = ',')]
    shapes: Vec<String>,
    /// Refinement iteration counts to measure after (comma-separated). Default 1,2,3,5,8.
    #[arg(long, value_delimiter = ',')]
    iterations: Vec<u32>,
    /// Where the error-against-time plot goes (SVG).
    #[arg(long, default_value = "target/bench/basis.svg")]
    plot: PathBuf,
    #[arg(long)]
    json: bool,
}

pub fn run(args: BasisArgs) -> Result<()> {
    let mut options = BasisOptions::default();
    if !args.shapes.is_empty() {
        options.shapes = args.shapes;
    }
    if !args.iterations.is_empty() {
        options.iterations = args.iterations;
    }
    let report = run_basis_bench(&options, |line| eprintln!("{line}"))?;
    super::write_plot(&args.plot, &basis_plot(&report))?;
    if args.json {
        super::print_json(&report);
    } else {
        print_table(&report);
        println!("plot: {}", args.plot.display());
    }
    Ok(())
}

fn print_table(report: &BasisReport) {
    println!("| shape | basis | iterations | ms to the basis | error % |");
    println!("|---|---|---:|---:|---:|");
    for p in &report.rows {
        let iterations = p.iterations.map_or("-".to_string(), |i| i.to_string());
        println!(
            "| {} | {} | {iterations} | {:.1} | {:.3} |",
            p.shape, p.basis, p.build_ms, p.error_pct
        );
    }
}
