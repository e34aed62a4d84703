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
use crate::multibody::{
    BodyHandle, MotionLaw, Profile, RunEnd, Sample, Simulation, SimulationOptions, SingularityEvent,
};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use std::sync::{Arc, Mutex};

/// Duration of the trajectory M1 → M2 → M3, s (it reaches M3 at this time).
pub const DURATION: f64 = TRAJECTORY_T_M3;

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
        // The last evaluation, keyed by the bits of t: the integrator evaluates the drives at
        // one t many times (every residual and Jacobian of a step's Newton iterations, value
        // and rate separately), and each evaluation solves the inverse kinematics. A busy
        // lock (another thread evaluating the same law) just skips the memo.
        let memo = Mutex::new((f64::NAN.to_bits(), [f64::NAN; 3]));
        MotionLaw::Custom(Arc::new(move |t| {
            if let Ok(m) = memo.try_lock() {
                if m.0 == t.to_bits() {
                    return m.1;
                }
            }
            let [z, zd, zdd] = zl.eval(t);
            let [q, dq, ddq] =
                inverse_z_derivatives(&g, i, Vector3::new(0.0, 0.0, z)).unwrap_or([f64::NAN; 3]);
            let out = [q, dq * zd, ddq * zd * zd + dq * zdd];
            if let Ok(mut m) = memo.try_lock() {
                *m = (t.to_bits(), out);
            }
            out
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
    let platform = model.platform;
    let laws = drive_laws(g);
    let mut sim = Simulation::new(Arc::new(model.mechanism), 0.0, opts)?;
    let n = crate::multibody::output_count(t_end, dt)?;
    let times: Vec<f64> = (1..=n).map(|k| k as f64 * dt).collect();
    let traj = sim.run(&times, progress)?;
    let mech = sim.model();
    let drivers: Vec<_> = mech.drivers().map(|(h, _)| h).collect();
    let zl = platform_law();
    let a0 = Matrix3::identity();
    let mut samples = Vec::with_capacity(traj.samples.len());
    let (mut max_dev, mut max_rot) = (0.0f64, 0.0f64);
    for s in &traj.samples {
        let m: [f64; 3] = s.body_position(platform).into();
        let mk = [0.0, 0.0, zl.value(s.t)];
        let dev = ((m[0] - mk[0]).powi(2) + (m[1] - mk[1]).powi(2) + (m[2] - mk[2]).powi(2)).sqrt();
        let a = s.body_rotation(platform);
        let rot = rotation_vector(&a, &a0).norm();
        if s.singularity > 1e-2 {
            max_dev = max_dev.max(dev);
        }
        max_rot = max_rot.max(rot);
        let torque = [0, 1, 2].map(|i| s.driver_effort(mech, drivers[i]).unwrap_or(f64::NAN));
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

/// Positioning errors of eq. (4.1) at one time: the clearance model against the ideal path.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ErrorSample {
    /// Time, s.
    pub t: f64,
    /// d_xM, d_yM, d_zM: platform-centre displacement from the ideal path, m.
    pub d: [f64; 3],
    /// δx, δy, δz: platform orientation change from the ideal (constant) orientation, rad
    /// (components of the rotation vector; equal to the angle differences for small angles).
    pub delta: [f64; 3],
}

/// Errors of eq. (4.1) of the pose of body `platform` in sample `s` against the ideal pose
/// (centre `m_ideal`, m; base-frame orientation): (d_xM, d_yM, d_zM) in m, then (δx, δy, δz)
/// in rad.
pub fn pose_errors(s: &Sample, platform: BodyHandle, m_ideal: &Vector3<f64>) -> [f64; 6] {
    let a = s.body_rotation(platform);
    let rv = rotation_vector(&a, &Matrix3::identity());
    let r = s.body_position(platform);
    [
        r.x - m_ideal.x,
        r.y - m_ideal.y,
        r.z - m_ideal.z,
        rv.x,
        rv.y,
        rv.z,
    ]
}

/// The trajectory of the clearance model for one clearance set.
#[derive(Debug, Clone, Serialize)]
pub struct ClearanceRun {
    /// Clearance set name.
    pub set: String,
    /// Error samples.
    pub samples: Vec<ErrorSample>,
    /// Integrator steps.
    pub steps: usize,
    /// Error-test failures.
    pub error_test_failures: usize,
    /// Newton iterations.
    pub newton_iters: usize,
    /// Wall time, s.
    pub wall_s: f64,
    /// How the run ended.
    pub end: RunEnd,
}

/// Integrator settings of the clearance runs: index-2 velocity errors, so the contact rattle
/// along stiff directions is damped by the BDF instead of resolved.
pub fn clearance_options() -> SimulationOptions {
    let mut o = SimulationOptions::with_tolerances(1e-4, 1e-6);
    o.formulation.velocities_index2 = true;
    o.bdf.max_steps = 1_000_000;
    o
}

/// Simulates the clearance model of `set` along the trajectory, sampling every `dt` seconds
/// up to `t_end`, and returns the errors of eq. (4.1) against the ideal path.
#[allow(clippy::too_many_arguments)]
pub fn run_clearance(
    g: &Geometry,
    mp: &MassProperties,
    set: &super::paper::ClearanceSet,
    damping: crate::contact::Damping,
    dt: f64,
    t_end: f64,
    opts: SimulationOptions,
    progress: impl FnMut(f64),
) -> Result<ClearanceRun, Mr2120Error> {
    use super::clearance::{bearing_design, clearance_model};
    let start = std::time::Instant::now();
    let m1 = Vector3::from(TABLE2[0].m);
    let model = clearance_model(g, mp, m1, Some(drive_laws(g)), &bearing_design(set, damping))?;
    let platform = model.platform;
    let mut sim = Simulation::new(Arc::new(model.mechanism), 0.0, opts)?;
    let n = crate::multibody::output_count(t_end, dt)?;
    let times: Vec<f64> = (1..=n).map(|k| k as f64 * dt).collect();
    let traj = sim.run(&times, progress)?;
    let zl = platform_law();
    let samples = traj
        .samples
        .iter()
        .map(|s| {
            let e = pose_errors(s, platform, &Vector3::new(0.0, 0.0, zl.value(s.t)));
            ErrorSample {
                t: s.t,
                d: [e[0], e[1], e[2]],
                delta: [e[3], e[4], e[5]],
            }
        })
        .collect();
    let st = *sim.stats();
    Ok(ClearanceRun {
        set: set.name.into(),
        samples,
        steps: st.steps,
        error_test_failures: st.error_test_failures,
        newton_iters: st.newton_iters,
        wall_s: start.elapsed().as_secs_f64(),
        end: traj.end,
    })
}

/// Largest |error| of each of the six errors (m, m, m, rad, rad, rad) over samples with
/// t in [t0, t1].
pub fn max_errors(samples: &[ErrorSample], t0: f64, t1: f64) -> [f64; 6] {
    let mut m = [0.0f64; 6];
    for s in samples.iter().filter(|s| s.t >= t0 && s.t <= t1) {
        for k in 0..3 {
            m[k] = m[k].max(s.d[k].abs());
            m[3 + k] = m[3 + k].max(s.delta[k].abs());
        }
    }
    m
}
