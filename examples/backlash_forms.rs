//! How far the suite's two forms of drive backlash differ, and how steep the gear mesh's
//! record is in what a diagnosis cannot see: one recording of the concealed-effects suite's
//! design with drive B's backlash as a gear mesh (`GearMesh::example`, 10 µrad half play)
//! simulated again with the flank's restitution 0.6 instead of 0.8, the output gear's
//! inertia doubled, the flank 10× stiffer, and beside it the same backlash as a dead zone in
//! the transmission's own spring (`DriveTruth::backlash`). Prints, per drive and time window,
//! the RMS difference of the drive torques from the gear-mesh run in torque-noise units,
//! beside the backlash's whole effect (the run less the nominal truth).
//!
//! ```text
//! cargo run --release --example backlash_forms -- [recording 1-6] [half play rad]
//! cargo run --release --example backlash_forms -- 5 1e-5
//! ```
//! (about a minute: six truth simulations of 5 s.)

mod common;

use lash::contact::NormalLaw;
use lash::diagnose::suite::SuiteOptions;
use lash::mechanisms::mr2120::truth::{
    simulate_run, GearMesh, TruthRun, TruthSpec, GEAR_MESH_REFERENCE_RATE,
};
use std::error::Error;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let recording: usize = args.first().map(|s| s.parse()).transpose()?.unwrap_or(5);
    if !(1..=6).contains(&recording) {
        return Err(format!("recording {recording}: 1 to 6").into());
    }
    let b: f64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(1e-5);
    let (path, ropts) = SuiteOptions::default().recording_setup(recording - 1);
    let run = |change: &dyn Fn(&mut TruthSpec)| {
        let mut spec = TruthSpec::nominal();
        change(&mut spec);
        simulate_run(&spec, &path, &ropts)
    };
    let mesh = GearMesh::example(b);
    let base = run(&|s| s.drives[1].gear = Some(mesh))?;
    let nominal = run(&|_| {})?;
    let end = base.t.last().copied().unwrap_or(0.0) + 1e-9;
    let windows = [(0.6, 2.5), (2.5, 3.0), (3.0, end), (0.6, end)];
    let sigma = ropts.noise.torque;
    println!(
        "recording {recording}, drive B gear mesh with ±{:.1} µrad: the drive torques' RMS difference from this run, torque-noise units ({sigma} N·m)",
        b * 1e6
    );
    let print =
        |name: &str, other: &TruthRun| common::print_torque_differences(name, &base, other, &windows, sigma);
    print("the backlash's whole effect (the nominal truth)", &nominal);
    let flank = |restitution: f64, k: f64| NormalLaw::Flores {
        k,
        n: 1.5,
        restitution,
        v_ref: GEAR_MESH_REFERENCE_RATE,
    };
    let (k0, e0) = match mesh.law {
        NormalLaw::Flores { k, restitution, .. } => (k, restitution),
        _ => unreachable!("the example's flank is Flores et al.'s"),
    };
    print(
        "flank restitution 0.6",
        &run(&|s| {
            s.drives[1].gear = Some(GearMesh {
                law: flank(0.6, k0),
                ..mesh
            })
        })?,
    );
    print(
        "flank 10× stiffer",
        &run(&|s| {
            s.drives[1].gear = Some(GearMesh {
                law: flank(e0, 10.0 * k0),
                ..mesh
            })
        })?,
    );
    print(
        "output gear's inertia × 2",
        &run(&|s| {
            s.drives[1].gear = Some(GearMesh {
                inertia: 2.0 * mesh.inertia,
                ..mesh
            })
        })?,
    );
    print(
        "the same play as a dead zone in the transmission's spring",
        &run(&|s| s.drives[1].backlash = b)?,
    );
    Ok(())
}
