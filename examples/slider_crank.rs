//! Build a mechanism with the multibody API, simulate it, and write CSV outputs.
//!
//! A spatial slider-crank: a crank turning about the vertical axis, a connecting rod with a
//! ball joint at the crank pin and a universal joint at the slider, a slider on a horizontal
//! guide, and a spring-damper pulling the slider back. The crank is driven at 2 rev/s.
//!
//! Run: `cargo run --release --example slider_crank` (writes out/slider_crank/*.csv)

use lash::multibody::{
    output, Attach, Mechanism, MotionLaw, RigidBody, Simulation, SimulationOptions, SpringDamper,
};
use nalgebra::{Rotation3, Vector3};
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (a, b) = (0.1, 0.3); // crank and rod lengths, m
    let tip = Vector3::new(a, 0.0, 0.0);
    let pin = Vector3::new(a + (b * b - 0.05f64.powi(2) - 0.1f64.powi(2)).sqrt(), 0.05, 0.1);

    let mut mech = Mechanism::new();
    let crank = mech.add_body(RigidBody::rod("crank", 0.5, a).at(tip / 2.0));
    let rod_axis = Rotation3::rotation_between(&Vector3::x(), &(pin - tip)).expect("not antiparallel");
    let rod = mech.add_body(
        RigidBody::rod("rod", 0.8, b)
            .at((tip + pin) / 2.0)
            .oriented(rod_axis.matrix()),
    );
    let slider = mech.add_body(RigidBody::cuboid("slider", 1.0, 0.05, 0.03, 0.03).at(pin));

    let pivot = mech.revolute_at("pivot", Attach::Ground, crank, Vector3::zeros(), Vector3::z());
    mech.spherical_at("crank pin", crank, rod, tip);
    mech.universal_at("wrist pin", rod, slider, pin, Vector3::y(), Vector3::z());
    let guide = mech.prismatic_along("guide", Attach::Ground, slider, pin, Vector3::x());
    // Crank angle θ(t) = 4π·t rad (2 rev/s).
    let motor = mech.drive(
        "motor",
        pivot,
        MotionLaw::Polynomial {
            coeffs: vec![0.0, 4.0 * std::f64::consts::PI],
        },
        0.0,
    )?;
    mech.add_force(Box::new(SpringDamper {
        name: "return spring".into(),
        i: (Attach::Ground, Vector3::new(0.6, 0.05, 0.1)),
        j: (Attach::Body(slider), Vector3::zeros()),
        stiffness: 500.0,
        damping: 2.0,
        free_length: 0.15,
    }));
    println!(
        "degrees of freedom: {} (0 with the motor)",
        mech.degrees_of_freedom()
    );

    let mech = Arc::new(mech);
    let mut sim = Simulation::new(mech.clone(), 0.0, SimulationOptions::default())?;
    let times: Vec<f64> = (1..=100).map(|k| k as f64 * 0.01).collect();
    let traj = sim.run(&times, |_| {})?;
    let last = traj.samples.last().expect("samples");
    println!(
        "after 1 s: slider at x = {:.4} m, {} steps",
        last.body_position(slider).x,
        sim.stats().steps
    );
    // The effort is the torque the motor applies about the pivot axis (positive: driving
    // the crank angle up).
    println!(
        "motor torque needed: {:.3} N·m",
        last.driver_effort(&mech, motor).expect("the motor's effort")
    );
    let reaction = last.reaction(&mech, guide).expect("the guide exists");
    println!(
        "guide reaction on the slider: {:?} N",
        reaction.force.map(|f| (f * 1e3).round() / 1e3)
    );

    std::fs::create_dir_all("out/slider_crank")?;
    let mut f = std::fs::File::create("out/slider_crank/bodies.csv")?;
    output::write_bodies_csv(&mut f, &mech, &traj.samples)?;
    let mut f = std::fs::File::create("out/slider_crank/joints.csv")?;
    output::write_reactions_csv(&mut f, &mech, sim.analysis(), &traj.samples)?;
    println!("wrote out/slider_crank/bodies.csv and joints.csv");
    Ok(())
}
