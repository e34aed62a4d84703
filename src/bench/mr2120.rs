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

pub use super::mr2120_options::{BenchError, Mr2120BenchOptions, BENCH_ALPHA, BENCH_DAMPING};
use crate::contact::Damping;
use crate::dae::explicit::{Dopri5, Dopri5Options, SymplecticEuler};
use crate::dae::{Integrator, IntegratorError, WorkStats};
use crate::mechanisms::mr2120::clearance::{bearing_design, clearance_model, clearance_set, ClearanceModel};
use crate::mechanisms::mr2120::paper::TABLE2;
use crate::mechanisms::mr2120::trajectory::{clearance_options, drive_laws};
use crate::mechanisms::mr2120::{Geometry, MassProperties, Mr2120Error};
use crate::multibody::{
    Analysis, BodyHandle, Layout, Mechanism, MechanismData, MultibodyOde, RunEnd, Simulation,
};
use nalgebra::Vector3;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;

/// One run of one solver at one setting.
#[derive(Debug, Clone, Serialize)]
pub struct WorkPoint {
    /// Solver name.
    pub solver: String,
    /// Relative tolerance (atol = rtol/100); NaN for a fixed-step method.
    pub rtol: f64,
    /// Fixed step size of a fixed-step method, s.
    pub step_size: Option<f64>,
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
    /// Where lash's BDF spent its time (its own timers; None for the other solvers).
    pub phase_times: Option<crate::dae::PhaseTimes>,
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

impl WorkPoint {
    /// The setting in a few characters: the tolerance, or the fixed step ("h 2e-6").
    pub fn setting(&self) -> String {
        match self.step_size {
            Some(h) => format!("h {h:.0e}"),
            None => format!("{:.0e}", self.rtol),
        }
    }
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
    /// The comparison at this solver's own best accuracy up to the horizon, for a solver that
    /// did not reach the target (equal accuracy at a looser level), if lash reached it too.
    pub at_own_accuracy: Option<OwnAccuracy>,
}

/// Equal accuracy at the level a peer reached: its most accurate run against lash's cheapest
/// run at least as accurate.
#[derive(Debug, Clone, Serialize)]
pub struct OwnAccuracy {
    /// The peer's best error up to the horizon, m.
    pub accuracy_m: f64,
    /// The peer's setting that reached it.
    pub setting: String,
    /// The peer's wall time to the horizon, s.
    pub wall_to_horizon_s: f64,
    /// lash's cheapest setting within that accuracy.
    pub lash_setting: String,
    /// lash's error up to the horizon, m.
    pub lash_error_m: f64,
    /// lash's wall time to the horizon, s.
    pub lash_wall_to_horizon_s: f64,
    /// Peer time / lash time.
    pub time_ratio: f64,
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
    /// Output times, s.
    pub times: Vec<f64>,
    /// Platform centre of the reference run at the output times, m.
    pub reference_path: Vec<[f64; 3]>,
    /// Time up to which the reference and an independent run (the reference check run, or
    /// else the tightest Dormand–Prince of the sweep: another formulation and integrator)
    /// agree within the target, s; `None` when this run made no independent run, and then
    /// nothing was checked against the reference. Past the horizon the motion near the
    /// direct-kinematics singularity is too sensitive for any solver to be checked to the
    /// target: accuracy is compared up to here, or over the whole run when it is `None`.
    pub horizon_s: Option<f64>,
    /// The independent run that measured the horizon (e.g. "Dormand-Prince rtol 1e-5"), or
    /// `None` when there was none.
    pub horizon_source: Option<String>,
    /// Distance between the reference and the Dormand–Prince check run, m (None if skipped).
    pub reference_check: Option<f64>,
    /// Every run of the sweep.
    pub points: Vec<WorkPoint>,
    /// Per solver, the cheapest setting at the target accuracy, with ratios to lash's BDF.
    pub comparison: Vec<Comparison>,
}

/// One run of the sweep in the benchmark's JSON summary (`runs`, see
/// [`Mr2120Bench::to_json`]).
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Solver name.
    pub solver: String,
    /// Its setting (tolerance or fixed step).
    pub setting: String,
    /// Wall time of the whole run, s.
    pub wall_s: f64,
    /// Accepted steps.
    pub steps: usize,
    /// LU factorisations.
    pub lu: usize,
    /// Largest distance from the reference up to the agreement horizon (the whole run when
    /// no horizon was measured), m.
    pub err_to_horizon: f64,
    /// Largest distance from the reference over the whole run, m.
    pub err_whole: f64,
}

impl Mr2120Bench {
    /// Every run of the sweep, summarised.
    pub fn runs(&self) -> Vec<RunSummary> {
        self.points
            .iter()
            .map(|p| RunSummary {
                solver: p.solver.clone(),
                setting: p.setting(),
                wall_s: p.wall_s,
                steps: p.steps,
                lu: p.factorisations,
                err_to_horizon: p.error_to_horizon,
                err_whole: p.error,
            })
            .collect()
    }

    /// The result as `lash bench mr2120 --json` prints it: every field, and the stable
    /// summary keys `horizon` (s, null when no independent run measured it),
    /// `horizon_source` and `runs` ([`RunSummary`] per solver and setting).
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).unwrap_or_default();
        if let Some(o) = v.as_object_mut() {
            o.insert("horizon".into(), serde_json::json!(self.horizon_s));
            o.insert(
                "runs".into(),
                serde_json::to_value(self.runs()).unwrap_or_default(),
            );
        }
        v
    }

    /// End of the interval every accuracy figure "to the horizon" holds over, s: the
    /// agreement horizon when an independent run measured it, else the whole run.
    pub fn compared_until(&self) -> f64 {
        self.horizon_s.unwrap_or(self.t_end)
    }

    /// One sentence on the agreement horizon that says only what this run measured.
    pub fn horizon_statement(&self) -> String {
        match (&self.horizon_s, &self.horizon_source) {
            (Some(h), Some(src)) => format!(
                "agreement horizon: the reference and the independent run ({src}) agree within {:.0e} m up to t = {h:.2} s",
                self.target
            ),
            _ => format!(
                "agreement horizon: no independent check in this run (no Dormand-Prince run); accuracies are distances from the reference over the whole run, t = 0 to {:.2} s, and nothing checked the reference itself",
                self.t_end
            ),
        }
    }
}

pub(crate) struct Model {
    pub(crate) mech: Arc<Mechanism>,
    pub(crate) platform: BodyHandle,
    /// Body indices of the three driven arms.
    pub(crate) arms: [usize; 3],
    pub(crate) times: Vec<f64>,
}

/// The benchmark's mechanism: the 63-DOF MR2120 clearance model of clearance set `set` (`L1`,
/// `L2` or `L3`, the paper's Table 1), assembled at M1 and driven along the paper's trajectory,
/// its bearings damped by `damping` (`lash bench mr2120` uses [`BENCH_DAMPING`]). The one
/// place the benchmark, the criterion bench and `examples/l1_run.rs` build it.
pub fn bench_mechanism(set: &str, damping: Damping) -> Result<ClearanceModel, Mr2120Error> {
    let g = Geometry::default();
    let set = clearance_set(set)?;
    clearance_model(
        &g,
        &MassProperties::default(),
        Vector3::from(TABLE2[0].m),
        Some(drive_laws(&g)),
        &bearing_design(&set, damping),
    )
}

pub(crate) fn build(opts: &Mr2120BenchOptions) -> Result<Model, Mr2120Error> {
    let model = bench_mechanism(&opts.set, opts.damping)?;
    let n = (opts.t_end / opts.dt).round() as usize;
    Ok(Model {
        platform: model.platform,
        arms: model.arms.map(|a| a.index()),
        mech: Arc::new(model.mechanism),
        times: (1..=n).map(|k| k as f64 * opts.dt).collect(),
    })
}

type Path = Vec<[f64; 3]>;

/// Solver names as they appear in the tables and the JSON.
const LASH_BDF: &str = "lash BDF (GGL index 2)";
const DOPRI: &str = "Dormand-Prince 5(4) (index 1 + Baumgarte)";
const SYMPLECTIC: &str = "symplectic Euler (index 1 + Baumgarte)";
#[cfg_attr(not(feature = "peers"), allow(dead_code))]
const DIFFSOL: &str = "diffsol BDF 0.18 (index 1 + Baumgarte)";

/// A run's platform path and the wall time at each sample.
struct Traced {
    path: Path,
    wall_at: Vec<f64>,
}

fn point(solver: &str, rtol: f64) -> WorkPoint {
    WorkPoint {
        solver: solver.into(),
        rtol,
        step_size: None,
        error: f64::NAN,
        steps: 0,
        rejected: 0,
        rhs_evals: 0,
        newton_iters: 0,
        factorisations: 0,
        phase_times: None,
        wall_s: f64::NAN,
        reached_t: 0.0,
        failure: None,
        out_of_budget: false,
        error_windows: vec![],
        error_to_horizon: f64::NAN,
        wall_to_horizon_s: f64::NAN,
    }
}

/// The platform centre in a state whose first entries are the bodies' positions
/// (x, y, z, Euler parameters per body).
fn platform_centre(y: &[f64], platform: BodyHandle) -> [f64; 3] {
    Layout::position_of(y, platform)
}

/// What [`run_sampled`] saw: the samples reached, and why it stopped early, if it did.
struct Sampled {
    traced: Traced,
    error: Option<IntegratorError>,
    over_budget: bool,
}

/// The one driver of every solver: advances `integ` through the sample times, recording the
/// platform centre and the wall time (since `start`) at each, until the last sample, a
/// failure, or — past a sample before the last — the wall-time budget `budget` (s).
fn run_sampled(
    m: &Model,
    integ: &mut dyn Integrator,
    start: Instant,
    budget: f64,
    progress: &mut dyn FnMut(f64),
) -> Sampled {
    let mut traced = Traced {
        path: Vec::with_capacity(m.times.len()),
        wall_at: Vec::with_capacity(m.times.len()),
    };
    let last = m.times[m.times.len() - 1];
    for &t in &m.times {
        if let Err(e) = integ.advance_to(t) {
            return Sampled {
                traced,
                error: Some(e),
                over_budget: false,
            };
        }
        traced.path.push(platform_centre(integ.y(), m.platform));
        traced.wall_at.push(start.elapsed().as_secs_f64());
        progress(t);
        if start.elapsed().as_secs_f64() > budget && t < last {
            return Sampled {
                traced,
                error: None,
                over_budget: true,
            };
        }
    }
    Sampled {
        traced,
        error: None,
        over_budget: false,
    }
}

/// Fills the work point's counters, wall time and reached time after a sampled run.
fn record(m: &Model, wp: &mut WorkPoint, run: &Sampled, work: WorkStats, start: Instant, budget: f64) {
    wp.wall_s = start.elapsed().as_secs_f64();
    let reached = run.traced.path.len();
    wp.reached_t = if reached == 0 { 0.0 } else { m.times[reached - 1] };
    wp.steps = work.steps;
    wp.rejected = work.rejected;
    wp.rhs_evals = work.rhs_evals;
    wp.newton_iters = work.newton_iters;
    wp.factorisations = work.factorisations;
    if run.over_budget {
        wp.out_of_budget = true;
        wp.failure = Some(format!(
            "wall-time budget of {budget:.0} s exhausted at t = {:.3} s",
            wp.reached_t
        ));
    }
}

/// lash's BDF on the GGL index-2 DAE through [`Simulation`], as an [`Integrator`]: each
/// `advance_to` is a one-sample [`Simulation::run`], so a sampled run does the same work as
/// a whole-trajectory one (including the singularity measure at each sample).
struct SimulationStepper {
    sim: Simulation,
    t: f64,
    /// Positions, velocities and multipliers of the last sample.
    y: Vec<f64>,
}

impl Integrator for SimulationStepper {
    fn advance_to(&mut self, t: f64) -> Result<(), IntegratorError> {
        let mut tr = self
            .sim
            .run(&[t], |_| {})
            .map_err(|e| IntegratorError::Other(e.to_string()))?;
        match (tr.end, tr.samples.pop()) {
            (RunEnd::Completed, Some(s)) => {
                self.t = s.t;
                self.y = [s.q, s.w, s.lambda].concat();
                Ok(())
            }
            (end, _) => Err(IntegratorError::Other(format!(
                "stopped at t = {:.3} s: {end:?}",
                self.t
            ))),
        }
    }
    fn t(&self) -> f64 {
        self.t
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn work(&self) -> WorkStats {
        self.sim.stats().into()
    }
}

fn run_bdf(m: &Model, rtol: f64, progress: &mut dyn FnMut(f64)) -> (WorkPoint, Option<Traced>) {
    let mut wp = point(LASH_BDF, rtol);
    let start = Instant::now();
    let mut opts = clearance_options();
    opts.bdf.rtol = rtol;
    opts.bdf.atol = crate::dae::AbsTol::Scalar(rtol / 100.0);
    // The singularity watch is not part of the integration cost.
    opts.singularity_warning = 0.0;
    let sim = match Simulation::new(m.mech.clone(), 0.0, opts) {
        Ok(sim) => sim,
        Err(e) => {
            wp.wall_s = start.elapsed().as_secs_f64();
            wp.failure = Some(e.to_string());
            return (wp, None);
        }
    };
    let mut st = SimulationStepper {
        sim,
        t: 0.0,
        y: vec![],
    };
    let run = run_sampled(m, &mut st, start, f64::INFINITY, progress);
    record(m, &mut wp, &run, st.work(), start, f64::INFINITY);
    wp.phase_times = Some(st.sim.stats().time);
    match run.error {
        None => (wp, Some(run.traced)),
        // The reference must be complete: a failed BDF run has no trace.
        Some(e) => {
            wp.failure = Some(e.to_string());
            (wp, None)
        }
    }
}

/// The index-1 ODE of the model and its consistent initial state (q, w).
fn ode_start(m: &Model) -> Result<(MultibodyOde, Vec<f64>, Vec<f64>), String> {
    let s0 = Analysis::new(&m.mech)
        .and_then(|a| a.initial_state(&m.mech, &mut MechanismData::new(&m.mech), 0.0))
        .map_err(|e| e.to_string())?;
    let ode = MultibodyOde::new(m.mech.clone()).map_err(|e| e.to_string())?;
    Ok((ode, s0.q, s0.w))
}

/// Runs an explicit integrator, built by `make` from the ODE and its initial (q, w), sample
/// by sample within the wall-time budget `budget` (s).
fn run_explicit(
    m: &Model,
    mut wp: WorkPoint,
    budget: f64,
    progress: &mut dyn FnMut(f64),
    make: impl FnOnce(MultibodyOde, Vec<f64>, Vec<f64>) -> Result<Box<dyn Integrator>, String>,
) -> (WorkPoint, Option<Traced>) {
    let start = Instant::now();
    let built = ode_start(m).and_then(|(ode, q, w)| make(ode, q, w));
    let mut integ = match built {
        Ok(i) => i,
        Err(e) => {
            wp.wall_s = start.elapsed().as_secs_f64();
            wp.failure = Some(format!("failed after the sample at t = 0.000 s: {e}"));
            return (wp, None);
        }
    };
    let run = run_sampled(m, integ.as_mut(), start, budget, progress);
    record(m, &mut wp, &run, integ.work(), start, budget);
    if let Some(e) = &run.error {
        wp.failure = Some(format!(
            "failed after the sample at t = {:.3} s: {e}",
            wp.reached_t
        ));
    }
    let traced = (!run.traced.path.is_empty()).then_some(run.traced);
    (wp, traced)
}

fn run_dopri(
    m: &Model,
    rtol: f64,
    budget: f64,
    progress: &mut dyn FnMut(f64),
) -> (WorkPoint, Option<Traced>) {
    let wp = point(DOPRI, rtol);
    run_explicit(m, wp, budget, progress, |ode, q, w| {
        let y0: Vec<f64> = q.iter().chain(&w).copied().collect();
        let o = Dopri5Options {
            rtol,
            atol: rtol / 100.0,
            max_steps: 50_000_000,
            ..Default::default()
        };
        let dp = Dopri5::new(ode, 0.0, &y0, &[], o).map_err(|e| e.to_string())?;
        Ok(Box::new(dp) as Box<dyn Integrator>)
    })
}

fn run_symplectic(
    m: &Model,
    h: f64,
    budget: f64,
    progress: &mut dyn FnMut(f64),
) -> (WorkPoint, Option<Traced>) {
    let wp = WorkPoint {
        step_size: Some(h),
        ..point(SYMPLECTIC, f64::NAN)
    };
    run_explicit(m, wp, budget, progress, |ode, q, w| {
        let se = SymplecticEuler::new(ode, 0.0, &q, &w, &[], h).map_err(|e| e.to_string())?;
        Ok(Box::new(se) as Box<dyn Integrator>)
    })
}

/// diffsol's BDF on the index-1 ODE (its formulation: y' = f(t, y), dense LU, Jacobian by
/// differences of f), sample by sample within the wall-time budget.
#[cfg(feature = "peers")]
fn run_diffsol(
    m: &Model,
    rtol: f64,
    budget: f64,
    progress: &mut dyn FnMut(f64),
) -> (WorkPoint, Option<Traced>) {
    use crate::dae::explicit::OdeSystem;
    let mut wp = point(DIFFSOL, rtol);
    let start = Instant::now();
    let (ode, q, w) = match ode_start(m) {
        Ok(x) => x,
        Err(e) => {
            wp.failure = Some(e);
            return (wp, None);
        }
    };
    let y0: Vec<f64> = q.iter().chain(&w).copied().collect();
    let n = y0.len();
    let ode = std::cell::RefCell::new(ode);
    let failed = std::cell::Cell::new(None::<String>);
    let f = |t: f64, y: &[f64], dy: &mut [f64]| {
        if let Err(e) = ode.borrow_mut().rhs(t, y, &[], dy) {
            failed.set(Some(format!("{e:?}")));
            dy.iter_mut().for_each(|v| *v = f64::NAN);
        }
    };
    let res = crate::peers::with_diffsol_bdf(f, &vec![1.0; n], &y0, rtol, &vec![rtol / 100.0; n], |integ| {
        let run = run_sampled(m, integ, start, budget, progress);
        let work = integ.work();
        (run, work)
    });
    let cause = || failed.take().map(|c| format!(" ({c})")).unwrap_or_default();
    match res {
        Ok((run, work)) => {
            record(m, &mut wp, &run, work, start, budget);
            if let Some(e) = &run.error {
                wp.failure = Some(format!("failed after t = {:.3} s: {e}{}", wp.reached_t, cause()));
            }
            let traced = (!run.traced.path.is_empty()).then_some(run.traced);
            (wp, traced)
        }
        Err(e) => {
            wp.wall_s = start.elapsed().as_secs_f64();
            wp.failure = Some(format!("failed after t = 0.000 s: {e}{}", cause()));
            (wp, None)
        }
    }
}

/// Largest distance over the samples both paths have.
fn distance(a: &Path, b: &Path) -> f64 {
    a.iter().zip(b).map(|(x, y)| dist(x, y)).fold(0.0, f64::max)
}

/// Runs the benchmark. `progress` receives (what is running, fraction of that run done).
/// Settings are checked first ([`Mr2120BenchOptions::validate`]).
pub fn bench_mr2120(
    opts: &Mr2120BenchOptions,
    mut progress: impl FnMut(&str, f64),
) -> Result<Mr2120Bench, BenchError> {
    opts.validate()?;
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
    for &h in &opts.symplectic_steps {
        let label = format!("symplectic Euler h {h:.0e} s");
        let (wp, path) = run_symplectic(&m, h, opts.explicit_budget_s, &mut |t| {
            progress(&label, t / t_end)
        });
        points.push(wp);
        traces.push(path);
    }
    #[cfg(feature = "peers")]
    for &rtol in &opts.diffsol_rtols {
        let label = format!("diffsol BDF rtol {rtol:.0e}");
        let (wp, path) = run_diffsol(&m, rtol, opts.explicit_budget_s, &mut |t| {
            progress(&label, t / t_end)
        });
        points.push(wp);
        traces.push(path);
    }
    // The agreement horizon: as long as an independent run stays within the target.
    let independent = match (&check, opts.reference_check_rtol) {
        (Some(c), Some(rtol)) => Some((c, format!("Dormand-Prince check run rtol {rtol:.0e}"))),
        _ => points
            .iter()
            .zip(&traces)
            .filter(|(p, t)| p.solver == DOPRI && t.is_some())
            .min_by(|a, b| a.0.rtol.total_cmp(&b.0.rtol))
            .and_then(|(p, t)| Some((t.as_ref()?, format!("{DOPRI} rtol {:.0e}", p.rtol)))),
    };
    // Without an independent run nothing bounds the comparison: it covers the whole run.
    let n_h = match &independent {
        Some((c, _)) => leading_within(&c.path, &ref_path.path, opts.target),
        None => m.times.len(),
    };
    let horizon_s = independent
        .as_ref()
        .map(|_| if n_h > 0 { m.times[n_h - 1] } else { 0.0 });
    let horizon_source = independent.map(|(_, s)| s);
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
        times: m.times.clone(),
        reference_path: ref_path.path.clone(),
        horizon_s,
        horizon_source,
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
            let at_own_accuracy = if c.is_none() {
                own_accuracy(points, s, solvers[0])
            } else {
                None
            };
            Comparison {
                solver: s.to_string(),
                chosen: c,
                time_ratio: tr,
                steps_ratio: sr,
                time_ratio_at_least: at_least,
                at_own_accuracy,
            }
        })
        .collect()
}

/// `solver`'s most accurate run up to the horizon against `base`'s cheapest run at least as
/// accurate.
fn own_accuracy(points: &[WorkPoint], solver: &str, base: &str) -> Option<OwnAccuracy> {
    let finite = |p: &&WorkPoint| p.error_to_horizon.is_finite() && p.wall_to_horizon_s.is_finite();
    let best = points
        .iter()
        .filter(|p| p.solver == solver)
        .filter(finite)
        .min_by(|a, b| a.error_to_horizon.total_cmp(&b.error_to_horizon))?;
    let lash = points
        .iter()
        .filter(|p| p.solver == base && p.error_to_horizon <= best.error_to_horizon)
        .filter(finite)
        .min_by(|a, b| a.wall_to_horizon_s.total_cmp(&b.wall_to_horizon_s))?;
    Some(OwnAccuracy {
        accuracy_m: best.error_to_horizon,
        setting: best.setting(),
        wall_to_horizon_s: best.wall_to_horizon_s,
        lash_setting: lash.setting(),
        lash_error_m: lash.error_to_horizon,
        lash_wall_to_horizon_s: lash.wall_to_horizon_s,
        time_ratio: best.wall_to_horizon_s / lash.wall_to_horizon_s,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp(solver: &str, rtol: f64, err: f64, wall: f64) -> WorkPoint {
        WorkPoint {
            error_to_horizon: err,
            wall_to_horizon_s: wall,
            wall_s: wall,
            steps: 10,
            ..point(solver, rtol)
        }
    }

    #[test]
    fn a_peer_short_of_the_target_is_compared_at_its_own_accuracy() {
        let points = [
            wp(LASH_BDF, 1e-4, 5e-5, 0.7),
            wp(LASH_BDF, 1e-7, 1e-7, 3.7),
            wp(DOPRI, 1e-5, 9e-7, 150.0),
            wp(DIFFSOL, 1e-4, 6e-5, 20.0),
            wp(DIFFSOL, 1e-6, 2e-6, 40.0),
        ];
        let c = compare(&points, 1e-6);
        assert_eq!(c.len(), 3);
        assert!((c[1].time_ratio - 150.0 / 3.7).abs() < 1e-12);
        assert!(c[1].at_own_accuracy.is_none());
        assert!(c[2].chosen.is_none());
        let o = c[2].at_own_accuracy.as_ref().unwrap();
        // diffsol's best is 2 µm at 40 s; the cheapest lash run within 2 µm is rtol 1e-7.
        assert_eq!(o.setting, "1e-6");
        assert_eq!(o.lash_setting, "1e-7");
        assert!((o.time_ratio - 40.0 / 3.7).abs() < 1e-12);
    }

    #[test]
    fn settings_are_checked_before_anything_runs() {
        let ok = Mr2120BenchOptions::default();
        assert!(ok.validate().is_ok());
        assert_eq!(ok.t_end, crate::mechanisms::mr2120::trajectory::DURATION);
        assert_eq!(ok.damping, BENCH_DAMPING);
        let late = Mr2120BenchOptions {
            t_end: crate::mechanisms::mr2120::trajectory::DURATION + 1.0,
            ..ok.clone()
        };
        let e = bench_mr2120(&late, |_, _| {}).unwrap_err();
        assert!(matches!(e, BenchError::Invalid(_)), "{e}");
        let bad = Mr2120BenchOptions {
            bdf_rtols: vec![1e-4, -1.0],
            ..ok.clone()
        };
        assert!(bad.validate().unwrap_err().to_string().contains("bdf_rtols"));
        let unknown = Mr2120BenchOptions {
            set: "L7".into(),
            ..ok.clone()
        };
        assert!(unknown.validate().unwrap_err().to_string().contains("L7"));
        let diffsol = Mr2120BenchOptions {
            diffsol_rtols: vec![1e-4],
            ..ok
        };
        if cfg!(feature = "peers") {
            assert!(diffsol.validate().is_ok());
        } else {
            let e = diffsol.validate().unwrap_err();
            assert!(matches!(e, BenchError::PeersDisabled(_)), "{e}");
            assert!(e.to_string().contains("peers"), "{e}");
        }
    }
}
