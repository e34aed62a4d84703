//! The MR2120 geometry: the reconstruction of `../shared/reference/mr2120-geometry.md`
//! (the paper's figures are missing; that file derives a layout that reproduces Table 2).
//! All lengths in m, angles in rad.

use super::paper;
use nalgebra::{Rotation3, Vector3};

/// Geometry of the MR2120. [`Default`] is the reconstruction; every field can be changed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Circumradius of the base triangle ABC, m (= 0.74/√3).
    pub base_radius: f64,
    /// Circumradius of the platform triangle PQR, m (= 0.15/√3).
    pub platform_radius: f64,
    /// Height of the platform centre M above the plane of P, Q, R, m.
    pub platform_height: f64,
    /// Arm length L1 = AD, m.
    pub arm_length: f64,
    /// Forearm length L2 = DP, m.
    pub forearm_length: f64,
    /// Angle between a revolute axis and the radial line from its vertex to the centre, rad.
    pub axis_angle: f64,
    /// Offset of the arm plane along the revolute axis from the vertex, m.
    pub arm_offset: f64,
    /// Drive-angle offset q0: the arm direction is at q + q0 from the horizontal, rad.
    pub q0: f64,
}

impl Default for Geometry {
    /// The reconstruction of `mr2120-geometry.md` (reproduces Table 2 to 1e-6°).
    fn default() -> Self {
        Self {
            base_radius: paper::BASE_SIDE / 3f64.sqrt(),
            platform_radius: paper::PLATFORM_SIDE / 3f64.sqrt(),
            platform_height: 0.0667717,
            arm_length: paper::ARM_LENGTH,
            forearm_length: paper::FOREARM_LENGTH,
            // n = (−0.7410198, 0.6714832, 0) for branch A.
            axis_angle: 0.6714832f64.atan2(0.7410198),
            arm_offset: -0.2431981,
            q0: (-8.838063f64).to_radians(),
        }
    }
}

/// One branch (A, B or C) in the base frame, for the geometry it was computed from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Branch {
    /// Azimuth of the branch about z, rad (0, 2π/3, 4π/3).
    pub azimuth: f64,
    /// Base vertex (A, B, C), m.
    pub vertex: Vector3<f64>,
    /// Unit revolute axis n (horizontal).
    pub axis: Vector3<f64>,
    /// Unit arm direction at q + q0 = 0 (horizontal, = n × e_z).
    pub arm_dir: Vector3<f64>,
    /// Centre of the arm's circle A' = vertex + offset·n, m.
    pub arm_centre: Vector3<f64>,
    /// Platform joint relative to M (P − M), m.
    pub platform_joint: Vector3<f64>,
}

impl Geometry {
    /// The three branches, A at azimuth 0 and B, C rotated by 120° and 240° about z.
    pub fn branches(&self) -> [Branch; 3] {
        let (sa, ca) = self.axis_angle.sin_cos();
        let n_a = Vector3::new(-ca, sa, 0.0);
        let a_a = Vector3::new(self.base_radius, 0.0, 0.0);
        let p_a = Vector3::new(self.platform_radius, 0.0, -self.platform_height);
        let ez = Vector3::z();
        std::array::from_fn(|i| {
            let azimuth = i as f64 * 2.0 * std::f64::consts::PI / 3.0;
            let r = Rotation3::from_axis_angle(&Vector3::z_axis(), azimuth);
            let axis = r * n_a;
            let vertex = r * a_a;
            Branch {
                azimuth,
                vertex,
                axis,
                arm_dir: axis.cross(&ez),
                arm_centre: vertex + self.arm_offset * axis,
                platform_joint: r * p_a,
            }
        })
    }

    /// Elbow point D of a branch for drive angle `q`, m.
    pub fn elbow(&self, b: &Branch, q: f64) -> Vector3<f64> {
        let (s, c) = (q + self.q0).sin_cos();
        b.arm_centre + self.arm_length * (c * b.arm_dir + s * Vector3::z())
    }

    /// dD/dq of a branch at drive angle `q`, m/rad.
    pub fn elbow_rate(&self, b: &Branch, q: f64) -> Vector3<f64> {
        let (s, c) = (q + self.q0).sin_cos();
        self.arm_length * (-s * b.arm_dir + c * Vector3::z())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn branch_data_match_the_reconstruction() {
        let g = Geometry::default();
        let b = g.branches();
        let close = |a: Vector3<f64>, e: [f64; 3]| (a - Vector3::from(e)).norm() < 2e-7;
        assert!(close(b[0].vertex, [0.4272392, 0.0, 0.0]));
        assert!(close(b[0].arm_centre, [0.6074538, -0.1633034, 0.0]));
        assert!(close(b[1].vertex, [-0.2136196, 0.37, 0.0]));
        assert!(close(b[1].axis, [-0.2110116, -0.9774836, 0.0]));
        assert!(close(b[1].arm_centre, [-0.1623020, 0.6077222, 0.0]));
        assert!(close(b[2].axis, [0.9520314, 0.3060003, 0.0]));
        assert!(close(b[2].arm_centre, [-0.4451518, -0.4444187, 0.0]));
        assert!(close(b[1].platform_joint, [-0.0433013, 0.075, -0.0667717]));
    }
}

/// Mass properties the paper does not give: documented defaults from
/// `../shared/reference/mr2120-geometry.md` ("Assumptions the paper does not give").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MassProperties {
    /// Arm AD (aluminium), kg; centre of mass at mid-length, slender-rod inertia.
    pub arm: f64,
    /// Forearm DP (aluminium tube), kg; centre of mass at mid-length, slender-rod inertia.
    pub forearm: f64,
    /// Platform, kg; centre of mass at M.
    pub platform: f64,
    /// Platform plate thickness, m (inertia of a 0.15 m triangle plate).
    pub platform_thickness: f64,
    /// Cross of each universal joint (steel), kg (used by the clearance model).
    pub cross: f64,
}

impl Default for MassProperties {
    fn default() -> Self {
        Self {
            arm: 1.0,
            forearm: 0.8,
            platform: 1.5,
            platform_thickness: 0.010,
            cross: 0.05,
        }
    }
}
