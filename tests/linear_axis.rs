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

#[test]
fn the_linear_axis_is_diagnosed_from_its_model_file_with_defaults_only() {
    let dir = std::env::temp_dir().join(format!("lash-linear-axis-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
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
    let mut files = vec![];
    let mut top: f64 = 0.0;
    for (k, (a1, f1, p1, a2, f2, p2)) in [
        (40.0, 0.45, 0.3, 15.0, 1.3, 1.1),
        (38.0, 0.35, 2.0, 18.0, 1.7, 0.4),
        (42.0, 0.55, 4.1, 12.0, 1.1, 2.9),
        (36.0, 0.40, 1.2, 16.0, 1.9, 5.0),
        (44.0, 0.50, 5.3, 11.0, 1.5, 3.3),
    ]
    .into_iter()
    .enumerate()
    {
        let mut cmd = String::from("t,force\n");
        for i in 0..=600 {
            let t = i as f64 * 0.01;
            // Two slow components for speed and reversals, one at 4 Hz for the inertia.
            let f = a1 * (std::f64::consts::TAU * f1 * t + p1).sin()
                + a2 * (std::f64::consts::TAU * f2 * t + p2).sin()
                + 12.0 * (std::f64::consts::TAU * 4.0 * t + p1 + p2).sin();
            cmd += &format!("{t},{f}\n");
        }
        std::fs::write(dir.join(format!("cmd{k}.csv")), cmd).unwrap();
        let truth = nominal
            .replace("nominal = 8.0", "nominal = 7.68")
            .replace("linear_axis_command.csv", &format!("cmd{k}.csv"))
            + friction;
        let path = dir.join(format!("truth{k}.toml"));
        std::fs::write(&path, truth).unwrap();
        let file = ModelFile::load(&path).unwrap();
        let (_, rec) = simulate(
            file.build().unwrap(),
            5.0,
            1e-3,
            SimulationOptions::default(),
            |_| {},
        )
        .unwrap();
        let mut csv = String::from("t,q,qd,force\n");
        for (t, r) in rec.t.iter().zip(&rec.rows) {
            top = top.max(r[1].abs());
            csv += &format!(
                "{t},{},{},{}\n",
                r[0] + 1e-6 * noise.gauss(),
                r[1] + 1e-3 * noise.gauss(),
                r[2] + 2.0 + 0.5 * noise.gauss()
            );
        }
        let p = dir.join(format!("rec{k}.csv"));
        std::fs::write(&p, csv).unwrap();
        files.push(p.display().to_string());
    }
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
    let _ = std::fs::remove_dir_all(&dir);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let verdict = d["verdict"].as_str().unwrap();
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
