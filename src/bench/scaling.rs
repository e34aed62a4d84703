//! `lash bench scaling`: cost per BDF step of a chain of N links with clearance universal
//! joints ([`clearance_chain`]) against N, and the fitted log-log slope. Sparse assembly and
//! factorisation should keep the per-step cost near O(N).

use crate::mechanisms::chain::{chain_design, clearance_chain};
use crate::multibody::Simulation;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// One chain length.
#[derive(Debug, Clone, Serialize)]
pub struct ScalingRow {
    /// Links.
    pub links: usize,
    /// Bodies (links and crosses).
    pub bodies: usize,
    /// DAE unknowns.
    pub unknowns: usize,
    /// Set-up time (model, initial state, pattern, symbolic analysis), s.
    pub setup_s: f64,
    /// Integration wall time, s.
    pub wall_s: f64,
    /// Accepted steps.
    pub steps: usize,
    /// LU factorisations.
    pub factorisations: usize,
    /// Of those, factorisations whose block elimination was redone equilibrated
    /// ([`Statistics::lu_equilibrated`](crate::dae::Statistics::lu_equilibrated)).
    pub lu_equilibrated: usize,
    /// Of those, factorisations that fell back to the plain sparse LU of the whole matrix
    /// ([`Statistics::lu_plain_fallbacks`](crate::dae::Statistics::lu_plain_fallbacks)).
    pub lu_plain_fallbacks: usize,
    /// Residual evaluations.
    pub residual_evals: usize,
    /// Wall time per step, s.
    pub per_step_s: f64,
    /// LU factorisations per accepted step.
    pub lu_per_step: f64,
    /// Resident memory of the process after the run, bytes (Linux; 0 elsewhere).
    pub resident_bytes: u64,
    /// Failure, if any.
    pub failure: Option<String>,
}

/// Longest chain the benchmark builds: each link takes 100–150 kB of memory in a run (1.06–1.45 GB
/// resident at N = 10 000 across the runs the README and its performance log quote), so 20 000
/// links need up to ~3 GB.
pub const MAX_LINKS: usize = 20_000;

/// Issue #16's target for the log-log slope of the time per step against N (N ≥ 100).
pub const TARGET_SLOPE_TIME: f64 = 1.1;
/// Issue #16's target for the log-log slope of the resident memory against N.
pub const TARGET_SLOPE_MEMORY: f64 = 1.0;

/// The scaling result.
#[derive(Debug, Clone, Serialize)]
pub struct Scaling {
    /// Simulated time per run, s.
    pub t_end: f64,
    /// Rows.
    pub rows: Vec<ScalingRow>,
    /// Least-squares slope of log(time per step) against log(N) over N ≥ 100 (all rows if
    /// fewer than two qualify).
    pub slope: f64,
    /// The same for memory.
    pub memory_slope: f64,
}

impl Scaling {
    /// The result as `lash bench scaling --json` prints it: every field, and the stable keys
    /// `slope_time` and `slope_memory` (the rows carry `lu_per_step`).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.insert("slope_time".into(), serde_json::json!(self.slope));
            o.insert("slope_memory".into(), serde_json::json!(self.memory_slope));
        }
        v
    }

    /// One line: each fitted slope against issue #16's target ([`TARGET_SLOPE_TIME`],
    /// [`TARGET_SLOPE_MEMORY`]), or "not measured" where fewer than two chain lengths ran
    /// (a single length has no slope, and no target is then called met or missed).
    pub fn slope_line(&self) -> String {
        let part = |name: &str, x: f64, target: f64| {
            if x.is_finite() {
                let verdict = if x <= target { "met" } else { "not met" };
                format!("{name} {x:.2} (target <= {target}: {verdict})")
            } else {
                format!("{name} not measured (needs two or more chain lengths that ran)")
            }
        };
        format!(
            "log-log slope against N (N >= 100 where two or more ran): {}; {}",
            part("time per step", self.slope, TARGET_SLOPE_TIME),
            part("memory", self.memory_slope, TARGET_SLOPE_MEMORY)
        )
    }
}

fn resident_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|v| v.parse::<u64>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// Least-squares slope of log y on log x.
pub fn log_slope(points: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.0 > 0.0 && p.1 > 0.0)
        .map(|p| (p.0.ln(), p.1.ln()))
        .collect();
    let n = pts.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    sxy / sxx
}

/// The chain's simulation settings: the MR2120 clearance runs' (`clearance_options`), without
/// singularity warnings.
pub fn chain_options() -> crate::multibody::SimulationOptions {
    let mut opts = crate::mechanisms::mr2120::trajectory::clearance_options();
    opts.singularity_warning = 0.0;
    opts
}

/// Runs each chain length for `t_end` seconds of simulated time. `progress` receives the
/// chain length about to run.
pub fn bench_scaling(lengths: &[usize], t_end: f64, mut progress: impl FnMut(usize)) -> Scaling {
    let mut rows = vec![];
    for &n in lengths {
        progress(n);
        let mut row = ScalingRow {
            links: n,
            bodies: 2 * n,
            unknowns: 0,
            setup_s: f64::NAN,
            wall_s: f64::NAN,
            steps: 0,
            factorisations: 0,
            lu_equilibrated: 0,
            lu_plain_fallbacks: 0,
            residual_evals: 0,
            per_step_s: f64::NAN,
            lu_per_step: f64::NAN,
            resident_bytes: 0,
            failure: None,
        };
        let start = Instant::now();
        let built = clearance_chain(n, &chain_design())
            .map_err(|e| e.to_string())
            .and_then(|m| Simulation::new(Arc::new(m), 0.0, chain_options()).map_err(|e| e.to_string()));
        row.setup_s = start.elapsed().as_secs_f64();
        match built {
            Ok(mut sim) => {
                row.unknowns = sim.layout().dim();
                let t0 = Instant::now();
                let res = sim.run(&[t_end], |_| {});
                row.wall_s = t0.elapsed().as_secs_f64();
                let st = *sim.stats();
                row.steps = st.steps;
                row.factorisations = st.lu_factorisations;
                row.lu_equilibrated = st.lu_equilibrated;
                row.lu_plain_fallbacks = st.lu_plain_fallbacks;
                row.residual_evals = st.residual_evals;
                row.per_step_s = row.wall_s / st.steps.max(1) as f64;
                row.lu_per_step = st.lu_factorisations as f64 / st.steps.max(1) as f64;
                row.resident_bytes = resident_bytes();
                if let Err(e) = res {
                    row.failure = Some(e.to_string());
                }
            }
            Err(e) => row.failure = Some(e),
        }
        rows.push(row);
    }
    let ok: Vec<&ScalingRow> = rows.iter().filter(|r| r.failure.is_none()).collect();
    let big: Vec<&ScalingRow> = ok.iter().copied().filter(|r| r.links >= 100).collect();
    let use_rows = if big.len() >= 2 { big } else { ok };
    let slope = log_slope(
        &use_rows
            .iter()
            .map(|r| (r.links as f64, r.per_step_s))
            .collect::<Vec<_>>(),
    );
    let memory_slope = log_slope(
        &use_rows
            .iter()
            .map(|r| (r.links as f64, r.resident_bytes as f64))
            .collect::<Vec<_>>(),
    );
    Scaling {
        t_end,
        rows,
        slope,
        memory_slope,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(links: usize, per_step_s: f64, resident_bytes: u64) -> ScalingRow {
        ScalingRow {
            links,
            bodies: 2 * links,
            unknowns: 28 * links,
            setup_s: 0.0,
            wall_s: per_step_s * 100.0,
            steps: 100,
            factorisations: 100,
            lu_equilibrated: 0,
            lu_plain_fallbacks: 0,
            residual_evals: 300,
            per_step_s,
            lu_per_step: 1.0,
            resident_bytes,
            failure: None,
        }
    }

    fn scaling(rows: Vec<ScalingRow>) -> Scaling {
        let pts =
            |f: &dyn Fn(&ScalingRow) -> f64| rows.iter().map(|r| (r.links as f64, f(r))).collect::<Vec<_>>();
        Scaling {
            t_end: 0.01,
            slope: log_slope(&pts(&|r| r.per_step_s)),
            memory_slope: log_slope(&pts(&|r| r.resident_bytes as f64)),
            rows,
        }
    }

    /// A run of one chain length fits no slope: the line says so instead of "NaN (not met)".
    #[test]
    fn one_length_reports_no_slope_and_no_verdict() {
        let line = scaling(vec![row(1000, 0.02, 100_000_000)]).slope_line();
        assert!(line.contains("time per step not measured"), "{line}");
        assert!(line.contains("memory not measured"), "{line}");
        assert!(!line.contains("NaN") && !line.contains("met)"), "{line}");
    }

    /// Two lengths: the slopes and their verdicts against the targets.
    #[test]
    fn two_lengths_report_slopes_against_the_targets() {
        // Time 12× for 10× the links (slope 1.08), memory 9× (0.95).
        let line = scaling(vec![row(100, 1e-3, 10_000_000), row(1000, 1.2e-2, 90_000_000)]).slope_line();
        assert!(line.contains("time per step 1.08 (target <= 1.1: met)"), "{line}");
        assert!(line.contains("memory 0.95 (target <= 1: met)"), "{line}");
        let slow = scaling(vec![row(100, 1e-3, 10_000_000), row(1000, 1.5e-2, 100_000_000)]).slope_line();
        assert!(
            slow.contains("time per step 1.18 (target <= 1.1: not met)"),
            "{slow}"
        );
    }
}
