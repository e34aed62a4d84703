//! Test fixtures: one compliant drive carrying a joint of 1 kg (side j) on axes x and y,
//! n = z, loaded along z, whose shift along z moves the drive's torque.

use crate::diagnose::model::PlayDynamics;
use crate::diagnose::transmission::TransmissionDynamics;
use nalgebra::{DMatrix, Vector3};

use crate::contact::play::UniversalPlay;

/// The joint under `load` N along z, the drive's torque moving by `tau_per_m` N·m per m
/// of its shift along z; 1 kg on each shift coordinate, 1e-4 kg·m² on the tilt.
pub(crate) fn hanging_joint(load: f64, tau_per_m: f64) -> PlayDynamics {
    PlayDynamics {
        z_i: Vector3::x(),
        z_j: Vector3::y(),
        play: UniversalPlay {
            ball_spacing: 0.024,
            ball_radius: 0.004,
            material: crate::contact::Material::steel(),
        },
        cross_mass: 0.05,
        cross_load: [0.0; 3],
        reaction: [0.0, 0.0, load, 0.0],
        torque_by_offset: [vec![0.0], vec![0.0], vec![tau_per_m], vec![0.0]],
        torque_by_offset_acceleration: [vec![0.0], vec![0.0], vec![0.0], vec![0.0]],
        reaction_by_offset: [[0.0; 4]; 4],
        reaction_by_offset_acceleration: [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1e-4],
        ],
        reaction_by_drive: vec![[0.0; 4]],
        reaction_by_drive_acceleration: vec![[0.0; 4]],
        torque_by_offset_rate: vec![],
        reaction_by_offset_rate: vec![],
        reaction_by_drive_rate: vec![],
        torque_by_drive_rate: vec![],
    }
}

/// The drive: 0.01 kg·m² on 1e-4 rad/(N·m), damped by 5 N·m·s/rad.
pub(crate) fn one_drive() -> TransmissionDynamics {
    TransmissionDynamics {
        mass: DMatrix::from_element(1, 1, 0.01),
        compliance: vec![1e-4],
        damping: vec![5.0],
        windup_rate: vec![0.0],
        windup: vec![0.0],
        load_stiffness: None,
    }
}
