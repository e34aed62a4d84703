//! The validation suite against published reference solutions (the same rows `lash validate`
//! prints), with the targets on accuracy and step counts.

use lash::validation::{self, andrews::AndrewsIndex, reference};

fn check(row: &validation::ValidationRow) {
    assert!(
        row.pass,
        "{} ({}) failed: error {:e} (limit {:e}), {} steps; {}",
        row.problem, row.variant, row.error, row.error_limit, row.steps, row.note
    );
}

#[test]
fn andrews_all_formulations_within_1e5_at_tolerance_1e6() {
    for idx in [AndrewsIndex::Two, AndrewsIndex::One, AndrewsIndex::Ggl] {
        let row = validation::andrews(idx, 1e-6);
        check(&row);
        assert!(row.error <= 1e-5);
    }
}

#[test]
fn andrews_index2_beats_ida_step_count_and_error() {
    let row = validation::andrews(AndrewsIndex::Two, 1e-6);
    assert!(row.steps < reference::ANDREWS_IDA_STEPS, "{} steps", row.steps);
    assert!(row.error < reference::ANDREWS_IDA_ERROR);
}

#[test]
fn turning_stiff_spring_damped_and_undamped() {
    let damped = validation::stiff_spring(true, 1e-6);
    check(&damped);
    assert!(damped.steps <= 1000, "{} steps", damped.steps);
    assert!(damped.error <= 1e-5);
    // At least 50× fewer steps than diffsol's BDF needs (issue figure; measured again in
    // tests/peers_diffsol.rs).
    assert!(damped.steps * 50 <= reference::STIFF_SPRING_DIFFSOL_STEPS);
    let undamped = validation::stiff_spring(false, 1e-6);
    check(&undamped);
    assert!(undamped.steps > 0);
}

#[test]
fn robertson_to_1e11() {
    let row = validation::robertson(1e-6);
    check(&row);
}

#[test]
fn ggl_pendulum_keeps_constraints_over_100s() {
    let row = validation::ggl_pendulum(1e-8);
    check(&row);
    assert!(row.error <= 1e-8);
}

#[test]
fn validate_rows_serialise_to_json() {
    let rows = vec![validation::robertson(1e-6)];
    let json = serde_json::to_string(&rows).unwrap();
    let back: serde_json::Value = serde_json::from_str(&json).unwrap();
    for key in [
        "problem",
        "variant",
        "rtol",
        "error",
        "error_limit",
        "steps",
        "pass",
        "newton_iters",
        "lu_factorisations",
    ] {
        assert!(back[0].get(key).is_some(), "missing key {key}");
    }
}
