//! The simulated multibody truth of the MR2120 (`mechanisms::mr2120::truth`): input checks,
//! agreement of the nominal truth with a quasi-static reference, friction at constant
//! velocity, noise statistics. Measurements (`--ignored`): integration error and wall time.

use lash::mechanisms::mr2120::record::{Excitation, RecordOptions};
use lash::mechanisms::mr2120::truth::*;

fn opts(duration: f64) -> RecordOptions {
    RecordOptions {
        duration,
        rate: 500.0,
        ..Default::default()
    }
}

fn max_rms(a: &[f64], b: &[f64]) -> (f64, f64) {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    let max = d.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let rms = (d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt();
    (max, rms)
}

#[test]
#[ignore]
fn measure_nominal_vs_reference() {
    for (name, ex) in [
        ("gentle", Excitation::random(11, 0.32, 0.0)),
        ("shaken", Excitation::random(11, 0.30, 10.0)),
    ] {
        let spec = TruthSpec::nominal();
        let o = opts(2.0);
        let run = simulate_run(&spec, &ex, &o).unwrap();
        let r = quasi_static_reference(&spec, &ex, &o).unwrap();
        println!("{name}: steps {} wall {:.2} s", run.steps, run.wall_s);
        for i in 0..3 {
            let (m, s) = max_rms(&run.tau[i], &r.tau[i]);
            println!(
                "  tau{i}: max {:.4} rms {:.4} N·m = {:.2}/{:.2} noise",
                m,
                s,
                m / 0.02,
                s / 0.02
            );
        }
        for i in 0..3 {
            let (m, s) = max_rms(&run.pose[i], &r.pose[i]);
            println!(
                "  x{i}: max {:.3e} rms {:.3e} m = {:.2}/{:.2} noise",
                m,
                s,
                m / 5e-6,
                s / 5e-6
            );
        }
    }
}

#[test]
#[ignore]
fn dump_nominal_vs_reference() {
    let shake: f64 = std::env::var("SHAKE").map(|v| v.parse().unwrap()).unwrap_or(0.0);
    let zlow = if shake > 0.0 { 0.30 } else { 0.32 };
    let ex = Excitation::random(11, zlow, shake);
    let mut spec = TruthSpec::nominal();
    if let Ok(v) = std::env::var("RAMP") {
        spec.settle_ramp = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("HOLD") {
        spec.settle_hold = v.parse().unwrap();
    }
    if let Ok(v) = std::env::var("DAMP") {
        for d in spec.drives.iter_mut() {
            d.damping = v.parse().unwrap();
        }
    }
    let o = opts(2.0);
    let run = simulate_run(&spec, &ex, &o).unwrap();
    let r = quasi_static_reference(&spec, &ex, &o).unwrap();
    for k in (0..run.t.len()).step_by(std::env::var("STEP").map(|v| v.parse().unwrap()).unwrap_or(10)) {
        println!(
            "{:.3} tau {:8.4} {:8.4} dtau {:8.5} {:8.5} {:8.5} dz {:9.3e} qa-qm {:9.3e} ref {:9.3e} dm {:.4} z {:.4}",
            run.t[k],
            run.tau[0][k],
            r.tau[0][k],
            run.tau[0][k] - r.tau[0][k],
            run.tau[1][k] - r.tau[1][k],
            run.tau[2][k] - r.tau[2][k],
            run.pose[2][k] - r.pose[2][k],
            run.arm[0][k] - run.q[0][k],
            -r.tau[0][k] / 1e4,
            lash::mechanisms::mr2120::kinematics::singularity(&spec.geometry, [run.q[0][k], run.q[1][k], run.q[2][k]], ex.at(run.t[k])).direct_measure,
            ex.at(run.t[k]).z
        );
    }
}
