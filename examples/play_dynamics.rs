//! The reduced dynamic play model ([`lash::diagnose::play_dynamics`]) against the multibody
//! truth: one recording of the concealed-effects suite's design simulated twice by the truth
//! (the 63-DOF-style model with Hertz trunnion bearings in one joint, with and without
//! clearance, noise-free), and the play's effect on the drive torques — the difference of the
//! two — set beside what the reduced model, linearised about the nominal multibody model,
//! predicts for the same play: its response with the play less without (as the axial-play
//! candidates use it) and, in parentheses over the whole record, its response alone (as the
//! radial-play candidates use it: the truth's balls fit their bores without radial
//! clearance, a much stiffer contact than the model's). Prints the RMS per drive and time
//! window in torque-noise units and writes plots.
//!
//! ```text
//! cargo run --release --example play_dynamics -- [joint D|E|F|P|Q|R] [radial clearance m[,axial play m]] [recording 1-6] [out dir] [ball stiffness N/m] [ball damping N·s/m]
//! cargo run --release --example play_dynamics -- F 6e-6 5 out/play-dynamics
//! cargo run --release --example play_dynamics -- D 0,1e-5 5 out/play-dynamics-axial
//! ```
//! (about a minute: two truth simulations and the nominal model's play derivatives at every
//! sample).

use lash::contact::BearingDesign;
use lash::diagnose::model::InverseDynamicsModel;
use lash::diagnose::mr2120::mr2120_model;
use lash::diagnose::play_dynamics::{respond, BallContact, JointPlay, PlaySample, BALL_CONTACT};
use lash::diagnose::suite::{lumped::excitation, SuiteOptions};
use lash::mechanisms::mr2120::clearance::LUBRICATED_DAMPING;
use lash::mechanisms::mr2120::record::RecordOptions;
use lash::mechanisms::mr2120::truth::{simulate_run, TruthSpec};
use lash::plot::{LineChart, Series};
use std::error::Error;
use std::path::PathBuf;

const JOINTS: [&str; 6] = ["D", "E", "F", "P", "Q", "R"];

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map(String::as_str).unwrap_or("F");
    let joint = JOINTS
        .iter()
        .position(|j| *j == name)
        .ok_or_else(|| format!("joint '{name}': one of D, E, F, P, Q, R"))?;
    let (h, h_a): (f64, f64) = match args.get(1).map(|s| s.split_once(',')) {
        None => (6e-6, 0.0),
        Some(None) => (args[1].parse()?, 0.0),
        Some(Some((r, a))) => (r.parse()?, a.parse()?),
    };
    let recording: usize = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(5);
    if !(1..=6).contains(&recording) {
        return Err(format!("recording {recording}: 1 to 6").into());
    }
    let out = PathBuf::from(args.get(3).map(String::as_str).unwrap_or("out/play-dynamics"));
    std::fs::create_dir_all(&out)?;
    let contact = BallContact {
        stiffness: args
            .get(4)
            .map(|s| s.parse())
            .transpose()?
            .unwrap_or(BALL_CONTACT.stiffness),
        damping: args
            .get(5)
            .map(|s| s.parse())
            .transpose()?
            .unwrap_or(BALL_CONTACT.damping),
    };

    // The truth, with and without clearance in the joint (a Hertz bearing both times).
    let suite = SuiteOptions::default();
    let ropts = RecordOptions {
        torques: true,
        tracker: true,
        ..suite.record
    };
    let path = excitation(suite.seed, recording - 1);
    let truth = |radial: f64, axial: f64| {
        let mut spec = TruthSpec::nominal();
        spec.joints[joint] = Some(BearingDesign::mr2120(radial, axial, LUBRICATED_DAMPING));
        simulate_run(&spec, &path, &ropts)
    };
    let (tight, loose) = (truth(0.0, 0.0)?, truth(h, h_a)?);

    // The nominal model along the commanded motion (the encoders read the motors, which follow
    // their command in both truths).
    let spec = TruthSpec::nominal();
    let model = mr2120_model(&spec.geometry, &spec.mass)?;
    let site = model
        .play_sites()
        .iter()
        .position(|s| s == name)
        .ok_or("the nominal model has no play site for that joint")?;
    let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    let t = &tight.t;
    let n = t.len();
    let mut lin = Vec::with_capacity(n);
    let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
    for i in 0..n {
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let q: Vec<f64> = (0..3).map(|j| tight.q[j][i]).collect();
        let qd: Vec<f64> = (0..3).map(|j| tight.qd[j][i]).collect();
        let qdd: Vec<f64> = (0..3)
            .map(|j| (tight.qd[j][b] - tight.qd[j][a]) / (t[b] - t[a]))
            .collect();
        model.evaluate_at(t[i], &theta, &q, &qd, &qdd, &mut tau, &mut y);
        let play = model
            .play_dynamics(&theta, &q, &qd, &qdd)
            .and_then(|mut s| (site < s.len()).then(|| s.swap_remove(site)));
        lin.push(play.zip(model.transmission_dynamics(&theta)));
    }
    let samples: Vec<Option<PlaySample>> = lin
        .iter()
        .zip(t)
        .map(|(x, &t)| {
            x.as_ref().map(|(play, transmission)| PlaySample {
                t,
                play,
                transmission,
            })
        })
        .collect();
    // The play's effect in the reduced model, as in the truth: with the play less without
    // (the balls' own compliance is in both).
    let clock = std::time::Instant::now();
    let loose_model = respond(
        &samples,
        &JointPlay {
            radial: h,
            axial: h_a,
        },
        &contact,
    );
    let tight_model = respond(&samples, &JointPlay::default(), &contact);
    eprintln!(
        "the reduced model: {:.2} s for two runs",
        clock.elapsed().as_secs_f64()
    );
    let reduced: Vec<Option<Vec<f64>>> = loose_model
        .iter()
        .zip(&tight_model)
        .map(|(a, b)| {
            let (a, b) = (a.as_ref()?, b.as_ref()?);
            Some(a.torque.iter().zip(&b.torque).map(|(x, y)| x - y).collect())
        })
        .collect();

    // Side by side, in torque-noise units.
    let sigma = ropts.noise.torque;
    let windows = [
        (0.6, 2.6),
        (2.6, 2.77),
        (2.77, 3.1),
        (3.1, t[n - 1] + 1e-9),
        (0.6, t[n - 1] + 1e-9),
    ];
    println!(
        "joint {name}, radial clearance {:.1} µm, axial play {:.1} µm, recording {recording}, balls {:e} N/m and {:e} N·s/m: the play's effect on the drive torques \
         (truth with clearance − without) and what the reduced model leaves of it, RMS in torque-noise units ({sigma} N·m)",
        h * 1e6,
        h_a * 1e6,
        contact.stiffness,
        contact.damping
    );
    for (k, drive) in ["A", "B", "C"].iter().enumerate() {
        let effect = |i: usize| loose.tau[k][i] - tight.tau[k][i];
        let model_at = |i: usize| reduced[i].as_ref().map(|r| r[k]);
        let mut line = format!("  drive {drive}:");
        for (w0, w1) in windows {
            let (mut s0, mut s1, mut m) = (0.0, 0.0, 0usize);
            for i in (0..n).filter(|&i| t[i] >= w0 && t[i] < w1) {
                if let Some(x) = model_at(i) {
                    s0 += effect(i).powi(2);
                    s1 += (effect(i) - x).powi(2);
                    m += 1;
                }
            }
            let rms = |s: f64| (s / m.max(1) as f64).sqrt() / sigma;
            if m == 0 {
                // (The reduced model gave no response in the window: nothing compared.)
                line.push_str(&format!("  {w0:.2}–{w1:.2} s: no samples compared"));
                continue;
            }
            line.push_str(&format!("  {w0:.2}–{w1:.2} s: {:.2} → {:.2}", rms(s0), rms(s1)));
        }
        // Beside it, the model's response with the play alone (its balls' compliance not
        // taken out), as the radial-play candidates use it.
        let (mut s1, mut m) = (0.0, 0usize);
        for i in (0..n).filter(|&i| t[i] >= 0.6) {
            if let Some(x) = loose_model[i].as_ref() {
                s1 += (effect(i) - x.torque[k]).powi(2);
                m += 1;
            }
        }
        line.push_str(&format!(
            "  (response with the play alone: {:.2})",
            (s1 / m.max(1) as f64).sqrt() / sigma
        ));
        println!("{line}");
        let points = |f: &dyn Fn(usize) -> Option<f64>| -> Vec<(f64, f64)> {
            (0..n)
                .filter(|&i| t[i] >= 0.6)
                .filter_map(|i| f(i).map(|v| (t[i], v)))
                .collect()
        };
        LineChart {
            title: format!(
                "drive {drive} torque: the play of joint {name} ({:.1} µm radial, {:.1} µm axial), recording {recording}",
                h * 1e6,
                h_a * 1e6
            ),
            x_label: "t [s]".into(),
            y_label: "N·m".into(),
            series: vec![
                Series {
                    name: "truth: with clearance − without".into(),
                    points: points(&|i| Some(effect(i))),
                },
                Series {
                    name: "reduced dynamic play model".into(),
                    points: points(&model_at),
                },
            ],
            y_range: None,
        }
        .save(&out.join(format!("drive-{}", drive.to_lowercase())))?;
    }
    println!("plots: {}/drive-{{a,b,c}}.png / .svg", out.display());
    Ok(())
}
