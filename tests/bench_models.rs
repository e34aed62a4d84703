//! The benchmark models and harnesses run and measure what they claim (short runs; the
//! timings themselves come from `lash bench`, never from tests).

use lash::bench::mr2120::{bench_mr2120, Mr2120BenchOptions};
use lash::bench::scaling::{bench_scaling, log_slope};
use lash::mechanisms::chain::{chain_design, clearance_chain};

#[test]
fn clearance_chain_has_two_bodies_and_12_dof_per_link_and_its_bearings_engage() {
    let m = clearance_chain(3, &chain_design()).unwrap();
    assert_eq!(m.bodies.len(), 6);
    assert_eq!(m.degrees_of_freedom(), 36);
    assert!(clearance_chain(0, &chain_design()).is_err());
    let s = bench_scaling(&[2, 4], 0.005, |_| {});
    for r in &s.rows {
        assert!(r.failure.is_none(), "{:?}", r.failure);
        // The chain falls into its clearances: contact needs many more steps than free fall.
        assert!(r.steps > 20, "{} steps", r.steps);
        assert_eq!(r.unknowns, 14 * r.bodies);
    }
    assert!((log_slope(&[(10.0, 1.0), (100.0, 10.0), (1000.0, 100.0)]) - 1.0).abs() < 1e-12);
}

#[test]
fn mr2120_bench_measures_both_integrators_against_one_reference() {
    let opts = Mr2120BenchOptions {
        t_end: 0.02,
        dt: 0.01,
        reference_rtol: 1e-7,
        bdf_rtols: vec![1e-4],
        dopri_rtols: vec![1e-5],
        explicit_budget_s: 60.0,
        ..Default::default()
    };
    let b = bench_mr2120(&opts, |_, _| {}).unwrap();
    assert_eq!(b.reference.error, 0.0);
    assert_eq!(b.points.len(), 2);
    for p in &b.points {
        assert!(p.failure.is_none(), "{}: {:?}", p.solver, p.failure);
        assert!(
            p.error.is_finite() && p.error < 1e-4,
            "{}: error {}",
            p.solver,
            p.error
        );
        assert!(p.steps > 0 && p.rhs_evals > p.steps);
        assert!((p.reached_t - 0.02).abs() < 1e-12);
    }
    // The explicit run is an independent formulation and integrator: it agrees with the
    // BDF reference far below the 1 µm target.
    let dp = b.points.iter().find(|p| p.solver.starts_with("Dormand")).unwrap();
    assert!(dp.error < 1e-7, "Dormand-Prince vs reference {}", dp.error);
    assert_eq!(b.comparison.len(), 2);
}
