//! diffsol's BDF on M·y' = f(t, y).

use crate::dae::{Integrator, IntegratorError, WorkStats};
use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeEquations, OdeSolverMethod, Op, Vector};
use std::marker::PhantomData;
use std::time::Instant;

/// Result of a peer run.
#[derive(Debug, Clone)]
pub struct PeerRun {
    /// Solution at the final time.
    pub y_end: Vec<f64>,
    /// Accepted steps.
    pub steps: usize,
    /// Error-test failures.
    pub error_test_failures: usize,
    /// Nonlinear-solver iterations.
    pub newton_iters: usize,
    /// Right-hand-side evaluations (including Jacobian-vector products, each one f call here).
    pub rhs_evals: usize,
    /// Jacobian (matrix) evaluations.
    pub jacobian_evals: usize,
    /// Wall time, s.
    pub wall_s: f64,
}

/// diffsol's default failure limits are cumulative over the whole run (50 nonlinear
/// failures) and its step floor is absolute (1e-13); both end long stiff runs that lash's
/// per-step limits let finish, so the peer runs with them lifted to compare like with like.
fn relax_limits(o: &mut diffsol::OdeSolverOptions<f64>) {
    o.max_nonlinear_solver_failures = usize::MAX / 2;
    o.min_timestep = 1e-300;
}

/// Solves M·y' = f(t, y) from (0, y0) to `t_end` with diffsol's BDF (dense nalgebra LU).
/// `atol` has one value or one per component.
///
/// `mass_diag` is the diagonal of M (zeros mark algebraic equations). The Jacobian–vector
/// products diffsol needs are computed here by a forward difference of `f` (one evaluation
/// each), so the peer solves the same problem with the information lash's
/// finite-difference path has.
pub fn diffsol_bdf<F>(
    f: F,
    mass_diag: &[f64],
    y0: &[f64],
    rtol: f64,
    atol: &[f64],
    t_end: f64,
) -> Result<PeerRun, String>
where
    F: Fn(f64, &[f64], &mut [f64]),
{
    let mut y_end = vec![];
    let mut run = diffsol_bdf_sampled(f, mass_diag, y0, rtol, atol, &[t_end], |_, y| {
        y_end = y.to_vec();
        true
    })?;
    run.y_end = y_end;
    Ok(run)
}

/// As [`diffsol_bdf`], reporting the solution (interpolated by diffsol) at each of `times`
/// (increasing, > 0) to `on_sample(k, y)`; the run stops early when `on_sample` returns false.
pub fn diffsol_bdf_sampled<F>(
    f: F,
    mass_diag: &[f64],
    y0: &[f64],
    rtol: f64,
    atol: &[f64],
    times: &[f64],
    mut on_sample: impl FnMut(usize, &[f64]) -> bool,
) -> Result<PeerRun, String>
where
    F: Fn(f64, &[f64], &mut [f64]),
{
    let start = Instant::now();
    let work = with_diffsol_bdf(f, mass_diag, y0, rtol, atol, |integ| {
        for (k, &t) in times.iter().enumerate() {
            integ.advance_to(t).map_err(|e| e.to_string())?;
            if !on_sample(k, integ.y()) {
                break;
            }
        }
        Ok::<_, String>(integ.work())
    })??;
    Ok(PeerRun {
        y_end: vec![],
        steps: work.steps,
        error_test_failures: work.rejected,
        newton_iters: work.newton_iters,
        rhs_evals: work.rhs_evals,
        jacobian_evals: work.jacobian_evals,
        wall_s: start.elapsed().as_secs_f64(),
    })
}

/// Sets up diffsol's BDF on M·y' = f(t, y) from (0, y0) (as [`diffsol_bdf`]) and hands it to
/// `body` as a stepping [`Integrator`]: `advance_to(t)` steps diffsol past `t` and
/// interpolates there. diffsol's solver borrows its problem, so the integrator lives for the
/// call of `body` only.
///
/// Work counters: `rejected` are diffsol's error-test failures, `rhs_evals` every call of
/// `f` (Jacobian–vector products included), `jacobian_evals` and `factorisations` both its
/// matrix evaluations (diffsol factorises after each and does not report the
/// refactorisations after step-size changes separately).
pub fn with_diffsol_bdf<F, R>(
    f: F,
    mass_diag: &[f64],
    y0: &[f64],
    rtol: f64,
    atol: &[f64],
    body: impl FnOnce(&mut dyn Integrator) -> R,
) -> Result<R, String>
where
    F: Fn(f64, &[f64], &mut [f64]),
{
    let n = y0.len();
    if mass_diag.len() != n {
        return Err(format!(
            "mass diagonal has length {}, expected {n}",
            mass_diag.len()
        ));
    }
    let f = &f;
    let calls = std::cell::Cell::new(0usize);
    let calls = &calls;
    let y0v = y0.to_vec();
    let md = mass_diag.to_vec();
    let has_mass = md.iter().any(|&m| m != 1.0);
    let rhs = move |x: &[f64], _p: &[f64], t: f64, y: &mut [f64]| {
        calls.set(calls.get() + 1);
        f(t, x, y)
    };
    let jvp = move |x: &[f64], _p: &[f64], t: f64, v: &[f64], y: &mut [f64]| {
        let vn = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if vn == 0.0 {
            y.iter_mut().for_each(|a| *a = 0.0);
            return;
        }
        // Scale the increment to the components v points along (for v = e_j, as when diffsol
        // assembles the Jacobian column by column, this is √ε·max(1, |x_j|)).
        let xv: f64 = x.iter().zip(v).map(|(a, b)| (a * b).abs()).sum();
        let eps = f64::EPSILON.sqrt() * (xv / (vn * vn)).max(1.0 / vn);
        let xp: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + eps * b).collect();
        let mut f0 = vec![0.0; x.len()];
        calls.set(calls.get() + 2);
        f(t, x, &mut f0);
        f(t, &xp, y);
        for i in 0..y.len() {
            y[i] = (y[i] - f0[i]) / eps;
        }
    };
    let init = move |_p: &[f64], _t: f64, y: &mut [f64]| y.copy_from_slice(&y0v);
    let builder = OdeBuilder::<NalgebraMat<f64>>::new()
        .rtol(rtol)
        .atol(atol.iter().copied())
        .rhs_implicit(rhs, jvp)
        .init(init, n);
    if has_mass {
        let mass = move |v: &[f64], _p: &[f64], _t: f64, beta: f64, y: &mut [f64]| {
            for i in 0..v.len() {
                y[i] = md[i] * v[i] + beta * y[i];
            }
        };
        let mut problem = builder.mass(mass).build().map_err(|e| e.to_string())?;
        relax_limits(&mut problem.ode_options);
        let solver = problem.bdf::<NalgebraLU<f64>>().map_err(|e| e.to_string())?;
        let mut stepper = DiffsolStepper::new(solver, calls, y0);
        let out = body(&mut stepper);
        Ok(out)
    } else {
        let mut problem = builder.build().map_err(|e| e.to_string())?;
        relax_limits(&mut problem.ode_options);
        let solver = problem.bdf::<NalgebraLU<f64>>().map_err(|e| e.to_string())?;
        let mut stepper = DiffsolStepper::new(solver, calls, y0);
        let out = body(&mut stepper);
        Ok(out)
    }
}

/// A diffsol solver advanced from output time to output time.
struct DiffsolStepper<'a, 'c, Eqn, S> {
    solver: S,
    /// Calls of f so far (shared with the closures diffsol holds).
    calls: &'c std::cell::Cell<usize>,
    t: f64,
    y: Vec<f64>,
    _eqn: PhantomData<&'a Eqn>,
}

impl<'a, 'c, Eqn, S> DiffsolStepper<'a, 'c, Eqn, S>
where
    Eqn: OdeEquations<T = f64> + 'a,
    S: OdeSolverMethod<'a, Eqn>,
{
    fn new(solver: S, calls: &'c std::cell::Cell<usize>, y0: &[f64]) -> Self {
        Self {
            t: solver.state().t,
            solver,
            calls,
            y: y0.to_vec(),
            _eqn: PhantomData,
        }
    }
}

impl<'a, Eqn, S> Integrator for DiffsolStepper<'a, '_, Eqn, S>
where
    Eqn: OdeEquations<T = f64> + 'a,
    S: OdeSolverMethod<'a, Eqn>,
{
    fn advance_to(&mut self, t: f64) -> Result<(), IntegratorError> {
        let err = |e: diffsol::DiffsolError| IntegratorError::Other(e.to_string());
        while self.solver.state().t < t {
            self.solver.step().map_err(err)?;
        }
        self.y = self.solver.interpolate(t).map_err(err)?.clone_as_vec();
        self.t = t;
        Ok(())
    }
    fn t(&self) -> f64 {
        self.t
    }
    fn y(&self) -> &[f64] {
        &self.y
    }
    fn work(&self) -> WorkStats {
        let st = self.solver.get_statistics();
        let matrix_evals = self
            .solver
            .problem()
            .eqn
            .rhs()
            .statistics()
            .number_of_matrix_evals;
        WorkStats {
            steps: st.number_of_steps,
            rejected: st.number_of_error_test_failures,
            rhs_evals: self.calls.get(),
            jacobian_evals: matrix_evals,
            factorisations: matrix_evals,
            newton_iters: st.number_of_nonlinear_solver_iterations,
        }
    }
}

/// Runs a [`DaeSystem`](crate::dae::DaeSystem) whose residual is F = D·y' − f(t, y) with a
/// constant diagonal D (`mass_diag`) through diffsol: f(t, y) = −F(t, y, 0).
pub fn diffsol_dae<P: crate::dae::DaeSystem>(
    sys: P,
    mass_diag: &[f64],
    y0: &[f64],
    rtol: f64,
    atol: &[f64],
    t_end: f64,
) -> Result<PeerRun, String> {
    let n = sys.dim();
    let sys = std::cell::RefCell::new(sys);
    let zeros = vec![0.0; n];
    let failed = std::cell::Cell::new(false);
    let f = |t: f64, y: &[f64], out: &mut [f64]| {
        if sys.borrow_mut().residual(t, y, &zeros, &[], out).is_err() {
            failed.set(true);
        }
        out.iter_mut().for_each(|v| *v = -*v);
    };
    let run = diffsol_bdf(f, mass_diag, y0, rtol, atol, t_end)?;
    if failed.get() {
        return Err("the residual failed during the diffsol run".into());
    }
    Ok(run)
}
