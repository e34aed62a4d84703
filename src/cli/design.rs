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
        /// The region: poses by name (M1,M2,M3), a path through poses or 'x y z' positions
        /// in m (path:M1,M2), or a box of positions in m (box:xmin,xmax,ymin,ymax,zmin,zmax).
        #[arg(long, alias = "points", default_value = "M1,M2,M3")]
        region: String,
        /// Poses a leg of a path, or a side of a box.
        #[arg(long, default_value_t = 5)]
        samples: usize,
        /// Cost weight of an axial clearance against a radial one (cost = sum of weight / h).
        #[arg(long, default_value_t = 1.0)]
        axial_weight: f64,
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
    /// A worst-case error map over a horizontal slice of the work zone for one clearance
    /// set of Table 1: the largest platform position error over the static load cases at
    /// every cell by the first-order play bound, and on a coarser sub-grid by the nonlinear
    /// equilibria; heatmaps (PNG and SVG; cells outside the work zone and on singular loci
    /// marked), a CSV and --json. All cores.
    Map {
        /// Height of the slice z_M, m (M1: 0.5; the direct singularity M3: 0.2509).
        #[arg(long, default_value_t = 0.5)]
        z: f64,
        /// Half-width of the square slice around the z axis, m.
        #[arg(long, default_value_t = 0.25)]
        extent: f64,
        /// Cells per side.
        #[arg(long, default_value_t = 41)]
        n: usize,
        /// Clearance set (L1, L2, L3).
        #[arg(long, default_value = "L1")]
        set: String,
        /// Solve the nonlinear equilibria on every k-th cell in both directions (0: none).
        #[arg(long, default_value_t = 10)]
        nonlinear_every: usize,
        /// The inverse question: where does this accuracy hold for the set's clearances (as
        /// for `design clearance`, e.g. 0.2mm,0.5deg)? Adds map-accuracy.png/svg and
        /// `accuracy_region` to --json.
        #[arg(long)]
        accuracy: Option<String>,
        /// Compute only part K of N (0 <= K < N) and write it to OUT/part-K-of-N.json, for
        /// `lash design merge` (e.g. a Slurm job array: --shard $SLURM_ARRAY_TASK_ID/N).
        #[arg(long)]
        shard: Option<String>,
        /// Output folder (map.csv, heatmaps).
        #[arg(long, default_value = "out/design-map")]
        out: std::path::PathBuf,
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Calibrates the two bearing dimensions the paper does not give (ball radius and
    /// spacing) to its Table 3 by least squares on the static envelopes; prints the 54
    /// ranges' agreement before and after.
    Calibrate {
        /// Print the result as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Joins the parts of a sharded `design map` (files part-K-of-N.json) into the CSV,
    /// heatmaps and JSON an unsharded run writes.
    Merge {
        /// The part files.
        #[arg(required = true)]
        parts: Vec<std::path::PathBuf>,
        /// The inverse question, as for `design map --accuracy`.
        #[arg(long)]
        accuracy: Option<String>,
        /// Output folder.
        #[arg(long, default_value = "out/design-map")]
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
            region,
            samples,
            axial_weight,
            json,
        } => clearance(&accuracy, &region, samples, axial_weight, json),
        DesignWhat::Curve {
            accuracy,
            poses,
            out,
            json,
        } => curve(&accuracy, poses, &out, json),
        DesignWhat::Map {
            z,
            extent,
            n,
            set,
            nonlinear_every,
            accuracy,
            shard,
            out,
            json,
        } => map(
            z,
            extent,
            n,
            &set,
            nonlinear_every,
            accuracy.as_deref(),
            shard.as_deref(),
            &out,
            json,
        ),
        DesignWhat::Calibrate { json } => calibrate(json),
        DesignWhat::Merge {
            parts,
            accuracy,
            out,
            json,
        } => merge(&parts, accuracy.as_deref(), &out, json),
    }
}

/// Direct-kinematics singularity measure below which a map cell is dotted as near the
/// direct singularity (the measure is 0.70–0.76 over the slice through M1 and 0.03 on the
/// axis 9 mm above M3).
const NEAR_DIRECT_MARK: f64 = 0.1;

#[allow(clippy::too_many_arguments)]
fn map(
    z: f64,
    extent: f64,
    n: usize,
    set: &str,
    nonlinear_every: usize,
    accuracy: Option<&str>,
    shard: Option<&str>,
    out: &std::path::Path,
    as_json: bool,
) -> Result<Output, CliError> {
    use lash::design::{error_map, MapGrid, Shard};
    let accuracy = accuracy.map(parse_accuracy).transpose()?;
    let shard: Option<Shard> = shard
        .map(|s| s.parse().map_err(|e| CliError::Input(format!("--shard: {e}"))))
        .transpose()?;
    if !(extent > 0.0 && extent.is_finite()) {
        return Err(CliError::input(format!(
            "--extent must be positive, not {extent} m"
        )));
    }
    let cs = lash::mechanisms::mr2120::clearance::clearance_set(set).map_err(CliError::input)?;
    let grid = MapGrid {
        z,
        x: [-extent, extent],
        y: [-extent, extent],
        nx: n,
        ny: n,
        nonlinear_every,
    };
    if let Some(shard) = shard {
        return map_part(&grid, &cs, shard, out, as_json);
    }
    let started = std::time::Instant::now();
    let progress = std::sync::Mutex::new(Progress::new("design map", (n * n) as f64));
    let r = error_map(
        &Geometry::default(),
        &MassProperties::default(),
        &grid,
        &cs,
        |done, _| {
            if let Ok(mut p) = progress.lock() {
                p.update(done as f64);
            }
        },
    );
    if let Ok(p) = progress.lock() {
        p.finish();
    }
    let map = r.map_err(|e| match e {
        lash::design::DesignError::BadGrid(_) | lash::design::DesignError::OutsideWorkZone(_) => {
            CliError::input(e)
        }
        other => CliError::run(other),
    })?;
    let wall = started.elapsed().as_secs_f64();
    write_map(&map, accuracy, wall, out, as_json)
}

/// `design map --shard K/N`: one part, written to OUT/part-K-of-N.json.
fn map_part(
    grid: &lash::design::MapGrid,
    cs: &paper::ClearanceSet,
    shard: lash::design::Shard,
    out: &std::path::Path,
    as_json: bool,
) -> Result<Output, CliError> {
    let cells = grid.nx * grid.ny;
    let mine = shard.cells(grid).len();
    let progress = std::sync::Mutex::new(Progress::new("design map part", mine as f64));
    let part = lash::design::error_map_part(
        &Geometry::default(),
        &MassProperties::default(),
        grid,
        cs,
        shard,
        |done, _| {
            if let Ok(mut p) = progress.lock() {
                p.update(done as f64);
            }
        },
    );
    if let Ok(p) = progress.lock() {
        p.finish();
    }
    let part = part.map_err(|e| match e {
        lash::design::DesignError::BadGrid(_) | lash::design::DesignError::BadShard(_) => CliError::input(e),
        other => CliError::run(other),
    })?;
    std::fs::create_dir_all(out).map_err(|e| CliError::run(format!("{}: {e}", out.display())))?;
    let file = out.join(format!("part-{}-of-{}.json", shard.index, shard.count));
    std::fs::write(&file, serde_json::to_string(&part).map_err(CliError::run)?)
        .map_err(|e| CliError::run(format!("{}: {e}", file.display())))?;
    if as_json {
        println!(
            "{}",
            json(
                &serde_json::json!({"part": file, "shard": shard, "cells": part.cells.len(), "wall_s": part.wall_s})
            )
        );
    } else {
        println!(
            "part {}/{} of the map: {} of {cells} cells in {:.1} s, wrote {}",
            shard.index,
            shard.count,
            part.cells.len(),
            part.wall_s,
            file.display()
        );
    }
    Ok(Output::OK)
}

/// `design calibrate`.
fn calibrate(as_json: bool) -> Result<Output, CliError> {
    use lash::mechanisms::mr2120::accuracy::Excitation;
    let started = std::time::Instant::now();
    let progress = std::sync::Mutex::new(Progress::new("calibration", 1.0));
    let r = lash::design::calibration::calibrate(
        &Geometry::default(),
        &MassProperties::default(),
        &Excitation::default(),
        |k, n| {
            if let Ok(mut p) = progress.lock() {
                p.update(k as f64 / n as f64);
            }
        },
    );
    if let Ok(p) = progress.lock() {
        p.finish();
    }
    let r = r.map_err(CliError::run)?;
    let wall = started.elapsed().as_secs_f64();
    if as_json {
        println!("{}", json(&serde_json::json!({"calibration": r, "wall_s": wall})));
        return Ok(Output::OK);
    }
    let (b, a) = (&r.before, &r.after);
    println!(
        "bearing dimensions fitted to the paper's Table 3 (static envelopes; least squares on ln(lash / paper) of the range widths at M1 and M2, all 54 reported; {} evaluations, {wall:.1} s):",
        r.evaluations
    );
    println!(
        "  assumed: ball radius {:.2} mm, spacing {:.2} mm — {} of {} ranges within 3x of the paper's; RMS ln ratio {:.3} over all (typical factor {:.2}), {:.3} over M1 and M2 (fitted)",
        b.geometry.ball_radius * 1e3,
        b.geometry.ball_spacing * 1e3,
        b.within_3x,
        b.total,
        b.rms_log_ratio,
        b.rms_log_ratio.exp(),
        b.rms_log_ratio_fitted
    );
    println!(
        "  fitted:  ball radius {:.2} mm (± {:.0} %), spacing {:.2} mm (± {:.0} %), correlation {:.2} — {} of {} within 3x; RMS ln ratio {:.3} over all (typical factor {:.2}), {:.3} over M1 and M2",
        a.geometry.ball_radius * 1e3,
        r.relative_std_error.ball_radius * 100.0,
        a.geometry.ball_spacing * 1e3,
        r.relative_std_error.ball_spacing * 100.0,
        r.correlation,
        a.within_3x,
        a.total,
        a.rms_log_ratio,
        a.rms_log_ratio.exp(),
        a.rms_log_ratio_fitted
    );
    if r.at_bound {
        use lash::design::calibration::{RADIUS_BOUNDS, SPACING_BOUNDS};
        println!(
            "  the fit ends on a bound of the plausible range (radius {}-{} mm, spacing {}-{} mm): the paper's table pushes the dimensions out of it, so they are not what separates lash from the paper (no error bars at a bound)",
            RADIUS_BOUNDS[0] * 1e3,
            RADIUS_BOUNDS[1] * 1e3,
            SPACING_BOUNDS[0] * 1e3,
            SPACING_BOUNDS[1] * 1e3
        );
    }
    println!("  (fitted on M1 and M2, whose ranges a static envelope can be compared with; the error bars include the misfit: the fitted residual is a typical factor {:.2}, far above any measurement noise — two dimensions do not explain the paper's table, whose excitation is unknown)", a.rms_log_ratio_fitted.exp());
    println!(
        "{:<6} {:<4} {:<4} {:>12} {:>14} {:>14}",
        "point", "set", "", "paper", "lash assumed", "lash fitted"
    );
    for (x, y) in b.ranges.iter().zip(&a.ranges) {
        let unit = if x.component.starts_with('d') { "mm" } else { "deg" };
        println!(
            "{:<6} {:<4} {:<4} {:>9.4} {unit:<3} {:>8.4} ({:>4.2}) {:>8.4} ({:>4.2})",
            x.point,
            x.set,
            x.component,
            x.paper,
            x.lash,
            x.ratio(),
            y.lash,
            y.ratio()
        );
    }
    Ok(Output::OK)
}

/// `design merge`: the parts of a sharded map joined and written as an unsharded run would.
fn merge(
    parts: &[std::path::PathBuf],
    accuracy: Option<&str>,
    out: &std::path::Path,
    as_json: bool,
) -> Result<Output, CliError> {
    let accuracy = accuracy.map(parse_accuracy).transpose()?;
    let mut read = vec![];
    for p in parts {
        let text =
            std::fs::read_to_string(p).map_err(|e| CliError::Input(format!("{}: {e}", p.display())))?;
        let part: lash::design::MapPart = serde_json::from_str(&text).map_err(|e| {
            CliError::Input(format!(
                "{}:{}:{}: not a map part: {e}",
                p.display(),
                e.line(),
                e.column()
            ))
        })?;
        read.push(part);
    }
    let wall: f64 = read.iter().map(|p| p.wall_s).sum();
    let map = lash::design::merge_parts(&read).map_err(CliError::input)?;
    write_map(&map, accuracy, wall, out, as_json)
}

/// Writes a map's CSV, heatmaps and summary (or JSON): the same for an unsharded run and a
/// merged one.
fn write_map(
    map: &lash::design::ErrorMap,
    accuracy: Option<Accuracy>,
    wall: f64,
    out: &std::path::Path,
    as_json: bool,
) -> Result<Output, CliError> {
    use lash::design::CellKind;
    let grid = map.grid;
    let (n, ny, z, extent, nonlinear_every) = (grid.nx, grid.ny, grid.z, grid.x[1], grid.nonlinear_every);
    let (set_name, radial, axial) = (map.clearance.0.as_str(), map.clearance.1, map.clearance.2);
    std::fs::create_dir_all(out).map_err(|e| CliError::run(format!("{}: {e}", out.display())))?;
    // CSV: every cell.
    let mut csv = String::from(
        "x_mm,y_mm,kind,direct_measure,lin_dx_um,lin_dy_um,lin_dz_um,lin_rx_deg,lin_ry_deg,lin_rz_deg,nl_dx_um,nl_dy_um,nl_dz_um,nl_rx_deg,nl_ry_deg,nl_rz_deg\n",
    );
    let six = |e: Option<[f64; 6]>| -> String {
        match e {
            Some(e) => (0..6)
                .map(|k| {
                    if k < 3 {
                        format!("{}", e[k] * 1e6)
                    } else {
                        format!("{}", e[k].to_degrees())
                    }
                })
                .collect::<Vec<_>>()
                .join(","),
            None => ",,,,,".into(),
        }
    };
    for c in &map.cells {
        csv += &format!(
            "{},{},{},{},{},{}\n",
            c.x * 1e3,
            c.y * 1e3,
            serde_json::to_value(c.kind)
                .map(|v| v.as_str().unwrap_or("").to_string())
                .unwrap_or_default(),
            c.direct_measure.map(|m| m.to_string()).unwrap_or_default(),
            six(c.linear),
            six(c.nonlinear)
        );
    }
    std::fs::write(out.join("map.csv"), csv).map_err(|e| CliError::run(format!("{}: {e}", out.display())))?;
    // Heatmaps of the worst position error, µm.
    let markers = vec![
        ("outside the work zone".to_string(), (200, 200, 200)),
        (
            "no answer (singular, or no equilibrium found)".to_string(),
            (0, 0, 0),
        ),
    ];
    let heat = |which: &str,
                every: usize,
                value: &dyn Fn(&lash::design::MapCell) -> Option<[f64; 6]>,
                scalar: &dyn Fn(&[f64; 6]) -> f64,
                value_label: &str| {
        let (is, ks): (Vec<usize>, Vec<usize>) = (
            (0..n).step_by(every.max(1)).collect(),
            (0..ny).step_by(every.max(1)).collect(),
        );
        let values = ks
            .iter()
            .flat_map(|&k| is.iter().map(move |&i| (i, k)))
            .map(|(i, k)| {
                let c = map.cell(i, k);
                match (c.kind, value(c)) {
                    (_, Some(e)) => Ok(scalar(&e)),
                    (CellKind::Unreachable, None) => Err(0),
                    (CellKind::Singular, None) => Err(1),
                    (CellKind::Regular, None) => Err(1),
                }
            })
            .collect();
        lash::plot::Heatmap {
            title: format!(
                "MR2120 at z_M = {} mm, clearance set {}: {which}",
                z * 1e3,
                set_name
            ),
            x_label: "x_M, mm".into(),
            y_label: "y_M, mm".into(),
            value_label: value_label.into(),
            xs: is.iter().map(|&i| grid.x_at(i) * 1e3).collect(),
            ys: ks.iter().map(|&k| grid.y_at(k) * 1e3).collect(),
            values,
            markers: markers.clone(),
            dots: (
                format!("near the direct singularity (measure < {NEAR_DIRECT_MARK})"),
                ks.iter()
                    .flat_map(|&k| is.iter().map(move |&i| (i, k)))
                    .filter(|&(i, k)| {
                        map.cell(i, k)
                            .direct_measure
                            .is_some_and(|m| m < NEAR_DIRECT_MARK)
                    })
                    .map(|(i, k)| (grid.x_at(i) * 1e3, grid.y_at(k) * 1e3))
                    .collect(),
            ),
        }
    };
    let um = |e: &[f64; 6]| lash::design::map::worst_position(e) * 1e6;
    let d_label = "largest |d_x|, |d_y|, |d_z|, um";
    heat(
        "worst |d| over the load cases (first order)",
        1,
        &|c| c.linear,
        &um,
        d_label,
    )
    .save(&out.join("map-first-order"))
    .map_err(CliError::run)?;
    if nonlinear_every > 0 {
        heat(
            "worst |d| over the load cases (nonlinear equilibria)",
            nonlinear_every,
            &|c| c.nonlinear,
            &um,
            d_label,
        )
        .save(&out.join("map-nonlinear"))
        .map_err(CliError::run)?;
    }
    let region = accuracy.map(|a| map.where_accuracy_holds(&a));
    if let Some(a) = accuracy {
        let which = format!(
            "where |d| <= {} mm and |delta| <= {} deg hold (first order; <= 1 holds)",
            a.position * 1e3,
            a.rotation.to_degrees()
        );
        heat(
            &which,
            1,
            &|c| c.linear,
            &|e| lash::design::map::accuracy_ratio(e, &a),
            "worst error / required accuracy",
        )
        .save(&out.join("map-accuracy"))
        .map_err(CliError::run)?;
    }
    let count = |k: CellKind| map.cells.iter().filter(|c| c.kind == k).count();
    if as_json {
        let linear: Vec<_> = map
            .cells
            .iter()
            .filter_map(|c| {
                c.linear
                    .map(|e| serde_json::json!({"x": c.x, "y": c.y, "errors": e}))
            })
            .collect();
        let nonlinear: Vec<_> = map
            .cells
            .iter()
            .filter_map(|c| {
                c.nonlinear
                    .map(|e| serde_json::json!({"x": c.x, "y": c.y, "errors": e}))
            })
            .collect();
        println!(
            "{}",
            json(&serde_json::json!({
                "grid": map.grid,
                "clearance": {"set": set_name, "radial_m": radial, "axial_m": axial},
                "cells": map.cells,
                "linear": linear,
                "nonlinear": nonlinear,
                "max_disagreement": map.max_disagreement,
                "accuracy_region": region,
                "wall_s": wall,
            }))
        );
        return Ok(Output::OK);
    }
    println!(
        "MR2120 error map at z_M = {} mm, clearance set {} ({} um radial, {} um axial): {n} x {ny} cells over x, y in [{}, {}] mm, {:.1} s",
        z * 1e3,
        set_name,
        radial * 1e6,
        axial * 1e6,
        -extent * 1e3,
        extent * 1e3,
        wall
    );
    println!(
        "  {} regular, {} singular (no first-order answer), {} outside the work zone",
        count(CellKind::Regular),
        count(CellKind::Singular),
        count(CellKind::Unreachable)
    );
    let range = |f: &dyn Fn(&lash::design::MapCell) -> Option<[f64; 6]>| {
        let v: Vec<f64> = map
            .cells
            .iter()
            .filter_map(|c| f(c).map(|e| lash::design::map::worst_position(&e) * 1e6))
            .collect();
        (
            v.iter().copied().fold(f64::INFINITY, f64::min),
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            v.len(),
        )
    };
    let (a, b, k) = range(&|c| c.linear);
    println!("  first order: worst |d| {a:.2} to {b:.2} um over {k} cells");
    if nonlinear_every > 0 {
        let (a, b, k) = range(&|c| c.nonlinear);
        println!("  nonlinear equilibria (every {nonlinear_every}th cell): worst |d| {a:.2} to {b:.2} um over {k} cells");
    }
    match map.max_disagreement {
        Some(d) => println!(
            "  the methods part most at x = {:.1} mm, y = {:.1} mm: {:.2} um ({:.0} % of the nonlinear value)",
            d.at[0] * 1e3,
            d.at[1] * 1e3,
            d.position_m * 1e6,
            d.relative * 100.0
        ),
        None => println!("  no cell has both methods"),
    }
    if let Some(r) = region {
        let pct = |a: usize, b: usize| 100.0 * a as f64 / b.max(1) as f64;
        println!(
            "  |d| <= {} mm and |delta| <= {} deg hold at first order in {} of {} cells inside the work zone ({:.1} %; {} singular cells without an answer); by the equilibria in {} of {} cells ({:.1} %); the methods disagree at {} cells",
            r.accuracy.position * 1e3,
            r.accuracy.rotation.to_degrees(),
            r.holds_first_order,
            r.reachable,
            pct(r.holds_first_order, r.reachable),
            r.singular,
            r.holds_nonlinear,
            r.nonlinear_cells,
            pct(r.holds_nonlinear, r.nonlinear_cells),
            r.methods_disagree
        );
    }
    println!(
        "  wrote {0}/map.csv, {0}/map-first-order.png (.svg){1}{2}",
        out.display(),
        if nonlinear_every > 0 {
            ", map-nonlinear.png (.svg)"
        } else {
            ""
        },
        if region.is_some() {
            ", map-accuracy.png (.svg)"
        } else {
            ""
        }
    );
    Ok(Output::OK)
}

fn clearance(
    accuracy: &str,
    region: &str,
    samples: usize,
    axial_weight: f64,
    as_json: bool,
) -> Result<Output, CliError> {
    use lash::design::{allocate, CostModel, DesignError, Grouping, Region};
    let acc = parse_accuracy(accuracy)?;
    let (position, rotation) = (acc.position, acc.rotation);
    let (g, mp) = (Geometry::default(), MassProperties::default());
    let input_or_run = |e: DesignError| match e {
        DesignError::BadAccuracy { .. }
        | DesignError::BadRegion(_)
        | DesignError::BadCost(_)
        | DesignError::OutsideWorkZone(_) => CliError::input(e),
        other => CliError::run(other),
    };
    let region: Region = region
        .parse()
        .map_err(|e| CliError::Input(format!("--region: {e}")))?;
    let sampled = region.poses(&g, samples).map_err(input_or_run)?;
    let pts = &sampled.poses;
    if !(axial_weight > 0.0 && axial_weight.is_finite()) {
        return Err(CliError::input(format!(
            "--axial-weight must be positive and finite, not {axial_weight}"
        )));
    }
    let progress = std::sync::Mutex::new(Progress::new("design clearance", pts.len() as f64));
    let r = allowable_uniform(&g, &mp, pts, acc, |k, _| {
        if let Ok(mut p) = progress.lock() {
            p.update(k as f64)
        }
    });
    if let Ok(p) = progress.lock() {
        p.finish()
    }
    let r = r.map_err(input_or_run)?;
    let cost = CostModel {
        radial: [1.0; 6],
        axial: [axial_weight; 6],
    };
    let progress = std::sync::Mutex::new(Progress::new("clearance allocation", 1.0));
    let design = allocate(&g, &mp, pts, acc, cost, |k, n| {
        if let Ok(mut p) = progress.lock() {
            p.update(k as f64 / n as f64)
        }
    });
    if let Ok(p) = progress.lock() {
        p.finish()
    }
    // A singular pose leaves the allocation without a first order: said, not an error.
    let (design, allocation_note) = match design {
        Ok(d) => (Some(d), None),
        Err(e @ (DesignError::SingularPose { .. } | DesignError::NoClearanceAllowable { .. })) => {
            (None, Some(e.to_string()))
        }
        Err(e) => return Err(input_or_run(e)),
    };
    let per_point_verified = r.iter().all(|p| p.verified);
    // The uniform answer over all poses: the smallest nonlinear h, none if any pose has none.
    let uniform: Option<f64> = r
        .iter()
        .map(|p| p.nonlinear_h)
        .try_fold(f64::INFINITY, |m, h| h.map(|h| m.min(h)));
    let per_joint = design.as_ref().and_then(|d| d.get(Grouping::PerJoint)).cloned();
    let uniform_cost = design
        .as_ref()
        .and_then(|d| d.get(Grouping::Uniform))
        .and_then(|a| a.cost);
    let verified = per_point_verified && per_joint.as_ref().is_none_or(|a| a.verified);
    if as_json {
        let joints = per_joint.as_ref().and_then(|a| a.clearances).map(|h| {
            lash::design::allocation::JOINTS
                .iter()
                .enumerate()
                .map(
                    |(k, name)| serde_json::json!({ "joint": name, "h_lr": h.radial[k], "h_lw": h.axial[k] }),
                )
                .collect::<Vec<_>>()
        });
        let out = serde_json::json!({
            "accuracy": { "position_m": position, "rotation_rad": rotation },
            "region": { "poses": pts.len(), "unreachable": sampled.unreachable },
            "uniform": {
                "h_lr": uniform,
                "h_lw": uniform,
            },
            "per_point": r,
            "per_joint": per_joint.as_ref().map(|a| serde_json::json!({
                "joints": joints,
                "cost_per_m": a.cost,
                "relative_cost": a.cost.zip(uniform_cost).map(|(c, u)| c / u),
                "scale": a.scale,
                "verified": a.verified,
                "limiting": a.limiting,
            })),
            "allocation": design,
            "allocation_note": allocation_note,
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
    if sampled.unreachable > 0 {
        println!(
            "({} poses of the region lie outside the work zone and are left out)",
            sampled.unreachable
        );
    }
    println!(
        "{:<26} {:>16} {:>8} {:>18} {:>10}   largest errors there (mm, deg)",
        "pose (x, y, z mm)", "first order um", "limit", "nonlinear um", "verified"
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
        let name = if p.point == "region" {
            format!("{:.1} {:.1} {:.1}", p.m[0] * 1e3, p.m[1] * 1e3, p.m[2] * 1e3)
        } else {
            p.point.clone()
        };
        println!(
            "{:<26} {:>16} {:>8} {:>18} {:>10}   d {:.4} {:.4} {:.4}  delta {:.4} {:.4} {:.4}",
            name,
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
            if per_point_verified { "yes" } else { "no" }
        ),
    }
    println!();
    match (&design, &allocation_note) {
        (Some(d), _) => print_allocation(d, axial_weight),
        (None, Some(note)) => println!("no per-joint allocation: {note}"),
        (None, None) => {}
    }
    Ok(Output::OK)
}

/// The allocation table of `design clearance`.
fn print_allocation(d: &lash::design::RegionDesign, axial_weight: f64) {
    use lash::design::Grouping;
    println!(
        "allocation over the region's {} poses, cost = sum of 1/h_LR + {axial_weight}/h_LW (1/m): first order with the joints' contributions added in absolute value (conservative), then scaled until the 63-DOF equilibria verify it at every pose:",
        d.poses
    );
    let uniform_cost = d.get(Grouping::Uniform).and_then(|a| a.cost);
    println!(
        "{:<14} {:<6} {:>12} {:>12} {:>8} {:>12} {:>10} {:>9}   limiting",
        "design", "joint", "h_LR um", "h_LW um", "scale", "cost 1/m", "vs uniform", "verified"
    );
    for a in &d.allocations {
        let name = match a.grouping {
            Grouping::Uniform => "uniform",
            Grouping::PerDirection => "per direction",
            Grouping::PerJoint => "per joint",
        };
        let h = a.clearances.unwrap_or(a.first_order);
        let rows: Vec<usize> = if a.grouping == Grouping::PerJoint {
            (0..6).collect()
        } else {
            vec![0]
        };
        for (i, k) in rows.into_iter().enumerate() {
            let joint = if a.grouping == Grouping::PerJoint {
                lash::design::allocation::JOINTS[k]
            } else {
                "all"
            };
            if i == 0 {
                let limiting = a
                    .limiting
                    .map(|l| {
                        let v = if l.component.starts_with('d') {
                            format!("{:.4} mm", l.value * 1e3)
                        } else {
                            format!("{:.4} deg", l.value.to_degrees())
                        };
                        format!(
                            "{} = {v} at ({:.1}, {:.1}, {:.1}) mm",
                            l.component,
                            l.m[0] * 1e3,
                            l.m[1] * 1e3,
                            l.m[2] * 1e3
                        )
                    })
                    .unwrap_or_default();
                println!(
                    "{:<14} {:<6} {:>12.3} {:>12.3} {:>8} {:>12} {:>10} {:>9}   {}",
                    name,
                    joint,
                    h.radial[k] * 1e6,
                    h.axial[k] * 1e6,
                    a.scale
                        .map(|s| format!("{s:.3}"))
                        .unwrap_or_else(|| "none".into()),
                    a.cost.map(|c| format!("{c:.4e}")).unwrap_or_else(|| "-".into()),
                    a.cost
                        .zip(uniform_cost)
                        .map(|(c, u)| format!("{:.3}", c / u))
                        .unwrap_or_else(|| "-".into()),
                    if a.verified { "yes" } else { "no" },
                    limiting
                );
            } else {
                println!(
                    "{:<14} {:<6} {:>12.3} {:>12.3}",
                    "",
                    joint,
                    h.radial[k] * 1e6,
                    h.axial[k] * 1e6
                );
            }
        }
    }
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
