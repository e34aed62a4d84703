//! Synthetic MR2120 recordings from a **simulated multibody truth**, independent of the
//! diagnosis' candidate library: what a lab would log (motor encoder angles and rates, motor
//! torques from the currents, the platform centre from a laser tracker) when the machine is
//! the multibody model described by a [`TruthSpec`].
//!
//! # The physics
//! * **Links**: the 7-body MR2120 ([`ideal`](super::ideal)) with each branch's own arm and
//!   forearm lengths, a point-mass payload and a gravity direction (base tilt) from
//!   [`LinkSpec`].
//! * **Universal joints** D, E, F, P, Q, R: each ideal or a trunnion bearing with its own
//!   radial and axial clearance and Hertz ball contacts
//!   ([`clearance_model_per_joint`](super::clearance::clearance_model_per_joint)). A joint
//!   with a bearing has its cross ([`MassProperties::cross`](super::geometry::MassProperties))
//!   as a body of its own, and that mass comes out of the link the cross belongs to with an
//!   ideal joint (the arm at an elbow D, E, F; the forearm at a platform joint P, Q, R; mass,
//!   centre of mass and inertia of link and cross together unchanged): the machine weighs the
//!   same whichever joints have play, so a case hides the play, not 50 g more at a joint.
//! * **Compliant transmissions as bodies**, per drive A, B, C: a rotor on a revolute joint to
//!   the ground, coaxial with the arm's revolute pair, follows the commanded motor angle
//!   exactly (a driver); the arm's revolute pair is *not* driven: the arm is coupled to the
//!   rotor by a torsional spring-damper
//!   ([`crate::multibody::forces::RotationalSpringDamper`]), or, with backlash
//!   ([`DriveTruth::backlash`]), by a dead zone: free within ±b, the spring and damper on the
//!   excess beyond ([`DriveTruth::transmission_torque`]), crossed at every torque reversal;
//!   or with a gear mesh ([`DriveTruth::gear`], [`GearMesh`]): the spring and damper turn an
//!   output gear (a body of its own), whose teeth meet the arm's across a play by an impact
//!   law on the flank (Flores et al.'s by default), the other form of backlash.
//! * **Arm-side joint friction** as force elements ([`ArmFriction`]): Stribeck friction with
//!   its own scales and exponent, Coulomb friction that drifts over the record, cogging
//!   torque ripple. (LuGre is not implemented: it needs a friction state, which a force
//!   element does not have.)
//! * **Payload as a body** ([`PayloadBody`]): rigidly fixed to the platform at an offset from
//!   M, or on a vertical spring mount (prismatic joint + spring-damper, a flexible part
//!   outside any rigid-body library).
//! * **Sensors** ([`SensorModel`]): the encoder and the rate channel sit on the **motor side**
//!   (they read the rotor); the torque channel reads the **motor torque**, the rotor driver's
//!   effort (the torque the motor applies to the rotor, positive towards increasing drive
//!   angle: −λ of the driver, see [`data`](crate::multibody::data)); the tracker reads the
//!   platform centre M. Offsets, scales and delays per channel; white noise from
//!   [`SensorNoise`](super::record::SensorNoise) (`RecordOptions::noise`).
//!
//! # The commanded motion and the start from rest
//! The motor angles follow the nominal inverse kinematics ([`kinematics::inverse`] on the
//! nominal [`Geometry`]) of the platform path, sampled every [`KNOT_SPACING`] and
//! interpolated by a natural cubic spline (`MotionLaw::Sampled`). The recording's t = 0 is
//! preceded by a **pre-roll** ([`TruthSpec::pre_roll`]): the platform rests at the path's
//! centre c for `settle_hold` seconds (the transmissions, the bearings and a sprung payload
//! settle under gravity; the simulation starts with the springs unloaded), then the path is
//! blended in over `settle_ramp` seconds, p(t) = c + w(t)·(path(t) − c) with a C^∞ smooth
//! step w (every derivative continuous), then the platform follows `path` exactly for
//! `settle_run_in` seconds before the record's t = 0 (the path is defined for negative t).
//! Defaults [`SETTLE_HOLD`], [`SETTLE_RAMP`], [`SETTLE_RUN_IN`]. The slowest mode of the
//! nominal transmissions is the platform bouncing on the three springs (≈ 25 Hz, decaying at
//! ≈ 16 s⁻¹ with the nominal damping): the run-in lets what the ramp excited decay (by
//! e⁻⁸) before the record. Paths that pass near the direct singularity ring that mode
//! themselves (there the platform's stiffness on the transmissions vanishes): that is
//! physics, and it shows in the record.
//!
//! # Example
//! ```
//! use lash::mechanisms::mr2120::record::{Excitation, RecordOptions};
//! use lash::mechanisms::mr2120::truth::{simulate_truth, ArmFriction, StribeckFriction, TruthSpec};
//!
//! let mut spec = TruthSpec::nominal();
//! // Stribeck friction on arm B; a short pre-roll keeps the example fast.
//! spec.drives[1].friction.push(ArmFriction::Stribeck(StribeckFriction {
//!     coulomb: 0.05,          // N·m
//!     stiction: 0.08,         // N·m
//!     stribeck_velocity: 0.02, // rad/s
//!     exponent: 1.4,
//!     regularisation: 0.004,  // rad/s
//!     viscous: 0.01,          // N·m·s/rad
//! }));
//! spec.settle_hold = 0.05;
//! spec.settle_ramp = 0.05;
//! spec.settle_run_in = 0.0;
//! let opts = RecordOptions { duration: 0.02, rate: 500.0, ..Default::default() };
//! let path = Excitation::random(1, 0.32, 0.0);
//! let noise_free = simulate_truth(&spec, &path, &opts, None).unwrap();
//! let noisy = simulate_truth(&spec, &path, &opts, Some(7)).unwrap();
//! assert_eq!(noisy.t.len(), 11);
//! // Noise only: the encoders differ by a few µrad.
//! assert!((noisy.q[0][5] - noise_free.q[0][5]).abs() < 2e-5);
//! ```

use super::clearance::add_universal_joints;
use super::geometry::{Geometry, MassProperties};
use super::ideal::{
    add_links, ideal_model_with, LinkSpec, Mr2120Error, DRIVE_JOINTS, ELBOW_JOINTS, PLATFORM_JOINTS,
};
use super::kinematics::{self, KinematicsError};
use super::lumped::NOMINAL_COMPLIANCE;
use super::record::{
    reversals, Excitation, RecordOptions, Recorded, Rng, BACKLASH_SCALE, CLEARANCE_SCALE, FRICTION_VELOCITY,
};
use crate::contact::{BearingDesign, NormalLaw};
use crate::multibody::forces::{RelativeRotation, RotationalSpringDamper, RotationalTorque};
use crate::multibody::{
    Analysis, Attach, BodyHandle, BodyState, DriverHandle, Mechanism, MechanismData, ModelError, MotionLaw,
    RigidBody, RunEnd, Sample, Simulation, SimulationOptions, Snapshot, SpringDamper,
};
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;

/// Nominal transmission stiffness, N·m/rad: the inverse of the lumped model's nominal drive
/// compliance [`NOMINAL_COMPLIANCE`] (1e-4 rad/(N·m)).
pub const NOMINAL_STIFFNESS: f64 = 1.0 / NOMINAL_COMPLIANCE;
/// Nominal rotor inertia about the drive axis, kg·m² (a small rotor: no reflected gearbox
/// inertia beyond it; a nominal model declares the same). Chosen, not measured: at the
/// paths' drive accelerations (≤ 10 rad/s²) it adds ≤ 1e-3 N·m to the motor torque.
pub const NOMINAL_ROTOR_INERTIA: f64 = 1e-4;
/// Rotor mass, kg (its centre of mass is on the drive axis, so it adds no gravity torque).
pub const ROTOR_MASS: f64 = 0.2;
/// Damping ratio of the transmission mode the nominal damping gives at
/// [`REFERENCE_ARM_INERTIA`].
pub const NOMINAL_DAMPING_RATIO: f64 = 0.2;
/// Arm-side inertia about a drive axis used to state the damping ratio, kg·m²: arm
/// (1 kg·(0.3 m)²/3 = 0.03) plus about half a forearm and a third of the platform reflected
/// to the arm tip (≈ 0.07); the real value varies along the path (and grows without bound
/// near the direct singularity).
pub const REFERENCE_ARM_INERTIA: f64 = 0.1;
/// Nominal transmission damping, N·m·s/rad: 2·ζ·√(k·J) with ζ = [`NOMINAL_DAMPING_RATIO`],
/// k = [`NOMINAL_STIFFNESS`], J = [`REFERENCE_ARM_INERTIA`] (mode ≈ 50 Hz).
pub const NOMINAL_TRANSMISSION_DAMPING: f64 = 12.649110640673518;
/// Default hold at rest before the ramp, s.
pub const SETTLE_HOLD: f64 = 0.2;
/// Default ramp that blends the path in, s.
pub const SETTLE_RAMP: f64 = 1.0;
/// Default run-in on the exact path before the record starts, s.
pub const SETTLE_RUN_IN: f64 = 0.5;
/// Spacing of the samples of the commanded motor angles that the drivers' splines
/// interpolate, s.
pub const KNOT_SPACING: f64 = 1e-3;
/// Extra commanded path after the record's end (keeps the spline's natural end condition out
/// of the record), s.
const TAIL: f64 = 0.1;
/// Largest number of fixed-point passes of the quasi-static reference per sample.
const MAX_REFERENCE_PASSES: usize = 200;
/// Largest sensor delay accepted, s.
pub const MAX_DELAY: f64 = 0.1;

/// Stribeck friction with its own scales:
/// τ = −[F_c + (F_s − F_c)·exp(−|v/v_s|^δ)]·v/√(v² + ε²) − σ₂·v (N·m on the arm, v its rate in
/// rad/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StribeckFriction {
    /// Coulomb level F_c, N·m.
    pub coulomb: f64,
    /// Static (breakaway) level F_s, N·m.
    pub stiction: f64,
    /// Stribeck velocity v_s, rad/s.
    pub stribeck_velocity: f64,
    /// Stribeck exponent δ.
    pub exponent: f64,
    /// Regularisation velocity ε of the sign function, rad/s.
    pub regularisation: f64,
    /// Viscous coefficient σ₂, N·m·s/rad.
    pub viscous: f64,
}

impl StribeckFriction {
    /// The friction torque on the arm at rate `v` (rad/s), N·m.
    pub fn torque(&self, v: f64) -> f64 {
        let level = self.coulomb
            + (self.stiction - self.coulomb)
                * (-(v / self.stribeck_velocity).abs().powf(self.exponent)).exp();
        -level * v / (v * v + self.regularisation * self.regularisation).sqrt() - self.viscous * v
    }
}

/// A torque on the arm side of a drive (a force element between the ground and the arm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ArmFriction {
    /// Stribeck friction ([`StribeckFriction`]).
    Stribeck(StribeckFriction),
    /// Coulomb friction whose level grows linearly over the record:
    /// τ = −(F₀ + ġ·max(t, 0))·v/√(v² + ε²), t the recording time (s).
    Drifting {
        /// Level at t = 0 (and during the pre-roll), N·m.
        initial: f64,
        /// Growth rate ġ, N·m/s.
        growth: f64,
        /// Regularisation velocity ε, rad/s.
        regularisation: f64,
    },
    /// Cogging torque ripple τ = A·sin(z·θ + φ), θ the arm's drive angle (rad).
    Cogging {
        /// Amplitude A, N·m.
        amplitude: f64,
        /// Periods per revolution z.
        periods: f64,
        /// Phase φ, rad.
        phase: f64,
    },
}

impl ArmFriction {
    /// The torque on the arm (N·m) at recording time `t` (s), arm angle `theta` (rad) and
    /// arm rate `v` (rad/s).
    pub fn torque(&self, t: f64, theta: f64, v: f64) -> f64 {
        match *self {
            ArmFriction::Stribeck(s) => s.torque(v),
            ArmFriction::Drifting {
                initial,
                growth,
                regularisation,
            } => -(initial + growth * t.max(0.0)) * v / (v * v + regularisation * regularisation).sqrt(),
            ArmFriction::Cogging {
                amplitude,
                periods,
                phase,
            } => amplitude * (periods * theta + phase).sin(),
        }
    }

    fn validate(&self, drive: &str) -> Result<(), TruthError> {
        let bad = |what: &str, v: f64| TruthError::Invalid(format!("drive {drive}: {what} = {v}"));
        match *self {
            ArmFriction::Stribeck(s) => {
                nonneg(s.coulomb)
                    .then_some(())
                    .ok_or_else(|| bad("Stribeck Coulomb level (N·m, ≥ 0)", s.coulomb))?;
                nonneg(s.stiction)
                    .then_some(())
                    .ok_or_else(|| bad("Stribeck static level (N·m, ≥ 0)", s.stiction))?;
                pos(s.stribeck_velocity)
                    .then_some(())
                    .ok_or_else(|| bad("Stribeck velocity (rad/s, > 0)", s.stribeck_velocity))?;
                pos(s.exponent)
                    .then_some(())
                    .ok_or_else(|| bad("Stribeck exponent (> 0)", s.exponent))?;
                pos(s.regularisation)
                    .then_some(())
                    .ok_or_else(|| bad("regularisation velocity (rad/s, > 0)", s.regularisation))?;
                nonneg(s.viscous)
                    .then_some(())
                    .ok_or_else(|| bad("viscous coefficient (N·m·s/rad, ≥ 0)", s.viscous))?;
            }
            ArmFriction::Drifting {
                initial,
                growth,
                regularisation,
            } => {
                nonneg(initial)
                    .then_some(())
                    .ok_or_else(|| bad("drifting friction level (N·m, ≥ 0)", initial))?;
                growth
                    .is_finite()
                    .then_some(())
                    .ok_or_else(|| bad("drifting friction growth (N·m/s)", growth))?;
                pos(regularisation)
                    .then_some(())
                    .ok_or_else(|| bad("regularisation velocity (rad/s, > 0)", regularisation))?;
            }
            ArmFriction::Cogging {
                amplitude,
                periods,
                phase,
            } => {
                for (what, v) in [
                    ("cogging amplitude (N·m)", amplitude),
                    ("cogging periods", periods),
                    ("cogging phase (rad)", phase),
                ] {
                    v.is_finite().then_some(()).ok_or_else(|| bad(what, v))?;
                }
            }
        }
        Ok(())
    }
}

/// One drive's transmission and arm-side torques.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveTruth {
    /// Torsional stiffness between rotor and arm, N·m/rad (> 0).
    pub stiffness: f64,
    /// Torsional damping between rotor and arm, N·m·s/rad (≥ 0).
    pub damping: f64,
    /// Rotor inertia about the drive axis, kg·m² (> 0).
    pub rotor_inertia: f64,
    /// Torques on the arm side (friction, cogging), summed.
    pub friction: Vec<ArmFriction>,
    /// Backlash of the transmission: half its play, rad (≥ 0, at most [`MAX_BACKLASH`]).
    /// Within ±backlash of its unloaded angle the arm turns free of the rotor; beyond it the
    /// transmission acts as a spring and damper on the excess, and pushes only (a dead zone
    /// that the rotor crosses whenever the transmission's torque reverses).
    pub backlash: f64,
    /// A gear mesh with play between the transmission and the arm, if any ([`GearMesh`]):
    /// the spring and damper then turn an output gear, and the arm meets that gear's teeth
    /// across the mesh's play by a nonlinear contact law — another form of backlash than
    /// [`backlash`](Self::backlash) (which must then be 0).
    pub gear: Option<GearMesh>,
}

/// A gear mesh with backlash: an output gear (a body on the drive axis, turned by the
/// transmission's spring and damper) whose teeth meet the arm's across a play of ±`backlash`,
/// pressing by an impact law on the flank's penetration: F = K·δ^n·(1 + χ·δ̇) of
/// [`NormalLaw`] read in angular units (δ in rad, δ̇ in rad/s, K in N·m/rad^n, the law's
/// reference velocity in rad/s, the result in N·m), never pulling.
///
/// Unlike [`DriveTruth::backlash`] (a dead zone in the transmission's own spring, damped only
/// in contact), here the play sits in series with the spring, the flank is stiff and
/// nonlinear, its damping is the law's hysteresis (vanishing as contact begins), the
/// transmission's damper acts in the play too, and the gear has its own inertia: a truth of
/// a form the diagnosis's dead-zone candidate does not share.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GearMesh {
    /// Half the mesh's play, rad (≥ 0, at most [`MAX_BACKLASH`]).
    pub backlash: f64,
    /// The flank's contact law, in angular units (above).
    pub law: NormalLaw,
    /// The output gear's inertia about the drive axis, kg·m² (> 0); its mass is
    /// [`GEAR_MASS`], centred on the axis.
    pub inertia: f64,
}

/// The flank stiffness of [`GearMesh::example`], N·m/rad^1.5: a flank deflection of 1 µrad
/// under 1 N·m (a tenth of a 10 µrad backlash; secant stiffness 1e6 N·m/rad there, a hundred
/// times the transmission's [`NOMINAL_STIFFNESS`]). Chosen, not measured.
pub const GEAR_MESH_STIFFNESS: f64 = 1e9;
/// Coefficient of restitution of [`GearMesh::example`]'s flank (Flores et al.'s law), at
/// [`GEAR_MESH_REFERENCE_RATE`]. Chosen, not measured.
pub const GEAR_MESH_RESTITUTION: f64 = 0.8;
/// Reference impact rate of [`GearMesh::example`]'s flank law, rad/s: of the order of the
/// transmissions' wind-up rate as a drive torque reverses (some hundreds of N·m/s over
/// [`NOMINAL_STIFFNESS`]: 0.08 rad/s at the 800 N·m/s measured on the suite's shaken
/// recording). Chosen, not measured.
pub const GEAR_MESH_REFERENCE_RATE: f64 = 0.05;
/// Inertia of [`GearMesh::example`]'s output gear about the drive axis, kg·m² (a fifth of
/// [`NOMINAL_ROTOR_INERTIA`]: at the paths' ≤ 10 rad/s² it adds ≤ 2e-4 N·m, a hundredth of the
/// torque noise). Chosen, not measured.
pub const GEAR_INERTIA: f64 = 2e-5;
/// Mass of an output gear, kg (centred on the drive axis: no gravity torque).
pub const GEAR_MASS: f64 = 0.05;

impl GearMesh {
    /// A mesh with half-play `backlash` (rad): Flores et al.'s law with
    /// [`GEAR_MESH_STIFFNESS`], exponent 1.5, [`GEAR_MESH_RESTITUTION`] at
    /// [`GEAR_MESH_REFERENCE_RATE`], and an output gear of [`GEAR_INERTIA`].
    pub fn example(backlash: f64) -> Self {
        Self {
            backlash,
            law: NormalLaw::Flores {
                k: GEAR_MESH_STIFFNESS,
                n: 1.5,
                restitution: GEAR_MESH_RESTITUTION,
                v_ref: GEAR_MESH_REFERENCE_RATE,
            },
            inertia: GEAR_INERTIA,
        }
    }

    /// The mesh's torque on the arm at relative rotation θ (arm against gear, rad) and rate θ̇
    /// (rad/s), N·m: zero for |θ| ≤ b; beyond, −sign(θ)·F(|θ| − b, θ̇·sign(θ)) with F the
    /// flank's law (≥ 0: it never pulls).
    pub fn torque(&self, theta: f64, rate: f64) -> f64 {
        let over = theta.abs() - self.backlash;
        if over <= 0.0 {
            return 0.0;
        }
        let s = theta.signum();
        -s * self.law.force(over, rate * s)
    }
}

/// Largest transmission backlash accepted (half the play), rad.
pub const MAX_BACKLASH: f64 = 1e-2;

impl DriveTruth {
    /// [`NOMINAL_STIFFNESS`], [`NOMINAL_TRANSMISSION_DAMPING`], [`NOMINAL_ROTOR_INERTIA`], no
    /// friction, no backlash.
    pub fn nominal() -> Self {
        Self {
            stiffness: NOMINAL_STIFFNESS,
            damping: NOMINAL_TRANSMISSION_DAMPING,
            rotor_inertia: NOMINAL_ROTOR_INERTIA,
            friction: vec![],
            backlash: 0.0,
            gear: None,
        }
    }

    /// The transmission's torque on the arm at relative rotation θ (arm against rotor, rad)
    /// and rate θ̇ (rad/s), N·m: −k·θ − c·θ̇ without backlash; with backlash b, zero for
    /// |θ| ≤ b and −sign(θ)·max(k·(|θ| − b) + c·θ̇·sign(θ), 0) beyond (the damping acts
    /// only in contact, and a separating contact does not pull).
    pub fn transmission_torque(&self, theta: f64, rate: f64) -> f64 {
        let (k, c, b) = (self.stiffness, self.damping, self.backlash);
        if b <= 0.0 {
            return -k * theta - c * rate;
        }
        let over = theta.abs() - b;
        if over <= 0.0 {
            return 0.0;
        }
        let s = theta.signum();
        -s * (k * over + c * rate * s).max(0.0)
    }
}

/// How a payload body is mounted on the platform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PayloadMount {
    /// Fixed to the platform (a fixed joint).
    Rigid,
    /// On a vertical spring mount: a prismatic joint along the platform's z axis and a
    /// linear spring-damper, pre-loaded so that it is in equilibrium at rest.
    Spring {
        /// Natural frequency of the payload on its mount, Hz (> 0).
        frequency: f64,
        /// Damping ratio of that mode (≥ 0).
        damping_ratio: f64,
    },
}

/// A payload body on the platform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PayloadBody {
    /// Mass, kg (> 0).
    pub mass: f64,
    /// Centre of mass relative to M in the platform frame (parallel to the base frame), m.
    pub offset: Vector3<f64>,
    /// Principal moments of inertia about the centre of mass (platform axes), kg·m² (> 0).
    pub inertia: Vector3<f64>,
    /// Mount.
    pub mount: PayloadMount,
}

impl PayloadBody {
    /// A 0.5 kg, 4 cm steel-like cube 2 cm above M, rigidly mounted.
    pub fn example() -> Self {
        let (m, a) = (0.5, 0.04);
        Self {
            mass: m,
            offset: Vector3::new(0.0, 0.0, 0.02),
            inertia: Vector3::repeat(m * a * a / 6.0),
            mount: PayloadMount::Rigid,
        }
    }
}

/// Systematic sensor errors (noise comes from `RecordOptions::noise`). Per-drive arrays are
/// ordered A, B, C; delays mean the channel reports at t what was true at t − delay.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorModel {
    /// Encoder offsets (measured − rotor angle), rad.
    pub encoder_offset: [f64; 3],
    /// Torque offsets, N·m.
    pub torque_offset: [f64; 3],
    /// Torque scale errors (gain − 1).
    pub torque_scale: [f64; 3],
    /// Delay of the torque channels, s (0 ≤ delay ≤ [`MAX_DELAY`]).
    pub torque_delay: f64,
    /// Tracker offset, m.
    pub tracker_offset: [f64; 3],
    /// Tracker scale errors per axis (gain − 1): measured = (1 + s)·x + offset.
    pub tracker_scale: [f64; 3],
    /// Delay of the tracker, s (0 ≤ delay ≤ [`MAX_DELAY`]).
    pub tracker_delay: f64,
}

/// Integrator settings of a truth simulation.
///
/// Measured with the defaults against 10× tighter tolerances (rtol, atol / 10, h_max / √10;
/// 2 s at 500 Hz, `Excitation::random(11, …)`, `measure_tolerance_and_timing` in
/// `tests/integration/mr2120_truth.rs`), in units of the default sensor noise (0.02 N·m, 5 µm):
/// * ideal joints: torques max 0.001 (gentle) and 0.011 (shaken), tracker ≤ 0.002 — the
///   integration error is far below the noise;
/// * 6 µm play in leg C's joints F and R (default contact damping): gentle path torques max
///   0.24, rms 0.1, tracker ≤ 0.07; shaken path torques max 11, rms 2.2, tracker max 1.2:
///   under load reversals the bearings' impact sequence changes with the tolerance (rattle
///   is sensitive to perturbations; 10× tighter again, or resolving the rattle with
///   `damp_contact_rattle = false`, does not converge it either). Such records are valid
///   samples of the physics, not reproducible to the noise point by point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverSettings {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance (m, rad, m/s, rad/s alike).
    pub atol: f64,
    /// Largest step, s.
    pub h_max: f64,
    /// With bearings with clearance: velocities as index-2 variables in the error test, so
    /// contact rattle along stiff directions is damped by the BDF instead of resolved (as in
    /// the clearance studies, `trajectory::clearance_options`). Ignored with ideal joints.
    pub damp_contact_rattle: bool,
}

impl Default for SolverSettings {
    /// rtol 1e-8, atol 1e-9, steps ≤ 2 ms.
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol: 1e-9,
            h_max: 2e-3,
            damp_contact_rattle: true,
        }
    }
}

/// Everything a truth simulation is made of.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthSpec {
    /// Layout of the machine (the commanded motion uses it as the nominal geometry).
    pub geometry: Geometry,
    /// Link masses (and the crosses of bearings with clearance).
    pub mass: MassProperties,
    /// Each branch's real link lengths, a point-mass payload at M, gravity (base tilt).
    pub links: LinkSpec,
    /// A payload body on the platform.
    pub payload_body: Option<PayloadBody>,
    /// Transmissions and arm-side torques of drives A, B, C.
    pub drives: [DriveTruth; 3],
    /// Bearings of the universal joints D, E, F, P, Q, R (`None`: ideal joint).
    pub joints: [Option<BearingDesign>; 6],
    /// Systematic sensor errors.
    pub sensors: SensorModel,
    /// Integrator settings.
    pub solver: SolverSettings,
    /// Pre-roll hold at rest, s (≥ 0).
    pub settle_hold: f64,
    /// Pre-roll ramp, s (> 0).
    pub settle_ramp: f64,
    /// Pre-roll run-in on the exact path before the record's t = 0, s (≥ 0).
    pub settle_run_in: f64,
}

impl TruthSpec {
    /// The nominal truth: default geometry and masses, nominal links, no payload body,
    /// nominal transmissions without friction, ideal joints, perfect sensors, the default
    /// pre-roll.
    pub fn nominal() -> Self {
        let geometry = Geometry::default();
        Self {
            geometry,
            mass: MassProperties::default(),
            links: LinkSpec::nominal(&geometry),
            payload_body: None,
            drives: std::array::from_fn(|_| DriveTruth::nominal()),
            joints: [None; 6],
            sensors: SensorModel::default(),
            solver: SolverSettings::default(),
            settle_hold: SETTLE_HOLD,
            settle_ramp: SETTLE_RAMP,
            settle_run_in: SETTLE_RUN_IN,
        }
    }

    /// Length of the pre-roll before the record's t = 0 (hold + ramp + run-in), s.
    pub fn pre_roll(&self) -> f64 {
        self.settle_hold + self.settle_ramp + self.settle_run_in
    }

    fn commanded<'a>(&self, path: &'a Excitation) -> CommandedPath<'a> {
        CommandedPath {
            path,
            ramp: self.settle_ramp,
            ramp_end: -self.settle_run_in,
        }
    }

    /// Checks every quantity, naming the bad one.
    pub fn validate(&self) -> Result<(), TruthError> {
        let inv = |what: String| Err(TruthError::Invalid(what));
        for (i, d) in self.drives.iter().enumerate() {
            let n = DRIVE_JOINTS[i];
            if !pos(d.stiffness) {
                return inv(format!(
                    "drive {n}: stiffness = {} N·m/rad (must be > 0)",
                    d.stiffness
                ));
            }
            if !nonneg(d.damping) {
                return inv(format!(
                    "drive {n}: damping = {} N·m·s/rad (must be ≥ 0)",
                    d.damping
                ));
            }
            if !pos(d.rotor_inertia) {
                return inv(format!(
                    "drive {n}: rotor inertia = {} kg·m² (must be > 0)",
                    d.rotor_inertia
                ));
            }
            if !(nonneg(d.backlash) && d.backlash <= MAX_BACKLASH) {
                return inv(format!(
                    "drive {n}: backlash = {} rad (must be in [0, {MAX_BACKLASH}] rad)",
                    d.backlash
                ));
            }
            if let Some(g) = &d.gear {
                if !(nonneg(g.backlash) && g.backlash <= MAX_BACKLASH) {
                    return inv(format!(
                        "drive {n}: gear mesh backlash = {} rad (must be in [0, {MAX_BACKLASH}] rad)",
                        g.backlash
                    ));
                }
                if !pos(g.inertia) {
                    return inv(format!(
                        "drive {n}: output gear inertia = {} kg·m² (must be > 0)",
                        g.inertia
                    ));
                }
                if let Err(e) = g.law.validate() {
                    return inv(format!("drive {n}: gear mesh flank law: {e}"));
                }
                if d.backlash > 0.0 {
                    return inv(format!(
                        "drive {n}: backlash = {} rad in the transmission and a gear mesh with play: one form at a time",
                        d.backlash
                    ));
                }
            }
            for f in &d.friction {
                f.validate(n)?;
            }
        }
        let l = &self.links;
        for i in 0..3 {
            if !pos(l.arm_length[i]) || !pos(l.forearm_length[i]) {
                return inv(format!(
                    "branch {}: arm length {} m, forearm length {} m (must be > 0)",
                    DRIVE_JOINTS[i], l.arm_length[i], l.forearm_length[i]
                ));
            }
        }
        if !nonneg(l.payload) || !l.gravity.iter().all(|g| g.is_finite()) {
            return inv(format!("payload {} kg, gravity {:?} m/s²", l.payload, l.gravity));
        }
        if let Some(p) = &self.payload_body {
            if !pos(p.mass) || !p.inertia.iter().all(|&j| pos(j)) || !p.offset.iter().all(|x| x.is_finite()) {
                return inv(format!(
                    "payload body: mass {} kg, inertia {:?} kg·m², offset {:?} m (mass and inertia must be > 0)",
                    p.mass, p.inertia, p.offset
                ));
            }
            if let PayloadMount::Spring {
                frequency,
                damping_ratio,
            } = p.mount
            {
                if !pos(frequency) || !nonneg(damping_ratio) {
                    return inv(format!(
                        "payload mount: frequency {frequency} Hz (> 0), damping ratio {damping_ratio} (≥ 0)"
                    ));
                }
            }
        }
        for (k, d) in self.joints.iter().enumerate() {
            if let Some(d) = d {
                d.validate()
                    .map_err(|e| TruthError::Invalid(format!("joint {}: {e}", JOINT_NAMES[k])))?;
                // The cross comes out of the arm (elbows) or the forearm (platform joints).
                let (link, m) = if k < 3 {
                    ("arm", self.mass.arm)
                } else {
                    ("forearm", self.mass.forearm)
                };
                if !(pos(self.mass.cross) && self.mass.cross < m) {
                    return inv(format!(
                        "joint {}: cross mass {} kg must be > 0 and below the {link}'s {m} kg",
                        JOINT_NAMES[k], self.mass.cross
                    ));
                }
            }
        }
        let s = &self.sensors;
        let finite = s
            .encoder_offset
            .iter()
            .chain(&s.torque_offset)
            .chain(&s.torque_scale)
            .chain(&s.tracker_offset)
            .chain(&s.tracker_scale)
            .all(|v| v.is_finite());
        if !finite {
            return inv(format!("sensor errors must be finite: {s:?}"));
        }
        for (what, d) in [("torque", s.torque_delay), ("tracker", s.tracker_delay)] {
            if !(nonneg(d) && d <= MAX_DELAY) {
                return inv(format!("{what} delay = {d} s (must be in [0, {MAX_DELAY}] s)"));
            }
        }
        if !nonneg(self.settle_hold) || !pos(self.settle_ramp) || !nonneg(self.settle_run_in) {
            return inv(format!(
                "pre-roll: hold {} s (≥ 0), ramp {} s (> 0), run-in {} s (≥ 0)",
                self.settle_hold, self.settle_ramp, self.settle_run_in
            ));
        }
        if self.pre_roll() < s.torque_delay.max(s.tracker_delay) {
            return inv("the pre-roll must be longer than the sensor delays".into());
        }
        let v = &self.solver;
        if !pos(v.rtol) || !pos(v.atol) || !pos(v.h_max) {
            return inv(format!(
                "solver: rtol {}, atol {}, h_max {} s (all must be > 0)",
                v.rtol, v.atol, v.h_max
            ));
        }
        Ok(())
    }
}

/// Names of the universal joints in the order of [`TruthSpec::joints`].
pub const JOINT_NAMES: [&str; 6] = ["D", "E", "F", "P", "Q", "R"];

fn pos(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

fn nonneg(v: f64) -> bool {
    v.is_finite() && v >= 0.0
}

/// Why a truth could not be simulated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TruthError {
    /// Invalid specification or recording settings.
    #[error("invalid truth: {0}")]
    Invalid(String),
    /// The platform path leaves the work zone.
    #[error("path at t = {t:.4} s: {source}")]
    Path {
        /// Time, s (negative in the pre-roll).
        t: f64,
        /// Cause.
        source: KinematicsError,
    },
    /// Building the multibody model failed.
    #[error("building the truth model: {0}")]
    Build(#[from] Mr2120Error),
    /// The integration failed.
    #[error("simulation failed after t = {t:.6} s (last step h = {h:.3e} s): {source}")]
    Simulation {
        /// Time of the last good output, s.
        t: f64,
        /// Size of the integrator's last step, s.
        h: f64,
        /// The multibody layer's error.
        source: ModelError,
    },
    /// The integration stopped near a singular configuration.
    #[error("simulation stopped near a singular configuration at t = {t:.6} s (measure {measure:.2e}, last step h = {h:.3e} s): {error}")]
    Singular {
        /// Time of the last good output, s.
        t: f64,
        /// Singularity measure there.
        measure: f64,
        /// Size of the integrator's last step, s.
        h: f64,
        /// The integrator's error.
        error: String,
    },
    /// The quasi-static reference's arm angles q_a = q_m − τ(q_a)/k did not converge (near a
    /// direct singularity the transmissions cannot hold the platform quasi-statically).
    #[error("quasi-static reference at t = {t:.6} s: the arm angles did not converge in {passes} passes")]
    ReferenceDiverged {
        /// Time, s.
        t: f64,
        /// Passes made.
        passes: usize,
    },
    /// An analysis at an output time failed (torques from the state, or the reference).
    #[error("analysis at t = {t:.6} s: {source}")]
    Analysis {
        /// Time, s.
        t: f64,
        /// The multibody layer's error.
        source: ModelError,
    },
}

/// The commanded platform path with the pre-roll: the centre before `ramp_end − ramp`, the
/// blend during the ramp, `path` from `ramp_end`.
#[derive(Debug, Clone, Copy)]
struct CommandedPath<'a> {
    path: &'a Excitation,
    ramp: f64,
    /// End of the ramp, s (≤ 0: the path runs exactly from here).
    ramp_end: f64,
}

impl CommandedPath<'_> {
    fn at(&self, t: f64) -> Vector3<f64> {
        let c = Vector3::from(self.path.centre);
        c + blend((t - self.ramp_end + self.ramp) / self.ramp) * (self.path.at(t) - c)
    }
}

/// The C^∞ smooth step: 0 for s ≤ 0, 1 for s ≥ 1, ψ(s)/(ψ(s) + ψ(1 − s)) between with
/// ψ(s) = exp(−1/s); every derivative vanishes at both ends, so the blend excites no mode
/// with a jump in any derivative (a quintic step's jerk jump at its end rang the platform's
/// ≈ 25 Hz vertical mode at 6 µm).
fn blend(s: f64) -> f64 {
    if s <= 0.0 {
        return 0.0;
    }
    if s >= 1.0 {
        return 1.0;
    }
    let (a, b) = ((-1.0 / s).exp(), (-1.0 / (1.0 - s)).exp());
    a / (a + b)
}

/// Sampled commanded motor angles q_i(t_k) (continuous in time) and their splines.
fn commanded_laws(g: &Geometry, cmd: &CommandedPath, t0: f64, t1: f64) -> Result<[MotionLaw; 3], TruthError> {
    let n = ((t1 - t0) / KNOT_SPACING).ceil() as usize + 1;
    let mut times = Vec::with_capacity(n);
    let mut values: [Vec<f64>; 3] = Default::default();
    let mut prev: Option<[f64; 3]> = None;
    for k in 0..n {
        let t = t0 + k as f64 * KNOT_SPACING;
        let q = kinematics::inverse(g, cmd.at(t)).map_err(|source| TruthError::Path { t, source })?;
        let q: [f64; 3] = std::array::from_fn(|i| match prev {
            Some(r) => {
                r[i] + (q[i] - r[i] + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                    - std::f64::consts::PI
            }
            None => q[i],
        });
        prev = Some(q);
        times.push(t);
        for i in 0..3 {
            values[i].push(q[i]);
        }
    }
    let mut laws = Vec::with_capacity(3);
    for v in values {
        laws.push(MotionLaw::sampled(times.clone(), v).map_err(TruthError::Invalid)?);
    }
    Ok(laws.try_into().expect("three laws"))
}

/// Orthonormal frame with z along `z`.
fn frame_z(z: Vector3<f64>) -> Matrix3<f64> {
    let z = z.normalize();
    let helper = if z.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let x = (helper - z * helper.dot(&z)).normalize();
    Matrix3::from_columns(&[x, z.cross(&x), z])
}

/// Where a universal joint's two sides meet, to read the joint's play from a state: the
/// bodies of its sides and, in each body's frame, the joint centre and the side's trunnion
/// axis (side i: the arm at an elbow D, E, F, the forearm at a platform joint P, Q, R; side
/// j: the forearm, the platform), as `lash::diagnose`'s reduced play model defines them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSides {
    /// Body of side i.
    pub body_i: BodyHandle,
    /// Body of side j.
    pub body_j: BodyHandle,
    /// The joint centre in side i's body frame, m.
    pub centre_i: Vector3<f64>,
    /// The joint centre in side j's body frame, m.
    pub centre_j: Vector3<f64>,
    /// Side i's trunnion axis z_i in its body frame (unit).
    pub axis_i: Vector3<f64>,
    /// Side j's trunnion axis z_j in its body frame (unit).
    pub axis_j: Vector3<f64>,
}

impl JointSides {
    /// The sides of the joint at base-frame `centre` with base-frame axes `axis_i`, `axis_j`
    /// between `body_i` and `body_j`, all as built in `mech`.
    fn new(
        mech: &Mechanism,
        (body_i, body_j): (BodyHandle, BodyHandle),
        centre: Vector3<f64>,
        (axis_i, axis_j): (Vector3<f64>, Vector3<f64>),
    ) -> Option<Self> {
        let ((ri, ai), (rj, aj)) = (
            mech.initial_pose(Attach::Body(body_i))?,
            mech.initial_pose(Attach::Body(body_j))?,
        );
        Some(Self {
            body_i,
            body_j,
            centre_i: ai.transpose() * (centre - ri),
            centre_j: aj.transpose() * (centre - rj),
            axis_i: ai.transpose() * axis_i.normalize(),
            axis_j: aj.transpose() * axis_j.normalize(),
        })
    }

    /// The joint's play coordinates in state `s`: the shift of side j's centre from side
    /// i's along base x, y, z (m) and the tilt of side j about n = z_i × z_j, −z_i·z_j (rad;
    /// zero for an ideal joint, up to the constraint tolerance).
    pub fn play(&self, s: &Sample) -> [f64; 4] {
        let (ai, aj) = (s.body_rotation(self.body_i), s.body_rotation(self.body_j));
        let d = (s.body_position(self.body_j) + aj * self.centre_j)
            - (s.body_position(self.body_i) + ai * self.centre_i);
        [d.x, d.y, d.z, -(ai * self.axis_i).dot(&(aj * self.axis_j))]
    }
}

/// The truth model and the handles the recording needs.
#[derive(Debug)]
pub struct TruthModel {
    /// The mechanism.
    pub mechanism: Mechanism,
    /// Platform (its centre of mass is M).
    pub platform: BodyHandle,
    /// Arms A, B, C.
    pub arms: [BodyHandle; 3],
    /// Rotors of drives A, B, C.
    pub rotors: [BodyHandle; 3],
    /// Drivers of the rotors (their efforts are the motor torques, N·m).
    pub motors: [DriverHandle; 3],
    /// Payload body, if any.
    pub payload: Option<BodyHandle>,
    /// Drive angles of the build configuration (rotor and arm coincide), rad.
    pub q_build: [f64; 3],
    /// The rotor angles relative to the ground (zero in the build configuration).
    pub rotor_angles: [RelativeRotation; 3],
    /// The sides of the universal joints D, E, F, P, Q, R (ideal or with a bearing).
    pub joint_sides: [JointSides; 6],
}

/// Builds the truth model of `spec` at rest with the platform at `m_build` (m), the rotors
/// following `laws` (absolute motor angles, rad). The recording time t of the arm-side
/// torques is the simulation time.
pub fn truth_model(
    spec: &TruthSpec,
    m_build: Vector3<f64>,
    laws: [MotionLaw; 3],
) -> Result<TruthModel, TruthError> {
    spec.validate()?;
    let mut mech = Mechanism::new();
    // A joint with a bearing has its cross as a body of its own; its mass comes out of the
    // link it belongs to in the ideal joint (the arm at an elbow, the forearm at the
    // platform), so the machine weighs the same whichever joints have play.
    let carved = spec.joints.map(|j| j.is_some());
    let l = add_links(
        &mut mech,
        &spec.geometry,
        &spec.mass,
        &spec.links,
        m_build,
        None,
        carved,
    )?;
    add_universal_joints(&mut mech, &l, &spec.mass, &spec.joints)?;
    // The joints' sides as `add_universal_joints` joins them: an elbow from the arm (its
    // axis along the drive axis) to the forearm, a platform joint from the forearm to the
    // platform, the other way round.
    let sides: Vec<JointSides> = (0..6)
        .map(|k| {
            let i = k % 3;
            let (bodies, centre, axes) = if k < 3 {
                (
                    (l.arms[i], l.forearms[i]),
                    l.elbows[i],
                    (l.axes[i], l.cross_axes[i]),
                )
            } else {
                (
                    (l.forearms[i], l.platform),
                    l.platform_points[i],
                    (l.cross_axes[i], l.axes[i]),
                )
            };
            let name = if k < 3 {
                ELBOW_JOINTS[i]
            } else {
                PLATFORM_JOINTS[i]
            };
            JointSides::new(&mech, bodies, centre, axes)
                .ok_or_else(|| TruthError::Invalid(format!("joint {name}: its bodies are not in the model")))
        })
        .collect::<Result<_, _>>()?;
    let joint_sides: [JointSides; 6] = sides.try_into().expect("six joints");
    let branches = spec.geometry.branches();
    let mut rotors = [l.platform; 3];
    let mut motors = Vec::with_capacity(3);
    let mut rotor_angles = Vec::with_capacity(3);
    for (i, law) in laws.into_iter().enumerate() {
        let b = &branches[i];
        let d = &spec.drives[i];
        let name = DRIVE_JOINTS[i];
        // Positive drive angles rotate about −n (see `ideal`).
        let axis = -b.axis;
        let j = d.rotor_inertia;
        let rotor = mech.add_body(
            RigidBody::new(
                format!("rotor {name}"),
                ROTOR_MASS,
                Matrix3::from_diagonal(&Vector3::new(j / 2.0, j / 2.0, j)),
            )
            .at(b.arm_centre)
            .oriented(&frame_z(axis)),
        );
        let rj = mech.revolute_at(
            &format!("{name} rotor"),
            Attach::Ground,
            rotor,
            b.arm_centre,
            axis,
        );
        motors.push(
            mech.drive(&format!("q{}", i + 1), rj, law, l.q[i])
                .map_err(Mr2120Error::from)?,
        );
        // An output gear on the drive axis, when the drive has a gear mesh.
        let gear = d.gear.map(|g| {
            let gear = mech.add_body(
                RigidBody::new(
                    format!("output gear {name}"),
                    GEAR_MASS,
                    Matrix3::from_diagonal(&Vector3::new(g.inertia / 2.0, g.inertia / 2.0, g.inertia)),
                )
                .at(b.arm_centre)
                .oriented(&frame_z(axis)),
            );
            mech.revolute_at(
                &format!("{name} output gear"),
                Attach::Ground,
                gear,
                b.arm_centre,
                axis,
            );
            gear
        });
        let rel = |a: Attach, c: Attach| {
            RelativeRotation::from_initial_poses(&mech, a, c, axis)
                .ok_or_else(|| TruthError::Invalid(format!("drive {name}: bad transmission axis")))
        };
        let spring = rel(Attach::Body(rotor), Attach::Body(l.arms[i]))?;
        let arm_angle = rel(Attach::Ground, Attach::Body(l.arms[i]))?;
        rotor_angles.push(rel(Attach::Ground, Attach::Body(rotor))?);
        if let (Some(g), Some(gear)) = (d.gear, gear) {
            // The spring and damper turn the output gear; the arm meets the gear's teeth.
            let shaft = rel(Attach::Body(rotor), Attach::Body(gear))?;
            let mesh = rel(Attach::Body(gear), Attach::Body(l.arms[i]))?;
            mech.add_force(Box::new(RotationalSpringDamper {
                name: format!("transmission {name}"),
                rotation: shaft,
                stiffness: d.stiffness,
                damping: d.damping,
                free_angle: 0.0,
            }));
            mech.add_force(Box::new(RotationalTorque {
                name: format!("gear mesh {name}"),
                rotation: mesh,
                law: Arc::new(move |_, theta, rate| g.torque(theta, rate)),
            }));
        } else if d.backlash > 0.0 {
            let drive = d.clone();
            mech.add_force(Box::new(RotationalTorque {
                name: format!("transmission {name} (with backlash)"),
                rotation: spring,
                law: Arc::new(move |_, theta, rate| drive.transmission_torque(theta, rate)),
            }));
        } else {
            mech.add_force(Box::new(RotationalSpringDamper {
                name: format!("transmission {name}"),
                rotation: spring,
                stiffness: d.stiffness,
                damping: d.damping,
                free_angle: 0.0,
            }));
        }
        if !d.friction.is_empty() {
            let laws = d.friction.clone();
            let q0 = l.q[i];
            mech.add_force(Box::new(RotationalTorque {
                name: format!("arm friction {name}"),
                rotation: arm_angle,
                law: Arc::new(move |t, theta, v| laws.iter().map(|f| f.torque(t, q0 + theta, v)).sum()),
            }));
        }
        rotors[i] = rotor;
    }
    let payload = match &spec.payload_body {
        None => None,
        Some(p) => {
            let at = m_build + p.offset;
            let body =
                mech.add_body(RigidBody::new("payload", p.mass, Matrix3::from_diagonal(&p.inertia)).at(at));
            match p.mount {
                PayloadMount::Rigid => {
                    mech.fixed_at("payload mount", l.platform, body, at);
                }
                PayloadMount::Spring {
                    frequency,
                    damping_ratio,
                } => {
                    let z = Vector3::z();
                    mech.prismatic_along("payload guide", l.platform, body, at, z);
                    let omega = 2.0 * std::f64::consts::PI * frequency;
                    let k = p.mass * omega * omega;
                    // Spring from a platform point `arm` below the payload; pre-loaded so the
                    // payload rests in equilibrium under gravity's component along the guide.
                    let arm = 0.05;
                    let weight = -p.mass * spec.links.gravity.dot(&z);
                    mech.add_force(Box::new(SpringDamper {
                        name: "payload mount".into(),
                        i: (Attach::Body(l.platform), p.offset - arm * z),
                        j: (Attach::Body(body), Vector3::zeros()),
                        stiffness: k,
                        damping: 2.0 * damping_ratio * p.mass * omega,
                        free_length: arm + weight / k,
                    }));
                }
            }
            Some(body)
        }
    };
    Ok(TruthModel {
        mechanism: mech,
        platform: l.platform,
        arms: l.arms,
        rotors,
        motors: motors.try_into().expect("three motors"),
        payload,
        q_build: l.q,
        rotor_angles: rotor_angles.try_into().expect("three rotors"),
        joint_sides,
    })
}

/// Body states of a sample, as force elements see them.
fn body_states(mech: &Mechanism, s: &Sample) -> Vec<BodyState> {
    mech.bodies()
        .iter()
        .map(|(h, _)| BodyState {
            r: s.body_position(h),
            p: s.body_euler_parameters(h),
            a: s.body_rotation(h),
            v: s.body_velocity(h),
            omega: s.body_angular_velocity(h),
        })
        .collect()
}

fn check_options(opts: &RecordOptions) -> Result<usize, TruthError> {
    let samples = opts.duration * opts.rate;
    if !(pos(opts.rate) && pos(opts.duration) && (2.0..1e7).contains(&samples)) {
        return Err(TruthError::Invalid(format!(
            "duration {} s at {} Hz (rate and duration must be > 0, at least 3 samples)",
            opts.duration, opts.rate
        )));
    }
    if !opts.torques && !opts.tracker {
        return Err(TruthError::Invalid("record torques, the tracker or both".into()));
    }
    let n = &opts.noise;
    if ![n.encoder, n.rate, n.torque, n.tracker]
        .iter()
        .all(|&v| nonneg(v))
    {
        return Err(TruthError::Invalid(format!("noise levels must be ≥ 0: {n:?}")));
    }
    Ok(samples.round() as usize + 1)
}

/// Simulates the truth `spec` along the platform path `path` and records it at `opts.rate`
/// for `opts.duration` (samples at t = k/rate, k = 0 … duration·rate). `seed`: `None` gives
/// the noise-free signals (systematic sensor errors included), `Some(s)` adds white noise of
/// `opts.noise` from [`Rng::new(s)`](Rng::new).
///
/// The returned [`Recorded`]:
/// * `q`, `qd`: encoder angle and rate of each **rotor** (motor side), rad and rad/s;
/// * `tau`: motor torque of each drive (the rotor driver's effort), N·m, after the torque
///   sensor's delay, scale and offset;
/// * `pose`: platform centre M after the tracker's delay, scale and offset, m;
/// * `contribution`: zeros — a simulated truth does not split the signals into effects;
/// * `min_direct_measure`: smallest direct-singularity measure of the nominal kinematics
///   along the commanded path;
/// * `torque_reversals`: sign changes of the simulated motor torques beyond
///   ±[`BACKLASH_SCALE`]; `velocity_reversals`: of the rotor rates beyond
///   ±[`FRICTION_VELOCITY`]; `tension_reversals`: of each forearm's force in the quasi-static
///   reference ([`quasi_static_reference`]) beyond ±[`CLEARANCE_SCALE`] (the constants serve
///   only as hysteresis thresholds of the counts).
pub fn simulate_truth(
    spec: &TruthSpec,
    path: &Excitation,
    opts: &RecordOptions,
    seed: Option<u64>,
) -> Result<Recorded, TruthError> {
    let run = simulate_run(spec, path, opts)?;
    let reference = quasi_static_reference(spec, path, opts)?;
    let mut out = run.sensed(spec, path, opts, seed);
    for i in 0..3 {
        out.tension_reversals[i] = reversals(&reference.tension[i], CLEARANCE_SCALE);
    }
    Ok(out)
}

/// The true (noise-free, error-free) signals of a truth simulation at the record's sample
/// times, plus the delayed channels.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthRun {
    /// Sample times t_k = k/rate, s.
    pub t: Vec<f64>,
    /// Rotor (motor) angles, rad.
    pub q: [Vec<f64>; 3],
    /// Rotor rates, rad/s.
    pub qd: [Vec<f64>; 3],
    /// Arm angles, rad.
    pub arm: [Vec<f64>; 3],
    /// Motor torques (rotor driver efforts), N·m.
    pub tau: [Vec<f64>; 3],
    /// Platform centre M, m.
    pub pose: [Vec<f64>; 3],
    /// Motor torques at t_k − torque delay, N·m.
    pub tau_delayed: [Vec<f64>; 3],
    /// Platform centre at t_k − tracker delay, m.
    pub pose_delayed: [Vec<f64>; 3],
    /// Per universal joint D, E, F, P, Q, R and sample, its play coordinates
    /// ([`JointSides::play`]): the shift of side j from side i along base x, y, z (m) and the
    /// tilt about n (rad). A joint with a bearing moves within its clearance and the balls'
    /// compression; an ideal joint stays at zero (to the constraint tolerance).
    pub joint_play: [Vec<[f64; 4]>; 6],
    /// Integrator steps (pre-roll included).
    pub steps: usize,
    /// Wall time of the simulation, s.
    pub wall_s: f64,
}

/// Simulates the truth and returns its true signals ([`TruthRun`]); [`simulate_truth`] adds
/// the sensors. Torques come from a consistent acceleration analysis at each output state
/// (not from the integrator's multipliers, which are outside its error test).
pub fn simulate_run(
    spec: &TruthSpec,
    path: &Excitation,
    opts: &RecordOptions,
) -> Result<TruthRun, TruthError> {
    let start = std::time::Instant::now();
    spec.validate()?;
    let n = check_options(opts)?;
    let dt = 1.0 / opts.rate;
    let t_end = (n - 1) as f64 * dt;
    let t0 = -spec.pre_roll();
    let cmd = spec.commanded(path);
    let laws = commanded_laws(&spec.geometry, &cmd, t0, t_end + TAIL)?;
    let model = truth_model(spec, cmd.at(t0), laws)?;
    // Output times: the record's, and the delayed channels'.
    let mut times: Vec<f64> = vec![];
    for k in 0..n {
        let t = k as f64 * dt;
        times.push(t);
        times.push(t - spec.sensors.torque_delay);
        times.push(t - spec.sensors.tracker_delay);
    }
    times.sort_by(f64::total_cmp);
    times.dedup();
    let mut o = SimulationOptions::with_tolerances(spec.solver.rtol, spec.solver.atol);
    o.bdf.h_max = spec.solver.h_max;
    o.bdf.max_steps = 1_000_000;
    // The truth reads only the run's end (a stop at a singular configuration is an error
    // here), never the samples' singularity measure: not measured at every output time.
    o.measure_singularity = false;
    if spec.joints.iter().any(Option::is_some) && spec.solver.damp_contact_rattle {
        o.formulation.velocities_index2 = true;
    }
    let mech = Arc::new(model.mechanism);
    let mut sim = Simulation::new(mech.clone(), t0, o).map_err(|source| TruthError::Simulation {
        t: t0,
        h: 0.0,
        source,
    })?;
    let traj = sim.run(&times, |_| {}).map_err(|source| TruthError::Simulation {
        t: sim_t(&sim, t0),
        h: sim.stats().last_step,
        source,
    });
    let traj = traj?;
    if let RunEnd::StoppedAtSingularity { t, measure, error } = traj.end {
        return Err(TruthError::Singular {
            t,
            measure,
            h: sim.stats().last_step,
            error,
        });
    }
    let analysis = Analysis::with_options(&mech, SimulationOptions::default().assembly)
        .map_err(|source| TruthError::Analysis { t: t0, source })?;
    let mut data = MechanismData::new(&mech);
    let mut out = TruthRun {
        t: (0..n).map(|k| k as f64 * dt).collect(),
        q: Default::default(),
        qd: Default::default(),
        arm: Default::default(),
        tau: Default::default(),
        pose: Default::default(),
        tau_delayed: Default::default(),
        pose_delayed: Default::default(),
        joint_play: Default::default(),
        steps: sim.stats().steps,
        wall_s: 0.0,
    };
    let arm_angles: Vec<RelativeRotation> = (0..3)
        .map(|i| {
            RelativeRotation::from_initial_poses(
                &mech,
                Attach::Ground,
                Attach::Body(model.arms[i]),
                -spec.geometry.branches()[i].axis,
            )
            .expect("the arms exist")
        })
        .collect();
    // Per output time: torques and pose.
    let mut tau_at = Vec::with_capacity(traj.samples.len());
    let mut pose_at = Vec::with_capacity(traj.samples.len());
    for s in &traj.samples {
        let (wdot, lambda) = analysis
            .accelerations(&mech, &mut data, s.t, &s.q, &s.w)
            .map_err(|source| TruthError::Analysis { t: s.t, source })?;
        let snap = Snapshot {
            t: s.t,
            q: s.q.clone(),
            w: s.w.clone(),
            wdot,
            lambda,
        };
        let tau: [f64; 3] =
            std::array::from_fn(|i| snap.driver_effort(&mech, model.motors[i]).unwrap_or(f64::NAN));
        tau_at.push(tau);
        pose_at.push(s.body_position(model.platform));
    }
    let find = |t: f64| {
        times
            .binary_search_by(|x| x.total_cmp(&t))
            .unwrap_or_else(|k| k.min(times.len() - 1))
    };
    for k in 0..n {
        let t = out.t[k];
        let ks = find(t);
        let s = &traj.samples[ks];
        let states = body_states(&mech, s);
        let kt = find(t - spec.sensors.torque_delay);
        let kp = find(t - spec.sensors.tracker_delay);
        for i in 0..3 {
            let (th, rate, _) = model.rotor_angles[i].evaluate(&states);
            out.q[i].push(model.q_build[i] + th);
            out.qd[i].push(rate);
            let (tha, _, _) = arm_angles[i].evaluate(&states);
            out.arm[i].push(model.q_build[i] + tha);
            out.tau[i].push(tau_at[ks][i]);
            out.pose[i].push(pose_at[ks][i]);
            out.tau_delayed[i].push(tau_at[kt][i]);
            out.pose_delayed[i].push(pose_at[kp][i]);
        }
        for (play, sides) in out.joint_play.iter_mut().zip(&model.joint_sides) {
            play.push(sides.play(s));
        }
    }
    out.wall_s = start.elapsed().as_secs_f64();
    Ok(out)
}

fn sim_t(sim: &Simulation, t0: f64) -> f64 {
    let t = sim.data().t;
    if t.is_finite() {
        t
    } else {
        t0
    }
}

/// The quasi-static multibody reference of a truth: per sample, the ideal model
/// ([`ideal_model_with`] with the spec's links; a payload body's mass added at M) with its
/// drive angles prescribed as arm angles q_a = q_m − τ/k (q_m the commanded motor angle, k
/// the drive's stiffness, τ the ideal inverse-dynamics torque at q_a with the motor's rates
/// and accelerations; fixed-point passes to convergence). Motor torque = τ + J_rotor·q̈_m. Joint
/// clearance, friction, transmission damping and dynamics, and a sprung payload's motion are
/// left out — what a quasi-static multibody nominal model would predict.
#[derive(Debug, Clone, PartialEq)]
pub struct QuasiStatic {
    /// Sample times, s.
    pub t: Vec<f64>,
    /// Commanded motor angles, rad.
    pub q: [Vec<f64>; 3],
    /// Motor torques, N·m.
    pub tau: [Vec<f64>; 3],
    /// Platform centre M, m.
    pub pose: [Vec<f64>; 3],
    /// Axial force of each forearm (tension positive), N, from the elbow joint's reaction.
    pub tension: [Vec<f64>; 3],
}

/// Computes the [`QuasiStatic`] reference of `spec` along `path` at the record's sample
/// times.
pub fn quasi_static_reference(
    spec: &TruthSpec,
    path: &Excitation,
    opts: &RecordOptions,
) -> Result<QuasiStatic, TruthError> {
    spec.validate()?;
    let n = check_options(opts)?;
    let dt = 1.0 / opts.rate;
    let t_end = (n - 1) as f64 * dt;
    let t0 = -spec.pre_roll();
    let cmd = spec.commanded(path);
    let laws = commanded_laws(&spec.geometry, &cmd, t0, t_end + TAIL)?;
    let mut links = spec.links;
    if let Some(p) = &spec.payload_body {
        links.payload += p.mass;
    }
    let placeholder = [0, 1, 2].map(|i| MotionLaw::Constant(laws[i].value(0.0)));
    let model = ideal_model_with(
        &spec.geometry,
        &spec.mass,
        &links,
        path.at(0.0),
        Some(placeholder),
    )?;
    let mech = model.mechanism;
    let drivers: Vec<DriverHandle> = mech.drivers().map(|(h, _)| h).collect();
    let elbows: Vec<_> = ELBOW_JOINTS
        .iter()
        .map(|name| {
            mech.joints()
                .find(|(_, j)| j.name == *name)
                .map(|(h, _)| h)
                .expect("the ideal model has its elbow joints")
        })
        .collect();
    let analysis = Analysis::new(&mech).map_err(|source| TruthError::Analysis { t: 0.0, source })?;
    let mut data = MechanismData::new(&mech);
    let (mut qg, mut wg) = mech.initial_guess();
    let mut tau = [0.0; 3];
    let mut out = QuasiStatic {
        t: vec![],
        q: Default::default(),
        tau: Default::default(),
        pose: Default::default(),
        tension: Default::default(),
    };
    for k in 0..n {
        let t = k as f64 * dt;
        let qm: [[f64; 3]; 3] = std::array::from_fn(|i| laws[i].eval(t));
        // Fixed point q_a = q_m − τ(q_a)/k, warm-started from the previous sample's torques;
        // its contraction factor |∂τ/∂q_a|/k grows near the direct singularity, so it runs
        // to convergence (arm angles to 1e-12 rad), not a fixed number of passes.
        let mut snap = None;
        let mut converged = false;
        for _ in 0..MAX_REFERENCE_PASSES {
            for i in 0..3 {
                let qa = qm[i][0] - tau[i] / spec.drives[i].stiffness;
                data.prescribe_driver(drivers[i], t, [qa, qm[i][1], qm[i][2]])
                    .map_err(|source| TruthError::Analysis { t, source })?;
            }
            let s = analysis
                .state_at(&mech, &mut data, t, &qg, &wg)
                .map_err(|source| TruthError::Analysis { t, source })?;
            let new: [f64; 3] =
                std::array::from_fn(|i| s.driver_effort(&mech, drivers[i]).unwrap_or(f64::NAN));
            let change = (0..3)
                .map(|i| ((new[i] - tau[i]) / spec.drives[i].stiffness).abs())
                .fold(0.0, f64::max);
            tau = new;
            qg.clone_from(&s.q);
            wg.clone_from(&s.w);
            snap = Some(s);
            if change < 1e-12 {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(TruthError::ReferenceDiverged {
                t,
                passes: MAX_REFERENCE_PASSES,
            });
        }
        let s = snap.expect("at least one pass ran");
        out.t.push(t);
        let m = s.body_position(model.platform);
        for i in 0..3 {
            out.q[i].push(qm[i][0]);
            out.tau[i].push(tau[i] + spec.drives[i].rotor_inertia * qm[i][2]);
            out.pose[i].push(m[i]);
            // Force of the elbow joint on the forearm (side j), along the forearm's x axis
            // (from D towards P): tension pulls the forearm towards D.
            let f = s
                .reaction(&mech, elbows[i])
                .map(|r| Vector3::from(r.force))
                .unwrap_or_else(|| Vector3::repeat(f64::NAN));
            let x = s.body_rotation(model.forearms[i]).column(0).into_owned();
            out.tension[i].push(-f.dot(&x));
        }
    }
    Ok(out)
}

impl TruthRun {
    /// What the sensors of `spec` record of this run ([`simulate_truth`]'s channels without
    /// the tension-reversal count of the quasi-static reference, which stays 0): encoder
    /// offsets, torque scale and offset, tracker scale and offset, and white noise from
    /// `seed` (`None`: noise-free). `path` is the run's platform path.
    pub fn sensed(
        &self,
        spec: &TruthSpec,
        path: &Excitation,
        opts: &RecordOptions,
        seed: Option<u64>,
    ) -> Recorded {
        let n = self.t.len();
        let s = &spec.sensors;
        let mut rng = seed.map(Rng::new);
        let noise = opts.noise;
        let mut normal = |sigma: f64| match rng.as_mut() {
            Some(r) => sigma * r.normal(),
            None => 0.0,
        };
        let mut out = Recorded {
            t: self.t.clone(),
            q: Default::default(),
            qd: Default::default(),
            tau: Default::default(),
            pose: Default::default(),
            contribution: std::array::from_fn(|_| vec![0.0; n]),
            min_direct_measure: f64::INFINITY,
            torque_reversals: [0; 3],
            tension_reversals: [0; 3],
            velocity_reversals: [0; 3],
        };
        for k in 0..n {
            let m = path.at(self.t[k]);
            let qc: [f64; 3] = std::array::from_fn(|i| self.q[i][k]);
            out.min_direct_measure = out
                .min_direct_measure
                .min(kinematics::singularity(&spec.geometry, qc, m).direct_measure);
            for i in 0..3 {
                out.q[i].push(self.q[i][k] + s.encoder_offset[i] + normal(noise.encoder));
                out.qd[i].push(self.qd[i][k] + normal(noise.rate));
                if opts.torques {
                    let tau = (1.0 + s.torque_scale[i]) * self.tau_delayed[i][k] + s.torque_offset[i];
                    out.tau[i].push(tau + normal(noise.torque));
                }
                if opts.tracker {
                    let x = (1.0 + s.tracker_scale[i]) * self.pose_delayed[i][k] + s.tracker_offset[i];
                    out.pose[i].push(x + normal(noise.tracker));
                }
            }
        }
        for i in 0..3 {
            out.torque_reversals[i] = reversals(&self.tau[i], BACKLASH_SCALE);
            out.velocity_reversals[i] = reversals(&self.qd[i], FRICTION_VELOCITY);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commanded_path_starts_at_rest_and_joins_the_path() {
        let path = Excitation::random(3, 0.32, 0.0);
        let cmd = CommandedPath {
            path: &path,
            ramp: 0.5,
            ramp_end: 0.0,
        };
        let c = Vector3::from(path.centre);
        assert!((cmd.at(-0.6) - c).norm() < 1e-15);
        assert!((cmd.at(0.0) - path.at(0.0)).norm() < 1e-15);
        assert!((cmd.at(0.3) - path.at(0.3)).norm() < 1e-15);
        // Smooth at the ramp's end: finite-difference accelerations agree.
        let acc =
            |f: &dyn Fn(f64) -> Vector3<f64>, t: f64, h: f64| (f(t + h) - 2.0 * f(t) + f(t - h)) / (h * h);
        let h = 1e-4;
        let a_cmd = acc(&|t| cmd.at(t), 0.0, h);
        let a_path = acc(&|t| path.at(t), 0.0, h);
        assert!(
            (a_cmd - a_path).norm() < 0.05 * a_path.norm().max(0.1),
            "{a_cmd:?} vs {a_path:?}"
        );
    }

    #[test]
    fn stribeck_law_limits() {
        let s = StribeckFriction {
            coulomb: 0.1,
            stiction: 0.3,
            stribeck_velocity: 0.02,
            exponent: 1.5,
            regularisation: 1e-3,
            viscous: 0.0,
        };
        assert!((s.torque(1.0) + 0.1).abs() < 1e-3);
        assert!((s.torque(-0.002) - 0.3 * 0.002 / (0.002f64.powi(2) + 1e-6).sqrt()).abs() < 0.02);
        assert_eq!(s.torque(0.0), 0.0);
    }

    /// The transmission: a spring-damper without backlash; with it, free within ±b, the
    /// spring on the excess beyond, damped only in contact and never pulling.
    #[test]
    fn a_transmission_with_backlash_is_free_within_its_play_and_pushes_only_beyond_it() {
        let mut d = DriveTruth::nominal();
        let (k, c) = (d.stiffness, d.damping);
        assert_eq!(d.transmission_torque(2e-5, 0.1), -k * 2e-5 - c * 0.1);
        d.backlash = 1e-5;
        assert_eq!(d.transmission_torque(5e-6, 0.1), 0.0);
        assert_eq!(d.transmission_torque(-1e-5, -3.0), 0.0);
        let f = k * 1e-5;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * f;
        assert!(close(d.transmission_torque(2e-5, 0.0), -f));
        assert!(close(d.transmission_torque(-2e-5, 0.0), f));
        // Closing, the damping adds; separating, it subtracts, down to nothing (no pull).
        let rate = 0.5 * f / c;
        assert!(close(d.transmission_torque(2e-5, rate), -1.5 * f));
        assert!(close(d.transmission_torque(2e-5, -rate), -0.5 * f));
        assert!(close(d.transmission_torque(-2e-5, rate), 0.5 * f));
        assert_eq!(d.transmission_torque(2e-5, -4.0 * rate), 0.0);
        // A backlash outside [0, MAX_BACKLASH] is refused, naming the drive.
        let mut spec = TruthSpec::nominal();
        spec.drives[1].backlash = -1e-6;
        let e = spec.validate().expect_err("negative backlash");
        assert!(
            e.to_string().contains("drive B") && e.to_string().contains("backlash"),
            "{e}"
        );
        spec.drives[1].backlash = 2.0 * MAX_BACKLASH;
        assert!(spec.validate().is_err());
    }

    /// The gear mesh: free within ±b; beyond, K·δ^1.5 at rest (1 N·m at 1 µrad for the
    /// example's flank), more while closing, less while opening, never pulling; refused with
    /// the transmission's own backlash or a bad flank, naming the drive.
    #[test]
    fn a_gear_mesh_is_free_within_its_play_and_presses_by_its_flank_law_beyond_it() {
        let g = GearMesh::example(1e-5);
        assert_eq!(g.torque(9e-6, 1.0), 0.0);
        assert_eq!(g.torque(-1e-5, -1.0), 0.0);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1.0);
        assert!(close(g.torque(1.1e-5, 0.0), -1.0), "{}", g.torque(1.1e-5, 0.0));
        assert!(close(g.torque(-1.1e-5, 0.0), 1.0));
        // Flores: χ = 8(1 − e)/(5e·v_ref) = 8 s/rad with e = 0.8 at 0.05 rad/s.
        let chi =
            8.0 * (1.0 - GEAR_MESH_RESTITUTION) / (5.0 * GEAR_MESH_RESTITUTION * GEAR_MESH_REFERENCE_RATE);
        assert!(close(chi, 8.0));
        assert!(close(g.torque(1.1e-5, 0.05), -(1.0 + chi * 0.05)));
        assert!(close(g.torque(-1.1e-5, -0.05), 1.0 + chi * 0.05));
        assert!(close(g.torque(1.1e-5, -0.05), -(1.0 - chi * 0.05)));
        assert_eq!(g.torque(1.1e-5, -1.0), 0.0);
        let mut spec = TruthSpec::nominal();
        spec.drives[2].gear = Some(g);
        spec.validate().expect("a gear mesh alone is valid");
        spec.drives[2].backlash = 1e-5;
        let e = spec.validate().expect_err("two forms of backlash");
        assert!(e.to_string().contains("drive C"), "{e}");
        spec.drives[2].backlash = 0.0;
        spec.drives[2].gear = Some(GearMesh { inertia: 0.0, ..g });
        assert!(spec.validate().is_err());
        spec.drives[2].gear = Some(GearMesh {
            law: NormalLaw::Flores {
                k: 1e9,
                n: 1.5,
                restitution: 1.5,
                v_ref: 0.05,
            },
            ..g
        });
        let e = spec.validate().expect_err("restitution above 1");
        assert!(
            e.to_string().contains("drive C") && e.to_string().contains("flank"),
            "{e}"
        );
    }
}
