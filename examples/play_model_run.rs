//! The reduced play model ([`lash::diagnose::play_dynamics::respond`]) alone, for profiling
//! and for timing it between builds (alternated whole-process pairs): a universal joint with
//! 6 µm of radial clearance on three compliant drives, its load swinging ±200 N at 20 Hz
//! along the tilt axis n and turning slowly about it, Hertz balls of the MR2120 bearing
//! geometry (4 mm steel balls 24 mm apart), 20 N·s/m + 500 s/m × F of damping, the linear
//! forces blended between samples — the options the diagnosis's bearing cases run with —
//! sampled every 2 ms for 5 s. The loads and couplings are made up (no nominal model is
//! evaluated): what is timed is the play model's substeps, most of a bearing diagnosis.
//!
//! Prints per repetition the wall time, the samples answered and a checksum of the drive
//! torques and play coordinates (the sum of their bit patterns): two builds whose arithmetic
//! is the same print the same checksum.
//!
//! The contact damping may be given too (constant N·s/m, then s/m per newton of the ball's
//! load; default 20 and 500): lighter dampings (say 1 and 50) let the substeps take them
//! explicitly, the path most of a diagnosis's damping searches take. Then `stiff` or
//! `stiff:N` steps the model in stiff substeps ([`Stepping::Stiff`], at least N per sample
//! interval, default [`STIFF_SUBSTEPS`]) instead of resolved ones.
//!
//! ```text
//! cargo run --release --example play_model_run -- [REPETITIONS [DAMPING LOAD_DAMPING [stiff[:N]]]]
//! cargo run --release --example play_model_run -- 3 20 500 stiff:40
//! perf record -g target/release/examples/play_model_run 3
//! ```

use lash::contact::play::UniversalPlay;
use lash::contact::BearingDesign;
use lash::diagnose::model::PlayDynamics;
use lash::diagnose::play_dynamics::{
    respond_stepped, BallContact, HertzBalls, Interpolation, JointPlay, PlaySample, Stepping, BALL_CONTACT,
    STIFF_SUBSTEPS,
};
use lash::diagnose::transmission::TransmissionDynamics;
use lash::mechanisms::mr2120::clearance::DEFAULT_DAMPING;
use nalgebra::{DMatrix, Vector3};
use std::time::Instant;

/// Radial clearance of the joint, m.
const CLEARANCE: f64 = 6e-6;
/// Sampling interval, s, and samples (5 s).
const DT: f64 = 2e-3;
const SAMPLES: usize = 2500;

/// The joint at time `t` with the bearings of `design`: the load's amplitude along n (z)
/// swinging at 20 Hz with a slow turn in the x–y plane; every drive coupled to the shift
/// along n and the tilt; 1 kg on each shift coordinate, 1e-4 kg·m² on the tilt.
fn joint(t: f64, design: &BearingDesign) -> PlayDynamics {
    let swing = 200.0 * (2.0 * std::f64::consts::PI * 20.0 * t).cos();
    let turn = 0.3 * t;
    let drives = 3;
    PlayDynamics {
        z_i: Vector3::x(),
        z_j: Vector3::y(),
        play: UniversalPlay::from_design(design),
        cross_mass: 0.05,
        cross_load: [0.0; 3],
        reaction: [40.0 * turn.cos(), 40.0 * turn.sin(), swing, 0.5 * swing * 1e-2],
        torque_by_offset: [
            vec![50.0, -20.0, 10.0],
            vec![-10.0, 60.0, 5.0],
            vec![1000.0, 800.0, 1200.0],
            vec![2.0, -1.0, 1.5],
        ],
        torque_by_offset_acceleration: [vec![0.0; 3], vec![0.0; 3], vec![0.01; 3], vec![0.0; 3]],
        reaction_by_offset: [[0.0; 4]; 4],
        reaction_by_offset_acceleration: std::array::from_fn(|c| {
            let mut r = [0.0; 4];
            r[c] = if c == 3 { 1e-4 } else { 1.0 };
            r
        }),
        reaction_by_drive: vec![[0.0, 0.0, 30.0, 0.0]; drives],
        reaction_by_drive_acceleration: vec![[0.0; 4]; drives],
        torque_by_offset_rate: vec![],
        reaction_by_offset_rate: vec![],
        reaction_by_drive_rate: vec![],
        torque_by_drive_rate: vec![],
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let arg = |k: usize| std::env::args().nth(k).and_then(|s| s.parse::<f64>().ok());
    let repetitions = arg(1).map_or(1, |r| r as usize);
    let (damping, load_damping) = (arg(2).unwrap_or(20.0), arg(3).unwrap_or(500.0));
    let stepping = match std::env::args().nth(4) {
        None => Stepping::Resolved,
        Some(s) if s == "stiff" => Stepping::Stiff {
            per_sample: STIFF_SUBSTEPS,
        },
        Some(s) => match s.strip_prefix("stiff:").map(str::parse::<usize>) {
            Some(Ok(per_sample)) if per_sample > 0 => Stepping::Stiff { per_sample },
            _ => {
                return Err(format!("the fourth argument is `stiff` or `stiff:N` (N ≥ 1), not `{s}`").into())
            }
        },
    };
    let transmission = TransmissionDynamics {
        mass: DMatrix::from_diagonal_element(3, 3, 0.01),
        compliance: vec![1e-4; 3],
        damping: vec![5.0; 3],
        windup_rate: vec![0.0; 3],
        windup: vec![0.0; 3],
        load_stiffness: None,
    };
    // The MR2120 trunnion bearing (4 mm steel balls 24 mm apart) with the clearance.
    let design = BearingDesign::mr2120(CLEARANCE, 0.0, DEFAULT_DAMPING);
    let joints: Vec<PlayDynamics> = (0..SAMPLES).map(|i| joint(DT * i as f64, &design)).collect();
    let samples: Vec<Option<PlaySample>> = joints
        .iter()
        .enumerate()
        .map(|(i, play)| {
            Some(PlaySample {
                t: DT * i as f64,
                play,
                transmission: &transmission,
                about: None,
            })
        })
        .collect();
    let play = JointPlay::radial(CLEARANCE);
    let hertz = HertzBalls::from_design(&design)?;
    let contact = BallContact {
        hertz: Some(hertz),
        damping,
        load_damping,
        ..BALL_CONTACT
    };
    for rep in 0..repetitions {
        let start = Instant::now();
        let out = respond_stepped(&samples, &play, &contact, Interpolation::Linear, stepping);
        let wall = start.elapsed().as_secs_f64();
        let answered = out.iter().flatten().count();
        let checksum = out.iter().flatten().fold(0u64, |acc, r| {
            r.torque
                .iter()
                .chain(&r.offset)
                .fold(acc, |a, v| a.wrapping_add(v.to_bits()))
        });
        println!(
            "repetition {}: {wall:.3} s wall, {answered} of {SAMPLES} samples answered, checksum {checksum:016x}",
            rep + 1
        );
    }
    Ok(())
}
