//! A closed-form rigid-body model of the MR2120 for fast inverse dynamics and forward
//! kinematics at thousands of samples (diagnosis, synthetic recordings).
//!
//! Every link may carry its own length (link-length errors), the base its own gravity
//! direction (tilt), the platform a payload, and each drive a compliant transmission
//! between its encoder (on the motor side) and its arm.
//!
//! Dynamics by virtual work. The platform translates only, so with the constraints
//! ½(|M + P_i − D_i(q_i)|² − L2_i²) = 0 the drive torques are
//!
//! τ_i = I_i q̈_i − (m_a/2 + m_f/2) g·D_i'(q_i) + Jq_i μ_i,  Jx^T μ = m_P (M̈ − g),
//!
//! with Jx the matrix of rows (M + P_i − D_i)ᵀ, Jq_i = (M + P_i − D_i)·D_i', the arm inertia
//! I_i = m_a a_i²/3 plus (m_f/2) a_i² (slender arm about its pivot, half a forearm at the
//! elbow) and m_P the platform, payload and the other halves of the forearms. Each forearm is
//! lumped into two point masses at its ends (the one approximation; `tests/integration/mr2120_lumped.rs`
//! measures it against the multibody ideal model). μ_i is the force of forearm i on the
//! platform per unit of (M + P_i − D_i): the forearm tension is −μ_i L2_i.
//!
//! Lengths in m, angles in rad, masses in kg, torques in N·m, forces in N.

use super::geometry::{Branch, Geometry, MassProperties};
use super::kinematics::{platform_from_elbows, KinematicsError};
use nalgebra::{Matrix3, Vector3};

/// Standard gravity, m/s² (the same value as the multibody model's gravity).
pub const STANDARD_GRAVITY: f64 = 9.81;

/// Parameters of the lumped model. [`LumpedModel::nominal`] builds them from the geometry
/// reconstruction and the documented mass assumptions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LumpedModel {
    /// Base layout (branch vertices, axes, platform joints, q0); its lengths are overridden
    /// per branch by the fields below.
    pub geometry: Geometry,
    /// Arm length a_i = |A_i D_i| per branch, m.
    pub arm_length: [f64; 3],
    /// Forearm length L2_i = |D_i P_i| per branch, m.
    pub forearm_length: [f64; 3],
    /// Arm mass, kg (centre of mass at mid-length).
    pub arm_mass: f64,
    /// Forearm mass, kg (lumped half at each end).
    pub forearm_mass: f64,
    /// Platform mass, kg.
    pub platform_mass: f64,
    /// Payload carried by the platform, kg.
    pub payload: f64,
    /// Gravity vector in the base frame, m/s² (−9.81 e_z for a level base).
    pub gravity: Vector3<f64>,
    /// Compliance of each drive's transmission, rad/(N·m): the arm lags the encoder angle
    /// by c_i·τ_i.
    pub compliance: [f64; 3],
    /// Displacement of each elbow joint centre along its drive axis, m (axial play).
    pub axial_offset: [f64; 3],
}

/// Kinematic and dynamic state at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LumpedState {
    /// Platform centre M, m.
    pub m: Vector3<f64>,
    /// Its velocity, m/s.
    pub md: Vector3<f64>,
    /// Its acceleration, m/s².
    pub mdd: Vector3<f64>,
    /// Drive torques (the torque each transmission carries), N·m.
    pub torque: [f64; 3],
    /// Forearm tensions, N (negative: compression).
    pub tension: [f64; 3],
    /// ∂M/∂q_i (columns), m/rad.
    pub jm: Matrix3<f64>,
    /// Jq_i = (M + P_i − D_i)·D_i', m².
    pub jq: [f64; 3],
    /// (M + P_i − D_i)·n_i (n_i the drive axis), m.
    pub f_dot_axis: [f64; 3],
    /// Axial load of each forearm's joints: the component along n_i of the force the
    /// arm exerts on the forearm's ball, reversed (the side axial play opens to), N.
    pub axial_force: [f64; 3],
    /// |det Jx| / L2³: 0 at a direct-kinematics singularity.
    pub direct_measure: f64,
}

/// Nominal drive compliance, rad/(N·m): a harmonic drive of torsional stiffness 1e4 N·m/rad
/// (an assumption: the paper gives no drive data).
pub const NOMINAL_COMPLIANCE: f64 = 1e-4;

/// Gravity for a base tilted by `about_x` then `about_y` (rad), m/s².
pub fn tilted_gravity(about_x: f64, about_y: f64) -> Vector3<f64> {
    let (sx, cx) = about_x.sin_cos();
    let (sy, cy) = about_y.sin_cos();
    -STANDARD_GRAVITY * Vector3::new(sy * cx, -sx, cx * cy)
}

impl LumpedModel {
    /// The nominal model: reconstructed geometry, documented masses, level base, no payload,
    /// nominal drive compliance [`NOMINAL_COMPLIANCE`].
    pub fn nominal(g: &Geometry, mp: &MassProperties) -> Self {
        Self {
            geometry: *g,
            arm_length: [g.arm_length; 3],
            forearm_length: [g.forearm_length; 3],
            arm_mass: mp.arm,
            forearm_mass: mp.forearm,
            platform_mass: mp.platform,
            payload: 0.0,
            gravity: Vector3::new(0.0, 0.0, -STANDARD_GRAVITY),
            compliance: [NOMINAL_COMPLIANCE; 3],
            axial_offset: [0.0; 3],
        }
    }

    fn elbow(&self, b: &Branch, i: usize, q: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let (s, c) = (q + self.geometry.q0).sin_cos();
        let a = self.arm_length[i];
        let radial = c * b.arm_dir + s * Vector3::z();
        let d = b.arm_centre + a * radial + self.axial_offset[i] * b.axis;
        let d1 = a * (-s * b.arm_dir + c * Vector3::z());
        (d, d1, -a * radial)
    }

    /// Platform centre for arm angles `q` (rad), by Newton's method from `guess`.
    pub fn forward(&self, q: [f64; 3], guess: Vector3<f64>) -> Result<Vector3<f64>, KinematicsError> {
        if !q.iter().all(|v| v.is_finite()) || !guess.iter().all(|v| v.is_finite()) {
            return Err(KinematicsError::InvalidInput(
                "drive angles and guess must be finite".into(),
            ));
        }
        let br = self.geometry.branches();
        let d: [Vector3<f64>; 3] = std::array::from_fn(|i| self.elbow(&br[i], i, q[i]).0);
        platform_from_elbows(&br, &d, self.forearm_length, q, guess)
    }

    /// Positions, rates, accelerations of the platform and the drive torques for arm angles
    /// `q`, rates `qd` and accelerations `qdd` (rad, rad/s, rad/s²).
    pub fn state(
        &self,
        q: [f64; 3],
        qd: [f64; 3],
        qdd: [f64; 3],
        guess: Vector3<f64>,
    ) -> Result<LumpedState, KinematicsError> {
        let m = self.forward(q, guess)?;
        let br = self.geometry.branches();
        let mut jx = Matrix3::zeros();
        let mut jq = [0.0; 3];
        let mut f_dot_axis = [0.0; 3];
        let mut d1s = [Vector3::zeros(); 3];
        let mut d2s = [Vector3::zeros(); 3];
        for i in 0..3 {
            let (d, d1, d2) = self.elbow(&br[i], i, q[i]);
            let f = m + br[i].platform_joint - d;
            jx.set_row(i, &f.transpose());
            jq[i] = f.dot(&d1);
            f_dot_axis[i] = f.dot(&br[i].axis);
            d1s[i] = d1;
            d2s[i] = d2;
        }
        let singular = || KinematicsError::ForwardFailed {
            q1: q[0].to_degrees(),
            q2: q[1].to_degrees(),
            q3: q[2].to_degrees(),
            reason: "the direct Jacobian is singular".into(),
        };
        let lu = jx.lu();
        let jm = lu
            .solve(&Matrix3::from_diagonal(&Vector3::from(jq)))
            .ok_or_else(singular)?;
        let md = jm * Vector3::from(qd);
        let mut rhs = Vector3::zeros();
        for i in 0..3 {
            let f = jx.row(i).transpose();
            let fd = md - d1s[i] * qd[i];
            rhs[i] = f.dot(&(d1s[i] * qdd[i] + d2s[i] * qd[i] * qd[i])) - fd.norm_squared();
        }
        let mdd = lu.solve(&rhs).ok_or_else(singular)?;
        let mp = self.platform_mass + self.payload + 1.5 * self.forearm_mass;
        let force = mp * (mdd - self.gravity);
        let mu = jx.transpose().lu().solve(&force).ok_or_else(singular)?;
        let mut torque = [0.0; 3];
        let mut tension = [0.0; 3];
        let mut axial_force = [0.0; 3];
        for i in 0..3 {
            axial_force[i] = -mu[i] * f_dot_axis[i];
            let a = self.arm_length[i];
            let inertia = self.arm_mass * a * a / 3.0 + 0.5 * self.forearm_mass * a * a;
            let weight = 0.5 * (self.arm_mass + self.forearm_mass);
            torque[i] = inertia * qdd[i] - weight * self.gravity.dot(&d1s[i]) + jq[i] * mu[i];
            tension[i] = -mu[i] * self.forearm_length[i];
        }
        let l3 = self.forearm_length.iter().product::<f64>();
        Ok(LumpedState {
            m,
            md,
            mdd,
            torque,
            tension,
            jm,
            jq,
            f_dot_axis,
            axial_force,
            direct_measure: jx.determinant().abs() / l3,
        })
    }

    /// The platform centre seen from the encoders: arm angles q − c·τ (the transmissions
    /// wind up under the torques `torque`), then forward kinematics.
    pub fn pose_from_encoders(
        &self,
        q_encoder: [f64; 3],
        torque: [f64; 3],
        guess: Vector3<f64>,
    ) -> Result<Vector3<f64>, KinematicsError> {
        let q = std::array::from_fn(|i| q_encoder[i] - self.compliance[i] * torque[i]);
        self.forward(q, guess)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanisms::mr2120::kinematics::{forward, inverse};

    #[test]
    fn forward_kinematics_matches_the_geometry_module() {
        let g = Geometry::default();
        let model = LumpedModel::nominal(&g, &MassProperties::default());
        let target = Vector3::new(0.03, -0.02, 0.45);
        let q = inverse(&g, target).unwrap();
        let a = model.forward(q, Vector3::new(0.0, 0.0, 0.5)).unwrap();
        let b = forward(&g, q, Vector3::new(0.0, 0.0, 0.5)).unwrap();
        assert!((a - target).norm() < 1e-12 && (a - b).norm() < 1e-12);
    }

    #[test]
    fn torques_do_the_work_of_the_platform_at_rest() {
        // At rest with only a payload changed, the extra drive power for a virtual motion
        // equals the payload's weight times the platform's virtual displacement.
        let g = Geometry::default();
        let mut model = LumpedModel::nominal(&g, &MassProperties::default());
        let q = inverse(&g, Vector3::new(0.0, 0.0, 0.5)).unwrap();
        let guess = Vector3::new(0.0, 0.0, 0.5);
        let s0 = model.state(q, [0.0; 3], [0.0; 3], guess).unwrap();
        model.payload = 1.0;
        let s1 = model.state(q, [0.0; 3], [0.0; 3], guess).unwrap();
        let dq = Vector3::new(1e-3, -2e-3, 0.5e-3);
        let work: f64 = (0..3).map(|i| (s1.torque[i] - s0.torque[i]) * dq[i]).sum();
        let lift = STANDARD_GRAVITY * (s0.jm * dq).z;
        assert!(
            (work - lift).abs() < 1e-9 * lift.abs().max(1.0),
            "{work} vs {lift}"
        );
    }
}
