//! `lash diagnose`: where a model and recordings disagree, the missing physics, its fit and
//! the held-out improvement; with `--suite`, the concealed-effects suite on the MR2120.

use super::progress::Progress;
use super::{items, json, CliError, Output};
use lash::diagnose::columns::{csv_header, resolve_columns, DFKI_RECORDINGS};
use lash::diagnose::model::{DoublePendulumModel, InverseDynamicsModel, Mr2120Model};
use lash::diagnose::play_dynamics::{ContactDamping, Interpolation, Stepping, STIFF_SUBSTEPS};
use lash::diagnose::recording::{read_csv, Recording};
use lash::diagnose::transmission::PlayPlace;
use lash::diagnose::{diagnose_recordings, format::number, DiagnoseOptions};
use std::path::{Path, PathBuf};

/// Report folder of a single diagnosis unless `--report` names one.
const REPORT: &str = "out/diagnose";
/// Report folder of the suite unless `--report` names one.
const SUITE_REPORT: &str = "out/diagnose-suite";

/// The half-width of the rate differentiation: chosen by cross-validation, or fixed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Window {
    /// Cross-validated over the model's grid.
    Auto,
    /// This many samples.
    Fixed(usize),
}

fn parse_window(s: &str) -> Result<Window, String> {
    match s {
        "auto" => Ok(Window::Auto),
        _ => match s.parse::<usize>() {
            Ok(w) if w >= 1 => Ok(Window::Fixed(w)),
            _ => Err("neither 'auto' nor a positive integer".into()),
        },
    }
}

fn parse_positive(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() => Ok(x),
        _ => Err("not a positive number".into()),
    }
}

/// Options of `lash diagnose`.
#[derive(clap::Args)]
pub struct Args {
    /// Nominal model (a model file `*.toml` or a URDF `*.urdf`: its measured joints are the
    /// channels, its sensors name the columns, its parameters may be perturbed, its
    /// `[recordings]` are the default --fit/--holdout (lash::diagnose::model_file);
    /// double-pendulum: the DFKI pendulum's rigid model from --params;
    /// mr2120: the MR2120's multibody ideal model with compliant drives (lash::diagnose::mr2120);
    /// mr2120-lumped: its closed-form rigid model, the model `lash mr2120 record` makes
    /// recordings from).
    #[arg(long, default_value = "double-pendulum")]
    model: String,
    /// A side file (TOML) over a URDF given as --model: its sensors, parameters, candidates
    /// and recordings, in place of the URDF the side file names itself
    /// (`--model ../shared/data/dfki-double-pendulum/pendubot-rigid.urdf --side models/dfki_pendulum.toml`).
    #[arg(long)]
    side: Option<PathBuf>,
    /// README with the model's parameter table.
    #[arg(long, default_value = lash::mechanisms::double_pendulum::DFKI_README)]
    params: PathBuf,
    /// Recordings to fit on, comma-separated CSV paths [default: the model's default
    /// recordings from the library: for double-pendulum the DFKI trajectories 0-5
    /// (lash::diagnose::columns::DFKI_RECORDINGS); mr2120 has none, so --fit is required].
    #[arg(long)]
    fit: Option<String>,
    /// Recordings held out (never fitted), comma-separated CSV paths [default: the model's
    /// default recordings: for double-pendulum the DFKI trajectories 12 and 13; for mr2120
    /// none].
    #[arg(long)]
    holdout: Option<String>,
    /// Time column [default: "time", or "t" if the first recording has no "time" column].
    #[arg(long)]
    time_column: Option<String>,
    /// Column mapping role=column for the model's roles (q1.., qd1.., tau1.., outputs).
    /// Default for double-pendulum: the DFKI recordings' columns
    /// (lash::diagnose::columns::DFKI_COLUMNS, e.g. q1=pos_filt1);
    /// for mr2120 each role reads the column of its own name (torques and tracker when
    /// present), and a mapping renames some of them.
    #[arg(long)]
    map: Option<String>,
    /// Half-width (samples) of the local cubic fit that differentiates rates into
    /// accelerations, or "auto": chosen by cross-validation on the fit recordings.
    #[arg(long, default_value = "auto", value_parser = parse_window)]
    derivative_window: Window,
    /// Candidates to leave out of the library: comma-separated texts, each matching every
    /// candidate whose name contains it, ignoring case (e.g. "sensor delay,Stribeck"); a text
    /// that matches none is an error listing the candidates.
    #[arg(long)]
    exclude: Option<String>,
    /// Report folder (Markdown, JSON, PNG/SVG plots) [default: out/diagnose, with --suite
    /// out/diagnose-suite].
    #[arg(long)]
    report: Option<PathBuf>,
    /// Skip the play-dynamics check (after the selection, a found radial play's drive
    /// torques from the reduced dynamic play model, the selection refitted: how much of what
    /// remains is the play's dynamics; costs the play's derivatives at every sample).
    #[arg(long)]
    no_play_dynamics: bool,
    /// Keep the play candidates quasi-static in the re-linearised pass (by default their
    /// drive torques come from the reduced dynamic play model at the first pass's estimate).
    #[arg(long)]
    quasi_static_play: bool,
    /// The reduced dynamic play model's balls on Hertz's law per direction, with the
    /// constants of the joint's own bearings (a ball in a bore of the reference play's
    /// clearance, a ball on the bore's end face), instead of one linear stiffness (part of
    /// the default since 2026-12-01; on top of --no-bearing-play, alone; also with --suite).
    #[arg(long)]
    hertz_play_contact: bool,
    /// The reduced dynamic play model's linear stiffness of a ball on its bore's end face,
    /// N/m, alone (with linear balls, --no-bearing-play: by default cross-validation chooses
    /// between 1e8 and 1.5e7; also with --suite).
    #[arg(long, value_name = "N_PER_M", value_parser = parse_positive)]
    play_axial_stiffness: Option<f64>,
    /// Re-linearise the reduced dynamic play model once about its own motion where its
    /// response is large (near a singular position; part of the default since 2026-12-01;
    /// on top of --no-bearing-play, alone; also with --suite).
    #[arg(long)]
    play_relinearize: bool,
    /// Continue the re-linearisation's Gauss–Newton steps to the last pass's estimates also
    /// when no step was held back (at most three passes, each kept only if it
    /// cross-validates better; also with --suite). The default since 2026-12-01; the
    /// flag stays for the commands written before.
    #[arg(long)]
    relinearize_to_convergence: bool,
    /// Stop the re-linearisation's Gauss–Newton steps after the second pass unless a step
    /// was held back (the behaviour before 2026-12-01; also with --suite).
    #[arg(long, conflicts_with = "relinearize_to_convergence")]
    no_relinearize_to_convergence: bool,
    /// Blend the reduced dynamic play model's linear forces in time from sample to sample
    /// rather than hold them at each sample interval's end (part of the default since
    /// 2026-12-01; on top of --no-bearing-play, alone; also with --suite).
    #[arg(long)]
    play_blended_forces: bool,
    /// Step the reduced dynamic play model through each sample interval in stiff substeps
    /// (the Rosenbrock method ROS2, taken again in halves where a ball starts or stops
    /// touching), at least N per interval (without N, `play_dynamics::STIFF_SUBSTEPS`, 40),
    /// instead of substeps that resolve the balls' fastest mode: about 4× less time in the
    /// model; not the default (at seed 2026 the suite's clearance-F held out at 1.30× with
    /// it, 1.17× without; also with --suite).
    #[arg(long, value_name = "N", num_args = 0..=1,
          value_parser = clap::value_parser!(u32).range(1..=100_000))]
    play_stiff_substeps: Option<Option<u32>>,
    /// Search the first found radial play's size: the selection refitted with the reduced
    /// dynamic play model run at each trial size (steps of 4, 2 and 1 %), then the other
    /// contact dampings at the best size (and the size again at a better one); the whole
    /// selection at the best size and damping kept if it cross-validates better (part of
    /// the default since 2026-12-01; on top of --no-bearing-play, alone; also with --suite).
    #[arg(long)]
    play_size_search: bool,
    /// With the size search (implies --play-size-search), the balls' damping searched too
    /// where a load-proportional one refits best: its constant part (steps of √10 and ⁴√10),
    /// then γ (steps of 50, 22 and 10 %), the size refined at each (the default since
    /// 2026-12-06; the flag stays for the commands written before, and turns the size
    /// search on with --no-bearing-play; also with --suite).
    #[arg(long)]
    play_damping_search: bool,
    /// The balls' damping chosen from the grid of contact dampings only, not searched
    /// (the behaviour before 2026-12-06; also with --suite).
    #[arg(long, conflicts_with = "play_damping_search")]
    no_play_damping_search: bool,
    /// No probe for a play the first pass saw but could not carry (by default, where the
    /// first pass selected no play and the candidate that cross-validated best alone is a
    /// play with an estimate outside its bounds, that joint's radial play is refitted with its dynamics at
    /// 1–20 µm at the default contact damping (2000 N·s/m), its size then searched at each
    /// other contact damping of the grid (up to 12 refits each), and the best size, where
    /// it refits better, becomes the second pass's reference play; likewise where the first
    /// pass selected a drive backlash and no play beside an unstable estimate, for the play
    /// that cross-validated best alone among the plays, in its own direction; also with
    /// --suite).
    #[arg(long)]
    no_play_probe: bool,
    /// Keep a contact compliance at the joint the selection held where the data cannot
    /// tell it from the compliance of the joint in series with it whose play was found (by
    /// default it is named at that joint after the last pass, the fit's numbers unchanged;
    /// also with --suite).
    #[arg(long)]
    keep_selected_compliance: bool,
    /// Also try load-proportional contact dampings γ·F in the reduced dynamic play model (γ
    /// in s/m, one or more, comma-separated, each over a small constant damping for the
    /// balls' sliding; cross-validation chooses among the dampings; 250, 500 and 1000 are
    /// tried by default since 2026-12-01, not with --no-bearing-play; also with --suite).
    #[arg(long, value_name = "S_PER_M", value_parser = parse_positive, value_delimiter = ',')]
    play_load_damping: Vec<f64>,
    /// Where a found backlash's play sits, alone: "output" (between the transmission's
    /// spring and the arm, as a gear mesh) or "spring" (a dead zone of the spring's
    /// deflection); by default cross-validation chooses, the output first (also with
    /// --suite).
    #[arg(long, value_name = "PLACE", value_parser = ["output", "spring"])]
    backlash_place: Option<String>,
    /// The reduced dynamic play model as close to the joints' bearings as lash makes it:
    /// --hertz-play-contact --play-relinearize --play-blended-forces --play-size-search
    /// and --play-load-damping 250,500,1000 together (`DiagnoseOptions::with_bearing_play`;
    /// 2–6× the time where a play is selected; also with --suite). The default since
    /// 2026-12-01; the flag stays for the commands written before.
    #[arg(long)]
    bearing_play: bool,
    /// The fast path of the reduced dynamic play model, as before 2026-12-01: linear balls,
    /// linearised about the nominal motion, forces held within a sample interval, constant
    /// contact dampings only, no search on the play's size
    /// (`DiagnoseOptions::without_bearing_play`; the flags above then add back what they
    /// name; also with --suite).
    #[arg(long, conflicts_with = "bearing_play")]
    no_bearing_play: bool,
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
    /// With --suite: where the recordings come from: multibody (simulated multibody truths,
    /// the proof) or lumped (the closed-form model with the library's own forms: fast unit
    /// cases of the selection only).
    #[arg(long, default_value = "multibody", value_parser = ["multibody", "lumped"])]
    truth: String,
    /// With --suite: also write each case's recordings (with their noise) to
    /// DIR/<case>/recording-01.csv, … (fit recordings first, then the held-out ones), to
    /// diagnose them again with --model mr2120 --fit … --holdout …
    #[arg(long, value_name = "DIR")]
    keep_recordings: Option<PathBuf>,
    /// With --suite: the base seed of the recordings' commanded paths and noise (default:
    /// that of the scoreboard the README quotes, 2026 for either design); another seed
    /// diagnoses paths and noise that no result in the repository has seen.
    #[arg(long)]
    seed: Option<u64>,
    /// With --suite: every sensor's noise (encoders, rates, torques, tracker) times this
    /// factor (default 1: the suite's sensors; 0.1 separates what the noise costs the
    /// diagnosis from what its models miss).
    #[arg(long, value_name = "FACTOR", value_parser = parse_positive, requires = "suite")]
    noise_scale: Option<f64>,
}

/// Diagnoses the recordings, or runs the suite; the suite's check is its targets.
pub fn run(a: Args) -> Result<Output, CliError> {
    if a.suite {
        let dir = a.report.clone().unwrap_or_else(|| SUITE_REPORT.into());
        return suite(&a, &dir);
    }
    let dp;
    let mr;
    let mb;
    let mf;
    if a.side.is_some() && !a.model.ends_with(".urdf") {
        return Err(CliError::input(format!(
            "--side applies a side file over a URDF, but --model '{}' is not a .urdf file",
            a.model
        )));
    }
    let mut file_recordings: Option<(Vec<String>, Vec<String>)> = None;
    let (model, defaults): (&dyn InverseDynamicsModel, _) = match a.model.as_str() {
        file if file.ends_with(".toml") || file.ends_with(".urdf") => {
            let f = lash::model_file::ModelFile::load_with_side(file, a.side.as_deref())
                .map_err(CliError::input)?;
            if !f.fit_recordings.is_empty() {
                let s = |v: &[std::path::PathBuf]| v.iter().map(|p| p.display().to_string()).collect();
                file_recordings = Some((s(&f.fit_recordings), s(&f.holdout_recordings)));
            }
            mf = lash::diagnose::model_file::model_from_file(f).map_err(CliError::input)?;
            (&mf, None)
        }
        "double-pendulum" => {
            let params = lash::mechanisms::double_pendulum::DoublePendulumParams::from_readme(&a.params)
                .map_err(CliError::input)?;
            dp = DoublePendulumModel { params };
            (&dp, Some(DFKI_RECORDINGS))
        }
        "mr2120" => {
            mb = lash::diagnose::mr2120::mr2120_model(
                &lash::mechanisms::mr2120::Geometry::default(),
                &lash::mechanisms::mr2120::MassProperties::default(),
            )
            .map_err(CliError::run)?;
            (&mb, None)
        }
        "mr2120-lumped" => {
            mr = Mr2120Model {
                nominal: lash::mechanisms::mr2120::record::nominal_model(),
            };
            (&mr, None)
        }
        other => {
            return Err(CliError::Input(format!(
                "unknown model '{other}' (available: double-pendulum, mr2120, mr2120-lumped, or a model file ending in .toml or .urdf)"
            )))
        }
    };
    let fit_files: Vec<String> = match (&a.fit, defaults) {
        (Some(list), _) => items(list).map(String::from).collect(),
        (None, Some(d)) => d.fit.iter().map(|f| f.to_string()).collect(),
        (None, None) if file_recordings.is_some() => file_recordings.clone().unwrap_or_default().0,
        (None, None) => {
            return Err(CliError::Input(format!(
                "--model {} has no default recordings: name the recordings to fit on with --fit (e.g. written by `lash mr2120 record`)",
                a.model
            )))
        }
    };
    let holdout_files: Vec<String> = match (&a.holdout, defaults) {
        (Some(list), _) => items(list).map(String::from).collect(),
        (None, Some(d)) => d.holdout.iter().map(|f| f.to_string()).collect(),
        (None, None) => file_recordings.map(|r| r.1).unwrap_or_default(),
    };
    let first = fit_files
        .first()
        .ok_or_else(|| CliError::input("--fit names no recording"))?;
    let header = csv_header(Path::new(first)).map_err(CliError::input)?;
    let mapping = resolve_columns(model, a.map.as_deref(), &header).map_err(CliError::input)?;
    let time_column = a.time_column.clone().unwrap_or_else(|| {
        if header.iter().any(|h| h == "time") || !header.iter().any(|h| h == "t") {
            "time".into()
        } else {
            "t".into()
        }
    });
    let windows = match a.derivative_window {
        Window::Auto => model.derivative_windows(),
        Window::Fixed(w) => vec![w],
    };
    let load = |list: &[String]| -> Result<Vec<Recording>, CliError> {
        list.iter()
            .map(|f| read_csv(Path::new(f), &time_column, &mapping).map_err(CliError::input))
            .collect()
    };
    let fit = load(&fit_files)?;
    let held = load(&holdout_files)?;
    let mut opts = DiagnoseOptions {
        play_dynamics: !a.no_play_dynamics,
        dynamic_play_selection: !a.quasi_static_play,
        ..DiagnoseOptions::default()
    };
    play_options(&a, &mut opts);
    opts.library.exclude = a
        .exclude
        .as_deref()
        .map(|x| items(x).map(String::from).collect())
        .unwrap_or_default();
    let mut progress = Progress::new("diagnose", 1.0);
    let d = diagnose_recordings(model, &fit, &held, &windows, &opts, |s, f| {
        progress.update_stage("diagnose", s, f)
    });
    progress.finish();
    let d = d.map_err(CliError::input)?;
    let report = a.report.unwrap_or_else(|| REPORT.into());
    let md = lash::diagnose::report::write_report(&d, &report).map_err(CliError::run)?;
    if a.json {
        println!("{}", json(&d));
        return Ok(Output::OK);
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
    if let Some(why) = d.nothing_selected() {
        println!("  none: {why}");
    }
    println!("\nreport: {}", md.display());
    Ok(Output::OK)
}

/// The concealed-effects suite with the arguments' options (`--reduced`, `--truth`,
/// `--only`, `--keep-recordings`, `--seed`, the play model's switches), its report in `dir`.
fn suite(a: &Args, dir: &Path) -> Result<Output, CliError> {
    use lash::diagnose::suite::{run_suite, SuiteError, SuiteOptions, SCOREBOARD_FILE};
    let mut opts = match (a.truth.as_str(), a.reduced) {
        ("lumped", true) => SuiteOptions::lumped_reduced(),
        ("lumped", false) => SuiteOptions::lumped(),
        (_, true) => SuiteOptions::reduced(),
        (_, false) => SuiteOptions::default(),
    };
    let chosen: Vec<String> = items(&a.only).map(String::from).collect();
    if !chosen.is_empty() {
        opts.only = chosen;
    }
    opts.keep_recordings = a.keep_recordings.clone();
    if let Some(seed) = a.seed {
        opts.seed = seed;
    }
    if let Some(f) = a.noise_scale {
        opts.record.noise = opts.record.noise.scaled(f);
    }
    play_options(a, &mut opts.diagnose);
    let mut progress = Progress::new("diagnose --suite", 1.0);
    let board = run_suite(&opts, Some(dir), |s, f| {
        progress.update_stage("diagnose --suite", s, f)
    });
    progress.finish();
    let board = board.map_err(|e| match e {
        SuiteError::NoSuchCase { .. } => CliError::Input(format!("--only: {e}")),
        e => CliError::run(e),
    })?;
    if a.json {
        println!("{}", json(&board));
        return Ok(Output::checked(board.targets_met));
    }
    let (f, h, d, r) = board.design;
    println!(
        "Concealed-effects suite on the MR2120, truth from {}: {f} recordings fitted, {h} held out per case, {d} s at {r} Hz; noise: torque {} N m, tracker {} m, encoder {} rad, rate {} rad/s; seed {}\n",
        match board.truth_source {
            lash::diagnose::suite::TruthSource::Multibody => "simulated multibody models",
            lash::diagnose::suite::TruthSource::Lumped => "the closed-form model (the library's own forms: unit cases only)",
        },
        board.noise.torque, board.noise.tracker, board.noise.encoder, board.noise.rate, board.seed
    );
    println!(
        "{:<24} {:>7} {:>6}  {:<6} {:<22} {:>8} {:>9}  {:<5} {:>6}  found first",
        "case", "<noise", "peak", "ranked", "estimate (rel. err.)", "held/σ", "explained", "pass", "time"
    );
    for c in &board.cases {
        let est: Vec<String> = c
            .estimates
            .iter()
            .map(|e| match e {
                Some((_, r)) if r.is_nan() => "named (not sized)".into(),
                Some((_, r)) => format!("{:.1} %", 100.0 * r),
                None => "not found".into(),
            })
            .collect();
        println!(
            "{:<24} {:>6}% {:>6.1}  {:<6} {:<22} {:>8.2} {:>8}%  {:<5} {:>4.0} s  {}",
            c.case,
            lash::diagnose::adequacy::percent_text(c.below_noise_fraction),
            c.peak_snr,
            match c.kind {
                lash::diagnose::suite::CaseKind::OutOfLibrary => "n/a",
                _ if c.ranked_first => "yes",
                _ => "no",
            },
            if est.is_empty() {
                "-".to_string()
            } else {
                est.join(", ")
            },
            c.holdout_noise_ratio,
            lash::diagnose::adequacy::percent_text(c.explained_fraction),
            if c.pass { "yes" } else { "NO" },
            c.seconds,
            c.found_text()
        );
        if let Some(x) = &c.confounded {
            println!("{:<24} flagged as confounded; separating experiment: {x}", "");
        }
    }
    println!(
        "\nconcealed by measure {}/{}  ranked first {}/{}  estimates within 30 % {}/{}  held-out ≤ 1.2× noise {}/{}  null case {}  out of library flagged {}/{}  pair case {}",
        board.concealed_by_measure.0,
        board.concealed_by_measure.1,
        board.ranked_first.0,
        board.ranked_first.1,
        board.estimates_within_30pct.0,
        board.estimates_within_30pct.1,
        board.holdout_at_noise.0,
        board.holdout_at_noise.1,
        if board.null_ok { "ok" } else { "FAILED" },
        board.out_of_library_ok.0,
        board.out_of_library_ok.1,
        if board.pair_ok { "ok" } else { "FAILED" }
    );
    println!(
        "targets {}; scoreboard: {}; one diagnosis report per case in {}/<case>/",
        if board.targets_met { "met" } else { "NOT met" },
        dir.join(SCOREBOARD_FILE).display(),
        dir.display()
    );
    Ok(Output::checked(board.targets_met))
}

/// The flags on the re-linearisation and the reduced dynamic play model, for a diagnosis and
/// for the suite alike: the bearing preset is the default (`--bearing-play` asks for it
/// again), `--no-bearing-play` the fast path (`DiagnoseOptions::without_bearing_play`);
/// then each flag of its own on top.
fn play_options(a: &Args, opts: &mut DiagnoseOptions) {
    *opts = if a.no_bearing_play {
        std::mem::take(opts).without_bearing_play()
    } else {
        std::mem::take(opts).with_bearing_play()
    };
    opts.library.play_contact_hertz |= a.hertz_play_contact;
    if let Some(k) = a.play_axial_stiffness {
        opts.library.play_axial_stiffness = Some(k);
        opts.play_axial_stiffnesses = vec![k];
    }
    opts.library.play_relinearize |= a.play_relinearize;
    opts.relinearize_to_convergence = converge(a);
    if a.play_blended_forces {
        opts.library.play_interpolation = Interpolation::Linear;
    }
    if let Some(n) = a.play_stiff_substeps {
        opts.library.play_stepping = Stepping::Stiff {
            per_sample: n.map_or(STIFF_SUBSTEPS, |n| n as usize),
        };
    }
    opts.play_size_search |= a.play_size_search || a.play_damping_search;
    opts.play_damping_search =
        (opts.play_damping_search || a.play_damping_search) && !a.no_play_damping_search;
    opts.play_probe &= !a.no_play_probe;
    opts.name_compliance_at_play &= !a.keep_selected_compliance;
    for &g in &a.play_load_damping {
        opts.add_contact_damping(ContactDamping::load_proportional(g));
    }
    if let Some(p) = backlash_place(a) {
        opts.backlash_places = vec![p];
    }
}

/// Whether the Gauss–Newton steps go on to convergence: the default, unless
/// `--no-relinearize-to-convergence` (the two flags together are refused by clap).
fn converge(a: &Args) -> bool {
    a.relinearize_to_convergence || !a.no_relinearize_to_convergence
}

/// The place `--backlash-place` names, if given.
fn backlash_place(a: &Args) -> Option<PlayPlace> {
    a.backlash_place.as_deref().map(|p| match p {
        "spring" => PlayPlace::Spring,
        _ => PlayPlace::Output,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// `lash diagnose`'s flags alone, as the binary parses them.
    #[derive(Parser)]
    struct Cmd {
        #[command(flatten)]
        args: Args,
    }

    fn options(flags: &[&str]) -> DiagnoseOptions {
        let cmd = Cmd::try_parse_from(std::iter::once("diagnose").chain(flags.iter().copied()))
            .expect("the flags parse");
        let mut opts = DiagnoseOptions::default();
        play_options(&cmd.args, &mut opts);
        opts
    }

    #[test]
    fn the_damping_search_is_the_default_and_a_flag_turns_it_off() {
        let d = options(&[]);
        assert!(d.play_size_search && d.play_damping_search);
        let grid = options(&["--no-play-damping-search"]);
        assert!(grid.play_size_search && !grid.play_damping_search);
        // The old flag still parses and changes nothing in the default.
        assert_eq!(options(&["--play-damping-search"]), d);
        // On the fast path the size search is off, so the search does not act; the flag
        // turns both on there, as before.
        let fast = options(&["--no-bearing-play"]);
        assert!(!fast.play_size_search);
        let fast_searched = options(&["--no-bearing-play", "--play-damping-search"]);
        assert!(fast_searched.play_size_search && fast_searched.play_damping_search);
        // Both at once are refused.
        assert!(
            Cmd::try_parse_from(["diagnose", "--play-damping-search", "--no-play-damping-search"]).is_err()
        );
    }
}
