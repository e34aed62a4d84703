//! The closed-form MR2120 model (forearms lumped at their ends) against the multibody ideal
//! model along the paper's trajectory, and synthetic recordings read back for diagnosis.

use lash::diagnose::data::MotionData;
use lash::diagnose::model::{InverseDynamicsModel, Mr2120Model};
use lash::diagnose::recording::{parse_csv, RecordingError};
use lash::mechanisms::mr2120::lumped::LumpedModel;
use lash::mechanisms::mr2120::record::{nominal_model, record, Excitation, HiddenEffects, RecordOptions};
use lash::mechanisms::mr2120::{trajectory, Geometry, MassProperties};
use lash::multibody::SimulationOptions;
use nalgebra::Vector3;

#[test]
fn lumped_torques_agree_with_the_multibody_ideal_model() {
    let g = Geometry::default();
    let mp = MassProperties::default();
    let run = trajectory::run_ideal(&g, &mp, 0.05, 3.0, SimulationOptions::default(), |_| {}).unwrap();
    let laws = trajectory::drive_laws(&g);
    let model = LumpedModel::nominal(&g, &mp);
    let (mut worst, mut peak) = (0.0f64, 0.0f64);
    let mut guess = Vector3::new(0.0, 0.0, 0.5);
    for s in &run.samples {
        let e: Vec<[f64; 3]> = laws.iter().map(|l| l.eval(s.t)).collect();
        let st = model
            .state(
                [e[0][0], e[1][0], e[2][0]],
                [e[0][1], e[1][1], e[2][1]],
                [e[0][2], e[1][2], e[2][2]],
                guess,
            )
            .unwrap();
        guess = st.m;
        for i in 0..3 {
            worst = worst.max((st.torque[i] - s.torque[i]).abs());
            peak = peak.max(s.torque[i].abs());
        }
        // Same platform position as the multibody model's.
        assert!((st.m - Vector3::from(s.m)).norm() < 1e-6, "t = {}", s.t);
    }
    // The lumped forearms miss only their rotational inertia about their own centre.
    assert!(
        worst < 0.05 * peak,
        "largest torque difference {worst} N m of {peak} N m"
    );
}

#[test]
fn recordings_round_trip_through_csv_into_torque_and_tracker_channels() {
    let nominal = nominal_model();
    let ex = Excitation::random(3, 0.32, 10.0);
    let opts = RecordOptions {
        duration: 1.0,
        ..RecordOptions::default()
    };
    let rec = record(&nominal, &HiddenEffects::default(), &ex, &opts, 3).unwrap();
    assert_eq!(rec.t.len(), 501);
    let roles = [
        "q1", "q2", "q3", "qd1", "qd2", "qd3", "tau1", "tau2", "tau3", "x", "y", "z",
    ];
    let map: Vec<(String, String)> = roles.iter().map(|r| (r.to_string(), r.to_string())).collect();
    let parsed = parse_csv(std::path::Path::new("rec.csv"), &rec.csv(), "time", &map).unwrap();
    let model = Mr2120Model { nominal };
    let d = MotionData::from_recording_with_outputs(&parsed, &model, 8).unwrap();
    assert_eq!(d.channels().len(), 6);
    // With nothing hidden, the nominal model predicts the tracker to within its noise.
    let theta: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    let (_, y) = d.model_all(&model, &theta);
    let rms = (0..d.len()).map(|i| (d.y[2][i] - y[2][i]).powi(2)).sum::<f64>() / d.len() as f64;
    assert!(rms.sqrt() < 2.0 * opts.noise.tracker, "{}", rms.sqrt());
    // A tracker-only recording: no torque channels; a missing tracker column is named.
    let only: Vec<(String, String)> = map
        .iter()
        .filter(|(r, _)| !r.starts_with("tau"))
        .cloned()
        .collect();
    let parsed = parse_csv(std::path::Path::new("rec.csv"), &rec.csv(), "time", &only).unwrap();
    let d = MotionData::from_recording_with_outputs(&parsed, &model, 8).unwrap();
    assert_eq!(d.channels().len(), 3);
    let partial: Vec<(String, String)> = only.iter().filter(|(r, _)| r != "z").cloned().collect();
    let parsed = parse_csv(std::path::Path::new("rec.csv"), &rec.csv(), "time", &partial).unwrap();
    match MotionData::from_recording_with_outputs(&parsed, &model, 8) {
        Err(RecordingError::Unmapped { role, .. }) => assert_eq!(role, "z"),
        other => panic!("expected an unmapped z, got {other:?}"),
    }
}

#[test]
fn unknown_effects_are_refused_by_name() {
    let mut e = HiddenEffects::default();
    assert!(e.set("clearance_c", 4e-6).is_ok() && e.clearance[2] == 4e-6);
    assert!(e.set("tracker_offset_y", 1e-6).is_ok() && e.tracker_offset[1] == 1e-6);
    assert!(e.set("friction_a", 1.0).unwrap_err().contains("friction_a"));
    assert!(e.set("payload", f64::NAN).is_err());
}
