//! diffsol's BDF on M·y' = f(t, y).

use diffsol::{NalgebraLU, NalgebraMat, OdeBuilder, OdeEquations, OdeSolverMethod, Op, Vector};
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
    let start = Instant::now();
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
    let (st, ops) = if has_mass {
        let mass = move |v: &[f64], _p: &[f64], _t: f64, beta: f64, y: &mut [f64]| {
            for i in 0..v.len() {
                y[i] = md[i] * v[i] + beta * y[i];
            }
        };
        let mut problem = builder.mass(mass).build().map_err(|e| e.to_string())?;
        relax_limits(&mut problem.ode_options);
        let mut solver = problem.bdf::<NalgebraLU<f64>>().map_err(|e| e.to_string())?;
        sample(&mut solver, times, &mut on_sample)?;
        let st = solver.get_statistics().clone();
        (st, problem.eqn.rhs().statistics())
    } else {
        let mut problem = builder.build().map_err(|e| e.to_string())?;
        relax_limits(&mut problem.ode_options);
        let mut solver = problem.bdf::<NalgebraLU<f64>>().map_err(|e| e.to_string())?;
        sample(&mut solver, times, &mut on_sample)?;
        let st = solver.get_statistics().clone();
        (st, problem.eqn.rhs().statistics())
    };
    Ok(PeerRun {
        y_end: vec![],
        steps: st.number_of_steps,
        error_test_failures: st.number_of_error_test_failures,
        newton_iters: st.number_of_nonlinear_solver_iterations,
        rhs_evals: calls.get(),
        jacobian_evals: ops.number_of_matrix_evals,
        wall_s: start.elapsed().as_secs_f64(),
    })
}

/// Steps `solver` past each of `times` and hands the interpolated solution to `on_sample`.
fn sample<'a, Eqn, S>(
    solver: &mut S,
    times: &[f64],
    on_sample: &mut impl FnMut(usize, &[f64]) -> bool,
) -> Result<(), String>
where
    Eqn: OdeEquations<T = f64> + 'a,
    S: OdeSolverMethod<'a, Eqn>,
{
    for (k, &t) in times.iter().enumerate() {
        while solver.state().t < t {
            solver.step().map_err(|e| e.to_string())?;
        }
        let y = solver.interpolate(t).map_err(|e| e.to_string())?;
        if !on_sample(k, &y.clone_as_vec()) {
            break;
        }
    }
    Ok(())
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
