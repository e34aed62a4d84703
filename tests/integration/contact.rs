//! Joints with clearance: convergence to the ideal joint as the clearance vanishes, and clear
//! errors on bad contact data.

use lash::contact::{
    revolute_with_clearance, spherical_with_clearance, universal_with_clearance, BearingDesign, ContactError,
    Damping, Material,
};
use lash::mechanisms::mr2120::{clearance, Geometry, MassProperties, Mr2120Error};
use lash::multibody::{Attach, Mechanism, RigidBody, Simulation, SimulationOptions};
use nalgebra::Vector3;
use std::sync::Arc;

/// A 0.5 m rod pendulum released 30° from the vertical, swinging about the y axis.
fn pendulum(joint: Option<(f64, &str)>) -> (Mechanism, lash::multibody::BodyHandle) {
    let th = 30f64.to_radians();
    let dir = Vector3::new(th.sin(), 0.0, -th.cos());
    let mut mech = Mechanism::new();
    let rot = lash::multibody::rotation::rotation(&lash::multibody::rotation::from_axis_angle(
        &Vector3::y(),
        -(std::f64::consts::FRAC_PI_2 - th),
    ));
    let rod = mech.add_body(RigidBody::rod("rod", 1.0, 0.5).at(dir * 0.25).oriented(&rot));
    match joint {
        None => {
            mech.revolute_at("pivot", Attach::Ground, rod, Vector3::zeros(), Vector3::y());
        }
        Some((h, kind)) => {
            let design = BearingDesign {
                ball_spacing: 0.04,
                ..BearingDesign::mr2120(h, h, Damping::HuntCrossley(1.0))
            };
            match kind {
                "revolute" => revolute_with_clearance(
                    &mut mech,
                    "pivot",
                    Attach::Ground,
                    rod,
                    Vector3::zeros(),
                    Vector3::y(),
                    &design,
                )
                .unwrap(),
                "ideal spherical" => {
                    mech.spherical_at("pivot", Attach::Ground, rod, Vector3::zeros());
                }
                "spherical" => spherical_with_clearance(
                    &mut mech,
                    "pivot",
                    Attach::Ground,
                    rod,
                    Vector3::zeros(),
                    &design,
                )
                .unwrap(),
                "ideal universal" => {
                    mech.universal_at(
                        "pivot",
                        Attach::Ground,
                        rod,
                        Vector3::zeros(),
                        Vector3::y(),
                        Vector3::x(),
                    );
                }
                "universal" => {
                    universal_with_clearance(
                        &mut mech,
                        "pivot",
                        Attach::Ground,
                        rod,
                        Vector3::zeros(),
                        Vector3::y(),
                        Vector3::x(),
                        &design,
                        0.05,
                    )
                    .unwrap();
                }
                other => panic!("unknown joint kind {other}"),
            }
        }
    }
    (mech, rod)
}

fn tip_after(mech: Mechanism, rod: lash::multibody::BodyHandle, t: f64) -> Vector3<f64> {
    let opts = SimulationOptions::with_tolerances(1e-6, 1e-8);
    let mut sim = Simulation::new(Arc::new(mech), 0.0, opts).unwrap();
    let traj = sim.run(&[t], |_| {}).unwrap();
    let s = &traj.samples[0];
    s.body_position(rod) + s.body_rotation(rod) * Vector3::new(0.25, 0.0, 0.0)
}

#[test]
fn revolute_with_clearance_converges_to_the_ideal_joint() {
    let t = 0.15;
    let (ideal, rod) = pendulum(None);
    let reference = tip_after(ideal, rod, t);
    let mut diffs = vec![];
    for h in [1e-4, 1e-5, 1e-6] {
        let (m, rod) = pendulum(Some((h, "revolute")));
        diffs.push((tip_after(m, rod, t) - reference).norm());
    }
    assert!(diffs[0] > diffs[1] && diffs[1] > diffs[2], "{diffs:?}");
    assert!(diffs[2] < 2e-5, "{diffs:?}");
}

#[test]
fn spherical_and_universal_with_clearance_converge_to_their_ideal_joints() {
    let t = 0.1;
    for (ideal, with_play) in [("ideal spherical", "spherical"), ("ideal universal", "universal")] {
        let (m, rod) = pendulum(Some((0.0, ideal)));
        let reference = tip_after(m, rod, t);
        let mut diffs = vec![];
        for h in [1e-4, 1e-5, 1e-6] {
            let (m, rod) = pendulum(Some((h, with_play)));
            diffs.push((tip_after(m, rod, t) - reference).norm());
        }
        assert!(
            diffs[0] > diffs[1] && diffs[1] > diffs[2],
            "{with_play}: {diffs:?}"
        );
        assert!(diffs[2] < 5e-5, "{with_play}: {diffs:?}");
    }
}

#[test]
fn bad_contact_data_are_clear_errors() {
    let mut mech = Mechanism::new();
    let a = mech.add_body(RigidBody::rod("a", 1.0, 0.3));
    let b = mech.add_body(RigidBody::rod("b", 1.0, 0.3).at(Vector3::new(0.3, 0.0, 0.0)));
    let base = BearingDesign::mr2120(2e-5, 2e-5, Damping::Elastic);
    let negative = BearingDesign {
        radial_clearance: -1e-6,
        ..base
    };
    let e = universal_with_clearance(
        &mut mech,
        "U",
        a,
        b,
        Vector3::zeros(),
        Vector3::x(),
        Vector3::y(),
        &negative,
        0.05,
    )
    .unwrap_err();
    assert!(
        matches!(e, ContactError::NegativeClearance { .. }) && e.to_string().contains("radial clearance"),
        "{e}"
    );
    let soft = BearingDesign {
        material: Material { e: 0.0, nu: 0.3 },
        ..base
    };
    let e = revolute_with_clearance(&mut mech, "R", a, b, Vector3::zeros(), Vector3::z(), &soft).unwrap_err();
    assert!(e.to_string().contains("Young's modulus"), "{e}");
    let no_ball = BearingDesign {
        ball_radius: 0.0,
        ..base
    };
    assert!(
        spherical_with_clearance(&mut mech, "S", a, b, Vector3::zeros(), &no_ball)
            .unwrap_err()
            .to_string()
            .contains("ball radius")
    );
    let e = lash::contact::stiffness::ball_in_bore(0.005, 0.004, &Material::steel(), &Material::steel())
        .unwrap_err();
    assert!(matches!(e, ContactError::BallLargerThanSocket { .. }), "{e}");
    let e = clearance::clearance_set("L4").unwrap_err();
    assert!(matches!(e, Mr2120Error::UnknownClearanceSet(_)) && e.to_string().contains("L4"));
    // The MR2120 clearance model refuses the same bad data.
    let bad = BearingDesign {
        axial_clearance: f64::NAN,
        ..base
    };
    let r = clearance::clearance_model(
        &Geometry::default(),
        &MassProperties::default(),
        Vector3::new(0.0, 0.0, 0.5),
        None,
        &bad,
    );
    assert!(matches!(
        r,
        Err(Mr2120Error::Contact(ContactError::NegativeClearance { .. }))
    ));
}

/// The exact load derivatives of the contact elements against central differences of their
/// loads, in contact (radial and axial at once) with moving bodies.
#[test]
fn contact_load_jacobians_match_differences() {
    use lash::contact::{BallInSocket, ClearanceBearing, NormalLaw};
    use lash::multibody::rotation::{from_axis_angle, rotation};
    use lash::multibody::{BodyLoad, BodyState, ForceElement};
    let state = |r: Vector3<f64>, axis: Vector3<f64>, ang: f64, v: Vector3<f64>, w: Vector3<f64>| {
        let p = from_axis_angle(&axis.normalize(), ang);
        BodyState {
            r,
            p,
            a: rotation(&p),
            v,
            omega: w,
        }
    };
    let states = vec![
        state(
            Vector3::new(0.1, 0.0, 0.0),
            Vector3::new(0.2, 1.0, 0.1),
            0.3,
            Vector3::new(0.01, -0.02, 0.005),
            Vector3::new(0.3, -0.1, 0.2),
        ),
        state(
            Vector3::new(0.1 + 3e-5, 2e-5, -1e-5),
            Vector3::new(0.2, 1.0, 0.1),
            0.3 + 1e-4,
            Vector3::new(-0.01, 0.01, 0.0),
            Vector3::new(0.1, 0.2, -0.3),
        ),
    ];
    let mut mech = Mechanism::new();
    let h0 = mech.add_body(RigidBody::rod("ball side", 1.0, 0.1));
    let h1 = mech.add_body(RigidBody::rod("socket side", 1.0, 0.1));
    let (b0, b1) = (Attach::Body(h0), Attach::Body(h1));
    let law = NormalLaw::HuntCrossley {
        k: 1e10,
        n: 1.5,
        alpha: 300.0,
    };
    let bearing = ClearanceBearing {
        name: "b".into(),
        ball_body: b0,
        ball_centre: Vector3::new(0.012, 0.001, 0.0),
        socket_body: b1,
        socket_centre: Vector3::new(0.012, 0.001, 0.0),
        socket_axis: Vector3::x(),
        radial_clearance: 5e-6,
        axial_stop: -1e-5,
        radial_law: law,
        axial_law: law,
        friction: None,
    };
    let socket = BallInSocket {
        name: "s".into(),
        ball_body: b0,
        ball_centre: Vector3::new(0.0, 0.01, 0.0),
        socket_body: b1,
        socket_centre: Vector3::new(0.0, 0.01, 0.0),
        clearance: 5e-6,
        law,
        friction: None,
    };
    let elements: [&dyn ForceElement; 2] = [&bearing, &socket];
    for el in elements {
        let mut blocks = vec![];
        assert!(el.load_jacobian(0.0, &states, &mut blocks), "exact derivatives");
        assert_eq!(blocks.len(), 4, "{}", el.name());
        let loads = |st: &[BodyState]| {
            let mut l = vec![BodyLoad::default(); 2];
            el.apply(0.0, st, &mut l);
            l
        };
        for blk in &blocks {
            for c in 0..13 {
                // Loads are linear in the velocities (large increments are exact there) and
                // strongly nonlinear in the positions near contact (tiny increments).
                let h = if c < 7 { 1e-9 } else { 1e-5 };
                let perturb = |sign: f64| {
                    let mut st = states.clone();
                    let s = &mut st[blk.wrt.index()];
                    match c {
                        0..=2 => s.r[c] += sign * h,
                        3..=6 => {
                            s.p[c - 3] += sign * h;
                            s.a = rotation(&s.p);
                        }
                        7..=9 => s.v[c - 7] += sign * h,
                        _ => s.omega[c - 10] += sign * h,
                    }
                    loads(&st)[blk.loaded.index()]
                };
                let (lp, lm) = (perturb(1.0), perturb(-1.0));
                for r in 0..6 {
                    let fd = if r < 3 {
                        (lp.force[r] - lm.force[r]) / (2.0 * h)
                    } else {
                        (lp.torque[r - 3] - lm.torque[r - 3]) / (2.0 * h)
                    };
                    let an = blk.d[(r, c)];
                    assert!(
                        (fd - an).abs() <= 1e-5 * (1.0 + an.abs().max(fd.abs())),
                        "{}: d load[{r}] of body {} / state {c} of body {}: exact {an}, difference {fd}",
                        el.name(),
                        blk.loaded.index(),
                        blk.wrt.index()
                    );
                }
            }
        }
    }
}
