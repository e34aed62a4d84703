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

use super::clearance::{
    bearing_design, clearance_model, clearance_model_per_joint, ClearanceModel, JointClearances,
    DEFAULT_DAMPING, UNIVERSAL_JOINTS,
};
use super::geometry::{Geometry, MassProperties};
use super::ideal::{ideal_model, EquilibriumError, LinkSpec, Mr2120Error, ELBOW_JOINTS, PLATFORM_JOINTS};
use super::kinematics::inverse;
use super::paper::{ClearanceSet, Table2Point, TABLE1, TABLE3};
use super::trajectory::{clearance_options, pose_errors};
use crate::contact::play::UniversalPlay;
use crate::contact::play_bound::{play_pose_error, play_pose_errors_per_joint, JointPlay, PlayPoseError};
use crate::multibody::forces::{BodyLoad, BodyState, ForceElement};
use crate::multibody::{AssemblyOptions, ModelError};
use crate::multibody::{BodyHandle, MotionLaw, Simulation, Statics, StaticsOptions};
use nalgebra::{Matrix3, Vector3};
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

fn widen(r: &mut Ranges, e: &[f64; 6]) {
    for k in 0..6 {
        r[k].0 = r[k].0.min(e[k]);
        r[k].1 = r[k].1.max(e[k]);
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
    let mut model = locked_clearance_model(g, mp, point, set)?;
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
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); 6];
    for s in &traj.samples {
        widen(&mut r, &pose_errors(s, platform, &m));
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

/// Method of the accuracy study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// (a) dynamic excitation, the paper's method.
    Dynamic,
    /// (b) envelope of quasi-static equilibria under a set of loads, each solved directly
    /// ([`crate::multibody::static_equilibrium`]).
    Static,
    /// (b) by dynamic relaxation: the same equilibria found by integrating heavily damped
    /// motion until it dies out (lash's earlier route, kept as a cross-check and as the
    /// benchmark's baseline).
    Relaxation,
    /// (c) the same load cases to first order in the clearances, the ideal model's joint
    /// reactions pushing each joint across its play ([`linear_envelope`]); contact
    /// elasticity left out.
    Linear,
}

/// A method name that is neither "dynamic" nor "static".
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method '{0}'; expected dynamic, static, relaxation or linear")]
pub struct UnknownMethod(pub String);

impl std::str::FromStr for Method {
    type Err = UnknownMethod;
    /// "dynamic", "static", "relaxation" or "linear" (the names it serialises as).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "dynamic" => Ok(Method::Dynamic),
            "static" => Ok(Method::Static),
            "relaxation" => Ok(Method::Relaxation),
            "linear" => Ok(Method::Linear),
            other => Err(UnknownMethod(other.into())),
        }
    }
}

/// The given methods for the given points and sets, beside the paper's Table 3.
#[allow(clippy::too_many_arguments)]
pub fn table3(
    g: &Geometry,
    mp: &MassProperties,
    points: &[Table2Point],
    sets: &[ClearanceSet],
    methods: &[Method],
    ex: &Excitation,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<AccuracyRow>, Mr2120Error> {
    let total = points.len() * sets.len() * methods.len();
    let mut rows = vec![];
    for p in points {
        for s in sets {
            for &method in methods {
                progress(rows.len(), total);
                let (r, steps) = match method {
                    Method::Dynamic => dynamic_envelope(g, mp, p, s, ex)?,
                    Method::Static => static_envelope(g, mp, p, s, ex)?,
                    Method::Relaxation => relaxation_envelope(g, mp, p, s, ex)?,
                    Method::Linear => match linear_envelope(g, mp, p, s, ex) {
                        // No first-order bound at a singular configuration: NaN ranges.
                        Err(Mr2120Error::Model(ModelError::Singular { .. })) => {
                            ([(f64::NAN, f64::NAN); 6], 0)
                        }
                        other => (other?, 0),
                    },
                };
                let conv = |k: usize, v: f64| if k < 3 { v * 1e3 } else { v.to_degrees() };
                let ranges = std::array::from_fn(|k| (conv(k, r[k].0), conv(k, r[k].1)));
                let paper = TABLE3
                    .iter()
                    .find(|t| t.point == p.name && t.set == s.name)
                    .map(|t| t.ranges)
                    .unwrap_or([(f64::NAN, f64::NAN); 6]);
                let method = match method {
                    Method::Dynamic => "dynamic excitation",
                    Method::Static => "quasi-static envelope",
                    Method::Relaxation => "quasi-static envelope (dynamic relaxation)",
                    Method::Linear if r[0].0.is_nan() => {
                        "linearised play envelope: none (singular configuration)"
                    }
                    Method::Linear => "linearised play envelope",
                };
                rows.push(AccuracyRow {
                    point: p.name.into(),
                    set: s.name.into(),
                    method: method.into(),
                    ranges,
                    paper,
                    steps,
                });
            }
        }
    }
    progress(total, total);
    Ok(rows)
}

/// The clearance model (the bearings of `set`, lash's default contact damping) with its
/// drives locked at the angles that put the ideal platform at `point`.
pub fn locked_clearance_model(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
) -> Result<ClearanceModel, Mr2120Error> {
    let m = Vector3::from(point.m);
    let q = inverse(g, m)?;
    clearance_model(
        g,
        mp,
        m,
        Some(q.map(MotionLaw::Constant)),
        &bearing_design(set, DEFAULT_DAMPING),
    )
}

/// The 13 load cases of method (b): none, then a force of `ex.force` along +x, −x, +y, −y,
/// +z, −z, then a torque of `ex.torque` about the same directions (N, N·m; on the platform).
pub fn static_load_cases(ex: &Excitation) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let mut out = vec![(Vector3::zeros(), Vector3::zeros())];
    for case in 0..12 {
        let mut dir = Vector3::zeros();
        dir[case % 6 / 2] = if case % 2 == 0 { 1.0 } else { -1.0 };
        out.push(if case < 6 {
            (dir * ex.force, Vector3::zeros())
        } else {
            (Vector3::zeros(), dir * ex.torque)
        });
    }
    out
}

/// Method (b): a deterministic envelope of quasi-static equilibria. With the drives locked at
/// q(M), the platform carries in turn the loads of [`static_load_cases`] (none, a force of
/// [`Excitation::force`] along ±x, ±y, ±z, a torque of [`Excitation::torque`] about ±x, ±y,
/// ±z); each equilibrium is solved directly by [`crate::multibody::static_equilibrium`] (pseudo-transient
/// continuation on the contact model, Newton in the limit), the loaded cases warm-started
/// from the unloaded one. The ranges span the 13 equilibria. Returns the ranges and the
/// pseudo-steps taken.
pub fn static_envelope(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
    ex: &Excitation,
) -> Result<(Ranges, usize), Mr2120Error> {
    let model = locked_clearance_model(g, mp, point, set)?;
    equilibria_envelope(model.mechanism, model.platform, point, set.name, ex)
}

/// [`static_envelope`] with its own clearances in each universal joint: the drives locked
/// at q(M), the same load cases and solver. With the clearances of a set in every joint it
/// is [`static_envelope`] for that set.
pub fn static_envelope_per_joint(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    clearances: &JointClearances,
    ex: &Excitation,
) -> Result<(Ranges, usize), Mr2120Error> {
    static_envelope_with(g, mp, point, &clearances.designs(), ex)
}

/// [`static_envelope`] with a bearing design of its own in each universal joint (order of
/// [`UNIVERSAL_JOINTS`]; `None`: an ideal joint) — other bearing dimensions, materials or
/// damping than the MR2120's assumed ones.
pub fn static_envelope_with(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    designs: &[Option<crate::contact::BearingDesign>; 6],
    ex: &Excitation,
) -> Result<(Ranges, usize), Mr2120Error> {
    let m = Vector3::from(point.m);
    let q = inverse(g, m)?;
    let model = clearance_model_per_joint(
        g,
        mp,
        &LinkSpec::nominal(g),
        m,
        Some(q.map(MotionLaw::Constant)),
        designs,
    )?;
    equilibria_envelope(model.mechanism, model.platform, point, "per joint", ex)
}

/// The envelope of the static equilibria of `mechanism` (drives locked) under the load
/// cases: one model whose platform load is set per case, one solver set up for it
/// ([`Statics`]), the loaded cases warm-started from the unloaded one.
fn equilibria_envelope(
    mut mechanism: crate::multibody::Mechanism,
    platform: BodyHandle,
    point: &Table2Point,
    set_name: &str,
    ex: &Excitation,
) -> Result<(Ranges, usize), Mr2120Error> {
    let m = Vector3::from(point.m);
    let load = Arc::new(std::sync::Mutex::new((Vector3::zeros(), Vector3::zeros())));
    mechanism.add_force(Box::new(SharedLoad {
        body: platform,
        load: load.clone(),
    }));
    let mech = Arc::new(mechanism);
    let fail = |case: usize, force: Vector3<f64>, torque: Vector3<f64>, source| {
        Mr2120Error::Equilibrium(Box::new(EquilibriumError {
            point: point.name.into(),
            set: set_name.into(),
            case,
            force: force.into(),
            torque: torque.into(),
            source,
        }))
    };
    let mut statics = Statics::new(&mech, &StaticsOptions::default())
        .map_err(|e| fail(0, Vector3::zeros(), Vector3::zeros(), e))?;
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); 6];
    let mut steps = 0;
    let mut start: Option<Vec<f64>> = None;
    for (case, (force, torque)) in static_load_cases(ex).into_iter().enumerate() {
        if let Ok(mut l) = load.lock() {
            *l = (force, torque);
        }
        let eq = statics
            .solve(0.0, start.as_deref())
            .map_err(|e| fail(case, force, torque, e))?;
        steps += eq.stats.steps;
        widen(&mut r, &pose_errors(&eq.sample, platform, &m));
        if start.is_none() {
            start = Some(eq.sample.q);
        }
    }
    Ok((r, steps))
}

/// Method (c): the envelope of [`static_load_cases`] to first order in the clearances. For
/// each load case the ideal model with the drives locked at q(M) gives the joints' static
/// reactions; each universal joint sits across its play the way its reaction pushes it
/// ([`crate::contact::play`], the bearings of `set`), and the constraint-offset sensitivity
/// carries the shifts to the platform ([`play_pose_error`]). Linear in the clearances; no
/// contact elasticity; unreliable near singular configurations (compare [`static_envelope`]).
pub fn linear_envelope(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
    ex: &Excitation,
) -> Result<Ranges, Mr2120Error> {
    // The joints' contributions at the set's clearances, added ([`linear_per_joint`]: one
    // model, pose and sensitivity for all load cases).
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); 6];
    for case in linear_per_joint(g, mp, point, ex)? {
        let e: [f64; 6] = std::array::from_fn(|c| {
            case.iter()
                .map(|j| set.radial * j.radial[c] + set.axial * j.axial[c])
                .sum()
        });
        widen(&mut r, &e);
    }
    Ok(r)
}

/// Method (c) joint by joint: for each load case of [`static_load_cases`], the platform's
/// pose error per metre of radial clearance and per metre of axial play in each universal
/// joint alone, in the order of [`UNIVERSAL_JOINTS`] (the play geometry of the MR2120's
/// bearings; it does not depend on the clearances). To first order a design with clearances
/// h errs by Σ_k (h_LR,k · radial_k + h_LW,k · axial_k) in each case. Every joint's cross
/// hangs on the model (a design with play in all six joints, as the clearance model has).
pub fn linear_per_joint(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    ex: &Excitation,
) -> Result<Vec<Vec<PlayPoseError>>, Mr2120Error> {
    linear_per_joint_with_crosses(g, mp, point, ex, [true; 6])
}

/// [`linear_per_joint`] with a cross only in the joints `crosses` marks (in the order of
/// [`UNIVERSAL_JOINTS`]), as in a clearance model whose other joints are ideal
/// ([`static_envelope_with`]).
fn linear_per_joint_with_crosses(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    ex: &Excitation,
    crosses: [bool; 6],
) -> Result<Vec<Vec<PlayPoseError>>, Mr2120Error> {
    let m = Vector3::from(point.m);
    let q = inverse(g, m)?;
    let mut model = ideal_model(g, mp, m, Some(q.map(MotionLaw::Constant)))?;
    let cases = static_load_cases(ex);
    let load = Arc::new(std::sync::Mutex::new((Vector3::zeros(), Vector3::zeros())));
    model.mechanism.add_force(Box::new(SharedLoad {
        body: model.platform,
        load: load.clone(),
    }));
    let play = UniversalPlay::from_design(&bearing_design(&TABLE1[0], DEFAULT_DAMPING));
    let joints: Vec<JointPlay> = UNIVERSAL_JOINTS
        .iter()
        .zip(crosses)
        .map(|(name, cross)| {
            model
                .mechanism
                .joints()
                .find(|(_, j)| j.name == *name)
                .map(|(joint, _)| JointPlay {
                    joint,
                    play,
                    cross_mass: if cross { mp.cross } else { 0.0 },
                })
                .ok_or_else(|| {
                    Mr2120Error::Model(ModelError::BadElement {
                        kind: "joint",
                        name: (*name).into(),
                        reason: "not in the ideal model".into(),
                    })
                })
        })
        .collect::<Result<_, _>>()?;
    hang_crosses(&mut model.mechanism, &joints);
    Ok(play_pose_errors_per_joint(
        &model.mechanism,
        0.0,
        &joints,
        model.platform,
        AssemblyOptions::default(),
        cases.len(),
        |k| {
            if let Ok(mut l) = load.lock() {
                *l = cases[k];
            }
        },
    )?)
}

/// The universal joints of the ideal model (elbows and platform joints), each with the play
/// of the bearings of `set`.
fn play_joints(mech: &crate::multibody::Mechanism, set: &ClearanceSet, cross_mass: f64) -> Vec<JointPlay> {
    let play = UniversalPlay::from_design(&bearing_design(set, DEFAULT_DAMPING));
    mech.joints()
        .filter(|(_, j)| {
            ELBOW_JOINTS.contains(&j.name.as_str()) || PLATFORM_JOINTS.contains(&j.name.as_str())
        })
        .map(|(joint, _)| JointPlay {
            joint,
            play,
            cross_mass,
        })
        .collect()
}

/// Hangs each joint's cross on the ideal model: its weight as a load on the joint's side-i
/// body at the joint's point. The clearance model carries the crosses as bodies of their own
/// on top of whole links ([`clearance_model`]); with these loads the ideal model's static
/// reactions are the clearance model's at zero clearance (the crosses' weights included down
/// the chain), and side i's pair carries the cross besides ([`JointPlay::cross_mass`]).
fn hang_crosses(mech: &mut crate::multibody::Mechanism, joints: &[JointPlay]) {
    let gravity = mech.gravity();
    let hung: Vec<(String, BodyHandle, Vector3<f64>, Vector3<f64>)> = joints
        .iter()
        .filter(|jp| jp.cross_mass > 0.0)
        .filter_map(|jp| {
            let j = mech.joint(jp.joint)?;
            match j.body_i {
                crate::multibody::Attach::Body(b) => Some((
                    format!("cross of {}", j.name),
                    b,
                    j.frame_i.origin,
                    jp.cross_mass * gravity,
                )),
                // A cross hung on the ground loads nothing that moves.
                crate::multibody::Attach::Ground => None,
            }
        })
        .collect();
    for (name, body, point, weight) in hung {
        mech.add_force(Box::new(crate::multibody::PointForce {
            name,
            body,
            point,
            force: Arc::new(move |_| weight),
        }));
    }
}

/// One load case of [`linear_envelope`]: the platform's pose error per metre of radial
/// clearance and of axial play (every universal joint with the bearings of `set`).
pub fn linear_case(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
    force: Vector3<f64>,
    torque: Vector3<f64>,
) -> Result<PlayPoseError, Mr2120Error> {
    let m = Vector3::from(point.m);
    let q = inverse(g, m)?;
    let mut model = ideal_model(g, mp, m, Some(q.map(MotionLaw::Constant)))?;
    if force != Vector3::zeros() || torque != Vector3::zeros() {
        model.mechanism.add_force(Box::new(ConstantLoad {
            body: model.platform,
            force,
            torque,
        }));
    }
    let joints = play_joints(&model.mechanism, set, mp.cross);
    hang_crosses(&mut model.mechanism, &joints);
    Ok(play_pose_error(
        &model.mechanism,
        0.0,
        &joints,
        model.platform,
        AssemblyOptions::default(),
    )?)
}

/// Method (b) by dynamic relaxation, the route [`static_envelope`] replaced: the same 13
/// equilibria, each found by integrating the motion with strong mass-proportional damping
/// ([`RELAXATION_RATE`]) on every free body until it dies out — an exact static equilibrium
/// (damping does no work at rest), at the cost of a simulation per load case. Kept as an
/// independent cross-check of the direct solver and as the benchmark's baseline. Returns the
/// ranges and the integrator steps.
pub fn relaxation_envelope(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
    ex: &Excitation,
) -> Result<(Ranges, usize), Mr2120Error> {
    let mut r = [(f64::INFINITY, f64::NEG_INFINITY); 6];
    let mut steps = 0;
    for (force, torque) in static_load_cases(ex) {
        let (e, n) = relaxation_case(g, mp, point, set, force, torque, RELAXATION_TIME)?;
        steps += n;
        widen(&mut r, &e);
    }
    Ok((r, steps))
}

/// One load case of [`relaxation_envelope`] relaxed for `time` seconds: the errors of eq.
/// (4.1) (m, rad) and the integrator steps.
pub fn relaxation_case(
    g: &Geometry,
    mp: &MassProperties,
    point: &Table2Point,
    set: &ClearanceSet,
    force: Vector3<f64>,
    torque: Vector3<f64>,
    time: f64,
) -> Result<([f64; 6], usize), Mr2120Error> {
    let m = Vector3::from(point.m);
    let mut model = locked_clearance_model(g, mp, point, set)?;
    let platform = model.platform;
    let free: Vec<BodyHandle> = model
        .forearms
        .iter()
        .chain(model.crosses.iter())
        .copied()
        .chain([platform])
        .collect();
    for &b in &free {
        let body = model.mechanism.body(b).expect("handle of this model");
        let (mass, inertia) = (body.mass, body.inertia);
        model.mechanism.add_force(Box::new(Relaxation {
            body: b,
            mass,
            inertia,
        }));
    }
    if force != Vector3::zeros() || torque != Vector3::zeros() {
        model.mechanism.add_force(Box::new(ConstantLoad {
            body: platform,
            force,
            torque,
        }));
    }
    let mut sim = Simulation::new(Arc::new(model.mechanism), 0.0, clearance_options())?;
    let traj = sim.run(&[time], |_| {})?;
    let s = traj.samples.last().expect("one sample");
    Ok((pose_errors(s, platform, &m), sim.stats().steps))
}

/// Rate of the relaxation damping of method (b), 1/s: each free body feels −ζ·m·v and
/// −ζ·J·ω', so motion decays within a few multiples of 1/ζ = 5 ms.
pub const RELAXATION_RATE: f64 = 200.0;
/// Time integrated per equilibrium in method (b), s.
pub const RELAXATION_TIME: f64 = 0.15;

#[derive(Debug, Clone)]
struct Relaxation {
    body: BodyHandle,
    mass: f64,
    inertia: Matrix3<f64>,
}

impl ForceElement for Relaxation {
    fn name(&self) -> &str {
        "relaxation damping"
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.body]
    }
    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let b = self.body.index();
        loads[b].force -= states[b].v * (RELAXATION_RATE * self.mass);
        loads[b].torque -= self.inertia * states[b].omega * RELAXATION_RATE;
    }
}

/// A load on a body (force N, torque N·m, base frame) that the caller sets between
/// evaluations: the load cases of one pose share one model.
#[derive(Debug, Clone)]
struct SharedLoad {
    body: BodyHandle,
    load: Arc<std::sync::Mutex<(Vector3<f64>, Vector3<f64>)>>,
}

impl ForceElement for SharedLoad {
    fn name(&self) -> &str {
        "static load"
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.body]
    }
    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let (force, torque) = self.load.lock().map(|l| *l).unwrap_or_default();
        let b = self.body.index();
        loads[b].force += force;
        loads[b].torque += states[b].a.transpose() * torque;
    }
}

#[derive(Debug, Clone)]
struct ConstantLoad {
    body: BodyHandle,
    force: Vector3<f64>,
    torque: Vector3<f64>,
}

impl ForceElement for ConstantLoad {
    fn name(&self) -> &str {
        "static load"
    }
    fn bodies(&self) -> Vec<BodyHandle> {
        vec![self.body]
    }
    fn apply(&self, _t: f64, states: &[BodyState], loads: &mut [BodyLoad]) {
        let b = self.body.index();
        loads[b].force += self.force;
        loads[b].torque += states[b].a.transpose() * self.torque;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanisms::mr2120::paper::{TABLE1, TABLE2};

    /// The first-order envelope from one model whose load changes between cases equals the
    /// envelope of one freshly built model per load case.
    #[test]
    fn the_shared_model_envelope_is_the_envelope_of_models_built_per_case() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let ex = Excitation::default();
        for (point, set) in [(&TABLE2[0], &TABLE1[0]), (&TABLE2[1], &TABLE1[2])] {
            let shared = linear_envelope(&g, &mp, point, set, &ex).unwrap();
            let mut fresh = [(f64::INFINITY, f64::NEG_INFINITY); 6];
            for (force, torque) in static_load_cases(&ex) {
                let e = linear_case(&g, &mp, point, set, force, torque).unwrap();
                widen(&mut fresh, &e.at(set.radial, set.axial));
            }
            for k in 0..6 {
                let scale = fresh[k].0.abs().max(fresh[k].1.abs()).max(1e-12);
                assert!(
                    (shared[k].0 - fresh[k].0).abs() <= 1e-9 * scale
                        && (shared[k].1 - fresh[k].1).abs() <= 1e-9 * scale,
                    "{} component {k}: {:?} vs {:?}",
                    point.name,
                    shared[k],
                    fresh[k]
                );
            }
        }
    }

    /// Joint by joint, the first order agrees with the equilibria of a model whose play is in
    /// that joint alone (the others ideal, so that joint's cross the only one) at a regular
    /// pose: each error range's width within 0.8–1.1× (contact elasticity is what the first
    /// order leaves out). And the equilibria with a set's clearances given joint by joint are
    /// those of the set.
    #[test]
    fn per_joint_first_order_matches_play_in_one_joint_alone() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let ex = Excitation::default();
        let (point, set) = (&TABLE2[0], &TABLE1[0]);
        assert_eq!(
            linear_per_joint(&g, &mp, point, &ex).unwrap().len(),
            static_load_cases(&ex).len()
        );
        for k in [0, 4] {
            let per_joint =
                linear_per_joint_with_crosses(&g, &mp, point, &ex, std::array::from_fn(|c| c == k)).unwrap();
            let mut first = [(f64::INFINITY, f64::NEG_INFINITY); 6];
            for case in &per_joint {
                assert_eq!(case.len(), 6);
                let e: [f64; 6] =
                    std::array::from_fn(|c| set.radial * case[k].radial[c] + set.axial * case[k].axial[c]);
                widen(&mut first, &e);
            }
            let mut designs = [None; 6];
            designs[k] = Some(bearing_design(set, DEFAULT_DAMPING));
            let (nonlinear, _) = static_envelope_with(&g, &mp, point, &designs, &ex).unwrap();
            for c in 0..6 {
                let (wf, wn) = (first[c].1 - first[c].0, nonlinear[c].1 - nonlinear[c].0);
                if wn < 1e-3 * set.radial {
                    continue; // a component this joint's play does not move
                }
                assert!(
                    (0.8..=1.1).contains(&(wf / wn)),
                    "joint {} component {c}: first order {wf:e}, equilibria {wn:e}",
                    UNIVERSAL_JOINTS[k]
                );
            }
        }
        let (a, _) = static_envelope(&g, &mp, &TABLE2[0], set, &ex).unwrap();
        let (b, _) =
            static_envelope_per_joint(&g, &mp, &TABLE2[0], &JointClearances::uniform(set), &ex).unwrap();
        assert_eq!(a, b);
    }

    /// The direct equilibrium is the state dynamic relaxation tends to: at M1 (regular) and
    /// at M3 (near the direct singularity, where the platform sags 12.7 mm under gravity in
    /// the L1 set and relaxation for 0.15 s stops 4 mm short), relaxed for 0.6 s the two
    /// agree to 0.05 µm and 0.05 mrad.
    #[test]
    fn the_direct_equilibrium_is_where_dynamic_relaxation_settles() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let ex = Excitation::default();
        let cases = static_load_cases(&ex);
        for (point, case) in [(&TABLE2[0], 0), (&TABLE2[0], 1), (&TABLE2[2], 0)] {
            let set = &TABLE1[0];
            let m = Vector3::from(point.m);
            let mut model = locked_clearance_model(&g, &mp, point, set).unwrap();
            let (force, torque) = cases[case];
            if case > 0 {
                model.mechanism.add_force(Box::new(ConstantLoad {
                    body: model.platform,
                    force,
                    torque,
                }));
            }
            let platform = model.platform;
            let eq = crate::multibody::static_equilibrium(
                &Arc::new(model.mechanism),
                0.0,
                None,
                &StaticsOptions::default(),
            )
            .unwrap();
            let direct = pose_errors(&eq.sample, platform, &m);
            let (relaxed, _) = relaxation_case(&g, &mp, point, set, force, torque, 0.6).unwrap();
            for k in 0..6 {
                let tol = if k < 3 { 5e-8 } else { 5e-5 };
                assert!(
                    (direct[k] - relaxed[k]).abs() < tol,
                    "{} case {case}, error {k}: direct {:e}, relaxation {:e}",
                    point.name,
                    direct[k],
                    relaxed[k]
                );
            }
        }
    }

    /// The first-order play bound against the nonlinear equilibria (L1): at M1 and M2 every
    /// range's width is within 0.7–1.3× the equilibria's (measured 0.76–1.00× at M1,
    /// 0.93–1.17× at M2, the crosses' weights carried; the bound leaves out contact
    /// elasticity, which widens the equilibria's d_z most) and each end within 0.35 of that
    /// width; at M3, a direct singularity, it refuses.
    #[test]
    fn the_linear_play_bound_against_the_equilibria() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let ex = Excitation::default();
        let set = &TABLE1[0];
        for point in &TABLE2[..2] {
            let lin = linear_envelope(&g, &mp, point, set, &ex).unwrap();
            let (nl, _) = static_envelope(&g, &mp, point, set, &ex).unwrap();
            for k in 0..6 {
                let w = nl[k].1 - nl[k].0;
                let ratio = (lin[k].1 - lin[k].0) / w;
                assert!(
                    (0.7..=1.3).contains(&ratio),
                    "{} error {k}: width ratio {ratio}",
                    point.name
                );
                let ends = (lin[k].0 - nl[k].0).abs().max((lin[k].1 - nl[k].1).abs());
                assert!(
                    ends <= 0.35 * w,
                    "{} error {k}: ends {lin:?} vs {nl:?}",
                    point.name
                );
            }
        }
        let e = linear_envelope(&g, &mp, &TABLE2[2], set, &ex).unwrap_err();
        assert!(
            matches!(e, Mr2120Error::Model(ModelError::Singular { .. })),
            "{e}"
        );
    }
}
