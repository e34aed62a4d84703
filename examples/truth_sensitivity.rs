//! How far the suite's clearance truth moves under changes a diagnosis cannot see: one
//! recording of the concealed-effects suite's design (joint F with radial clearance, Hertz
//! trunnion bearings, lubricated: Hunt–Crossley α = 300 s/m) simulated again at tolerances
//! ÷ 10, with the play 10⁻⁴ and 4 % larger, and with α = 100 and 1 000 s/m. Prints, per drive
//! and time window, the RMS difference of the drive torques from the first run in
//! torque-noise units, beside the play's whole effect (the first run less the same truth
//! without clearance).
//!
//! What it shows (diagnosis log, "Load-proportional contact damping"): the rattle after the load
//! peak near the direct singularity is deterministic (tolerances and a 10⁻⁴ change move it by
//! hundredths of the noise), but steep in the play and in the contact's damping — a model of
//! it must size the play within a few per cent and damp the contact as the truth does.
//!
//! ```text
//! cargo run --release --example truth_sensitivity -- [recording 1-6] [radial clearance m]
//! cargo run --release --example truth_sensitivity -- 5 6e-6
//! ```
//! (about a minute per variant: eight truth simulations of 5 s.)

mod common;

use lash::contact::{BearingDesign, Damping};
use lash::diagnose::suite::SuiteOptions;
use lash::mechanisms::mr2120::clearance::LUBRICATED_ALPHA;
use lash::mechanisms::mr2120::truth::{simulate_run, TruthRun, TruthSpec};
use std::error::Error;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let recording: usize = args.first().map(|s| s.parse()).transpose()?.unwrap_or(5);
    if !(1..=6).contains(&recording) {
        return Err(format!("recording {recording}: 1 to 6").into());
    }
    let h: f64 = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(6e-6);
    let (path, ropts) = SuiteOptions::default().recording_setup(recording - 1);
    // Joint F with clearance h and Hunt–Crossley α (s/m); tolerances divided by `tighter`.
    let run = |h: f64, alpha: f64, tighter: f64| {
        let mut spec = TruthSpec::nominal();
        spec.joints[2] = Some(BearingDesign::mr2120(h, 0.0, Damping::HuntCrossley(alpha)));
        spec.solver.rtol /= tighter;
        spec.solver.atol /= tighter;
        spec.solver.h_max /= tighter.sqrt();
        simulate_run(&spec, &path, &ropts)
    };
    let base = run(h, LUBRICATED_ALPHA, 1.0)?;
    let without = run(0.0, LUBRICATED_ALPHA, 1.0)?;
    let end = base.t.last().copied().unwrap_or(0.0) + 1e-9;
    let windows = [(0.6, 2.6), (2.6, 2.77), (2.77, 3.1), (3.1, end), (0.6, end)];
    let sigma = ropts.noise.torque;
    println!(
        "recording {recording}, {:.1} µm radial clearance in joint F, α = {LUBRICATED_ALPHA} s/m: the drive torques' RMS difference from this run, torque-noise units ({sigma} N·m)",
        h * 1e6
    );
    let print =
        |name: &str, other: &TruthRun| common::print_torque_differences(name, &base, other, &windows, sigma);
    print("the play's whole effect (the truth without clearance)", &without);
    print("tolerances ÷ 10", &run(h, LUBRICATED_ALPHA, 10.0)?);
    print(
        "play × (1 + 1e-4)",
        &run(h * (1.0 + 1e-4), LUBRICATED_ALPHA, 1.0)?,
    );
    print("play × 1.04", &run(h * 1.04, LUBRICATED_ALPHA, 1.0)?);
    for alpha in [100.0, 1000.0] {
        print(&format!("α = {alpha} s/m"), &run(h, alpha, 1.0)?);
    }
    Ok(())
}
