//! The `refl` command line: `refl report` (error against run time for every
//! method), `refl plan` (refl-core's pass plan per camera pose),
//! `refl calibrate` (the planner's cost and error table) and
//! `refl export-crosscheck` (scene + rays + obvhs hits for the
//! Embree cross-check in cpp_tests).

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "refl",
    version,
    about = "Reflection-rendering kernels: reports and tools"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Render the built-in scenes with every method at several settings and
    /// write the error-vs-time report (summary.csv, summary.md, plot, images).
    Report(refl_app::report::Options),
    /// Print refl-core's frame summary and plan (passes run and skipped,
    /// with the reason) for every camera pose of the scenes.
    Plan(refl_app::report::PlanArgs),
    /// Measure the planner's cost and error model (time per pixel as a
    /// ratio to the reference tracer's, error per technique, roughness
    /// class and surface) and write the calibration table.
    Calibrate(refl_app::report::calibrate::CalibrateArgs),
    /// Write a scene (OBJ), a ray set and its obvhs hits for the C++
    /// obvhs-vs-Embree cross-check.
    ExportCrosscheck {
        /// Output directory (created).
        dir: PathBuf,
        /// Triangle budget of the exported room scene.
        #[arg(long, default_value_t = 100_000)]
        tris: usize,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli
        .command
        .unwrap_or(Command::Report(refl_app::report::Options::default()))
    {
        Command::Report(opts) => {
            refl_app::report::run(&opts).map(|dir| println!("report written to {}", dir.display()))
        }
        Command::Plan(args) => refl_app::report::plans(&args).map(|text| print!("{text}")),
        Command::Calibrate(args) => refl_app::report::calibrate::calibrate(&args).map(|cal| {
            print!("{}", refl_app::report::calibrate::markdown(&cal));
            println!("calibration table written to {}", args.out.display());
        }),
        Command::ExportCrosscheck { dir, tris } => refl_app::export::export_crosscheck(&dir, tris)
            .map(|()| println!("cross-check data written to {}", dir.display()))
            .map_err(|e| e.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("refl: {e}");
            ExitCode::FAILURE
        }
    }
}
