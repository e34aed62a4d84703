//! Side-by-side benchmarks: every number a performance claim quotes comes from here
//! (`lash bench dae`), measured in one run with ratios to lash.
//!
//! | file | concern |
//! |---|---|
//! | `mod.rs` | `lash bench dae`: the validation problems, lash against diffsol and explicit stepping |
//! | `mr2120.rs` | `lash bench mr2120`: the 63-DOF clearance model at equal accuracy, every solver through [`Integrator`] |
//! | `mr2120_options.rs` | its settings, their defaults and their check ([`mr2120::Mr2120BenchOptions`]) |
//! | `scaling.rs` | `lash bench scaling`: cost per step of a clearance chain against its length |
//! | `statics.rs` | `lash bench statics`: the static Table 3 envelope, direct equilibrium solver against dynamic relaxation |
//! | `exudyn.rs` | the MR2120 model exported for the Exudyn comparison (`benches/exudyn/`) |
//! | `charts.rs` | work-precision and log-log diagrams (feature `plot`) |

#[cfg(feature = "plot")]
pub mod charts;
pub mod exudyn;
pub mod mr2120;
mod mr2120_options;
pub mod scaling;
pub mod statics;

use crate::dae::explicit::{Dopri5, Dopri5Options, SymplecticEuler};
use crate::dae::{BdfOptions, BdfSolver, DaeSystem, Integrator};
use crate::validation::{andrews, reference, robertson, stiff_spring};
use serde::Serialize;
use std::time::Instant;

/// Work-precision data for Andrews' squeezer: every solver of [`andrews_rows_at`] at each
/// tolerance.
pub fn andrews_work_precision(tols: &[f64], repeats: usize) -> Vec<BenchRow> {
    tols.iter().flat_map(|&t| andrews_rows_at(t, repeats)).collect()
}

/// One solver on one problem.
#[derive(Debug, Clone, Serialize)]
pub struct BenchRow {
    /// Problem.
    pub problem: String,
    /// Solver.
    pub solver: String,
    /// Tolerance (rtol = atol) or fixed step, as text.
    pub setting: String,
    /// Achieved error against the reference (problem-specific measure, see `error_measure`).
    pub error: f64,
    /// What `error` measures.
    pub error_measure: String,
    /// Accepted steps.
    pub steps: usize,
    /// Residual / right-hand-side evaluations.
    pub rhs_evals: usize,
    /// Best wall time over the repeats, s.
    pub wall_s: f64,
    /// steps / lash's steps on the same problem.
    pub steps_ratio: f64,
    /// wall time / lash's wall time on the same problem.
    pub time_ratio: f64,
    /// Failure message, if the solver failed.
    pub failure: Option<String>,
}

fn best_of<T>(repeats: usize, mut f: impl FnMut() -> T) -> (T, f64) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (out.expect("at least one repeat"), best)
}

struct Run {
    y: Vec<f64>,
    steps: usize,
    rhs: usize,
}

#[cfg(feature = "peers")]
impl From<crate::peers::PeerRun> for Run {
    fn from(r: crate::peers::PeerRun) -> Self {
        Run {
            y: r.y_end,
            steps: r.steps,
            rhs: r.rhs_evals,
        }
    }
}

fn row(
    problem: &str,
    solver: &str,
    setting: String,
    measure: &str,
    res: Result<(Run, f64), String>,
    err: impl Fn(&[f64]) -> f64,
) -> BenchRow {
    let mut r = BenchRow {
        problem: problem.into(),
        solver: solver.into(),
        setting,
        error: f64::NAN,
        error_measure: measure.into(),
        steps: 0,
        rhs_evals: 0,
        wall_s: f64::NAN,
        steps_ratio: f64::NAN,
        time_ratio: f64::NAN,
        failure: None,
    };
    match res {
        Ok((run, wall)) => {
            r.error = err(&run.y);
            r.steps = run.steps;
            r.rhs_evals = run.rhs;
            r.wall_s = wall;
        }
        Err(e) => r.failure = Some(e),
    }
    r
}

/// Advances `integ` to `t_end` and collects its final state and work.
fn run_to_end(integ: &mut dyn Integrator, t_end: f64) -> Result<Run, String> {
    integ.advance_to(t_end).map_err(|e| e.to_string())?;
    let work = integ.work();
    Ok(Run {
        y: integ.y().to_vec(),
        steps: work.steps,
        rhs: work.rhs_evals,
    })
}

fn lash_bdf<P: DaeSystem + Clone>(
    sys: &P,
    y0: &[f64],
    yp0: &[f64],
    opts: &BdfOptions,
    t_end: f64,
    repeats: usize,
) -> Result<(Run, f64), String> {
    let (res, wall) = best_of(repeats, || {
        let mut s =
            BdfSolver::new(sys.clone(), 0.0, y0, yp0, &[], opts.clone()).map_err(|e| e.to_string())?;
        run_to_end(&mut s, t_end)
    });
    res.map(|r| (r, wall))
}

fn ratios(rows: &mut [BenchRow]) {
    if let Some(base) = rows.first().cloned() {
        for r in rows.iter_mut() {
            r.steps_ratio = r.steps as f64 / base.steps as f64;
            r.time_ratio = r.wall_s / base.wall_s;
        }
    }
}

/// The turning stiff spring (damped), t ∈ [0, 10] s: lash BDF, diffsol BDF, Dormand–Prince
/// and symplectic Euler.
pub fn stiff_spring_rows(repeats: usize) -> Vec<BenchRow> {
    let sys = stiff_spring::StiffSpring::validation(true);
    let (y0, yp0) = sys.initial_values();
    let tol = 1e-6;
    let measure = "|theta(10) - theta_ref| rad";
    let err = |y: &[f64]| (stiff_spring::StiffSpring::angle(y) - reference::STIFF_SPRING_THETA_T10).abs();
    let name = "turning stiff spring";
    let mut rows = vec![row(
        name,
        "lash BDF",
        format!("rtol=atol={tol:e}"),
        measure,
        lash_bdf(
            &sys,
            &y0,
            &yp0,
            &BdfOptions::with_tolerances(tol, tol),
            10.0,
            repeats,
        ),
        err,
    )];
    #[cfg(feature = "peers")]
    {
        let (res, wall) = best_of(repeats.min(2), || {
            crate::peers::diffsol_dae(sys, &[1.0, 1.0, sys.m, sys.m], &y0, tol, &[tol], 10.0)
        });
        rows.push(row(
            name,
            "diffsol BDF 0.18",
            format!("rtol=atol={tol:e}"),
            measure,
            res.map(|r| (Run::from(r), wall)),
            err,
        ));
    }
    let (res, wall) = best_of(repeats.min(2), || {
        let mut d = Dopri5::new(
            sys,
            0.0,
            &y0,
            &[],
            Dopri5Options {
                rtol: tol,
                atol: tol,
                ..Default::default()
            },
        )
        .map_err(|e| e.to_string())?;
        run_to_end(&mut d, 10.0)
    });
    rows.push(row(
        name,
        "Dormand-Prince 5(4)",
        format!("rtol=atol={tol:e}"),
        measure,
        res.map(|r| (r, wall)),
        err,
    ));
    // Symplectic Euler: a step near its stability limit for the stiff, critically damped
    // spring (h·ω = 0.5) — it cannot go larger whatever accuracy is asked.
    let omega = (sys.k / sys.m).sqrt();
    let h = 0.5 / omega;
    let (res, wall) = best_of(1, || {
        let mut s =
            SymplecticEuler::new(sys, 0.0, &y0[0..2], &y0[2..4], &[], h).map_err(|e| e.to_string())?;
        // The state is the positions followed by the velocities, as y0.
        run_to_end(&mut s, 10.0)
    });
    rows.push(row(
        name,
        "symplectic Euler",
        format!("h={h:.2e} (near the stability limit)"),
        measure,
        res.map(|r| (r, wall)),
        err,
    ));
    ratios(&mut rows);
    rows
}

/// Andrews at rtol = atol = 1e-6: lash's BDF on four formulations and diffsol's BDF on the
/// index-1 one (the only one in its M·y' = f form).
pub fn andrews_rows(repeats: usize) -> Vec<BenchRow> {
    andrews_rows_at(1e-6, repeats)
}

/// Andrews' squeezer at one tolerance (rtol = atol = `tol`) for every lash formulation and
/// diffsol, with ratios to lash's index-2 + projection run.
pub fn andrews_rows_at(tol: f64, repeats: usize) -> Vec<BenchRow> {
    let (y0, yp0) = andrews::initial_values();
    let measure = "max relative angle error at 0.03 s";
    let err = |y: &[f64]| andrews::angle_error(y);
    let name = "andrews";
    let suppressed = BdfOptions {
        suppress_algebraic: true,
        ..BdfOptions::with_tolerances(tol, tol)
    };
    let plain = BdfOptions::with_tolerances(tol, tol);
    let two = andrews::Andrews {
        index: andrews::AndrewsIndex::Two,
        project: true,
    };
    let mut rows = vec![row(
        name,
        "lash BDF idx2+proj",
        format!("rtol=atol={tol:e}"),
        measure,
        lash_bdf(&two, &y0, &yp0, &suppressed, reference::ANDREWS_T_END, repeats),
        err,
    )];
    let two_raw = andrews::Andrews::new(andrews::AndrewsIndex::Two);
    rows.push(row(
        name,
        "lash BDF idx2",
        format!("rtol=atol={tol:e}"),
        measure,
        lash_bdf(
            &two_raw,
            &y0,
            &yp0,
            &suppressed,
            reference::ANDREWS_T_END,
            repeats,
        ),
        err,
    ));
    let (yg, ypg) = andrews::initial_values_for(andrews::AndrewsIndex::Ggl);
    let ggl = andrews::Andrews::new(andrews::AndrewsIndex::Ggl);
    rows.push(row(
        name,
        "lash BDF GGL",
        format!("rtol=atol={tol:e}"),
        measure,
        lash_bdf(&ggl, &yg, &ypg, &suppressed, reference::ANDREWS_T_END, repeats),
        err,
    ));
    let one = andrews::Andrews {
        index: andrews::AndrewsIndex::One,
        project: true,
    };
    rows.push(row(
        name,
        "lash BDF idx1+proj",
        format!("rtol=atol={tol:e}"),
        measure,
        lash_bdf(&one, &y0, &yp0, &plain, reference::ANDREWS_T_END, repeats),
        err,
    ));
    #[cfg(feature = "peers")]
    {
        let sys = andrews::Andrews::new(andrews::AndrewsIndex::One);
        let mass: Vec<f64> = (0..27).map(|i| if i < 14 { 1.0 } else { 0.0 }).collect();
        let (res, wall) = best_of(repeats, || {
            crate::peers::diffsol_dae(sys.clone(), &mass, &y0, tol, &[tol], reference::ANDREWS_T_END)
        });
        rows.push(row(
            name,
            "diffsol BDF idx1",
            format!("rtol=atol={tol:e}"),
            measure,
            res.map(|r| (Run::from(r), wall)),
            err,
        ));
    }
    ratios(&mut rows);
    rows
}

/// Robertson to 1e11 at rtol 1e-6 and the validation's absolute tolerances: lash BDF and
/// diffsol BDF.
pub fn robertson_rows(repeats: usize) -> Vec<BenchRow> {
    use crate::validation::ROBERTSON_ATOL;
    let (y0, yp0) = robertson::Robertson::initial_values();
    let rtol = 1e-6;
    let setting = format!("rtol={rtol:e} atol=(1e-14,1e-20,1e-14)");
    let measure = "max relative error at t = 1e11";
    let err = robertson::Robertson::relative_error;
    let name = "robertson";
    let opts = BdfOptions {
        atol: crate::dae::AbsTol::Vector(ROBERTSON_ATOL.to_vec()),
        ..BdfOptions::with_tolerances(rtol, 1.0)
    };
    let mut rows = vec![row(
        name,
        "lash BDF",
        setting.clone(),
        measure,
        lash_bdf(
            &robertson::Robertson,
            &y0,
            &yp0,
            &opts,
            reference::ROBERTSON_T_END,
            repeats,
        ),
        err,
    )];
    #[cfg(feature = "peers")]
    {
        let (res, wall) = best_of(repeats, || {
            crate::peers::diffsol_dae(
                robertson::Robertson,
                &[1.0, 1.0, 0.0],
                &y0,
                rtol,
                &ROBERTSON_ATOL,
                reference::ROBERTSON_T_END,
            )
        });
        rows.push(row(
            name,
            "diffsol BDF 0.18",
            setting,
            measure,
            res.map(|r| (Run::from(r), wall)),
            err,
        ));
    }
    ratios(&mut rows);
    rows
}

/// All DAE-layer benchmarks.
pub fn bench_dae(repeats: usize) -> Vec<BenchRow> {
    let mut rows = stiff_spring_rows(repeats);
    rows.extend(andrews_rows(repeats));
    rows.extend(robertson_rows(repeats));
    rows
}
