//! `lash check` and `lash simulate`: mechanisms from model files.

use super::progress::Progress;
use super::{json, CliError, Output};
use clap::Args as ClapArgs;
use lash::model_file::{simulate, BuildOptions, ModelFile};
use lash::multibody::SimulationOptions;
use std::path::PathBuf;

/// Arguments of `lash check`.
#[derive(ClapArgs, Debug)]
pub struct CheckArgs {
    /// Model files (TOML).
    #[arg(required = true)]
    pub models: Vec<PathBuf>,
    /// A side file (TOML) applied over each model, which must then be a URDF (in place of
    /// the URDF the side file names itself)
    #[arg(long)]
    pub side: Option<PathBuf>,
    /// Print JSON (one object per file, in an array if more than one).
    #[arg(long)]
    pub json: bool,
    /// Build joints that declare a clearance with their bearings (Hertz contact) instead of
    /// ideal joints.
    #[arg(long)]
    pub clearance: bool,
}

/// Arguments of `lash simulate`.
#[derive(ClapArgs, Debug)]
pub struct SimulateArgs {
    /// Model file (TOML).
    pub model: PathBuf,
    /// A side file (TOML) applied over the model, which must then be a URDF
    #[arg(long)]
    pub side: Option<PathBuf>,
    /// End time, s.
    #[arg(long)]
    pub t_end: f64,
    /// Sample interval, s.
    #[arg(long, default_value_t = 1e-3)]
    pub dt: f64,
    /// Relative tolerance of the BDF integrator.
    #[arg(long, default_value_t = 1e-6)]
    pub rtol: f64,
    /// Absolute tolerance (m, rad and their rates).
    #[arg(long, default_value_t = 1e-8)]
    pub atol: f64,
    /// Build joints that declare a clearance with their bearings (Hertz contact) instead of
    /// ideal joints.
    #[arg(long)]
    pub clearance: bool,
    /// Output folder (sensors.csv and one chart per sensor column, PNG and SVG).
    #[arg(long, default_value = "out/simulate")]
    pub out: PathBuf,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
}

/// Runs `lash check`.
pub fn check(a: CheckArgs) -> Result<Output, CliError> {
    let mut reports = vec![];
    for path in &a.models {
        let file = ModelFile::load_with_side(path, a.side.as_deref()).map_err(CliError::input)?;
        let opts = BuildOptions {
            clearance: a.clearance,
            ..Default::default()
        };
        let r = file.check_with(&opts).map_err(CliError::input)?;
        if !a.json {
            println!("{}: model '{}' is valid", r.file, r.name);
            println!(
                "  {} degrees of freedom ({} once the drivers act); assembles at t = 0 s to {:.1e} (m or rad)",
                r.dof, r.dof_driven, r.assembly_residual
            );
            let declared = r.joints.iter().filter(|j| j.clearance_m.is_some()).count();
            if declared > 0 {
                println!(
                    "  {declared} joints declare a clearance: {}",
                    if r.clearance {
                        "built as bearings (contact)"
                    } else {
                        "built as ideal joints here; --clearance builds their bearings"
                    }
                );
            }
            let names = |v: Vec<String>| {
                if v.is_empty() {
                    "none".to_string()
                } else {
                    v.join(", ")
                }
            };
            println!(
                "  bodies ({}): {}",
                r.bodies.len(),
                names(
                    r.bodies
                        .iter()
                        .map(|b| format!("{} {} kg", b.name, b.mass_kg))
                        .collect()
                )
            );
            println!(
                "  joints ({}): {}",
                r.joints.len(),
                names(
                    r.joints
                        .iter()
                        .map(|j| {
                            let c = j
                                .clearance_m
                                .map(|c| {
                                    format!(
                                        ", clearance {:.1} um radial / {:.1} um axial",
                                        c[0] * 1e6,
                                        c[1] * 1e6
                                    )
                                })
                                .unwrap_or_default();
                            let unit = if j.kind == "prismatic" { "m" } else { "rad" };
                            let l = j
                                .limits
                                .map(|l| format!(", limits {} to {} {unit}", l[0], l[1]))
                                .unwrap_or_default();
                            let t = j
                                .transmission
                                .as_ref()
                                .map(|t| {
                                    let (cu, ju, du) = if j.kind == "prismatic" {
                                        ("m/N", "kg", "N s/m")
                                    } else {
                                        ("rad/(N m)", "kg m^2", "N m s/rad")
                                    };
                                    format!(
                                        ", transmission: compliance {} {cu}, rotor {} {ju}, damping {} {du}",
                                        t.compliance, t.rotor_inertia, t.damping
                                    )
                                })
                                .unwrap_or_default();
                            format!("{} ({} {}-{}{c}{l}{t})", j.name, j.kind, j.i, j.j)
                        })
                        .collect()
                )
            );
            println!(
                "  drivers ({}): {}",
                r.drivers.len(),
                names(
                    r.drivers
                        .iter()
                        .map(|d| format!("{} on {}", d.name, d.joint))
                        .collect()
                )
            );
            println!(
                "  forces ({}): {}",
                r.forces.len(),
                names(
                    r.forces
                        .iter()
                        .map(|f| format!("{} ({})", f.name, f.kind))
                        .collect()
                )
            );
            println!(
                "  sensors ({}): {}",
                r.sensors.len(),
                names(
                    r.sensors
                        .iter()
                        .flat_map(|s| {
                            let side = if s.side == "motor" { ", motor side" } else { "" };
                            s.columns
                                .iter()
                                .map(move |c| format!("{} [{}{side}]", c[0], c[1]))
                        })
                        .collect()
                )
            );
            println!(
                "  parameters ({}): {}",
                r.parameters.len(),
                names(
                    r.parameters
                        .iter()
                        .map(|p| format!("{} = {} {}", p.name, p.nominal, p.unit))
                        .collect()
                )
            );
        }
        reports.push(r);
    }
    if a.json {
        if reports.len() == 1 {
            println!("{}", json(&reports[0]));
        } else {
            println!("{}", json(&reports));
        }
    }
    Ok(Output::OK)
}

/// Runs `lash simulate`.
pub fn simulate_cmd(a: SimulateArgs) -> Result<Output, CliError> {
    if !(a.t_end > 0.0 && a.t_end.is_finite()) {
        return Err(CliError::input(format!(
            "--t-end must be positive, not {} s",
            a.t_end
        )));
    }
    if !(a.dt > 0.0 && a.dt.is_finite() && a.dt <= a.t_end) {
        return Err(CliError::input(format!(
            "--dt must be positive and at most --t-end, not {} s",
            a.dt
        )));
    }
    if !(a.rtol > 0.0 && a.rtol < 1.0 && a.atol > 0.0) {
        return Err(CliError::input("--rtol must be in (0, 1) and --atol positive"));
    }
    lash::multibody::output_count(a.t_end, a.dt)
        .map_err(|e| CliError::input(format!("--t-end and --dt: {e}")))?;
    let file = ModelFile::load_with_side(&a.model, a.side.as_deref()).map_err(CliError::input)?;
    let values: Vec<f64> = file.parameters.iter().map(|p| p.nominal).collect();
    let built = file
        .build_with(
            &values,
            &BuildOptions {
                clearance: a.clearance,
                ..Default::default()
            },
        )
        .map_err(CliError::input)?;
    file.assemble(&built).map_err(CliError::input)?;
    std::fs::create_dir_all(&a.out).map_err(|e| CliError::run(format!("{}: {e}", a.out.display())))?;
    let mut bar = Progress::new(&format!("simulating {}", file.name), a.t_end);
    let started = std::time::Instant::now();
    let (built, record) = simulate(
        built,
        a.t_end,
        a.dt,
        SimulationOptions::with_tolerances(a.rtol, a.atol),
        |t| bar.update(t),
    )
    .map_err(|e| CliError::run(file.model_error(e)))?;
    bar.finish();
    let wall = started.elapsed().as_secs_f64();
    let csv = a.out.join("sensors.csv");
    record.write_csv(&csv).map_err(CliError::run)?;
    let charts = record.plot(&a.out).map_err(CliError::run)?;
    let t_last = record.t.last().copied().unwrap_or(0.0);
    if a.json {
        #[derive(serde::Serialize)]
        struct Summary<'a> {
            model: &'a str,
            t_end_s: f64,
            samples: usize,
            wall_s: f64,
            completed: bool,
            sensors_csv: String,
            charts: Vec<String>,
            columns: &'a [(String, String)],
        }
        println!(
            "{}",
            json(&Summary {
                model: &file.name,
                t_end_s: t_last,
                samples: record.t.len(),
                wall_s: wall,
                completed: matches!(record.end, lash::multibody::RunEnd::Completed),
                sensors_csv: csv.display().to_string(),
                charts: charts.iter().map(|p| p.display().to_string()).collect(),
                columns: &record.columns,
            })
        );
    } else {
        println!(
            "{}: simulated 0 to {t_last} s ({} samples, {} bodies, {} sensor columns) in {wall:.2} s",
            file.name,
            record.t.len(),
            built.bodies.len(),
            record.columns.len()
        );
        if let lash::multibody::RunEnd::StoppedAtSingularity { t, measure, error } = &record.end {
            println!("  stopped at t = {t} s near a singular configuration (measure {measure:.2e}): {error}");
        }
        println!(
            "  wrote {} and {} charts in {}",
            csv.display(),
            charts.len(),
            a.out.display()
        );
    }
    Ok(Output::OK)
}
