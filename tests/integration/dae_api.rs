//! The public DAE API: results, events, restarts, dense output, initial conditions, and
//! clear errors (never panics) on bad input or solver failure.

use lash::dae::explicit::{Dopri5, Dopri5Options, OdeSystem, SecondOrderSystem, SymplecticEuler};
use lash::dae::{
    AbsTol, BdfOptions, BdfSolver, DaeError, DaeSystem, EvalError, Integrator, JacobianSource,
    LinearSolverKind, Outcome, VarKind,
};
use lash::sparse::CscPattern;

/// y' = -k·y (one component), analytic or finite-difference Jacobian.
#[derive(Clone)]
struct Decay {
    k: f64,
    analytic: bool,
}

impl DaeSystem for Decay {
    fn dim(&self) -> usize {
        1
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] + self.k * y[0];
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(1, 1)
    }
    fn jacobian_source(&self) -> JacobianSource {
        if self.analytic {
            JacobianSource::Analytic
        } else {
            JacobianSource::FiniteDifference
        }
    }
    fn jacobian(
        &mut self,
        _t: f64,
        _y: &[f64],
        _yp: &[f64],
        _p: &[f64],
        alpha: f64,
        v: &mut [f64],
    ) -> Result<(), EvalError> {
        v[0] = self.k + alpha;
        Ok(())
    }
}

/// Harmonic oscillator with parameters p = (ω²), plus an event when x crosses zero.
struct Oscillator;

impl DaeSystem for Oscillator {
    fn dim(&self) -> usize {
        2
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] - y[1];
        r[1] = yp[1] + p[0] * y[0];
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(2, 2)
    }
    fn num_events(&self) -> usize {
        1
    }
    fn events(&mut self, _t: f64, y: &[f64], _yp: &[f64], _p: &[f64], g: &mut [f64]) {
        g[0] = y[0];
    }
}

fn tight() -> BdfOptions {
    BdfOptions::with_tolerances(1e-9, 1e-11)
}

#[test]
fn exponential_decay_analytic_and_fd_agree_with_exact() {
    for analytic in [true, false] {
        let mut s = BdfSolver::new(Decay { k: 2.0, analytic }, 0.0, &[1.0], &[-2.0], &[], tight()).unwrap();
        assert_eq!(s.solve_to(3.0).unwrap(), Outcome::Reached);
        let exact = (-6.0f64).exp();
        assert!(
            (s.y()[0] - exact).abs() < 1e-8,
            "analytic={analytic}: {} vs {exact}",
            s.y()[0]
        );
        assert_eq!(s.t(), 3.0);
        let st = s.stats();
        assert!(st.steps > 10 && st.lu_factorisations >= 1 && st.newton_iters >= st.steps);
        assert!(st.residual_evals > st.steps);
    }
}

#[test]
fn output_at_requested_times_uses_dense_output_and_is_accurate() {
    let mut s = BdfSolver::new(Oscillator, 0.0, &[1.0, 0.0], &[0.0, -1.0], &[1.0], tight()).unwrap();
    for k in 1..=50 {
        let t = k as f64 * 0.1;
        // Events interrupt; keep calling until the output time is reached.
        while s.solve_to(t).unwrap() != Outcome::Reached {}
        assert!((s.t() - t).abs() < 1e-14);
        assert!((s.y()[0] - t.cos()).abs() < 1e-6, "t = {t}");
        assert!((s.yp()[0] + t.sin()).abs() < 1e-5, "t = {t}");
    }
    // The integrator steps past output times and interpolates back.
    assert!(s.t_internal() >= 5.0);
    let (y, _) = s.dense_output(s.t_internal()).unwrap();
    assert!((y[0] - s.t_internal().cos()).abs() < 1e-6);
    assert!(matches!(s.dense_output(-1.0), Err(DaeError::OutOfRange { .. })));
}

#[test]
fn events_are_located_by_root_finding() {
    let mut s = BdfSolver::new(Oscillator, 0.0, &[1.0, 0.0], &[0.0, -1.0], &[1.0], tight()).unwrap();
    let mut roots = vec![];
    loop {
        match s.solve_to(10.0).unwrap() {
            Outcome::Event { indices } => {
                assert_eq!(indices, vec![0]);
                roots.push(s.t());
            }
            Outcome::Reached => break,
            Outcome::StopTime => unreachable!(),
        }
    }
    // cos t = 0 at π/2 + kπ: 3 roots in [0, 10].
    assert_eq!(roots.len(), 3, "{roots:?}");
    for (k, r) in roots.iter().enumerate() {
        let exact = std::f64::consts::FRAC_PI_2 + k as f64 * std::f64::consts::PI;
        assert!((r - exact).abs() < 1e-6, "root {k}: {r} vs {exact}");
    }
}

#[test]
fn stop_time_is_never_passed_and_restart_continues_at_order_one() {
    let mut opts = tight();
    opts.stop_time = Some(1.0);
    let mut s = BdfSolver::new(
        Decay {
            k: 1.0,
            analytic: true,
        },
        0.0,
        &[1.0],
        &[-1.0],
        &[],
        opts,
    )
    .unwrap();
    assert_eq!(s.solve_to(2.0).unwrap(), Outcome::StopTime);
    assert_eq!(s.t(), 1.0);
    assert_eq!(s.t_internal(), 1.0);
    // A discontinuity at t = 1: the rate changes; restart from the current state.
    s.set_stop_time(None);
    s.system_mut().k = 3.0;
    let y1 = s.y()[0];
    assert!(s.stats().last_order > 1, "order had risen before the restart");
    s.restart_from(1.0, &[y1], &[-3.0 * y1]).unwrap();
    s.step(2.0).unwrap();
    assert_eq!(
        s.stats().last_order,
        1,
        "the first step after a restart is order 1"
    );
    assert_eq!(s.solve_to(2.0).unwrap(), Outcome::Reached);
    let exact = (-1.0f64).exp() * (-3.0f64).exp();
    assert!((s.y()[0] - exact).abs() < 1e-8, "{} vs {exact}", s.y()[0]);
}

/// Index-1: y1' = -y1 + y2, 0 = y2 - sin(t) (algebraic y2).
struct SemiExplicit;

impl DaeSystem for SemiExplicit {
    fn dim(&self) -> usize {
        2
    }
    fn residual(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] + y[0] - y[1];
        r[1] = y[1] - t.sin();
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::from_entries(2, 2, [(0, 0), (0, 1), (1, 1)]).unwrap()
    }
    fn var_kinds(&self) -> Vec<VarKind> {
        vec![VarKind::Differential, VarKind::Algebraic]
    }
}

#[test]
fn calc_ic_makes_index1_initial_values_consistent() {
    // Wrong algebraic value and derivative at t0 = 1.
    let mut s = BdfSolver::new(SemiExplicit, 1.0, &[2.0, 0.0], &[0.0, 0.0], &[], tight()).unwrap();
    let iters = s.calc_ic(1e-3).unwrap();
    assert!(iters >= 1);
    assert!((s.y()[1] - 1f64.sin()).abs() < 1e-10);
    assert!((s.yp()[0] - (-2.0 + 1f64.sin())).abs() < 1e-8);
    s.solve_to(2.0).unwrap();
    // Exact: y1 = C e^{-t} + (sin t − cos t)/2.
    let c = (2.0 - (1f64.sin() - 1f64.cos()) / 2.0) * 1f64.exp();
    let exact = c * (-2f64).exp() + (2f64.sin() - 2f64.cos()) / 2.0;
    assert!((s.y()[0] - exact).abs() < 1e-7);
}

#[test]
fn inconsistent_initial_values_are_reported_not_integrated() {
    let mut s = BdfSolver::new(SemiExplicit, 1.0, &[2.0, 0.0], &[0.0, 0.0], &[], tight()).unwrap();
    let e = s.solve_to(2.0).unwrap_err();
    match &e {
        DaeError::InconsistentInitialValues { culprits, .. } => assert_eq!(culprits[0].index, 1),
        other => panic!("unexpected {other:?}"),
    }
    assert!(e.to_string().contains("inconsistent"));
}

#[test]
fn bad_tolerances_and_dimensions_are_errors() {
    let sys = || Decay {
        k: 1.0,
        analytic: true,
    };
    for (rtol, atol) in [
        (0.0, 1e-6),
        (-1e-6, 1e-6),
        (1e-6, 0.0),
        (f64::NAN, 1e-6),
        (1e-6, -1.0),
    ] {
        let r = BdfSolver::new(
            sys(),
            0.0,
            &[1.0],
            &[-1.0],
            &[],
            BdfOptions::with_tolerances(rtol, atol),
        );
        assert!(
            matches!(r, Err(DaeError::InvalidInput(_))),
            "rtol {rtol} atol {atol}"
        );
    }
    let mut o = tight();
    o.atol = AbsTol::Vector(vec![1e-6, 1e-6]);
    assert!(matches!(
        BdfSolver::new(sys(), 0.0, &[1.0], &[-1.0], &[], o),
        Err(DaeError::InvalidInput(_))
    ));
    assert!(matches!(
        BdfSolver::new(sys(), 0.0, &[1.0, 2.0], &[-1.0], &[], tight()),
        Err(DaeError::InvalidInput(_))
    ));
    assert!(matches!(
        BdfSolver::new(sys(), 0.0, &[f64::NAN], &[-1.0], &[], tight()),
        Err(DaeError::InvalidInput(_))
    ));
    for (ceiling, relaxation) in [(0.0, 1.2), (f64::NAN, 1.2), (0.5, 0.9), (0.5, f64::INFINITY)] {
        let mut o = tight();
        o.step_ceiling_after_newton_failure = ceiling;
        o.step_ceiling_relaxation = relaxation;
        assert!(
            matches!(
                BdfSolver::new(sys(), 0.0, &[1.0], &[-1.0], &[], o),
                Err(DaeError::InvalidInput(_))
            ),
            "ceiling {ceiling} relaxation {relaxation}"
        );
    }
    let mut o = tight();
    o.max_order = 7;
    assert!(matches!(
        BdfSolver::new(sys(), 0.0, &[1.0], &[-1.0], &[], o),
        Err(DaeError::InvalidInput(_))
    ));
    let mut o = tight();
    o.anderson_depth = 9;
    assert!(matches!(
        BdfSolver::new(sys(), 0.0, &[1.0], &[-1.0], &[], o),
        Err(DaeError::InvalidInput(m)) if m.contains("anderson_depth")
    ));
    let mut s = BdfSolver::new(sys(), 0.0, &[1.0], &[-1.0], &[], tight()).unwrap();
    assert!(matches!(
        s.solve_to(f64::INFINITY),
        Err(DaeError::InvalidInput(_))
    ));
    assert!(matches!(s.solve_to(0.0), Err(DaeError::InvalidInput(_))));
}

/// A residual whose iteration matrix is singular: the second unknown appears nowhere.
struct Singular;

impl DaeSystem for Singular {
    fn dim(&self) -> usize {
        2
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] + y[0];
        r[1] = y[0] - 1.0;
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(2, 2)
    }
    fn component_name(&self, i: usize) -> String {
        ["x", "ghost"][i].to_string()
    }
}

#[test]
fn singular_iteration_matrix_is_an_error_naming_the_unknown() {
    let mut s = BdfSolver::new(Singular, 0.0, &[1.0, 0.0], &[-1.0, 0.0], &[], tight()).unwrap();
    let e = s.solve_to(1.0).unwrap_err();
    match &e {
        DaeError::LinearSolve { culprits, .. } => {
            assert!(culprits.iter().any(|c| c.name.contains("ghost")), "{e}");
        }
        other => panic!("unexpected {other:?}"),
    }
}

/// A residual that turns NaN after t = 0.5.
struct GoesNan;

impl DaeSystem for GoesNan {
    fn dim(&self) -> usize {
        1
    }
    fn residual(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] + y[0] + if t > 0.5 { f64::NAN } else { 0.0 };
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(1, 1)
    }
}

#[test]
fn nan_residual_is_an_error_with_time_not_a_panic() {
    let mut s = BdfSolver::new(GoesNan, 0.0, &[1.0], &[-1.0], &[], tight()).unwrap();
    let e = s.solve_to(1.0).unwrap_err();
    match e {
        DaeError::NonFiniteResidual { t, ref culprits } => {
            assert!((0.4..=0.5).contains(&t), "{t}");
            assert_eq!(culprits[0].index, 0);
        }
        other => panic!("unexpected {other:?}"),
    }
}

/// A callback failing fatally.
struct Fails;

impl DaeSystem for Fails {
    fn dim(&self) -> usize {
        1
    }
    fn residual(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        if t > 0.2 {
            return Err(EvalError::Fatal("sensor model undefined past 0.2 s".into()));
        }
        r[0] = yp[0] + y[0];
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(1, 1)
    }
}

#[test]
fn fatal_callback_error_stops_with_its_message() {
    let mut s = BdfSolver::new(Fails, 0.0, &[1.0], &[-1.0], &[], tight()).unwrap();
    let e = s.solve_to(1.0).unwrap_err();
    assert!(matches!(e, DaeError::Evaluation { .. }));
    assert!(e.to_string().contains("sensor model undefined"));
}

#[test]
fn step_limit_ends_the_run_with_an_error_not_a_hang() {
    let mut o = tight();
    o.max_steps = 5;
    let mut s = BdfSolver::new(
        Decay {
            k: 1.0,
            analytic: true,
        },
        0.0,
        &[1.0],
        &[-1.0],
        &[],
        o,
    )
    .unwrap();
    assert!(matches!(
        s.solve_to(100.0),
        Err(DaeError::TooManySteps { max_steps: 5, .. })
    ));
}

#[test]
fn stiff_problem_takes_few_steps() {
    // y' = -1e6 (y - cos t): stiff, smooth solution; BDF needs O(100) steps, not O(1e6).
    struct Stiff;
    impl DaeSystem for Stiff {
        fn dim(&self) -> usize {
            1
        }
        fn residual(
            &mut self,
            t: f64,
            y: &[f64],
            yp: &[f64],
            _p: &[f64],
            r: &mut [f64],
        ) -> Result<(), EvalError> {
            r[0] = yp[0] + 1e6 * (y[0] - t.cos());
            Ok(())
        }
        fn jacobian_pattern(&self) -> CscPattern {
            CscPattern::dense(1, 1)
        }
    }
    let mut s = BdfSolver::new(
        Stiff,
        0.0,
        &[1.0],
        &[0.0],
        &[],
        BdfOptions::with_tolerances(1e-6, 1e-8),
    )
    .unwrap();
    s.solve_to(10.0).unwrap();
    assert!(s.stats().steps < 1000, "{}", s.stats().steps);
    assert!((s.y()[0] - 10f64.cos()).abs() < 1e-5);
}

/// Van der Pol's oscillator in Hairer & Wanner's stiff scaling (II, IV.1; ε = 1e-5): y' = v,
/// ε·v' = (1 − y²)·v − y. Stiff on the slow branches, with jumps that the steps must resolve:
/// the Jacobian turns along the cycle.
struct VanDerPol;

const VDP_EPS: f64 = 1e-5;

impl DaeSystem for VanDerPol {
    fn dim(&self) -> usize {
        2
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] - y[1];
        r[1] = VDP_EPS * yp[1] - ((1.0 - y[0] * y[0]) * y[1] - y[0]);
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(2, 2)
    }
}

/// (y, v) at t = 2 (past the first jump) and the run's statistics.
fn van_der_pol(opts: BdfOptions) -> (Vec<f64>, lash::dae::Statistics) {
    let (y0, v0) = (2.0, -0.66);
    let vp0 = ((1.0 - y0 * y0) * v0 - y0) / VDP_EPS;
    let mut s = BdfSolver::new(VanDerPol, 0.0, &[y0, v0], &[v0, vp0], &[], opts).unwrap();
    s.solve_to(2.0).unwrap();
    (s.y().to_vec(), *s.stats())
}

#[test]
fn an_accelerated_newton_iteration_gives_the_plain_iterations_solution() {
    let reference = van_der_pol(BdfOptions::with_tolerances(1e-10, 1e-10)).0;
    let plain = van_der_pol(BdfOptions::with_tolerances(1e-6, 1e-6));
    let accelerated = van_der_pol(BdfOptions {
        anderson_depth: 3,
        ..BdfOptions::with_tolerances(1e-6, 1e-6)
    });
    for (name, (y, st)) in [("plain", &plain), ("accelerated", &accelerated)] {
        let err = (y[0] - reference[0]).abs();
        // Both reach 1.5e-5 (measured); the bound leaves room for round-off elsewhere.
        assert!(
            err < 1e-4,
            "{name}: y = {} against {}, {} steps",
            y[0],
            reference[0],
            st.steps
        );
    }
    // The acceleration acts (the iterates differ, same problem and tolerances).
    assert_ne!(plain.0, accelerated.0);
}

/// y' = −k·(y − cos t) whose analytic Jacobian understates the stiffness k by 1.8× (as a
/// matrix kept from before a contact stiffened would): the modified Newton iteration then
/// contracts at only ~0.8 while the step is large.
struct WrongJacobian;

const WRONG_K: f64 = 1e4;

impl DaeSystem for WrongJacobian {
    fn dim(&self) -> usize {
        1
    }
    fn residual(
        &mut self,
        t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] + WRONG_K * (y[0] - t.cos());
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(1, 1)
    }
    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::Analytic
    }
    fn jacobian(
        &mut self,
        _t: f64,
        _y: &[f64],
        _yp: &[f64],
        _p: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        values[0] = alpha + WRONG_K / 1.8;
        Ok(())
    }
}

#[test]
fn with_a_wrong_matrix_the_accelerated_iteration_converges_where_the_plain_one_forces_tiny_steps() {
    let run = |depth: usize| {
        let opts = BdfOptions {
            anderson_depth: depth,
            ..BdfOptions::with_tolerances(1e-6, 1e-8)
        };
        let mut s = BdfSolver::new(WrongJacobian, 0.0, &[1.0], &[0.0], &[], opts).unwrap();
        s.solve_to(10.0).unwrap();
        (s.y()[0], *s.stats())
    };
    let (y_plain, plain) = run(0);
    let (y_acc, acc) = run(3);
    // Both solve the problem (y follows cos t within the tolerance, to O(1/k) lag).
    for y in [y_plain, y_acc] {
        assert!((y - 10f64.cos()).abs() < 1e-3, "y(10) = {y}");
    }
    // The plain iteration contracts at ~0.8 and fails at every large step, so the steps
    // shrink until c_j = 1/h dwarfs k; the accelerated one (a secant step on this linear
    // problem) converges at the steps the error test allows. Measured: 3 703 steps and
    // 1 698 Newton failures plain, 121 and none accelerated.
    assert!(
        acc.newton_failures * 10 < plain.newton_failures.max(1),
        "{acc:?} {plain:?}"
    );
    assert!(acc.steps * 3 < plain.steps, "{acc:?} {plain:?}");
}

/// Index-1, with a model domain: x' = -x, 0 = z - 2x, where the residual fails fatally for
/// z > 1.5 (a sensor model that is undefined there).
struct SaturatingSensor;

impl DaeSystem for SaturatingSensor {
    fn dim(&self) -> usize {
        2
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        if y[1] > 1.5 {
            return Err(EvalError::Fatal(format!("sensor saturated at z = {}", y[1])));
        }
        r[0] = yp[0] + y[0];
        r[1] = y[1] - 2.0 * y[0];
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::from_entries(2, 2, [(0, 0), (1, 0), (1, 1)]).unwrap()
    }
    // Analytic, so no finite-difference probe comes near the saturation.
    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::Analytic
    }
    fn jacobian(
        &mut self,
        _t: f64,
        _y: &[f64],
        _yp: &[f64],
        _p: &[f64],
        alpha: f64,
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        values.copy_from_slice(&[1.0 + alpha, -2.0, 1.0]);
        Ok(())
    }
    fn var_kinds(&self) -> Vec<VarKind> {
        vec![VarKind::Differential, VarKind::Algebraic]
    }
}

#[test]
fn fatal_evaluation_error_in_the_initial_condition_solve_is_fatal() {
    // The first Newton update of calc_ic moves z from 0 to 2, where the residual fails
    // fatally: the solve must stop with that error, not shorten the update and go on.
    let mut s = BdfSolver::new(SaturatingSensor, 0.0, &[1.0, 0.0], &[0.0, 0.0], &[], tight()).unwrap();
    let e = s.calc_ic(1e-3).unwrap_err();
    assert!(matches!(e, DaeError::Evaluation { .. }), "{e:?}");
    assert!(e.to_string().contains("sensor saturated at z = 2"), "{e}");
}

/// x' = -x, with an analytic Jacobian that fails fatally or recoverably.
struct JacobianFails {
    fatal: bool,
}

impl DaeSystem for JacobianFails {
    fn dim(&self) -> usize {
        1
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] + y[0];
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(1, 1)
    }
    fn jacobian_source(&self) -> JacobianSource {
        JacobianSource::Analytic
    }
    fn jacobian(
        &mut self,
        _t: f64,
        _y: &[f64],
        _yp: &[f64],
        _p: &[f64],
        _alpha: f64,
        _values: &mut [f64],
    ) -> Result<(), EvalError> {
        let m = "Jacobian table missing".to_string();
        Err(if self.fatal {
            EvalError::Fatal(m)
        } else {
            EvalError::Recoverable(m)
        })
    }
}

#[test]
fn a_failing_jacobian_ends_the_initial_condition_solve_and_check_with_its_message() {
    for fatal in [true, false] {
        // calc_ic and the consistency check at the start build their matrices through the
        // same set-up path; neither counts a factorisation that did not happen.
        let mut s = BdfSolver::new(JacobianFails { fatal }, 0.0, &[1.0], &[-1.0], &[], tight()).unwrap();
        let e = s.calc_ic(1e-3).unwrap_err();
        assert!(matches!(e, DaeError::Evaluation { .. }), "{e:?}");
        assert!(e.to_string().contains("Jacobian table missing"), "{e}");
        let mut s = BdfSolver::new(JacobianFails { fatal }, 0.0, &[1.0], &[-1.0], &[], tight()).unwrap();
        let e = s.solve_to(1.0).unwrap_err();
        assert!(matches!(e, DaeError::Evaluation { .. }), "{e:?}");
        assert!(e.to_string().contains("Jacobian table missing"), "{e}");
        assert_eq!(s.stats().lu_factorisations, 0);
        assert_eq!(s.stats().jacobian_evals, 1);
    }
}

#[test]
fn dense_and_sparse_lu_give_the_same_solution_of_a_small_dae() {
    // The index-1 problem with an initial-condition solve, through each linear solver.
    let run = |kind: LinearSolverKind| {
        let opts = BdfOptions {
            linear_solver: kind,
            ..tight()
        };
        let mut s = BdfSolver::new(SemiExplicit, 1.0, &[2.0, 0.0], &[0.0, 0.0], &[], opts).unwrap();
        s.calc_ic(1e-3).unwrap();
        s.solve_to(2.0).unwrap();
        (s.y().to_vec(), *s.stats())
    };
    let (y_sparse, st_sparse) = run(LinearSolverKind::SparseLu);
    let (y_dense, st_dense) = run(LinearSolverKind::DenseLu);
    for i in 0..2 {
        assert!(
            (y_sparse[i] - y_dense[i]).abs() < 1e-12,
            "{y_sparse:?} vs {y_dense:?}"
        );
    }
    assert_eq!(st_sparse.steps, st_dense.steps);
    assert!(st_dense.lu_factorisations > 0);
}

/// The harmonic oscillator q'' = -q in every form the integrators take.
#[derive(Clone, Copy)]
struct Harmonic;

impl DaeSystem for Harmonic {
    fn dim(&self) -> usize {
        2
    }
    fn residual(
        &mut self,
        _t: f64,
        y: &[f64],
        yp: &[f64],
        _p: &[f64],
        r: &mut [f64],
    ) -> Result<(), EvalError> {
        r[0] = yp[0] - y[1];
        r[1] = yp[1] + y[0];
        Ok(())
    }
    fn jacobian_pattern(&self) -> CscPattern {
        CscPattern::dense(2, 2)
    }
}

impl OdeSystem for Harmonic {
    fn dim(&self) -> usize {
        2
    }
    fn rhs(&mut self, _t: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) -> Result<(), EvalError> {
        dy[0] = y[1];
        dy[1] = -y[0];
        Ok(())
    }
}

impl SecondOrderSystem for Harmonic {
    fn npos(&self) -> usize {
        1
    }
    fn acceleration(
        &mut self,
        _t: f64,
        q: &[f64],
        _v: &[f64],
        _p: &[f64],
        a: &mut [f64],
    ) -> Result<(), EvalError> {
        a[0] = -q[0];
        Ok(())
    }
}

/// Samples `integ` at t = 0.5, 1, …, 3 and returns the largest distance of (q, v) from
/// (cos t, −sin t), checking the time and work counters on the way.
fn oscillator_error(integ: &mut dyn Integrator) -> f64 {
    let mut err: f64 = 0.0;
    let mut steps = 0;
    for k in 1..=6 {
        let t = 0.5 * k as f64;
        integ.advance_to(t).unwrap();
        assert_eq!(integ.t(), t);
        let y = integ.y();
        assert_eq!(y.len(), 2);
        err = err.max((y[0] - t.cos()).abs()).max((y[1] + t.sin()).abs());
        let work = integ.work();
        assert!(work.steps > steps && work.rhs_evals >= work.steps, "{work:?}");
        steps = work.steps;
    }
    err
}

#[test]
fn every_integrator_runs_the_same_ode_through_the_trait_and_agrees() {
    let y0 = [1.0, 0.0];
    let tol = 1e-8;
    let mut bdf = BdfSolver::new(
        Harmonic,
        0.0,
        &y0,
        &[0.0, -1.0],
        &[],
        BdfOptions::with_tolerances(tol, tol),
    )
    .unwrap();
    let dopri_opts = Dopri5Options {
        rtol: tol,
        atol: tol,
        ..Default::default()
    };
    let mut dopri = Dopri5::new(Harmonic, 0.0, &y0, &[], dopri_opts).unwrap();
    let h = 1e-4;
    let mut euler = SymplecticEuler::new(Harmonic, 0.0, &y0[..1], &y0[1..], &[], h).unwrap();
    // (integrator, what its tolerance or step promises on this problem)
    let mut runs: Vec<(&str, &mut dyn Integrator, f64)> = vec![
        ("lash BDF", &mut bdf, 1e-5),
        ("Dormand-Prince", &mut dopri, 1e-6),
        // First order: the error is O(h) over a few periods.
        ("symplectic Euler", &mut euler, 10.0 * h),
    ];
    for (name, integ, bound) in runs.iter_mut() {
        let err = oscillator_error(*integ);
        assert!(err < *bound, "{name}: error {err:e} above {bound:e}");
    }
    // Implicit work is counted, explicit has none.
    let bdf_work = Integrator::work(&bdf);
    assert!(bdf_work.factorisations > 0 && bdf_work.jacobian_evals > 0 && bdf_work.newton_iters > 0);
    assert_eq!(bdf_work.factorisations, bdf.stats().lu_factorisations);
    let explicit_work = Integrator::work(&dopri);
    assert_eq!((explicit_work.factorisations, explicit_work.newton_iters), (0, 0));
    // The trait's state is the integrator's own: symplectic Euler's is q then v.
    assert_eq!(Integrator::y(&euler), &[euler.q()[0], euler.v()[0]]);
    #[cfg(feature = "peers")]
    {
        let f = |_t: f64, y: &[f64], dy: &mut [f64]| {
            dy[0] = y[1];
            dy[1] = -y[0];
        };
        let (err, work) = lash::peers::with_diffsol_bdf(f, &[1.0, 1.0], &y0, tol, &[tol], |integ| {
            (oscillator_error(integ), integ.work())
        })
        .unwrap();
        assert!(err < 1e-5, "diffsol BDF: error {err:e}");
        assert!(work.factorisations > 0 && work.newton_iters > 0, "{work:?}");
    }
}
