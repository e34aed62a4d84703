//! `lash validate`: the validation problems against their published reference solutions.

use super::{json, CliError, Output};

/// Options of `lash validate`.
#[derive(clap::Args)]
pub struct Args {
    /// Print the rows as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs every validation problem and prints one row each; a row over its limit fails the
/// check.
pub fn run(a: Args) -> Result<Output, CliError> {
    let rows = lash::validation::run_all();
    if a.json {
        println!("{}", json(&rows));
    } else {
        println!(
            "{:<21} {:<56} {:>6} {:>9} {:>7} {:>6} {:>4} {:>4} {:>6} {:>5} {:>5} {:>6}  result",
            "problem", "variant", "rtol", "error", "limit", "steps", "etf", "ncf", "res", "jac", "lu", "nni"
        );
        let mut notes = vec![];
        for (k, r) in rows.iter().enumerate() {
            println!(
                "{:<21} {:<56} {:>6.0e} {:>9.3e} {:>7.0e} {:>6} {:>4} {:>4} {:>6} {:>5} {:>5} {:>6}  {} [{}]",
                r.problem,
                r.variant,
                r.rtol,
                r.error,
                r.error_limit,
                r.steps,
                r.error_test_failures,
                r.newton_failures,
                r.residual_evals,
                r.jacobian_evals,
                r.lu_factorisations,
                r.newton_iters,
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
    Ok(Output::checked(rows.iter().all(|r| r.pass)))
}
