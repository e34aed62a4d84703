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
    /// The WUT MR2120 parallel mechanism of the reference paper.
    Mr2120 {
        #[command(subcommand)]
        what: Mr2120What,
    },
}

#[derive(Subcommand)]
enum Mr2120What {
    /// Table 2: drive angles at M1, M2, M3 beside the paper's, with singularity measures.
    Kinematics {
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
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

fn mr2120_kinematics(json: bool) -> ExitCode {
    let g = lash::mechanisms::mr2120::Geometry::default();
    let rows = match lash::mechanisms::mr2120::table2(&g) {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&rows).expect("rows serialise"));
        return ExitCode::SUCCESS;
    }
    println!("MR2120 kinematics at the points of the paper's Table 2 (geometry: shared/reference/mr2120-geometry.md)");
    println!(
        "{:<5} {:>8} {:>26} {:>26} {:>9}  {:>10} {:>10} {:>10}  class",
        "point",
        "z_M [m]",
        "q1 q2 q3 lash [deg]",
        "q1 q2 q3 paper [deg]",
        "max diff",
        "det Jx[m3]",
        "direct",
        "inverse"
    );
    for r in &rows {
        println!(
            "{:<5} {:>8.4} {:>8.3} {:>8.3} {:>8.3} {:>8.2} {:>8.2} {:>8.2} {:>8.4}°  {:>10.3e} {:>10.3e} {:>10.3e}  {:?}",
            r.point,
            r.m[2],
            r.q_deg[0],
            r.q_deg[1],
            r.q_deg[2],
            r.q_paper_deg[0],
            r.q_paper_deg[1],
            r.q_paper_deg[2],
            r.max_diff_deg,
            r.singularity.det_jx,
            r.singularity.direct_measure,
            r.singularity.inverse_measure,
            r.singularity.class
        );
    }
    println!();
    for r in &rows {
        if let (Some((lo, hi)), Some(d)) = (r.z_range, r.below_boundary) {
            println!(
                "{}: reachable z on this vertical [{lo:.4}, {hi:.4}] m; {:.2} mm below the upper work-zone boundary",
                r.point,
                d * 1e3
            );
        }
    }
    println!("direct = |det Jx|/L2^3 (0: platform free with drives locked); inverse = min|Jq_ii|/(L1 L2) (0: branch stretched/folded, work-zone boundary)");
    println!(
        "classes: near below {:.0e}, singular below {:.0e}",
        lash::mechanisms::mr2120::kinematics::NEAR,
        lash::mechanisms::mr2120::kinematics::SINGULAR
    );
    ExitCode::SUCCESS
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
        Command::Mr2120 {
            what: Mr2120What::Kinematics { json },
        } => mr2120_kinematics(json),
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
