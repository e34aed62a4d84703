//! Positioning accuracy at fixed drive angles (paper §4.2, Table 3): the range (min…max) of
//! each error of eq. (4.1) while the platform of the clearance model is excited around the
//! position the drives command.
//!
//! Method (a), the paper's: a dynamic excitation. With the drives locked at q(M_i), the
//! clearance model first settles under gravity ([`Excitation::settle`]); then a sequence of
//! smooth half-sine force pulses along ±x, ±y, ±z of amplitude [`Excitation::force`] and
//! torque pulses about ±x, ±y, ±z of amplitude [`Excitation::torque`] pushes the platform
//! through its play, one pulse after the other. The errors are recorded after settling.
//! The paper does not state its excitation; these amplitudes are lash's documented choice.

use super::clearance::{bearing_design, clearance_model, DEFAULT_DAMPING};
use super::geometry::{Geometry, MassProperties};
use super::ideal::Mr2120Error;
use super::kinematics::inverse;
use super::paper::{ClearanceSet, Table2Point, TABLE3};
use super::trajectory::clearance_options;
use crate::multibody::forces::{BodyLoad, BodyState, ForceElement};
use crate::multibody::rotation::{rotation, rotation_vector};
use crate::multibody::{BodyHandle, MotionLaw, Simulation};
use nalgebra::{Matrix3, Vector3, Vector4};
use serde::Serialize;
use std::sync::Arc;

/// The dynamic excitation of method (a).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Excitation {
    /// Settling time before the pulses, s.
    pub settle: f64,
    /// Duration of one pulse, s.
    pub pulse: f64,
    /// Force amplitude, N.
    pub force: f64,
    /// Torque amplitude, N·m.
    pub torque: f64,
}

impl Default for Excitation {
    fn default() -> Self {
        Self {
            settle: 0.1,
            pulse: 0.05,
            force: 10.0,
            torque: 0.5,
        }
    }
}

impl Excitation {
    /// End time of the last pulse, s.
    pub fn end(&self) -> f64 {
        self.settle + 12.0 * self.pulse
    }
}

/// Force element applying the excitation to the platform.
#[derive(Debug, Clone)]
struct PlatformPulses {
    body: BodyHandle,
    ex: Excitation,
}

impl ForceElement for PlatformPulses {
    fn name(&self) -> &str {
        "platform excitation"
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.body]
    }
    fn apply(&self, t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let s = t - self.ex.settle;
        if s <= 0.0 || s >= 12.0 * self.ex.pulse {
            return;
        }
        let k = (s / self.ex.pulse).floor() as usize;
        let shape = (std::f64::consts::PI * (s / self.ex.pulse - k as f64))
            .sin()
            .powi(2);
        let axis = k % 6 / 2;
        let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
        let mut dir = Vector3::zeros();
        dir[axis] = sign * shape;
        let b = self.body.index();
        if k < 6 {
            loads[b].force += dir * self.ex.force;
        } else {
            loads[b].torque += states[b].a.transpose() * (dir * self.ex.torque);
        }
    }
}

/// Ranges (min, max) of d_xM, d_yM, d_zM (m) and δx, δy, δz (rad).
pub type Ranges = [(f64, f64); 6];

/// Method (a) at one point and clearance set.
pub fn dynamic_envelope(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
    ex: &Excitation,
) -> Result<(Ranges, usize), Mr2120Error> {
    let m = Vector3::from(point.m);
    let q = inverse(g, m)?;
    let mut model = clearance_model(
        g,
        mp,
        m,
        Some(q.map(MotionLaw::Constant)),
        &bearing_design(set, DEFAULT_DAMPING),
    )?;
    let platform = model.platform;
    model.mechanism.add_force(Box::new(PlatformPulses {
        body: platform,
        ex: *ex,
    }));
    let mut sim = Simulation::new(Arc::new(model.mechanism), 0.0, clearance_options())?;
    let n = 400;
    let times: Vec<f64> = (1..=n)
        .map(|k| ex.settle + (ex.end() - ex.settle) * k as f64 / n as f64)
        .collect();
    let traj = sim.run(&times, |_| {})?;
    let p = platform.index();
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); 6];
    for s in &traj.samples {
        let qq = &s.q[7 * p..7 * p + 7];
        let rv = rotation_vector(
            &rotation(&Vector4::new(qq[3], qq[4], qq[5], qq[6])),
            &Matrix3::identity(),
        );
        let e = [qq[0] - m.x, qq[1] - m.y, qq[2] - m.z, rv.x, rv.y, rv.z];
        for k in 0..6 {
            r[k].0 = r[k].0.min(e[k]);
            r[k].1 = r[k].1.max(e[k]);
        }
    }
    Ok((r, sim.stats().steps))
}

/// One row of the Table 3 comparison.
#[derive(Debug, Clone, Serialize)]
pub struct AccuracyRow {
    /// Point (M1, M2, M3).
    pub point: String,
    /// Clearance set.
    pub set: String,
    /// Method.
    pub method: String,
    /// lash's ranges: d in mm, δ in degrees.
    pub ranges: [(f64, f64); 6],
    /// The paper's ranges (Table 3), same units.
    pub paper: [(f64, f64); 6],
    /// Integrator steps.
    pub steps: usize,
}

/// Method (a) for the given points and sets, beside the paper's Table 3.
pub fn table3(
    g: &Geometry,
    mp: &MassProperties,
    points: &[Table2Point],
    sets: &[ClearanceSet],
    ex: &Excitation,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<AccuracyRow>, Mr2120Error> {
    let total = points.len() * sets.len();
    let mut rows = vec![];
    for p in points {
        for s in sets {
            progress(rows.len(), total);
            let (r, steps) = dynamic_envelope(g, mp, p, s, ex)?;
            let conv = |k: usize, v: f64| if k < 3 { v * 1e3 } else { v.to_degrees() };
            let ranges = std::array::from_fn(|k| (conv(k, r[k].0), conv(k, r[k].1)));
            let paper = TABLE3
                .iter()
                .find(|t| t.point == p.name && t.set == s.name)
                .map(|t| t.ranges)
                .unwrap_or([(f64::NAN, f64::NAN); 6]);
            rows.push(AccuracyRow {
                point: p.name.into(),
                set: s.name.into(),
                method: "dynamic excitation".into(),
                ranges,
                paper,
                steps,
            });
        }
    }
    progress(total, total);
    Ok(rows)
}
