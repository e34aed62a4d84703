//! The index layout of a mechanism's state vectors (positions, velocities, multipliers, and
//! the DAE unknowns): the one place that computes an address.

use super::body::BodyHandle;
use super::joints::JointHandle;
use super::model::{DriverHandle, Mechanism};
use std::ops::Range;

/// Index layout of a mechanism's state vectors: the one place that knows where a body's
/// coordinates, a joint's multipliers and a driver's multiplier live.
///
/// Three kinds of vectors use it:
/// * positions q (per body r, p: [`Q_PER_BODY`](Self::Q_PER_BODY) values), velocities w (per
///   body v, ω': [`W_PER_BODY`](Self::W_PER_BODY) values) and multipliers λ (joints in
///   insertion order, then drivers), as in [`Snapshot`](super::Snapshot),
///   [`Sample`](super::Sample) and [`MechanismData`](super::MechanismData): addressed with
///   [`body_q`](Self::body_q), [`body_w`](Self::body_w), [`joint_lambda`](Self::joint_lambda),
///   [`driver_lambda`](Self::driver_lambda);
/// * the DAE unknowns y = (q, w, λ, μ, ν) of [`MultibodyDae`](super::MultibodyDae): [`y_q`](Self::y_q),
///   [`y_w`](Self::y_w), [`y_lambda`](Self::y_lambda) and the offsets [`q`](Self::q),
///   [`w`](Self::w), [`lambda`](Self::lambda), [`mu`](Self::mu), [`nu`](Self::nu).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Layout {
    /// Bodies.
    nb: usize,
    /// Constraint equations (joints and drivers).
    m: usize,
    /// (first row, rows) of each joint slot (removed joints: no rows).
    joints: std::sync::Arc<[(usize, usize)]>,
    /// Row of the first driver.
    drivers0: usize,
    /// Drivers.
    nd: usize,
}

impl Default for Layout {
    /// The layout of an empty model.
    fn default() -> Self {
        Self {
            nb: 0,
            m: 0,
            joints: Vec::new().into(),
            drivers0: 0,
            nd: 0,
        }
    }
}

impl Layout {
    /// Position coordinates per body: r (3, m) and Euler parameters p (4).
    pub const Q_PER_BODY: usize = 7;
    /// Velocity coordinates per body: v (3, m/s) and body-frame ω' (3, rad/s).
    pub const W_PER_BODY: usize = 6;

    /// The layout of a model.
    pub fn of(model: &Mechanism) -> Self {
        let mut joints = Vec::new();
        let mut k = 0;
        let mut slot = 0;
        for (h, j) in model.joints() {
            while slot < h.index() {
                joints.push((k, 0));
                slot += 1;
            }
            let n: usize = j.primitives().iter().map(|p| p.len()).sum();
            joints.push((k, n));
            k += n;
            slot += 1;
        }
        let nd = model
            .drivers()
            .filter(|(_, d)| model.joint(d.joint).is_some())
            .count();
        Self {
            nb: model.bodies().len(),
            m: k + nd,
            joints: joints.into(),
            drivers0: k,
            nd,
        }
    }

    /// Number of bodies.
    pub fn bodies(&self) -> usize {
        self.nb
    }
    /// Number of scalar constraint equations (joints and drivers; not the Euler-parameter
    /// normalisations): the length of a λ vector.
    pub fn constraints(&self) -> usize {
        self.m
    }
    /// Number of drivers (whose joints are present).
    pub fn drivers(&self) -> usize {
        self.nd
    }

    /// Range of body `h`'s positions (r, p) in a q vector (and in the DAE unknowns y).
    pub fn body_q(&self, h: BodyHandle) -> Range<usize> {
        let o = Self::Q_PER_BODY * h.index();
        o..o + Self::Q_PER_BODY
    }
    /// Position (m, base frame) of body `h`'s centre of mass read from a vector that starts
    /// with the positions q: a q vector, or the unknowns y of [`MultibodyDae`](super::MultibodyDae) or of the
    /// explicit [`MultibodyOde`](super::MultibodyOde).
    pub fn position_of(q: &[f64], h: BodyHandle) -> [f64; 3] {
        let o = Self::Q_PER_BODY * h.index();
        [q[o], q[o + 1], q[o + 2]]
    }
    /// Range of body `h`'s velocities (v, ω') in a w vector.
    pub fn body_w(&self, h: BodyHandle) -> Range<usize> {
        let o = Self::W_PER_BODY * h.index();
        o..o + Self::W_PER_BODY
    }
    /// Range of joint `h`'s constraint multipliers in a λ vector (empty for a removed
    /// joint or a handle of another model).
    pub fn joint_lambda(&self, h: JointHandle) -> Range<usize> {
        let (o, n) = self.joints.get(h.index()).copied().unwrap_or((0, 0));
        o..o + n
    }
    /// Index of driver `h`'s multiplier in a λ vector (`None` for a handle of another model).
    pub fn driver_lambda(&self, h: DriverHandle) -> Option<usize> {
        (h.index() < self.nd).then_some(self.drivers0 + h.index())
    }
    /// Length of a q vector.
    pub fn q_len(&self) -> usize {
        Self::Q_PER_BODY * self.nb
    }
    /// Length of a w vector.
    pub fn w_len(&self) -> usize {
        Self::W_PER_BODY * self.nb
    }
    /// Range of the positions q in the DAE unknowns y.
    pub fn y_q(&self) -> Range<usize> {
        0..self.q_len()
    }
    /// Range of the velocities w in the DAE unknowns y.
    pub fn y_w(&self) -> Range<usize> {
        self.q_len()..self.q_len() + self.w_len()
    }
    /// Range of the constraint forces λ in the DAE unknowns y.
    pub fn y_lambda(&self) -> Range<usize> {
        self.lambda()..self.lambda() + self.m
    }
    /// Offset of body b's position coordinates (r, p) in y.
    pub fn q(&self, b: usize) -> usize {
        Self::Q_PER_BODY * b
    }
    /// Offset of body b's velocities (v, ω') in y.
    pub fn w(&self, b: usize) -> usize {
        self.q_len() + Self::W_PER_BODY * b
    }
    /// Offset of the constraint forces λ in y.
    pub fn lambda(&self) -> usize {
        self.q_len() + self.w_len()
    }
    /// Offset of the stabilisation multipliers μ in y.
    pub fn mu(&self) -> usize {
        self.lambda() + self.m
    }
    /// Offset of the normalisation multipliers ν in y.
    pub fn nu(&self) -> usize {
        self.lambda() + 2 * self.m
    }
    /// Total number of unknowns of the DAE.
    pub fn dim(&self) -> usize {
        // (q, w, λ, μ, ν): one normalisation multiplier ν per body.
        self.nu() + self.nb
    }
}
