//! Explicit baselines: Dormand–Prince 5(4) and symplectic Euler.

use lash::dae::explicit::{Dopri5, Dopri5Options, ExplicitError, SymplecticEuler};
use lash::validation::{pendulum, stiff_spring};

#[test]
fn dopri5_matches_rigid_pendulum_reference() {
    let th0 = std::f64::consts::FRAC_PI_4;
    let mut d = Dopri5::new(
        pendulum::AnglePendulum { g_over_l: 9.81 },
        0.0,
        &[th0, 0.0],
        &[],
        Dopri5Options {
            rtol: 1e-11,
            atol: 1e-11,
            ..Default::default()
        },
    )
    .unwrap();
    d.solve_to(10.0).unwrap();
    assert!((d.y()[0] - lash::validation::reference::STIFF_SPRING_THETA_T10).abs() < 1e-9);
}

#[test]
fn symplectic_euler_converges_at_first_order() {
    let sys = stiff_spring::StiffSpring {
        m: 1.0,
        l: 1.0,
        k: 1e4,
        c: 0.0,
        g: 9.81,
    };
    let (y0, _) = sys.initial_values();
    let mut errs = vec![];
    let reference = {
        let mut d = Dopri5::new(
            sys,
            0.0,
            &y0,
            &[],
            Dopri5Options {
                rtol: 1e-11,
                atol: 1e-11,
                ..Default::default()
            },
        )
        .unwrap();
        d.solve_to(1.0).unwrap();
        d.y().to_vec()
    };
    for h in [1e-4, 5e-5] {
        let mut s = SymplecticEuler::new(sys, 0.0, &y0[0..2], &y0[2..4], &[], h).unwrap();
        s.solve_to(1.0).unwrap();
        assert_eq!(s.t(), 1.0);
        errs.push((s.q()[0] - reference[0]).abs());
    }
    // Halving h roughly halves the error (order 1).
    let ratio = errs[0] / errs[1];
    assert!((1.5..3.0).contains(&ratio), "{errs:?}");
}

#[test]
fn explicit_bad_input_is_an_error() {
    let sys = stiff_spring::StiffSpring::validation(true);
    assert!(matches!(
        SymplecticEuler::new(sys, 0.0, &[1.0], &[0.0, 0.0], &[], 1e-3),
        Err(ExplicitError::InvalidInput(_))
    ));
    assert!(matches!(
        SymplecticEuler::new(sys, 0.0, &[1.0, 0.0], &[0.0, 0.0], &[], 0.0),
        Err(ExplicitError::InvalidInput(_))
    ));
    assert!(matches!(
        Dopri5::new(
            sys,
            0.0,
            &[1.0; 4],
            &[],
            Dopri5Options {
                rtol: 0.0,
                ..Default::default()
            }
        ),
        Err(ExplicitError::InvalidInput(_))
    ));
    let mut d = Dopri5::new(
        sys,
        0.0,
        &[1.0, 0.0, 0.0, 0.0],
        &[],
        Dopri5Options {
            max_steps: 10,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(matches!(d.solve_to(1.0), Err(ExplicitError::TooManySteps { .. })));
}
