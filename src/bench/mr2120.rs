//! `lash bench mr2120`: the 63-DOF MR2120 clearance model along the 4 s trajectory, lash's BDF
//! against explicit Dormand–Prince, at equal accuracy, measured in one run.
//!
//! Accuracy is the largest distance of the platform centre from a tight-tolerance reference
//! over the output samples. Each solver runs over a sweep of tolerances (a work-precision
//! curve); for each, the cheapest setting that reaches the target accuracy is the one compared.
//! The BDF integrates the GGL index-2 DAE ([`MultibodyDae`](crate::multibody::MultibodyDae));
//! Dormand–Prince integrates the index-1 ODE with Baumgarte stabilisation
//! ([`MultibodyOde`]), the formulation explicit multibody codes step. Both start from the
//! same consistent initial state.

use crate::contact::Damping;
use crate::dae::explicit::{Dopri5, Dopri5Options};
use crate::mechanisms::mr2120::clearance::{bearing_design, clearance_model, clearance_set};
use crate::mechanisms::mr2120::paper::TABLE2;
use crate::mechanisms::mr2120::trajectory::{clearance_options, drive_laws};
use crate::mechanisms::mr2120::{Geometry, MassProperties, Mr2120Error};
use crate::multibody::{Analysis, Mechanism, MultibodyOde, Simulation, SimulationOptions};
use nalgebra::Vector3;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// Why the MR2120 benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The model could not be built.
    #[error(transparent)]
    Model(#[from] Mr2120Error),
    /// The tight-tolerance reference run failed, so no accuracy can be measured.
    #[error("the reference run failed: {0}")]
    Reference(String),
}

/// Settings of the MR2120 benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct Mr2120BenchOptions {
    /// Clearance set (L1, L2, L3).
    pub set: String,
    /// End of the trajectory, s (the paper's trajectory ends at 4 s).
    pub t_end: f64,
    /// Interval of the output samples at which accuracy is measured, s.
    pub dt: f64,
    /// Target accuracy: largest platform-centre distance from the reference, m.
    pub target: f64,
    /// Relative tolerance of the reference run (lash BDF; atol = rtol/100 m).
    pub reference_rtol: f64,
    /// Relative tolerances swept for lash's BDF (atol = rtol/100).
    pub bdf_rtols: Vec<f64>,
    /// Relative tolerances swept for Dormand–Prince (atol = rtol/100).
    pub dopri_rtols: Vec<f64>,
    /// Also check the reference with Dormand–Prince at this tolerance (None: skip).
    pub reference_check_rtol: Option<f64>,
    /// Contact damping of the bearings (see [`BENCH_DAMPING`]).
    pub damping: Damping,
    /// Wall-time budget of each explicit run, s: a run that exhausts it stops and reports
    /// how far it got, and the time ratio becomes a lower bound.
    pub explicit_budget_s: f64,
}

/// Contact damping of the benchmark: Hunt–Crossley α = 300 s/m (lubricated steel joints;
/// impacts above ~5 mm/s are fully damped). With the studies' near-elastic default
/// ([`DEFAULT_DAMPING`](crate::mechanisms::mr2120::clearance::DEFAULT_DAMPING), α = 1 s/m) the 63-DOF model rattles inside its clearances for the
/// whole run and the motion is chaotic: BDF runs at rtol 1e-4, 1e-5 and 1e-6 differ from each
/// other by 20–40 µm at every time (measured over the first second), so no run is within 1 µm
/// of any "reference" and equal-accuracy timing has no meaning. With α = 300 s/m runs at
/// 1e-5 and 1e-6 agree to ~1 µm.
pub const BENCH_DAMPING: Damping = Damping::HuntCrossley(300.0);

impl Default for Mr2120BenchOptions {
    fn default() -> Self {
        Self {
            set: "L1".into(),
            t_end: 4.0,
            dt: 0.01,
            target: 1e-6,
            reference_rtol: 1e-8,
            bdf_rtols: vec![1e-4, 1e-5, 1e-6, 1e-7],
            dopri_rtols: vec![1e-5],
            reference_check_rtol: None,
            damping: BENCH_DAMPING,
            explicit_budget_s: 600.0,
        }
    }
}

/// One run of one solver at one setting.
#[derive(Debug, Clone, Serialize)]
pub struct WorkPoint {
    /// Solver name.
    pub solver: String,
    /// Relative tolerance (atol = rtol/100).
    pub rtol: f64,
    /// Largest platform-centre distance from the reference over the samples, m.
    pub error: f64,
    /// Accepted steps.
    pub steps: usize,
    /// Rejected steps (error test and, for the BDF, Newton failures).
    pub rejected: usize,
    /// Residual or right-hand-side evaluations.
    pub rhs_evals: usize,
    /// Newton iterations (0 for explicit methods).
    pub newton_iters: usize,
    /// LU factorisations (0 for explicit methods).
    pub factorisations: usize,
    /// Wall time including set-up, s.
    pub wall_s: f64,
    /// Simulated time reached, s (the trajectory end unless the run failed or ran out of
    /// its wall-time budget).
    pub reached_t: f64,
    /// Failure message, if the run failed.
    pub failure: Option<String>,
    /// True if the run stopped because it exhausted its wall-time budget.
    pub out_of_budget: bool,
    /// Largest distance from the reference over each window (t0, t1, error m).
    pub error_windows: Vec<(f64, f64, f64)>,
    /// Largest distance from the reference up to the agreement horizon, m.
    pub error_to_horizon: f64,
    /// Wall time to reach the agreement horizon, s.
    pub wall_to_horizon_s: f64,
}

/// The comparison at equal accuracy.
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// Solver name.
    pub solver: String,
    /// The cheapest work point that meets the target, if any.
    pub chosen: Option<WorkPoint>,
    /// Wall time to the horizon / lash's (NaN if either did not meet the target).
    pub time_ratio: f64,
    /// If the solver ran out of its wall-time budget before reaching the horizon: its budget /
    /// lash's wall time to the horizon, a lower bound of the time ratio.
    pub time_ratio_at_least: Option<f64>,
    /// Steps / lash's steps (whole runs).
    pub steps_ratio: f64,
}

/// Result of the MR2120 benchmark.
#[derive(Debug, Clone, Serialize)]
pub struct Mr2120Bench {
    /// Clearance set.
    pub set: String,
    /// Trajectory end, s.
    pub t_end: f64,
    /// Target accuracy, m.
    pub target: f64,
    /// The reference run (its error field is 0 by definition).
    pub reference: WorkPoint,
    /// Time up to which the reference and an independent run (the tightest Dormand–Prince
    /// of the sweep: another formulation and integrator) agree within the target, s. Past it
    /// the motion near the direct-kinematics singularity is too sensitive for any solver to be
    /// checked to the target: accuracy is compared up to here.
    pub horizon_s: f64,
    /// Distance between the reference and the Dormand–Prince check run, m (None if skipped).
    pub reference_check: Option<f64>,
    /// Every run of the sweep.
    pub points: Vec<WorkPoint>,
    /// Per solver, the cheapest setting at the target accuracy, with ratios to lash's BDF.
    pub comparison: Vec<Comparison>,
}

struct Model {
    mech: Arc<Mechanism>,
    platform: usize,
    times: Vec<f64>,
}

fn build(opts: &Mr2120BenchOptions) -> Result<Model, Mr2120Error> {
    let g = Geometry::default();
    let mp = MassProperties::default();
    let set = clearance_set(&opts.set)?;
    let m1 = Vector3::from(TABLE2[0].m);
    let model = clearance_model(
        &g,
        &mp,
        m1,
        Some(drive_laws(&g)),
        &bearing_design(&set, opts.damping),
    )?;
    let n = (opts.t_end / opts.dt).round() as usize;
    Ok(Model {
        platform: model.platform.index(),
        mech: Arc::new(model.mechanism),
        times: (1..=n).map(|k| k as f64 * opts.dt).collect(),
    })
}

type Path = Vec<[f64; 3]>;

/// A run's platform path and the wall time at each sample.
struct Traced {
    path: Path,
    wall_at: Vec<f64>,
}

fn point(solver: &str, rtol: f64) -> WorkPoint {
    WorkPoint {
        solver: solver.into(),
        rtol,
        error: f64::NAN,
        steps: 0,
        rejected: 0,
        rhs_evals: 0,
        newton_iters: 0,
        factorisations: 0,
        wall_s: f64::NAN,
        reached_t: 0.0,
        failure: None,
        out_of_budget: false,
        error_windows: vec![],
        error_to_horizon: f64::NAN,
        wall_to_horizon_s: f64::NAN,
    }
}

fn run_bdf(m: &Model, rtol: f64, progress: &mut dyn FnMut(f64)) -> (WorkPoint, Option<Traced>) {
    let mut wp = point("lash BDF (GGL index 2)", rtol);
    let start = Instant::now();
    let opts = SimulationOptions {
        rtol,
        atol: rtol / 100.0,
        // The singularity watch is not part of the integration cost.
        singularity_warning: 0.0,
        ..clearance_options()
    };
    let res = Simulation::new(m.mech.clone(), 0.0, opts).and_then(|mut sim| {
        let mut walls = Vec::with_capacity(m.times.len());
        let tr = sim.run(&m.times, |t| {
            walls.push(start.elapsed().as_secs_f64());
            progress(t)
        })?;
        Ok((tr, *sim.stats(), walls))
    });
    wp.wall_s = start.elapsed().as_secs_f64();
    match res {
        Ok((tr, st, wall_at)) if tr.samples.len() == m.times.len() => {
            wp.reached_t = tr.samples.last().map_or(0.0, |s| s.t);
            wp.steps = st.steps;
            wp.rejected = st.error_test_failures + st.newton_failures;
            wp.rhs_evals = st.residual_evals;
            wp.newton_iters = st.newton_iters;
            wp.factorisations = st.lu_factorisations;
            let p = m.platform;
            let path = tr
                .samples
                .iter()
                .map(|s| [s.q[7 * p], s.q[7 * p + 1], s.q[7 * p + 2]])
                .collect();
            (wp, Some(Traced { path, wall_at }))
        }
        Ok((tr, _, _)) => {
            wp.failure = Some(format!(
                "stopped at t = {:.3} s: {:?}",
                tr.samples.last().map_or(0.0, |s| s.t),
                tr.end
            ));
            (wp, None)
        }
        Err(e) => {
            wp.failure = Some(e.to_string());
            (wp, None)
        }
    }
}

fn run_dopri(
    m: &Model,
    rtol: f64,
    budget: f64,
    progress: &mut dyn FnMut(f64),
) -> (WorkPoint, Option<Traced>) {
    let mut wp = point("Dormand-Prince 5(4) (index 1 + Baumgarte)", rtol);
    let start = Instant::now();
    let mut over = false;
    let mut wall_at = Vec::with_capacity(m.times.len());
    let res = (|| -> Result<(Path, crate::dae::explicit::ExplicitStats), String> {
        let s0 = Analysis::new(m.mech.clone())
            .and_then(|mut a| a.initial_state(0.0))
            .map_err(|e| e.to_string())?;
        let ode = MultibodyOde::new(m.mech.clone()).map_err(|e| e.to_string())?;
        let y0: Vec<f64> = s0.q.iter().chain(&s0.w).copied().collect();
        let o = Dopri5Options {
            rtol,
            atol: rtol / 100.0,
            max_steps: 50_000_000,
            ..Default::default()
        };
        let mut dp = Dopri5::new(ode, 0.0, &y0, &[], o).map_err(|e| e.to_string())?;
        let p = m.platform;
        let mut path = Vec::with_capacity(m.times.len());
        for &t in &m.times {
            dp.solve_to(t).map_err(|e| e.to_string())?;
            let y = dp.y();
            path.push([y[7 * p], y[7 * p + 1], y[7 * p + 2]]);
            wall_at.push(start.elapsed().as_secs_f64());
            progress(t);
            if start.elapsed().as_secs_f64() > budget && t < m.times[m.times.len() - 1] {
                over = true;
                break;
            }
        }
        Ok((path, *dp.stats()))
    })();
    wp.wall_s = start.elapsed().as_secs_f64();
    match res {
        Ok((path, st)) => {
            wp.steps = st.steps;
            wp.rejected = st.rejected;
            wp.rhs_evals = st.rhs_evals;
            wp.reached_t = m.times[path.len().saturating_sub(1).min(m.times.len() - 1)];
            if over {
                wp.out_of_budget = true;
                wp.failure = Some(format!(
                    "wall-time budget of {budget:.0} s exhausted at t = {:.3} s",
                    wp.reached_t
                ));
            }
            (wp, Some(Traced { path, wall_at }))
        }
        Err(e) => {
            wp.failure = Some(e);
            (wp, None)
        }
    }
}

/// Largest distance over the samples both paths have.
fn distance(a: &Path, b: &Path) -> f64 {
    a.iter().zip(b).map(|(x, y)| dist(x, y)).fold(0.0, f64::max)
}

/// Runs the benchmark. `progress` receives (what is running, fraction of that run done).
pub fn bench_mr2120(
    opts: &Mr2120BenchOptions,
    mut progress: impl FnMut(&str, f64),
) -> Result<Mr2120Bench, BenchError> {
    let m = build(opts)?;
    let t_end = opts.t_end;
    let label = format!("reference: lash BDF rtol {:.0e}", opts.reference_rtol);
    let (mut reference, ref_path) = run_bdf(&m, opts.reference_rtol, &mut |t| progress(&label, t / t_end));
    let Some(ref_path) = ref_path else {
        return Err(BenchError::Reference(reference.failure.unwrap_or_default()));
    };
    reference.error = 0.0;
    let mut check: Option<Traced> = None;
    let reference_check = opts.reference_check_rtol.map(|rtol| {
        let label = format!("reference check: Dormand-Prince rtol {rtol:.0e}");
        let (_, path) = run_dopri(&m, rtol, opts.explicit_budget_s, &mut |t| {
            progress(&label, t / t_end)
        });
        let d = path
            .as_ref()
            .map_or(f64::NAN, |p| distance(&p.path, &ref_path.path));
        check = path;
        d
    });
    let mut points = vec![];
    let mut traces = vec![];
    for &rtol in &opts.bdf_rtols {
        let label = format!("lash BDF rtol {rtol:.0e}");
        let (wp, path) = run_bdf(&m, rtol, &mut |t| progress(&label, t / t_end));
        points.push(wp);
        traces.push(path);
    }
    for &rtol in &opts.dopri_rtols {
        let label = format!("Dormand-Prince rtol {rtol:.0e}");
        let (wp, path) = run_dopri(&m, rtol, opts.explicit_budget_s, &mut |t| {
            progress(&label, t / t_end)
        });
        points.push(wp);
        traces.push(path);
    }
    // The agreement horizon: as long as an independent run stays within the target.
    let independent = check.as_ref().or_else(|| {
        points
            .iter()
            .zip(&traces)
            .filter(|(p, t)| p.solver.starts_with("Dormand") && t.is_some())
            .min_by(|a, b| a.0.rtol.total_cmp(&b.0.rtol))
            .and_then(|(_, t)| t.as_ref())
    });
    let n_h = match independent {
        Some(c) => leading_within(&c.path, &ref_path.path, opts.target),
        None => m.times.len(),
    };
    let horizon_s = if n_h > 0 { m.times[n_h - 1] } else { 0.0 };
    let windows: Vec<(f64, f64)> = [(0.0f64, 1.0f64), (1.0, 2.0), (2.0, 3.0), (3.0, 3.5), (3.5, 4.0)]
        .into_iter()
        .filter(|w| w.0 < t_end)
        .map(|(a, b)| (a, b.min(t_end)))
        .collect();
    for (wp, tr) in points.iter_mut().zip(&traces) {
        let Some(tr) = tr else { continue };
        wp.error = distance(&tr.path, &ref_path.path);
        wp.error_windows = windows
            .iter()
            .map(|&(a, b)| {
                let e = (0..tr.path.len().min(ref_path.path.len()))
                    .filter(|&k| m.times[k] > a && m.times[k] <= b + 1e-12)
                    .map(|k| dist(&tr.path[k], &ref_path.path[k]))
                    .fold(f64::NAN, f64::max);
                (a, b, e)
            })
            .collect();
        if tr.path.len() >= n_h && n_h > 0 {
            wp.error_to_horizon = distance(&tr.path[..n_h].to_vec(), &ref_path.path[..n_h].to_vec());
            wp.wall_to_horizon_s = tr.wall_at[n_h - 1];
        }
    }
    let comparison = compare(&points, opts.target);
    Ok(Mr2120Bench {
        set: opts.set.clone(),
        t_end,
        target: opts.target,
        reference,
        horizon_s,
        reference_check,
        points,
        comparison,
    })
}

fn dist(x: &[f64; 3], y: &[f64; 3]) -> f64 {
    ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt()
}

/// Number of leading samples of `a` within `target` of `b`.
fn leading_within(a: &Path, b: &Path, target: f64) -> usize {
    a.iter().zip(b).take_while(|(x, y)| dist(x, y) <= target).count()
}

/// Per solver (in order of first appearance), the cheapest point within `target` up to the
/// agreement horizon (wall time to the horizon), with ratios to the first solver's choice.
pub fn compare(points: &[WorkPoint], target: f64) -> Vec<Comparison> {
    let mut solvers: Vec<&str> = vec![];
    for p in points {
        if !solvers.contains(&p.solver.as_str()) {
            solvers.push(&p.solver);
        }
    }
    let chosen: Vec<Option<WorkPoint>> = solvers
        .iter()
        .map(|s| {
            points
                .iter()
                .filter(|p| p.solver == *s && p.error_to_horizon <= target)
                .min_by(|a, b| a.wall_to_horizon_s.total_cmp(&b.wall_to_horizon_s))
                .cloned()
        })
        .collect();
    let base = chosen.first().cloned().flatten();
    solvers
        .iter()
        .zip(chosen)
        .map(|(s, c)| {
            let (tr, sr) = match (&c, &base) {
                (Some(c), Some(b)) => (
                    c.wall_to_horizon_s / b.wall_to_horizon_s,
                    c.steps as f64 / b.steps as f64,
                ),
                _ => (f64::NAN, f64::NAN),
            };
            let at_least = match (&c, &base) {
                (None, Some(b)) => points
                    .iter()
                    .filter(|p| p.solver == *s && p.out_of_budget && p.error_to_horizon.is_nan())
                    .map(|p| p.wall_s / b.wall_to_horizon_s)
                    .fold(None, |m: Option<f64>, v| Some(m.map_or(v, |m| m.min(v)))),
                _ => None,
            };
            Comparison {
                solver: s.to_string(),
                chosen: c,
                time_ratio: tr,
                steps_ratio: sr,
                time_ratio_at_least: at_least,
            }
        })
        .collect()
}
