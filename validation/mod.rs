//! Validation problems with published reference solutions, run by `lash validate` and by the
//! test suite. Sources live in the top-level `validation/` folder of the repository.
//!
//! | problem | form | reference | pass criterion |
//! |---|---|---|---|
//! | Andrews' squeezer | index 2 (+ projection), index 1 (+ projection), GGL | Bari test set (PSIDE, 1e-14) | max relative angle error ≤ 1e-5 at rtol = atol = 1e-6 |
//! | turning stiff spring | ODE in residual form, k = 1e9 N/m | rigid-pendulum angle 0.2135638702 rad | \|θ(10) − θ_ref\| ≤ 1e-5, ≤ 1000 steps at rtol 1e-6 (damped); undamped must finish |
//! | Robertson | index-1 DAE to t = 1e11 | Bari test set | max relative error ≤ 1e-4 |
//! | GGL pendulum | index 2 (stabilised), 100 s | constraint g(q) = 0 | max drift ≤ 1e-8 |
//!
//! Every reference value is in [`mod@reference`] with its source.

pub mod andrews;
pub mod pendulum;
pub mod reference;
pub mod robertson;
pub mod stiff_spring;

use crate::dae::explicit::{Dopri5, Dopri5Options};
use crate::dae::{AbsTol, BdfOptions, BdfSolver, Statistics};
use serde::Serialize;
use std::time::Instant;

/// One row of the validation report.
#[derive(Debug, Clone, Serialize)]
pub struct ValidationRow {
    /// Problem name.
    pub problem: String,
    /// Formulation / variant.
    pub variant: String,
    /// Relative tolerance used.
    pub rtol: f64,
    /// Absolute tolerance used.
    pub atol: f64,
    /// What `error` measures.
    pub error_measure: String,
    /// Achieved error against the reference (NaN if the run failed).
    pub error: f64,
    /// Largest error that passes.
    pub error_limit: f64,
    /// Largest step count that passes (`None`: no limit).
    pub max_steps: Option<usize>,
    /// Accepted steps.
    pub steps: usize,
    /// Error-test failures.
    pub error_test_failures: usize,
    /// Newton convergence failures.
    pub newton_failures: usize,
    /// Residual evaluations.
    pub residual_evals: usize,
    /// Jacobian evaluations.
    pub jacobian_evals: usize,
    /// LU factorisations.
    pub lu_factorisations: usize,
    /// Newton iterations.
    pub newton_iters: usize,
    /// Wall time of the run, s (informational: performance is claimed only by `lash bench`).
    pub wall_s: f64,
    /// Did it pass?
    pub pass: bool,
    /// Remarks (e.g. the solver error, or a comparison figure).
    pub note: String,
}

impl ValidationRow {
    #[allow(clippy::too_many_arguments)]
    fn new(
        problem: &str,
        variant: &str,
        rtol: f64,
        atol: f64,
        error_measure: &str,
        error_limit: f64,
        max_steps: Option<usize>,
    ) -> Self {
        Self {
            problem: problem.into(),
            variant: variant.into(),
            rtol,
            atol,
            error_measure: error_measure.into(),
            error: f64::NAN,
            error_limit,
            max_steps,
            steps: 0,
            error_test_failures: 0,
            newton_failures: 0,
            residual_evals: 0,
            jacobian_evals: 0,
            lu_factorisations: 0,
            newton_iters: 0,
            wall_s: 0.0,
            pass: false,
            note: String::new(),
        }
    }

    fn finish(mut self, result: Result<(f64, Statistics), Failure>, start: Instant) -> Self {
        self.wall_s = start.elapsed().as_secs_f64();
        let stats = match result {
            Ok((err, s)) => {
                self.error = err;
                s
            }
            Err(f) => {
                let (e, s) = *f;
                self.note = format!("solver error: {e}");
                s
            }
        };
        self.steps = stats.steps;
        self.error_test_failures = stats.error_test_failures;
        self.newton_failures = stats.newton_failures;
        self.residual_evals = stats.residual_evals;
        self.jacobian_evals = stats.jacobian_evals;
        self.lu_factorisations = stats.lu_factorisations;
        self.newton_iters = stats.newton_iters;
        self.pass = self.error.is_finite()
            && self.error <= self.error_limit
            && self.max_steps.is_none_or(|m| self.steps <= m);
        self
    }
}

/// A failed run: the message and the statistics reached.
type Failure = Box<(String, Statistics)>;

/// Runs a solver to `t_end` and maps the error together with the statistics reached.
fn run_to<P: crate::dae::DaeSystem>(s: &mut BdfSolver<P>, t_end: f64) -> Result<(), Failure> {
    s.solve_to(t_end)
        .map(|_| ())
        .map_err(|e| Box::new((e.to_string(), *s.stats())))
}

/// Andrews' squeezer at rtol = atol = `tol` in one of three formulations:
///
/// * index 2 (velocity constraints) with projection of accepted steps onto the position
///   constraints g(q) = 0 (Hairer & Wanner II, VII.2), multipliers and accelerations out of
///   the error test;
/// * index 1 (acceleration constraints) with projection onto g(q) = 0 and G(q)v = 0;
///   its algebraic unknowns are index-1 and stay in the error test;
/// * GGL stabilised index 2 (both constraint levels, no projection needed).
pub fn andrews(index: andrews::AndrewsIndex, tol: f64) -> ValidationRow {
    use andrews::AndrewsIndex;
    let (variant, project, suppress) = match index {
        AndrewsIndex::Two => (
            "index 2 + position projection, 27 unknowns, FD Jacobian",
            true,
            true,
        ),
        AndrewsIndex::One => ("index 1 + projection, 27 unknowns, FD Jacobian", true, false),
        AndrewsIndex::Ggl => ("GGL index 2, 33 unknowns, FD Jacobian", false, true),
    };
    let row = ValidationRow::new(
        "andrews",
        variant,
        tol,
        tol,
        "max relative error of the 7 angles at t = 0.03 s",
        1e-5,
        None,
    );
    let start = Instant::now();
    let (y0, yp0) = andrews::initial_values_for(index);
    let opts = BdfOptions {
        suppress_algebraic: suppress,
        ..BdfOptions::with_tolerances(tol, tol)
    };
    let sys = andrews::Andrews { index, project };
    let res = BdfSolver::new(sys, 0.0, &y0, &yp0, &[], opts)
        .map_err(|e| Box::new((e.to_string(), Statistics::default())))
        .and_then(|mut s| {
            run_to(&mut s, reference::ANDREWS_T_END)?;
            Ok((andrews::angle_error(s.y()), *s.stats()))
        });
    let mut row = row.finish(res, start);
    if row.error.is_finite() {
        row.note = format!(
            "IDA at this tolerance: {} steps, error {:.1e}",
            reference::ANDREWS_IDA_STEPS,
            reference::ANDREWS_IDA_ERROR
        );
    }
    row
}

/// The turning stiff spring at `rtol` (atol = rtol).
pub fn stiff_spring(damped: bool, rtol: f64) -> ValidationRow {
    let variant = if damped {
        "damped c = 2*sqrt(km), k = 1e9 N/m"
    } else {
        "undamped c = 0, k = 1e9 N/m"
    };
    let row = ValidationRow::new(
        "turning stiff spring",
        variant,
        rtol,
        rtol,
        "|theta(10 s) - rigid pendulum reference| in rad",
        if damped { 1e-5 } else { 1e-4 },
        if damped { Some(1000) } else { None },
    );
    let start = Instant::now();
    let sys = stiff_spring::StiffSpring::validation(damped);
    let (y0, yp0) = sys.initial_values();
    let res = BdfSolver::new(sys, 0.0, &y0, &yp0, &[], BdfOptions::with_tolerances(rtol, rtol))
        .map_err(|e| Box::new((e.to_string(), Statistics::default())))
        .and_then(|mut s| {
            run_to(&mut s, 10.0)?;
            let th = stiff_spring::StiffSpring::angle(s.y());
            Ok(((th - reference::STIFF_SPRING_THETA_T10).abs(), *s.stats()))
        });
    let mut row = row.finish(res, start);
    if row.error.is_finite() {
        row.note = format!(
            "diffsol BDF needs {} steps here, Tsit5 {} (issue figures)",
            reference::STIFF_SPRING_DIFFSOL_STEPS,
            reference::STIFF_SPRING_TSIT5_STEPS
        );
    }
    row
}

/// Absolute tolerances of the Robertson runs: tight enough to resolve y2 ≈ 8e-14 at
/// t = 1e11, and not below the round-off of y3 = 1 − y1 − y2.
pub const ROBERTSON_ATOL: [f64; 3] = [1e-14, 1e-20, 1e-14];

/// Robertson to t = 1e11 at `rtol` with [`ROBERTSON_ATOL`].
pub fn robertson(rtol: f64) -> ValidationRow {
    let row = ValidationRow::new(
        "robertson",
        "index-1 DAE, t to 1e11, atol (1e-14, 1e-20, 1e-14)",
        rtol,
        ROBERTSON_ATOL[1],
        "max relative error of (y1, y2, y3) at t = 1e11",
        1e-4,
        None,
    );
    let start = Instant::now();
    let (y0, yp0) = robertson::Robertson::initial_values();
    let opts = BdfOptions {
        atol: AbsTol::Vector(ROBERTSON_ATOL.to_vec()),
        ..BdfOptions::with_tolerances(rtol, 1.0)
    };
    let res = BdfSolver::new(robertson::Robertson, 0.0, &y0, &yp0, &[], opts)
        .map_err(|e| Box::new((e.to_string(), Statistics::default())))
        .and_then(|mut s| {
            run_to(&mut s, reference::ROBERTSON_T_END)?;
            Ok((robertson::Robertson::relative_error(s.y()), *s.stats()))
        });
    row.finish(res, start)
}

/// GGL pendulum over 100 s at `rtol` (atol = rtol): the largest position-constraint drift,
/// sampled every 0.1 s.
pub fn ggl_pendulum(rtol: f64) -> ValidationRow {
    let row = ValidationRow::new(
        "pendulum GGL",
        "index 2 stabilised, 100 s, released at 60 deg",
        rtol,
        rtol,
        "max |x^2 + y^2 - L^2|/2 over [0, 100] s, m^2",
        1e-8,
        None,
    );
    let start = Instant::now();
    let sys = pendulum::GglPendulum::default();
    let theta0 = 60f64.to_radians();
    let (y0, yp0) = sys.initial_values(theta0);
    let opts = BdfOptions {
        suppress_algebraic: true,
        ..BdfOptions::with_tolerances(rtol, rtol)
    };
    let mut energy_drift = 0.0f64;
    let mut theta_end = f64::NAN;
    let e0 = sys.energy(&y0);
    let res = BdfSolver::new(sys, 0.0, &y0, &yp0, &[], opts)
        .map_err(|e| Box::new((e.to_string(), Statistics::default())))
        .and_then(|mut s| {
            let mut drift = 0.0f64;
            for k in 1..=1000 {
                run_to(&mut s, k as f64 * 0.1)?;
                drift = drift.max(sys.drift(s.y()));
                energy_drift = energy_drift.max(((sys.energy(s.y()) - e0) / e0).abs());
            }
            theta_end = pendulum::GglPendulum::angle(s.y());
            Ok((drift, *s.stats()))
        });
    let mut row = row.finish(res, start);
    // Reference angle from the angle ODE at tight tolerance.
    let mut r = Dopri5::new(
        pendulum::AnglePendulum {
            g_over_l: sys.g / sys.l,
        },
        0.0,
        &[theta0, 0.0],
        &[],
        Dopri5Options {
            rtol: 1e-12,
            atol: 1e-12,
            ..Default::default()
        },
    )
    .expect("valid reference problem");
    if r.solve_to(100.0).is_ok() {
        row.note = format!(
            "relative energy drift {:.2e}; angle error at 100 s vs Dormand-Prince 1e-12: {:.2e} rad",
            energy_drift,
            (theta_end - r.y()[0]).abs()
        );
    }
    row
}

/// The full validation suite at the tolerances the issue specifies.
pub fn run_all() -> Vec<ValidationRow> {
    vec![
        andrews(andrews::AndrewsIndex::Two, 1e-6),
        andrews(andrews::AndrewsIndex::One, 1e-6),
        andrews(andrews::AndrewsIndex::Ggl, 1e-6),
        stiff_spring(true, 1e-6),
        stiff_spring(false, 1e-6),
        robertson(1e-6),
        ggl_pendulum(1e-8),
    ]
}
