//! The multibody layer beyond the pendulum: energy of a free tumbling body, a closed-loop
//! spatial slider-crank (assembly, drift), singularity detection, and clear errors.

use lash::multibody::{
    Analysis, Attach, BodyHandle, Layout, Mechanism, MechanismData, ModelError, MotionLaw, Profile,
    RigidBody, RunEnd, Simulation, SimulationOptions,
};
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;

#[test]
fn free_tumbling_body_conserves_energy_to_1e6_over_10s() {
    let mut mech = Mechanism::new();
    let inertia = Matrix3::from_diagonal(&Vector3::new(0.02, 0.05, 0.09));
    mech.add_body(
        RigidBody::new("brick", 2.0, inertia)
            .at(Vector3::new(0.0, 0.0, 1.0))
            .moving(Vector3::new(0.3, -0.2, 4.0))
            // Near the intermediate axis: the tumbling (Dzhanibekov) motion.
            .spinning(Vector3::new(0.05, 6.0, 0.03)),
    );
    let mech = Arc::new(mech);
    let brick = mech.bodies().iter().next().unwrap().0;
    let opts = SimulationOptions::with_tolerances(1e-8, 1e-10);
    let mut sim = Simulation::new(mech, 0.0, opts).unwrap();
    let times: Vec<f64> = (1..=100).map(|k| k as f64 * 0.1).collect();
    let traj = sim.run(&times, |_| {}).unwrap();
    let energy = |r: Vector3<f64>, v: Vector3<f64>, om: Vector3<f64>| {
        0.5 * 2.0 * v.norm_squared() + 0.5 * om.dot(&(inertia * om)) + 2.0 * 9.81 * r.z
    };
    let e0 = energy(
        Vector3::new(0.0, 0.0, 1.0),
        Vector3::new(0.3, -0.2, 4.0),
        Vector3::new(0.05, 6.0, 0.03),
    );
    let worst = traj
        .samples
        .iter()
        .map(|s| {
            let e = energy(
                s.body_position(brick),
                s.body_velocity(brick),
                s.body_angular_velocity(brick),
            );
            ((e - e0) / e0).abs()
        })
        .fold(0.0, f64::max);
    assert!(worst <= 1e-6, "relative energy drift {worst:e}");
    // The spin axis really flips (the motion is not trivial).
    let flipped = traj
        .samples
        .iter()
        .any(|s| s.body_angular_velocity(brick).y < 0.0);
    assert!(flipped, "expected the intermediate-axis flip");
}

/// Spatial slider-crank: crank (revolute about z at the origin), rod (spherical at the crank
/// tip, universal at the slider), slider (prismatic along x on the line y = 0.05, z = 0.1).
fn slider_crank() -> (
    Mechanism,
    lash::multibody::JointHandle,
    lash::multibody::JointHandle,
    f64,
) {
    let (a, b) = (0.1, 0.3);
    let s_line = Vector3::new(0.0, 0.05, 0.1);
    let x0 = a + (b * b - 0.05f64.powi(2) - 0.1f64.powi(2)).sqrt();
    let tip = Vector3::new(a, 0.0, 0.0);
    let slider_pt = Vector3::new(x0, s_line.y, s_line.z);
    let mut mech = Mechanism::new();
    let crank = mech.add_body(RigidBody::rod("crank", 0.5, a).at(tip / 2.0));
    let dir = (slider_pt - tip).normalize();
    let rod_rot = nalgebra::Rotation3::rotation_between(&Vector3::x(), &dir).unwrap();
    let rod = mech.add_body(
        RigidBody::rod("rod", 0.8, b)
            .at((tip + slider_pt) / 2.0)
            .oriented(rod_rot.matrix()),
    );
    let slider = mech.add_body(RigidBody::cuboid("slider", 1.0, 0.05, 0.03, 0.03).at(slider_pt));
    let rev = mech.revolute_at(
        "crank pivot",
        Attach::Ground,
        crank,
        Vector3::zeros(),
        Vector3::z(),
    );
    mech.spherical_at("crank pin", crank, rod, tip);
    mech.universal_at("wrist pin", rod, slider, slider_pt, Vector3::y(), Vector3::z());
    let pri = mech.prismatic_along("slide", Attach::Ground, slider, slider_pt, Vector3::x());
    // Deliberately rough initial guesses (after the joints were defined): assembly must
    // close the loop.
    mech.body_mut(rod).unwrap().position += Vector3::new(0.01, -0.01, 0.005);
    mech.body_mut(slider).unwrap().position += Vector3::new(0.003, 0.002, 0.0);
    let c = mech.body_mut(crank).unwrap();
    c.orientation = lash::multibody::rotation::from_axis_angle(&Vector3::z(), 0.05);
    (mech, rev, pri, x0)
}

/// The slider-crank with its crank turning at 10 rad/s. Gravity acts along the crank axis, so
/// the spin is what moves it (the velocity analysis makes the other bodies' velocities
/// consistent).
fn turning_slider_crank() -> Arc<Mechanism> {
    let (mut mech, _, _, _) = slider_crank();
    let crank = body(&mech, "crank");
    mech.body_mut(crank).unwrap().angular_velocity = Vector3::new(0.0, 0.0, 10.0);
    Arc::new(mech)
}

/// The handle of the body named `name`.
fn body(mech: &Mechanism, name: &str) -> BodyHandle {
    mech.bodies()
        .iter()
        .find(|(_, b)| b.name == name)
        .map(|(h, _)| h)
        .unwrap()
}

#[test]
fn slider_crank_assembles_closed_loop_and_keeps_drift_below_1e8() {
    let mech = turning_slider_crank();
    assert_eq!(mech.degrees_of_freedom(), 1);
    let an = Analysis::new(&mech).unwrap();
    let mut data = MechanismData::new(&mech);
    let (guess, _) = mech.initial_guess();
    assert!(
        an.constraint_residual(&mech, &data, 0.0, &guess).unwrap() > 1e-3,
        "the guess is off the constraints"
    );
    let s0 = an.initial_state(&mech, &mut data, 0.0).unwrap();
    assert!(an.constraint_residual(&mech, &data, 0.0, &s0.q).unwrap() < 1e-12);
    let mut sim = Simulation::new(mech.clone(), 0.0, SimulationOptions::default()).unwrap();
    let times: Vec<f64> = (1..=200).map(|k| k as f64 * 0.01).collect();
    let traj = sim.run(&times, |_| {}).unwrap();
    assert_eq!(traj.end, RunEnd::Completed);
    let drift = traj
        .samples
        .iter()
        .map(|s| sim.constraint_residual(s.t, &s.q))
        .fold(0.0, f64::max);
    assert!(drift < 1e-8, "drift {drift:e}");
    // It moved: the slider travelled.
    let slider = body(&mech, "slider");
    let x_end = traj.samples.last().unwrap().body_position(slider).x;
    assert!((x_end - traj.samples[0].body_position(slider).x).abs() > 1e-3);
}

#[test]
fn driving_the_slider_to_the_dead_centre_is_reported_as_a_singularity() {
    let (mut mech, _, pri, x0) = slider_crank();
    // The dead centre: the largest slider position over crank angles.
    let (a, b) = (0.1f64, 0.3f64);
    let x_of = |th: f64| a * th.cos() + (b * b - (a * th.sin() - 0.05).powi(2) - 0.01).sqrt();
    let x_max = (0..20000)
        .map(|k| x_of(-1.0 + k as f64 * 1e-4))
        .fold(f64::MIN, f64::max);
    let law = MotionLaw::RestToRest {
        t0: 0.0,
        t1: 1.0,
        from: x0,
        to: x_max,
        profile: Profile::Quintic,
    };
    mech.drive("slide position", pri, law, x0).unwrap();
    let mech = Arc::new(mech);
    let mut sim = Simulation::new(mech, 0.0, SimulationOptions::default()).unwrap();
    let times: Vec<f64> = (1..=100).map(|k| k as f64 * 0.01).collect();
    let traj = sim
        .run(&times, |_| {})
        .expect("a singularity is reported, not an opaque error");
    assert!(
        !traj.singularity_warnings.is_empty(),
        "no warning; end {:?}",
        traj.end
    );
    let first = &traj.singularity_warnings[0];
    assert!(first.t > 0.5 && first.t <= 1.0, "{first:?}");
    assert!(
        traj.samples[0].singularity > 1e-2,
        "{}",
        traj.samples[0].singularity
    );
}

#[test]
fn bad_models_give_clear_errors() {
    let mut mech = Mechanism::new();
    mech.add_body(RigidBody::new("ghost", 0.0, Matrix3::identity()));
    let e = Analysis::new(&mech).unwrap_err();
    assert!(
        matches!(&e, ModelError::BadBody { body, .. } if body == "ghost"),
        "{e}"
    );

    let mut mech = Mechanism::new();
    mech.add_body(RigidBody::new(
        "flat",
        1.0,
        Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1e-3)),
    ));
    assert!(Analysis::new(&mech).unwrap_err().to_string().contains("flat"));

    // A loop that cannot close: a 0.3 m link between points 1 m apart.
    let mut mech = Mechanism::new();
    let link = mech.add_body(RigidBody::rod("link", 1.0, 0.3).at(Vector3::new(0.15, 0.0, 0.0)));
    mech.spherical_at("left", Attach::Ground, link, Vector3::zeros());
    let j = mech.joints().count();
    mech.add_joint(lash::multibody::Joint {
        name: "right".into(),
        kind: lash::multibody::JointKind::Spherical,
        body_i: Attach::Ground,
        body_j: Attach::Body(link),
        frame_i: lash::multibody::JointFrame::new(Vector3::new(1.0, 0.0, 0.0), Vector3::z()),
        frame_j: lash::multibody::JointFrame::new(Vector3::new(0.15, 0.0, 0.0), Vector3::z()),
    });
    assert_eq!(mech.joints().count(), j + 1);
    let an = Analysis::new(&mech).unwrap();
    match an.initial_state(&mech, &mut MechanismData::new(&mech), 0.0) {
        Err(ModelError::AssemblyFailed { residuals }) => {
            assert!(
                residuals
                    .iter()
                    .any(|(n, _)| n.contains("right") || n.contains("left")),
                "{residuals:?}"
            );
        }
        other => panic!("expected an assembly failure, got {other:?}"),
    }

    // Drivers only on revolute, cylindrical or prismatic joints.
    let mut mech = Mechanism::new();
    let b = mech.add_body(RigidBody::rod("b", 1.0, 1.0));
    let s = mech.spherical_at("ball", Attach::Ground, b, Vector3::zeros());
    let e = mech.drive("spin", s, MotionLaw::Constant(0.0), 0.0).unwrap_err();
    assert!(e.to_string().contains("ball"));
}

#[test]
fn markers_and_csv_outputs() {
    let (mech, _, _, _) = slider_crank();
    let mut mech = mech;
    let crank = body(&mech, "crank");
    let tip_marker = mech.add_marker("crank tip", crank, Vector3::new(0.1, 0.0, 0.0), Vector3::z());
    mech.body_mut(crank).unwrap().angular_velocity = Vector3::new(0.0, 0.0, 5.0);
    let mech = Arc::new(mech);
    let mut sim = Simulation::new(mech, 0.0, SimulationOptions::default()).unwrap();
    let traj = sim.run(&[0.05, 0.1], |_| {}).unwrap();
    let radius = |k: usize| {
        let s = &traj.samples[k];
        let (p, _, v) = s.marker_state(sim.model(), tip_marker).unwrap();
        // A crank-fixed point moves on a circle about the pivot axis, in a horizontal plane.
        assert!(v.dot(&Vector3::new(p.x, p.y, 0.0)).abs() < 1e-9 && v.z.abs() < 1e-9);
        ((p.x * p.x + p.y * p.y).sqrt(), p.z)
    };
    let (r0, z0) = radius(0);
    let (r1, z1) = radius(1);
    assert!((r0 - r1).abs() < 1e-10 && (z0 - z1).abs() < 1e-10 && (r0 - 0.1).abs() < 1e-3);
    let mut bodies = Vec::new();
    lash::multibody::output::write_bodies_csv(&mut bodies, sim.model(), &traj.samples).unwrap();
    let text = String::from_utf8(bodies).unwrap();
    assert!(text.starts_with("t_s,body,x_m"));
    assert_eq!(text.lines().count(), 1 + 2 * 3);
    let mut joints = Vec::new();
    lash::multibody::output::write_reactions_csv(&mut joints, sim.model(), sim.analysis(), &traj.samples)
        .unwrap();
    let text = String::from_utf8(joints).unwrap();
    assert_eq!(text.lines().count(), 1 + 2 * 4);
    assert!(text.contains("crank pin"));
}

#[test]
fn explicit_ode_form_agrees_with_the_implicit_ggl_run_on_the_slider_crank() {
    use lash::dae::explicit::{Dopri5, Dopri5Options};
    use lash::multibody::MultibodyOde;
    let mech = turning_slider_crank();
    let s0 = Analysis::new(&mech)
        .unwrap()
        .initial_state(&mech, &mut MechanismData::new(&mech), 0.0)
        .unwrap();
    let mut sim = Simulation::new(mech.clone(), 0.0, SimulationOptions::default()).unwrap();
    let traj = sim.run(&[0.5], |_| {}).unwrap();
    let ode = MultibodyOde::new(mech.clone()).unwrap();
    let y0: Vec<f64> = s0.q.iter().chain(&s0.w).copied().collect();
    let opts = Dopri5Options {
        rtol: 1e-9,
        atol: 1e-11,
        ..Default::default()
    };
    let mut dp = Dopri5::new(ode, 0.0, &y0, &[], opts).unwrap();
    dp.solve_to(0.5).unwrap();
    let lay = mech.layout();
    let diff = traj.samples[0]
        .q
        .iter()
        .zip(&dp.y()[lay.y_q()])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-6, "explicit and implicit runs differ by {diff:e}");
    // Baumgarte keeps the explicit run on the constraints.
    let drift = sim.constraint_residual(0.5, &dp.y()[lay.y_q()]);
    assert!(drift < 1e-7, "explicit drift {drift:e}");
    // The slider moved.
    let slider = body(&mech, "slider");
    assert!((Layout::position_of(dp.y(), slider)[0] - s0.body_position(slider).x).abs() > 1e-3);
}

/// A user force element whose load Jacobian names a body its `bodies()` does not list.
#[derive(Debug)]
struct UndeclaredCoupling {
    declared: BodyHandle,
    other: BodyHandle,
}

impl lash::multibody::ForceElement for UndeclaredCoupling {
    fn name(&self) -> &str {
        "sneaky coupler"
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.declared]
    }
    fn apply(
        &self,
        _t: f64,
        _states: &[lash::multibody::BodyState],
        _loads: &mut [lash::multibody::BodyLoad],
    ) {
    }
    fn load_jacobian(
        &self,
        _t: f64,
        _states: &[lash::multibody::BodyState],
        out: &mut Vec<lash::multibody::LoadDerivative>,
    ) -> bool {
        out.push(lash::multibody::LoadDerivative {
            loaded: self.declared,
            wrt: self.other,
            d: nalgebra::SMatrix::<f64, 6, 13>::from_element(1.0),
        });
        true
    }
}

#[test]
fn a_load_jacobian_outside_the_declared_bodies_is_an_error_naming_element_and_body() {
    use lash::dae::DaeSystem;
    let mut mech = Mechanism::new();
    let a = mech.add_body(RigidBody::rod("anchor", 1.0, 0.2));
    let b = mech.add_body(RigidBody::rod("bystander", 1.0, 0.2).at(Vector3::new(1.0, 0.0, 0.0)));
    mech.add_force(Box::new(UndeclaredCoupling {
        declared: a,
        other: b,
    }));
    let mech = Arc::new(mech);
    let mut dae = lash::multibody::MultibodyDae::new(mech.clone()).unwrap();
    let n = dae.dim();
    let mut y = vec![0.0; n];
    y[mech.layout().y_q()].copy_from_slice(&mech.initial_guess().0);
    let mut values = vec![0.0; dae.jacobian_pattern().nnz()];
    let e = dae
        .jacobian(0.0, &y, &vec![0.0; n], &[], 1.0, &mut values)
        .expect_err("an undeclared body in the load Jacobian is an error");
    let msg = e.to_string();
    assert!(
        msg.contains("sneaky coupler") && msg.contains("bystander"),
        "{msg}"
    );
    // Through the simulation pipeline: an error (not a panic) that names the cause.
    let run =
        Simulation::new(mech, 0.0, SimulationOptions::default()).and_then(|mut sim| sim.run(&[0.1], |_| {}));
    let msg = run.expect_err("the run fails").to_string();
    assert!(
        msg.contains("sneaky coupler") && msg.contains("bystander"),
        "{msg}"
    );
}

#[test]
fn joints_and_forces_are_replaced_and_removed_with_other_handles_valid() {
    let (mut mech, rev, pri, _) = slider_crank();
    let slider = body(&mech, "slider");
    let pin = mech
        .joints()
        .find(|(_, j)| j.name == "crank pin")
        .map(|(h, _)| h)
        .unwrap();
    let spring = mech.add_force(Box::new(lash::multibody::SpringDamper {
        name: "spring".into(),
        i: (Attach::Ground, Vector3::new(0.6, 0.05, 0.1)),
        j: (Attach::Body(slider), Vector3::zeros()),
        stiffness: 500.0,
        damping: 2.0,
        free_length: 0.15,
    }));
    let extra = mech.add_force(Box::new(lash::multibody::PointForce {
        name: "push".into(),
        body: slider,
        point: Vector3::zeros(),
        force: Arc::new(|_| Vector3::new(1.0, 0.0, 0.0)),
    }));
    // Removing a force leaves a tombstone: the other handle still names its element.
    let removed = mech.remove_force(spring).unwrap();
    assert_eq!(removed.name(), "spring");
    assert!(mech.force(spring).is_none());
    assert_eq!(mech.force(extra).unwrap().name(), "push");
    assert_eq!(mech.forces().count(), 1);
    assert!(mech.remove_force(spring).is_err());
    let old = mech
        .replace_force(
            extra,
            Box::new(lash::multibody::PointForce {
                name: "pull".into(),
                body: slider,
                point: Vector3::zeros(),
                force: Arc::new(|_| Vector3::new(-1.0, 0.0, 0.0)),
            }),
        )
        .unwrap();
    assert_eq!(old.name(), "push");
    assert_eq!(mech.force(extra).unwrap().name(), "pull");

    // A driven joint cannot be removed; the error names it and its driver.
    let motor = mech.drive("motor", rev, MotionLaw::Constant(0.05), 0.0).unwrap();
    let e = mech.remove_joint(rev).unwrap_err().to_string();
    assert!(e.contains("crank pivot") && e.contains("motor"), "{e}");
    // Nor replaced by a joint that cannot be driven the same way.
    let mut ball = mech.joint(pin).unwrap().clone();
    ball.name = "ball".into();
    let e = mech.replace_joint(rev, ball).unwrap_err().to_string();
    assert!(e.contains("crank pivot") && e.contains("motor"), "{e}");
    // Replace the prismatic guide by an identical one and remove nothing else: the same
    // model, so the same state; the handles of the other joints still address their joints.
    let guide = mech.joint(pri).unwrap().clone();
    let before = mech.joint(pri).unwrap().clone();
    assert_eq!(mech.replace_joint(pri, guide).unwrap(), before);
    let lay = mech.layout();
    assert_eq!(lay.joint_lambda(rev).len(), 5);
    assert_eq!(lay.joint_lambda(pin), 5..8);
    assert_eq!(lay.driver_lambda(motor), Some(lay.constraints() - 1));
    // Removing the (undriven) crank pin frees the loop: one joint fewer, tombstone kept.
    let n = mech.joints().count();
    let pin_joint = mech.remove_joint(pin).unwrap();
    assert_eq!(pin_joint.name, "crank pin");
    assert!(mech.joint(pin).is_none());
    assert_eq!(mech.joints().count(), n - 1);
    assert_eq!(mech.joint(pri).unwrap().name, "slide");
    let lay = mech.layout();
    assert!(lay.joint_lambda(pin).is_empty());
    assert_eq!(lay.constraints(), 5 + 4 + 5 + 1);
    // The reduced model still assembles and runs; reactions and efforts by handle.
    let mech = Arc::new(mech);
    let mut sim = Simulation::new(mech.clone(), 0.0, SimulationOptions::default()).unwrap();
    let s = sim.run(&[0.01], |_| {}).unwrap().samples.pop().unwrap();
    assert!(s.reaction(&mech, pin).is_none());
    assert!(s.reaction(&mech, pri).is_some());
    assert!(s.driver_effort(&mech, motor).unwrap().is_finite());
    assert_eq!(sim.data().driver_effort(motor), s.driver_effort(&mech, motor));
}

#[test]
fn data_made_before_a_model_change_is_refused_by_the_analyses() {
    let (mut mech, _, _, _) = slider_crank();
    let an = Analysis::new(&mech).unwrap();
    let mut data = MechanismData::new(&mech);
    let (q0, _) = mech.initial_guess();
    let s0 = an.initial_state(&mech, &mut data, 0.0).unwrap();
    assert!(an.constraint_residual(&mech, &data, 0.0, &s0.q).unwrap() < 1e-12);
    // A force element changes no layout, but the data is stale all the same.
    let slider = body(&mech, "slider");
    mech.add_force(Box::new(lash::multibody::PointForce {
        name: "push".into(),
        body: slider,
        point: Vector3::zeros(),
        force: Arc::new(|_| Vector3::new(1.0, 0.0, 0.0)),
    }));
    let stale = |e: ModelError| {
        assert_eq!(e, ModelError::StaleData);
        let msg = e.to_string();
        assert!(
            msg.contains("different version of the model") && msg.contains("make a new MechanismData"),
            "{msg}"
        );
    };
    stale(an.assemble(&mech, &mut data, 0.0, &q0).unwrap_err());
    stale(an.initial_state(&mech, &mut data, 0.0).unwrap_err());
    stale(an.constraint_residual(&mech, &data, 0.0, &s0.q).unwrap_err());
    stale(an.singularity_measure(&mech, &data, 0.0, &s0.q).unwrap_err());
    stale(an.velocities(&mech, &mut data, 0.0, &s0.q, &s0.w).unwrap_err());
    stale(an.accelerations(&mech, &mut data, 0.0, &s0.q, &s0.w).unwrap_err());
    // Data of another model is refused too, even with the same number of bodies.
    let (other, _, _, _) = slider_crank();
    stale(an.assemble(&other, &mut data, 0.0, &q0).unwrap_err());
    // New data for the changed model works.
    let mut data = MechanismData::new(&mech);
    assert!(an.initial_state(&mech, &mut data, 0.0).is_ok());
}

#[test]
fn a_force_naming_a_body_of_another_model_is_refused_by_the_dae() {
    let mut big = Mechanism::new();
    big.add_body(RigidBody::rod("first", 1.0, 0.2));
    let foreign = big.add_body(RigidBody::rod("second", 1.0, 0.2));
    let mut mech = Mechanism::new();
    mech.add_body(RigidBody::rod("only", 1.0, 0.2));
    mech.add_force(Box::new(lash::multibody::PointForce {
        name: "stray push".into(),
        body: foreign,
        point: Vector3::zeros(),
        force: Arc::new(|_| Vector3::new(1.0, 0.0, 0.0)),
    }));
    let e = lash::multibody::MultibodyDae::new(Arc::new(mech))
        .expect_err("a body handle the model does not have is an error");
    let msg = e.to_string();
    assert!(
        msg.contains("stray push") && msg.contains("body handle 1"),
        "{msg}"
    );
}

#[test]
fn a_constraint_offset_moves_the_joint_and_its_acceleration_loads_it() {
    // A 2 kg bob 0.5 m below a driven revolute pivot about y.
    let mut mech = Mechanism::new();
    let bob = mech
        .add_body(RigidBody::new("bob", 2.0, Matrix3::identity() * 1e-3).at(Vector3::new(0.0, 0.0, -0.5)));
    let pivot = mech.revolute_at("pivot", Attach::Ground, bob, Vector3::zeros(), Vector3::y());
    mech.drive("q", pivot, MotionLaw::Constant(0.0), 0.0).unwrap();
    let analysis = Analysis::new(&mech).unwrap();
    let mut data = MechanismData::new(&mech);
    let (q0, w0) = mech.initial_guess();
    let nominal = analysis.state_at(&mech, &mut data, 0.0, &q0, &w0).unwrap();
    let f0 = data.reaction(&mech, pivot).unwrap().force;
    // Row 0 of the pivot: the bob's point sits 1 mm off the ground's along x.
    let row = mech.layout().joint_lambda(pivot).start;
    data.set_constraint_offset(row, 0.0, [1e-3, 0.0, 0.0]).unwrap();
    let shifted = analysis
        .state_at(&mech, &mut data, 0.0, &nominal.q, &nominal.w)
        .unwrap();
    let moved = shifted.body_position(bob) - nominal.body_position(bob);
    assert!((moved - Vector3::new(1e-3, 0.0, 0.0)).norm() < 1e-9, "{moved}");
    // Accelerated along x at 3 m/s², the pivot pushes the bob with m·a = 6 N more.
    data.set_constraint_offset(row, 0.0, [0.0, 0.0, 3.0]).unwrap();
    analysis
        .state_at(&mech, &mut data, 0.0, &nominal.q, &nominal.w)
        .unwrap();
    let f = data.reaction(&mech, pivot).unwrap().force;
    assert!((f[0] - f0[0] - 6.0).abs() < 1e-6, "{f:?} against {f0:?}");
    assert!((f[2] - f0[2]).abs() < 1e-6);
    // Cleared, the nominal comes back; a row out of range is an error.
    data.clear_constraint_offsets();
    let back = analysis
        .state_at(&mech, &mut data, 0.0, &shifted.q, &shifted.w)
        .unwrap();
    assert!((back.body_position(bob) - nominal.body_position(bob)).norm() < 1e-9);
    assert!(data.set_constraint_offset(99, 0.0, [1.0, 0.0, 0.0]).is_err());
}

#[test]
fn the_multipliers_sensitivity_to_acceleration_offsets_is_the_bobs_inertia() {
    // The bob of the test above, its pivot driven: a unit acceleration along x at the pivot
    // asks m = 2 N more of it, a unit angular acceleration of the drive asks the bob's
    // inertia about the pivot, 1e-3 + 2·0.5² = 0.501 N·m, of the driver — exactly, and as
    // central differences of the full analysis with the offsets set give them.
    let mut mech = Mechanism::new();
    let bob = mech
        .add_body(RigidBody::new("bob", 2.0, Matrix3::identity() * 1e-3).at(Vector3::new(0.0, 0.0, -0.5)));
    let pivot = mech.revolute_at("pivot", Attach::Ground, bob, Vector3::zeros(), Vector3::y());
    let driver = mech.drive("q", pivot, MotionLaw::Constant(0.3), 0.0).unwrap();
    let analysis = Analysis::new(&mech).unwrap();
    let mut data = MechanismData::new(&mech);
    let (q0, w0) = mech.initial_guess();
    data.prescribe_driver(driver, 0.0, [0.3, 0.5, 0.0]).unwrap();
    let s = analysis.state_at(&mech, &mut data, 0.0, &q0, &w0).unwrap();
    let lay = mech.layout();
    let (row, drow) = (lay.joint_lambda(pivot).start, lay.driver_lambda(driver).unwrap());
    let d = analysis
        .acceleration_offset_sensitivity(&mech, &mut data, 0.0, &s.q, &s.w, &[row, drow])
        .unwrap();
    let force = |dl: &[f64]| analysis.reactions(&mech, 0.0, &s.q, dl)[0].force;
    assert!((force(&d[0])[0] - 2.0).abs() < 1e-9, "{:?}", force(&d[0]));
    assert!((-d[1][drow] - 0.501).abs() < 1e-9, "{}", -d[1][drow]);
    // Against the analysis with the offsets set (central differences, ±1).
    let lambda_at =
        |data: &mut MechanismData| analysis.state_at(&mech, data, 0.0, &s.q, &s.w).unwrap().lambda;
    for (k, set) in [0, 1].into_iter().zip([true, false]) {
        let mut l = vec![];
        for a in [1.0, -1.0] {
            if set {
                data.set_constraint_offset(row, 0.0, [0.0, 0.0, a]).unwrap();
            } else {
                data.prescribe_driver(driver, 0.0, [0.3, 0.5, a]).unwrap();
            }
            l.push(lambda_at(&mut data));
            data.clear_constraint_offsets();
            data.prescribe_driver(driver, 0.0, [0.3, 0.5, 0.0]).unwrap();
        }
        for (i, x) in d[k].iter().enumerate() {
            let fd = (l[0][i] - l[1][i]) / 2.0;
            assert!(
                (x - fd).abs() < 1e-8 * (1.0 + fd.abs()),
                "row {k}, λ {i}: {x} against {fd}"
            );
        }
    }
}
