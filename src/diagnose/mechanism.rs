//! Any mechanism built with the multibody API as a nominal model for the diagnosis
//! (equation error): the drive torques at each measured sample come from the multibody
//! inverse dynamics — assembly, velocity and acceleration analysis with the drivers set to
//! the measured joint positions, rates and accelerations — and the driver multipliers.
//!
//! The user supplies a builder that makes the mechanism for given parameter values and
//! attaches its drivers with the motion laws it is handed (one per measured joint, in the
//! order of the torque channels: the j-th driver added serves channel j); the parameters are
//! named, with units, nominal values and scales, so the candidate library can perturb them.
//! [`MechanismModel::new`] builds the mechanism once with the nominal values and refuses a
//! builder that fails or attaches a wrong number of drivers.
//! At each sample the measured motion is prescribed to the drivers in the mechanism's
//! [`MechanismData`] ([`MechanismData::prescribe_driver`]), and the torques are the drivers'
//! efforts ([`MechanismData::driver_effort`]).
//!
//! **Sensors are declared, not assumed** ([`Sensors`]): where each joint's encoder sits
//! ([`EncoderPlacement`]: on the joint, or on the motor behind a compliant transmission whose
//! compliance is a model parameter, with the motor's reflected rotor inertia), and which body
//! points a tracker measures ([`PointSensor`], the output channels). With a motor-side
//! encoder the joint lags its encoder by the transmission's wind-up c·τ under the joint-side
//! torque τ (quasi-static: solved at every sample by fixed-point passes, warm-started from
//! the previous sample), and the torque sensor (the motor current) reads τ + J·q̈.
//!
//! **Joints with play** ([`MechanismModel::with_play`]): for each declared universal joint
//! the model gives the diagnosis how its outputs move when the joint sits off-centre in its
//! clearance — the first-order sensitivities of the assembled configuration to offsets of
//! the joint's constraints ([`Analysis::constraint_offset_sensitivity`]) — and the joint's
//! force and moment, from which the play model of the contact layer
//! ([`crate::contact::play`]) tells which way the clearance lets it sit.
//!
//! ```
//! use lash::diagnose::mechanism::MechanismModel;
//! use lash::diagnose::model::{InverseDynamicsModel, ModelParameter, ParameterFamily};
//! use lash::multibody::{Attach, Mechanism, MotionLaw, RigidBody};
//! use nalgebra::{Matrix3, Vector3};
//! use std::sync::Arc;
//!
//! // A pendulum of mass m (the parameter) on a driven revolute joint about y.
//! let model = MechanismModel::new(
//!     "pendulum",
//!     vec!["joint 1".into()],
//!     vec![ModelParameter {
//!         name: "bob mass".into(),
//!         unit: "kg".into(),
//!         nominal: 1.0,
//!         scale: 1.0,
//!         family: ParameterFamily::MassProperties,
//!     }],
//!     Arc::new(|theta: &[f64], laws: &[MotionLaw]| {
//!         let mut m = Mechanism::new();
//!         let bob = m.add_body(
//!             RigidBody::new("bob", theta[0], Matrix3::identity() * 1e-3).at(Vector3::new(0.0, 0.0, -0.5)),
//!         );
//!         let j = m.revolute_at("pivot", Attach::Ground, bob, Vector3::zeros(), Vector3::y());
//!         m.drive("q1", j, laws[0].clone(), 0.0)?;
//!         Ok(m)
//!     }),
//! )?;
//! let mut tau = [0.0];
//! // Held at 90° the drive carries the weight: m g r = 1 · 9.81 · 0.5 N·m.
//! model.torques(&[1.0], &[std::f64::consts::FRAC_PI_2], &[0.0], &[0.0], &mut tau);
//! assert!((tau[0].abs() - 9.81 * 0.5).abs() < 1e-6);
//! # Ok::<(), lash::diagnose::DiagnoseError>(())
//! ```

use super::error::DiagnoseError;
use super::model::{
    ArmTorque, ColumnDefaults, DeclaredCandidate, InverseDynamicsModel, JointMotion, ModelParameter,
    OutputSensitivities, PlayData, PlayDynamics, PlayPoint, SampleState,
};
use super::transmission::{self, TransmissionDynamics};
use crate::contact::play::UniversalPlay;
use crate::multibody::{
    Analysis, BodyHandle, DriverHandle, JointHandle, JointKind, Mechanism, MechanismData, ModelError,
    MotionLaw,
};
use nalgebra::Vector3;
use std::cell::RefCell;
use std::sync::Arc;

/// Builds the mechanism for parameter values `theta`, attaching one driver per measured
/// joint with the laws given (in channel order).
pub type MechanismBuilder = Arc<dyn Fn(&[f64], &[MotionLaw]) -> Result<Mechanism, ModelError> + Send + Sync>;

/// Tags a sample's configuration for the localisation (e.g. "near the direct-kinematics
/// singularity"), from the joint positions and the outputs.
pub type ConfigurationTagger = Arc<dyn Fn(&[f64], &[f64]) -> Option<String> + Send + Sync>;

/// How much compliance in drive coordinates, rad/(N·m), one unit of a [`SeriesCompliance`]'s
/// parameter adds at a configuration: a function of the drive positions and the outputs
/// (e.g. a tracked platform position).
pub type SeriesGain = Arc<dyn Fn(&[f64], &[f64]) -> f64 + Send + Sync>;

/// A compliance in series with a drive's transmission whose value in drive coordinates
/// depends on the configuration: e.g. the contact compliance of a leg's joints, c (m/N), which
/// a drive sees as c/ℓ'(q)² (ℓ' how fast the drive stretches the leg). The transmission of
/// `drive` then has compliance θ\[its own\] + Σ θ\[`parameter`\]·`gain`(q, y), taken at the
/// previous sample's configuration along a recording.
#[derive(Clone)]
pub struct SeriesCompliance {
    /// Torque channel (driver order) of the drive it acts on; its encoder must sit on the
    /// motor side.
    pub drive: usize,
    /// Index of the compliance among the model's parameters (nominal 0: rigid).
    pub parameter: usize,
    /// Drive-coordinate compliance per unit of the parameter at a configuration.
    pub gain: SeriesGain,
}

impl std::fmt::Debug for SeriesCompliance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SeriesCompliance")
            .field("drive", &self.drive)
            .field("parameter", &self.parameter)
            .finish_non_exhaustive()
    }
}

/// Where a joint's position sensor sits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EncoderPlacement {
    /// On the joint itself: the recorded position is the joint's.
    JointSide,
    /// On the motor, behind a compliant transmission (a torsion spring of compliance c, the
    /// value of parameter `compliance` in rad/(N·m), with a damper): the joint lags the
    /// encoder by the wind-up w, and the torque sensor reads the transmitted torque
    /// w/c + d·ẇ plus J·q̈ (J the rotor inertia reflected to the joint, kg·m²). Along a
    /// recording ([`InverseDynamicsModel::evaluate_at`]) the wind-up follows its own dynamics
    /// (see [`MechanismModel`]); at a lone sample it is quasi-static, w = c·τ.
    MotorSide {
        /// Index of the transmission's compliance among the model's parameters.
        compliance: usize,
        /// Reflected rotor inertia, kg·m².
        rotor_inertia: f64,
        /// Damping of the transmission's torsion, N·m·s/rad.
        damping: f64,
    },
}

/// An output channel: one coordinate of a body point in the base frame (a tracker).
#[derive(Debug, Clone, PartialEq)]
pub struct PointSensor {
    /// Name for reports, e.g. "platform x".
    pub name: String,
    /// Recording role (the column name `--map` uses), e.g. "x".
    pub role: String,
    /// The body's name in the mechanism.
    pub body: String,
    /// The point, body frame, m.
    pub point: Vector3<f64>,
    /// Base-frame axis measured: 0, 1 or 2 (x, y, z).
    pub axis: usize,
}

/// The sensors of a mechanism model: one encoder placement per torque channel, and the
/// output channels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sensors {
    /// Per torque channel (driver order); empty: every encoder on its joint.
    pub encoders: Vec<EncoderPlacement>,
    /// Output channels.
    pub outputs: Vec<PointSensor>,
}

/// A universal joint whose clearance the diagnosis may test.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaySite {
    /// The joint's name in the mechanism.
    pub joint: String,
    /// Its play geometry (bearing spacing).
    pub play: UniversalPlay,
    /// Mass of its cross, kg (in the nominal model it is part of a link; the reduced play
    /// model lets it move between the joint's sides).
    pub cross_mass: f64,
    /// The model's parameters (indices) that are this joint's contact compliance: what its
    /// balls' compression reads as where the diagnosis resolves no play
    /// ([`InverseDynamicsModel::play_site_compliance`]). May be empty.
    pub compliance: Vec<usize>,
}

struct Built {
    theta: Vec<f64>,
    model: Mechanism,
    data: MechanismData,
    analysis: Analysis,
    /// The drivers, in channel order.
    drivers: Vec<DriverHandle>,
    /// The play sites' joints.
    play_joints: Vec<JointHandle>,
    /// The output sensors' bodies.
    sensor_bodies: Vec<BodyHandle>,
    /// Where the walk along a recording stands.
    walk: WalkState,
}

/// Where a [`Built`] mechanism's walk along a recording stands after the last sample it
/// evaluated: what the next sample warm-starts from and carries on (a
/// [`Checkpoint`] keeps a copy to put back).
#[derive(Debug, Clone)]
struct WalkState {
    /// Assembled positions (7 per body: position, unit quaternion).
    q: Vec<f64>,
    /// Body velocities (6 per body).
    w: Vec<f64>,
    /// Joint positions of the last assembled configuration.
    last: Vec<f64>,
    /// Transmission wind-up (encoder − joint, rad) at the last two samples evaluated (the
    /// warm start extrapolates them).
    windup: [Vec<f64>; 2],
    /// Encoder positions of the last sample evaluated.
    last_encoder: Vec<f64>,
    /// The transmissions' state along a recording (time, w, ẇ, ẅ, sensed torques).
    dynamic: Option<Windup>,
}

/// A play joint's loads at a sample's arm motion ([`MechanismModel::play_loads`]).
struct PlayLoad {
    /// The reaction on side j at the joint's origin, N (base frame).
    force: Vector3<f64>,
    /// Its moment, N·m (base frame).
    moment: Vector3<f64>,
    /// g − a_i: gravity less the acceleration of side i's point at the joint's origin, m/s²
    /// (base frame) — per kilogram, what carries a mass that rides with side i there.
    carried: Vector3<f64>,
}

/// A point off a sample for [`MechanismModel::offset_differences_about`]: offsets of the
/// perturbed constraint rows (m, or rad) and each arm's extra lag behind its encoder (rad,
/// or m).
struct OffsetBase {
    offsets: Vec<f64>,
    lag: Vec<f64>,
}

/// What [`MechanismModel::offset_differences_about`] returns: the columns, the torques and
/// loads then the outputs at the point, and at the sample (empty where the point is the
/// sample).
type OffsetColumns = (Vec<Vec<f64>>, Vec<f64>, Vec<f64>);

/// The transmissions' wind-up state at one sample of a recording.
#[derive(Debug, Clone)]
struct Windup {
    t: f64,
    w: nalgebra::DVector<f64>,
    wd: nalgebra::DVector<f64>,
    wdd: nalgebra::DVector<f64>,
    /// Joint-side torques τ_s at this sample (None at a quasi-static start: the step then
    /// holds the next sample's).
    tau_s: Option<nalgebra::DVector<f64>>,
    tau: Vec<f64>,
    /// The mass matrix in drive coordinates at this sample (None at a quasi-static start).
    m: Option<nalgebra::DMatrix<f64>>,
    /// Quasi-static wind-up at this sample.
    w_qs: nalgebra::DVector<f64>,
    /// Where a dynamic step left the arms: positions, rates and accelerations (None at the
    /// quasi-static start).
    arm: Option<[Vec<f64>; 3]>,
    /// Time of the recording's first sample, s.
    start: f64,
    /// Quasi-static samples so far at the start of the recording (the dynamics runs from the
    /// fourth sample on: 3).
    started: usize,
}

/// What [`InverseDynamicsModel::sample_state`] keeps of the cache after a sample along a
/// recording: the parameter values it was built for, its assembled state, the drive
/// positions and the transmissions' wind-up. Everything else a later question about the
/// sample reads (the joints' loads, the play's differences) is computed from these again.
#[derive(Debug, Clone)]
struct Checkpoint {
    theta: Vec<f64>,
    walk: WalkState,
}

/// Largest joint-position change (rad or m) assembled in one Newton solve; larger jumps
/// between samples are walked in steps (continuation), so assembly stays on its branch.
pub const CONTINUATION_STEP: f64 = 0.1;

/// Step of the central differences in a play joint's constraint offsets and the arms'
/// positions for [`InverseDynamicsModel::play_dynamics`] (m for a shift, rad for a tilt or
/// an arm).
pub const PLAY_OFFSET_STEP: f64 = 1e-6;

/// Step of the central differences of the play joints' offset rates and the arms' rates
/// (m/s, or rad/s): the inverse dynamics is quadratic in the rates, so the differences are
/// exact but for rounding; a step well above it.
pub const PLAY_RATE_STEP: f64 = 1e-3;

/// Step of the central differences of the joint-side torques in the arm positions, rad
/// ([`TransmissionDynamics::load_stiffness`]).
pub const LOAD_STIFFNESS_STEP: f64 = 1e-6;

/// Full inverse-dynamics passes of the transmission wind-up continue until it changes by
/// less than this, rad; a last position-only pass then places the joints (see
/// [`MechanismModel`]'s sample evaluation).
pub const WINDUP_REFINE: f64 = 1e-6;

/// Largest time step between samples of one recording over which the transmission
/// dynamics is integrated, s; a larger gap starts quasi-statically (the candidates'
/// responses use the same, [`transmission::MAX_GAP`]).
pub const WINDUP_MAX_GAP: f64 = transmission::MAX_GAP;

/// Evaluations of the joint-side torques per sample along a recording: at the predicted
/// wind-up, then at the wind-up the step arrives at (the torques' dependence on the joint
/// positions is iterated, not linearised). Measured on a noise-free simulated MR2120 at
/// 500 Hz passing near its direct singularity (suite recording 5, 2.75–3.0 s): with one
/// evaluation the model's torques were off by 0.043 N·m RMS there (twice the suite's torque
/// noise; 0.0099 N·m over the 5 s), with two 0.013 N·m (0.0034 N·m), with three or eight
/// the same; at 1 kHz with two, 0.0026 N·m.
pub const WINDUP_CORRECTIONS: usize = 2;

/// Start transient of the transmission dynamics, s: along a recording the first samples
/// within this time of its start carry no weight (the wind-up's initial rate is not known;
/// on simulated MR2120 recordings the start error was 0.018 N m RMS over 0.3–0.5 s under a
/// 0.5 kg payload, 0.001 N m after).
pub const WINDUP_SETTLING: f64 = 0.5;

/// Central-difference step of the parameter sensitivities, relative to each parameter's
/// scale: large against the assembly tolerance (1e-12), small
/// enough that the truncation error (∝ step²) stays below 1e-8 relative.
pub const PARAMETER_STEP: f64 = 1e-4;

/// At most this many wind-up passes per sample.
pub const WINDUP_PASSES: usize = 30;

/// A mechanism built with the multibody API, seen by the diagnosis.
pub struct MechanismModel {
    name: String,
    joints: Vec<String>,
    parameters: Vec<ModelParameter>,
    builder: MechanismBuilder,
    sensors: Sensors,
    play: Vec<PlaySite>,
    tagger: Option<ConfigurationTagger>,
    series: Vec<SeriesCompliance>,
    windows: Option<Vec<usize>>,
    columns: ColumnDefaults,
    /// Whether each channel's joint turns or slides (from the nominal mechanism's drivers).
    motions: Vec<JointMotion>,
    /// Candidates the model declares (perturbing some of its parameters together).
    declared: Vec<DeclaredCandidate>,
    /// Friction on the arms, part of the load the drives carry (None: none).
    arm_torque: Option<ArmTorque>,
    /// The mechanism built for the last parameter values, with its data (a cache: the
    /// diagnosis asks for torques through `&self`).
    built: RefCell<Option<Built>>,
}

impl std::fmt::Debug for MechanismModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MechanismModel")
            .field("name", &self.name)
            .field("joints", &self.joints)
            .field("parameters", &self.parameters)
            .field("sensors", &self.sensors)
            .field("play", &self.play)
            .finish_non_exhaustive()
    }
}

/// The same model with an empty cache (the copy builds its mechanism when first evaluated).
impl Clone for MechanismModel {
    fn clone(&self) -> Self {
        Self {
            name: self.name.clone(),
            joints: self.joints.clone(),
            parameters: self.parameters.clone(),
            builder: self.builder.clone(),
            sensors: self.sensors.clone(),
            play: self.play.clone(),
            tagger: self.tagger.clone(),
            series: self.series.clone(),
            windows: self.windows.clone(),
            columns: self.columns.clone(),
            motions: self.motions.clone(),
            declared: self.declared.clone(),
            arm_torque: self.arm_torque.clone(),
            built: RefCell::new(None),
        }
    }
}

impl MechanismModel {
    /// A model named `name` with torque channels `joints` (names, one per driver), the
    /// perturbable `parameters` and the `builder`; every encoder on its joint, no outputs.
    /// Builds the mechanism with the nominal parameter values; fails
    /// ([`DiagnoseError::Model`], naming the cause) if the builder fails, the mechanism is
    /// invalid or it has not one driver per torque channel.
    pub fn new(
        name: &str,
        joints: Vec<String>,
        parameters: Vec<ModelParameter>,
        builder: MechanismBuilder,
    ) -> Result<Self, DiagnoseError> {
        let mut m = Self {
            name: name.into(),
            joints,
            parameters,
            builder,
            sensors: Sensors::default(),
            play: vec![],
            tagger: None,
            series: vec![],
            windows: None,
            columns: ColumnDefaults::RoleNames,
            motions: vec![],
            declared: vec![],
            arm_torque: None,
            built: RefCell::new(None),
        };
        m.ensure(&m.nominal())
            .map_err(|message| m.error(format!("with the nominal parameters: {message}")))?;
        m.motions = {
            let b = m.built.borrow();
            let built = b.as_ref().expect("ensure built the nominal mechanism");
            built
                .drivers
                .iter()
                .map(|&h| {
                    let kind = built
                        .model
                        .driver(h)
                        .and_then(|d| built.model.joint(d.joint))
                        .map(|j| j.kind);
                    if kind == Some(JointKind::Prismatic) {
                        JointMotion::Linear
                    } else {
                        JointMotion::Rotary
                    }
                })
                .collect()
        };
        Ok(m)
    }

    fn nominal(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.nominal).collect()
    }

    fn error(&self, message: String) -> DiagnoseError {
        DiagnoseError::Model {
            model: self.name.clone(),
            message,
        }
    }

    /// Declares candidates of the model's own: each perturbs some of its parameters together
    /// (indices into the parameters). Fails ([`DiagnoseError::Model`]) for an index out of
    /// range, an empty candidate, or bounds that do not match the parameters.
    pub fn with_declared_candidates(
        mut self,
        declared: Vec<DeclaredCandidate>,
    ) -> Result<Self, DiagnoseError> {
        for g in &declared {
            if g.parameters.is_empty()
                || g.parameters.len() != g.bounds.len()
                || g.parameters.iter().any(|&k| k >= self.parameters.len())
            {
                return Err(self.error(format!(
                    "candidate '{}': its parameters must be one or more of the model's {} parameters, each with bounds",
                    g.name,
                    self.parameters.len()
                )));
            }
        }
        self.declared = declared;
        Ok(self)
    }

    /// Declares the sensors. Fails ([`DiagnoseError::Model`]) for an encoder list whose
    /// length is not the number of torque channels, a compliance that names no parameter, a
    /// negative or non-finite rotor inertia, a sensor on a body the mechanism does not have,
    /// or an axis other than 0, 1, 2.
    pub fn with_sensors(mut self, sensors: Sensors) -> Result<Self, DiagnoseError> {
        if !sensors.encoders.is_empty() && sensors.encoders.len() != self.joints.len() {
            return Err(self.error(format!(
                "{} encoder placements for {} torque channels (one per channel, in channel order)",
                sensors.encoders.len(),
                self.joints.len()
            )));
        }
        for (j, e) in sensors.encoders.iter().enumerate() {
            if let EncoderPlacement::MotorSide {
                compliance,
                rotor_inertia,
                damping,
            } = *e
            {
                if !(damping.is_finite() && damping >= 0.0) {
                    return Err(self.error(format!(
                        "the transmission damping of {} must be finite and ≥ 0 N m s/rad, got {damping}",
                        self.joints[j]
                    )));
                }
                if compliance >= self.parameters.len() {
                    return Err(self.error(format!(
                        "the encoder of {} names compliance parameter {compliance}, but the model has {} parameters",
                        self.joints[j],
                        self.parameters.len()
                    )));
                }
                if !(rotor_inertia.is_finite() && rotor_inertia >= 0.0) {
                    return Err(self.error(format!(
                        "the rotor inertia of {} must be finite and ≥ 0 kg m², got {rotor_inertia}",
                        self.joints[j]
                    )));
                }
            }
        }
        {
            for s in &sensors.outputs {
                if s.axis > 2 || !s.point.iter().all(|v| v.is_finite()) {
                    return Err(self.error(format!(
                        "output sensor '{}': axis must be 0, 1 or 2 (x, y, z) and the point finite",
                        s.name
                    )));
                }
            }
        }
        self.sensors = sensors;
        *self.built.borrow_mut() = None;
        self.ensure(&self.nominal()).map_err(|m| self.error(m))?;
        Ok(self)
    }

    /// Declares universal joints whose clearance the diagnosis may test. Fails
    /// ([`DiagnoseError::Model`]) for a joint the mechanism does not have or that is not a
    /// universal joint (the play of other kinds is not modelled yet), or a bearing spacing
    /// that is not positive.
    pub fn with_play(mut self, sites: Vec<PlaySite>) -> Result<Self, DiagnoseError> {
        {
            let b = self.built.borrow();
            let Some(built) = b.as_ref() else {
                return Err(self.error("the mechanism is not built".into()));
            };
            for s in &sites {
                let Some((_, j)) = built.model.joints().find(|(_, j)| j.name == s.joint) else {
                    return Err(self.error(format!("no joint named '{}' for a play site", s.joint)));
                };
                if j.kind != JointKind::Universal {
                    return Err(self.error(format!(
                        "joint '{}' is a {:?} joint: only the play of universal joints is modelled",
                        s.joint, j.kind
                    )));
                }
                if let Some(k) = s.compliance.iter().find(|&&k| k >= self.parameters.len()) {
                    return Err(self.error(format!(
                        "joint '{}': its compliance is parameter {k}, but the model has {} parameters",
                        s.joint,
                        self.parameters.len()
                    )));
                }
                if !(s.play.ball_spacing.is_finite() && s.play.ball_spacing > 0.0) {
                    return Err(self.error(format!(
                        "joint '{}': the bearing spacing must be positive, got {} m",
                        s.joint, s.play.ball_spacing
                    )));
                }
            }
        }
        self.play = sites;
        *self.built.borrow_mut() = None;
        self.ensure(&self.nominal()).map_err(|m| self.error(m))?;
        Ok(self)
    }

    /// Declares compliances in series with the drives' transmissions
    /// ([`SeriesCompliance`]). Fails ([`DiagnoseError::Model`]) for a drive that is not a
    /// torque channel or whose encoder is not on the motor side, or a parameter the model
    /// does not have.
    pub fn with_series_compliance(mut self, series: Vec<SeriesCompliance>) -> Result<Self, DiagnoseError> {
        for s in &series {
            if !matches!(
                self.sensors.encoders.get(s.drive),
                Some(EncoderPlacement::MotorSide { .. })
            ) {
                return Err(self.error(format!(
                    "a series compliance acts on drive {}, which has no motor-side encoder (declare the sensors first)",
                    s.drive
                )));
            }
            if s.parameter >= self.parameters.len() {
                return Err(self.error(format!(
                    "a series compliance names parameter {}, but the model has {} parameters",
                    s.parameter,
                    self.parameters.len()
                )));
            }
        }
        self.series = series;
        Ok(self)
    }

    /// The same model with `torque` on the arms' side of the drives: part of the load the
    /// transmissions carry, so with compliant drives it winds them up inside the model's own
    /// wind-up dynamics (at the arms' rates, the encoders' less the wind-up's), and with
    /// rigid ones it adds to the torques. The diagnosis moves friction it found into the
    /// model this way before it linearises again ([`InverseDynamicsModel::with_arm_torque`]).
    pub fn arm_torque_model(&self, torque: ArmTorque) -> Self {
        Self {
            arm_torque: Some(torque),
            ..self.clone()
        }
    }

    /// The joint-side torques at the arms' motion with the arms' friction
    /// ([`Self::arm_torque_model`]) added.
    fn loads(&self, built: &mut Built, qa: &[f64], qda: &[f64], qdd: &[f64]) -> Option<Vec<f64>> {
        let mut tau = Self::joint_torques(built, qa, qda, qdd)?;
        if let Some(f) = &self.arm_torque {
            for (j, x) in tau.iter_mut().enumerate() {
                *x += f(j, qda[j]);
            }
        }
        Some(tau)
    }

    /// Tags configurations for the localisation.
    pub fn with_tagger(mut self, tagger: ConfigurationTagger) -> Self {
        self.tagger = Some(tagger);
        self
    }

    /// Which recording column each role reads when the user maps none (default: each role
    /// the column of its own name, [`ColumnDefaults::RoleNames`]).
    pub fn with_column_defaults(mut self, columns: ColumnDefaults) -> Self {
        self.columns = columns;
        self
    }

    /// The half-widths (samples) of rate differentiation the cross-validation tries.
    pub fn with_derivative_windows(mut self, windows: Vec<usize>) -> Self {
        self.windows = Some(windows);
        self
    }

    /// The declared sensors.
    pub fn sensors(&self) -> &Sensors {
        &self.sensors
    }

    /// Builds (or reuses) the mechanism for `theta`; the error names the cause.
    fn ensure(&self, theta: &[f64]) -> Result<(), String> {
        let mut b = self.built.borrow_mut();
        if b.as_ref().is_some_and(|x| x.theta == theta) {
            return Ok(());
        }
        // Placeholder laws: every analysis below prescribes the drivers' motion in the data.
        let laws = vec![MotionLaw::Constant(0.0); self.joints.len()];
        let model = (self.builder)(theta, &laws).map_err(|e| format!("the builder failed: {e}"))?;
        let analysis = Analysis::new(&model).map_err(|e| format!("invalid mechanism: {e}"))?;
        let drivers: Vec<DriverHandle> = model.drivers().map(|(h, _)| h).collect();
        if drivers.len() != self.joints.len() {
            return Err(format!(
                "the builder attached {} drivers for {} torque channels (one driver per measured joint, in channel order)",
                drivers.len(),
                self.joints.len()
            ));
        }
        let play_joints = self
            .play
            .iter()
            .map(|s| {
                model
                    .joints()
                    .find(|(_, j)| j.name == s.joint)
                    .map(|(h, _)| h)
                    .ok_or_else(|| format!("no joint named '{}' for a play site", s.joint))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let sensor_bodies = self
            .sensors
            .outputs
            .iter()
            .map(|s| {
                model
                    .bodies()
                    .bodies
                    .iter()
                    .position(|b| b.name == s.body)
                    .map(BodyHandle::from_index)
                    .ok_or_else(|| {
                        format!(
                            "output sensor '{}' sits on body '{}', which the mechanism does not have",
                            s.name, s.body
                        )
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let (q, w) = model.initial_guess();
        let data = MechanismData::new(&model);
        let n = self.joints.len();
        *b = Some(Built {
            theta: theta.to_vec(),
            model,
            data,
            analysis,
            drivers,
            play_joints,
            sensor_bodies,
            walk: WalkState {
                q,
                w,
                last: vec![0.0; n],
                windup: [vec![0.0; n], vec![0.0; n]],
                last_encoder: vec![f64::NAN; n],
                dynamic: None,
            },
        });
        Ok(())
    }

    /// Assembles the mechanism (positions only) with the joints at `qa` (their rates and
    /// accelerations prescribed too), continuing from the last configuration; the state and
    /// the last joint positions are left in `built`.
    fn place_joints(built: &mut Built, qa: &[f64], qd: &[f64], qdd: &[f64]) -> Option<()> {
        for (j, &h) in built.drivers.iter().enumerate() {
            let _ = built.data.prescribe_driver(h, 0.0, [qa[j], qd[j], qdd[j]]);
        }
        let q_new = built
            .analysis
            .assemble(&built.model, &mut built.data, 0.0, &built.walk.q)
            .ok()?;
        built.data.q.clone_from(&q_new);
        built.walk.q = q_new;
        built.walk.last = qa.to_vec();
        Some(())
    }

    /// ∂τ_s/∂q_arm at the arms' place and motion of the last dynamic step (central
    /// differences over [`LOAD_STIFFNESS_STEP`], at the arms' own rates and accelerations),
    /// N·m/rad: how the joint-side torques change when the arms lag their encoders further;
    /// the joints are placed back afterwards. None where the last
    /// sample was not a dynamic step or a difference fails.
    fn load_stiffness(built: &mut Built) -> Option<nalgebra::DMatrix<f64>> {
        let [qa, qda, qdda] = built.walk.dynamic.as_ref()?.arm.clone()?;
        let n = qa.len();
        let (q0, last0) = (built.walk.q.clone(), built.walk.last.clone());
        let mut g = nalgebra::DMatrix::zeros(n, n);
        let mut ok = true;
        'columns: for k in 0..n {
            let mut column = [vec![], vec![]];
            for (s, sign) in [1.0, -1.0].into_iter().enumerate() {
                let mut x = qa.clone();
                x[k] += sign * LOAD_STIFFNESS_STEP;
                match Self::joint_torques(built, &x, &qda, &qdda) {
                    Some(t) if t.iter().all(|v| v.is_finite()) => column[s] = t,
                    _ => {
                        ok = false;
                        break 'columns;
                    }
                }
            }
            for j in 0..n {
                g[(j, k)] = (column[0][j] - column[1][j]) / (2.0 * LOAD_STIFFNESS_STEP);
            }
        }
        built.walk.q = q0;
        built.walk.last = last0;
        Self::place_joints(built, &qa, &qda, &qdda)?;
        ok.then_some(g)
    }

    /// The transmissions' dampings, N·m·s/rad (0 for an encoder on its joint).
    fn dampings(&self, n: usize) -> Vec<f64> {
        (0..n)
            .map(|j| match self.sensors.encoders.get(j) {
                Some(EncoderPlacement::MotorSide { damping, .. }) => *damping,
                _ => 0.0,
            })
            .collect()
    }

    /// The transmission's own compliance (a parameter), rad/(N·m).
    fn compliance(&self, theta: &[f64], j: usize) -> f64 {
        match self.sensors.encoders.get(j) {
            Some(EncoderPlacement::MotorSide { compliance, .. }) => theta[*compliance],
            _ => 0.0,
        }
    }

    /// Every drive's compliance at the configuration the cache holds (drive positions
    /// `built.walk.last`, the outputs of its state): the transmission's own plus the series
    /// compliances'.
    fn compliances_at(&self, theta: &[f64], built: &Built) -> Vec<f64> {
        let n = self.joints.len();
        let mut c: Vec<f64> = (0..n).map(|j| self.compliance(theta, j)).collect();
        // The outputs only when a series compliance is not zero (its drive is a torque
        // channel: `with_series_compliance` checked it).
        let mut y: Option<Vec<f64>> = None;
        for s in self.series.iter().filter(|s| theta[s.parameter] != 0.0) {
            let y = y.get_or_insert_with(|| {
                let mut y = vec![0.0; self.sensors.outputs.len()];
                Self::outputs_of(&self.sensors, built, &mut y);
                y
            });
            let g = (s.gain)(&built.walk.last, y);
            if g.is_finite() {
                c[s.drive] += theta[s.parameter] * g;
            }
        }
        c
    }

    /// Leaves the sample at encoder positions `q` in the cache: the one last evaluated along
    /// a recording (with its wind-up state) if it is that one, else a lone sample.
    fn ensure_sample(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64]) -> Option<()> {
        let current = {
            let b = self.built.borrow();
            b.as_ref().is_some_and(|x| {
                x.theta == theta
                    && x.walk.dynamic.is_some()
                    && (0..q.len()).all(|j| x.walk.last_encoder[j] == q[j])
            })
        };
        if !current {
            self.sample(None, theta, q, qd, qdd)?;
        }
        Some(())
    }

    /// The play joints' constraint rows, four each (point along x, y, z; perpendicularity).
    fn play_rows(built: &Built) -> Vec<usize> {
        let lay = built.model.layout();
        built
            .play_joints
            .iter()
            .flat_map(|&jh| {
                let r = lay.joint_lambda(jh);
                r.start..r.start + 4
            })
            .collect()
    }

    /// The trunnion axes (z_i, z_j) of universal joint `jh` at the cached state (unit, base
    /// frame).
    fn trunnion_axes(built: &Built, jh: JointHandle) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let joint = built.model.joint(jh)?;
        let axis = |side: crate::multibody::Attach, a: Vector3<f64>| match side {
            crate::multibody::Attach::Ground => a,
            crate::multibody::Attach::Body(h) => built.data.body_rotation(h) * a,
        };
        Some((
            axis(joint.body_i, joint.frame_i.axes.column(2).into()),
            axis(joint.body_j, joint.frame_j.axes.column(2).into()),
        ))
    }

    /// The arms' motion of the cached sample: positions, rates and accelerations (the
    /// encoders' less the wind-up's, where the model integrates one; else the encoders'
    /// motion, `built.walk.last`).
    fn arm_motion(built: &Built, qd: &[f64], qdd: &[f64]) -> [Vec<f64>; 3] {
        built
            .walk
            .dynamic
            .as_ref()
            .and_then(|d| d.arm.clone())
            .unwrap_or_else(|| [built.walk.last.clone(), qd.to_vec(), qdd.to_vec()])
    }

    /// Runs `f` on the cache, then puts the cached sample back: its assembled positions and
    /// velocities, its drive positions, the joints placed at the arms' motion `arm`
    /// ([`Self::arm_motion`]). None if placing them back fails.
    fn keeping_sample<T>(
        built: &mut Built,
        arm: &[Vec<f64>; 3],
        f: impl FnOnce(&mut Built) -> T,
    ) -> Option<T> {
        let (q0, w0, last0) = (
            built.walk.q.clone(),
            built.walk.w.clone(),
            built.walk.last.clone(),
        );
        let out = f(built);
        built.walk.q = q0;
        built.walk.w = w0;
        built.walk.last = last0;
        Self::place_joints(built, &arm[0], &arm[1], &arm[2])?;
        Some(out)
    }

    /// [`PlayLoad::carried`] of play joint `jh` at the state `built.data` holds: gravity less
    /// the acceleration of side i's point at the joint's origin, m/s² (base frame).
    fn carried(built: &Built, jh: JointHandle) -> Option<Vector3<f64>> {
        let joint = built.model.joint(jh)?;
        let a = built
            .data
            .point_acceleration(joint.body_i, &joint.frame_i.origin)?;
        Some(built.model.gravity() - a)
    }

    /// The play joints' reactions (force in N, moment in N·m; on side j, base frame) and what
    /// carries a mass riding with their side i ([`PlayLoad::carried`]) at the arms'
    /// motion of the cached sample: the inverse dynamics evaluated afresh at the arms'
    /// positions, rates and accelerations — the encoders' less the wind-up where the model
    /// integrates one. The cached multipliers will not do: the wind-up integration takes them
    /// at the encoders' accelerations (while the transmissions ring near a singular position
    /// the arms' differ by enough to move a joint's load by some 100 N), and perturbation
    /// passes leave theirs. The cache is put back afterwards.
    fn play_loads(built: &mut Built, qd: &[f64], qdd: &[f64]) -> Option<Vec<PlayLoad>> {
        let arm = Self::arm_motion(built, qd, qdd);
        Self::keeping_sample(built, &arm, |built| {
            Self::joint_torques(built, &arm[0], &arm[1], &arm[2])?;
            built
                .play_joints
                .iter()
                .map(|&jh| {
                    let r = built.data.reaction(&built.model, jh)?;
                    Some(PlayLoad {
                        force: Vector3::from(r.force),
                        moment: Vector3::from(r.torque),
                        carried: Self::carried(built, jh)?,
                    })
                })
                .collect::<Option<Vec<_>>>()
        })?
    }

    /// Play site `site`'s [`PlayDynamics`] from the columns of [`Self::offset_differences`]
    /// over `np` sites' rows, its own at `slot`: its axes (z_i, z_j, n), its reaction Λ, what
    /// carries its cross ([`PlayLoad::carried`]).
    fn coupling(
        &self,
        site: usize,
        (slot, np): (usize, usize),
        (z_i, z_j, n): &(Vector3<f64>, Vector3<f64>, Vector3<f64>),
        lam: [f64; 4],
        carried: &Vector3<f64>,
        d: &[Vec<f64>],
    ) -> PlayDynamics {
        let nj = self.joints.len();
        // The tilt's sign: the perpendicularity row's offset is −φ.
        let sign = |c: usize| if c == 3 { -1.0 } else { 1.0 };
        let reaction = |v: &[f64]| -> [f64; 4] {
            let l = &v[nj + 6 * site..nj + 6 * site + 6];
            [l[0], l[1], l[2], Vector3::new(l[3], l[4], l[5]).dot(n)]
        };
        let scaled = |v: [f64; 4], s: f64| v.map(|x| s * x);
        let off = |c: usize| &d[4 * slot + c];
        let acc = |c: usize| &d[4 * np + 4 * slot + c];
        // The rates' columns follow the accelerations' (offsets, then arms).
        let rates = 8 * np + 2 * nj;
        let rate = |c: usize| &d[rates + 4 * slot + c];
        PlayDynamics {
            z_i: *z_i,
            z_j: *z_j,
            play: self.play[site].play,
            cross_mass: self.play[site].cross_mass,
            cross_load: (self.play[site].cross_mass * carried).into(),
            reaction: lam,
            torque_by_offset: std::array::from_fn(|c| off(c)[..nj].iter().map(|v| sign(c) * v).collect()),
            torque_by_offset_acceleration: std::array::from_fn(|c| {
                acc(c)[..nj].iter().map(|v| sign(c) * v).collect()
            }),
            reaction_by_offset: std::array::from_fn(|c| scaled(reaction(off(c)), sign(c))),
            reaction_by_offset_acceleration: std::array::from_fn(|c| scaled(reaction(acc(c)), sign(c))),
            reaction_by_drive: (0..nj).map(|a| reaction(&d[8 * np + a])).collect(),
            reaction_by_drive_acceleration: (0..nj).map(|a| reaction(&d[8 * np + nj + a])).collect(),
            torque_by_offset_rate: (0..4)
                .map(|c| rate(c)[..nj].iter().map(|v| sign(c) * v).collect())
                .collect(),
            reaction_by_offset_rate: (0..4).map(|c| scaled(reaction(rate(c)), sign(c))).collect(),
            reaction_by_drive_rate: (0..nj).map(|a| reaction(&d[rates + 4 * np + a])).collect(),
            torque_by_drive_rate: (0..nj).map(|a| d[rates + 4 * np + a][..nj].to_vec()).collect(),
        }
    }

    /// Derivatives of the joint-side torques and the play joints' reactions at the arms'
    /// place of the last sample, one per perturbation: each of `rows` offset by
    /// ±[`PLAY_OFFSET_STEP`] and each arm moved by ±[`PLAY_OFFSET_STEP`] (central differences
    /// of the inverse dynamics), each of `rows` and each arm accelerated by a unit (exact:
    /// the accelerations enter linearly, so one factorisation at the sample gives them all,
    /// [`Analysis::acceleration_offset_sensitivity`]), then each of `rows`' rates and each
    /// arm's rate moved by ±[`PLAY_RATE_STEP`] (central differences). In the order: offsets,
    /// offset accelerations, arm positions, arm accelerations, offset rates, arm rates. Per
    /// perturbation: the torques (one per drive), then per play joint its reaction's force and
    /// moment (base frame). The joints are placed back afterwards; None where an evaluation
    /// fails.
    fn offset_differences(
        built: &mut Built,
        sensors: &Sensors,
        rows: &[usize],
        qd: &[f64],
        qdd: &[f64],
    ) -> Option<Vec<Vec<f64>>> {
        let n = built.drivers.len();
        let base = OffsetBase {
            offsets: vec![0.0; rows.len()],
            lag: vec![0.0; n],
        };
        Self::offset_differences_about(built, sensors, rows, qd, qdd, &base).map(|(d, _, _)| d)
    }

    /// [`Self::offset_differences`] about a point off the sample: `rows` offset by
    /// `base.offsets` and the arms lagging by `base.lag` more. Also returns the torques and
    /// loads (laid out as a perturbation's) followed by the outputs (`sensors`') there and,
    /// where the point is off the sample, at the sample itself (else empty). Every path out clears the offsets it set: the cache
    /// serves the nominal model next.
    fn offset_differences_about(
        built: &mut Built,
        sensors: &Sensors,
        rows: &[usize],
        qd: &[f64],
        qdd: &[f64],
        base: &OffsetBase,
    ) -> Option<OffsetColumns> {
        let arm = Self::arm_motion(built, qd, qdd);
        if base.offsets.len() != rows.len() || base.lag.len() != arm[0].len() {
            return None;
        }
        Self::keeping_sample(built, &arm, |built| {
            let out = Self::offset_columns(built, sensors, rows, base, &arm);
            built.data.clear_constraint_offsets();
            out
        })?
    }

    /// Sets the offsets of `rows` to `offsets` (m or rad), every other row's to none.
    fn set_offsets(built: &mut Built, rows: &[usize], offsets: &[f64]) -> Option<()> {
        built.data.clear_constraint_offsets();
        for (&r, &x) in rows.iter().zip(offsets) {
            if x != 0.0 {
                built.data.set_constraint_offset(r, 0.0, [x, 0.0, 0.0]).ok()?;
            }
        }
        Some(())
    }

    /// The torques `tau` followed by each play joint's reaction (force, moment) at the
    /// cached state.
    fn with_loads(built: &Built, mut tau: Vec<f64>) -> Vec<f64> {
        for &jh in &built.play_joints {
            match built.data.reaction(&built.model, jh) {
                Some(r) => tau.extend(r.force.iter().chain(r.torque.iter())),
                None => tau.extend([f64::NAN; 6]),
            }
        }
        tau
    }

    /// `v` followed by the outputs of `sensors` at the cached state.
    fn with_outputs(sensors: &Sensors, built: &Built, mut v: Vec<f64>) -> Vec<f64> {
        let start = v.len();
        v.resize(start + sensors.outputs.len(), 0.0);
        Self::outputs_of(sensors, built, &mut v[start..]);
        v
    }

    /// The body of [`Self::offset_differences_about`] (which clears the offsets after it).
    fn offset_columns(
        built: &mut Built,
        sensors: &Sensors,
        rows: &[usize],
        base: &OffsetBase,
        arm: &[Vec<f64>; 3],
    ) -> Option<OffsetColumns> {
        // The derivatives at the arms' own accelerations: the joint-side torque is
        // τ(q_a, q̇_a, q̈_a) with q̈_a the encoder's less the wind-up's, so its derivative by
        // the arms' place carries ∂M/∂q_a·q̈_a (at the encoders' accelerations it missed
        // −∂M/∂q_a·ẅ, which near the direct singularity, where the drives ring, is a large
        // part of it: measured, diagnosis log).
        let [qa0, qda, qdda] = arm;
        let (n, nr) = (qa0.len(), rows.len());
        let qa: Vec<f64> = qa0.iter().zip(&base.lag).map(|(q, l)| q - l).collect();
        let (q0, w0) = (built.walk.q.clone(), built.walk.w.clone());
        let mut out = vec![vec![]; 2 * (nr + n)];
        // The point first. Every perturbation below starts from its configuration: one of
        // the positions assembles in a chord step or two, one of the rates in none (the
        // residual there is already within the tolerance), and the rates' velocity and
        // acceleration analyses solve with the factors of B made at the point
        // ([`Analysis::state_at`] keeps them for the same positions).
        Self::set_offsets(built, rows, &base.offsets)?;
        let tau = Self::joint_torques(built, &qa, qda, qdda)?;
        let at_point = Self::with_outputs(sensors, built, Self::with_loads(built, tau));
        let (qp, wp) = (built.walk.q.clone(), built.walk.w.clone());
        // Accelerations: exact, at the point.
        let lay = built.model.layout();
        let drivers: Vec<usize> = built
            .drivers
            .iter()
            .map(|&h| lay.driver_lambda(h))
            .collect::<Option<_>>()?;
        let joints: Vec<(&crate::multibody::Joint, usize)> = built
            .play_joints
            .iter()
            .map(|&jh| Some((built.model.joint(jh)?, lay.joint_lambda(jh).start)))
            .collect::<Option<_>>()?;
        let accelerated: Vec<usize> = rows.iter().chain(&drivers).copied().collect();
        let dl = built
            .analysis
            .acceleration_offset_sensitivity(&built.model, &mut built.data, 0.0, &qp, &wp, &accelerated)
            .ok()?;
        for (m, dl) in dl.iter().enumerate() {
            // A driver's effort is −λ of its row.
            let mut v: Vec<f64> = drivers.iter().map(|&k| -dl[k]).collect();
            for &(joint, k0) in &joints {
                let (r, _) = crate::multibody::analysis::joint_reaction(joint, k0, 0.0, &qp, dl);
                v.extend(r.force.iter().chain(r.torque.iter()));
            }
            if !v.iter().all(|x| x.is_finite()) {
                return None;
            }
            out[if m < nr { nr + m } else { 2 * nr + n + (m - nr) }] = v;
        }
        // Rates: central differences (the velocity products are quadratic in them), after
        // the accelerations' columns.
        for p in 0..nr + n {
            let mut column = [vec![], vec![]];
            for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
                let mut rates = qda.clone();
                built.walk.q.clone_from(&qp);
                built.walk.w.clone_from(&wp);
                Self::set_offsets(built, rows, &base.offsets)?;
                if p < nr {
                    let x = [base.offsets[p], sign * PLAY_RATE_STEP, 0.0];
                    built.data.set_constraint_offset(rows[p], 0.0, x).ok()?;
                } else {
                    rates[p - nr] += sign * PLAY_RATE_STEP;
                }
                match Self::joint_torques(built, &qa, &rates, qdda) {
                    Some(t) if t.iter().all(|v| v.is_finite()) => column[k] = Self::with_loads(built, t),
                    _ => return None,
                }
            }
            out.push(
                (0..column[0].len())
                    .map(|j| (column[0][j] - column[1][j]) / (2.0 * PLAY_RATE_STEP))
                    .collect(),
            );
        }
        // Positions: central differences.
        for p in (0..nr).chain(2 * nr..2 * nr + n) {
            let mut column = [vec![], vec![]];
            for (k, sign) in [1.0, -1.0].into_iter().enumerate() {
                let (mut x, mut offsets) = (qa.clone(), base.offsets.clone());
                if p < nr {
                    offsets[p] += sign * PLAY_OFFSET_STEP;
                } else {
                    x[p - 2 * nr] += sign * PLAY_OFFSET_STEP;
                }
                built.walk.q.clone_from(&qp);
                built.walk.w.clone_from(&wp);
                Self::set_offsets(built, rows, &offsets)?;
                match Self::joint_torques(built, &x, qda, qdda) {
                    Some(t) if t.iter().all(|v| v.is_finite()) => column[k] = Self::with_loads(built, t),
                    _ => return None,
                }
            }
            out[p] = (0..column[0].len())
                .map(|j| (column[0][j] - column[1][j]) / (2.0 * PLAY_OFFSET_STEP))
                .collect();
        }
        // The sample itself, where the point is off it.
        let off_sample = base.offsets.iter().chain(&base.lag).any(|&v| v != 0.0);
        let at_sample = if off_sample {
            built.walk.q.clone_from(&q0);
            built.walk.w.clone_from(&w0);
            built.data.clear_constraint_offsets();
            let tau = Self::joint_torques(built, qa0, qda, qdda)?;
            Self::with_outputs(sensors, built, Self::with_loads(built, tau))
        } else {
            vec![]
        };
        Some((out, at_point, at_sample))
    }

    /// The joint-side torques at joint positions `qa` (with rates and accelerations): the
    /// drivers' efforts, the state left in `built`. None where the mechanism cannot be
    /// assembled or its inverse dynamics is singular.
    fn joint_torques(built: &mut Built, qa: &[f64], qd: &[f64], qdd: &[f64]) -> Option<Vec<f64>> {
        let n = qa.len();
        // Walk large jumps (the first sample, or a new recording) from the last assembled
        // configuration (the built one at first: drive coordinates 0).
        let jump = (0..n)
            .map(|j| (qa[j] - built.walk.last[j]).abs())
            .fold(0.0, f64::max);
        let steps = (jump / CONTINUATION_STEP).ceil().min(1000.0) as usize;
        for k in 1..steps {
            let f = k as f64 / steps as f64;
            for j in 0..n {
                let x = built.walk.last[j] + f * (qa[j] - built.walk.last[j]);
                // The sample's motion as a local quadratic in time about t = 0 (the analyses
                // differentiate driver laws in time).
                let _ = built.data.prescribe_driver(built.drivers[j], 0.0, [x, 0.0, 0.0]);
            }
            match built
                .analysis
                .assemble(&built.model, &mut built.data, 0.0, &built.walk.q)
            {
                Ok(x) => built.walk.q = x,
                Err(_) => break,
            }
        }
        for j in 0..n {
            let _ = built
                .data
                .prescribe_driver(built.drivers[j], 0.0, [qa[j], qd[j], qdd[j]]);
        }
        // Continue from the previous sample (samples come in time order); fall back to the
        // built configuration if that fails.
        let Built {
            model,
            data,
            analysis,
            ..
        } = built;
        let snap = match analysis.state_at(model, data, 0.0, &built.walk.q, &built.walk.w) {
            Ok(s) => Ok(s),
            Err(_) => {
                let (q0, w0) = model.initial_guess();
                analysis.state_at(model, data, 0.0, &q0, &w0)
            }
        };
        let s = snap.ok()?;
        let tau: Vec<f64> = (0..n)
            .map(|j| data.driver_effort(built.drivers[j]).unwrap_or(f64::NAN))
            .collect();
        built.walk.q = s.q;
        built.walk.w = s.w;
        built.walk.last = qa.to_vec();
        Some(tau)
    }

    /// The sample at encoder positions `q` (time `t` along a recording, or a lone sample):
    /// joint positions after the wind-up, torques as the torque sensors read them; the
    /// state is left in the cache. None where the mechanism cannot be evaluated.
    fn sample(&self, t: Option<f64>, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64]) -> Option<Vec<f64>> {
        self.ensure(theta).ok()?;
        let n = self.joints.len();
        let mut b = self.built.borrow_mut();
        let built = b.as_mut()?;
        let c = self.compliances_at(theta, built);
        if let (Some(t), true) = (t, c.iter().any(|&v| v > 0.0)) {
            if let Some(tau) = self.step_windup(built, t, &c, q, qd, qdd) {
                return Some(tau);
            }
        }
        // Warm start from the previous samples' wind-up when this sample is near them
        // (linear extrapolation: the wind-up follows the torque smoothly in time).
        let near = (0..n).all(|j| (q[j] - built.walk.last_encoder[j]).abs() < CONTINUATION_STEP);
        if !near {
            built.walk.windup = [vec![0.0; n], vec![0.0; n]];
        }
        let mut qa: Vec<f64> = (0..n)
            .map(|j| q[j] - (2.0 * built.walk.windup[1][j] - built.walk.windup[0][j]))
            .collect();
        let mut tau = self.loads(built, &qa, qd, qdd)?;
        if c.iter().any(|&v| v != 0.0) {
            // Full passes until the wind-up moves by less than WINDUP_REFINE (one pass from a
            // warm start), then one position-only pass: the joints sit at q − c·τ with τ from
            // the last full pass (its error, ∂τ/∂q times a change below WINDUP_REFINE, is far
            // below any torque sensor's noise; the position error is c·∂τ/∂q smaller still).
            for _ in 0..WINDUP_PASSES {
                let next: Vec<f64> = (0..n).map(|j| q[j] - c[j] * tau[j]).collect();
                let change = (0..n).map(|j| (next[j] - qa[j]).abs()).fold(0.0, f64::max);
                qa = next;
                if change < WINDUP_REFINE {
                    break;
                }
                tau = self.loads(built, &qa, qd, qdd)?;
            }
            Self::place_joints(built, &qa, qd, qdd)?;
        }
        let now: Vec<f64> = (0..n).map(|j| q[j] - qa[j]).collect();
        built.walk.windup = [std::mem::take(&mut built.walk.windup[1]), now];
        if !near {
            built.walk.windup[0] = built.walk.windup[1].clone();
        }
        built.walk.last_encoder = q[..n].to_vec();
        for (j, x) in tau.iter_mut().enumerate() {
            if let Some(EncoderPlacement::MotorSide { rotor_inertia, .. }) = self.sensors.encoders.get(j) {
                *x += rotor_inertia * qdd[j];
            }
        }
        // A quasi-static start over the first three samples of a recording; at the third,
        // the wind-up's rate and acceleration from their differences and the dynamic part of
        // the wind-up, −K⁻¹(M_d·ẅ + D·ẇ), which a slowly forced, damped mode follows (a start
        // at rest would ring through the first few tenths of a second).
        let w = nalgebra::DVector::from_iterator(n, (0..n).map(|j| q[j] - qa[j]));
        let prev = built.walk.dynamic.clone();
        let next = match (prev, t) {
            (Some(p), Some(t)) if p.started >= 1 && p.started < 3 && t > p.t && t - p.t <= WINDUP_MAX_GAP => {
                let h = t - p.t;
                let wd = (&w - &p.w_qs) / h;
                if p.started == 2 {
                    let wdd = (&wd - &p.wd) / h;
                    let m = built
                        .analysis
                        .driver_mass_matrix(&built.model, &mut built.data)
                        .ok();
                    let damping = self.dampings(n);
                    let force = m
                        .map(|m| &m * &wdd)
                        .unwrap_or_else(|| nalgebra::DVector::zeros(n))
                        + nalgebra::DVector::from_iterator(n, (0..n).map(|j| damping[j] * wd[j]));
                    let dynamic = nalgebra::DVector::from_iterator(n, (0..n).map(|j| -c[j] * force[j]));
                    Some(Windup {
                        t,
                        start: p.start,
                        w: &w + dynamic,
                        w_qs: w.clone(),
                        arm: None,
                        wd,
                        wdd,
                        tau_s: None,
                        m: None,
                        tau: tau.clone(),
                        started: 3,
                    })
                } else {
                    Some(Windup {
                        t,
                        start: p.start,
                        w: w.clone(),
                        w_qs: w.clone(),
                        arm: None,
                        wd,
                        wdd: nalgebra::DVector::zeros(n),
                        tau_s: None,
                        m: None,
                        tau: tau.clone(),
                        started: p.started + 1,
                    })
                }
            }
            (_, Some(t)) => Some(Windup {
                t,
                start: t,
                w: w.clone(),
                w_qs: w.clone(),
                arm: None,
                wd: nalgebra::DVector::zeros(n),
                wdd: nalgebra::DVector::zeros(n),
                tau_s: None,
                m: None,
                tau: tau.clone(),
                started: 1,
            }),
            _ => None,
        };
        // Only compliant transmissions have a state to carry (and a start transient).
        built.walk.dynamic = if c.iter().any(|&v| v > 0.0) { next } else { None };
        Some(tau)
    }

    /// The wind-up over `h` from `prev` ([`transmission::newmark_interval`]), τ and M
    /// linear in time from the previous sample's to `tau_s` and `m`. (With M held at the
    /// sample's value the error was first order in the sample interval: 0.07 N m RMS near
    /// the direct singularity of a simulated MR2120 at 500 Hz; interpolated, 0.010 N m,
    /// second order.)
    fn newmark(
        prev: &Windup,
        tau_s: &nalgebra::DVector<f64>,
        m: &nalgebra::DMatrix<f64>,
        k: &nalgebra::DVector<f64>,
        d: &nalgebra::DVector<f64>,
        h: f64,
    ) -> Option<transmission::State> {
        let stiffness = nalgebra::DMatrix::from_diagonal(k);
        let start = transmission::End {
            mass: prev.m.as_ref().unwrap_or(m),
            stiffness: &stiffness,
            load: prev.tau_s.as_ref().unwrap_or(tau_s),
        };
        let end = transmission::End {
            mass: m,
            stiffness: &stiffness,
            load: tau_s,
        };
        let state = (prev.w.clone(), prev.wd.clone(), prev.wdd.clone());
        transmission::newmark_interval(&state, &start, &end, d, h)
    }

    /// One step of the transmissions' wind-up dynamics to time `t`, from the state of the
    /// previous sample: M_d·ẅ + D·ẇ + K·w = τ_s, with τ_s the joint-side torques at the
    /// joint positions q − w and rates q̇ − ẇ with the encoder's accelerations q̈, M_d the
    /// mechanism's mass matrix in drive coordinates there
    /// ([`Analysis::driver_mass_matrix`]), K = diag(1/c), D the dampings; integrated by the
    /// average-acceleration Newmark rule (unconditionally stable, second order). The
    /// sensors read K·w + D·ẇ + J·q̈. None (the caller starts quasi-statically) at the first
    /// sample of a recording (time not after the previous sample's, or more than
    /// [`WINDUP_MAX_GAP`] after it) or where the step fails.
    fn step_windup(
        &self,
        built: &mut Built,
        t: f64,
        c: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
    ) -> Option<Vec<f64>> {
        let n = c.len();
        let prev = built.walk.dynamic.clone()?;
        let same = (0..n).all(|j| q[j] == built.walk.last_encoder[j]);
        if t == prev.t && same {
            return Some(prev.tau);
        }
        if prev.started < 3 {
            return None;
        }
        let h = t - prev.t;
        if !(h > 0.0 && h <= WINDUP_MAX_GAP) {
            return None;
        }
        let damping = self.dampings(n);
        // A rigid transmission (c = 0) keeps w = 0: a stiffness far above any other.
        let k = nalgebra::DVector::from_iterator(n, c.iter().map(|&v| if v > 0.0 { 1.0 / v } else { 1e12 }));
        let d = nalgebra::DVector::from_column_slice(&damping);
        // The joint-side torques at the predicted wind-up, then once more at the wind-up the
        // step arrives at (their dependence on the joint positions is treated explicitly).
        let mut w_at = &prev.w + &prev.wd * h + &prev.wdd * (0.5 * h * h);
        let mut wd_at = &prev.wd + &prev.wdd * h;
        let mut result = None;
        for _ in 0..WINDUP_CORRECTIONS {
            let qa: Vec<f64> = (0..n).map(|j| q[j] - w_at[j]).collect();
            let qda: Vec<f64> = (0..n).map(|j| qd[j] - wd_at[j]).collect();
            let tau_s = self.loads(built, &qa, &qda, qdd)?;
            let m = built
                .analysis
                .driver_mass_matrix(&built.model, &mut built.data)
                .ok()?;
            let tau_s = nalgebra::DVector::from_column_slice(&tau_s);
            let (w, wd, wdd) = Self::newmark(&prev, &tau_s, &m, &k, &d, h)?;
            w_at = w.clone();
            wd_at = wd.clone();
            result = Some((w, wd, wdd, tau_s, m));
        }
        let (w, wd, wdd, tau_s, m) = result?;
        if !w.iter().chain(wd.iter()).all(|v| v.is_finite()) {
            return None;
        }
        // The joints where the step puts them (positions only).
        let qa: Vec<f64> = (0..n).map(|j| q[j] - w[j]).collect();
        let (qda, qdda): (Vec<f64>, Vec<f64>) = (0..n).map(|j| (qd[j] - wd[j], qdd[j] - wdd[j])).unzip();
        Self::place_joints(built, &qa, &qda, &qdda)?;
        built.walk.last_encoder = q[..n].to_vec();
        let tau: Vec<f64> = (0..n)
            .map(|j| {
                let rotor = match self.sensors.encoders.get(j) {
                    Some(EncoderPlacement::MotorSide { rotor_inertia, .. }) => rotor_inertia * qdd[j],
                    _ => 0.0,
                };
                k[j] * w[j] + d[j] * wd[j] + rotor
            })
            .collect();
        built.walk.dynamic = Some(Windup {
            t,
            start: prev.start,
            w,
            wd,
            wdd,
            tau_s: Some(tau_s),
            tau: tau.clone(),
            m: Some(m),
            w_qs: nalgebra::DVector::zeros(n),
            arm: Some([qa, qda, qdda]),
            started: 3,
        });
        Some(tau)
    }

    #[allow(clippy::too_many_arguments)]
    fn evaluate_sample(
        &self,
        t: Option<f64>,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        tau: &mut [f64],
        y: &mut [f64],
    ) {
        let n = self.joints.len();
        match self.sample(t, theta, q, qd, qdd) {
            Some(x) if !self.settling() => {
                tau[..n].copy_from_slice(&x);
                self.outputs_now(y);
            }
            // Not evaluable, or within the transmissions' start transient (the model does not
            // know the wind-up's state yet): NaN, the sample carries no weight.
            _ => {
                tau[..n].iter_mut().for_each(|v| *v = f64::NAN);
                y.iter_mut().for_each(|v| *v = f64::NAN);
            }
        }
    }

    /// Whether the last sample evaluated lies within [`WINDUP_SETTLING`] of the start of
    /// its recording's transmission dynamics.
    fn settling(&self) -> bool {
        let b = self.built.borrow();
        b.as_ref()
            .and_then(|x| x.walk.dynamic.as_ref())
            .is_some_and(|d| d.t - d.start < WINDUP_SETTLING)
    }

    /// The outputs at the state left in the cache.
    fn outputs_now(&self, y: &mut [f64]) {
        let b = self.built.borrow();
        let Some(built) = b.as_ref() else { return };
        Self::outputs_of(&self.sensors, built, y);
    }

    /// The outputs at the state `built` holds.
    fn outputs_of(sensors: &Sensors, built: &Built, y: &mut [f64]) {
        for (k, (s, &h)) in sensors.outputs.iter().zip(&built.sensor_bodies).enumerate() {
            let r = built.data.body_position(h) + built.data.body_rotation(h) * s.point;
            y[k] = r[s.axis];
        }
    }
}

impl InverseDynamicsModel for MechanismModel {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn column_defaults(&self) -> ColumnDefaults {
        self.columns.clone()
    }
    fn joint_motion(&self, j: usize) -> JointMotion {
        self.motions.get(j).copied().unwrap_or_default()
    }
    fn joints(&self) -> usize {
        self.joints.len()
    }
    fn joint_name(&self, j: usize) -> String {
        self.joints
            .get(j)
            .cloned()
            .unwrap_or_else(|| format!("joint {}", j + 1))
    }
    fn parameters(&self) -> Vec<ModelParameter> {
        self.parameters.clone()
    }
    fn declared_candidates(&self) -> Vec<DeclaredCandidate> {
        self.declared.clone()
    }
    /// One-sided: every evaluation is a pass of multibody analyses along the recording, and
    /// with a step of [`PARAMETER_STEP`] of the scale the truncation error (1e-4 relative) is
    /// far below what the estimates resolve.
    fn one_sided_differences(&self) -> bool {
        true
    }
    /// [`PARAMETER_STEP`] of the parameter's scale.
    fn parameter_step(&self, k: usize) -> f64 {
        PARAMETER_STEP * self.parameters.get(k).map_or(1.0, |p| p.scale).max(1e-12)
    }
    /// Driver torques (N·m, or N for a prismatic drive) at the sample, as the torque
    /// sensors read them; NaN where the mechanism cannot be assembled, its inverse dynamics
    /// is singular or the builder fails for perturbed parameter values (the nominal ones are
    /// checked by [`MechanismModel::new`]).
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        let mut y = vec![0.0; self.sensors.outputs.len()];
        self.evaluate(theta, q, qd, qdd, tau, &mut y);
    }
    fn evaluate(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64], y: &mut [f64]) {
        self.evaluate_sample(None, theta, q, qd, qdd, tau, y)
    }
    fn evaluate_at(
        &self,
        t: f64,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        tau: &mut [f64],
        y: &mut [f64],
    ) {
        self.evaluate_sample(Some(t), theta, q, qd, qdd, tau, y)
    }
    fn outputs(&self) -> usize {
        self.sensors.outputs.len()
    }
    fn output_name(&self, k: usize) -> String {
        self.sensors
            .outputs
            .get(k)
            .map_or_else(|| format!("output {}", k + 1), |s| s.name.clone())
    }
    fn output_role(&self, k: usize) -> String {
        self.sensors
            .outputs
            .get(k)
            .map_or_else(|| format!("y{}", k + 1), |s| s.role.clone())
    }
    fn derivative_windows(&self) -> Vec<usize> {
        self.windows
            .clone()
            .unwrap_or_else(|| super::model::DEFAULT_DERIVATIVE_WINDOWS.to_vec())
    }
    fn drive_compliance(&self, theta: &[f64], j: usize) -> f64 {
        self.compliance(theta, j)
    }
    fn with_arm_torque(&self, torque: ArmTorque) -> Option<Box<dyn InverseDynamicsModel + Send>> {
        Some(Box::new(self.arm_torque_model(torque)))
    }
    fn fork(&self) -> Option<Box<dyn InverseDynamicsModel + Send>> {
        Some(Box::new(self.clone()))
    }
    fn integrates_windup(&self) -> bool {
        self.sensors
            .encoders
            .iter()
            .any(|e| matches!(e, EncoderPlacement::MotorSide { .. }))
    }
    fn transmission_dynamics(&self, theta: &[f64]) -> Option<TransmissionDynamics> {
        let n = self.joints.len();
        if !(0..n).any(|j| self.compliance(theta, j) > 0.0) {
            return None;
        }
        let mut b = self.built.borrow_mut();
        let built = b.as_mut()?;
        if built.theta != theta {
            return None;
        }
        let compliance = self.compliances_at(theta, built);
        // The mass matrix where the last sample left the joints.
        let mass = built
            .analysis
            .driver_mass_matrix(&built.model, &mut built.data)
            .ok()?;
        let load_stiffness = Self::load_stiffness(built);
        let (windup, windup_rate) = match &built.walk.dynamic {
            Some(w)
                if w.wd.len() == n
                    && w.w.len() == n
                    && w.wd.iter().chain(w.w.iter()).all(|v| v.is_finite()) =>
            {
                (w.w.iter().copied().collect(), w.wd.iter().copied().collect())
            }
            _ => (vec![f64::NAN; n], vec![0.0; n]),
        };
        mass.iter().all(|v| v.is_finite()).then(|| TransmissionDynamics {
            mass,
            compliance,
            damping: self.dampings(n),
            windup_rate,
            windup,
            load_stiffness,
        })
    }
    fn play_sites(&self) -> Vec<String> {
        self.play.iter().map(|s| s.joint.clone()).collect()
    }
    fn play_site_compliance(&self, site: usize) -> Vec<usize> {
        self.play
            .get(site)
            .map(|s| s.compliance.clone())
            .unwrap_or_default()
    }
    /// Per play site: how the outputs move when the joint's side j shifts along base x, y,
    /// z or tilts about z_i × z_j (first order, from the assembled configuration of this
    /// sample), the joint's axes, force and moment.
    fn output_sensitivities(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        _y: &[f64],
    ) -> Option<OutputSensitivities> {
        if self.play.is_empty() || self.sensors.outputs.is_empty() {
            return None;
        }
        self.ensure_sample(theta, q, qd, qdd)?;
        let mut b = self.built.borrow_mut();
        let built = b.as_mut()?;
        let rows = Self::play_rows(built);
        let q_now = built.data.q.clone();
        let dq = built
            .analysis
            .constraint_offset_sensitivity(&built.model, &mut built.data, 0.0, &q_now, &rows)
            .ok()?;
        let outputs = &self.sensors.outputs;
        let dy = |col: &[f64], sign: f64| -> Vec<f64> {
            outputs
                .iter()
                .zip(&built.sensor_bodies)
                .map(|(s, &h)| {
                    sign * Analysis::point_variation(&built.model, &q_now, col, h, &s.point)[s.axis]
                })
                .collect()
        };
        let mut play = vec![];
        for (k, (&jh, site)) in built.play_joints.iter().zip(&self.play).enumerate() {
            // The load the sample's state carries (the encoders' accelerations): a play
            // follows the mean load, not the transmissions' ringing (with the load at the
            // arms' motion, `play_loads`, the suite's clearance-F ranked its play fourth
            // instead of first and held out 6.57× instead of 6.58×; 2026-11-26).
            let reaction = built.data.reaction(&built.model, jh)?;
            let (force, moment) = (Vector3::from(reaction.force), Vector3::from(reaction.torque));
            let (z_i, z_j) = Self::trunnion_axes(built, jh)?;
            // What carries the cross with side i, at the same state as the reaction.
            let cross_load = site.cross_mass * Self::carried(built, jh)?;
            play.push(PlayData {
                dy_dshift: [
                    dy(&dq[4 * k], 1.0),
                    dy(&dq[4 * k + 1], 1.0),
                    dy(&dq[4 * k + 2], 1.0),
                ],
                // Offset ε of the perpendicularity row is −φ.
                dy_dtilt: dy(&dq[4 * k + 3], -1.0),
                z_i,
                z_j,
                force,
                moment,
                cross_load,
                play: site.play,
            });
        }
        Some(OutputSensitivities { sites: vec![], play })
    }
    /// Per play site: [`PlayDynamics`] from central differences of the inverse dynamics
    /// ([`PLAY_OFFSET_STEP`] in positions, [`PLAY_RATE_STEP`] in rates; accelerations by unit
    /// steps, exact as they enter linearly).
    fn play_dynamics(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64]) -> Option<Vec<PlayDynamics>> {
        if self.play.is_empty() {
            return None;
        }
        self.ensure_sample(theta, q, qd, qdd)?;
        let mut b = self.built.borrow_mut();
        let built = b.as_mut()?;
        let rows = Self::play_rows(built);
        let loads = Self::play_loads(built, qd, qdd)?;
        let mut sites = vec![];
        for (&jh, l) in built.play_joints.iter().zip(loads) {
            let (z_i, z_j) = Self::trunnion_axes(built, jh)?;
            let n = z_i.cross(&z_j);
            let n = if n.norm() > 0.0 { n.normalize() } else { n };
            let lam = [l.force.x, l.force.y, l.force.z, l.moment.dot(&n)];
            sites.push(((z_i, z_j, n), lam, l.carried));
        }
        let d = Self::offset_differences(built, &self.sensors, &rows, qd, qdd)?;
        let np = sites.len();
        Some(
            sites
                .iter()
                .enumerate()
                .map(|(k, (axes, lam, carried))| self.coupling(k, (k, np), axes, *lam, carried, &d))
                .collect(),
        )
    }
    /// Central differences as [`play_dynamics`](Self::play_dynamics), of one site, about the
    /// point; the torques' and the reaction's change from the sample to the point from the
    /// inverse dynamics at both (the same arms' rates and accelerations), the reaction at the
    /// point the sample's (at the arms' own motion) plus that change.
    fn play_dynamics_at(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        site: usize,
        windup: &[f64],
        offset: [f64; 4],
    ) -> Option<PlayPoint> {
        let nj = self.joints.len();
        if site >= self.play.len() || windup.len() != nj {
            return None;
        }
        self.ensure_sample(theta, q, qd, qdd)?;
        let mut b = self.built.borrow_mut();
        let built = b.as_mut()?;
        let rows = Self::play_rows(built).get(4 * site..4 * site + 4)?.to_vec();
        let jh = *built.play_joints.get(site)?;
        let PlayLoad {
            force,
            moment,
            carried,
        } = Self::play_loads(built, qd, qdd)?.into_iter().nth(site)?;
        let (z_i, z_j) = Self::trunnion_axes(built, jh)?;
        let n = z_i.cross(&z_j);
        let n = if n.norm() > 0.0 { n.normalize() } else { n };
        // The perpendicularity row's offset is −φ.
        let base = OffsetBase {
            offsets: vec![offset[0], offset[1], offset[2], -offset[3]],
            lag: windup.to_vec(),
        };
        let (d, at_point, at_sample) =
            Self::offset_differences_about(built, &self.sensors, &rows, qd, qdd, &base)?;
        let change: Vec<f64> = if at_sample.is_empty() {
            vec![0.0; at_point.len()]
        } else {
            at_point.iter().zip(&at_sample).map(|(a, b)| a - b).collect()
        };
        let l = change.get(nj + 6 * site..nj + 6 * site + 6)?;
        let lam = [
            force.x + l[0],
            force.y + l[1],
            force.z + l[2],
            (moment + Vector3::new(l[3], l[4], l[5])).dot(&n),
        ];
        // (The cross's load kept at the sample's: the play moves side i's point by microns.)
        let dynamics = self.coupling(site, (0, 1), &(z_i, z_j, n), lam, &carried, &d);
        let by_drive = |first: usize| nalgebra::DMatrix::from_fn(nj, nj, |j, k| d[first + k][j]);
        // The outputs follow every play joint's loads.
        let outputs = change.get(nj + 6 * built.play_joints.len()..)?.to_vec();
        let point = PlayPoint {
            windup: windup.to_vec(),
            offset,
            dynamics,
            torque: change[..nj].to_vec(),
            load_stiffness: by_drive(8),
            mass: by_drive(8 + nj),
            outputs,
        };
        (point.torque.iter().all(|v| v.is_finite())
            && point.dynamics.reaction.iter().all(|v| v.is_finite())
            && point
                .load_stiffness
                .iter()
                .chain(point.mass.iter())
                .all(|v| v.is_finite()))
        .then_some(point)
    }
    /// The cache after the last sample of a recording's walk (its assembled state, drive
    /// positions and the transmissions' wind-up); None where
    /// the last evaluation was not along a recording with compliant transmissions (nothing
    /// then carries over from sample to sample).
    fn sample_state(&self) -> Option<SampleState> {
        let b = self.built.borrow();
        let x = b.as_ref()?;
        x.walk.dynamic.as_ref()?;
        Some(SampleState::new(Checkpoint {
            theta: x.theta.clone(),
            walk: x.walk.clone(),
        }))
    }
    /// Puts such a state back (the mechanism built for its parameter values first, if the
    /// cache holds other ones), the bodies placed at its assembled positions.
    fn restore_sample(&self, state: &SampleState) -> bool {
        let Some(c) = state.get::<Checkpoint>() else {
            return false;
        };
        if self.ensure(&c.theta).is_err() {
            return false;
        }
        let mut b = self.built.borrow_mut();
        let Some(x) = b.as_mut() else {
            return false;
        };
        if x.walk.q.len() != c.walk.q.len() || x.walk.w.len() != c.walk.w.len() {
            return false;
        }
        x.walk.clone_from(&c.walk);
        x.data.q.clone_from(&c.walk.q);
        x.data.w.clone_from(&c.walk.w);
        true
    }
    fn configuration_tag(&self, _theta: &[f64], q: &[f64], y: &[f64]) -> Option<String> {
        self.tagger.as_ref().and_then(|t| t(q, y))
    }
}
