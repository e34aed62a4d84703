//! A double pendulum built with the multibody API against the closed-form equations of the
//! DFKI pendulum's nominal model (`../shared/data/dfki-double-pendulum/README.md`).

use lash::dae::{BdfOptions, BdfSolver};
use lash::multibody::{Analysis, Mechanism, MechanismData, MotionLaw, MultibodyDae, RigidBody};
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;

/// m1, m2, l1, l2, r1, r2, I1, I2 from the README's parameter table (read, not copied).
fn dfki_parameters() -> [f64; 8] {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/dfki-double-pendulum/README.md"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("this test needs {path}: {e}"));
    let mut lines = text.lines().skip_while(|l| !l.trim_start().starts_with("| m1"));
    lines.next(); // header
    lines.next(); // separator
    let row = lines.next().expect("parameter row after the table header");
    let v: Vec<f64> = row.split('|').filter_map(|c| c.trim().parse().ok()).collect();
    assert_eq!(v.len(), 8, "expected 8 parameters in '{row}'");
    [v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]]
}

const G: f64 = 9.81;

/// The README's model: M(q)q̈ + C(q,q̇)q̇ − G(q) = τ.
fn closed_form_torque(p: &[f64; 8], q: [f64; 2], qd: [f64; 2], qdd: [f64; 2]) -> [f64; 2] {
    let [m1, m2, l1, _l2, r1, r2, i1, i2] = *p;
    let c2 = q[1].cos();
    let m11 = i1 + i2 + m2 * l1 * l1 + 2.0 * m2 * l1 * r2 * c2;
    let m12 = i2 + m2 * l1 * r2 * c2;
    let m22 = i2;
    let h = m2 * l1 * r2 * q[1].sin();
    let c1 = -h * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]);
    let c2v = h * qd[0] * qd[0];
    let g1 = -m1 * G * r1 * q[0].sin() - m2 * G * (l1 * q[0].sin() + r2 * (q[0] + q[1]).sin());
    let g2 = -m2 * G * r2 * (q[0] + q[1]).sin();
    [
        m11 * qdd[0] + m12 * qdd[1] + c1 - g1,
        m12 * qdd[0] + m22 * qdd[1] + c2v - g2,
    ]
}

/// The pendulum: links along −z at q = 0, joints about +y at the origin and at (0, 0, −l1).
fn build(p: &[f64; 8], laws: Option<[MotionLaw; 2]>) -> (Mechanism, [lash::multibody::BodyHandle; 2]) {
    let [m1, m2, l1, _l2, r1, r2, i1, i2] = *p;
    let inertia = |i_joint: f64, m: f64, r: f64| {
        let ic = i_joint - m * r * r; // about the centre of mass
        Matrix3::from_diagonal(&Vector3::new(ic, ic, ic))
    };
    let mut mech = Mechanism::new();
    let link1 =
        mech.add_body(RigidBody::new("link1", m1, inertia(i1, m1, r1)).at(Vector3::new(0.0, 0.0, -r1)));
    let link2 =
        mech.add_body(RigidBody::new("link2", m2, inertia(i2, m2, r2)).at(Vector3::new(0.0, 0.0, -l1 - r2)));
    let shoulder = mech.revolute_at(
        "shoulder",
        lash::multibody::Attach::Ground,
        link1,
        Vector3::zeros(),
        Vector3::y(),
    );
    let elbow = mech.revolute_at("elbow", link1, link2, Vector3::new(0.0, 0.0, -l1), Vector3::y());
    if let Some([a, b]) = laws {
        mech.drive("q1", shoulder, a, 0.0).unwrap();
        mech.drive("q2", elbow, b, 0.0).unwrap();
    }
    (mech, [link1, link2])
}

fn laws() -> [MotionLaw; 2] {
    let f1 = |t: f64| {
        [
            0.8 * (1.3 * t).sin(),
            0.8 * 1.3 * (1.3 * t).cos(),
            -0.8 * 1.69 * (1.3 * t).sin(),
        ]
    };
    let f2 = |t: f64| {
        [
            0.4 + 0.6 * (2.1 * t).cos(),
            -0.6 * 2.1 * (2.1 * t).sin(),
            -0.6 * 4.41 * (2.1 * t).cos(),
        ]
    };
    [MotionLaw::Custom(Arc::new(f1)), MotionLaw::Custom(Arc::new(f2))]
}

#[test]
fn inverse_dynamics_matches_closed_form_to_1e10() {
    let p = dfki_parameters();
    let [l1, l2] = laws();
    let mech = build(&p, Some([l1.clone(), l2.clone()])).0;
    assert_eq!(mech.degrees_of_freedom(), 2);
    let an = Analysis::new(&mech).unwrap();
    let times: Vec<f64> = (0..40).map(|k| k as f64 * 0.137).collect();
    let snaps = an
        .kinematics(&mech, &mut MechanismData::new(&mech), &times)
        .unwrap();
    let drivers: Vec<_> = mech.drivers().map(|(h, _)| h).collect();
    let mut worst = 0.0f64;
    for s in &snaps {
        let (a, b) = (l1.eval(s.t), l2.eval(s.t));
        let tau = closed_form_torque(&p, [a[0], b[0]], [a[1], b[1]], [a[2], b[2]]);
        // The drivers' efforts are the actuator torques about the joint axes.
        let got = drivers
            .iter()
            .map(|&d| s.driver_effort(&mech, d).unwrap())
            .collect::<Vec<_>>();
        for k in 0..2 {
            worst = worst.max((got[k] - tau[k]).abs());
        }
    }
    assert!(worst < 1e-10, "largest torque difference {worst:e} N·m");
}

#[test]
fn free_swing_matches_closed_form_dynamics_and_keeps_constraints() {
    let p = dfki_parameters();
    let (mut mech, [h1, h2]) = build(&p, None);
    // Start at q1 = 0.6, q2 = −0.4 rad at rest: rotate the links by assembling from a guess.
    let (q1, q2) = (0.6f64, -0.4f64);
    let [_, _, l1, _, r1, r2, _, _] = p;
    let rot = |a: f64| lash::multibody::rotation::from_axis_angle(&Vector3::y(), a);
    let tip = |a: f64, d: f64| Vector3::new(-d * a.sin(), 0.0, -d * a.cos());
    {
        let b1 = mech.body_mut(h1).unwrap();
        b1.position = tip(q1, r1);
        b1.orientation = rot(q1);
        let b2 = mech.body_mut(h2).unwrap();
        b2.position = tip(q1, l1) + tip(q1 + q2, r2);
        b2.orientation = rot(q1 + q2);
    }
    let mech = Arc::new(mech);
    let an = Analysis::new(&mech).unwrap();
    let mut data = MechanismData::new(&mech);
    let s0 = an.initial_state(&mech, &mut data, 0.0).unwrap();
    assert!(an.constraint_residual(&mech, &data, 0.0, &s0.q).unwrap() < 1e-12);
    let dae = MultibodyDae::new(mech.clone()).unwrap();
    let lay = dae.layout();
    let mut y0 = vec![0.0; lay.dim()];
    let mut yp0 = vec![0.0; lay.dim()];
    y0[lay.y_q()].copy_from_slice(&s0.q);
    y0[lay.y_w()].copy_from_slice(&s0.w);
    y0[lay.y_lambda()].copy_from_slice(&s0.lambda);
    yp0[lay.y_w()].copy_from_slice(&s0.wdot);
    let opts = BdfOptions {
        suppress_algebraic: true,
        ..BdfOptions::with_tolerances(1e-9, 1e-9)
    };
    let mut solver = BdfSolver::new(dae, 0.0, &y0, &yp0, &[], opts).unwrap();
    let mut drift = 0.0f64;
    for k in 1..=200 {
        solver.solve_to(k as f64 * 0.01).unwrap();
        drift = drift.max(
            an.constraint_residual(&mech, &data, solver.t(), &solver.y()[lay.y_q()])
                .unwrap(),
        );
    }
    assert!(drift < 1e-8, "constraint drift {drift:e}");
    // Relative angle of link 2 and absolute angle of link 1 from the orientations.
    let angle = |q: &[f64], b: lash::multibody::BodyHandle| {
        let pq = nalgebra::Vector4::from_column_slice(&q[lay.body_q(b)][3..]);
        let a = lash::multibody::rotation::rotation(&pq);
        let x = a * Vector3::x();
        (-x.z).atan2(x.x)
    };
    let y = solver.y();
    let (th1, th12) = (angle(y, h1), angle(y, h2));
    // Reference: the closed-form ODE M q̈ = −C q̇ + G integrated by Dormand–Prince.
    struct Ode([f64; 8]);
    impl lash::dae::explicit::OdeSystem for Ode {
        fn dim(&self) -> usize {
            4
        }
        fn rhs(
            &mut self,
            _t: f64,
            y: &[f64],
            _p: &[f64],
            dy: &mut [f64],
        ) -> Result<(), lash::dae::EvalError> {
            let p = &self.0;
            let zero = closed_form_torque(p, [y[0], y[1]], [y[2], y[3]], [0.0, 0.0]);
            let e1 = closed_form_torque(p, [y[0], y[1]], [0.0, 0.0], [1.0, 0.0]);
            let e2 = closed_form_torque(p, [y[0], y[1]], [0.0, 0.0], [0.0, 1.0]);
            // Mass matrix columns (subtract the gravity part included in e1, e2).
            let g = closed_form_torque(p, [y[0], y[1]], [0.0, 0.0], [0.0, 0.0]);
            let mm = nalgebra::Matrix2::new(e1[0] - g[0], e2[0] - g[0], e1[1] - g[1], e2[1] - g[1]);
            let acc = mm
                .lu()
                .solve(&nalgebra::Vector2::new(-zero[0], -zero[1]))
                .unwrap();
            dy[0] = y[2];
            dy[1] = y[3];
            dy[2] = acc[0];
            dy[3] = acc[1];
            Ok(())
        }
    }
    let mut reference = lash::dae::explicit::Dopri5::new(
        Ode(p),
        0.0,
        &[q1, q2, 0.0, 0.0],
        &[],
        lash::dae::explicit::Dopri5Options {
            rtol: 1e-12,
            atol: 1e-12,
            ..Default::default()
        },
    )
    .unwrap();
    reference.solve_to(2.0).unwrap();
    let r = reference.y();
    assert!((th1 - r[0]).abs() < 1e-6, "q1: {th1} vs {}", r[0]);
    assert!(
        (th12 - (r[0] + r[1])).abs() < 1e-6,
        "q1+q2: {th12} vs {}",
        r[0] + r[1]
    );
}
