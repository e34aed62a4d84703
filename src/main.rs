//! The `lash` command-line tool: argument parsing and dispatch. Each subcommand lives in its
//! own file under `src/cli/`; [`cli::exit`] turns its result into a message and an exit code.

mod cli;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// lash: mechanisms with joint clearance, simulated with a stiff-DAE BDF on sparse LU.
#[derive(Parser)]
#[command(
    name = "lash",
    version,
    about,
    after_help = "Exit status: 0 success; 1 a check or target failed, or a run failed; 2 bad input or usage."
)]
struct Cli {
    /// No progress bars (they are also hidden when stderr is not a terminal).
    #[arg(long, short, global = true)]
    quiet: bool,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the validation problems against their published reference solutions.
    Validate(cli::validate::Args),
    /// Benchmarks measured side by side in one run, reported as ratios to lash.
    Bench {
        #[command(subcommand)]
        what: cli::bench::BenchWhat,
    },
    /// Locate where a model and recordings disagree, name the missing physics, fit it, and
    /// show the held-out improvement (equation error: measured motion -> inverse dynamics ->
    /// measured torques). Defaults: the DFKI double pendulum, fit on runs 00-05, held out 12-13.
    Diagnose(cli::diagnose::Args),
    /// Clearance design: the allowable clearance for a required positioning accuracy.
    Design {
        #[command(subcommand)]
        what: cli::design::DesignWhat,
    },
    /// Validate model files (TOML): degrees of freedom, joints, drivers, sensors, parameters,
    /// assembly at t = 0.
    Check(cli::model::CheckArgs),
    /// Simulate a model file's mechanism: every sensor to CSV, one chart per sensor column.
    Simulate(cli::model::SimulateArgs),
    /// The WUT MR2120 parallel mechanism of the reference paper.
    Mr2120 {
        #[command(subcommand)]
        what: cli::mr2120::Mr2120What,
    },
}

fn main() -> ExitCode {
    // A closed pipe (`lash check … | head`) ends the process as it ends any Unix tool,
    // instead of a panic on the next print: Rust starts programs with SIGPIPE ignored.
    #[cfg(unix)]
    // SAFETY: called once at start-up, before any thread exists; SIG_DFL is a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let args = Cli::parse();
    cli::progress::set_quiet(args.quiet);
    let result = match args.command {
        Command::Validate(a) => cli::validate::run(a),
        Command::Bench { what } => cli::bench::run(what),
        Command::Diagnose(a) => cli::diagnose::run(a),
        Command::Design { what } => cli::design::run(what),
        Command::Check(a) => cli::model::check(a),
        Command::Simulate(a) => cli::model::simulate_cmd(a),
        Command::Mr2120 { what } => cli::mr2120::run(what),
    };
    cli::exit(result)
}
