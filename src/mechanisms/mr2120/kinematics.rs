//! Kinematics of the ideal MR2120: closed-form inverse kinematics, numerical forward
//! kinematics, the Jacobians of Jx·v = Jq·q̇, and singularity measures.
//!
//! Each branch closes |P_i − D_i(q_i)| = L2 with P_i = M + p_i (the platform only
//! translates) and D_i(q) = A'_i + L1·(cos(q+q0)·u_i + sin(q+q0)·e_z). Differentiating,
//! (P_i − D_i)·v = (P_i − D_i)·(dD_i/dq)·q̇_i, so the rows of Jx are the forearm vectors
//! P_i − D_i and Jq = diag((P_i − D_i)·dD_i/dq).

use super::geometry::{Branch, Geometry};
use nalgebra::{Matrix3, Vector3};
use serde::Serialize;
use thiserror::Error;

/// Kinematics failures, with what a user needs to fix the input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum KinematicsError {
    /// The target lies outside the work zone.
    #[error("target M = ({x:.4}, {y:.4}, {z:.4}) m is outside the work zone: branch {branch} cannot reach it; on this vertical the reachable z range is {range}")]
    Unreachable {
        /// Target x, m.
        x: f64,
        /// Target y, m.
        y: f64,
        /// Target z, m.
        z: f64,
        /// Branch that cannot close (A, B, C).
        branch: char,
        /// Reachable z interval on the vertical through (x, y), as text.
        range: String,
    },
    /// Forward kinematics did not converge (singular configuration or bad guess).
    #[error("forward kinematics did not converge for q = ({q1:.4}, {q2:.4}, {q3:.4})°: {reason}")]
    ForwardFailed {
        /// Drive angle 1, degrees.
        q1: f64,
        /// Drive angle 2, degrees.
        q2: f64,
        /// Drive angle 3, degrees.
        q3: f64,
        /// Why.
        reason: String,
    },
    /// Non-finite input.
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

const BRANCH_NAMES: [char; 3] = ['A', 'B', 'C'];

/// Closed-form solution data of one branch: a·cos φ + b·sin φ = k with φ = q + q0.
fn branch_equation(g: &Geometry, i: usize, m: &Vector3<f64>) -> (f64, f64, f64) {
    let b = &g.branches()[i];
    let w = m + b.platform_joint - b.arm_centre;
    let a = w.dot(&b.arm_dir);
    let bb = w.z;
    let k = (w.norm_squared() + g.arm_length.powi(2) - g.forearm_length.powi(2)) / (2.0 * g.arm_length);
    (a, bb, k)
}

/// Inverse kinematics: drive angles (rad) that put the platform centre at `m`.
///
/// Of the two elbow solutions per branch, lash takes the one of the paper's Table 2 (elbow
/// out and up: φ = atan2(b, a) − acos(k/√(a² + b²))).
pub fn inverse(g: &Geometry, m: Vector3<f64>) -> Result<[f64; 3], KinematicsError> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err(KinematicsError::InvalidInput(format!(
            "target {m:?} is not finite"
        )));
    }
    let mut q = [0.0; 3];
    for i in 0..3 {
        let (a, b, k) = branch_equation(g, i, &m);
        let rho = (a * a + b * b).sqrt();
        if rho == 0.0 || k.abs() > rho {
            let range = match reachable_z_range(g, m.x, m.y) {
                Some((lo, hi)) => format!("[{lo:.4}, {hi:.4}] m"),
                None => "empty (the vertical misses the work zone)".into(),
            };
            return Err(KinematicsError::Unreachable {
                x: m.x,
                y: m.y,
                z: m.z,
                branch: BRANCH_NAMES[i],
                range,
            });
        }
        let phi = b.atan2(a) - (k / rho).acos();
        q[i] = phi - g.q0;
    }
    Ok(q)
}

/// Drive angle of branch `i` at platform centre `m` with its first and second derivatives
/// with respect to z_M (x_M, y_M fixed): implicit differentiation of the branch equation
/// F(φ, z) = a·cos φ + b·sin φ − k = 0, with ∂a/∂z = 0, ∂b/∂z = 1, ∂k/∂z = b/L1.
/// Returns (q in rad, dq/dz in rad/m, d²q/dz² in rad/m²).
pub fn inverse_z_derivatives(g: &Geometry, i: usize, m: Vector3<f64>) -> Result<[f64; 3], KinematicsError> {
    let q = inverse(g, m)?[i];
    let phi = q + g.q0;
    let (a, b, k) = branch_equation(g, i, &m);
    let (s, c) = phi.sin_cos();
    let f_phi = -a * s + b * c;
    let f_z = s - b / g.arm_length;
    let d1 = -f_z / f_phi;
    let d2 = -(-1.0 / g.arm_length + 2.0 * c * d1 - k * d1 * d1) / f_phi;
    Ok([q, d1, d2])
}

/// Margin of branch `i` at `m`: √(a² + b²) − |k| (> 0 inside the work zone, 0 on its boundary).
fn margin(g: &Geometry, m: &Vector3<f64>) -> f64 {
    (0..3)
        .map(|i| {
            let (a, b, k) = branch_equation(g, i, m);
            (a * a + b * b).sqrt() - k.abs()
        })
        .fold(f64::INFINITY, f64::min)
}

/// The reachable interval of z on the vertical through (x, y), by scanning and bisection.
pub fn reachable_z_range(g: &Geometry, x: f64, y: f64) -> Option<(f64, f64)> {
    let f = |z: f64| margin(g, &Vector3::new(x, y, z));
    let (lo, hi, n) = (-2.0, 2.0, 4000);
    let dz = (hi - lo) / n as f64;
    let mut first = None;
    let mut last = None;
    for k in 0..=n {
        let z = lo + k as f64 * dz;
        if f(z) >= 0.0 {
            if first.is_none() {
                first = Some(z);
            }
            last = Some(z);
        }
    }
    let refine = |mut inside: f64, mut outside: f64| {
        for _ in 0..60 {
            let mid = 0.5 * (inside + outside);
            if f(mid) >= 0.0 {
                inside = mid;
            } else {
                outside = mid;
            }
        }
        inside
    };
    match (first, last) {
        (Some(a), Some(b)) => Some((refine(a, a - dz), refine(b, b + dz))),
        _ => None,
    }
}

/// Elbow points D_i for drive angles `q`, m.
pub fn elbows(g: &Geometry, q: [f64; 3]) -> [Vector3<f64>; 3] {
    let br = g.branches();
    std::array::from_fn(|i| g.elbow(&br[i], q[i]))
}

/// The Jacobians at (q, m): Jx (rows P_i − D_i, m) and the diagonal of Jq (m²).
pub fn jacobians(g: &Geometry, q: [f64; 3], m: Vector3<f64>) -> (Matrix3<f64>, [f64; 3]) {
    let br = g.branches();
    let mut jx = Matrix3::zeros();
    let mut jq = [0.0; 3];
    for i in 0..3 {
        let f = m + br[i].platform_joint - g.elbow(&br[i], q[i]);
        jx.set_row(i, &f.transpose());
        jq[i] = f.dot(&g.elbow_rate(&br[i], q[i]));
    }
    (jx, jq)
}

/// Forward kinematics: the platform centre for drive angles `q` (rad), by Newton's method
/// from `guess` (the assembly mode closest to the guess).
pub fn forward(g: &Geometry, q: [f64; 3], guess: Vector3<f64>) -> Result<Vector3<f64>, KinematicsError> {
    if !q.iter().all(|v| v.is_finite()) || !guess.iter().all(|v| v.is_finite()) {
        return Err(KinematicsError::InvalidInput(
            "drive angles and guess must be finite".into(),
        ));
    }
    platform_from_elbows(&g.branches(), &elbows(g, q), [g.forearm_length; 3], q, guess)
}

/// The platform centre M that puts each platform joint P_i at distance `lengths[i]` (m) from
/// the elbow point `elbows[i]`, by Newton's method from `guess`; `q` (rad) names the
/// configuration in errors.
pub(crate) fn platform_from_elbows(
    br: &[Branch; 3],
    elbows: &[Vector3<f64>; 3],
    lengths: [f64; 3],
    q: [f64; 3],
    guess: Vector3<f64>,
) -> Result<Vector3<f64>, KinematicsError> {
    let fail = |reason: String| KinematicsError::ForwardFailed {
        q1: q[0].to_degrees(),
        q2: q[1].to_degrees(),
        q3: q[2].to_degrees(),
        reason,
    };
    let mut m = guess;
    for _ in 0..50 {
        let mut r = Vector3::zeros();
        let mut jx = Matrix3::zeros();
        for i in 0..3 {
            let f = m + br[i].platform_joint - elbows[i];
            r[i] = 0.5 * (f.norm_squared() - lengths[i].powi(2));
            jx.set_row(i, &f.transpose());
        }
        if r.amax() < 1e-15 {
            return Ok(m);
        }
        let step = jx.lu().solve(&r).ok_or_else(|| {
            fail(format!(
                "the direct Jacobian is singular at M = ({:.4}, {:.4}, {:.4}) m",
                m.x, m.y, m.z
            ))
        })?;
        m -= step;
        if step.norm() < 1e-13 * (1.0 + m.norm()) {
            return Ok(m);
        }
    }
    Err(fail(
        "no convergence in 50 Newton iterations (near a direct-kinematics singularity?)".into(),
    ))
}

/// Kind of singularity (Gosselin & Angeles): of the inverse problem (Jq loses rank: a
/// branch is stretched or folded, the work-zone boundary), of the direct problem (Jx loses
/// rank: the platform can move with the drives locked), or both.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SingularityClass {
    /// Well away from both.
    Regular,
    /// Close to an inverse-kinematics singularity (normalised measure below `NEAR`).
    NearInverse,
    /// At an inverse-kinematics singularity.
    Inverse,
    /// Close to a direct-kinematics singularity.
    NearDirect,
    /// At a direct-kinematics singularity.
    Direct,
    /// Near or at both.
    Both,
}

/// Normalised measures below this are "at" a singularity.
pub const SINGULAR: f64 = 1e-6;
/// Normalised measures below this are "near" a singularity.
pub const NEAR: f64 = 0.1;

/// Singularity measures at one configuration.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SingularityReport {
    /// det Jx, m³.
    pub det_jx: f64,
    /// |det Jx| / L2³: 1 for mutually orthogonal forearms, 0 at a direct singularity.
    pub direct_measure: f64,
    /// Diagonal of Jq, m².
    pub jq: [f64; 3],
    /// min |Jq_ii| / (L1·L2): 1 for arm ⟂ forearm, 0 at an inverse singularity.
    pub inverse_measure: f64,
    /// Classification.
    pub class: SingularityClass,
}

/// Singularity measures and class at (q, m).
pub fn singularity(g: &Geometry, q: [f64; 3], m: Vector3<f64>) -> SingularityReport {
    let (jx, jq) = jacobians(g, q, m);
    let det_jx = jx.determinant();
    let direct_measure = det_jx.abs() / g.forearm_length.powi(3);
    let inverse_measure =
        jq.iter().map(|v| v.abs()).fold(f64::INFINITY, f64::min) / (g.arm_length * g.forearm_length);
    let level = |x: f64| {
        if x < SINGULAR {
            2
        } else if x < NEAR {
            1
        } else {
            0
        }
    };
    let class = match (level(inverse_measure), level(direct_measure)) {
        (0, 0) => SingularityClass::Regular,
        (i, 0) => {
            if i == 2 {
                SingularityClass::Inverse
            } else {
                SingularityClass::NearInverse
            }
        }
        (0, d) => {
            if d == 2 {
                SingularityClass::Direct
            } else {
                SingularityClass::NearDirect
            }
        }
        _ => SingularityClass::Both,
    };
    SingularityReport {
        det_jx,
        direct_measure,
        jq,
        inverse_measure,
        class,
    }
}

#[cfg(test)]
mod tests {
    use super::super::paper::TABLE2;
    use super::*;

    #[test]
    fn table2_within_002_degrees() {
        let g = Geometry::default();
        for p in TABLE2 {
            let q = inverse(&g, Vector3::from(p.m)).unwrap();
            for i in 0..3 {
                assert!(
                    (q[i].to_degrees() - p.q_deg[i]).abs() < 0.02,
                    "{} q{}: {}",
                    p.name,
                    i + 1,
                    q[i].to_degrees()
                );
            }
        }
    }

    #[test]
    fn reconstruction_checks() {
        let g = Geometry::default();
        let m1 = Vector3::new(0.0, 0.0, 0.5);
        let q = inverse(&g, m1).unwrap();
        let d = elbows(&g, q);
        assert!((d[0] - Vector3::new(0.7356104, -0.0218754, 0.2314605)).norm() < 1e-6);
        let (jx, jq) = jacobians(&g, q, m1);
        assert!((jx.determinant() - 0.22105).abs() < 1e-5);
        assert!((jq[0] - 0.135627).abs() < 1e-6 && (jq[1] - jq[0]).abs() < 1e-12);
        let m3 = Vector3::new(0.0, 0.0, 0.2509);
        let q3 = inverse(&g, m3).unwrap();
        let s = singularity(&g, q3, m3);
        assert!(s.direct_measure < 1e-4, "{s:?}");
        let (lo, hi) = reachable_z_range(&g, 0.0, 0.0).unwrap();
        assert!(
            (hi - 0.797384).abs() < 1e-5 && (lo + 0.664).abs() < 1e-3,
            "{lo} {hi}"
        );
    }

    #[test]
    fn z_derivatives_match_finite_differences() {
        let g = Geometry::default();
        let m = Vector3::new(0.03, -0.02, 0.6);
        let h = 1e-5;
        for i in 0..3 {
            let [q, d1, d2] = inverse_z_derivatives(&g, i, m).unwrap();
            let qp = inverse(&g, m + Vector3::new(0.0, 0.0, h)).unwrap()[i];
            let qm = inverse(&g, m - Vector3::new(0.0, 0.0, h)).unwrap()[i];
            assert!(((qp - qm) / (2.0 * h) - d1).abs() < 1e-8, "d1");
            assert!(((qp - 2.0 * q + qm) / (h * h) - d2).abs() < 1e-4, "d2");
        }
    }

    #[test]
    fn forward_inverts_inverse_off_axis() {
        let g = Geometry::default();
        let m = Vector3::new(0.05, -0.03, 0.55);
        let q = inverse(&g, m).unwrap();
        let back = forward(&g, q, Vector3::new(0.0, 0.0, 0.5)).unwrap();
        assert!((back - m).norm() < 1e-12);
    }

    #[test]
    fn unreachable_target_names_the_point_and_the_range() {
        let g = Geometry::default();
        let e = inverse(&g, Vector3::new(0.0, 0.0, 0.9)).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("0.9000") && msg.contains("0.797"), "{msg}");
        assert!(inverse(&g, Vector3::new(f64::NAN, 0.0, 0.5)).is_err());
    }
}
