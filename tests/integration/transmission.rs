//! Compliant transmissions and motor-side encoders in model files (`[[transmission]]`,
//! `side = "motor"`): what the simulation builds (a rotor on a spring, checked against the
//! static closed form), and a diagnosis that reads the encoder where it sits.
//!
//! The diagnosis case: recordings of `models/compliant_arm.toml` simulated by lash's
//! multibody solver (rotor body, torsion spring-damper, arm) with friction on the arm's joint
//! that the nominal file does not have: viscous 0.3 N m s/rad and Coulomb 0.2 N m smoothed by
//! tanh(v / 0.02 rad/s). The recorded angle and rate are the rotor's (encoder noise 1 µrad,
//! rate noise 2 mrad/s), the torque the motor's (noise 0.02 N m). The diagnosis models the
//! transmission its own way (a wind-up integrated along the recording,
//! `diagnose::transmission`), not with the rotor body.

use lash::diagnose::columns::{csv_header, resolve_columns};
use lash::diagnose::mechanism::EncoderPlacement;
use lash::diagnose::model::InverseDynamicsModel;
use lash::diagnose::model_file::model_from_file;
use lash::diagnose::recording::read_csv;
use lash::diagnose::{diagnose_recordings, DiagnoseOptions, Diagnosis};
use lash::model_file::{simulate, ModelFile};
use lash::multibody::SimulationOptions;
use std::path::{Path, PathBuf};

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models")
}

fn scratch(name: &str) -> crate::scratch::Dir {
    crate::scratch::dir(&format!("transmission-{name}"))
}

/// Deterministic standard normal numbers (xorshift and Box–Muller).
struct Noise(u64);
impl Noise {
    fn gauss(&mut self) -> f64 {
        let mut u = || {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        };
        let (a, b) = (u().max(1e-300), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

/// Held at an angle, the arm hangs behind its motor by the compliance times the gravity
/// torque it carries, and the motor's torque is that gravity torque: the rotor, spring and
/// sensors the file declares, against m g r sin q (the arm of `compliant_arm.toml`: 2 kg,
/// centre of mass 0.25 m from the axis, 5e-4 rad/(N m)).
#[test]
fn a_held_arm_lags_its_motor_by_the_compliance_times_its_load() {
    let text = std::fs::read_to_string(models().join("compliant_arm.toml")).unwrap();
    let law = "law = \"rest_to_rest\"\nt0 = 0\nt1 = 1\nfrom = 0\nto = \"60 deg\"\n";
    let text = text
        .replace("law = \"sampled\"\n", law)
        .replace("file = \"compliant_arm_command.csv\"\n", "")
        .replace("column = \"angle\"\n", "");
    let file = ModelFile::from_text("held_arm.toml", &text).unwrap();
    let (_, rec) = simulate(
        file.build().unwrap(),
        3.0,
        1e-3,
        SimulationOptions::default(),
        |_| {},
    )
    .unwrap();
    let last = rec.rows.last().unwrap();
    // Columns: q (motor side), qd (motor side), torque, arm_angle (joint side).
    let (motor, rate, torque, arm) = (last[0], last[1], last[2], last[3]);
    let gravity_torque = 2.0 * 9.81 * 0.25 * arm.sin();
    assert!((motor - 60f64.to_radians()).abs() < 1e-9, "motor at {motor} rad");
    assert!(rate.abs() < 1e-9, "motor rate {rate} rad/s");
    let windup = motor - arm;
    assert!(
        (windup - 5e-4 * gravity_torque).abs() < 1e-7,
        "wind-up {windup} rad, compliance × load {} rad",
        5e-4 * gravity_torque
    );
    assert!(
        (torque - gravity_torque).abs() < 1e-4,
        "motor torque {torque} N m, gravity torque {gravity_torque} N m"
    );
}

/// A prismatic transmission (a belt, say) on a vertical axis: the carriage hangs below its
/// motor's carriage by the compliance times its weight, the motor's force carries the
/// weight of both.
#[test]
fn a_prismatic_transmission_stretches_by_the_compliance_times_the_weight() {
    let text = r#"
[[body]]
name = "carriage"
mass = 3.0
inertia = [0.01, 0.01, 0.01]
position = [0, 0, 0]
[[joint]]
name = "lift"
type = "prismatic"
i = "ground"
j = "carriage"
point = [0, 0, 0]
axis = [0, 0, 1]
[[transmission]]
joint = "lift"
compliance = "0.02 mm/N"
rotor_inertia = "0.5 kg"
damping = "400 N s/m"
[[driver]]
name = "motor"
joint = "lift"
law = "constant"
value = 0
[[sensor]]
name = "motor_position"
type = "joint_position"
joint = "lift"
side = "motor"
[[sensor]]
name = "position"
type = "joint_position"
joint = "lift"
[[sensor]]
name = "force"
type = "joint_effort"
joint = "lift"
"#;
    let file = ModelFile::from_text("lift.toml", text).unwrap();
    let (_, rec) = simulate(
        file.build().unwrap(),
        1.0,
        1e-3,
        SimulationOptions::default(),
        |_| {},
    )
    .unwrap();
    let last = rec.rows.last().unwrap();
    let stretch = last[0] - last[1];
    assert!(
        (stretch - 2e-5 * 3.0 * 9.81).abs() < 1e-8,
        "stretch {stretch} m, compliance × weight {} m",
        2e-5 * 3.0 * 9.81
    );
    assert!(
        (last[2] - 3.5 * 9.81).abs() < 1e-5,
        "motor force {} N, weight of carriage and rotor {} N",
        last[2],
        3.5 * 9.81
    );
}

/// Records runs of the compliant arm with hidden arm friction, motor angles from
/// `commands` (phase, scale); returns the recordings' paths.
fn record(dir: &Path, commands: &[(f64, f64)], noise: &mut Noise) -> Vec<PathBuf> {
    let nominal = std::fs::read_to_string(models().join("compliant_arm.toml")).unwrap();
    let mut paths = vec![];
    for (k, &(phase, scale)) in commands.iter().enumerate() {
        let mut cmd = String::from("t,angle\n");
        for i in 0..=500 {
            let t = i as f64 * 0.01;
            let a = scale
                * (0.5 * (std::f64::consts::TAU * 0.4 * t + phase).sin()
                    + 0.25 * (std::f64::consts::TAU * 1.1 * t + 0.7 + 2.0 * phase).sin()
                    + 0.08 * (std::f64::consts::TAU * 2.9 * t + 1.9 + phase).sin());
            // From rest and back to rest (smoothstep over a second at each end).
            let r = (t / 1.0).min((5.0 - t) / 1.0).clamp(0.0, 1.0);
            cmd += &format!("{t},{}\n", r * r * (3.0 - 2.0 * r) * a);
        }
        std::fs::write(dir.join(format!("cmd{k}.csv")), cmd).unwrap();
        let truth = nominal.replace("compliant_arm_command.csv", &format!("cmd{k}.csv"))
            + "\n[[force]]\nname = \"hidden friction\"\ntype = \"friction\"\njoint = \"shoulder\"\n\
               viscous = 0.3\ncoulomb = 0.2\nvelocity_scale = 0.02\n";
        let path = dir.join(format!("truth{k}.toml"));
        std::fs::write(&path, truth).unwrap();
        let file = ModelFile::load(&path).unwrap();
        let (_, rec) = simulate(
            file.build().unwrap(),
            4.5,
            1e-3,
            SimulationOptions::default(),
            |_| {},
        )
        .unwrap();
        let mut csv = String::from("time,q,qd,torque\n");
        for (t, r) in rec.t.iter().zip(&rec.rows) {
            csv += &format!(
                "{t},{},{},{}\n",
                r[0] + 1e-6 * noise.gauss(),
                r[1] + 2e-3 * noise.gauss(),
                r[2] + 0.02 * noise.gauss()
            );
        }
        let p = dir.join(format!("rec{k}.csv"));
        std::fs::write(&p, csv).unwrap();
        paths.push(p);
    }
    paths
}

fn diagnose(model_path: &Path, recordings: &[PathBuf]) -> Diagnosis {
    let model = model_from_file(ModelFile::load(model_path).unwrap()).unwrap();
    let header = csv_header(&recordings[0]).unwrap();
    let map = resolve_columns(&model, None, &header).unwrap();
    let read = |p: &PathBuf| read_csv(p, "time", &map).unwrap();
    let n = recordings.len();
    let fit: Vec<_> = recordings[..n - 1].iter().map(read).collect();
    let held = vec![read(&recordings[n - 1])];
    diagnose_recordings(
        &model,
        &fit,
        &held,
        &model.derivative_windows(),
        &DiagnoseOptions::default(),
        |_, _| {},
    )
    .unwrap()
}

/// The file's motor-side encoder becomes the diagnosis's `EncoderPlacement::MotorSide` with
/// the transmission's compliance as a parameter; the hidden friction is found (both laws,
/// within 10 %) and the held-out torque residual comes within 2× the noise. The same
/// recordings read through a file without the transmission (the encoder taken for the
/// joint) leave at least three times as much.
#[test]
fn friction_behind_a_compliant_transmission_is_found_from_the_motor_side_encoder() {
    let dir = scratch("diagnose");
    let mut noise = Noise(0x9E3779B97F4A7C15);
    let recs = record(&dir, &[(0.0, 1.0), (1.3, 0.8), (0.6, 0.9)], &mut noise);

    let model = model_from_file(ModelFile::load(models().join("compliant_arm.toml")).unwrap()).unwrap();
    let p = model.parameters();
    let c = p
        .iter()
        .position(|p| p.name == "shoulder transmission compliance")
        .expect("the transmission's compliance is a diagnosis parameter");
    assert_eq!(p[c].nominal, 5e-4);
    assert_eq!(p[c].unit, "rad/(N m)");
    assert_eq!(
        model.sensors().encoders,
        vec![EncoderPlacement::MotorSide {
            compliance: c,
            rotor_inertia: 2e-3,
            damping: 3.5
        }]
    );

    let d = diagnose(&models().join("compliant_arm.toml"), &recs);
    eprintln!("with the transmission: {}", d.verdict);
    let value = |what: &str| {
        d.estimates
            .iter()
            .find(|e| e.candidate.starts_with(what))
            .map(|e| e.value)
            .unwrap_or_else(|| panic!("no '{what}' among {:?}: {}", d.selected, d.verdict))
    };
    assert!(
        d.selected[0].starts_with("viscous friction in shoulder"),
        "{:?}: {}",
        d.selected,
        d.verdict
    );
    let b = value("viscous friction in shoulder");
    let coulomb = value("Coulomb friction in shoulder");
    assert!((b - 0.3).abs() < 0.03, "viscous {b} N m s/rad: {}", d.verdict);
    assert!(
        (coulomb - 0.2).abs() < 0.02,
        "Coulomb {coulomb} N m: {}",
        d.verdict
    );
    let ch = &d.channels[0];
    assert!(
        ch.holdout_after < 2.0 * ch.noise_floor,
        "held out {} vs noise {}: {}",
        ch.holdout_after,
        ch.noise_floor,
        d.verdict
    );

    // The same recordings through a file without the transmission.
    let rigid = std::fs::read_to_string(models().join("compliant_arm.toml")).unwrap();
    let (a, b2) = (
        rigid.find("[[transmission]]").unwrap(),
        rigid.find("[[driver]]").unwrap(),
    );
    let rigid = format!("{}{}", &rigid[..a], &rigid[b2..])
        .replace("side = \"motor\"", "")
        .replace(
            "compliant_arm_command.csv",
            &models().join("compliant_arm_command.csv").display().to_string(),
        );
    let rigid_path = dir.join("rigid.toml");
    std::fs::write(&rigid_path, rigid).unwrap();
    let r = diagnose(&rigid_path, &recs);
    eprintln!("without it: {}", r.verdict);
    let rc = &r.channels[0];
    assert!(
        rc.holdout_after > 3.0 * ch.holdout_after,
        "without the transmission: held out {} N m; with it {} N m",
        rc.holdout_after,
        ch.holdout_after
    );
}

/// A file whose encoder sits behind a transmission on the joint side is refused by the
/// diagnosis (it models a transmission behind a motor-side encoder), and the rate must be
/// read on the same side as the position.
#[test]
fn the_diagnosis_refuses_sensors_it_cannot_place() {
    let text = std::fs::read_to_string(models().join("compliant_arm.toml")).unwrap();
    let dir = scratch("refuse");
    std::fs::copy(
        models().join("compliant_arm_command.csv"),
        dir.join("compliant_arm_command.csv"),
    )
    .unwrap();
    let write = |name: &str, t: String| {
        let p = dir.join(name);
        std::fs::write(&p, t).unwrap();
        ModelFile::load(p).unwrap()
    };
    let joint_side = write(
        "joint_side.toml",
        text.replace("side = \"motor\"", "side = \"joint\""),
    );
    let e = model_from_file(joint_side).unwrap_err().to_string();
    assert!(
        e.contains("joint 'shoulder' has a [[transmission]]") && e.contains("motor-side"),
        "{e}"
    );
    let mixed = write(
        "mixed.toml",
        text.replacen(
            "side = \"motor\"                         # the encoder reads the rotor",
            "",
            1,
        ),
    );
    let e = model_from_file(mixed).unwrap_err().to_string();
    assert!(e.contains("on one side"), "{e}");
}
