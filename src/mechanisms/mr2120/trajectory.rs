//! The trajectory M → M' → M'' of the paper's §4.1: the platform centre moves along the z
//! axis from M1 (t = 0) to M2 (t = 2 s) to M3 (t = 4 s), each leg a quintic rest-to-rest
//! motion law (zero velocity and acceleration at both ends of each leg). The drive angles
//! follow from the closed-form inverse kinematics, their rates and accelerations from its
//! exact derivatives along z.

use super::geometry::{Geometry, MassProperties};
use super::ideal::{ideal_model, Mr2120Error};
use super::kinematics::inverse_z_derivatives;
use super::paper::{TABLE2, TRAJECTORY_T_M2, TRAJECTORY_T_M3};
use crate::multibody::rotation::rotation_vector;
use crate::multibody::{MotionLaw, Profile, RunEnd, Simulation, SimulationOptions, SingularityEvent};
use nalgebra::{Matrix3, Vector3, Vector4};
use serde::Serialize;
use std::sync::Arc;

/// Platform height z_M(t), m.
pub fn platform_law() -> MotionLaw {
    let (z1, z2, z3) = (TABLE2[0].m[2], TABLE2[1].m[2], TABLE2[2].m[2]);
    MotionLaw::Sum(vec![
        MotionLaw::RestToRest {
            t0: 0.0,
            t1: TRAJECTORY_T_M2,
            from: z1,
            to: z2,
            profile: Profile::Quintic,
        },
        MotionLaw::RestToRest {
            t0: TRAJECTORY_T_M2,
            t1: TRAJECTORY_T_M3,
            from: 0.0,
            to: z3 - z2,
            profile: Profile::Quintic,
        },
    ])
}

/// Drive laws q_i(t) (rad) that move the platform along [`platform_law`].
pub fn drive_laws(g: &Geometry) -> [MotionLaw; 3] {
    std::array::from_fn(|i| {
        let g = *g;
        let zl = platform_law();
        MotionLaw::Custom(Arc::new(move |t| {
            let [z, zd, zdd] = zl.eval(t);
            let [q, dq, ddq] =
                inverse_z_derivatives(&g, i, Vector3::new(0.0, 0.0, z)).unwrap_or([f64::NAN; 3]);
            [q, dq * zd, ddq * zd * zd + dq * zdd]
        }))
    })
}

/// One output sample of the ideal run.
#[derive(Debug, Clone, Serialize)]
pub struct IdealSample {
    /// Time, s.
    pub t: f64,
    /// Drive angles, degrees.
    pub q_deg: [f64; 3],
    /// Platform centre from the dynamic simulation, m.
    pub m: [f64; 3],
    /// Platform centre on the kinematic path, m.
    pub m_kinematic: [f64; 3],
    /// Distance between the two, m.
    pub deviation: f64,
    /// Platform rotation from its initial orientation, rad.
    pub rotation: f64,
    /// Drive torques (positive in the sense of increasing q), N·m.
    pub torque: [f64; 3],
    /// Singularity measure of the constraint Jacobian.
    pub singularity: f64,
}

/// The result of the ideal trajectory run.
#[derive(Debug, Clone, Serialize)]
pub struct IdealRun {
    /// Samples.
    pub samples: Vec<IdealSample>,
    /// Singularity warnings (first below the threshold, and the smallest measure).
    pub singularity_warnings: Vec<SingularityEvent>,
    /// How the run ended.
    pub end: RunEnd,
    /// Integrator steps.
    pub steps: usize,
    /// Largest deviation from the kinematic path while the measure stayed above 1e-2, m.
    pub max_deviation_regular: f64,
    /// Largest platform rotation, rad.
    pub max_rotation: f64,
}

/// Simulates the ideal model along the trajectory, sampling every `dt` seconds up to
/// `t_end` (≤ 4 s); `progress` receives each sample time.
pub fn run_ideal(
    g: &Geometry,
    mp: &MassProperties,
    dt: f64,
    t_end: f64,
    opts: SimulationOptions,
    progress: impl FnMut(f64),
) -> Result<IdealRun, Mr2120Error> {
    let m1 = Vector3::from(TABLE2[0].m);
    let model = ideal_model(g, mp, m1, Some(drive_laws(g)))?;
    let platform = model.platform.index();
    let laws = drive_laws(g);
    let mut sim = Simulation::new(Arc::new(model.mechanism), 0.0, opts)?;
    let n = (t_end / dt).round() as usize;
    let times: Vec<f64> = (1..=n).map(|k| k as f64 * dt).collect();
    let traj = sim.run(&times, progress)?;
    let m_count = sim.layout().m;
    let zl = platform_law();
    let a0 = Matrix3::identity();
    let mut samples = Vec::with_capacity(traj.samples.len());
    let (mut max_dev, mut max_rot) = (0.0f64, 0.0f64);
    for s in &traj.samples {
        let q = &s.q[7 * platform..7 * platform + 7];
        let m = [q[0], q[1], q[2]];
        let mk = [0.0, 0.0, zl.value(s.t)];
        let dev = ((m[0] - mk[0]).powi(2) + (m[1] - mk[1]).powi(2) + (m[2] - mk[2]).powi(2)).sqrt();
        let a = crate::multibody::rotation::rotation(&Vector4::new(q[3], q[4], q[5], q[6]));
        let rot = rotation_vector(&a, &a0).norm();
        if s.singularity > 1e-2 {
            max_dev = max_dev.max(dev);
        }
        max_rot = max_rot.max(rot);
        let torque = [0, 1, 2].map(|i| -s.lambda[m_count - 3 + i]);
        samples.push(IdealSample {
            t: s.t,
            q_deg: [0, 1, 2].map(|i| laws[i].value(s.t).to_degrees()),
            m,
            m_kinematic: mk,
            deviation: dev,
            rotation: rot,
            torque,
            singularity: s.singularity,
        });
    }
    Ok(IdealRun {
        samples,
        singularity_warnings: traj.singularity_warnings,
        end: traj.end,
        steps: sim.stats().steps,
        max_deviation_regular: max_dev,
        max_rotation: max_rot,
    })
}
