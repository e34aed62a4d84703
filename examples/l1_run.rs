//! The whole L1 run of issue #16 alone (the MR2120 clearance model along the paper's
//! trajectory, rtol 1e-4, atol 1e-6), for profiling and for sweeps of the integrator's
//! settings: no reference run of its own, one line per repetition with the wall time, the
//! integrator's counters and phase timers, and (with `LASH_REF`) the distance from a
//! reference path.
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
//! `LASH_MEASURE_RATE` (`true`/`false`, `measure_rate_with_stale_jacobian`). `LASH_VEL_ATOL`
//! multiplies the velocities' absolute tolerance (m/s; the positions' stays rtol/100 m).
//! Accuracy: `LASH_DUMP=FILE` writes the platform centre's path (m, one point per sample,
//! JSON); `LASH_REF=FILE` compares the run's path with such a file (the largest distance up
//! to `LASH_ERR_UNTIL` s, default the whole run):
//!
//! ```text
//! LASH_RTOL=1e-9 LASH_T_END=1.5 LASH_DUMP=ref.json cargo run --release --example l1_run
//! LASH_RTOL=3e-7 LASH_T_END=1.5 LASH_REF=ref.json cargo run --release --example l1_run
//! ```

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
    let platform = model.platform;
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
        if let Some(f) = env::<f64>("LASH_VEL_ATOL") {
            let lay = lash::multibody::Layout::of(&mech);
            let mut a = vec![rtol / 100.0; lay.dim()];
            for i in lay.y_w() {
                a[i] *= f;
            }
            opts.bdf.atol = lash::dae::AbsTol::Vector(a);
        }
        opts.singularity_warning = 0.0;
        let b = &mut opts.bdf;
        set(&mut b.anderson_depth, "LASH_ANDERSON");
        set(&mut b.max_steps_between_jacobians, "LASH_JAC_AGE");
        set(&mut b.jacobian_refresh_rate, "LASH_REFRESH_RATE");
        set(&mut b.max_jacobian_refreshes_in_solve, "LASH_REFRESHES");
        set(&mut b.max_newton_iters, "LASH_MAX_NEWTON");
        set(&mut b.measure_rate_with_stale_jacobian, "LASH_MEASURE_RATE");
        let mut sim = Simulation::new(mech.clone(), 0.0, opts)?;
        let traj = sim.run(&times, |_| {})?;
        let wall = start.elapsed().as_secs_f64();
        let path: Vec<[f64; 3]> = traj
            .samples
            .iter()
            .map(|s| lash::multibody::Layout::position_of(&s.q, platform))
            .collect();
        if let Ok(f) = std::env::var("LASH_DUMP") {
            std::fs::write(&f, serde_json::to_string(&path)?)?;
        }
        // Against a reference path: the largest distance of the platform's centre over the
        // samples up to LASH_ERR_UNTIL, and apart the first sample's (t = 10 ms, the settling
        // into the play) and the largest after 0.1 s.
        let check = match std::env::var("LASH_REF") {
            Ok(f) => {
                let r: Vec<[f64; 3]> = serde_json::from_str(&std::fs::read_to_string(&f)?)?;
                let until = env::<f64>("LASH_ERR_UNTIL").unwrap_or(f64::INFINITY);
                let (mut worst, mut first, mut late) = (0.0f64, 0.0f64, 0.0f64);
                for (k, (a, b)) in path.iter().zip(&r).enumerate() {
                    if times[k] > until + 1e-9 {
                        break;
                    }
                    let d = (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt();
                    worst = worst.max(d);
                    if k == 0 {
                        first = d;
                    }
                    if times[k] > 0.1 + 1e-9 {
                        late = late.max(d);
                    }
                }
                format!("; against {f} to {until} s: max {worst:.3e} m (t = 0.01 s: {first:.3e} m, after 0.1 s: {late:.3e} m)")
            }
            Err(_) => String::new(),
        };
        let s = sim.stats();
        let p = s.time;
        println!(
            "rtol {rtol:.3e}, 0..{t_end} s: {:.3} s, steps {}, lu {} ({} equilibrated, {} plain), newton {}, etf {} nf {}; residuals {:.3} s, Jacobians {:.3} s, factorisations {:.3} s, solves {:.3} s{check}",
            wall,
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
