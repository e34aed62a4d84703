//! Applied forces: gravity (a model setting), point forces and torques, spring-dampers, and
//! the [`ForceElement`] interface that contact and clearance models implement.

use super::body::{Attach, BodyHandle};
use nalgebra::{Matrix3, Vector3, Vector4};
use std::fmt::Debug;
use std::sync::Arc;

/// Kinematic state of one body as force elements see it.
#[derive(Debug, Clone, Copy)]
pub struct BodyState {
    /// Centre-of-mass position, m.
    pub r: Vector3<f64>,
    /// Euler parameters.
    pub p: Vector4<f64>,
    /// Rotation matrix (body → base).
    pub a: Matrix3<f64>,
    /// Centre-of-mass velocity, m/s.
    pub v: Vector3<f64>,
    /// Angular velocity in the body frame, rad/s.
    pub omega: Vector3<f64>,
}

impl BodyState {
    /// The ground: at rest at the origin.
    pub fn ground() -> Self {
        Self {
            r: Vector3::zeros(),
            p: Vector4::new(1.0, 0.0, 0.0, 0.0),
            a: Matrix3::identity(),
            v: Vector3::zeros(),
            omega: Vector3::zeros(),
        }
    }
    /// Position of a body-fixed point s' (m, body frame) in the base frame.
    pub fn point(&self, s: &Vector3<f64>) -> Vector3<f64> {
        self.r + self.a * s
    }
    /// Velocity of a body-fixed point s' in the base frame, m/s.
    pub fn point_velocity(&self, s: &Vector3<f64>) -> Vector3<f64> {
        self.v + self.a * self.omega.cross(s)
    }
}

/// Generalised load on one body: a force through the centre of mass (base frame, N) and a
/// torque (body frame, N·m).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodyLoad {
    /// Force, N (base frame).
    pub force: Vector3<f64>,
    /// Torque, N·m (body frame).
    pub torque: Vector3<f64>,
}

impl BodyLoad {
    /// Adds a force `f` (base frame) applied at body point s' (body frame).
    pub fn add_force_at(&mut self, state: &BodyState, s: &Vector3<f64>, f: &Vector3<f64>) {
        self.force += f;
        self.torque += s.cross(&(state.a.transpose() * f));
    }
}

/// A force element: computes loads on the bodies it acts on from their states.
///
/// `bodies` lists every body whose state the element reads or loads: it declares the
/// coupling for the sparse Jacobian pattern. It is read once, when the equations of motion
/// are built ([`MultibodyDae`](super::MultibodyDae)), and must not change afterwards.
pub trait ForceElement: std::any::Any + Debug + Send + Sync {
    /// Name, used in reports.
    fn name(&self) -> &str;
    /// Bodies read or loaded.
    fn bodies(&self) -> Vec<BodyHandle>;
    /// Adds this element's loads at time `t` (s). `states[b]` and `loads[b]` are indexed by
    /// body index.
    fn apply(&self, t: f64, states: &[BodyState], loads: &mut [BodyLoad]);
    /// Exact derivatives of this element's loads at time `t`, if it provides them: **appends**
    /// its blocks to `out` and returns `true`; an element whose loads vanish (a contact that
    /// is open) returns `true` and appends nothing. Returning `false` (the default) lets the
    /// formulation difference [`apply`](Self::apply) instead; the element then appends
    /// nothing. An implementation only pushes: it neither clears `out` nor reads or changes
    /// what is already there (the formulation reuses one buffer for every element, so that
    /// the step loop allocates nothing). Every block's `loaded` and `wrt` must be among
    /// [`bodies`](Self::bodies).
    fn load_jacobian(&self, _t: f64, _states: &[BodyState], _out: &mut Vec<LoadDerivative>) -> bool {
        false
    }

    /// [`load_jacobian`](Self::load_jacobian) for a system at rest (static equilibria): only
    /// the derivatives with respect to positions (the first 7 columns of each block) are
    /// read; an element may leave the velocity columns zero and skip their work. Default:
    /// `load_jacobian`.
    fn load_jacobian_at_rest(&self, t: f64, states: &[BodyState], out: &mut Vec<LoadDerivative>) -> bool {
        self.load_jacobian(t, states, out)
    }
}

/// ∂(force, body-frame torque) on body `loaded` with respect to the state (r, p, v, ω') of
/// body `wrt`: rows force x, y, z (N), torque x', y', z' (N·m); columns r (3), p (4), v (3),
/// ω' (3).
#[derive(Debug, Clone, PartialEq)]
pub struct LoadDerivative {
    /// Body whose load is differentiated.
    pub loaded: BodyHandle,
    /// Body whose state varies.
    pub wrt: BodyHandle,
    /// The 6 × 13 block.
    pub d: nalgebra::SMatrix<f64, 6, 13>,
}

/// The state of a side (the ground is at rest at the origin).
pub(crate) fn state_of(states: &[BodyState], a: Attach) -> BodyState {
    match a {
        Attach::Ground => BodyState::ground(),
        Attach::Body(h) => states[h.0],
    }
}

/// A force f(t) (base frame, N) applied at a body point s' (body frame, m).
#[derive(Clone)]
pub struct PointForce {
    /// Name.
    pub name: String,
    /// Body.
    pub body: BodyHandle,
    /// Application point, body frame, m.
    pub point: Vector3<f64>,
    /// Force as a function of time, N (base frame).
    pub force: Arc<dyn Fn(f64) -> Vector3<f64> + Send + Sync>,
}

impl Debug for PointForce {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "PointForce({} on body {})", self.name, self.body.0)
    }
}

impl ForceElement for PointForce {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.body]
    }
    fn apply(&self, t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let f = (self.force)(t);
        loads[self.body.0].add_force_at(&states[self.body.0], &self.point, &f);
    }
}

/// A torque τ(t) (base frame, N·m) on a body.
#[derive(Clone)]
pub struct Torque {
    /// Name.
    pub name: String,
    /// Body.
    pub body: BodyHandle,
    /// Torque as a function of time, N·m (base frame).
    pub torque: Arc<dyn Fn(f64) -> Vector3<f64> + Send + Sync>,
}

impl Debug for Torque {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Torque({} on body {})", self.name, self.body.0)
    }
}

impl ForceElement for Torque {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.body]
    }
    fn apply(&self, t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let s = &states[self.body.0];
        loads[self.body.0].torque += s.a.transpose() * (self.torque)(t);
    }
}

/// A linear spring-damper between two points: tension k·(l − l0) + c·l̇ along the line.
#[derive(Debug, Clone)]
pub struct SpringDamper {
    /// Name.
    pub name: String,
    /// Side i and its point (body frame, m).
    pub i: (Attach, Vector3<f64>),
    /// Side j and its point (body frame, m).
    pub j: (Attach, Vector3<f64>),
    /// Stiffness, N/m.
    pub stiffness: f64,
    /// Damping, N·s/m.
    pub damping: f64,
    /// Free length, m.
    pub free_length: f64,
}

impl ForceElement for SpringDamper {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        [self.i.0, self.j.0]
            .into_iter()
            .filter_map(Attach::body)
            .collect()
    }
    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let (si, sj) = (state_of(states, self.i.0), state_of(states, self.j.0));
        let d = sj.point(&self.j.1) - si.point(&self.i.1);
        let l = d.norm();
        if l < 1e-15 {
            return;
        }
        let n = d / l;
        let ld = n.dot(&(sj.point_velocity(&self.j.1) - si.point_velocity(&self.i.1)));
        let tension = self.stiffness * (l - self.free_length) + self.damping * ld;
        let f = tension * n; // pulls i towards j
        if let Attach::Body(h) = self.i.0 {
            loads[h.0].add_force_at(&si, &self.i.1, &f);
        }
        if let Attach::Body(h) = self.j.0 {
            loads[h.0].add_force_at(&sj, &self.j.1, &(-f));
        }
    }
}

/// The rotation of side j relative to side i about an axis fixed in side i, as rotational
/// force elements see it.
///
/// The angle is measured between a reference direction fixed in side i (`reference_i`,
/// perpendicular to the axis) and one fixed in side j (`reference_j`), projected on the
/// plane normal to the axis: θ = atan2(u·(x_i × x_j), x_i·x_j) ∈ (−π, π], zero in the
/// configuration the element was built in ([`RelativeRotation::from_initial_poses`]). The
/// rate is the axial component of the relative angular velocity, θ̇ = u·(ω_j − ω_i) (base
/// frame): exactly dθ/dt while the two sides turn about the common axis (e.g. both on
/// revolute joints about it), a first-order approximation otherwise.
#[derive(Debug, Clone, PartialEq)]
pub struct RelativeRotation {
    /// Side i (the axis and the angle's zero are fixed in it).
    pub i: Attach,
    /// Side j.
    pub j: Attach,
    /// Unit axis in side i's body frame.
    pub axis_i: Vector3<f64>,
    /// Unit reference direction in side i's body frame, perpendicular to the axis.
    pub reference_i: Vector3<f64>,
    /// Unit reference direction in side j's body frame (equal to `reference_i` in the build
    /// configuration).
    pub reference_j: Vector3<f64>,
}

impl RelativeRotation {
    /// From the two sides' initial poses in `mech` (their `position`/`orientation`) and a
    /// base-frame `axis`: θ = 0 in that configuration. `None` if a body handle does not exist
    /// or the axis is zero or not finite.
    pub fn from_initial_poses(
        mech: &super::Mechanism,
        i: Attach,
        j: Attach,
        axis: Vector3<f64>,
    ) -> Option<Self> {
        let norm = axis.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return None;
        }
        let u = axis / norm;
        let rot = |a: Attach| -> Option<Matrix3<f64>> {
            match a {
                Attach::Ground => Some(Matrix3::identity()),
                Attach::Body(h) => mech
                    .body(h)
                    .map(|b| super::rotation::rotation(&b.orientation.normalize())),
            }
        };
        let (ai, aj) = (rot(i)?, rot(j)?);
        // Any direction perpendicular to the axis.
        let helper = if u.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let x = (helper - u * helper.dot(&u)).normalize();
        Some(Self {
            i,
            j,
            axis_i: ai.transpose() * u,
            reference_i: ai.transpose() * x,
            reference_j: aj.transpose() * x,
        })
    }

    /// Bodies involved (not the ground).
    pub fn bodies(&self) -> Vec<BodyHandle> {
        [self.i, self.j].into_iter().filter_map(Attach::body).collect()
    }

    /// (θ, θ̇, u): the angle (rad), its rate (rad/s) and the axis in the base frame.
    pub fn evaluate(&self, states: &[BodyState]) -> (f64, f64, Vector3<f64>) {
        let (si, sj) = (state_of(states, self.i), state_of(states, self.j));
        let u = si.a * self.axis_i;
        let xi = si.a * self.reference_i;
        let xj = sj.a * self.reference_j;
        let theta = u.dot(&xi.cross(&xj)).atan2(xi.dot(&xj));
        let rate = u.dot(&(sj.a * sj.omega - si.a * si.omega));
        (theta, rate, u)
    }

    /// Applies a torque `tau` (N·m) about the axis u on side j, and −`tau` on side i.
    pub fn apply_torque(&self, states: &[BodyState], loads: &mut [BodyLoad], u: &Vector3<f64>, tau: f64) {
        if let Attach::Body(h) = self.j {
            loads[h.0].torque += states[h.0].a.transpose() * (u * tau);
        }
        if let Attach::Body(h) = self.i {
            loads[h.0].torque -= states[h.0].a.transpose() * (u * tau);
        }
    }
}

/// A linear torsional spring-damper between two sides about a common axis (e.g. a
/// transmission between a motor rotor and an arm): torque on side j
/// τ = −k·(θ − θ₀) − c·θ̇ about the axis (and −τ on side i), θ and θ̇ as
/// [`RelativeRotation`] defines them.
#[derive(Debug, Clone, PartialEq)]
pub struct RotationalSpringDamper {
    /// Name.
    pub name: String,
    /// The relative rotation it acts on.
    pub rotation: RelativeRotation,
    /// Stiffness k, N·m/rad (≥ 0).
    pub stiffness: f64,
    /// Damping c, N·m·s/rad (≥ 0).
    pub damping: f64,
    /// Free angle θ₀, rad.
    pub free_angle: f64,
}

impl RotationalSpringDamper {
    /// The spring-damper's torque on side j at (θ, θ̇), N·m.
    pub fn torque(&self, theta: f64, rate: f64) -> f64 {
        -self.stiffness * (theta - self.free_angle) - self.damping * rate
    }
}

impl ForceElement for RotationalSpringDamper {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        self.rotation.bodies()
    }
    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let (theta, rate, u) = self.rotation.evaluate(states);
        self.rotation
            .apply_torque(states, loads, &u, self.torque(theta, rate));
    }
}

/// A torque about a common axis given by a law τ(t, θ, θ̇) (N·m on side j, −τ on side i; t in
/// s, θ and θ̇ as [`RelativeRotation`] defines them): joint friction of any form, cogging,
/// drive torques from a controller.
#[derive(Clone)]
pub struct RotationalTorque {
    /// Name.
    pub name: String,
    /// The relative rotation it acts on.
    pub rotation: RelativeRotation,
    /// The law τ(t, θ, θ̇), N·m.
    pub law: Arc<dyn Fn(f64, f64, f64) -> f64 + Send + Sync>,
}

impl Debug for RotationalTorque {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "RotationalTorque({})", self.name)
    }
}

impl ForceElement for RotationalTorque {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        self.rotation.bodies()
    }
    fn apply(&self, t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let (theta, rate, u) = self.rotation.evaluate(states);
        self.rotation
            .apply_torque(states, loads, &u, (self.law)(t, theta, rate));
    }
}

/// The translation of side j relative to side i along an axis fixed in side i, as
/// translational force elements see it: x = u·(p_j − p_i) − x₀ with u the axis, p_i and p_j
/// points fixed in the two sides, x₀ its value in the configuration the element was built in
/// (so x = 0 there); ẋ is its exact rate, (ω_i × u)·(p_j − p_i) + u·(ṗ_j − ṗ_i) (base frame).
#[derive(Debug, Clone, PartialEq)]
pub struct RelativeTranslation {
    /// Side i (the axis is fixed in it).
    pub i: Attach,
    /// Side j.
    pub j: Attach,
    /// Unit axis in side i's body frame.
    pub axis_i: Vector3<f64>,
    /// Point on side i, body frame, m.
    pub point_i: Vector3<f64>,
    /// Point on side j, body frame, m.
    pub point_j: Vector3<f64>,
    /// x₀, m.
    pub offset: f64,
}

impl RelativeTranslation {
    /// From the two sides' initial poses in `mech`, a base-frame `point` on the axis (both
    /// sides' points start there) and a base-frame `axis`: x = 0 in that configuration.
    /// `None` if a body handle does not exist or the axis is zero or not finite.
    pub fn from_initial_poses(
        mech: &super::Mechanism,
        i: Attach,
        j: Attach,
        point: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> Option<Self> {
        let norm = axis.norm();
        if !(norm.is_finite() && norm > 0.0) {
            return None;
        }
        let pose = |a: Attach| -> Option<(Vector3<f64>, Matrix3<f64>)> {
            match a {
                Attach::Ground => Some((Vector3::zeros(), Matrix3::identity())),
                Attach::Body(h) => mech
                    .body(h)
                    .map(|b| (b.position, super::rotation::rotation(&b.orientation.normalize()))),
            }
        };
        let ((ri, ai), (rj, aj)) = (pose(i)?, pose(j)?);
        Some(Self {
            i,
            j,
            axis_i: ai.transpose() * (axis / norm),
            point_i: ai.transpose() * (point - ri),
            point_j: aj.transpose() * (point - rj),
            offset: 0.0,
        })
    }

    /// Bodies involved (not the ground).
    pub fn bodies(&self) -> Vec<BodyHandle> {
        [self.i, self.j].into_iter().filter_map(Attach::body).collect()
    }

    /// (x, ẋ, u): the displacement (m), its rate (m/s) and the axis in the base frame.
    pub fn evaluate(&self, states: &[BodyState]) -> (f64, f64, Vector3<f64>) {
        let (si, sj) = (state_of(states, self.i), state_of(states, self.j));
        let u = si.a * self.axis_i;
        let d = sj.point(&self.point_j) - si.point(&self.point_i);
        let dd = sj.point_velocity(&self.point_j) - si.point_velocity(&self.point_i);
        let omega_i = si.a * si.omega;
        let x = u.dot(&d) - self.offset;
        let rate = omega_i.cross(&u).dot(&d) + u.dot(&dd);
        (x, rate, u)
    }

    /// Applies a force `f` (N) along the axis u on side j at its point, and −`f` on side i at
    /// its point.
    pub fn apply_force(&self, states: &[BodyState], loads: &mut [BodyLoad], u: &Vector3<f64>, f: f64) {
        let force = u * f;
        if let Attach::Body(h) = self.j {
            loads[h.0].add_force_at(&states[h.0], &self.point_j, &force);
        }
        if let Attach::Body(h) = self.i {
            loads[h.0].add_force_at(&states[h.0], &self.point_i, &(-force));
        }
    }
}

/// A force along a common axis given by a law F(t, x, ẋ) (N on side j along the axis, −F on
/// side i; t in s, x and ẋ as [`RelativeTranslation`] defines them): friction in a prismatic
/// joint, a force-commanded linear drive.
#[derive(Clone)]
pub struct TranslationalForce {
    /// Name.
    pub name: String,
    /// The relative translation it acts on.
    pub translation: RelativeTranslation,
    /// The law F(t, x, ẋ), N.
    pub law: Arc<dyn Fn(f64, f64, f64) -> f64 + Send + Sync>,
}

impl Debug for TranslationalForce {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "TranslationalForce({})", self.name)
    }
}

impl ForceElement for TranslationalForce {
    fn name(&self) -> &str {
        &self.name
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        self.translation.bodies()
    }
    fn apply(&self, t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let (x, rate, u) = self.translation.evaluate(states);
        self.translation
            .apply_force(states, loads, &u, (self.law)(t, x, rate));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::rotation::{from_axis_angle, rotation};
    use crate::multibody::{Mechanism, RigidBody};

    /// Body j turned by θ about the axis relative to body i, spinning at θ̇: the spring-damper
    /// puts −k·θ − c·θ̇ on j and the opposite on i, about the axis.
    #[test]
    fn rotational_spring_damper_torque_and_sign() {
        let mut mech = Mechanism::new();
        let axis = Vector3::new(1.0, 2.0, -0.5).normalize();
        let i = mech.add_body(RigidBody::new("i", 1.0, Matrix3::identity()));
        let j = mech.add_body(RigidBody::new("j", 1.0, Matrix3::identity()));
        let rel =
            RelativeRotation::from_initial_poses(&mech, Attach::Body(i), Attach::Body(j), axis).unwrap();
        let (k, c, theta, rate) = (200.0, 3.0, 0.3, -0.7);
        let e = RotationalSpringDamper {
            name: "s".into(),
            rotation: rel.clone(),
            stiffness: k,
            damping: c,
            free_angle: 0.05,
        };
        let aj = rotation(&from_axis_angle(&axis, theta));
        let mut sj = BodyState::ground();
        sj.a = aj;
        sj.omega = aj.transpose() * (axis * rate);
        let states = [BodyState::ground(), sj];
        let (th, r, u) = rel.evaluate(&states);
        assert!((th - theta).abs() < 1e-12 && (r - rate).abs() < 1e-12 && (u - axis).norm() < 1e-12);
        let mut loads = [BodyLoad::default(); 2];
        e.apply(0.0, &states, &mut loads);
        let expected = -k * (theta - 0.05) - c * rate;
        assert!(
            (aj * loads[1].torque - axis * expected).norm() < 1e-9,
            "{:?}",
            loads[1]
        );
        assert!((loads[0].torque + axis * expected).norm() < 1e-9);
        assert!(loads[0].force == Vector3::zeros() && loads[1].force == Vector3::zeros());
    }
}
