//! The DFKI two-link pendulum's nominal rigid model, as its data README states it
//! (`../shared/data/dfki-double-pendulum/README.md`): planar, q1 absolute from hanging
//! straight down, q2 relative to link 1, M(q)q̈ + C(q,q̇)q̇ − G(q) = τ.
//!
//! The parameter values are read from that README (its table is the one source; nothing is
//! copied here). Two extra parameters, zero in the nominal model, let the diagnosis perturb
//! what the README leaves out: a base tilt in the plane of motion and a point payload at the
//! tip of link 2.

use serde::Serialize;
use std::path::Path;

/// Gravity of the README's model, m/s².
pub const README_GRAVITY: f64 = 9.81;

/// The README of the DFKI recordings, relative to the project root.
pub const DFKI_README: &str = "../shared/data/dfki-double-pendulum/README.md";

/// Why the parameters could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PendulumError {
    /// The README could not be read.
    #[error("{path}: cannot read: {message}")]
    Io {
        /// File.
        path: String,
        /// Message.
        message: String,
    },
    /// The parameter table is missing or malformed.
    #[error("{path}:{line}: {message}")]
    Table {
        /// File.
        path: String,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Physical parameters of the double pendulum (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DoublePendulumParams {
    /// Mass of link 1, kg.
    pub m1: f64,
    /// Mass of link 2, kg.
    pub m2: f64,
    /// Length of link 1 (joint 1 to joint 2), m.
    pub l1: f64,
    /// Length of link 2, m.
    pub l2: f64,
    /// Centre-of-mass distance of link 1 from joint 1, m.
    pub r1: f64,
    /// Centre-of-mass distance of link 2 from joint 2, m.
    pub r2: f64,
    /// Inertia of link 1 about joint 1, kg·m².
    pub i1: f64,
    /// Inertia of link 2 about joint 2, kg·m².
    pub i2: f64,
    /// Gravity, m/s².
    pub g: f64,
    /// Base tilt in the plane of motion (gravity direction rotated by it), rad. Nominal 0.
    pub tilt: f64,
    /// Point payload at the tip of link 2 (distance l2 from joint 2), kg. Nominal 0.
    pub payload: f64,
    /// Gear ratio of the drives (motor turns per joint turn), if the README states it. The
    /// nominal model ignores the rotors; the diagnosis uses it to couple drive 2's rotor,
    /// which link 1 carries.
    pub gear_ratio: Option<f64>,
}

/// The number after "gear ratio" in the README's prose, if any.
fn gear_ratio(text: &str) -> Option<f64> {
    let lower = text.to_lowercase();
    let at = lower.find("gear ratio")? + "gear ratio".len();
    let rest: String = lower[at..]
        .chars()
        .skip_while(|c| !c.is_ascii_digit())
        .take_while(|c| c.is_ascii_digit() || *c == '.')
        .collect();
    rest.parse().ok().filter(|v: &f64| *v > 0.0)
}

impl DoublePendulumParams {
    /// Reads m1, m2, l1, l2, r1, r2, I1, I2 from the README's parameter table.
    pub fn from_readme(path: &Path) -> Result<Self, PendulumError> {
        let p = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| PendulumError::Io {
            path: p.clone(),
            message: e.to_string(),
        })?;
        let lines: Vec<&str> = text.lines().collect();
        let head = lines
            .iter()
            .position(|l| l.trim_start().starts_with("| m1"))
            .ok_or_else(|| PendulumError::Table {
                path: p.clone(),
                line: lines.len(),
                message: "no parameter table (a row starting with '| m1')".into(),
            })?;
        let row_line = head + 2;
        let row = lines.get(row_line).ok_or_else(|| PendulumError::Table {
            path: p.clone(),
            line: row_line + 1,
            message: "the table has no value row".into(),
        })?;
        let v: Vec<f64> = row.split('|').filter_map(|c| c.trim().parse().ok()).collect();
        if v.len() != 8 || v.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
            return Err(PendulumError::Table {
                path: p,
                line: row_line + 1,
                message: format!("expected 8 positive numbers (m1 m2 l1 l2 r1 r2 I1 I2), found '{row}'"),
            });
        }
        Ok(Self {
            m1: v[0],
            m2: v[1],
            l1: v[2],
            l2: v[3],
            r1: v[4],
            r2: v[5],
            i1: v[6],
            i2: v[7],
            g: README_GRAVITY,
            tilt: 0.0,
            payload: 0.0,
            gear_ratio: gear_ratio(&text),
        })
    }

    /// Joint torques τ (N·m) at (q, q̇, q̈) (rad, rad/s, rad/s²).
    pub fn torques(&self, q: [f64; 2], qd: [f64; 2], qdd: [f64; 2]) -> [f64; 2] {
        // Link 2 with the payload: mass, first moment about joint 2, inertia about joint 2.
        let m2 = self.m2 + self.payload;
        let s2 = self.m2 * self.r2 + self.payload * self.l2;
        let i2 = self.i2 + self.payload * self.l2 * self.l2;
        let c2 = q[1].cos();
        let m11 = self.i1 + i2 + m2 * self.l1 * self.l1 + 2.0 * self.l1 * s2 * c2;
        let m12 = i2 + self.l1 * s2 * c2;
        let h = self.l1 * s2 * q[1].sin();
        let c1 = -h * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]);
        let c2v = h * qd[0] * qd[0];
        let (a1, a12) = (q[0] + self.tilt, q[0] + q[1] + self.tilt);
        let g1 = -self.g * (self.m1 * self.r1 * a1.sin() + m2 * self.l1 * a1.sin() + s2 * a12.sin());
        let g2 = -self.g * s2 * a12.sin();
        [
            m11 * qdd[0] + m12 * qdd[1] + c1 - g1,
            m12 * qdd[0] + i2 * qdd[1] + c2v - g2,
        ]
    }
}
