//! Cross-checks against an independent BDF (diffsol 0.18) on the validation problems that fit
//! its M·y' = f form (index ≤ 1): the two answers must agree, and lash must need far fewer
//! steps on the turning stiff spring.
#![cfg(feature = "peers")]

use lash::dae::{AbsTol, BdfOptions, BdfSolver};
use lash::peers::diffsol_dae;
use lash::validation::{andrews, reference, robertson, stiff_spring, ROBERTSON_ATOL};

#[test]
fn robertson_lash_and_diffsol_agree() {
    let (y0, yp0) = robertson::Robertson::initial_values();
    let opts = BdfOptions {
        atol: AbsTol::Vector(ROBERTSON_ATOL.to_vec()),
        ..BdfOptions::with_tolerances(1e-8, 1.0)
    };
    let mut s = BdfSolver::new(robertson::Robertson, 0.0, &y0, &yp0, &[], opts).unwrap();
    s.solve_to(4e4).unwrap();
    let peer = diffsol_dae(
        robertson::Robertson,
        &[1.0, 1.0, 0.0],
        &y0,
        1e-8,
        &ROBERTSON_ATOL,
        4e4,
    )
    .unwrap();
    for i in 0..3 {
        let rel = (s.y()[i] - peer.y_end[i]).abs() / peer.y_end[i].abs();
        assert!(
            rel < 1e-5,
            "y{}: lash {} diffsol {}",
            i + 1,
            s.y()[i],
            peer.y_end[i]
        );
    }
}

#[test]
fn andrews_index1_lash_and_diffsol_agree() {
    let (y0, yp0) = andrews::initial_values();
    let sys = andrews::Andrews {
        index: andrews::AndrewsIndex::One,
        project: false,
    };
    let tol = 1e-8;
    let mut s = BdfSolver::new(
        sys.clone(),
        0.0,
        &y0,
        &yp0,
        &[],
        BdfOptions::with_tolerances(tol, tol),
    )
    .unwrap();
    s.solve_to(reference::ANDREWS_T_END).unwrap();
    let mass: Vec<f64> = (0..27).map(|i| if i < 14 { 1.0 } else { 0.0 }).collect();
    let peer = diffsol_dae(sys, &mass, &y0, tol, &[tol], reference::ANDREWS_T_END).unwrap();
    // Both converge to the reference; at this tolerance they agree to ~1e-5 relative.
    for i in 0..7 {
        let rel = (s.y()[i] - peer.y_end[i]).abs() / peer.y_end[i].abs().max(1e-2);
        assert!(
            rel < 1e-4,
            "angle {i}: lash {} diffsol {}",
            s.y()[i],
            peer.y_end[i]
        );
    }
    assert!(andrews::angle_error(s.y()) < 1e-4 && andrews::angle_error(&peer.y_end) < 1e-4);
}

#[test]
fn turning_stiff_spring_lash_needs_50x_fewer_steps_than_diffsol() {
    let sys = stiff_spring::StiffSpring::validation(true);
    let (y0, yp0) = sys.initial_values();
    let mut s = BdfSolver::new(sys, 0.0, &y0, &yp0, &[], BdfOptions::with_tolerances(1e-6, 1e-6)).unwrap();
    s.solve_to(10.0).unwrap();
    let peer = diffsol_dae(sys, &[1.0, 1.0, sys.m, sys.m], &y0, 1e-6, &[1e-6], 10.0).unwrap();
    let th_lash = stiff_spring::StiffSpring::angle(s.y());
    let th_peer = stiff_spring::StiffSpring::angle(&peer.y_end);
    assert!((th_lash - reference::STIFF_SPRING_THETA_T10).abs() < 1e-5);
    // diffsol finishes, less accurately, with many more steps.
    assert!((th_peer - reference::STIFF_SPRING_THETA_T10).abs() < 1e-1);
    assert!(
        s.stats().steps * 50 <= peer.steps,
        "lash {} diffsol {}",
        s.stats().steps,
        peer.steps
    );
}
