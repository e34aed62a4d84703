//! The reduced dynamic play model ([`lash::diagnose::play_dynamics`]) against the multibody
//! truth: one recording of the concealed-effects suite's design simulated twice by the truth
//! (the 63-DOF-style model with Hertz trunnion bearings in one joint, with and without
//! clearance, noise-free), and the play's effect on the drive torques — the difference of the
//! two — set beside what the reduced model, linearised about the nominal multibody model,
//! predicts for the same play: its response with the play less without (as the axial-play
//! candidates use it) and, in parentheses over the whole record, its response alone (as the
//! radial-play candidates use it: the truth's balls fit their bores without radial
//! clearance, a much stiffer contact than the model's). Then the same for the tracker (the
//! platform centre): the truth's effect against the reduced model's (its play coordinates
//! and extra wind-up through the nominal model's output sensitivities; with the play less
//! without in parentheses) and the quasi-static shift at load scales of 1, 5 and 20 N.
//! Prints the RMS per channel and time window in noise units and writes plots and
//! `drives.csv` (every sample's torque effect, truth and model, N·m, and the joint's play
//! coordinates with clearance, truth and model, m and rad); then, against
//! a third truth with no bearing in the joint (the ideal joint the diagnosis's nominal model
//! has), the balls' own compliance at zero clearance (tight − ideal) and what the reduced
//! model's run without play leaves of it — the joint's contact-compliance candidate under
//! Hertz's law — and what the response with the play leaves of the whole (with − ideal);
//! then the joint's play coordinates in the truth and the model side by side over the plot
//! window. `LASH_LAG_SCAN=1` also prints drive C's miss with the model's effect shifted by
//! −3 … +3 samples (a timing error shows as a minimum away from 0). The model reads the
//! encoders as a diagnosis does with `LASH_SENSOR_NOISE=f` (white noise of f × the suite's
//! encoder and rate noise on the angles and rates, seeded) and `LASH_QDD_CUBIC=8` (the rates
//! differentiated by local cubics over ±8 samples, the suite's setting; by default central
//! differences). `against-ideal.csv` holds, every sample, the truth with clearance less the
//! ideal truth and the model's responses with and without the play (N·m): the columns a
//! diagnosis combines, to set beside its `holdout-<recording>-<channel>.csv`.
//! `LASH_FOREARM_A=d` lengthens forearm A by d m in every truth (the suite's
//! clearance-under-length case: 3e-5), so the play's effect is the one beside that larger
//! effect; `LASH_MODEL_FOREARM_A=d` expands the reduced model about a forearm A d m longer,
//! the point a diagnosis reaches once it has estimated that length. `LASH_SEED=n` takes the
//! recording's commanded path from the suite at seed n (`lash diagnose --suite --seed n`;
//! default the suite's seed).
//!
//! ```text
//! cargo run --release --example play_dynamics -- [joint D|E|F|P|Q|R] [radial clearance m[,axial play m]] [recording 1-6] [out dir] [ball stiffness N/m, or hertz] [ball damping N·s/m] [plot window t0,t1 s] [re-linearisation passes] [load-proportional damping γ s/m] [interpolation linear|held] [the model's radial clearance m]
//! cargo run --release --example play_dynamics -- F 6e-6 5 out/play-dynamics
//! cargo run --release --example play_dynamics -- D 0,1e-5 5 out/play-dynamics-axial
//! cargo run --release --example play_dynamics -- F 6e-6 5 out/play-dynamics-relin 1e8 200 2.5,3.1 1
//! cargo run --release --example play_dynamics -- F 6e-6 5 out/play-dynamics-gamma hertz 200 0,5 0 1000
//! cargo run --release --example play_dynamics -- F 6e-6 5 out/play-dynamics-blended hertz 20 0,5 1 500 linear 5.8e-6
//! ```
//! The third: the reduced model with the play re-linearised
//! ([`InverseDynamicsModel::play_dynamics_at`](lash::diagnose::model::InverseDynamicsModel::play_dynamics_at))
//! about its own motion of the first pass at every sample in the plot window, once; the
//! tracker's prediction then reads the platform there to all orders and about it to first
//! order through the sample's sensitivities. The fourth:
//! Hertz balls damped by 200 N·s/m + 1 000 s/m × their elastic force (diagnosis log,
//! "Load-proportional contact damping"). The fifth: the forces blended from sample to
//! sample, and the model's play 3.3 % below the truth's (diagnosis log, "The rattle reproduced at
//! the truth's play").
//! (about a minute: two truth simulations and the nominal model's play derivatives at every
//! sample).

use lash::contact::BearingDesign;
use lash::diagnose::model::InverseDynamicsModel;
use lash::diagnose::mr2120::mr2120_model;
use lash::diagnose::play_dynamics::{
    expanded_about, respond, BallContact, HertzBalls, Interpolation, JointPlay, PlayResponse, PlaySample,
    BALL_CONTACT,
};
use lash::diagnose::signal::derivative_cubic;
use lash::diagnose::suite::SuiteOptions;
use lash::mechanisms::mr2120::clearance::LUBRICATED_DAMPING;
use lash::mechanisms::mr2120::truth::{simulate_run, TruthSpec};
use lash::plot::{LineChart, Series};
use std::error::Error;
use std::path::PathBuf;

const JOINTS: [&str; 6] = ["D", "E", "F", "P", "Q", "R"];

/// An optional setting from the environment: `None` when `var` is unset, an error naming the
/// variable when its value does not parse.
fn env_parse<T: std::str::FromStr>(var: &str) -> Result<Option<T>, Box<dyn Error>>
where
    T::Err: std::fmt::Display,
{
    match std::env::var(var) {
        Err(_) => Ok(None),
        Ok(s) => s
            .parse()
            .map(Some)
            .map_err(|e| format!("{var}='{s}': {e}").into()),
    }
}

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
    // The model's radial clearance (m; default the truth's): how much a size error costs.
    let h_model: f64 = args.get(10).map(|s| s.parse()).transpose()?.unwrap_or(h);
    let recording: usize = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(5);
    if !(1..=6).contains(&recording) {
        return Err(format!("recording {recording}: 1 to 6").into());
    }
    let out = PathBuf::from(args.get(3).map(String::as_str).unwrap_or("out/play-dynamics"));
    std::fs::create_dir_all(&out)?;
    // Ball stiffness: a number (N/m, the linear law) or `hertz` (Hertz's law with the
    // constants of the joint's own bearing design at this clearance).
    let hertz = args.get(4).is_some_and(|s| s == "hertz");
    let contact = BallContact {
        stiffness: match args.get(4) {
            Some(s) if !hertz => s.parse()?,
            _ => BALL_CONTACT.stiffness,
        },
        axial_stiffness: match args.get(4) {
            Some(s) if !hertz => s.parse()?,
            _ => BALL_CONTACT.axial_stiffness,
        },
        damping: args
            .get(5)
            .map(|s| s.parse())
            .transpose()?
            .unwrap_or(BALL_CONTACT.damping),
        load_damping: args.get(8).map(|s| s.parse()).transpose()?.unwrap_or(0.0),
        hertz: if hertz {
            Some(HertzBalls::from_design(&BearingDesign::mr2120(
                h_model,
                h_a,
                LUBRICATED_DAMPING,
            ))?)
        } else {
            None
        },
    };
    // Within a sample interval: the forces `held` at the interval's end (default, as the
    // diagnosis by default and every figure before 2026-11-30), or blended from sample to
    // sample (`linear`).
    let interpolation = match args.get(9).map(String::as_str) {
        Some("linear") => Interpolation::Linear,
        None | Some("held") => Interpolation::Held,
        Some(other) => return Err(format!("interpolation '{other}': linear or held").into()),
    };
    // Re-linearisation passes in the plot window (default none).
    let passes: usize = args.get(7).map(|s| s.parse()).transpose()?.unwrap_or(0);
    // The plots' time window, s (default from 0.6 s, after the start-up, to the end).
    let (plot_from, plot_to): (f64, f64) = match args.get(6).map(|s| s.split_once(',')) {
        None => (0.6, f64::INFINITY),
        Some(Some((a, b))) => (a.parse()?, b.parse()?),
        Some(None) => return Err(format!("plot window '{}': two times, s, as t0,t1", args[6]).into()),
    };

    // The truth, with and without clearance in the joint (a Hertz bearing both times).
    // `LASH_SEED=n`: the suite's paths at seed n (`lash diagnose --suite --seed n`).
    let suite = SuiteOptions::default();
    let suite = SuiteOptions {
        seed: env_parse("LASH_SEED")?.unwrap_or(suite.seed),
        ..suite
    };
    let (path, ropts) = suite.recording_setup(recording - 1);
    // `LASH_FOREARM_A=d`: every truth's forearm A d m longer (m).
    let forearm_a: f64 = env_parse("LASH_FOREARM_A")?.unwrap_or(0.0);
    let truth_spec = || {
        let mut spec = TruthSpec::nominal();
        spec.links.forearm_length[0] += forearm_a;
        spec
    };
    let truth = |radial: f64, axial: f64| {
        let mut spec = truth_spec();
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
    let mut theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    // `LASH_MODEL_FOREARM_A=d`: the reduced model expanded about a forearm A d m longer (m).
    if let Some(d) = env_parse::<f64>("LASH_MODEL_FOREARM_A")? {
        let k = model
            .parameters()
            .iter()
            .position(|p| p.name == "forearm A length")
            .ok_or("the nominal model has no parameter 'forearm A length'")?;
        theta[k] += d;
    }
    let theta = theta;
    let t = &tight.t;
    let n = t.len();
    let mut lin = Vec::with_capacity(n);
    let mut sens = Vec::with_capacity(n);
    let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
    // The rates differentiated as the diagnosis does (`LASH_QDD_CUBIC=8`: local cubics over
    // ±8 samples, the suite's setting), or by central differences (default).
    let cubic: Option<usize> = env_parse("LASH_QDD_CUBIC")?;
    // `LASH_SENSOR_NOISE=f` reads the motion through the suite's encoders and rate channels
    // times f: white noise of f × their standard deviations on the angles and rates (seeded).
    let noise_factor: Option<f64> = env_parse("LASH_SENSOR_NOISE")?;
    // (The motors follow their command in both truths: the encoders of the truth with
    // clearance read the same angles and rates as those of the truth without.)
    let mut tight = tight;
    if let Some(f) = noise_factor {
        let sd = lash::mechanisms::mr2120::record::SensorNoise::default().scaled(f);
        let mut rng = lash::mechanisms::mr2120::record::Rng::new(0x9e37_79b9_7f4a_7c15);
        for j in 0..3 {
            for i in 0..tight.t.len() {
                tight.q[j][i] += sd.encoder * rng.normal();
                tight.qd[j][i] += sd.rate * rng.normal();
            }
        }
    }
    let tight = tight;
    let t = &tight.t;
    let qdd_cubic: Option<Vec<Vec<f64>>> =
        cubic.map(|h| (0..3).map(|j| derivative_cubic(t, &tight.qd[j], h)).collect());
    // The encoders' motion at sample i: angles, rates, rates differenced.
    let motion_at = |i: usize| {
        let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
        let q: Vec<f64> = (0..3).map(|j| tight.q[j][i]).collect();
        let qd: Vec<f64> = (0..3).map(|j| tight.qd[j][i]).collect();
        let qdd: Vec<f64> = (0..3)
            .map(|j| match &qdd_cubic {
                Some(c) => c[j][i],
                None => (tight.qd[j][b] - tight.qd[j][a]) / (t[b] - t[a]),
            })
            .collect();
        (q, qd, qdd)
    };
    for i in 0..n {
        let (q, qd, qdd) = motion_at(i);
        model.evaluate_at(t[i], &theta, &q, &qd, &qdd, &mut tau, &mut y);
        // (Before the play's derivatives, which perturb the model's cached sample.)
        sens.push(
            model
                .output_sensitivities(&theta, &q, &qd, &qdd, &y)
                .and_then(|mut s| (site < s.play.len()).then(|| s.play.swap_remove(site))),
        );
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
                about: None,
            })
        })
        .collect();
    // The play's effect in the reduced model, as in the truth: with the play less without
    // (the balls' own compliance is in both).
    let clock = std::time::Instant::now();
    let loose_model = respond(
        &samples,
        &JointPlay {
            radial: h_model,
            axial: h_a,
        },
        &contact,
        interpolation,
    );
    let mut loose_model = loose_model;
    // Re-linearised: the nominal model expanded about the last pass's motion of the play
    // (its wind-up and play coordinates) at every sample of the plot window, `passes` times.
    for pass in 0..passes {
        let clock = std::time::Instant::now();
        let mut points = vec![None; n];
        for i in 0..n {
            let (q, qd, qdd) = motion_at(i);
            model.evaluate_at(t[i], &theta, &q, &qd, &qdd, &mut tau, &mut y);
            if t[i] < plot_from || t[i] > plot_to {
                continue;
            }
            if let Some(r) = &loose_model[i] {
                points[i] = model.play_dynamics_at(&theta, &q, &qd, &qdd, site, &r.windup, r.offset);
            }
        }
        let about = expanded_about(&samples, &points);
        loose_model = respond(
            &about,
            &JointPlay {
                radial: h_model,
                axial: h_a,
            },
            &contact,
            interpolation,
        );
        eprintln!(
            "re-linearisation pass {}: {} of {n} samples about the last pass's motion, {:.1} s",
            pass + 1,
            points.iter().flatten().count(),
            clock.elapsed().as_secs_f64()
        );
    }
    // Without clearance, Hertz balls fit their bores: a conformal, much stiffer contact.
    let tight_contact = BallContact {
        hertz: match contact.hertz {
            Some(_) => Some(HertzBalls::from_design(&BearingDesign::mr2120(
                0.0,
                0.0,
                LUBRICATED_DAMPING,
            ))?),
            None => None,
        },
        ..contact
    };
    let tight_model = respond(&samples, &JointPlay::default(), &tight_contact, interpolation);
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
        "joint {name}, radial clearance {:.1} µm (the model's {:.2} µm), axial play {:.1} µm, recording {recording}, balls {} and {:e} N·s/m + {} s/m × their force, \
         forces {} within a sample interval, {passes} re-linearisation pass(es): the play's effect on the drive torques \
         (truth with clearance − without) and what the reduced model leaves of it, RMS in torque-noise units ({sigma} N·m)",
        h * 1e6,
        h_model * 1e6,
        h_a * 1e6,
        match contact.hertz {
            Some(k) => format!("Hertz {:.3e} N/m^1.5 radially, {:.3e} axially", k.radial, k.axial),
            None => format!("{:e} N/m", contact.stiffness),
        },
        contact.damping,
        contact.load_damping,
        match interpolation {
            Interpolation::Linear => "blended from sample to sample",
            Interpolation::Held => "held at the interval's end",
        }
    );
    let what = format!(
        "the play of joint {name} ({:.1} µm radial, {:.1} µm axial), recording {recording}",
        h * 1e6,
        h_a * 1e6
    );
    // Every sample's effect and the model's, and the joint's play coordinates, for a closer
    // look than the RMS.
    {
        let mut csv = String::from(
            "t_s,truth_a_nm,truth_b_nm,truth_c_nm,model_a_nm,model_b_nm,model_c_nm,\
             truth_shift_x_m,truth_shift_y_m,truth_shift_z_m,truth_tilt_rad,\
             model_shift_x_m,model_shift_y_m,model_shift_z_m,model_tilt_rad\n",
        );
        // A field, empty where the model gave no response.
        let field = |v: Option<f64>| v.map_or(String::from(","), |v| format!(",{v:e}"));
        for i in 0..n {
            csv.push_str(&format!("{}", t[i]));
            for k in 0..3 {
                csv.push_str(&field(Some(loose.tau[k][i] - tight.tau[k][i])));
            }
            for k in 0..3 {
                csv.push_str(&field(reduced[i].as_ref().map(|r| r[k])));
            }
            for e in loose.joint_play[joint][i] {
                csv.push_str(&field(Some(e)));
            }
            for a in 0..4 {
                csv.push_str(&field(loose_model[i].as_ref().map(|m| m.offset[a])));
            }
            csv.push('\n');
        }
        std::fs::write(out.join("drives.csv"), csv)?;
    }
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
                .filter(|&i| t[i] >= plot_from && t[i] <= plot_to)
                .filter_map(|i| f(i).map(|v| (t[i], v)))
                .collect()
        };
        effect_chart(
            format!("drive {drive} torque: {what}"),
            "N·m",
            points(&|i| Some(effect(i))),
            points(&model_at),
            vec![],
        )
        .save(&out.join(format!("drive-{}", drive.to_lowercase())))?;
    }

    // Timing: the model's effect shifted by whole samples (model at i + lag against the
    // truth at i), drive C, in torque-noise units: a lag that lowers the miss is a delay.
    if std::env::var("LASH_LAG_SCAN").is_ok() {
        for (w0, w1) in [(0.6, 2.6), (2.77, 3.1)] {
            let mut line = format!("  lag scan, drive C, {w0:.2}–{w1:.2} s:");
            for lag in -3i64..=3 {
                let (mut s1, mut m) = (0.0, 0usize);
                for i in (0..n).filter(|&i| t[i] >= w0 && t[i] < w1) {
                    let j = i as i64 + lag;
                    if j < 0 || j >= n as i64 {
                        continue;
                    }
                    if let Some(x) = reduced[j as usize].as_ref() {
                        s1 += (loose.tau[2][i] - tight.tau[2][i] - x[2]).powi(2);
                        m += 1;
                    }
                }
                line.push_str(&format!(
                    "  {lag:+}: {:.2}",
                    (s1 / m.max(1) as f64).sqrt() / sigma
                ));
            }
            println!("{line}");
        }
    }

    // What the diagnosis's data hold beyond the play: the ideal truth (no bearing in the
    // joint) against the tight one — the balls' own compliance at zero clearance, which the
    // play's column (with the play less without) leaves to other candidates — and how the
    // reduced model's tight run and its response alone (with the play, not less without)
    // match it, over 0.6 s to the end, in torque-noise units.
    let ideal = simulate_run(&truth_spec(), &path, &ropts)?;
    // Every sample against the ideal truth (`against-ideal.csv`, N·m): the truth with
    // clearance less the ideal one, and the reduced model's responses with and without the
    // play — the columns a diagnosis combines (the play's as the difference of the two,
    // scaled to its estimate, the compliance's as the response without, scaled by its factor).
    {
        let field = |x: Option<f64>| x.map_or(",".to_string(), |v| format!(",{v:e}"));
        let mut csv = String::from(
            "t_s,whole_a_nm,whole_b_nm,whole_c_nm,loose_model_a_nm,loose_model_b_nm,loose_model_c_nm,tight_model_a_nm,tight_model_b_nm,tight_model_c_nm\n",
        );
        for i in 0..n {
            csv.push_str(&format!("{}", t[i]));
            for k in 0..3 {
                csv.push_str(&format!(",{:e}", loose.tau[k][i] - ideal.tau[k][i]));
            }
            for k in 0..3 {
                csv.push_str(&field(loose_model[i].as_ref().map(|m| m.torque[k])));
            }
            for k in 0..3 {
                csv.push_str(&field(tight_model[i].as_ref().map(|m| m.torque[k])));
            }
            csv.push('\n');
        }
        std::fs::write(out.join("against-ideal.csv"), csv)?;
    }
    for (k, drive) in ["A", "B", "C"].iter().enumerate() {
        let (mut s0, mut s1, mut s2, mut s3, mut m) = (0.0, 0.0, 0.0, 0.0, 0usize);
        for i in (0..n).filter(|&i| t[i] >= 0.6) {
            if let (Some(a), Some(b)) = (&loose_model[i], &tight_model[i]) {
                let compliance = tight.tau[k][i] - ideal.tau[k][i];
                let whole = loose.tau[k][i] - ideal.tau[k][i];
                s0 += compliance.powi(2);
                s1 += (compliance - b.torque[k]).powi(2);
                s2 += whole.powi(2);
                s3 += (whole - a.torque[k]).powi(2);
                m += 1;
            }
        }
        let rms = |s: f64| (s / m.max(1) as f64).sqrt() / sigma;
        println!(
            "  drive {drive}, against the ideal truth: tight − ideal {:.2} → model's tight run leaves {:.2}; with clearance − ideal {:.2} → response alone leaves {:.2}",
            rms(s0),
            rms(s1),
            rms(s2),
            rms(s3)
        );
    }

    // The joint's own motion: its play coordinates in the truth (`TruthRun::joint_play`) and
    // in the reduced model, with and without the clearance, beside drive A's torque effect:
    // where the two part, whether the model moves the joint differently or turns the same
    // motion into different torques.
    let rows = (plot_to.min(t[n - 1]) - plot_from).max(0.0);
    let every = (rows / 20.0).max(0.01);
    println!(
        "joint {name}'s play coordinates (shift of side j from side i along x, y, z in µm; tilt about n in µrad) and drive A's torque effect (with − without, N·m), every {:.0} ms:",
        every * 1e3
    );
    println!(
        "  {:>6}  {:^31}  {:^31}  {:^31}  {:^31}  {:>7} {:>7}",
        "t s",
        "truth with clearance",
        "model with clearance",
        "truth without",
        "model without",
        "truth",
        "model"
    );
    let fmt = |e: [f64; 4]| {
        format!(
            "{:+6.2} {:+6.2} {:+6.2} {:+8.1}",
            e[0] * 1e6,
            e[1] * 1e6,
            e[2] * 1e6,
            e[3] * 1e6
        )
    };
    let mut next = plot_from;
    for i in 0..n {
        if t[i] + 1e-9 < next || t[i] > plot_to {
            continue;
        }
        next = t[i] + every - 1e-9;
        let (Some(a), Some(b)) = (&loose_model[i], &tight_model[i]) else {
            continue;
        };
        println!(
            "  {:6.3}  {}  {}  {}  {}  {:+7.3} {:+7.3}",
            t[i],
            fmt(loose.joint_play[joint][i]),
            fmt(a.offset),
            fmt(tight.joint_play[joint][i]),
            fmt(b.offset),
            loose.tau[0][i] - tight.tau[0][i],
            a.torque[0] - b.torque[0]
        );
    }

    // The tracker: the play's effect on the platform centre (truth with clearance − without)
    // against the quasi-static play candidates' prediction (the joint where its nominal load
    // pushes it, smoothed over a load scale) and the reduced dynamic model's (its play
    // coordinates and its transmissions' extra wind-up, through the nominal model's output
    // sensitivities), in tracker-noise units.
    // −∂y/∂q_j along the recording (the arm lagging its encoder), central differences of the
    // whole model, its wind-up included (as the candidates take them).
    let walk = |shift: Option<(usize, f64)>| -> Vec<[f64; 3]> {
        let (mut tau, mut y) = (vec![0.0; 3], vec![0.0; 3]);
        (0..n)
            .map(|i| {
                let (mut q, qd, qdd) = motion_at(i);
                if let Some((j, h)) = shift {
                    q[j] += h;
                }
                model.evaluate_at(t[i], &theta, &q, &qd, &qdd, &mut tau, &mut y);
                [y[0], y[1], y[2]]
            })
            .collect()
    };
    let step = 1e-6;
    let lag: Vec<Vec<[f64; 3]>> = (0..3)
        .map(|j| {
            let (plus, minus) = (walk(Some((j, -step))), walk(Some((j, step))));
            plus.iter()
                .zip(&minus)
                .map(|(a, b)| std::array::from_fn(|c| (a[c] - b[c]) / (2.0 * step)))
                .collect()
        })
        .collect();
    let sigma_y = ropts.noise.tracker;
    let axis = ["x", "y", "z"];
    let quasi_static = |i: usize, c: usize, load_scale: f64| -> Option<f64> {
        let p = sens[i].as_ref()?;
        // Side i's pair carries the cross besides, as in the diagnosis's columns.
        let sh =
            p.play
                .shift_with_cross_weight(&p.z_i, &p.z_j, &p.force, &p.moment, &p.cross_load, load_scale);
        Some(
            h * ((0..3)
                .map(|a| p.dy_dshift[a][c] * sh.radial_translation[a])
                .sum::<f64>()
                + p.dy_dtilt[c] * sh.radial_tilt)
                + h_a
                    * (0..3)
                        .map(|a| p.dy_dshift[a][c] * sh.axial_translation[a])
                        .sum::<f64>(),
        )
    };
    // To first order about the sample, or where the response was re-linearised about a
    // point of its motion, the outputs there (to all orders) and to first order about it.
    let tracker_of = |r: &[Option<PlayResponse>], i: usize, c: usize| -> Option<f64> {
        let p = sens[i].as_ref()?;
        let r = r[i].as_ref()?;
        Some(r.output(c, |offset, windup| {
            (0..3).map(|a| p.dy_dshift[a][c] * offset[a]).sum::<f64>()
                + p.dy_dtilt[c] * offset[3]
                + (0..3).map(|j| windup[j] * lag[j][i][c]).sum::<f64>()
        }))
    };
    let dynamic = |i: usize, c: usize| tracker_of(&loose_model, i, c);
    let dynamic_less_without =
        |i: usize, c: usize| Some(tracker_of(&loose_model, i, c)? - tracker_of(&tight_model, i, c)?);
    println!(
        "the tracker (platform centre): the play's effect and what each prediction leaves of it, RMS in tracker-noise units ({sigma_y} m)"
    );
    for c in 0..3 {
        let effect = |i: usize| loose.pose[c][i] - tight.pose[c][i];
        let mut line = format!("  platform {}:", axis[c]);
        for (w0, w1) in windows {
            let rms = |f: &dyn Fn(usize) -> Option<f64>| {
                let (mut s, mut m) = (0.0, 0usize);
                for i in (0..n).filter(|&i| t[i] >= w0 && t[i] < w1) {
                    if let (Some(x), Some(_)) = (f(i), dynamic(i, c)) {
                        s += (effect(i) - x).powi(2);
                        m += 1;
                    }
                }
                (m > 0).then(|| (s / m as f64).sqrt() / sigma_y)
            };
            let Some(e) = rms(&|_| Some(0.0)) else {
                line.push_str(&format!("  {w0:.2}–{w1:.2} s: no samples compared"));
                continue;
            };
            let fmt = |x: Option<f64>| x.map_or("–".to_string(), |v| format!("{v:.2}"));
            line.push_str(&format!(
                "  {w0:.2}–{w1:.2} s: {e:.2} → dynamic {} (less without {}), quasi-static 1/5/20 N {}/{}/{}",
                fmt(rms(&|i| dynamic(i, c))),
                fmt(rms(&|i| dynamic_less_without(i, c))),
                fmt(rms(&|i| quasi_static(i, c, 1.0))),
                fmt(rms(&|i| quasi_static(i, c, 5.0))),
                fmt(rms(&|i| quasi_static(i, c, 20.0))),
            ));
        }
        println!("{line}");
        let points = |f: &dyn Fn(usize) -> Option<f64>| -> Vec<(f64, f64)> {
            (0..n)
                .filter(|&i| t[i] >= plot_from && t[i] <= plot_to)
                .filter_map(|i| f(i).map(|v| (t[i], v * 1e6)))
                .collect()
        };
        effect_chart(
            format!("platform {}: {what}", axis[c]),
            "µm",
            points(&|i| Some(effect(i))),
            points(&|i| dynamic(i, c)),
            vec![Series {
                name: "quasi-static, 5 N load scale".into(),
                points: points(&|i| quasi_static(i, c, 5.0)),
            }],
        )
        .save(&out.join(format!("platform-{}", axis[c])))?;
    }
    println!(
        "plots: {0}/drive-{{a,b,c}}.png / .svg, {0}/platform-{{x,y,z}}.png / .svg",
        out.display()
    );
    Ok(())
}

/// A chart of a play's effect over time: the truth's (with clearance − without), the reduced
/// dynamic model's and any `more` series, in `unit`.
fn effect_chart(
    title: String,
    unit: &str,
    truth: Vec<(f64, f64)>,
    model: Vec<(f64, f64)>,
    more: Vec<Series>,
) -> LineChart {
    let mut series = vec![
        Series {
            name: "truth: with clearance − without".into(),
            points: truth,
        },
        Series {
            name: "reduced dynamic play model".into(),
            points: model,
        },
    ];
    series.extend(more);
    LineChart {
        title,
        x_label: "t [s]".into(),
        y_label: unit.into(),
        series,
        y_range: None,
    }
}
