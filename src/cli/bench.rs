//! `lash bench`: benchmarks measured side by side in one run, reported as ratios to lash.

use super::progress::Progress;
use super::{items, json, CliError, Output};
use lash::bench::charts;
use lash::bench::mr2120::{bench_mr2120, Mr2120BenchOptions, BENCH_ALPHA};
use std::path::{Path, PathBuf};

/// The benchmarks.
#[derive(clap::Subcommand)]
pub enum BenchWhat {
    /// The DAE layer: lash's BDF against diffsol's BDF and explicit stepping.
    Dae {
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
        /// Repeats per timing (the best is kept).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Also sweep Andrews' squeezer over tolerances 1e-3..1e-9 and draw its
        /// work-precision diagram into this folder.
        #[arg(long)]
        plots: Option<PathBuf>,
    },
    /// Cost per BDF step of a chain of N links joined by universal joints with clearance,
    /// against N, with the fitted log-log slope (sparse factorisation must stay sparse).
    Scaling {
        /// Chain lengths, comma-separated.
        #[arg(long, default_value = "10,100,1000,10000")]
        links: String,
        /// Simulated time per run, s (long enough for every bearing to come into contact).
        #[arg(long, default_value_t = 0.01)]
        t_end: f64,
        /// Output folder for the log-log plot.
        #[arg(long, default_value = "out/bench-scaling")]
        out: PathBuf,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The 63-DOF MR2120 clearance model along the trajectory M1 → M2 → M3: lash's BDF against
    /// Dormand–Prince, symplectic Euler and diffsol's BDF at equal accuracy (platform centre
    /// within --target of a tight reference).
    Mr2120(Mr2120BenchArgs),
    /// The static envelope of the paper's Table 3 (13 load cases per point and clearance set)
    /// by the direct equilibrium solver against dynamic relaxation, alternated in one run:
    /// wall times, speed-up, and the largest difference between the two envelopes.
    Statics {
        /// Points, comma-separated (M1, M2, M3).
        #[arg(long, default_value = "M1,M2,M3")]
        points: String,
        /// Clearance sets, comma-separated (L1, L2, L3).
        #[arg(long, default_value = "L1,L2,L3")]
        sets: String,
        /// Repeats per timing (alternated direct, relaxation; the best of each is kept).
        #[arg(long, default_value_t = 1)]
        repeats: usize,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
}

/// A comma-separated list of positive numbers (empty: none), shown as it is parsed.
#[derive(Debug, Clone, PartialEq)]
pub struct Numbers(pub Vec<f64>);

impl std::fmt::Display for Numbers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s: Vec<String> = self.0.iter().map(|x| format!("{x:e}")).collect();
        f.write_str(&s.join(","))
    }
}

impl std::str::FromStr for Numbers {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        items(s)
            .map(|x| {
                x.parse::<f64>()
                    .ok()
                    .filter(|v| *v > 0.0 && v.is_finite())
                    .ok_or_else(|| format!("'{x}' is not a positive number"))
            })
            .collect::<Result<_, _>>()
            .map(Numbers)
    }
}

/// The library's default benchmark settings (every default below is one of them).
fn defaults() -> Mr2120BenchOptions {
    Mr2120BenchOptions::default()
}

/// Options of `lash bench mr2120`; every default is `Mr2120BenchOptions::default()`'s.
#[derive(clap::Args, Debug)]
pub struct Mr2120BenchArgs {
    /// Clearance set (L1, L2, L3).
    #[arg(long, default_value_t = defaults().set)]
    set: String,
    /// End of the trajectory, s (at most the trajectory's duration).
    #[arg(long, default_value_t = defaults().t_end)]
    t_end: f64,
    /// Target accuracy of the platform centre, m.
    #[arg(long, default_value_t = defaults().target)]
    target: f64,
    /// Relative tolerance of the reference run (lash BDF).
    #[arg(long, default_value_t = defaults().reference_rtol)]
    reference_rtol: f64,
    /// Relative tolerances swept for lash's BDF, comma-separated.
    #[arg(long, default_value_t = Numbers(defaults().bdf_rtols))]
    bdf_rtols: Numbers,
    /// Relative tolerances swept for Dormand–Prince, comma-separated (empty: none).
    #[arg(long, default_value_t = Numbers(defaults().dopri_rtols))]
    dopri_rtols: Numbers,
    /// Fixed steps swept for symplectic Euler, s, comma-separated (empty: none).
    #[arg(long, default_value_t = Numbers(defaults().symplectic_steps))]
    symplectic_steps: Numbers,
    /// Relative tolerances swept for diffsol's BDF on the index-1 ODE, comma-separated
    /// (empty: none; needs the `peers` feature).
    #[arg(long, default_value_t = Numbers(defaults().diffsol_rtols))]
    diffsol_rtols: Numbers,
    /// Hunt–Crossley contact damping α of the bearings, s/m (the studies use 1; see
    /// lash::bench::mr2120::BENCH_DAMPING for why the benchmark uses more).
    #[arg(long, default_value_t = BENCH_ALPHA)]
    alpha: f64,
    /// Wall-time budget of each explicit run, s (the time ratio is then a lower bound).
    #[arg(long, default_value_t = defaults().explicit_budget_s)]
    explicit_budget: f64,
    /// Relative tolerance of an extra Dormand–Prince run that checks the reference (not
    /// given or 0: skip; every Dormand–Prince run of the sweep is already an independent
    /// check).
    #[arg(long)]
    check_rtol: Option<f64>,
    /// Output folder for the work-precision diagram.
    #[arg(long, default_value = "out/bench-mr2120")]
    out: PathBuf,
    /// Also write the model (`model.json`, the schema of `benches/exudyn/`) and the
    /// result with the reference path (`lash.json`) into this folder, for the Exudyn
    /// comparison (`bash benches/exudyn/run.sh`).
    #[arg(long)]
    export: Option<PathBuf>,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs one benchmark.
pub fn run(what: BenchWhat) -> Result<Output, CliError> {
    match what {
        BenchWhat::Dae { json, repeats, plots } => dae(json, repeats, plots.as_deref()),
        BenchWhat::Scaling {
            links,
            t_end,
            out,
            json,
        } => scaling(&links, t_end, &out, json),
        BenchWhat::Mr2120(a) => mr2120(&a),
        BenchWhat::Statics {
            points,
            sets,
            repeats,
            json,
        } => statics(&points, &sets, repeats, json),
    }
}

fn statics(points: &str, sets: &str, repeats: usize, as_json: bool) -> Result<Output, CliError> {
    use lash::mechanisms::mr2120::{clearance, geometry};
    let points = super::mr2120_points(points)?;
    let sets = items(sets)
        .map(|n| clearance::clearance_set(n).map_err(|e| CliError::Input(format!("--sets: {e}"))))
        .collect::<Result<Vec<_>, _>>()?;
    if points.is_empty() || sets.is_empty() {
        return Err(CliError::input("--points and --sets must name at least one each"));
    }
    if repeats == 0 {
        return Err(CliError::input("--repeats must be at least 1"));
    }
    let total = points.len() * sets.len();
    let mut progress = Progress::new("bench statics", total as f64);
    let b = lash::bench::statics::statics_bench(
        &geometry::Geometry::default(),
        &geometry::MassProperties::default(),
        &points,
        &sets,
        repeats,
        |k, _| progress.update(k as f64),
    );
    progress.finish();
    let b = b.map_err(CliError::run)?;
    if as_json {
        println!("{}", json(&b));
        return Ok(Output::OK);
    }
    println!(
        "{:<4} {:<4} {:>12} {:>14} {:>9} {:>12} {:>14} {:>18}",
        "pt", "set", "direct s", "relaxation s", "speed-up", "direct steps", "relax. steps", "max range diff"
    );
    for r in &b.rows {
        println!(
            "{:<4} {:<4} {:>12.4} {:>14.3} {:>8.0}x {:>12} {:>14} {:>17.2}%",
            r.point,
            r.set,
            r.direct_s,
            r.relaxation_s,
            r.speedup,
            r.direct_steps,
            r.relaxation_steps,
            100.0 * r.max_rel_difference
        );
    }
    println!(
        "total: direct {:.3} s ({:.2} ms per load case), dynamic relaxation {:.2} s: {:.0}x faster, measured in this run (best of {} alternated repeats); envelopes differ by at most {:.2} % of a range's width",
        b.direct_total_s,
        1e3 * b.direct_per_case_s,
        b.relaxation_total_s,
        b.speedup,
        b.repeats,
        100.0 * b.max_rel_difference
    );
    Ok(Output::OK)
}

fn dae(as_json: bool, repeats: usize, plots: Option<&Path>) -> Result<Output, CliError> {
    let rows = lash::bench::bench_dae(repeats);
    if let Some(dir) = plots {
        let wp = lash::bench::andrews_work_precision(&charts::ANDREWS_TOLERANCES, repeats);
        eprintln!("{}", charts::andrews_work_precision_chart(&wp, dir));
    }
    if as_json {
        println!("{}", json(&rows));
        return Ok(Output::OK);
    }
    println!(
        "{:<22} {:<20} {:<40} {:>10} {:>9} {:>10} {:>10} {:>9} {:>9}",
        "problem", "solver", "setting", "error", "steps", "rhs evals", "wall s", "steps/x", "time/x"
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
    Ok(Output::OK)
}

fn scaling(links: &str, t_end: f64, out: &Path, as_json: bool) -> Result<Output, CliError> {
    let lengths = items(links)
        .map(|s| {
            s.parse::<usize>()
                .ok()
                .filter(|n| (1..=lash::bench::scaling::MAX_LINKS).contains(n))
                .ok_or_else(|| {
                    CliError::Input(format!(
                        "--links: '{s}' is not an integer from 1 to {}",
                        lash::bench::scaling::MAX_LINKS
                    ))
                })
        })
        .collect::<Result<Vec<usize>, _>>()?;
    if lengths.is_empty() {
        return Err(CliError::input("--links names no chain length"));
    }
    if !(t_end > 0.0 && t_end.is_finite()) {
        return Err(CliError::input("--t-end must be positive"));
    }
    let mut progress = Progress::new("bench scaling", lengths.len() as f64);
    let mut k = 0.0;
    let s = lash::bench::scaling::bench_scaling(&lengths, t_end, |_| {
        progress.update(k);
        k += 1.0;
    });
    progress.finish();
    let note = charts::scaling_chart(&s, out);
    if as_json {
        println!("{}", json(&s.to_json()));
        return Ok(Output::OK);
    }
    println!(
        "clearance chain (links + crosses, 4 bearings per joint), {} s simulated per run",
        s.t_end
    );
    println!(
        "{:>7} {:>8} {:>9} {:>9} {:>9} {:>7} {:>7} {:>12} {:>12} {:>10}",
        "links",
        "bodies",
        "unknowns",
        "setup s",
        "wall s",
        "steps",
        "LU",
        "LU eq/plain",
        "per step s",
        "RSS MB"
    );
    for r in &s.rows {
        println!(
            "{:>7} {:>8} {:>9} {:>9.3} {:>9.3} {:>7} {:>7} {:>12} {:>12.3e} {:>10.1}{}",
            r.links,
            r.bodies,
            r.unknowns,
            r.setup_s,
            r.wall_s,
            r.steps,
            r.factorisations,
            format!("{}/{}", r.lu_equilibrated, r.lu_plain_fallbacks),
            r.per_step_s,
            r.resident_bytes as f64 / 1e6,
            r.failure
                .as_ref()
                .map(|f| format!("  FAILED: {f}"))
                .unwrap_or_default()
        );
    }
    println!("{}", s.slope_line());
    println!("{note}");
    Ok(Output::OK)
}

/// Writes the MR2120 clearance model of the benchmark as `dir/model.json` for the Exudyn
/// comparison.
fn export_mr2120_model(opts: &Mr2120BenchOptions, dir: &Path) -> Result<(), CliError> {
    let model = lash::bench::exudyn::export_mr2120(opts).map_err(CliError::run)?;
    std::fs::create_dir_all(dir)
        .map_err(|e| CliError::Run(format!("cannot create {}: {e}", dir.display())))?;
    let path = dir.join("model.json");
    std::fs::write(&path, json(&model))
        .map_err(|e| CliError::Run(format!("cannot write {}: {e}", path.display())))?;
    eprintln!(
        "bench mr2120: model for the Exudyn comparison written to {}",
        path.display()
    );
    Ok(())
}

fn mr2120(a: &Mr2120BenchArgs) -> Result<Output, CliError> {
    let opts = Mr2120BenchOptions {
        set: a.set.clone(),
        t_end: a.t_end,
        target: a.target,
        reference_rtol: a.reference_rtol,
        bdf_rtols: a.bdf_rtols.0.clone(),
        dopri_rtols: a.dopri_rtols.0.clone(),
        symplectic_steps: a.symplectic_steps.0.clone(),
        diffsol_rtols: a.diffsol_rtols.0.clone(),
        reference_check_rtol: a
            .check_rtol
            .filter(|r| *r != 0.0)
            .or(defaults().reference_check_rtol),
        damping: lash::contact::Damping::HuntCrossley(a.alpha),
        explicit_budget_s: a.explicit_budget,
        ..defaults()
    };
    opts.validate().map_err(CliError::input)?;
    if let Some(dir) = &a.export {
        export_mr2120_model(&opts, dir)?;
    }
    let mut current = String::new();
    let mut progress = Progress::new("", 1.0);
    let res = bench_mr2120(&opts, |label, frac| {
        if label != current {
            progress.finish();
            current = label.to_string();
            progress = Progress::new(&format!("bench mr2120: {label}"), 1.0);
        }
        progress.update(frac);
    });
    progress.finish();
    let b = res.map_err(CliError::run)?;
    let plot_note = charts::mr2120_work_precision_chart(&b, &a.out);
    if let Some(dir) = &a.export {
        let path = dir.join("lash.json");
        std::fs::write(&path, json(&b))
            .map_err(|e| CliError::Run(format!("cannot write {}: {e}", path.display())))?;
    }
    if a.json {
        println!("{}", json(&b.to_json()));
        return Ok(Output::OK);
    }
    print_mr2120(&b);
    println!("{plot_note}");
    Ok(Output::OK)
}

fn print_mr2120(b: &lash::bench::mr2120::Mr2120Bench) {
    println!(
        "MR2120 clearance model ({}), trajectory 0..{} s; accuracy = largest platform-centre distance from the reference",
        b.set, b.t_end
    );
    println!(
        "reference: lash BDF rtol {:.0e}: {} steps, {:.1} s wall{}",
        b.reference.rtol,
        b.reference.steps,
        b.reference.wall_s,
        b.reference_check
            .map(|d| format!("; Dormand-Prince check run differs by {d:.2e} m"))
            .unwrap_or_default()
    );
    println!("{}", b.horizon_statement());
    println!(
        "\n{:<44} {:>9} {:>10} {:>10} {:>8} {:>8} {:>9} {:>8} {:>7} {:>8} {:>9} {:>6}",
        "solver",
        "setting",
        "err<=hor.",
        "err 0..end",
        "steps",
        "rejected",
        "rhs evals",
        "newton",
        "LU",
        "wall s",
        "wall hor.",
        "t s"
    );
    for p in &b.points {
        println!(
            "{:<44} {:>9} {:>10.2e} {:>10.2e} {:>8} {:>8} {:>9} {:>8} {:>7} {:>8.2} {:>9.2} {:>6.2}{}",
            p.solver,
            p.setting(),
            p.error_to_horizon,
            p.error,
            p.steps,
            p.rejected,
            p.rhs_evals,
            p.newton_iters,
            p.factorisations,
            p.wall_s,
            p.wall_to_horizon_s,
            p.reached_t,
            p.failure
                .as_ref()
                .map(|f| format!("  STOPPED: {f}"))
                .unwrap_or_default()
        );
    }
    println!("\nwhere lash's BDF spends its time (its own timers; the rest is step logic and output):");
    for p in b.points.iter().chain([&b.reference]) {
        if let Some(t) = p.phase_times {
            let share = |x: f64| 100.0 * x / p.wall_s;
            println!(
                "  rtol {:.0e}: {:.2} s = residuals {:.0} %, Jacobians {:.0} %, LU factorisations {:.0} %, triangular solves {:.0} %, other {:.0} %",
                p.rtol,
                p.wall_s,
                share(t.residual_s),
                share(t.jacobian_s),
                share(t.factorisation_s),
                share(t.solve_s),
                share(p.wall_s - t.residual_s - t.jacobian_s - t.factorisation_s - t.solve_s)
            );
        }
    }
    println!("\nlargest platform error [m] by time window:");
    for p in &b.points {
        let w: Vec<String> = p
            .error_windows
            .iter()
            .map(|(a, c, e)| format!("{a}-{c} s: {e:.1e}"))
            .collect();
        println!("  {:<44} {}: {}", p.solver, p.setting(), w.join(", "));
    }
    println!(
        "\nat equal accuracy (platform within {:.0e} m of the reference over t = 0 to {:.2} s{}), cheapest setting per solver:",
        b.target,
        b.compared_until(),
        if b.horizon_s.is_some() { ", the horizon" } else { ", the whole run: no independent check" }
    );
    for c in &b.comparison {
        match &c.chosen {
            Some(p) => {
                println!(
                "  {:<44} {}: {:.2} s to t = {:.2} s ({:.2} s for the whole run, {} steps); time {:.1}x lash",
                c.solver, p.setting(), p.wall_to_horizon_s, b.compared_until(), p.wall_s, p.steps, c.time_ratio
            )
            }
            None => match c.time_ratio_at_least {
                Some(r) => println!(
                    "  {:<44} ran out of its wall-time budget before t = {:.2} s: time >= {r:.1}x lash",
                    c.solver,
                    b.compared_until()
                ),
                None => println!("  {:<44} no setting in the sweep reached the target", c.solver),
            },
        }
        if let Some(o) = &c.at_own_accuracy {
            println!(
                "  {:<44}   at its own best accuracy over t = 0 to {:.2} s, {:.2e} m ({}, {:.2} s): lash {} reaches {:.2e} m in {:.2} s; time {:.1}x lash",
                "",
                b.compared_until(),
                o.accuracy_m,
                o.setting,
                o.wall_to_horizon_s,
                o.lash_setting,
                o.lash_error_m,
                o.lash_wall_to_horizon_s,
                o.time_ratio
            );
        }
    }
}
