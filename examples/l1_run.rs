//! The whole L1 run of issue #16 alone (the MR2120 clearance model along the paper's
//! trajectory, rtol 1e-4, atol 1e-6), for profiling and for sweeps of the integrator's
//! settings: no reference run, no output files, one line per repetition with the wall time
//! and the integrator's counters and phase timers.
//!
//! ```text
//! cargo run --release --example l1_run -- [REPETITIONS]
//! LASH_RTOL=9.5e-5 LASH_T_END=3.4 LASH_ANDERSON=3 cargo run --release --example l1_run
//! perf record -g target/release/examples/l1_run 3
//! ```
//! `LASH_RTOL` sets rtol (atol = rtol/100), `LASH_T_END` the end time (s, at most 4),
//! `LASH_ANDERSON` the Newton iteration's Anderson depth (`BdfOptions::anderson_depth`);
//! the matrix reuse's settings: `LASH_JAC_AGE` (`max_steps_between_jacobians`),
//! `LASH_REFRESH_RATE` (`jacobian_refresh_rate`), `LASH_REFRESHES`
//! (`max_jacobian_refreshes_in_solve`), `LASH_MAX_NEWTON` (`max_newton_iters`) and
//! `LASH_MEASURE_RATE` (`true`/`false`, `measure_rate_with_stale_jacobian`).

use lash::bench::mr2120::{bench_mechanism, BENCH_DAMPING};
use lash::mechanisms::mr2120::trajectory::clearance_options;
use lash::multibody::Simulation;
use std::sync::Arc;

fn env<T: std::str::FromStr>(name: &str) -> Option<T> {
    std::env::var(name).ok().and_then(|s| s.parse().ok())
}

/// Sets `field` from the environment variable `name` when it is set and parses.
fn set<T: std::str::FromStr>(field: &mut T, name: &str) {
    if let Some(v) = env(name) {
        *field = v;
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let model = bench_mechanism("L1", BENCH_DAMPING)?;
    let mech = Arc::new(model.mechanism);
    let t_end = env::<f64>("LASH_T_END").unwrap_or(4.0).min(4.0);
    // The benchmark's sampling: every 10 ms.
    let times: Vec<f64> = (1..=(t_end * 100.0).round() as usize)
        .map(|k| k as f64 * 0.01)
        .collect();
    let reps: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    for _ in 0..reps {
        let start = std::time::Instant::now();
        let mut opts = clearance_options();
        let rtol = env::<f64>("LASH_RTOL").unwrap_or(1e-4);
        opts.bdf.rtol = rtol;
        opts.bdf.atol = lash::dae::AbsTol::Scalar(rtol / 100.0);
        opts.singularity_warning = 0.0;
        let b = &mut opts.bdf;
        set(&mut b.anderson_depth, "LASH_ANDERSON");
        set(&mut b.max_steps_between_jacobians, "LASH_JAC_AGE");
        set(&mut b.jacobian_refresh_rate, "LASH_REFRESH_RATE");
        set(&mut b.max_jacobian_refreshes_in_solve, "LASH_REFRESHES");
        set(&mut b.max_newton_iters, "LASH_MAX_NEWTON");
        set(&mut b.measure_rate_with_stale_jacobian, "LASH_MEASURE_RATE");
        let mut sim = Simulation::new(mech.clone(), 0.0, opts)?;
        sim.run(&times, |_| {})?;
        let s = sim.stats();
        let p = s.time;
        println!(
            "rtol {rtol:.3e}, 0..{t_end} s: {:.3} s, steps {}, lu {} ({} equilibrated, {} plain), newton {}, etf {} nf {}; residuals {:.3} s, Jacobians {:.3} s, factorisations {:.3} s, solves {:.3} s",
            start.elapsed().as_secs_f64(),
            s.steps,
            s.lu_factorisations,
            s.lu_equilibrated,
            s.lu_plain_fallbacks,
            s.newton_iters,
            s.error_test_failures,
            s.newton_failures,
            p.residual_s,
            p.jacobian_s,
            p.factorisation_s,
            p.solve_s,
        );
    }
    Ok(())
}
