//! The benchmarks' charts (log-log, PNG and SVG): the scaling of the clearance chain, the
//! work-precision diagrams of Andrews' squeezer and of the MR2120 trajectory. Each function
//! returns the line to print: where the chart went, or why it could not be written.

use super::mr2120::Mr2120Bench;
use super::scaling::Scaling;
use super::BenchRow;
use crate::plot::{LineChart, Series};
use std::path::Path;

/// Tolerances (rtol = atol) of the Andrews work-precision sweep.
pub const ANDREWS_TOLERANCES: [f64; 7] = [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9];

/// Writes a chart with logarithmic axes as `<dir>/<stem>.png` and `.svg`, creating `dir`;
/// returns the line to print (where it went, or why it could not be written).
pub fn save_log_log_chart(chart: &LineChart, dir: &Path, stem: &str, what: &str) -> String {
    if let Err(e) = std::fs::create_dir_all(dir) {
        return format!("could not create {}: {e}", dir.display());
    }
    let stem = dir.join(stem);
    match chart.save_log_log(&stem) {
        Ok(()) => format!("{what}: {}.png / .svg", stem.display()),
        Err(e) => format!("could not write the {what}: {e}"),
    }
}

/// Time per BDF step and resident memory against the chain length, as `dir/scaling`.
pub fn scaling_chart(s: &Scaling, dir: &Path) -> String {
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
    save_log_log_chart(&chart, dir, "scaling", "plot")
}

/// Andrews' work-precision diagram from the rows of
/// [`andrews_work_precision`](super::andrews_work_precision) (one line per solver, in
/// tolerance order), as `dir/andrews-work-precision`.
pub fn andrews_work_precision_chart(rows: &[BenchRow], dir: &Path) -> String {
    let mut solvers: Vec<String> = vec![];
    for r in rows {
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

/// The MR2120 benchmark's work-precision diagram (error to the agreement horizon against
/// wall time to it, one line per solver), as `dir/work-precision`.
pub fn mr2120_work_precision_chart(b: &Mr2120Bench, dir: &Path) -> String {
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
            "MR2120 {} trajectory to {} t = {:.2} s: work-precision",
            b.set,
            if b.horizon_s.is_some() {
                "the agreement horizon"
            } else {
                "the end (no independent check)"
            },
            b.compared_until()
        ),
        x_label: "wall time to the horizon [s]".into(),
        y_label: "largest platform-centre error vs reference [m]".into(),
        series,
        y_range: None,
    };
    save_log_log_chart(&chart, dir, "work-precision", "work-precision diagram")
}
