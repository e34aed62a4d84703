//! A model file as the diagnosis's nominal model: `lash diagnose --model FILE.toml`.
//!
//! The torque channels are the joints the file measures: each `joint_position` sensor makes
//! one channel (in file order), which also needs a `joint_velocity` and a `joint_effort`
//! sensor on the same joint (a `joint_acceleration` sensor is optional: where the recording
//! has its column, accelerations are read instead of differentiated); the recording columns
//! default to the sensors' names. The
//! mechanism is built from the file for each parameter value the diagnosis tries, with the
//! measured joints driven by the recorded motion (the file's own drivers and `effort` forces
//! on them left out: the recorded effort is what the model must explain). `body_position`
//! sensors become output channels (tracker coordinates `<name>_x`, `_y`, `_z`). The file's
//! `[[parameter]]`s are the parameters the candidate library may perturb, and its
//! `[[candidate]]`s are candidates of its own (parameters perturbed together).

use super::error::DiagnoseError;
use super::mechanism::{EncoderPlacement, MechanismModel, PointSensor, Sensors};
use super::model::{ColumnDefaults, DeclaredCandidate, ModelParameter, ParameterFamily};
use crate::model_file::units::Dimension;
use crate::model_file::{BuildOptions, ModelFile, SensorKind, SensorTarget};
use crate::multibody::ModelError;
use std::sync::Arc;

/// The nominal model of `file` for the diagnosis (see the [module docs](self)).
pub fn model_from_file(file: ModelFile) -> Result<MechanismModel, DiagnoseError> {
    let fail = |message: String| DiagnoseError::Model {
        model: file.name.clone(),
        message,
    };
    let nominal = file.build().map_err(|e| fail(e.to_string()))?;
    // A joint's sensor of a kind, on the side asked for if it has one there.
    let sensor_on = |kind: SensorKind, joint: usize, motor: bool| {
        let on = |s: &&crate::model_file::Sensor| s.kind == kind && s.target == SensorTarget::Joint(joint);
        nominal
            .sensors
            .iter()
            .filter(on)
            .find(|s| s.motor_side == motor)
            .or_else(|| nominal.sensors.iter().find(on))
    };
    let mut channels: Vec<(String, usize)> = vec![];
    let mut mapping = vec![];
    let mut transmissions = vec![];
    for s in &nominal.sensors {
        let (SensorKind::JointPosition, SensorTarget::Joint(k)) = (s.kind, s.target) else {
            continue;
        };
        if channels.iter().any(|(_, c)| *c == k) {
            continue;
        }
        let joint = &nominal.joints[k];
        // Behind a transmission the motor-side encoder is the one the diagnosis reads.
        let motor = joint.transmission.is_some();
        let s = sensor_on(SensorKind::JointPosition, k, motor).unwrap_or(s);
        let n = channels.len() + 1;
        let rate = sensor_on(SensorKind::JointVelocity, k, s.motor_side).ok_or_else(|| {
            fail(format!(
                "joint '{}' has a joint_position sensor but no joint_velocity sensor; the diagnosis reads both",
                joint.name
            ))
        })?;
        let effort = sensor_on(SensorKind::JointEffort, k, false).ok_or_else(|| {
            fail(format!(
                "joint '{}' has no joint_effort sensor; the diagnosis compares the recorded effort with the model's",
                joint.name
            ))
        })?;
        if s.motor_side != rate.motor_side {
            return Err(fail(format!(
                "joint '{}': its position sensor '{}' is on the {} side and its rate sensor '{}' on the {} side; the diagnosis reads both on one side",
                joint.name,
                s.name,
                if s.motor_side { "motor" } else { "joint" },
                rate.name,
                if rate.motor_side { "motor" } else { "joint" },
            )));
        }
        match (&joint.transmission, s.motor_side) {
            (Some(t), true) => transmissions.push(Some((k, t.clone()))),
            (Some(_), false) => {
                return Err(fail(format!(
                    "joint '{}' has a [[transmission]] but its encoder '{}' is on the joint side; the diagnosis models a transmission behind a motor-side encoder (side = \"motor\" on its position and rate sensors)",
                    joint.name, s.name
                )))
            }
            (None, _) => transmissions.push(None),
        }
        mapping.push(format!("q{n}={}", s.name));
        mapping.push(format!("qd{n}={}", rate.name));
        mapping.push(format!("tau{n}={}", effort.name));
        if let Some(acc) =
            sensor_on(SensorKind::JointAcceleration, k, s.motor_side).filter(|a| a.motor_side == s.motor_side)
        {
            mapping.push(format!("qdd{n}={}", acc.name));
        }
        channels.push((joint.name.clone(), k));
    }
    if channels.is_empty() {
        return Err(fail(
            "the file declares no joint_position sensor: the diagnosis needs at least one measured joint"
                .into(),
        ));
    }
    let mut outputs = vec![];
    for s in &nominal.sensors {
        if let (SensorKind::BodyPosition, SensorTarget::Body(h, p)) = (s.kind, s.target) {
            let body = nominal
                .bodies
                .iter()
                .find(|(_, b)| *b == h)
                .map(|(n, _)| n.clone())
                .unwrap_or_default();
            for (axis, c) in ["x", "y", "z"].iter().enumerate() {
                let role = format!("{}_{c}", s.name);
                mapping.push(format!("{role}={role}"));
                outputs.push(PointSensor {
                    name: format!("{} {c}", s.name),
                    role,
                    body: body.clone(),
                    point: p,
                    axis,
                });
            }
        }
    }
    let parameters: Vec<ModelParameter> = file
        .parameters
        .iter()
        .map(|p| ModelParameter {
            name: p.name.clone(),
            unit: p.unit.clone(),
            nominal: p.nominal,
            scale: if p.nominal != 0.0 {
                p.nominal.abs()
            } else {
                p.bounds
                    .map(|(a, b)| (b - a).abs())
                    .filter(|w| *w > 0.0)
                    .unwrap_or(1.0)
            },
            family: match p.dimension {
                Dimension::Mass | Dimension::Inertia => ParameterFamily::MassProperties,
                _ => ParameterFamily::LinkGeometry,
            },
        })
        .collect();
    // Encoders: a motor-side one behind its transmission, whose compliance is a parameter of
    // the diagnosis (the file's, or one added here after the file's).
    let mut parameters = parameters;
    let file_parameters = parameters.len();
    let mut encoders = vec![];
    for (c, tr) in transmissions.iter().enumerate() {
        let Some((k, t)) = tr else {
            encoders.push(EncoderPlacement::JointSide);
            continue;
        };
        let prismatic = nominal.joints[*k].kind == crate::multibody::JointKind::Prismatic;
        let compliance = match t.compliance_parameter {
            Some(p) => {
                parameters[p].family = ParameterFamily::DriveCompliance;
                p
            }
            None => {
                parameters.push(ModelParameter {
                    name: format!("{} transmission compliance", channels[c].0),
                    unit: if prismatic { "m/N" } else { "rad/(N m)" }.into(),
                    nominal: t.compliance,
                    scale: t.compliance,
                    family: ParameterFamily::DriveCompliance,
                });
                parameters.len() - 1
            }
        };
        encoders.push(EncoderPlacement::MotorSide {
            compliance,
            rotor_inertia: t.rotor_inertia,
            damping: t.damping,
        });
    }
    if encoders.iter().all(|e| *e == EncoderPlacement::JointSide) {
        encoders.clear();
    }
    let declared: Vec<DeclaredCandidate> = file
        .candidates
        .iter()
        .map(|c| DeclaredCandidate {
            name: c.name.clone(),
            parameters: c.parameters.clone(),
            bounds: c
                .parameters
                .iter()
                .map(|&k| {
                    let p = &file.parameters[k];
                    p.bounds
                        .map(|(lo, hi)| (lo - p.nominal, hi - p.nominal))
                        .unwrap_or((f64::NEG_INFINITY, f64::INFINITY))
                })
                .collect(),
        })
        .collect();
    let measured: Vec<String> = channels.iter().map(|(n, _)| n.clone()).collect();
    let joints: Vec<(String, f64)> = channels
        .iter()
        .map(|(n, k)| (n.clone(), nominal.joints[*k].coordinate0))
        .collect();
    let name = file.name.clone();
    let file = Arc::new(file);
    let builder = Arc::new(move |theta: &[f64], laws: &[crate::multibody::MotionLaw]| {
        let opts = BuildOptions {
            clearance: false,
            measured_joints: measured.clone(),
        };
        let mut built = file
            .build_with(&theta[..file_parameters], &opts)
            .map_err(|e| ModelError::Output(e.to_string()))?;
        for ((joint, coordinate0), law) in joints.iter().zip(laws) {
            let h = built
                .joint(joint)
                .and_then(|j| j.handle)
                .ok_or_else(|| ModelError::Output(format!("joint '{joint}' is not an ideal joint")))?;
            built
                .mechanism
                .drive(&format!("measured {joint}"), h, law.clone(), *coordinate0)?;
        }
        Ok(built.mechanism)
    });
    MechanismModel::new(
        &name,
        channels.into_iter().map(|(n, _)| n).collect(),
        parameters,
        builder,
    )?
    .with_sensors(Sensors { encoders, outputs })
    .and_then(|m| m.with_declared_candidates(declared))
    .map(|m| m.with_column_defaults(ColumnDefaults::Fixed(mapping.join(","))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::columns::{csv_header, resolve_columns};
    use crate::diagnose::model::InverseDynamicsModel;
    use crate::diagnose::recording::read_csv;
    use crate::diagnose::{diagnose_recordings, DiagnoseOptions};
    use crate::model_file::simulate;
    use crate::multibody::SimulationOptions;
    use std::path::PathBuf;

    fn models() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("models")
    }

    /// Recordings simulated from the shipped linear axis itself (the multibody simulation of
    /// the file driven by three force commands of cosines, so the cart reverses at up to
    /// ~0.3 m/s; 1 kHz; 5 µm, 2 mm/s and 0.5 N of noise), diagnosed from the same file with
    /// default columns: nothing is missing, so nothing may be named and the held-out residual
    /// stays at the noise.
    #[test]
    fn a_model_file_diagnoses_its_own_simulation_as_matching() {
        let nominal = std::fs::read_to_string(models().join("linear_axis.toml")).unwrap();
        let scratch = tempfile::Builder::new()
            .prefix("lash-model-file-diagnose-")
            .tempdir()
            .unwrap();
        let dir = scratch.path();
        // Deterministic pseudo-noise (xorshift and Box–Muller).
        let mut state = 0x2545F4914F6CDD1Du64;
        let mut gauss = move || {
            let mut u = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 11) as f64 / (1u64 << 53) as f64
            };
            let (a, b) = (u().max(1e-300), u());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let mut paths = vec![];
        for (k, (a1, f1, a2, f2)) in [(8.0, 0.5, 6.0, 1.7), (10.0, 0.7, 4.0, 2.3), (7.0, 0.4, 9.0, 1.3)]
            .into_iter()
            .enumerate()
        {
            let mut cmd = String::from("t,force\n");
            for i in 0..=500 {
                let t = i as f64 * 0.01;
                let f =
                    a1 * (std::f64::consts::TAU * f1 * t).cos() + a2 * (std::f64::consts::TAU * f2 * t).cos();
                cmd += &format!("{t},{f}\n");
            }
            std::fs::write(dir.join(format!("cmd{k}.csv")), cmd).unwrap();
            let path = dir.join(format!("axis{k}.toml"));
            std::fs::write(
                &path,
                nominal.replace("linear_axis_command.csv", &format!("cmd{k}.csv")),
            )
            .unwrap();
            let file = ModelFile::load(&path).unwrap();
            let (_, rec) = simulate(
                file.build().unwrap(),
                4.0,
                1e-3,
                SimulationOptions::default(),
                |_| {},
            )
            .unwrap();
            let top = rec.rows.iter().map(|r| r[1].abs()).fold(0.0, f64::max);
            let reversals = rec.rows.windows(2).filter(|w| w[0][1] * w[1][1] < 0.0).count();
            assert!(
                top > 0.1 && reversals >= 2,
                "recording {k}: top speed {top} m/s, {reversals} reversals"
            );
            let p = dir.join(format!("rec{k}.csv"));
            let mut text = String::from("time,q,qd,force\n");
            for (t, r) in rec.t.iter().zip(&rec.rows) {
                text += &format!(
                    "{t},{},{},{}\n",
                    r[0] + 5e-6 * gauss(),
                    r[1] + 2e-3 * gauss(),
                    r[2] + 0.5 * gauss()
                );
            }
            std::fs::write(&p, text).unwrap();
            paths.push(p);
        }
        let file = ModelFile::load(models().join("linear_axis.toml")).unwrap();
        let model = model_from_file(file).unwrap();
        assert_eq!(model.joints(), 1);
        let header = csv_header(&paths[0]).unwrap();
        let map = resolve_columns(&model, None, &header).unwrap();
        let read = |p: &PathBuf| read_csv(p, "time", &map).unwrap();
        let fit: Vec<_> = paths[..2].iter().map(read).collect();
        let held = vec![read(&paths[2])];
        let d = diagnose_recordings(
            &model,
            &fit,
            &held,
            &model.derivative_windows(),
            &DiagnoseOptions::default(),
            |_, _| {},
        )
        .unwrap();
        assert!(
            d.steps.is_empty(),
            "named {:?}: {}",
            d.steps.iter().map(|s| &s.added).collect::<Vec<_>>(),
            d.verdict
        );
        let c = &d.channels[0];
        assert!(
            c.holdout_after < 1.2 * c.noise_floor,
            "held out {} vs noise {}",
            c.holdout_after,
            c.noise_floor
        );
    }

    /// A file whose measured joint has no rate or effort sensor cannot be diagnosed, and
    /// says which sensor is missing.
    #[test]
    fn a_model_file_without_the_sensors_the_diagnosis_reads_is_refused() {
        let text = std::fs::read_to_string(models().join("slider_crank.toml")).unwrap();
        let text = text.replace("[[driver]]", "[[driver_unused]]");
        assert!(
            ModelFile::from_text("x.toml", &text).is_err(),
            "unknown tables are refused"
        );
        let dir = models();
        let file = ModelFile::load(dir.join("slider_crank.toml")).unwrap();
        let e = model_from_file(file).unwrap_err().to_string();
        assert!(e.contains("joint 'A'") && e.contains("joint_velocity"), "{e}");
    }
}
