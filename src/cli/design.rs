//! `lash design`: clearance design for a required positioning accuracy.

use super::progress::Progress;
use super::{json, CliError, Output};
use lash::design::{allowable_uniform, Accuracy};
use lash::mechanisms::mr2120::geometry::{Geometry, MassProperties};
use lash::mechanisms::mr2120::paper;

/// The design studies.
#[derive(clap::Subcommand)]
pub enum DesignWhat {
    /// The largest uniform clearance (radial = axial, every universal joint of the MR2120)
    /// that keeps the platform within --accuracy at the given poses under the static load
    /// cases: first order and by the nonlinear equilibria (bisection), side by side.
    Clearance {
        /// Required accuracy: position with a unit (mm, um or m), optionally a rotation
        /// (deg or rad) after a comma, e.g. 0.1mm,0.05deg (rotation defaults to 1 deg).
        #[arg(long)]
        accuracy: String,
        /// Poses, comma-separated (M1, M2, M3).
        #[arg(long, default_value = "M1,M2,M3")]
        points: String,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// The allowable uniform clearance along the paper's path on the z axis, from M1 down
    /// towards the direct singularity M3, against the distance to M3: first order and
    /// nonlinear, a table and a chart (PNG and SVG).
    Curve {
        /// Required accuracy, as for `design clearance` (e.g. 0.2mm,0.5deg).
        #[arg(long)]
        accuracy: String,
        /// Number of poses, log-spaced in the distance to M3 from 1 mm to M1 (249.1 mm).
        #[arg(long, default_value_t = 10)]
        poses: usize,
        /// Output folder for the chart.
        #[arg(long, default_value = "out/design-curve")]
        out: std::path::PathBuf,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
}

/// A length or an angle with its unit, in SI (m or rad).
fn quantity(s: &str, what: &str) -> Result<f64, CliError> {
    let s = s.trim();
    let units: &[(&str, f64)] = match what {
        "position" => &[("mm", 1e-3), ("um", 1e-6), ("µm", 1e-6), ("m", 1.0)],
        _ => &[("deg", std::f64::consts::PI / 180.0), ("rad", 1.0)],
    };
    for (u, f) in units {
        if let Some(v) = s.strip_suffix(u) {
            return v
                .trim()
                .parse::<f64>()
                .map(|v| v * f)
                .map_err(|_| CliError::Input(format!("--accuracy: '{s}' is not a number with a unit")));
        }
    }
    let expected: Vec<&str> = units.iter().map(|(u, _)| *u).collect();
    Err(CliError::Input(format!(
        "--accuracy: '{s}' has no {what} unit (one of {})",
        expected.join(", ")
    )))
}

/// Runs one design study.
pub fn run(what: DesignWhat) -> Result<Output, CliError> {
    match what {
        DesignWhat::Clearance {
            accuracy,
            points,
            json,
        } => clearance(&accuracy, &points, json),
        DesignWhat::Curve {
            accuracy,
            poses,
            out,
            json,
        } => curve(&accuracy, poses, &out, json),
    }
}

fn clearance(accuracy: &str, points: &str, as_json: bool) -> Result<Output, CliError> {
    let acc = parse_accuracy(accuracy)?;
    let (position, rotation) = (acc.position, acc.rotation);
    let pts = super::mr2120_points(points)?;
    if pts.is_empty() {
        return Err(CliError::input("--points names no pose"));
    }
    let mut progress = Progress::new("design clearance", pts.len() as f64);
    let r = allowable_uniform(
        &Geometry::default(),
        &MassProperties::default(),
        &pts,
        acc,
        |k, _| progress.update(k as f64),
    );
    progress.finish();
    let r = r.map_err(|e| match e {
        lash::design::DesignError::BadAccuracy { .. } => CliError::input(e),
        other => CliError::run(other),
    })?;
    let verified = r.iter().all(|p| p.verified);
    // The uniform answer over all poses: the smallest nonlinear h, none if any pose has none.
    let uniform: Option<f64> = r
        .iter()
        .map(|p| p.nonlinear_h)
        .try_fold(f64::INFINITY, |m, h| h.map(|h| m.min(h)));
    if as_json {
        let out = serde_json::json!({
            "accuracy": { "position_m": position, "rotation_rad": rotation },
            "uniform": {
                "h_lr": uniform,
                "h_lw": uniform,
            },
            "per_point": r,
            "per_joint": serde_json::Value::Null,
            "verified": verified,
        });
        println!("{}", json(&out));
        return Ok(Output::OK);
    }
    println!(
        "allowable uniform clearance (radial = axial, all six universal joints) for |d| <= {:.4} mm and |delta| <= {:.4} deg under the static load cases (gravity; 10 N, 0.5 N m on the platform):",
        position * 1e3,
        rotation.to_degrees()
    );
    println!(
        "{:<4} {:>16} {:>8} {:>18} {:>10}   largest errors there (mm, deg)",
        "pose", "first order um", "limit", "nonlinear um", "verified"
    );
    for p in &r {
        let lin = p
            .linear_h
            .map(|h| format!("{:.3}", h * 1e6))
            .unwrap_or_else(|| "none (singular)".into());
        let nl = p
            .nonlinear_h
            .map(|h| format!("{:.3}", h * 1e6))
            .unwrap_or_else(|| "none".into());
        let e = &p.nonlinear_errors;
        println!(
            "{:<4} {:>16} {:>8} {:>18} {:>10}   d {:.4} {:.4} {:.4}  delta {:.4} {:.4} {:.4}",
            p.point,
            lin,
            p.linear_limit.as_deref().unwrap_or("-"),
            nl,
            if p.verified { "yes" } else { "no" },
            e[0] * 1e3,
            e[1] * 1e3,
            e[2] * 1e3,
            e[3].to_degrees(),
            e[4].to_degrees(),
            e[5].to_degrees()
        );
    }
    match uniform {
        None => println!("at a pose marked 'none' even 0.01 um of clearance breaks the accuracy: contact elasticity or the singular sag alone exceeds it"),
        Some(h) => println!(
            "uniform over these poses: h_LR = h_LW = {:.3} um (nonlinear, verified: {})",
            h * 1e6,
            if verified { "yes" } else { "no" }
        ),
    }
    Ok(Output::OK)
}

fn curve(accuracy: &str, poses: usize, out: &std::path::Path, as_json: bool) -> Result<Output, CliError> {
    let acc = parse_accuracy(accuracy)?;
    if poses < 2 {
        return Err(CliError::input("--poses must be at least 2"));
    }
    let far = paper::TABLE2[0].m[2] - paper::TABLE2[2].m[2];
    let near = 1e-3;
    let distances: Vec<f64> = (0..poses)
        .map(|k| near * (far / near).powf(k as f64 / (poses - 1) as f64))
        .collect();
    let mut progress = Progress::new("design curve", poses as f64);
    let r = lash::design::allowable_along(
        &Geometry::default(),
        &MassProperties::default(),
        &distances,
        acc,
        |k, _| progress.update(k as f64),
    );
    progress.finish();
    let r = r.map_err(CliError::run)?;
    {
        use lash::plot::{LineChart, Series};
        let pts = |f: &dyn Fn(&lash::design::CurvePoint) -> Option<f64>| -> Vec<(f64, f64)> {
            r.iter()
                .filter_map(|p| f(p).map(|h| (p.distance_to_m3 * 1e3, h * 1e6)))
                .collect()
        };
        let chart = LineChart {
            title: format!(
                "MR2120: allowable uniform clearance for |d| <= {:.3} mm, |delta| <= {:.3} deg",
                acc.position * 1e3,
                acc.rotation.to_degrees()
            ),
            x_label: "distance to the direct singularity M3 along z, mm".into(),
            y_label: "allowable clearance h_LR = h_LW, um".into(),
            series: vec![
                Series {
                    name: "nonlinear equilibria".into(),
                    points: pts(&|p| p.nonlinear_h),
                },
                Series {
                    name: "first order (play bound)".into(),
                    points: pts(&|p| p.linear_h),
                },
            ],
            y_range: None,
        };
        std::fs::create_dir_all(out).map_err(|e| CliError::run(format!("{}: {e}", out.display())))?;
        chart
            .save(&out.join("allowable-clearance"))
            .map_err(CliError::run)?;
        if !as_json {
            println!("chart: {}/allowable-clearance.png (.svg)", out.display());
        }
    }
    if as_json {
        println!("{}", json(&r));
        return Ok(Output::OK);
    }
    println!(
        "{:>12} {:>14} {:>16} {:>16}",
        "to M3, mm", "direct meas.", "first order um", "nonlinear um"
    );
    let um = |h: Option<f64>| {
        h.map(|h| format!("{:.3}", h * 1e6))
            .unwrap_or_else(|| "none".into())
    };
    for p in &r {
        println!(
            "{:>12.2} {:>14.2e} {:>16} {:>16}",
            p.distance_to_m3 * 1e3,
            p.direct_measure,
            um(p.linear_h),
            um(p.nonlinear_h)
        );
    }
    Ok(Output::OK)
}

/// `--accuracy`: a position with its unit and, after a comma, an optional rotation.
fn parse_accuracy(accuracy: &str) -> Result<Accuracy, CliError> {
    let mut parts = accuracy.split(',');
    let position = quantity(parts.next().unwrap_or(""), "position")?;
    let rotation = match parts.next() {
        Some(r) => quantity(r, "rotation")?,
        None => 1f64.to_radians(),
    };
    if parts.next().is_some() {
        return Err(CliError::input(
            "--accuracy takes a position and at most one rotation",
        ));
    }
    Ok(Accuracy { position, rotation })
}
