//! The `lash` command-line tool.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// lash: mechanisms with joint clearance, simulated with a stiff-DAE BDF on sparse LU.
#[derive(Parser)]
#[command(name = "lash", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run the validation problems against their published reference solutions.
    Validate {
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Validate { json } => {
            let rows = lash::validation::run_all();
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&rows).expect("rows serialise")
                );
            } else {
                for r in &rows {
                    println!(
                        "{:<22} {:<48} rtol {:.0e} err {:.3e} (limit {:.0e}) steps {:>6} etf {:>4} ncf {:>4} res {:>7} jac {:>5} lu {:>5} nni {:>7} {:>8.3}s {}  {}",
                        r.problem, r.variant, r.rtol, r.error, r.error_limit, r.steps, r.error_test_failures, r.newton_failures,
                        r.residual_evals, r.jacobian_evals, r.lu_factorisations, r.newton_iters, r.wall_s,
                        if r.pass { "PASS" } else { "FAIL" }, r.note
                    );
                }
            }
            if rows.iter().all(|r| r.pass) {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
