//! `lash design`: clearance design for a required positioning accuracy.

use super::progress::Progress;
use super::{items, json, CliError, Output};
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
    }
}

fn clearance(accuracy: &str, points: &str, as_json: bool) -> Result<Output, CliError> {
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
    let pts = items(points)
        .map(|n| {
            paper::TABLE2
                .iter()
                .find(|p| p.name.eq_ignore_ascii_case(n))
                .copied()
                .ok_or_else(|| {
                    CliError::Input(format!("--points: unknown point '{n}'; expected M1, M2 or M3"))
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    if pts.is_empty() {
        return Err(CliError::input("--points names no pose"));
    }
    let acc = Accuracy { position, rotation };
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
    let uniform = r
        .iter()
        .filter_map(|p| p.nonlinear_h)
        .fold(f64::INFINITY, f64::min);
    if as_json {
        let out = serde_json::json!({
            "accuracy": { "position_m": position, "rotation_rad": rotation },
            "uniform": {
                "h_lr": if uniform.is_finite() && r.iter().all(|p| p.nonlinear_h.is_some()) { Some(uniform) } else { None },
                "h_lw": if uniform.is_finite() && r.iter().all(|p| p.nonlinear_h.is_some()) { Some(uniform) } else { None },
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
    if r.iter().any(|p| p.nonlinear_h.is_none()) {
        println!("at a pose marked 'none' even 0.01 um of clearance breaks the accuracy: contact elasticity or the singular sag alone exceeds it");
    } else {
        println!(
            "uniform over these poses: h_LR = h_LW = {:.3} um (nonlinear, verified: {})",
            uniform * 1e6,
            if verified { "yes" } else { "no" }
        );
    }
    Ok(Output::OK)
}
