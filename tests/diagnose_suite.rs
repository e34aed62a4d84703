//! The concealed-effects suite: a few of its cases end to end (the whole suite runs as
//! `lash diagnose --suite --reduced` in CI).

use lash::diagnose::suite::lumped::{cases, run_case};
use lash::diagnose::suite::SuiteOptions;

fn run(name: &str) -> lash::diagnose::suite::CaseResult {
    let all = cases();
    let i = all.iter().position(|c| c.name == name).unwrap();
    run_case(&all[i], &SuiteOptions::lumped_reduced(), i).unwrap().0
}

#[test]
fn the_suite_has_at_least_twelve_concealed_cases_a_null_and_a_pair() {
    use lash::diagnose::suite::CaseKind::*;
    let all = cases();
    assert!(all.iter().filter(|c| c.kind == Concealed).count() >= 12);
    assert_eq!(all.iter().filter(|c| c.kind == Null).count(), 1);
    assert_eq!(all.iter().filter(|c| c.kind == Pair).count(), 1);
}

#[test]
fn clearance_that_shows_only_at_force_reversals_is_found_and_sized() {
    let r = run("clearance");
    // Concealed: below the tracker noise at most samples.
    assert!(r.below_noise_fraction > 0.5, "{r:?}");
    assert!(r.ranked_first && r.estimate_ok && r.holdout_ok, "{r:?}");
}

#[test]
fn nothing_hidden_gives_no_significant_mismatch() {
    let r = run("null");
    assert!(r.no_mismatch && r.pass, "{r:?}");
}

#[test]
fn only_names_no_case_is_refused_before_anything_runs() {
    use lash::diagnose::suite::{run_suite, SuiteError};
    let opts = SuiteOptions {
        only: vec!["clearance".into(), "gremlins".into()],
        ..SuiteOptions::lumped_reduced()
    };
    let e = run_suite(&opts, None, |_, _| {}).unwrap_err();
    assert!(
        matches!(&e, SuiteError::NoSuchCase { name, .. } if name == "gremlins"),
        "{e}"
    );
    assert!(
        e.to_string().contains("tilt-under-payload"),
        "the message lists the cases: {e}"
    );
}
