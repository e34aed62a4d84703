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
    /// Benchmarks measured side by side in one run, reported as ratios to lash.
    Bench {
        #[command(subcommand)]
        what: BenchWhat,
    },
}

#[derive(Subcommand)]
enum BenchWhat {
    /// The DAE layer: lash's BDF against diffsol's BDF and explicit stepping.
    Dae {
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
        /// Repeats per timing (the best is kept).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::Validate { json } => {
            let rows = lash::validation::run_all();
            if json {
                println!("{}", serde_json::to_string_pretty(&rows).expect("rows serialise"));
            } else {
                println!(
                    "{:<21} {:<56} {:>6} {:>9} {:>7} {:>6} {:>4} {:>4} {:>6} {:>5} {:>5} {:>6}  result",
                    "problem",
                    "variant",
                    "rtol",
                    "error",
                    "limit",
                    "steps",
                    "etf",
                    "ncf",
                    "res",
                    "jac",
                    "lu",
                    "nni"
                );
                let mut notes = vec![];
                for (k, r) in rows.iter().enumerate() {
                    println!(
                        "{:<21} {:<56} {:>6.0e} {:>9.3e} {:>7.0e} {:>6} {:>4} {:>4} {:>6} {:>5} {:>5} {:>6}  {} [{}]",
                        r.problem, r.variant, r.rtol, r.error, r.error_limit, r.steps, r.error_test_failures, r.newton_failures,
                        r.residual_evals, r.jacobian_evals, r.lu_factorisations, r.newton_iters,
                        if r.pass { "PASS" } else { "FAIL" },
                        k + 1
                    );
                    if !r.note.is_empty() {
                        notes.push(format!("[{}] {}: {}", k + 1, r.error_measure, r.note));
                    } else {
                        notes.push(format!("[{}] {}", k + 1, r.error_measure));
                    }
                }
                println!("\netf: error-test failures, ncf: Newton failures, res/jac/lu/nni: residual evaluations, Jacobians, LU factorisations, Newton iterations");
                for n in notes {
                    println!("{n}");
                }
            }
            if rows.iter().all(|r| r.pass) {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Command::Bench {
            what: BenchWhat::Dae { json, repeats },
        } => {
            let rows = lash::bench::bench_dae(repeats);
            if json {
                println!("{}", serde_json::to_string_pretty(&rows).expect("rows serialise"));
            } else {
                println!(
                    "{:<22} {:<20} {:<40} {:>10} {:>9} {:>10} {:>10} {:>9} {:>9}",
                    "problem",
                    "solver",
                    "setting",
                    "error",
                    "steps",
                    "rhs evals",
                    "wall s",
                    "steps/x",
                    "time/x"
                );
                for r in &rows {
                    println!(
                        "{:<22} {:<20} {:<40} {:>10.2e} {:>9} {:>10} {:>10.4} {:>9.2} {:>9.2}{}",
                        r.problem,
                        r.solver,
                        r.setting,
                        r.error,
                        r.steps,
                        r.rhs_evals,
                        r.wall_s,
                        r.steps_ratio,
                        r.time_ratio,
                        r.failure
                            .as_ref()
                            .map(|f| format!("  FAILED: {f}"))
                            .unwrap_or_default()
                    );
                }
                println!("(steps/x, time/x: ratio to lash BDF on the same problem, measured in this run)");
            }
            ExitCode::SUCCESS
        }
    }
}
