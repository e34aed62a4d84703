//! Measured motion and torques of one recording, ready for equation-error residuals.

use super::model::InverseDynamicsModel;
use super::recording::{Recording, RecordingError};
use super::signal::derivative;

/// One recording in equation-error form.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionData {
    /// Recording name (file stem).
    pub name: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// Joint positions per joint, rad.
    pub q: Vec<Vec<f64>>,
    /// Joint rates per joint, rad/s.
    pub qd: Vec<Vec<f64>>,
    /// Joint accelerations per joint (differentiated rates), rad/s².
    pub qdd: Vec<Vec<f64>>,
    /// Measured joint torques per joint, N·m.
    pub tau: Vec<Vec<f64>>,
}

/// Roles a recording must map for an n-joint model: q1.., qd1.., tau1.. (1-based).
pub fn roles(joints: usize) -> Vec<String> {
    let mut r = vec![];
    for prefix in ["q", "qd", "tau"] {
        for j in 1..=joints {
            r.push(format!("{prefix}{j}"));
        }
    }
    r
}

impl MotionData {
    /// From a recording with the roles of [`roles`]; accelerations by local least-squares
    /// lines over ±`half_window` samples of the rates.
    pub fn from_recording(
        rec: &Recording,
        joints: usize,
        half_window: usize,
    ) -> Result<Self, RecordingError> {
        let get = |role: String| {
            rec.channel(&role)
                .map(<[f64]>::to_vec)
                .ok_or(RecordingError::Unmapped {
                    role: role.clone(),
                    hint: format!("--map {role}=<column>"),
                })
        };
        let mut d = MotionData {
            name: rec.name(),
            t: rec.time.clone(),
            q: vec![],
            qd: vec![],
            qdd: vec![],
            tau: vec![],
        };
        for j in 1..=joints {
            d.q.push(get(format!("q{j}"))?);
            let qd = get(format!("qd{j}"))?;
            d.qdd.push(derivative(&rec.time, &qd, half_window));
            d.qd.push(qd);
            d.tau.push(get(format!("tau{j}"))?);
        }
        Ok(d)
    }

    /// Samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The model's torques per joint at every sample with parameters `theta`.
    pub fn model_torques(&self, model: &dyn InverseDynamicsModel, theta: &[f64]) -> Vec<Vec<f64>> {
        let nj = model.joints();
        let mut out = vec![vec![0.0; self.len()]; nj];
        let (mut q, mut qd, mut qdd, mut tau) = (vec![0.0; nj], vec![0.0; nj], vec![0.0; nj], vec![0.0; nj]);
        for i in 0..self.len() {
            for j in 0..nj {
                q[j] = self.q[j][i];
                qd[j] = self.qd[j][i];
                qdd[j] = self.qdd[j][i];
            }
            model.torques(theta, &q, &qd, &qdd, &mut tau);
            for j in 0..nj {
                out[j][i] = tau[j];
            }
        }
        out
    }
}
