//! The data of a mechanism (MuJoCo's `mjData` beside the model's `mjModel`): its state
//! (t, q, w, ẇ, λ) and the scratch the analyses need, plus typed access to the state by
//! handle. [`Snapshot`], [`Sample`] and [`MechanismData`] share the same accessors.
//!
//! # Driver efforts: sign convention
//! A driver's constraint is Φ_d = θ(q) − θ_d(t) (θ the driven joint coordinate: the rotation
//! of side j relative to side i about the joint axis, rad, or the translation of side j
//! relative to side i along it, m), so ∂Φ_d/∂θ = 1 and the constraint force on the bodies is
//! −Bᵀλ_d. The **effort** `driver_effort(h) = −λ_d` is therefore the generalized force the
//! driver applies on the joint coordinate: the torque (N·m) or force (N) acting on side j
//! (and its opposite on side i), positive when it acts towards increasing θ.

use super::analysis::{joint_reaction, Reaction, Snapshot};
use super::body::{Attach, BodyHandle};
use super::drivers::MotionLaw;
use super::error::ModelError;
use super::evaluator::Evaluator;
use super::joints::JointHandle;
use super::layout::Layout;
use super::model::{DriverHandle, MarkerHandle, Mechanism};
use super::rotation::rotation;
use super::simulation::Sample;
use nalgebra::{Matrix3, Vector3, Vector4};
use std::sync::Arc;

/// State and scratch of one mechanism: what changes while the model ([`Mechanism`]) stays
/// constant. Made from a complete model ([`MechanismData::new`]); make a new one after
/// changing the model (the analyses refuse stale data with [`ModelError::StaleData`]). The analyses ([`Analysis`](super::Analysis)) fill it; the typed
/// accessors read it.
#[derive(Debug, Clone)]
pub struct MechanismData {
    /// Time, s.
    pub t: f64,
    /// Positions (r, p) per body (see [`Layout::body_q`]).
    pub q: Vec<f64>,
    /// Velocities (v, ω') per body (see [`Layout::body_w`]).
    pub w: Vec<f64>,
    /// Accelerations (v̇, ω̇') per body (see [`Layout::body_w`]).
    pub wdot: Vec<f64>,
    /// Constraint multipliers λ (joints, then drivers; see [`Layout::joint_lambda`]).
    pub lambda: Vec<f64>,
    /// Compiled constraints and evaluation scratch.
    pub(crate) ev: Evaluator,
    /// The [`Mechanism::version`] this data was made for.
    pub(crate) model_version: u64,
    /// The LU of the velocity Jacobian B that the last [`Analysis::state_at`](super::Analysis::state_at)
    /// factorised, with the time and positions it holds at (the driver mass matrix at that
    /// state, and a velocity analysis at the same positions, solve with it again).
    pub(crate) velocity_lu: Option<VelocityLu>,
    /// The LU of the assembly Jacobian that the last position assembly ended with: the next
    /// assembly (the next sample along a trajectory, or the same sample with the drivers
    /// moved a little) starts with chord steps on it ([`Analysis::assemble`](super::Analysis::assemble)).
    pub(crate) position_lu: Option<crate::sparse::DenseLu>,
}

/// An LU of the velocity Jacobian B(q, t) and the (t, q) it was factorised at.
#[derive(Debug, Clone)]
pub(crate) struct VelocityLu {
    /// Time, s.
    pub t: f64,
    /// Positions.
    pub q: Vec<f64>,
    /// The factors.
    pub lu: crate::sparse::DenseLu,
}

impl MechanismData {
    /// Data for `model`: t = 0, the model's initial poses and velocities (not yet assembled),
    /// zero accelerations and multipliers, and the model's driver laws.
    pub fn new(model: &Mechanism) -> Self {
        let ev = Evaluator::new(model);
        let (q, w) = model.initial_guess();
        Self {
            t: 0.0,
            wdot: vec![0.0; w.len()],
            lambda: vec![0.0; ev.layout.constraints()],
            q,
            w,
            ev,
            model_version: model.version(),
            velocity_lu: None,
            position_lu: None,
        }
    }

    /// The index layout of the state vectors.
    pub fn layout(&self) -> &Layout {
        &self.ev.layout
    }

    /// The current state as a snapshot.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            t: self.t,
            q: self.q.clone(),
            w: self.w.clone(),
            wdot: self.wdot.clone(),
            lambda: self.lambda.clone(),
        }
    }

    /// Stores a snapshot as the current state.
    pub fn store(&mut self, s: &Snapshot) {
        self.t = s.t;
        self.q.clone_from(&s.q);
        self.w.clone_from(&s.w);
        self.wdot.clone_from(&s.wdot);
        self.lambda.clone_from(&s.lambda);
    }

    /// Replaces the motion law of driver `h` for the analyses on this data (the model keeps
    /// its own law). E.g. inverse dynamics along measured joint motion.
    pub fn set_driver_law(&mut self, h: DriverHandle, law: MotionLaw) -> Result<(), ModelError> {
        *self.driver_law_mut(h)? = law;
        Ok(())
    }

    /// Prescribes driver `h`'s coordinate as the local quadratic about `t0` with value `x`
    /// (rad or m), rate `v` and acceleration `a`: θ_d(t) = x + v·(t − t0) + ½a·(t − t0)². For
    /// an inverse-dynamics evaluation at t0 with given joint positions, rates and
    /// accelerations.
    pub fn prescribe_driver(
        &mut self,
        h: DriverHandle,
        t0: f64,
        [x, v, a]: [f64; 3],
    ) -> Result<(), ModelError> {
        self.set_driver_law(
            h,
            MotionLaw::Custom(Arc::new(move |t| {
                let dt = t - t0;
                [x + v * dt + 0.5 * a * dt * dt, v + a * dt, a]
            })),
        )
    }

    fn driver_law_mut(&mut self, h: DriverHandle) -> Result<&mut MotionLaw, ModelError> {
        use super::constraints::Primitive;
        let bad = || ModelError::BadElement {
            kind: "driver",
            name: format!("#{}", h.index()),
            reason: format!("driver handle {} does not exist in this data", h.index()),
        };
        if h.index() >= self.ev.blocks.len() - self.ev.driver_block0 {
            return Err(bad());
        }
        let blk = &mut self.ev.blocks[self.ev.driver_block0 + h.index()];
        // Driver blocks hold Sum([law, −reference]) (see `Mechanism::constraint_blocks`).
        let law = match &mut blk.prim {
            Primitive::Angle { law, .. } => law,
            Primitive::Dot2 { law: Some(law), .. } => law,
            _ => return Err(bad()),
        };
        match law {
            MotionLaw::Sum(v) if !v.is_empty() => Ok(&mut v[0]),
            _ => Err(bad()),
        }
    }

    /// Makes constraint row `row` hold at Φ_row = ε(t) instead of 0 in the analyses on this
    /// data ([`Analysis`](super::Analysis): assembly, velocities, accelerations, inverse
    /// dynamics), ε the local quadratic about `t0` with value `x`, rate `v` and acceleration
    /// `a`: a joint that sits, or moves, off its nominal — a joint in its play, say. Units are
    /// the row's: for a joint's point-coincidence rows ([`Layout::joint_lambda`], rows 0–2 of
    /// a spherical, universal or revolute joint) ε is the side-j point's displacement from the
    /// side-i point along base x, y, z (m); for a universal joint's perpendicularity row (row
    /// 3) ε = −φ, φ a rotation of side j about z_i × z_j (rad) — the convention of
    /// [`Analysis::constraint_offset_sensitivity`](super::Analysis::constraint_offset_sensitivity).
    /// Every offset shares the last `t0` given. The data's model is not changed.
    pub fn set_constraint_offset(
        &mut self,
        row: usize,
        t0: f64,
        [x, v, a]: [f64; 3],
    ) -> Result<(), ModelError> {
        let n = self.ev.layout.constraints();
        if row >= n {
            return Err(ModelError::Output(format!(
                "constraint row {row} out of range ({n} constraint equations)"
            )));
        }
        if self.ev.offsets.len() != n {
            self.ev.offsets = vec![[0.0; 3]; n];
        }
        self.ev.offsets[row] = [x, v, a];
        self.ev.offset_t0 = t0;
        Ok(())
    }

    /// Removes every constraint offset ([`set_constraint_offset`](Self::set_constraint_offset)).
    pub fn clear_constraint_offsets(&mut self) {
        self.ev.offsets.clear();
    }

    /// The reaction of joint `h` on its side-j body at the current state (at the joint
    /// origin, base frame); `None` for a removed joint.
    pub fn reaction(&self, model: &Mechanism, h: JointHandle) -> Option<Reaction> {
        reaction_at(model, &self.ev.layout, h, self.t, &self.q, &self.lambda)
    }

    /// The effort of driver `h` at the current state: torque (N·m) or force (N) it applies on
    /// its joint coordinate (see the module docs for the sign).
    pub fn driver_effort(&self, h: DriverHandle) -> Option<f64> {
        effort(&self.ev.layout, &self.lambda, h)
    }

    /// Acceleration (m/s², base frame) of the material point at `s_local` (m, body frame) of
    /// `side` at the current state's positions, velocities and accelerations:
    /// v̇ + A·(ω̇′ × s′ + ω′ × (ω′ × s′)). Zero on the ground; `None` if the body is not one of
    /// this data's.
    pub fn point_acceleration(&self, side: Attach, s_local: &Vector3<f64>) -> Option<Vector3<f64>> {
        let Attach::Body(h) = side else {
            return Some(Vector3::zeros());
        };
        let (iq, iw) = (Layout::Q_PER_BODY * h.index(), Layout::W_PER_BODY * h.index());
        if self.q.len() < iq + Layout::Q_PER_BODY
            || self.w.len() < iw + Layout::W_PER_BODY
            || self.wdot.len() < iw + Layout::W_PER_BODY
        {
            return None;
        }
        let vec = |x: &[f64], at: usize| Vector3::from_column_slice(&x[at..at + 3]);
        let (om, om_dot) = (vec(&self.w, iw + 3), vec(&self.wdot, iw + 3));
        let local = om_dot.cross(s_local) + om.cross(&om.cross(s_local));
        Some(vec(&self.wdot, iw) + self.body_rotation(h) * local)
    }
}

fn reaction_at(
    model: &Mechanism,
    lay: &Layout,
    h: JointHandle,
    t: f64,
    q: &[f64],
    lambda: &[f64],
) -> Option<Reaction> {
    let j = model.joint(h)?;
    let k0 = lay.joint_lambda(h).start;
    (lambda.len() >= lay.constraints() && q.len() >= lay.q_len())
        .then(|| joint_reaction(j, k0, t, q, lambda).0)
}

fn effort(lay: &Layout, lambda: &[f64], h: DriverHandle) -> Option<f64> {
    lay.driver_lambda(h).and_then(|k| lambda.get(k)).map(|l| -l)
}

fn q_of(q: &[f64], h: BodyHandle) -> &[f64] {
    let r = Layout::Q_PER_BODY * h.index();
    &q[r..r + Layout::Q_PER_BODY]
}

fn w_of(w: &[f64], h: BodyHandle) -> &[f64] {
    let r = Layout::W_PER_BODY * h.index();
    &w[r..r + Layout::W_PER_BODY]
}

/// Typed accessors on a state with fields `t`, `q`, `w`, `lambda`.
macro_rules! state_accessors {
    ($ty:ty) => {
        impl $ty {
            /// Position of body `h`'s centre of mass, m (base frame). Panics if `h` is not a
            /// body of this state's model.
            pub fn body_position(&self, h: BodyHandle) -> Vector3<f64> {
                Vector3::from_column_slice(&q_of(&self.q, h)[..3])
            }
            /// Euler parameters (e0, e1, e2, e3) of body `h`.
            pub fn body_euler_parameters(&self, h: BodyHandle) -> Vector4<f64> {
                Vector4::from_column_slice(&q_of(&self.q, h)[3..])
            }
            /// Rotation matrix of body `h` (body frame to base frame).
            pub fn body_rotation(&self, h: BodyHandle) -> Matrix3<f64> {
                rotation(&self.body_euler_parameters(h))
            }
            /// Velocity of body `h`'s centre of mass, m/s (base frame).
            pub fn body_velocity(&self, h: BodyHandle) -> Vector3<f64> {
                Vector3::from_column_slice(&w_of(&self.w, h)[..3])
            }
            /// Angular velocity of body `h`, rad/s, in the body frame (ω').
            pub fn body_angular_velocity(&self, h: BodyHandle) -> Vector3<f64> {
                Vector3::from_column_slice(&w_of(&self.w, h)[3..])
            }
            /// Position (m), axes (columns, base frame) and velocity (m/s) of marker `m`;
            /// `None` if the marker does not exist.
            pub fn marker_state(
                &self,
                model: &Mechanism,
                m: MarkerHandle,
            ) -> Option<(Vector3<f64>, Matrix3<f64>, Vector3<f64>)> {
                let mk = model.marker(m)?;
                Some(match mk.attach {
                    Attach::Ground => (mk.frame.origin, mk.frame.axes, Vector3::zeros()),
                    Attach::Body(h) => {
                        let r = self.body_position(h);
                        let a = self.body_rotation(h);
                        let v = self.body_velocity(h);
                        let om = self.body_angular_velocity(h);
                        (
                            r + a * mk.frame.origin,
                            a * mk.frame.axes,
                            v + a * om.cross(&mk.frame.origin),
                        )
                    }
                })
            }
            /// Multipliers of joint `h` (empty for a removed joint).
            pub fn joint_lambda(&self, model: &Mechanism, h: JointHandle) -> &[f64] {
                &self.lambda[model.layout().joint_lambda(h)]
            }
        }
    };
}

state_accessors!(Snapshot);
state_accessors!(Sample);
state_accessors!(MechanismData);

/// Reactions and efforts of states that carry no layout.
macro_rules! force_accessors {
    ($ty:ty) => {
        impl $ty {
            /// The reaction of joint `h` of `model` on its side-j body (at the joint origin,
            /// base frame); `None` for a removed joint.
            pub fn reaction(&self, model: &Mechanism, h: JointHandle) -> Option<Reaction> {
                reaction_at(model, model.layout(), h, self.t, &self.q, &self.lambda)
            }
            /// The effort of driver `h` of `model`: torque (N·m) or force (N) it applies on
            /// its joint coordinate, positive towards increasing coordinate (see
            /// [`data`](crate::multibody::data) for the convention).
            pub fn driver_effort(&self, model: &Mechanism, h: DriverHandle) -> Option<f64> {
                effort(model.layout(), &self.lambda, h)
            }
        }
    };
}

force_accessors!(Snapshot);
force_accessors!(Sample);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::body::RigidBody;
    use approx::assert_relative_eq;

    /// A point of a turning body accelerates by v̇ + A·(ω̇′ × s′ + ω′ × (ω′ × s′)): checked
    /// on a body turned a quarter turn about z (A maps body x to base y), spinning at 2 rad/s
    /// about its z and speeding up at 3 rad/s², its centre accelerating at (1, 0, 0) m/s².
    #[test]
    fn a_body_points_acceleration_carries_the_spin_and_its_rate() {
        let mut m = Mechanism::new();
        let h = m.add_body(RigidBody::new("b", 1.0, nalgebra::Matrix3::identity()));
        let mut d = MechanismData::new(&m);
        let half = std::f64::consts::FRAC_1_SQRT_2;
        d.q[..7].copy_from_slice(&[0.0, 0.0, 0.0, half, 0.0, 0.0, half]);
        d.w[..6].copy_from_slice(&[0.0, 0.0, 0.0, 0.0, 0.0, 2.0]);
        d.wdot[..6].copy_from_slice(&[1.0, 0.0, 0.0, 0.0, 0.0, 3.0]);
        let a = d
            .point_acceleration(Attach::Body(h), &Vector3::new(0.5, 0.0, 0.0))
            .unwrap();
        // In the body frame: ω̇′ × s′ = (0, 1.5, 0), ω′ × (ω′ × s′) = (−2, 0, 0); turned to
        // base: (−1.5, −2, 0).
        assert_relative_eq!(a, Vector3::new(1.0 - 1.5, -2.0, 0.0), epsilon = 1e-12);
        assert_eq!(
            d.point_acceleration(Attach::Ground, &Vector3::x()),
            Some(Vector3::zeros())
        );
    }
}
