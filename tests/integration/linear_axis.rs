//! Issue #14's acceptance case: a one-axis linear drive diagnosed from its model file
//! (`models/linear_axis.toml`) and CSV recordings with columns t, q, qd, force, with defaults
//! only, as a user runs `lash diagnose`.
//!
//! The recordings are simulated by lash's multibody solver from a truth file that the
//! diagnosis never reads: the nominal axis with a cart 4 % lighter, Coulomb friction 12 N whose
//! sign is smoothed algebraically (v/√(v² + v_s²), not the library's tanh), viscous friction
//! 90 N s/m forward and 130 N s/m backward; the recorded force carries a +2 N offset and
//! 0.5 N of noise; 1 kHz; top speed about 0.4 m/s with reversals, a 4 Hz component in the force command for the inertia.

use lash::model_file::{simulate, ModelFile};
use lash::multibody::SimulationOptions;
use std::path::PathBuf;
use std::process::Command;

fn models() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models")
}

/// Deterministic standard normal numbers (xorshift and Box–Muller).
struct Noise(u64);
impl Noise {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (a, b) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

fn number_after(text: &str, key: &str) -> Option<f64> {
    let at = text.find(key)? + key.len();
    text[at..]
        .trim_start()
        .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e' || c == '+'))
        .next()?
        .parse()
        .ok()
}

/// Force-command components of the runs: two slow sines (amplitude N, frequency Hz, phase)
/// for speed and reversals; a 4 Hz one is added for the inertia.
const RUNS: [(f64, f64, f64, f64, f64, f64); 5] = [
    (40.0, 0.45, 0.3, 15.0, 1.3, 1.1),
    (38.0, 0.35, 2.0, 18.0, 1.7, 0.4),
    (42.0, 0.55, 4.1, 12.0, 1.1, 2.9),
    (36.0, 0.40, 1.2, 16.0, 1.9, 5.0),
    (44.0, 0.50, 5.3, 11.0, 1.5, 3.3),
];

/// Simulates `truth(k)` (a model file text reading its force command from `cmd{k}.csv`) for
/// each run over `seconds`, and writes `rec{k}.csv` with columns t, q, qd, force (and qdd when
/// the truth has a fourth sensor), with encoder, rate and force noise and a +2 N force offset.
/// Returns the paths and the top speed (m/s).
fn record_runs(
    dir: &std::path::Path,
    runs: &[(f64, f64, f64, f64, f64, f64)],
    seconds: f64,
    noise: &mut Noise,
    truth: &dyn Fn(usize) -> String,
) -> (Vec<String>, f64) {
    let mut files = vec![];
    let mut top: f64 = 0.0;
    for (k, &(a1, f1, p1, a2, f2, p2)) in runs.iter().enumerate() {
        let mut cmd = String::from("t,force\n");
        for i in 0..=((seconds + 1.0) * 100.0) as usize {
            let t = i as f64 * 0.01;
            let f = a1 * (std::f64::consts::TAU * f1 * t + p1).sin()
                + a2 * (std::f64::consts::TAU * f2 * t + p2).sin()
                + 12.0 * (std::f64::consts::TAU * 4.0 * t + p1 + p2).sin();
            cmd += &format!("{t},{f}\n");
        }
        std::fs::write(dir.join(format!("cmd{k}.csv")), cmd).unwrap();
        let path = dir.join(format!("truth{k}.toml"));
        std::fs::write(&path, truth(k)).unwrap();
        let file = ModelFile::load(&path).unwrap();
        let (_, rec) = simulate(
            file.build().unwrap(),
            seconds,
            1e-3,
            SimulationOptions::default(),
            |_| {},
        )
        .unwrap();
        let with_qdd = rec.rows.first().is_some_and(|r| r.len() > 3);
        let mut csv = String::from(if with_qdd {
            "t,q,qd,force,qdd\n"
        } else {
            "t,q,qd,force\n"
        });
        for (t, r) in rec.t.iter().zip(&rec.rows) {
            top = top.max(r[1].abs());
            csv += &format!(
                "{t},{},{},{}",
                r[0] + 1e-6 * noise.gauss(),
                r[1] + 1e-3 * noise.gauss(),
                r[2] + 2.0 + 0.5 * noise.gauss()
            );
            if with_qdd {
                csv += &format!(",{}", r[3] + 0.05 * noise.gauss());
            }
            csv += "\n";
        }
        let p = dir.join(format!("rec{k}.csv"));
        std::fs::write(&p, csv).unwrap();
        files.push(p.display().to_string());
    }
    (files, top)
}

#[test]
fn the_linear_axis_is_diagnosed_from_its_model_file_with_defaults_only() {
    let dir = crate::scratch::dir("linear-axis");
    let nominal = std::fs::read_to_string(models().join("linear_axis.toml")).unwrap();
    assert!(nominal.contains("nominal = 8.0"), "the nominal cart is 8 kg");
    let friction = r#"
[[force]]
name = "guide friction"
type = "friction"
joint = "axis"
coulomb = "12 N"
viscous = "90 N s/m"
viscous_backward = "130 N s/m"
velocity_scale = "4 mm/s"
smoothing = "algebraic"
"#;
    let mut noise = Noise(0x9E3779B97F4A7C15);
    let (files, top) = record_runs(&dir, &RUNS, 5.0, &mut noise, &|k| {
        nominal
            .replace("nominal = 8.0", "nominal = 7.68")
            .replace("linear_axis_command.csv", &format!("cmd{k}.csv"))
            + friction
    });
    assert!((0.3..0.6).contains(&top), "top speed {top} m/s");
    let out = Command::new(env!("CARGO_BIN_EXE_lash"))
        .args([
            "diagnose",
            "--model",
            &models().join("linear_axis.toml").display().to_string(),
            "--fit",
            &files[..3].join(","),
            "--holdout",
            &files[3..].join(","),
            "--report",
            &dir.join("report").display().to_string(),
            "--json",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let verdict = d["verdict"].as_str().unwrap();
    eprintln!("verdict (cargo test -- --nocapture shows it): {verdict}");
    let est = |cand: &str, param: &str| {
        d["estimates"]
            .as_array()
            .unwrap()
            .iter()
            .find(|e| e["candidate"].as_str().unwrap().starts_with(cand) && e["parameter"] == param)
            .and_then(|e| e["value"].as_f64())
    };
    let close = |what: &str, got: Option<f64>, truth: f64| {
        let g = got.unwrap_or_else(|| panic!("{what} not estimated: {verdict}"));
        assert!(
            (g - truth).abs() <= 0.05 * truth.abs(),
            "{what}: {g} vs {truth}: {verdict}"
        );
    };
    // Units of the joint: N and N s/m, never N m or rad.
    close(
        "viscous forward [N s/m]",
        est("direction-dependent viscous friction in axis", "b+ [N s/m]"),
        90.0,
    );
    close(
        "viscous backward [N s/m]",
        est("direction-dependent viscous friction in axis", "b- [N s/m]"),
        130.0,
    );
    assert!(
        !verdict.contains("N m") && !verdict.contains("rad"),
        "rotary units in: {verdict}"
    );
    let f = &d["friction"][0];
    assert_eq!(f["unit"], "N");
    close("Coulomb friction at speed [N]", f["coulomb"].as_f64(), 12.0);
    let offset = f["offset_with_asymmetry"]
        .as_f64()
        .or_else(|| est("force-sensor offset in axis", "o [N]"));
    close("force offset [N]", offset, 2.0);
    // The moving mass: estimated as such, or as an effect the data cannot tell from it (a
    // force-sensor scale error), read in its terms.
    let mass = est("error in cart_mass", "delta [kg]").or_else(|| {
        d["confounded"].as_array().unwrap().iter().find_map(|c| {
            (c["alternative"] == "error in cart_mass")
                .then(|| {
                    c["equivalent"]
                        .as_str()
                        .and_then(|e| number_after(e, "delta [kg] ="))
                })
                .flatten()
        })
    });
    close("cart mass error [kg]", mass, -0.32);
}

/// A candidate of the user's own from the model file, one long fit recording cut into folds,
/// recorded accelerations, and `--exclude`. The truth has a cable carrier pulling the cart
/// back to x = 0 with 150 N/m (a spring element the library has no candidate for); the
/// nominal file declares that spring with its stiffness as a parameter (nominal 0) and a
/// `[[candidate]]` naming it. (The user states the law; the data find its size. The truth
/// is a forward simulation, the diagnosis an inverse one.)
#[test]
fn a_declared_candidate_is_fitted_from_one_long_recording_cut_into_folds() {
    let dir = crate::scratch::dir("linear-axis-user");
    let base = std::fs::read_to_string(models().join("linear_axis.toml")).unwrap();
    let spring = |stiffness: &str| {
        format!(
            r#"
[[force]]
name = "cable carrier"
type = "spring_damper"
i = "ground"
j = "cart"
point_i = [-0.5, 0, 0.05]
point_j = [0, 0, 0.05]
stiffness = {stiffness}
free_length = 0.5

[[sensor]]
name = "qdd"
type = "joint_acceleration"
joint = "axis"
"#
        )
    };
    let mut noise = Noise(0x2545F4914F6CDD1D);
    let runs = [RUNS[0], RUNS[3]];
    let (long, _) = record_runs(&dir, &runs[..1], 12.0, &mut noise, &|k| {
        base.replace("linear_axis_command.csv", &format!("cmd{k}.csv")) + &spring("150.0")
    });
    let held = dir.join("held");
    std::fs::create_dir_all(&held).unwrap();
    let (held, _) = record_runs(&held, &runs[1..], 5.0, &mut noise, &|k| {
        base.replace("linear_axis_command.csv", &format!("cmd{k}.csv")) + &spring("150.0")
    });
    let nominal = base.replace(
        "linear_axis_command.csv",
        &models().join("linear_axis_command.csv").display().to_string(),
    ) + &spring("\"k_cable\"")
        + r#"
[[parameter]]
name = "k_cable"
nominal = 0.0
unit = "N/m"
bounds = [0.0, 2000.0]
description = "stiffness of the cable carrier"

[[candidate]]
name = "cable-carrier spring"
parameters = ["k_cable"]
"#;
    let path = dir.join("nominal.toml");
    std::fs::write(&path, nominal).unwrap();
    let run = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_lash"))
            .args(["diagnose", "--model"])
            .arg(&path)
            .args([
                "--fit",
                &long[0],
                "--holdout",
                &held[0],
                "--json",
                "-q",
                "--report",
            ])
            .arg(dir.join("report"))
            .args(extra)
            .output()
            .unwrap()
    };
    let bad = run(&["--exclude", "no such effect"]);
    let out = run(&["--exclude", "sensor delay"]);
    assert_eq!(
        bad.status.code(),
        Some(2),
        "an exclusion matching nothing is bad input"
    );
    let msg = String::from_utf8_lossy(&bad.stderr);
    assert!(
        msg.contains("no such effect") && msg.contains("cable-carrier spring"),
        "{msg}"
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let verdict = d["verdict"].as_str().unwrap();
    eprintln!("verdict (cargo test -- --nocapture shows it): {verdict}");
    // Folds: the one fit recording in 4 parts, and the report says so.
    let parts = d["fit_recordings"].as_array().unwrap();
    assert_eq!(parts.len(), 4, "{parts:?}");
    assert!(parts[0].as_str().unwrap().ends_with("[part 1/4]"));
    assert!(
        d["folds"].as_str().unwrap().contains("4 contiguous parts"),
        "{}",
        d["folds"]
    );
    assert!(verdict.contains("cut into 4 contiguous parts"), "{verdict}");
    // Excluded candidates are not tried.
    assert!(
        !d["ranking"]
            .as_array()
            .unwrap()
            .iter()
            .any(|r| r["candidate"].as_str().unwrap().contains("sensor delay")),
        "sensor delays were excluded"
    );
    // The declared candidate, found first, with its size.
    assert_eq!(d["selected"][0], "cable-carrier spring", "{verdict}");
    let k = d["estimates"]
        .as_array()
        .unwrap()
        .iter()
        .find(|e| e["candidate"] == "cable-carrier spring")
        .and_then(|e| e["value"].as_f64())
        .unwrap();
    assert!((k - 150.0).abs() < 0.05 * 150.0, "k = {k} N/m: {verdict}");
}
