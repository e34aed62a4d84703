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
    /// Locate where a model and recordings disagree, name the missing physics, fit it, and
    /// show the held-out improvement (equation error: measured motion -> inverse dynamics ->
    /// measured torques). Defaults: the DFKI double pendulum, fit on runs 00-05, held out 12-13.
    Diagnose {
        /// Nominal model (double-pendulum: the DFKI pendulum's rigid model from --params).
        #[arg(long, default_value = "double-pendulum")]
        model: String,
        /// README with the model's parameter table.
        #[arg(long, default_value = lash::mechanisms::double_pendulum::DFKI_README)]
        params: std::path::PathBuf,
        /// Recordings to fit on, comma-separated CSV paths.
        #[arg(long, default_value = DFKI_FIT)]
        fit: String,
        /// Recordings held out (never fitted), comma-separated CSV paths.
        #[arg(long, default_value = DFKI_HOLDOUT)]
        holdout: String,
        /// Time column.
        #[arg(long, default_value = "time")]
        time_column: String,
        /// Column mapping role=column for q1, q2, qd1, qd2, tau1, tau2.
        #[arg(
            long,
            default_value = "q1=pos_filt1,q2=pos_filt2,qd1=vel_filt1,qd2=vel_filt2,tau1=tau_meas1,tau2=tau_meas2"
        )]
        map: String,
        /// Half-width (samples) of the local line that differentiates rates into
        /// accelerations, or "auto": chosen by cross-validation on the fit recordings.
        #[arg(long, default_value = "auto")]
        derivative_window: String,
        /// Report folder (Markdown, JSON, PNG/SVG plots).
        #[arg(long, default_value = "out/diagnose")]
        report: std::path::PathBuf,
        /// Print the diagnosis as JSON.
        #[arg(long)]
        json: bool,
        /// Run the concealed-effects suite on the MR2120 (synthetic recordings from a truth
        /// with hidden effects, each diagnosed blind) and print the scoreboard.
        #[arg(long)]
        suite: bool,
        /// With --suite: the reduced design CI runs (fewer, shorter recordings).
        #[arg(long)]
        reduced: bool,
        /// With --suite: only the cases whose names contain one of these (comma-separated).
        #[arg(long, default_value = "")]
        only: String,
    },
    /// The WUT MR2120 parallel mechanism of the reference paper.
    Mr2120 {
        #[command(subcommand)]
        what: Mr2120What,
    },
}

#[derive(Subcommand)]
enum Mr2120What {
    /// Synthetic recordings from a truth with hidden effects: drive angles, rates and
    /// torques, platform centre from a tracker, with stated noise (CSV), and the truth
    /// (truth.json, which the diagnosis never reads).
    Record {
        /// Hidden effects, comma-separated name=value (SI), e.g. "payload=0.01,clearance_c=4e-6";
        /// names: payload, tilt_x, tilt_y, arm_length_error_a.., forearm_length_error_a..,
        /// compliance_error_a.., viscous_a.., coulomb_a.., rotor_inertia_a.., backlash_a..,
        /// clearance_a.., encoder_offset_a.., torque_offset_a.., torque_scale_a..,
        /// tracker_offset_x|y|z.
        #[arg(long, default_value = "")]
        effects: String,
        /// Or a suite case by name (its effects and design), e.g. "clearance".
        #[arg(long)]
        case: Option<String>,
        /// Number of recordings (different paths).
        #[arg(long, default_value_t = 4)]
        recordings: usize,
        /// Seed of paths and noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Duration of each recording, s.
        #[arg(long, default_value_t = 8.0)]
        duration: f64,
        /// Sampling rate, Hz.
        #[arg(long, default_value_t = 500.0)]
        rate: f64,
        /// Leave out the drive torques (tracker only).
        #[arg(long)]
        no_torques: bool,
        /// Output folder.
        #[arg(long, default_value = "out/mr2120-record")]
        out: std::path::PathBuf,
        /// Print a summary as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Table 2: drive angles at M1, M2, M3 beside the paper's, with singularity measures.
    Kinematics {
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Table 3: positioning-error ranges at M1, M2, M3 for L1, L2, L3 beside the paper's.
    Accuracy {
        /// Points, comma-separated (M1, M2, M3).
        #[arg(long, default_value = "M1,M2,M3")]
        points: String,
        /// Clearance sets, comma-separated (L1, L2, L3).
        #[arg(long, default_value = "L1,L2,L3")]
        sets: String,
        /// Method: dynamic (the paper's excitation), static (envelope of equilibria) or both.
        #[arg(long, default_value = "dynamic")]
        method: String,
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Trajectory M1 → M2 → M3 (paper §4.1): drive angles, platform path, drive torques.
    Trajectory {
        /// Clearance set: none (ideal model), L1, L2, L3 or all.
        #[arg(long, default_value = "none")]
        clearance: String,
        /// Output folder for CSV and plots.
        #[arg(long, default_value = "out/mr2120-trajectory")]
        out: std::path::PathBuf,
        /// Sampling interval of the outputs, s.
        #[arg(long, default_value_t = 0.01)]
        dt: f64,
        /// Print a summary as JSON.
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
        /// Also sweep Andrews' squeezer over tolerances 1e-3..1e-9 and draw its
        /// work-precision diagram into this folder.
        #[arg(long)]
        plots: Option<std::path::PathBuf>,
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
        out: std::path::PathBuf,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The 63-DOF MR2120 clearance model along the 4 s trajectory: lash's BDF against
    /// Dormand–Prince, symplectic Euler and diffsol's BDF at equal accuracy (platform centre
    /// within --target of a tight reference).
    Mr2120(Mr2120BenchArgs),
}

/// Options of `lash bench mr2120`.
#[derive(clap::Args, Debug)]
struct Mr2120BenchArgs {
    /// Clearance set (L1, L2, L3).
    #[arg(long, default_value = "L1")]
    set: String,
    /// End of the trajectory, s.
    #[arg(long, default_value_t = 4.0)]
    t_end: f64,
    /// Target accuracy of the platform centre, m.
    #[arg(long, default_value_t = 1e-6)]
    target: f64,
    /// Relative tolerance of the reference run (lash BDF).
    #[arg(long, default_value_t = 1e-8)]
    reference_rtol: f64,
    /// Relative tolerances swept for lash's BDF, comma-separated.
    #[arg(long, default_value = "1e-4,1e-5,1e-6,1e-7")]
    bdf_rtols: String,
    /// Relative tolerances swept for Dormand–Prince, comma-separated (empty: none).
    #[arg(long, default_value = "1e-5")]
    dopri_rtols: String,
    /// Fixed steps swept for symplectic Euler, s, comma-separated (empty: none).
    #[arg(long, default_value = "5e-7")]
    symplectic_steps: String,
    /// Relative tolerances swept for diffsol's BDF on the index-1 ODE, comma-separated
    /// (empty: none).
    #[arg(long, default_value = "1e-4,1e-6")]
    diffsol_rtols: String,
    /// Hunt–Crossley contact damping α of the bearings, s/m (the studies use 1; see
    /// lash::bench::mr2120::BENCH_DAMPING for why the benchmark uses 300).
    #[arg(long, default_value_t = 300.0)]
    alpha: f64,
    /// Wall-time budget of each explicit run, s (the time ratio is then a lower bound).
    #[arg(long, default_value_t = 600.0)]
    explicit_budget: f64,
    /// Relative tolerance of an extra Dormand–Prince run that checks the reference (0: skip;
    /// every Dormand–Prince run of the sweep is already an independent check).
    #[arg(long, default_value_t = 0.0)]
    check_rtol: f64,
    /// Output folder for the work-precision diagram.
    #[arg(long, default_value = "out/bench-mr2120")]
    out: std::path::PathBuf,
    /// Also write the model (`model.json`, the schema of `benches/exudyn/`) and the
    /// result with the reference path (`lash.json`) into this folder, for the Exudyn
    /// comparison (`bash benches/exudyn/run.sh`).
    #[arg(long)]
    export: Option<std::path::PathBuf>,
    /// Print the result as JSON.
    #[arg(long)]
    json: bool,
}

const DFKI_FIT: &str = "../shared/data/dfki-double-pendulum/recordings/trajectory_00.csv,../shared/data/dfki-double-pendulum/recordings/trajectory_01.csv,../shared/data/dfki-double-pendulum/recordings/trajectory_02.csv,../shared/data/dfki-double-pendulum/recordings/trajectory_03.csv,../shared/data/dfki-double-pendulum/recordings/trajectory_04.csv,../shared/data/dfki-double-pendulum/recordings/trajectory_05.csv";
const DFKI_HOLDOUT: &str = "../shared/data/dfki-double-pendulum/recordings/trajectory_12.csv,../shared/data/dfki-double-pendulum/recordings/trajectory_13.csv";

#[allow(clippy::too_many_arguments)]
fn diagnose_cmd(
    model: &str,
    params: &std::path::Path,
    fit: &str,
    holdout: &str,
    time_column: &str,
    map: &str,
    half_window: &str,
    report: &std::path::Path,
    json: bool,
) -> ExitCode {
    use lash::diagnose::data::roles;
    use lash::diagnose::model::DoublePendulumModel;
    use lash::diagnose::recording::{parse_mapping, read_csv};
    use lash::diagnose::{diagnose_recordings, format::number, DiagnoseOptions};
    let fail = |e: &dyn std::fmt::Display| {
        eprintln!("error: {e}");
        ExitCode::FAILURE
    };
    let dp;
    let mr;
    let (m, mapping): (
        &dyn lash::diagnose::model::InverseDynamicsModel,
        Vec<(String, String)>,
    ) = match model {
        "double-pendulum" => {
            let params = match lash::mechanisms::double_pendulum::DoublePendulumParams::from_readme(params) {
                Ok(p) => p,
                Err(e) => return fail(&e),
            };
            dp = DoublePendulumModel { params };
            match parse_mapping(map, &roles(2)) {
                Ok(m) => (&dp, m),
                Err(e) => return fail(&e),
            }
        }
        "mr2120" => {
            mr = lash::diagnose::model::Mr2120Model {
                nominal: lash::mechanisms::mr2120::record::nominal_model(),
            };
            // Each role reads the column of its own name unless --map says otherwise; torque
            // and tracker columns are used when the first fit file has them.
            let first = fit
                .split(',')
                .map(str::trim)
                .find(|s| !s.is_empty())
                .unwrap_or_default();
            let header: Vec<String> = std::fs::read_to_string(first)
                .ok()
                .and_then(|t| {
                    t.lines()
                        .next()
                        .map(|l| l.split(',').map(|c| c.trim().to_string()).collect())
                })
                .unwrap_or_default();
            let user: Vec<(String, String)> = if map.starts_with("q1=pos_filt1") {
                vec![]
            } else {
                map.split(',')
                    .filter_map(|kv| kv.split_once('='))
                    .map(|(a, b)| (a.trim().to_string(), b.trim().to_string()))
                    .collect()
            };
            let all = lash::diagnose::data::model_roles(&mr);
            if let Some((r, _)) = user.iter().find(|(r, _)| !all.contains(r)) {
                return fail(&format!(
                    "--map: '{r}' is not a role of the MR2120 model ({})",
                    all.join(", ")
                ));
            }
            let mapping = all
                .iter()
                .map(|r| {
                    let col = user
                        .iter()
                        .find(|(u, _)| u == r)
                        .map(|(_, c)| c.clone())
                        .unwrap_or(r.clone());
                    (r.clone(), col)
                })
                .filter(|(r, c)| header.contains(c) || r.starts_with('q'))
                .collect();
            (&mr, mapping)
        }
        _ => {
            return fail(&format!(
                "unknown model '{model}' (available: double-pendulum, mr2120)"
            ))
        }
    };
    let windows: Vec<usize> = if half_window == "auto" && model == "mr2120" {
        vec![4, 6, 8, 12, 16]
    } else if half_window == "auto" {
        vec![2, 3, 5, 8, 12, 16, 20, 25, 30, 40, 50]
    } else {
        match half_window.parse::<usize>() {
            Ok(w) if w >= 1 => vec![w],
            _ => {
                return fail(&format!(
                    "--derivative-window: '{half_window}' is neither 'auto' nor a positive integer"
                ))
            }
        }
    };
    let load = |list: &str| -> Result<Vec<lash::diagnose::recording::Recording>, String> {
        list.split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .map(|f| read_csv(std::path::Path::new(f), time_column, &mapping).map_err(|e| e.to_string()))
            .collect()
    };
    let (fit, held) = match load(fit).and_then(|f| Ok((f, load(holdout)?))) {
        Ok(x) => x,
        Err(e) => return fail(&e),
    };
    if fit.is_empty() {
        return fail(&"--fit names no recording");
    }
    let mut progress = Progress::new("diagnose", 1.0);
    let d = match diagnose_recordings(m, &fit, &held, &windows, &DiagnoseOptions::default(), |_, f| {
        progress.update(f)
    }) {
        Ok(d) => d,
        Err(e) => return fail(&e),
    };
    progress.finish();
    let md = match lash::diagnose::report::write_report(&d, report) {
        Ok(p) => p,
        Err(e) => return fail(&e),
    };
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&d).expect("diagnosis serialises")
        );
        return ExitCode::SUCCESS;
    }
    println!("{}\n", d.verdict);
    println!(
        "{:<28} {:>10} {:>12} {:>12} {:>14} {:>14} {:>10}",
        "channel", "noise", "fit before", "fit after", "held-out bef.", "held-out aft.", "reduction"
    );
    for c in &d.channels {
        println!(
            "{:<28} {:>10} {:>12} {:>12} {:>14} {:>14} {:>9.1}%",
            c.channel,
            number(c.noise_floor),
            number(c.fit_before),
            number(c.fit_after),
            number(c.holdout_before),
            number(c.holdout_after),
            100.0 * c.holdout_reduction
        );
    }
    println!("\nselected (in order):");
    for s in &d.steps {
        println!(
            "  {:<60} statistic {:>10.1}  p {:.1e}  CV RMS {:.3}",
            s.added, s.statistic, s.p_value, s.cv_rms
        );
    }
    if d.steps.is_empty() {
        println!("  none: no significant mismatch");
    }
    println!("\nreport: {}", md.display());
    ExitCode::SUCCESS
}

fn suite_cmd(reduced: bool, only: &str, report: &std::path::Path, json: bool) -> ExitCode {
    use lash::diagnose::suite::{run_suite, SuiteOptions};
    let mut opts = if reduced {
        SuiteOptions::reduced()
    } else {
        SuiteOptions::default()
    };
    opts.only = only
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(String::from)
        .collect();
    let dir = if report == std::path::Path::new("out/diagnose") {
        std::path::PathBuf::from("out/diagnose-suite")
    } else {
        report.to_path_buf()
    };
    let mut progress = Progress::new("diagnose --suite", 1.0);
    let board = match run_suite(&opts, Some(&dir), |_, f| progress.update(f)) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    progress.finish();
    let text = serde_json::to_string_pretty(&board).expect("scoreboard serialises");
    if let Err(e) =
        std::fs::create_dir_all(&dir).and_then(|_| std::fs::write(dir.join("scoreboard.json"), &text))
    {
        eprintln!("error: {}: {e}", dir.display());
        return ExitCode::FAILURE;
    }
    if json {
        println!("{text}");
        return if board.targets_met {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        };
    }
    let (f, h, d, r) = board.design;
    println!(
        "Concealed-effects suite on the MR2120: {f} recordings fitted, {h} held out per case, {d} s at {r} Hz; noise: torque {} N m, tracker {} m, encoder {} rad, rate {} rad/s\n",
        board.noise.torque, board.noise.tracker, board.noise.encoder, board.noise.rate
    );
    println!(
        "{:<24} {:>7} {:>6}  {:<6} {:<22} {:>8}  {:<5}  selected first",
        "case", "<noise", "peak", "ranked", "estimate (rel. err.)", "held/σ", "pass"
    );
    for c in &board.cases {
        let est: Vec<String> = c
            .estimates
            .iter()
            .map(|e| match e {
                Some((_, r)) => format!("{:.1} %", 100.0 * r),
                None => "not found".into(),
            })
            .collect();
        println!(
            "{:<24} {:>6.0}% {:>6.1}  {:<6} {:<22} {:>8.2}  {:<5}  {}",
            c.case,
            100.0 * c.below_noise_fraction,
            c.peak_snr,
            if c.ranked_first { "yes" } else { "no" },
            if est.is_empty() {
                "-".to_string()
            } else {
                est.join(", ")
            },
            c.holdout_noise_ratio,
            if c.pass { "yes" } else { "NO" },
            if c.selected.is_empty() {
                "nothing (no significant mismatch)".to_string()
            } else {
                c.selected.iter().take(3).cloned().collect::<Vec<_>>().join("; ")
            }
        );
        if let Some(x) = &c.confounded {
            println!("{:<24} flagged as confounded; separating experiment: {x}", "");
        }
    }
    println!(
        "\nranked first {}/{}  estimates within 25 % {}/{}  held-out ≤ 1.1× noise {}/{}  null case {}  pair case {}",
        board.ranked_first.0,
        board.ranked_first.1,
        board.estimates_within_25pct.0,
        board.estimates_within_25pct.1,
        board.holdout_at_noise.0,
        board.holdout_at_noise.1,
        if board.null_ok { "ok" } else { "FAILED" },
        if board.pair_ok { "ok" } else { "FAILED" }
    );
    println!(
        "targets {}; scoreboard: {}; one diagnosis report per case in {}/<case>/",
        if board.targets_met { "met" } else { "NOT met" },
        dir.join("scoreboard.json").display(),
        dir.display()
    );
    if board.targets_met {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

#[allow(clippy::too_many_arguments)]
fn record_cmd(
    effects: &str,
    case: Option<&str>,
    recordings: usize,
    seed: u64,
    duration: f64,
    rate: f64,
    no_torques: bool,
    out: &std::path::Path,
    json: bool,
) -> ExitCode {
    use lash::diagnose::suite::{cases, excitation};
    use lash::mechanisms::mr2120::record::{nominal_model, record, HiddenEffects, RecordOptions};
    let fail = |e: &dyn std::fmt::Display| {
        eprintln!("error: {e}");
        ExitCode::FAILURE
    };
    let mut hidden = HiddenEffects::default();
    let mut torques = !no_torques;
    if let Some(name) = case {
        match cases().into_iter().find(|c| c.name == name) {
            Some(c) => {
                hidden = c.effects;
                torques &= c.torques;
            }
            None => {
                let names: Vec<String> = cases().into_iter().map(|c| c.name).collect();
                return fail(&format!("unknown case '{name}' (cases: {})", names.join(", ")));
            }
        }
    }
    for item in effects.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let Some((k, v)) = item.split_once('=') else {
            return fail(&format!("--effects: '{item}' is not name=value"));
        };
        let value = match v.trim().parse::<f64>() {
            Ok(x) => x,
            Err(_) => return fail(&format!("--effects: '{v}' is not a number")),
        };
        if let Err(e) = hidden.set(k.trim(), value) {
            return fail(&format!("--effects: {e}"));
        }
    }
    if recordings == 0 {
        return fail(&"--recordings must be at least 1");
    }
    let opts = RecordOptions {
        duration,
        rate,
        torques,
        ..RecordOptions::default()
    };
    if let Err(e) = std::fs::create_dir_all(out) {
        return fail(&format!("{}: {e}", out.display()));
    }
    let nominal = nominal_model();
    let mut files = vec![];
    for r in 0..recordings {
        let ex = excitation(seed, r);
        let rec = match record(&nominal, &hidden, &ex, &opts, seed.wrapping_add(r as u64)) {
            Ok(x) => x,
            Err(e) => return fail(&e),
        };
        let path = out.join(format!("recording-{:02}.csv", r + 1));
        if let Err(e) = rec.write(&path) {
            return fail(&e);
        }
        files.push(serde_json::json!({
            "file": path.display().to_string(),
            "samples": rec.t.len(),
            "min_direct_measure": rec.min_direct_measure,
            "torque_reversals": rec.torque_reversals,
            "forearm_force_reversals": rec.tension_reversals,
            "velocity_reversals": rec.velocity_reversals,
        }));
    }
    let truth = serde_json::json!({
        "effects": hidden,
        "noise": opts.noise,
        "seed": seed,
        "recordings": files,
    });
    let text = serde_json::to_string_pretty(&truth).expect("truth serialises");
    let tpath = out.join("truth.json");
    if let Err(e) = std::fs::write(&tpath, &text) {
        return fail(&format!("{}: {e}", tpath.display()));
    }
    if json {
        println!("{text}");
    } else {
        println!(
            "{} recordings of {duration} s at {rate} Hz in {} (columns: time, q1..q3 [rad], qd1..qd3 [rad/s]{}, x, y, z [m]); truth in {}",
            recordings,
            out.display(),
            if torques { ", tau1..tau3 [N m]" } else { "" },
            tpath.display()
        );
        println!(
            "diagnose them: lash diagnose --model mr2120 --fit {} --holdout {}",
            files
                .iter()
                .take(recordings.saturating_sub(1).max(1))
                .map(|f| f["file"].as_str().unwrap_or_default().to_string())
                .collect::<Vec<_>>()
                .join(","),
            files
                .last()
                .map(|f| f["file"].as_str().unwrap_or_default().to_string())
                .unwrap_or_default()
        );
    }
    ExitCode::SUCCESS
}

fn parse_list(s: &str, what: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(str::trim)
        .filter(|x| !x.is_empty())
        .map(|x| {
            x.parse::<f64>()
                .ok()
                .filter(|v| *v > 0.0 && v.is_finite())
                .ok_or_else(|| format!("{what}: '{x}' is not a positive number"))
        })
        .collect()
}

/// Writes the MR2120 clearance model of the benchmark as `dir/model.json` for the Exudyn
/// comparison.
fn export_mr2120_model(
    opts: &lash::bench::mr2120::Mr2120BenchOptions,
    dir: &std::path::Path,
) -> Result<(), String> {
    let model = lash::bench::exudyn::export_mr2120(opts).map_err(|e| e.to_string())?;
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let path = dir.join("model.json");
    let text = serde_json::to_string_pretty(&model).expect("model serialises");
    std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    eprintln!(
        "bench mr2120: model for the Exudyn comparison written to {}",
        path.display()
    );
    Ok(())
}

fn bench_mr2120(a: &Mr2120BenchArgs) -> ExitCode {
    use lash::bench::mr2120::{bench_mr2120, Mr2120BenchOptions};
    let lists = (|| -> Result<_, String> {
        Ok((
            parse_list(&a.bdf_rtols, "--bdf-rtols")?,
            parse_list(&a.dopri_rtols, "--dopri-rtols")?,
            parse_list(&a.symplectic_steps, "--symplectic-steps")?,
            parse_list(&a.diffsol_rtols, "--diffsol-rtols")?,
        ))
    })();
    let (bdf_rtols, dopri_rtols, symplectic_steps, diffsol_rtols) = match lists {
        Ok(l) => l,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let valid = a.t_end > 0.0 && a.t_end <= 4.0 && a.target > 0.0 && a.reference_rtol > 0.0 && a.alpha >= 0.0;
    if !valid {
        eprintln!("error: need 0 < --t-end <= 4, --target > 0, --reference-rtol > 0 and --alpha >= 0");
        return ExitCode::FAILURE;
    }
    let opts = Mr2120BenchOptions {
        set: a.set.clone(),
        t_end: a.t_end,
        target: a.target,
        reference_rtol: a.reference_rtol,
        bdf_rtols,
        dopri_rtols,
        symplectic_steps,
        diffsol_rtols,
        reference_check_rtol: (a.check_rtol > 0.0).then_some(a.check_rtol),
        damping: lash::contact::Damping::HuntCrossley(a.alpha),
        explicit_budget_s: a.explicit_budget,
        ..Default::default()
    };
    if let Some(dir) = &a.export {
        if let Err(e) = export_mr2120_model(&opts, dir) {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
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
    let b = match res {
        Ok(b) => b,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    let plot_note = write_work_precision(&b, &a.out);
    if let Some(dir) = &a.export {
        let path = dir.join("lash.json");
        let text = serde_json::to_string_pretty(&b).expect("bench serialises");
        if let Err(e) = std::fs::write(&path, text) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&b).expect("bench serialises"));
        return ExitCode::SUCCESS;
    }
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
    println!(
        "agreement horizon: the reference and the independent Dormand-Prince run agree within {:.0e} m up to t = {:.2} s",
        b.target, b.horizon_s
    );
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
        "\nat equal accuracy (platform within {:.0e} m of the reference up to the horizon), cheapest setting per solver:",
        b.target
    );
    for c in &b.comparison {
        match &c.chosen {
            Some(p) => {
                println!(
                "  {:<44} {}: {:.2} s to the horizon ({:.2} s for the whole run, {} steps); time {:.1}x lash",
                c.solver, p.setting(), p.wall_to_horizon_s, p.wall_s, p.steps, c.time_ratio
            )
            }
            None => match c.time_ratio_at_least {
                Some(r) => println!(
                    "  {:<44} ran out of its wall-time budget before the horizon: time >= {r:.1}x lash",
                    c.solver
                ),
                None => println!("  {:<44} no setting in the sweep reached the target", c.solver),
            },
        }
        if let Some(o) = &c.at_own_accuracy {
            println!(
                "  {:<44}   at its own best accuracy, {:.2e} m ({}, {:.2} s to the horizon): lash {} reaches {:.2e} m in {:.2} s; time {:.1}x lash",
                "",
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
    println!("{plot_note}");
    ExitCode::SUCCESS
}

fn bench_scaling_cmd(links: &str, t_end: f64, out: &std::path::Path, json: bool) -> ExitCode {
    use lash::plot::{LineChart, Series};
    let lengths: Result<Vec<usize>, String> = links
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<usize>()
                .ok()
                .filter(|n| *n > 0)
                .ok_or_else(|| format!("--links: '{s}' is not a positive integer"))
        })
        .collect();
    let lengths = match lengths {
        Ok(l) if !l.is_empty() => l,
        Ok(_) => {
            eprintln!("error: --links names no chain length");
            return ExitCode::FAILURE;
        }
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    if !(t_end > 0.0 && t_end.is_finite()) {
        eprintln!("error: --t-end must be positive");
        return ExitCode::FAILURE;
    }
    let total = lengths.len() as f64;
    let mut progress = Progress::new("bench scaling", total);
    let mut k = 0.0;
    let s = lash::bench::scaling::bench_scaling(&lengths, t_end, |_| {
        progress.update(k);
        k += 1.0;
    });
    progress.finish();
    let ok: Vec<_> = s.rows.iter().filter(|r| r.failure.is_none()).collect();
    let chart = LineChart {
        title: format!(
            "clearance chain: cost per step and memory vs N (slopes {:.2} and {:.2})",
            s.slope, s.memory_slope
        ),
        x_label: "links N".into(),
        y_label: "time per step [s] / resident memory [GB]".into(),
        series: vec![
            Series {
                name: format!("time per BDF step (slope {:.2})", s.slope),
                points: ok.iter().map(|r| (r.links as f64, r.per_step_s)).collect(),
            },
            Series {
                name: format!("resident memory (slope {:.2})", s.memory_slope),
                points: ok
                    .iter()
                    .map(|r| (r.links as f64, r.resident_bytes as f64 / 1e9))
                    .collect(),
            },
        ],
        y_range: None,
    };
    let note = save_log_log_chart(&chart, out, "scaling", "plot");
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&s).expect("scaling serialises")
        );
        return ExitCode::SUCCESS;
    }
    println!(
        "clearance chain (links + crosses, 4 bearings per joint), {} s simulated per run",
        s.t_end
    );
    println!(
        "{:>7} {:>8} {:>9} {:>9} {:>9} {:>7} {:>7} {:>12} {:>10}",
        "links", "bodies", "unknowns", "setup s", "wall s", "steps", "LU", "per step s", "RSS MB"
    );
    for r in &s.rows {
        println!(
            "{:>7} {:>8} {:>9} {:>9.3} {:>9.3} {:>7} {:>7} {:>12.3e} {:>10.1}{}",
            r.links,
            r.bodies,
            r.unknowns,
            r.setup_s,
            r.wall_s,
            r.steps,
            r.factorisations,
            r.per_step_s,
            r.resident_bytes as f64 / 1e6,
            r.failure
                .as_ref()
                .map(|f| format!("  FAILED: {f}"))
                .unwrap_or_default()
        );
    }
    println!(
        "log-log slope of time per step against N (N >= 100): {:.2} (target <= 1.2); memory: {:.2}",
        s.slope, s.memory_slope
    );
    println!("{note}");
    ExitCode::SUCCESS
}

/// Writes a chart with logarithmic axes as `<dir>/<stem>.png` and `.svg`, creating `dir`;
/// returns the line to print (where it went, or why it could not be written).
fn save_log_log_chart(
    chart: &lash::plot::LineChart,
    dir: &std::path::Path,
    stem: &str,
    what: &str,
) -> String {
    if let Err(e) = std::fs::create_dir_all(dir) {
        return format!("could not create {}: {e}", dir.display());
    }
    let stem = dir.join(stem);
    match chart.save_log_log(&stem) {
        Ok(()) => format!("{what}: {}.png / .svg", stem.display()),
        Err(e) => format!("could not write the {what}: {e}"),
    }
}

fn andrews_work_precision(dir: &std::path::Path, repeats: usize) -> String {
    use lash::plot::{LineChart, Series};
    let tols = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9];
    let rows = lash::bench::andrews_work_precision(&tols, repeats);
    let mut solvers: Vec<String> = vec![];
    for r in &rows {
        if !solvers.contains(&r.solver) {
            solvers.push(r.solver.clone());
        }
    }
    let series = solvers
        .iter()
        .map(|s| {
            // In tolerance order: the line joins successive tolerances.
            let points: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| &r.solver == s && r.failure.is_none() && r.error.is_finite())
                .map(|r| (r.wall_s, r.error.max(1e-16)))
                .collect();
            Series {
                name: s.clone(),
                points,
            }
        })
        .collect();
    let chart = LineChart {
        title: "Andrews' squeezer: work-precision (rtol = atol = 1e-3 .. 1e-9)".into(),
        x_label: "wall time [s]".into(),
        y_label: "max relative angle error at 0.03 s".into(),
        series,
        y_range: None,
    };
    save_log_log_chart(
        &chart,
        dir,
        "andrews-work-precision",
        "Andrews work-precision diagram",
    )
}

fn write_work_precision(b: &lash::bench::mr2120::Mr2120Bench, out: &std::path::Path) -> String {
    use lash::plot::{LineChart, Series};
    let series = b
        .comparison
        .iter()
        .map(|c| {
            // In tolerance order: the line joins successive tolerances.
            let points: Vec<(f64, f64)> = b
                .points
                .iter()
                .filter(|p| {
                    p.solver == c.solver && p.wall_to_horizon_s.is_finite() && p.error_to_horizon.is_finite()
                })
                .map(|p| (p.wall_to_horizon_s, p.error_to_horizon.max(1e-12)))
                .collect();
            Series {
                name: c.solver.clone(),
                points,
            }
        })
        .collect();
    let chart = LineChart {
        title: format!(
            "MR2120 {} trajectory to the agreement horizon t = {:.2} s: work-precision",
            b.set, b.horizon_s
        ),
        x_label: "wall time to the horizon [s]".into(),
        y_label: "largest platform-centre error vs reference [m]".into(),
        series,
        y_range: None,
    };
    save_log_log_chart(&chart, out, "work-precision", "work-precision diagram")
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

/// Prints progress to stderr once a run has taken longer than a second.
struct Progress {
    start: std::time::Instant,
    last: f64,
    total: f64,
    label: String,
    shown: bool,
}

impl Progress {
    fn new(label: &str, total: f64) -> Self {
        Self {
            start: std::time::Instant::now(),
            last: 0.0,
            total,
            label: label.into(),
            shown: false,
        }
    }
    fn update(&mut self, done: f64) {
        let el = self.start.elapsed().as_secs_f64();
        // Quiet for short runs; at most five updates a second afterwards.
        if el < 1.0 || (el - self.last < 0.2 && done < self.total) {
            return;
        }
        self.last = el;
        self.shown = true;
        let frac = (done / self.total).clamp(0.0, 1.0);
        let bar = (frac * 30.0) as usize;
        eprint!(
            "\r{} [{}{}] {:5.1}%  {:.1} s",
            self.label,
            "#".repeat(bar),
            " ".repeat(30 - bar),
            100.0 * frac,
            el
        );
    }
    fn finish(&self) {
        if self.shown {
            eprintln!();
        }
    }
}

fn mr2120_trajectory(clearance: &str, out: &std::path::Path, dt: f64, json: bool) -> ExitCode {
    use lash::mechanisms::mr2120::{trajectory, Geometry, MassProperties};
    use lash::plot::{LineChart, Series};
    if !(dt > 0.0 && dt <= 0.5) {
        eprintln!("error: --dt must be in (0, 0.5] s, got {dt}");
        return ExitCode::FAILURE;
    }
    let sets: Vec<lash::mechanisms::mr2120::paper::ClearanceSet> = match clearance {
        "none" => vec![],
        "all" | "ALL" => lash::mechanisms::mr2120::paper::TABLE1.to_vec(),
        name => match lash::mechanisms::mr2120::clearance::clearance_set(name) {
            Ok(s) => vec![s],
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        },
    };
    if !sets.is_empty() {
        return mr2120_clearance_trajectory(&sets, out, dt, json);
    }
    let mut progress = Progress::new("mr2120 ideal trajectory", 4.0);
    let run = match trajectory::run_ideal(
        &Geometry::default(),
        &MassProperties::default(),
        dt,
        4.0,
        Default::default(),
        |t| progress.update(t),
    ) {
        Ok(r) => r,
        Err(e) => {
            progress.finish();
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    progress.finish();
    if let Err(e) = std::fs::create_dir_all(out) {
        eprintln!("error: cannot create {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    let csv_path = out.join("trajectory_ideal.csv");
    let mut csv = String::from("t_s,q1_deg,q2_deg,q3_deg,xM_m,yM_m,zM_m,zM_kinematic_m,deviation_m,rotation_rad,tau1_Nm,tau2_Nm,tau3_Nm,singularity\n");
    for s in &run.samples {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            s.t,
            s.q_deg[0],
            s.q_deg[1],
            s.q_deg[2],
            s.m[0],
            s.m[1],
            s.m[2],
            s.m_kinematic[2],
            s.deviation,
            s.rotation,
            s.torque[0],
            s.torque[1],
            s.torque[2],
            s.singularity
        ));
    }
    if let Err(e) = std::fs::write(&csv_path, csv) {
        eprintln!("error: cannot write {}: {e}", csv_path.display());
        return ExitCode::FAILURE;
    }
    // Torques blow up at the singular end; scale the plot to 3x the range where regular.
    let regular: Vec<f64> = run
        .samples
        .iter()
        .filter(|s| s.singularity > 1e-2)
        .flat_map(|s| s.torque)
        .collect();
    let (tlo, thi) = regular
        .iter()
        .fold((0.0f64, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
    let torque_range = (
        tlo - 2.0 * (thi - tlo).abs().max(1.0),
        thi + 2.0 * (thi - tlo).abs().max(1.0),
    );
    let series3 = |f: &dyn Fn(&trajectory::IdealSample, usize) -> f64, names: [&str; 3]| -> Vec<Series> {
        (0..3)
            .map(|i| Series {
                name: names[i].into(),
                points: run.samples.iter().map(|s| (s.t, f(s, i))).collect(),
            })
            .collect()
    };
    let charts = [
        (
            "drive_angles",
            LineChart {
                title: "MR2120 drive angles along M1-M2-M3 (ideal model)".into(),
                x_label: "t [s]".into(),
                y_label: "q [deg]".into(),
                series: series3(&|s, i| s.q_deg[i], ["q1", "q2", "q3"]),
                y_range: None,
            },
        ),
        (
            "platform_position",
            LineChart {
                title: "Platform centre M (ideal model)".into(),
                x_label: "t [s]".into(),
                y_label: "coordinate [m]".into(),
                series: series3(&|s, i| s.m[i], ["x_M", "y_M", "z_M"]),
                y_range: None,
            },
        ),
        (
            "drive_torques",
            LineChart {
                title: "Drive torques (ideal model; clipped near M3, full values in the CSV)".into(),
                x_label: "t [s]".into(),
                y_label: "torque [N m]".into(),
                series: series3(&|s, i| s.torque[i], ["tau1", "tau2", "tau3"]),
                y_range: Some(torque_range),
            },
        ),
        (
            "singularity",
            LineChart {
                title: "Singularity measure of the constraint Jacobian".into(),
                x_label: "t [s]".into(),
                y_label: "sigma_min / sigma_max [-]".into(),
                series: vec![Series {
                    name: "measure".into(),
                    points: run.samples.iter().map(|s| (s.t, s.singularity)).collect(),
                }],
                y_range: None,
            },
        ),
    ];
    for (stem, chart) in &charts {
        if let Err(e) = chart.save(&out.join(stem)) {
            eprintln!("error: plot {stem}: {e}");
            return ExitCode::FAILURE;
        }
    }
    let end = match &run.end {
        lash::multibody::RunEnd::Completed => "completed to t = 4 s".to_string(),
        lash::multibody::RunEnd::StoppedAtSingularity { t, measure, error } => format!(
            "stopped at the direct-kinematics singularity M3: last good sample t = {t:.3} s (measure {measure:.2e}); the integrator then failed: {error}"
        ),
    };
    if json {
        let summary = serde_json::json!({
            "clearance": "none",
            "samples": run.samples.len(),
            "steps": run.steps,
            "max_deviation_regular_m": run.max_deviation_regular,
            "max_platform_rotation_rad": run.max_rotation,
            "singularity_warnings": run.singularity_warnings,
            "end": run.end,
            "csv": csv_path,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&summary).expect("summary serialises")
        );
    } else {
        println!("MR2120 ideal model along M1 (t = 0) -> M2 (2 s) -> M3 (4 s), quintic rest-to-rest legs on the z axis");
        println!("samples: {}  integrator steps: {}", run.samples.len(), run.steps);
        println!(
            "largest deviation from the kinematic path where regular: {:.2e} m",
            run.max_deviation_regular
        );
        println!("largest platform rotation: {:.2e} rad", run.max_rotation);
        for w in &run.singularity_warnings {
            println!(
                "singularity approached: t = {:.3} s, measure {:.3e}",
                w.t, w.measure
            );
        }
        println!("run: {end}");
        println!(
            "wrote {} and drive_angles, platform_position, drive_torques, singularity (.png, .svg) in {}",
            csv_path.display(),
            out.display()
        );
    }
    ExitCode::SUCCESS
}

fn mr2120_accuracy(points: &str, sets: &str, method: &str, json: bool) -> ExitCode {
    use lash::mechanisms::mr2120::{accuracy, clearance, paper, Geometry, MassProperties};
    let mut pts = vec![];
    for name in points.split(',').map(str::trim) {
        match paper::TABLE2.iter().find(|p| p.name.eq_ignore_ascii_case(name)) {
            Some(p) => pts.push(*p),
            None => {
                eprintln!("error: unknown point '{name}'; expected M1, M2 or M3");
                return ExitCode::FAILURE;
            }
        }
    }
    let mut ss = vec![];
    for name in sets.split(',').map(str::trim) {
        match clearance::clearance_set(name) {
            Ok(s) => ss.push(s),
            Err(e) => {
                eprintln!("error: {e}");
                return ExitCode::FAILURE;
            }
        }
    }
    let methods = match method {
        "dynamic" => vec![accuracy::Method::Dynamic],
        "static" => vec![accuracy::Method::Static],
        "both" => vec![accuracy::Method::Dynamic, accuracy::Method::Static],
        other => {
            eprintln!("error: unknown method '{other}'; expected dynamic, static or both");
            return ExitCode::FAILURE;
        }
    };
    let ex = accuracy::Excitation::default();
    let mut progress = Progress::new("mr2120 accuracy", (pts.len() * ss.len() * methods.len()) as f64);
    let rows = match accuracy::table3(
        &Geometry::default(),
        &MassProperties::default(),
        &pts,
        &ss,
        &methods,
        &ex,
        |i, _| progress.update(i as f64),
    ) {
        Ok(r) => r,
        Err(e) => {
            progress.finish();
            eprintln!("error: {e}");
            return ExitCode::FAILURE;
        }
    };
    progress.finish();
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({"excitation": ex, "rows": rows}))
                .expect("serialises")
        );
        return ExitCode::SUCCESS;
    }
    println!("MR2120 positioning accuracy (paper Table 3): ranges min..max; d in mm, delta in deg");
    println!("method (a): drives locked at q(M), settle {} s, then half-sine pulses of {} N along +-x, +-y, +-z and {} N m about +-x, +-y, +-z, {} s each", ex.settle, ex.force, ex.torque, ex.pulse);
    println!("method (b): equilibria (dynamic relaxation) under no load and constant {} N / {} N m along/about +-x, +-y, +-z", ex.force, ex.torque);
    let names = ["d_xM", "d_yM", "d_zM", "dx", "dy", "dz"];
    for r in &rows {
        println!("{} {} {} ({} steps)", r.point, r.set, r.method, r.steps);
        for k in 0..6 {
            let (lo, hi) = r.ranges[k];
            let (plo, phi) = r.paper[k];
            let ratio = (hi - lo) / (phi - plo);
            println!(
                "   {:<5} lash {:>8.3} .. {:>8.3}   paper {:>7.2} .. {:>7.2}   range ratio {:>5.2}",
                names[k], lo, hi, plo, phi, ratio
            );
        }
    }
    ExitCode::SUCCESS
}

fn mr2120_clearance_trajectory(
    sets: &[lash::mechanisms::mr2120::paper::ClearanceSet],
    out: &std::path::Path,
    dt: f64,
    json: bool,
) -> ExitCode {
    use lash::mechanisms::mr2120::{clearance::DEFAULT_DAMPING, trajectory, Geometry, MassProperties};
    use lash::plot::{LineChart, Series};
    if let Err(e) = std::fs::create_dir_all(out) {
        eprintln!("error: cannot create {}: {e}", out.display());
        return ExitCode::FAILURE;
    }
    let mut runs = vec![];
    for set in sets {
        let mut progress = Progress::new(&format!("mr2120 trajectory {}", set.name), 4.0);
        let r = trajectory::run_clearance(
            &Geometry::default(),
            &MassProperties::default(),
            set,
            DEFAULT_DAMPING,
            dt,
            4.0,
            trajectory::clearance_options(),
            |t| progress.update(t),
        );
        progress.finish();
        match r {
            Ok(run) => runs.push(run),
            Err(e) => {
                eprintln!("error: clearance set {}: {e}", set.name);
                return ExitCode::FAILURE;
            }
        }
    }
    for run in &runs {
        let mut csv = String::from("t_s,dxM_mm,dyM_mm,dzM_mm,dx_deg,dy_deg,dz_deg\n");
        for s in &run.samples {
            csv.push_str(&format!(
                "{},{},{},{},{},{},{}\n",
                s.t,
                s.d[0] * 1e3,
                s.d[1] * 1e3,
                s.d[2] * 1e3,
                s.delta[0].to_degrees(),
                s.delta[1].to_degrees(),
                s.delta[2].to_degrees()
            ));
        }
        let path = out.join(format!("trajectory_{}.csv", run.set));
        if let Err(e) = std::fs::write(&path, csv) {
            eprintln!("error: cannot write {}: {e}", path.display());
            return ExitCode::FAILURE;
        }
    }
    let names = ["d_xM", "d_yM", "d_zM", "delta_x", "delta_y", "delta_z"];
    for (k, name) in names.iter().enumerate() {
        let unit = if k < 3 { "mm" } else { "deg" };
        let series = runs
            .iter()
            .map(|r| Series {
                name: r.set.clone(),
                points: r
                    .samples
                    .iter()
                    .map(|s| {
                        (
                            s.t,
                            if k < 3 {
                                s.d[k] * 1e3
                            } else {
                                s.delta[k - 3].to_degrees()
                            },
                        )
                    })
                    .collect(),
            })
            .collect();
        let chart = LineChart {
            title: format!("MR2120 positioning error {name} along M1-M2-M3 (eq. 4.1)"),
            x_label: "t [s]".into(),
            y_label: format!("{name} [{unit}]"),
            series,
            y_range: None,
        };
        if let Err(e) = chart.save(&out.join(format!("error_{name}"))) {
            eprintln!("error: plot {name}: {e}");
            return ExitCode::FAILURE;
        }
    }
    let windows = [
        ("t < 1.5 s", 0.0, 1.5),
        ("near M2, 1.5-2.5 s", 1.5, 2.5),
        ("2.5-3.4 s", 2.5, 3.4),
        ("near M3, > 3.4 s", 3.4, 4.0),
    ];
    if json {
        let rows: Vec<_> = runs
            .iter()
            .map(|r| {
                let w: Vec<_> = windows
                    .iter()
                    .map(|(label, a, b)| {
                        let m = trajectory::max_errors(&r.samples, *a, *b);
                        serde_json::json!({"window": label, "max_abs_d_m": [m[0], m[1], m[2]], "max_abs_delta_rad": [m[3], m[4], m[5]]})
                    })
                    .collect();
                serde_json::json!({"set": r.set, "steps": r.steps, "wall_s": r.wall_s, "end": r.end, "windows": w})
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&rows).expect("serialises"));
    } else {
        println!("MR2120 clearance model along M1 -> M2 -> M3; errors of eq. (4.1) against the ideal path");
        println!(
            "{:<4} {:<20} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "set", "window", "|dxM| mm", "|dyM| mm", "|dzM| mm", "|dx| deg", "|dy| deg", "|dz| deg"
        );
        for r in &runs {
            for (label, a, b) in windows {
                let m = trajectory::max_errors(&r.samples, a, b);
                println!(
                    "{:<4} {:<20} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>9.4} {:>9.4}",
                    r.set,
                    label,
                    m[0] * 1e3,
                    m[1] * 1e3,
                    m[2] * 1e3,
                    m[3].to_degrees(),
                    m[4].to_degrees(),
                    m[5].to_degrees()
                );
            }
            println!(
                "{:<4} cost: {} steps, {} error-test failures, {} Newton iterations, {:.1} s wall",
                r.set, r.steps, r.error_test_failures, r.newton_iters, r.wall_s
            );
        }
        println!(
            "wrote trajectory_<set>.csv and error_<name>.png/.svg in {}",
            out.display()
        );
    }
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
        Command::Diagnose {
            report,
            json,
            suite,
            reduced,
            only,
            ..
        } if suite => suite_cmd(reduced, &only, &report, json),
        Command::Diagnose {
            model,
            params,
            fit,
            holdout,
            time_column,
            map,
            derivative_window,
            report,
            json,
            ..
        } => diagnose_cmd(
            &model,
            &params,
            &fit,
            &holdout,
            &time_column,
            &map,
            &derivative_window,
            &report,
            json,
        ),
        Command::Mr2120 {
            what:
                Mr2120What::Record {
                    effects,
                    case,
                    recordings,
                    seed,
                    duration,
                    rate,
                    no_torques,
                    out,
                    json,
                },
        } => record_cmd(
            &effects,
            case.as_deref(),
            recordings,
            seed,
            duration,
            rate,
            no_torques,
            &out,
            json,
        ),
        Command::Mr2120 {
            what: Mr2120What::Kinematics { json },
        } => mr2120_kinematics(json),
        Command::Mr2120 {
            what:
                Mr2120What::Accuracy {
                    points,
                    sets,
                    method,
                    json,
                },
        } => mr2120_accuracy(&points, &sets, &method, json),
        Command::Mr2120 {
            what:
                Mr2120What::Trajectory {
                    clearance,
                    out,
                    dt,
                    json,
                },
        } => mr2120_trajectory(&clearance, &out, dt, json),
        Command::Bench {
            what: BenchWhat::Mr2120(args),
        } => bench_mr2120(&args),
        Command::Bench {
            what:
                BenchWhat::Scaling {
                    links,
                    t_end,
                    out,
                    json,
                },
        } => bench_scaling_cmd(&links, t_end, &out, json),
        Command::Bench {
            what: BenchWhat::Dae { json, repeats, plots },
        } => {
            let rows = lash::bench::bench_dae(repeats);
            if let Some(dir) = plots {
                eprintln!("{}", andrews_work_precision(&dir, repeats));
            }
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
