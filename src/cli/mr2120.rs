//! `lash mr2120`: the WUT MR2120 parallel mechanism of the reference paper (kinematics,
//! accuracy, trajectory) and synthetic recordings of it.

use super::progress::Progress;
use super::{items, json, CliError, Output};
use lash::mechanisms::mr2120::record::RecordOptions;
use lash::mechanisms::mr2120::{accuracy, clearance, output, paper, trajectory, Geometry, MassProperties};
use std::path::{Path, PathBuf};

/// The MR2120 subcommands.
#[derive(clap::Subcommand)]
pub enum Mr2120What {
    /// Synthetic recordings from a truth with hidden effects: drive angles, rates and
    /// torques, platform centre from a tracker, with stated noise (CSV), and the truth
    /// (truth.json, which the diagnosis never reads).
    Record(RecordArgs),
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
        /// Method: dynamic (the paper's excitation), static (envelope of equilibria, solved directly), relaxation (the same equilibria by dynamic relaxation, slower), linear (first order in the clearances) or both (dynamic and static).
        #[arg(long, default_value = "dynamic", value_parser = parse_methods)]
        method: Methods,
        /// Print the rows as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Trajectory M1 → M2 → M3 (paper §4.1): drive angles, platform path, drive torques.
    Trajectory {
        /// Clearance set: none (ideal model), L1, L2, L3 or all.
        #[arg(long, default_value = "none", value_parser = parse_clearance)]
        clearance: Sets,
        /// Output folder for CSV and plots.
        #[arg(long, default_value = "out/mr2120-trajectory")]
        out: PathBuf,
        /// Sampling interval of the outputs, s.
        #[arg(long, default_value_t = 0.01)]
        dt: f64,
        /// Print a summary as JSON.
        #[arg(long)]
        json: bool,
    },
}

/// The methods `--method` names.
#[derive(Debug, Clone)]
pub struct Methods(Vec<accuracy::Method>);

/// The clearance sets `--clearance` names (none: the ideal model).
#[derive(Debug, Clone)]
pub struct Sets(Vec<paper::ClearanceSet>);

/// `--method`: one of the library's methods by name, or "both".
fn parse_methods(s: &str) -> Result<Methods, String> {
    match s {
        "both" => Ok(Methods(vec![accuracy::Method::Dynamic, accuracy::Method::Static])),
        m => m
            .parse()
            .map(|m| Methods(vec![m]))
            .map_err(|e| format!("{e} or both")),
    }
}

/// `--clearance`: "none" (the ideal model, no set), "all" (every set of the paper's
/// Table 1) or one set by the library's name.
fn parse_clearance(s: &str) -> Result<Sets, String> {
    match s {
        "none" => Ok(Sets(vec![])),
        "all" | "ALL" => Ok(Sets(paper::TABLE1.to_vec())),
        name => clearance::clearance_set(name)
            .map(|s| Sets(vec![s]))
            .map_err(|e| e.to_string()),
    }
}

/// Options of `lash mr2120 record`.
#[derive(clap::Args)]
pub struct RecordArgs {
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
    /// Duration of each recording, s (default: the library's `RecordOptions::default()`).
    #[arg(long, default_value_t = RecordOptions::default().duration)]
    duration: f64,
    /// Sampling rate, Hz (default: the library's `RecordOptions::default()`).
    #[arg(long, default_value_t = RecordOptions::default().rate)]
    rate: f64,
    /// Leave out the drive torques (tracker only).
    #[arg(long)]
    no_torques: bool,
    /// Output folder.
    #[arg(long, default_value = "out/mr2120-record")]
    out: PathBuf,
    /// Print a summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs one MR2120 subcommand.
pub fn run(what: Mr2120What) -> Result<Output, CliError> {
    match what {
        Mr2120What::Record(a) => record(&a),
        Mr2120What::Kinematics { json } => kinematics(json),
        Mr2120What::Accuracy {
            points,
            sets,
            method,
            json,
        } => accuracy_cmd(&points, &sets, &method.0, json),
        Mr2120What::Trajectory {
            clearance,
            out,
            dt,
            json,
        } => trajectory_cmd(&clearance.0, &out, dt, json),
    }
}

fn record(a: &RecordArgs) -> Result<Output, CliError> {
    use lash::diagnose::suite::lumped::{cases, excitation};
    use lash::mechanisms::mr2120::record::{
        nominal_model, write_recordings, HiddenEffects, RecordError, WrittenRecording,
    };
    let mut hidden = HiddenEffects::default();
    let mut torques = !a.no_torques;
    if let Some(name) = &a.case {
        match cases().into_iter().find(|c| &c.name == name) {
            Some(c) => {
                hidden = c.effects;
                torques &= c.torques;
            }
            None => {
                let names: Vec<String> = cases().into_iter().map(|c| c.name).collect();
                return Err(CliError::Input(format!(
                    "unknown case '{name}' (cases: {})",
                    names.join(", ")
                )));
            }
        }
    }
    for item in items(&a.effects) {
        let Some((k, v)) = item.split_once('=') else {
            return Err(CliError::Input(format!("--effects: '{item}' is not name=value")));
        };
        let value = v
            .trim()
            .parse::<f64>()
            .map_err(|_| CliError::Input(format!("--effects: '{v}' is not a number")))?;
        hidden
            .set(k.trim(), value)
            .map_err(|e| CliError::Input(format!("--effects: {e}")))?;
    }
    if a.recordings == 0 {
        return Err(CliError::input("--recordings must be at least 1"));
    }
    let opts = RecordOptions {
        duration: a.duration,
        rate: a.rate,
        torques,
        ..RecordOptions::default()
    };
    let out = &a.out;
    let excitations: Vec<_> = (0..a.recordings).map(|r| excitation(a.seed, r)).collect();
    let (truth, tpath) = write_recordings(out, &nominal_model(), &hidden, &excitations, &opts, a.seed)
        .map_err(|e| match e {
            RecordError::Invalid(_) => CliError::input(e),
            _ => CliError::run(e),
        })?;
    let files = &truth.recordings;
    if a.json {
        println!("{}", truth.json());
        return Ok(Output::OK);
    }
    println!(
        "{} recordings of {} s at {} Hz in {} (columns: time, q1..q3 [rad], qd1..qd3 [rad/s]{}, x, y, z [m]); truth in {}",
        a.recordings,
        opts.duration,
        opts.rate,
        out.display(),
        if torques { ", tau1..tau3 [N m]" } else { "" },
        tpath.display()
    );
    let file = |f: &WrittenRecording| f.file.clone();
    println!(
        "diagnose them: lash diagnose --model mr2120-lumped --fit {} --holdout {}",
        files
            .iter()
            .take(a.recordings.saturating_sub(1).max(1))
            .map(file)
            .collect::<Vec<_>>()
            .join(","),
        files.last().map(file).unwrap_or_default()
    );
    Ok(Output::OK)
}

fn kinematics(as_json: bool) -> Result<Output, CliError> {
    let g = Geometry::default();
    let rows = lash::mechanisms::mr2120::table2(&g).map_err(CliError::run)?;
    if as_json {
        println!("{}", json(&rows));
        return Ok(Output::OK);
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
    Ok(Output::OK)
}

fn accuracy_cmd(
    points: &str,
    sets: &str,
    methods: &[accuracy::Method],
    as_json: bool,
) -> Result<Output, CliError> {
    let pts = super::mr2120_points(points)?;
    let ss = sets
        .split(',')
        .map(str::trim)
        .map(|name| clearance::clearance_set(name).map_err(CliError::input))
        .collect::<Result<Vec<_>, _>>()?;
    let ex = accuracy::Excitation::default();
    let mut progress = Progress::new("mr2120 accuracy", (pts.len() * ss.len() * methods.len()) as f64);
    let rows = accuracy::table3(
        &Geometry::default(),
        &MassProperties::default(),
        &pts,
        &ss,
        methods,
        &ex,
        |i, _| progress.update(i as f64),
    );
    progress.finish();
    let rows = rows.map_err(CliError::run)?;
    if as_json {
        println!("{}", json(&serde_json::json!({"excitation": ex, "rows": rows})));
        return Ok(Output::OK);
    }
    println!("MR2120 positioning accuracy (paper Table 3): ranges min..max; d in mm, delta in deg");
    println!("method (a): drives locked at q(M), settle {} s, then half-sine pulses of {} N along +-x, +-y, +-z and {} N m about +-x, +-y, +-z, {} s each", ex.settle, ex.force, ex.torque, ex.pulse);
    println!("method (b): static equilibria (solved directly; `--method relaxation`: by dynamic relaxation) under no load and constant {} N / {} N m along/about +-x, +-y, +-z", ex.force, ex.torque);
    println!("method (c), --method linear: the same load cases to first order in the clearances (the ideal model's joint reactions push each joint across its play; no contact elasticity; none at singular configurations)");
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
    Ok(Output::OK)
}

fn trajectory_cmd(
    sets: &[paper::ClearanceSet],
    out: &Path,
    dt: f64,
    as_json: bool,
) -> Result<Output, CliError> {
    if !(dt > 0.0 && dt <= 0.5) {
        return Err(CliError::Input(format!("--dt must be in (0, 0.5] s, got {dt}")));
    }
    lash::multibody::output_count(trajectory::DURATION, dt)
        .map_err(|e| CliError::Input(format!("--dt: {e}")))?;
    if sets.is_empty() {
        ideal_trajectory(out, dt, as_json)
    } else {
        clearance_trajectory(sets, out, dt, as_json)
    }
}

fn ideal_trajectory(out: &Path, dt: f64, as_json: bool) -> Result<Output, CliError> {
    let mut progress = Progress::new("mr2120 ideal trajectory", trajectory::DURATION);
    let run = trajectory::run_ideal(
        &Geometry::default(),
        &MassProperties::default(),
        dt,
        trajectory::DURATION,
        Default::default(),
        |t| progress.update(t),
    );
    progress.finish();
    let run = run.map_err(CliError::run)?;
    let csv_path = output::write_ideal(&run, out).map_err(CliError::run)?;
    let end = match &run.end {
        lash::multibody::RunEnd::Completed => format!("completed to t = {} s", trajectory::DURATION),
        lash::multibody::RunEnd::StoppedAtSingularity { t, measure, error } => format!(
            "stopped at the direct-kinematics singularity M3: last good sample t = {t:.3} s (measure {measure:.2e}); the integrator then failed: {error}"
        ),
    };
    if as_json {
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
        println!("{}", json(&summary));
        return Ok(Output::OK);
    }
    println!(
        "MR2120 ideal model along M1 (t = 0) -> M2 ({} s) -> M3 ({} s), quintic rest-to-rest legs on the z axis",
        paper::TRAJECTORY_T_M2,
        trajectory::DURATION
    );
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
    Ok(Output::OK)
}

fn clearance_trajectory(
    sets: &[paper::ClearanceSet],
    out: &Path,
    dt: f64,
    as_json: bool,
) -> Result<Output, CliError> {
    output::create_dir(out).map_err(CliError::run)?;
    let mut runs = vec![];
    for set in sets {
        let mut progress = Progress::new(&format!("mr2120 trajectory {}", set.name), trajectory::DURATION);
        let r = trajectory::run_clearance(
            &Geometry::default(),
            &MassProperties::default(),
            set,
            clearance::DEFAULT_DAMPING,
            dt,
            trajectory::DURATION,
            trajectory::clearance_options(),
            |t| progress.update(t),
        );
        progress.finish();
        runs.push(r.map_err(|e| CliError::Run(format!("clearance set {}: {e}", set.name)))?);
    }
    output::write_clearance(&runs, out).map_err(CliError::run)?;
    if as_json {
        let rows: Vec<_> = runs
            .iter()
            .map(|r| {
                let w: Vec<_> = output::window_errors(r)
                    .iter()
                    .map(|e| {
                        serde_json::json!({"window": e.window, "max_abs_d_m": e.d, "max_abs_delta_rad": e.delta})
                    })
                    .collect();
                serde_json::json!({"set": r.set, "steps": r.steps, "wall_s": r.wall_s, "end": r.end, "windows": w})
            })
            .collect();
        println!("{}", json(&rows));
        return Ok(Output::OK);
    }
    println!("MR2120 clearance model along M1 -> M2 -> M3; errors of eq. (4.1) against the ideal path");
    println!(
        "{:<4} {:<20} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "set", "window", "|dxM| mm", "|dyM| mm", "|dzM| mm", "|dx| deg", "|dy| deg", "|dz| deg"
    );
    for r in &runs {
        for e in output::window_errors(r) {
            let [a, b, c, x, y, z] = output::in_mm_and_degrees(&e.d, &e.delta);
            println!(
                "{:<4} {:<20} {a:>9.4} {b:>9.4} {c:>9.4} {x:>9.4} {y:>9.4} {z:>9.4}",
                r.set, e.window
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
    Ok(Output::OK)
}
