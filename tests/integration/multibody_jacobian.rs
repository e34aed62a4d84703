//! The analytic iteration matrix of the multibody formulation against central differences of
//! its residual, at states with non-zero velocities and multipliers.

use lash::dae::DaeSystem;
use lash::mechanisms::mr2120::{ideal_model, trajectory, Geometry, MassProperties};
use lash::multibody::{Analysis, Attach, Mechanism, MechanismData, MultibodyDae, RigidBody, SpringDamper};
use nalgebra::Vector3;
use std::sync::Arc;

/// Every entry (row, column, analytic, central difference, in the pattern) of the iteration
/// matrix dF/dy + α·dF/dy' at (t, y, y'), the differences with increment h_rel·(1 + |y_c|).
fn entries(dae: &mut MultibodyDae, t: f64, y: &[f64], yp: &[f64], alpha: f64, h_rel: f64) -> Vec<Entry> {
    let n = y.len();
    let pattern = dae.jacobian_pattern();
    let mut vals = vec![0.0; pattern.nnz()];
    dae.jacobian(t, y, yp, &[], alpha, &mut vals).unwrap();
    let (mut rp, mut rm) = (vec![0.0; n], vec![0.0; n]);
    let mut out = Vec::with_capacity(n * n);
    for c in 0..n {
        let h = h_rel * (1.0 + y[c].abs());
        let (mut y1, mut y2, mut p1, mut p2) = (y.to_vec(), y.to_vec(), yp.to_vec(), yp.to_vec());
        y1[c] += h;
        y2[c] -= h;
        p1[c] += alpha * h;
        p2[c] -= alpha * h;
        dae.residual(t, &y1, &p1, &[], &mut rp).unwrap();
        dae.residual(t, &y2, &p2, &[], &mut rm).unwrap();
        for r in 0..n {
            let k = pattern.find(r, c);
            out.push(Entry {
                r,
                c,
                analytic: k.map_or(0.0, |k| vals[k]),
                difference: (rp[r] - rm[r]) / (2.0 * h),
                declared: k.is_some(),
            });
        }
    }
    out
}

/// One entry of [`entries`].
struct Entry {
    r: usize,
    c: usize,
    analytic: f64,
    difference: f64,
    declared: bool,
}

fn check(mech: Mechanism, t: f64) {
    let mech = Arc::new(mech);
    let s = Analysis::new(&mech)
        .unwrap()
        .initial_state(&mech, &mut MechanismData::new(&mech), t)
        .unwrap();
    let mut dae = MultibodyDae::new(mech).unwrap();
    let lay = dae.layout();
    let n = lay.dim();
    let mut y = vec![0.0; n];
    y[lay.y_q()].copy_from_slice(&s.q);
    // Velocities, multipliers and stabilisers off their consistent values exercise every term.
    for (i, v) in y.iter_mut().enumerate().skip(lay.q_len()) {
        *v = 0.3 * ((i as f64) * 1.7).sin();
    }
    let yp: Vec<f64> = (0..n).map(|i| 0.2 * ((i as f64) * 0.9).cos()).collect();
    for e in entries(&mut dae, t, &y, &yp, 37.0, 1e-6) {
        let (r, c, an, fd) = (e.r, e.c, e.analytic, e.difference);
        if !e.declared {
            assert!(
                fd.abs() < 1e-6,
                "entry ({r}, {c}) = {fd} missing from the pattern ({} / {})",
                dae.component_name(r),
                dae.component_name(c)
            );
        }
        let err = (fd - an).abs() / (1.0 + an.abs());
        assert!(
            err < 1e-5,
            "J({r}, {c}) [{} / {}]: analytic {an}, finite difference {fd}",
            dae.component_name(r),
            dae.component_name(c)
        );
    }
}

#[test]
fn analytic_jacobian_matches_differences_on_a_pendulum_with_a_spring() {
    let mut mech = Mechanism::new();
    let a = mech.add_body(
        RigidBody::rod("a", 1.2, 0.5)
            .at(Vector3::new(0.25, 0.0, 0.0))
            .spinning(Vector3::new(0.1, 0.4, 2.0)),
    );
    let b = mech.add_body(RigidBody::cuboid("b", 0.7, 0.2, 0.1, 0.05).at(Vector3::new(0.6, 0.1, -0.05)));
    mech.revolute_at(
        "pivot",
        Attach::Ground,
        a,
        Vector3::zeros(),
        Vector3::new(0.0, 0.3, 1.0),
    );
    mech.spherical_at("ball", a, b, Vector3::new(0.5, 0.0, 0.0));
    mech.add_force(Box::new(SpringDamper {
        name: "spring".into(),
        i: (Attach::Ground, Vector3::new(0.3, 0.4, 0.2)),
        j: (Attach::Body(b), Vector3::new(0.05, 0.02, 0.0)),
        stiffness: 200.0,
        damping: 3.0,
        free_length: 0.2,
    }));
    check(mech, 0.0);
}

/// A force element couples two bodies' dynamics rows, never their kinematic rows (in
/// q' = T(p)·w + G(q)ᵀμ another body enters only through a constraint's Hessian): the pattern
/// declares a's positions in b's kinematic rows only when a joint joins them. The block
/// elimination leaves entries between two bodies' kinematic rows out of its factors, so
/// declaring them for a force element only stored and cleared zeros (23 % of the chain's
/// entries).
#[test]
fn a_force_element_declares_no_other_body_in_a_bodys_kinematic_rows() {
    let build = |joined: bool| {
        let mut mech = Mechanism::new();
        let a = mech.add_body(RigidBody::rod("a", 1.2, 0.5).at(Vector3::new(0.25, 0.0, 0.0)));
        let b = mech.add_body(RigidBody::cuboid("b", 0.7, 0.2, 0.1, 0.05).at(Vector3::new(0.6, 0.1, -0.05)));
        if joined {
            mech.spherical_at("ball", a, b, Vector3::new(0.5, 0.0, 0.0));
        }
        mech.add_force(Box::new(SpringDamper {
            name: "spring".into(),
            i: (Attach::Body(a), Vector3::new(0.3, 0.0, 0.0)),
            j: (Attach::Body(b), Vector3::new(0.05, 0.02, 0.0)),
            stiffness: 200.0,
            damping: 3.0,
            free_length: 0.2,
        }));
        let dae = MultibodyDae::new(Arc::new(mech)).unwrap();
        let (lay, pattern) = (dae.layout(), dae.jacobian_pattern());
        let declared = |rows: std::ops::Range<usize>, cols: std::ops::Range<usize>| {
            rows.flat_map(|r| cols.clone().map(move |c| (r, c)))
                .filter(|&(r, c)| pattern.find(r, c).is_some())
                .count()
        };
        let (qa, qb, wb) = (
            lay.q(0)..lay.q(0) + 7,
            lay.q(1)..lay.q(1) + 7,
            lay.w(1)..lay.w(1) + 6,
        );
        (declared(qb.clone(), qa.clone()), declared(wb, qa))
    };
    // Spring only: a's positions in b's dynamics rows (42 entries), none in its kinematic rows.
    assert_eq!(build(false), (0, 42));
    // Joined: the joint's Hessian puts them in the kinematic rows too.
    assert_eq!(build(true), (49, 42));
}

#[test]
fn analytic_jacobian_matches_differences_on_the_driven_mr2120() {
    let g = Geometry::default();
    let m = ideal_model(
        &g,
        &MassProperties::default(),
        Vector3::new(0.0, 0.0, 0.5),
        Some(trajectory::drive_laws(&g)),
    )
    .unwrap();
    check(m.mechanism, 0.7);
}

/// The clearance model mid-run, its bearings in contact: the analytic iteration matrix against
/// central differences, compared on the scale of each row (stiff contact rows carry entries
/// ~1e5 beside tiny ones), and the declared pattern covers every derivative. Differences at
/// h = 1e-9 agree to ~2e-6 of the row scale (the Hertz law's curvature sets the error, which
/// shrinks with h); at the assembled initial state, where contacts only just touch, they do
/// not — central differences straddle the onset.
#[test]
fn analytic_jacobian_matches_differences_on_the_mr2120_clearance_model_in_contact() {
    use lash::contact::Damping;
    use lash::mechanisms::mr2120::clearance::{bearing_design, clearance_model, clearance_set};
    use lash::multibody::{Simulation, SimulationOptions};
    let g = Geometry::default();
    let set = clearance_set("L1").unwrap();
    let m = clearance_model(
        &g,
        &MassProperties::default(),
        Vector3::new(0.0, 0.0, 0.5),
        Some(trajectory::drive_laws(&g)),
        &bearing_design(&set, Damping::HuntCrossley(300.0)),
    )
    .unwrap();
    let mech = Arc::new(m.mechanism);
    let t = 0.1;
    let mut opts = SimulationOptions::with_tolerances(1e-6, 1e-8);
    opts.singularity_warning = 0.0;
    opts.formulation.velocities_index2 = true;
    let mut sim = Simulation::new(mech.clone(), 0.0, opts).unwrap();
    let s = sim.run(&[t], |_| {}).unwrap().samples.pop().unwrap();
    let mut dae = MultibodyDae::new(mech).unwrap();
    let lay = dae.layout();
    let n = lay.dim();
    let mut y = vec![0.0; n];
    y[lay.y_q()].copy_from_slice(&s.q);
    y[lay.y_w()].copy_from_slice(&s.w);
    y[lay.y_lambda()].copy_from_slice(&s.lambda);
    let yp = vec![0.0; n];
    let all = entries(&mut dae, t, &y, &yp, 1e3, 1e-9);
    let mut row_scale = vec![0.0f64; n];
    for e in &all {
        row_scale[e.r] = row_scale[e.r].max(e.analytic.abs());
    }
    // The contacts carry load: some rows are stiff.
    assert!(row_scale.iter().any(|&s| s > 1e4), "no bearing in contact");
    for e in &all {
        let (r, c, an, fd) = (e.r, e.c, e.analytic, e.difference);
        let err = (fd - an).abs() / row_scale[r].max(1.0);
        assert!(
            err < 1e-4,
            "J({r}, {c}) [{} / {}]: analytic {an}, finite difference {fd}, row scale {}",
            dae.component_name(r),
            dae.component_name(c),
            row_scale[r]
        );
    }
}
