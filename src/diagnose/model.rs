//! The nominal model as the diagnosis sees it in equation-error mode: joint torques from
//! measured motion (inverse dynamics), with named physical parameters the candidate library
//! may perturb.

use crate::mechanisms::double_pendulum::DoublePendulumParams;
use crate::mechanisms::mr2120::lumped::{tilted_gravity, LumpedModel, LumpedState};
use nalgebra::Vector3;
use serde::Serialize;
use std::sync::Arc;

/// A torque on the joint side of drive `j` (its first argument, driver order) at the arm's
/// rate (its second, rad/s or m/s): friction acting on the arm, N·m (N for a prismatic
/// drive), positive along the motion it opposes, as the drive must supply it
/// ([`InverseDynamicsModel::with_arm_torque`]).
pub type ArmTorque = Arc<dyn Fn(usize, f64) -> f64 + Send + Sync>;

/// The columns of the DFKI double pendulum's recordings for q1, q2, qd1, qd2, tau1, tau2
/// (filtered positions in rad, filtered rates in rad/s, measured torques in N·m).
pub const DFKI_COLUMNS: &str =
    "q1=pos_filt1,q2=pos_filt2,qd1=vel_filt1,qd2=vel_filt2,tau1=tau_meas1,tau2=tau_meas2";

/// Half-widths (samples) of the rate differentiation tried by cross-validation when a model
/// states no grid of its own ([`InverseDynamicsModel::derivative_windows`]).
pub const DEFAULT_DERIVATIVE_WINDOWS: [usize; 11] = [2, 3, 5, 8, 12, 16, 20, 25, 30, 40, 50];

/// How the roles of a model find their columns when the user maps none or only some.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ColumnDefaults {
    /// Without a user mapping, this "role=column,…" mapping; a user mapping replaces it and
    /// must then name every role.
    Fixed(String),
    /// Each role reads the column of its own name unless the user maps it; torque and output
    /// roles whose column the recording's header lacks are left out (they are optional
    /// measurements), motion roles (q, qd) are always read.
    RoleNames,
}

/// What a model parameter stands for (names the candidate and the experiment that
/// separates it from others).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ParameterFamily {
    /// A link length or joint location.
    LinkGeometry,
    /// A link's mass, centre of mass or inertia.
    MassProperties,
    /// A payload.
    Payload,
    /// Tilt of the base (gravity direction).
    BaseTilt,
    /// Compliance of a drive's transmission.
    DriveCompliance,
    /// Contact compliance of joints in series with a drive (nominal 0: rigid joints).
    JointCompliance,
}

/// How the outputs (e.g. a tracked platform position) respond at one sample to play at each
/// clearance site, and the load that sets which side of the play the joint sits on. (Joint
/// positions, drive wind-up and sensor offsets need no such hook: their columns are
/// differences of the whole model.)
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSensitivities {
    /// Per clearance site of a closed-form model ([`InverseDynamicsModel::clearance_sites`]):
    /// ∂y/∂(displacement of the site along its load), and that load (its sign sets which
    /// side of the clearance the joint sits on).
    pub sites: Vec<(Vec<f64>, f64)>,
    /// Per joint with play ([`InverseDynamicsModel::play_sites`]): its sensitivities, axes
    /// and loads at this sample.
    pub play: Vec<PlayData>,
}

/// A universal joint with play at one sample: how the outputs move when its side j shifts
/// or tilts from side i, its axes, and the loads that set where it sits in its clearance
/// ([`crate::contact::play`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PlayData {
    /// ∂y/∂(shift of side j along base x, y, z), per output (output unit per m).
    pub dy_dshift: [Vec<f64>; 3],
    /// ∂y/∂(tilt of side j about z_i × z_j), per output (output unit per rad).
    pub dy_dtilt: Vec<f64>,
    /// Axis of the side-i trunnions (unit, base frame).
    pub z_i: Vector3<f64>,
    /// Axis of the side-j trunnions (unit, base frame).
    pub z_j: Vector3<f64>,
    /// Force of the joint on side j, N (base frame).
    pub force: Vector3<f64>,
    /// Moment of the joint on side j about the joint centre, N·m (base frame).
    pub moment: Vector3<f64>,
    /// The load that carries the joint's cross along with side i, N (base frame): its mass
    /// times gravity less the acceleration of side i's point at the joint's centre, at the
    /// sample's state as `force` (the form of [`PlayDynamics::cross_load`], which takes the
    /// arms' motion). Side i's trunnion pair carries `force` less this
    /// ([`crate::contact::play::UniversalPlay::shift_with_cross_weight`]); zero for a
    /// weightless cross.
    pub cross_load: Vector3<f64>,
    /// The play geometry.
    pub play: crate::contact::play::UniversalPlay,
}

/// How a universal joint's play couples to the drives at one sample, to first order about the
/// nominal motion: the joint's four play coordinates e = (shift of side j from side i along
/// base x, y, z in m; tilt of side j about n = z_i × z_j in rad), the drives' joint-side
/// torques τ_s and the joint's generalised reaction Λ = (force on side j along base x, y, z
/// in N; moment on side j about n in N·m, the load conjugate to the tilt). Each entry is a
/// derivative of the nominal model's inverse dynamics with the joint's constraints offset by
/// e (or accelerated by ë) and the arms where they are — the data a reduced dynamic model of
/// the play needs: the play coordinates' inertia is ∂Λ/∂ë, their coupling to the drives
/// ∂τ_s/∂ë and ∂Λ/∂q̈_arm (equal by reciprocity), their stiffness ∂Λ/∂e.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayDynamics {
    /// Axis of the side-i trunnions (unit, base frame).
    pub z_i: Vector3<f64>,
    /// Axis of the side-j trunnions (unit, base frame).
    pub z_j: Vector3<f64>,
    /// The play geometry.
    pub play: crate::contact::play::UniversalPlay,
    /// The joint's cross (kg): its own mass, which the reduced play model moves between the
    /// joint's sides (the nominal model carries it in a link).
    pub cross_mass: f64,
    /// The load that carries the cross along with side i in the nominal motion, N along base
    /// x, y, z: m_x·(g − a_i), its weight less its mass times the nominal acceleration a_i of
    /// side i's point at the joint's centre. The nominal model carries the cross in side i's
    /// link, so Λ leaves it out; the reduced play model hangs the cross on its balls, which
    /// must carry it (zero: a weightless cross that moves with side i).
    pub cross_load: [f64; 3],
    /// Λ at the sample, N along x, y, z, then N·m about n: the inverse dynamics' at the arms'
    /// motion (the encoders' less the transmissions' wind-up, where the model carries one).
    pub reaction: [f64; 4],
    /// ∂τ_s/∂e_c per play coordinate c, per drive (N·m per m, N·m per rad).
    pub torque_by_offset: [Vec<f64>; 4],
    /// ∂τ_s/∂ë_c per play coordinate c, per drive (N·m per m/s², N·m per rad/s²).
    pub torque_by_offset_acceleration: [Vec<f64>; 4],
    /// ∂Λ_r/∂e_c as `[c][r]`.
    pub reaction_by_offset: [[f64; 4]; 4],
    /// ∂Λ_r/∂ë_c as `[c][r]`.
    pub reaction_by_offset_acceleration: [[f64; 4]; 4],
    /// ∂Λ_r/∂q_k per drive k (the arm's position, rad or m) as `[k][r]`.
    pub reaction_by_drive: Vec<[f64; 4]>,
    /// ∂Λ_r/∂q̈_k per drive k as `[k][r]`.
    pub reaction_by_drive_acceleration: Vec<[f64; 4]>,
    /// ∂τ_s/∂ė_c per play coordinate c, per drive (N·m per m/s, N·m per rad/s): the
    /// velocity products' share (empty: not known, taken as zero).
    pub torque_by_offset_rate: Vec<Vec<f64>>,
    /// ∂Λ_r/∂ė_c as `[c][r]` (empty: not known).
    pub reaction_by_offset_rate: Vec<[f64; 4]>,
    /// ∂Λ_r/∂q̇_k per drive k as `[k][r]` (empty: not known).
    pub reaction_by_drive_rate: Vec<[f64; 4]>,
    /// ∂τ_s,j/∂q̇_k as `[k][j]`, N·m·s/rad (empty: not known).
    pub torque_by_drive_rate: Vec<Vec<f64>>,
}

/// The nominal model re-linearised at a point of a play's motion
/// ([`InverseDynamicsModel::play_dynamics_at`]): near a singular position the play moves the
/// mechanism far enough (the platform by some 40× the clearance) that the derivatives at
/// the nominal configuration no longer carry the torques; the reduced play model then
/// expands about this point instead ([`super::play_dynamics::PlaySample::about`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PlayPoint {
    /// The point: each drive's extra wind-up δw (rad, or m): its arm lags its encoder by that
    /// much more than in the nominal model.
    pub windup: Vec<f64>,
    /// The point: the joint's play coordinates e (shift of side j from side i along base x,
    /// y, z in m; tilt about n in rad).
    pub offset: [f64; 4],
    /// The joint's coupling to the drives there (its `reaction`: Λ at the point).
    pub dynamics: PlayDynamics,
    /// τ_s at the point less τ_s at the sample (the same arms' rates and accelerations),
    /// per drive, N·m (or N).
    pub torque: Vec<f64>,
    /// ∂τ_s,j/∂q_k at the point as `(j, k)`: the joint-side torques' stiffness in the arms'
    /// positions, N·m/rad (or N/m).
    pub load_stiffness: nalgebra::DMatrix<f64>,
    /// ∂τ_s,j/∂q̈_k at the point as `(j, k)`: the mass matrix in drive coordinates, kg·m²
    /// (or kg).
    pub mass: nalgebra::DMatrix<f64>,
    /// The outputs (the model's point sensors, their units) at the point less at the sample,
    /// to all orders: near a singular position the platform's answer to the play is far from
    /// its first-order sensitivities ([`PlayData`]). Empty where the model has no outputs.
    pub outputs: Vec<f64>,
}

/// One perturbable parameter of a nominal model.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModelParameter {
    /// Name for reports, e.g. "link 1 length l1".
    pub name: String,
    /// Unit.
    pub unit: String,
    /// Nominal value (SI).
    pub nominal: f64,
    /// Typical scale, for difference steps and reporting (SI).
    pub scale: f64,
    /// Family.
    pub family: ParameterFamily,
}

/// A candidate a nominal model declares itself (e.g. a model file's `[[candidate]]`): a
/// force law already in the model whose parameters (nominal 0, or any other nominal) the
/// diagnosis may perturb together, as one effect.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DeclaredCandidate {
    /// Name for reports.
    pub name: String,
    /// Indices into the model's [`parameters`](InverseDynamicsModel::parameters).
    pub parameters: Vec<usize>,
    /// Bounds of each parameter's change from its nominal value (SI).
    pub bounds: Vec<(f64, f64)>,
}

/// Whether a joint channel turns or slides: sets the units and words of everything reported
/// about it (a prismatic joint's effort is a force in N, its friction in N and N s/m).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum JointMotion {
    /// A revolute joint: rad, rad/s, N m.
    #[default]
    Rotary,
    /// A prismatic joint: m, m/s, N.
    Linear,
}

impl JointMotion {
    /// "torque" or "force".
    pub fn effort_word(self) -> &'static str {
        match self {
            JointMotion::Rotary => "torque",
            JointMotion::Linear => "force",
        }
    }
    /// Unit of the effort: "N m" or "N".
    pub fn effort(self) -> &'static str {
        match self {
            JointMotion::Rotary => "N m",
            JointMotion::Linear => "N",
        }
    }
    /// Unit of the coordinate: "rad" or "m".
    pub fn position(self) -> &'static str {
        match self {
            JointMotion::Rotary => "rad",
            JointMotion::Linear => "m",
        }
    }
    /// Unit of the rate: "rad/s" or "m/s".
    pub fn rate(self) -> &'static str {
        match self {
            JointMotion::Rotary => "rad/s",
            JointMotion::Linear => "m/s",
        }
    }
    /// Unit of viscous friction: "N m s/rad" or "N s/m".
    pub fn damping(self) -> &'static str {
        match self {
            JointMotion::Rotary => "N m s/rad",
            JointMotion::Linear => "N s/m",
        }
    }
    /// Unit of a reflected inertia: "kg m^2" or "kg".
    pub fn inertia(self) -> &'static str {
        match self {
            JointMotion::Rotary => "kg m^2",
            JointMotion::Linear => "kg",
        }
    }
}

/// `f` on every item, side by side on copies of `model` where it makes them
/// ([`InverseDynamicsModel::fork`]: one copy per item, so no copy's cache depends on another
/// item's order), else one after another on `model` itself. Results in the items' order.
pub fn on_copies<I: Sync, T: Send>(
    items: &[I],
    model: &dyn InverseDynamicsModel,
    f: &(dyn Fn(&I, &dyn InverseDynamicsModel) -> T + Sync),
) -> Vec<T> {
    copies(items, model, f, 2)
}

/// [`on_copies`], on a copy of the model also for a single item (a copy starts afresh,
/// where the model itself carries the state its last evaluation left: the items' results
/// are then those they have within a batch of several).
pub(crate) fn on_forks<I: Sync, T: Send>(
    items: &[I],
    model: &dyn InverseDynamicsModel,
    f: &(dyn Fn(&I, &dyn InverseDynamicsModel) -> T + Sync),
) -> Vec<T> {
    copies(items, model, f, 1)
}

/// `f` over `items`, on copies of `model` side by side from `fork_from` items on.
fn copies<I: Sync, T: Send>(
    items: &[I],
    model: &dyn InverseDynamicsModel,
    f: &(dyn Fn(&I, &dyn InverseDynamicsModel) -> T + Sync),
    fork_from: usize,
) -> Vec<T> {
    use rayon::prelude::*;
    let forks: Option<Vec<Box<dyn InverseDynamicsModel + Send>>> = if items.len() >= fork_from {
        items.iter().map(|_| model.fork()).collect()
    } else {
        None
    };
    match forks {
        Some(forks) => forks
            .into_par_iter()
            .zip(items.par_iter())
            .map(|(m, item)| f(item, m.as_ref()))
            .collect(),
        None => items.iter().map(|item| f(item, model)).collect(),
    }
}

/// A model's state along a recording after one sample ([`InverseDynamicsModel::sample_state`]):
/// opaque to the diagnosis, which keeps it with the nominal walk and hands it back
/// ([`InverseDynamicsModel::restore_sample`]).
pub struct SampleState(Box<dyn std::any::Any + Send + Sync>);

impl SampleState {
    /// Wraps a model's own state.
    pub fn new<T: std::any::Any + Send + Sync>(state: T) -> Self {
        Self(Box::new(state))
    }
    /// The state, if it is a `T`.
    pub fn get<T: std::any::Any>(&self) -> Option<&T> {
        self.0.downcast_ref()
    }
}

impl std::fmt::Debug for SampleState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SampleState")
    }
}

/// A nominal model in equation-error form: τ = ID(θ; q, q̇, q̈).
pub trait InverseDynamicsModel {
    /// Model name for reports.
    fn name(&self) -> String;
    /// Number of joints (torque channels).
    fn joints(&self) -> usize;
    /// Name of joint j (0-based), e.g. "joint 2 (elbow)".
    fn joint_name(&self, j: usize) -> String;
    /// Whether joint j turns or slides (its units in every report). Default: it turns.
    fn joint_motion(&self, _j: usize) -> JointMotion {
        JointMotion::Rotary
    }
    /// Parameters the candidate library may perturb (nominal values included).
    fn parameters(&self) -> Vec<ModelParameter>;
    /// Candidates the model declares itself, each perturbing some of its parameters
    /// together (those parameters get no "error in" candidate of their own). Default: none.
    fn declared_candidates(&self) -> Vec<DeclaredCandidate> {
        vec![]
    }
    /// Step of the central difference that gives the sensitivities to parameter `k`, in its
    /// unit. Default: 1e-6 of its scale (closed-form models, exact to rounding); a model
    /// solved iteratively takes a larger step so that its iteration tolerance does not show.
    fn parameter_step(&self, k: usize) -> f64 {
        1e-6 * self.parameters().get(k).map_or(1.0, |p| p.scale).max(1e-12)
    }
    /// Sensitivities by one-sided differences from the nominal evaluation (half the model
    /// passes; truncation error of the order of the step) instead of central ones. Default:
    /// central (false).
    fn one_sided_differences(&self) -> bool {
        false
    }
    /// Joint torques (N·m) with parameter values `theta` (same order as
    /// [`parameters`](Self::parameters)) at joint positions, rates and accelerations.
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]);
    /// Torques per unit reflected rotor inertia J_j (kg·m², rotor inertia × gear ratio²) of
    /// drive j. Default: a drive fixed to the base, τ_j += J_j·q̈_j. A drive carried by a
    /// moving link also couples into the joints that carry it.
    fn rotor_regressor(&self, j: usize, qdd: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|v| *v = 0.0);
        out[j] = qdd[j];
    }
    /// Number of output channels predicted from the measured joint positions (output-error
    /// channels, e.g. the platform position from a laser tracker). Default: none.
    fn outputs(&self) -> usize {
        0
    }
    /// Name of output k, e.g. "platform x".
    fn output_name(&self, k: usize) -> String {
        format!("output {}", k + 1)
    }
    /// Unit of output k.
    fn output_unit(&self, _k: usize) -> String {
        "m".into()
    }
    /// Recording role of output k (the name `--map` uses), e.g. "x".
    fn output_role(&self, k: usize) -> String {
        format!("y{}", k + 1)
    }
    /// Half-widths (samples) of the local cubic fit that differentiates rates into accelerations,
    /// tried by cross-validation when the user gives none. Default:
    /// [`DEFAULT_DERIVATIVE_WINDOWS`].
    fn derivative_windows(&self) -> Vec<usize> {
        DEFAULT_DERIVATIVE_WINDOWS.to_vec()
    }
    /// How its roles find their recording columns when the user maps none or only some.
    /// Default: [`ColumnDefaults::RoleNames`].
    fn column_defaults(&self) -> ColumnDefaults {
        ColumnDefaults::RoleNames
    }
    /// Torques and outputs at one sample. `y` holds, on entry, the previous sample's outputs
    /// (zeros at the first) as a starting guess for iterative kinematics; a configuration the
    /// model cannot evaluate gives NaN. Default: [`torques`](Self::torques), no outputs.
    fn evaluate(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64], _y: &mut [f64]) {
        self.torques(theta, q, qd, qdd, tau);
    }
    /// [`evaluate`](Self::evaluate) at sample time `t` (s) of a recording whose samples come
    /// in time order: a model with internal dynamics (a compliant transmission integrated
    /// along the recording) carries its state from one sample to the next and restarts when
    /// time goes back (a new recording). Default: [`evaluate`](Self::evaluate).
    #[allow(clippy::too_many_arguments)]
    fn evaluate_at(
        &self,
        _t: f64,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        tau: &mut [f64],
        y: &mut [f64],
    ) {
        self.evaluate(theta, q, qd, qdd, tau, y)
    }
    /// Output sensitivities at one sample (None for a model without outputs or where the
    /// model cannot be evaluated). A model with internal dynamics answers for the sample it
    /// last evaluated with [`evaluate_at`](Self::evaluate_at) when `q` is that sample's.
    fn output_sensitivities(
        &self,
        _theta: &[f64],
        _q: &[f64],
        _qd: &[f64],
        _qdd: &[f64],
        _y: &[f64],
    ) -> Option<OutputSensitivities> {
        None
    }
    /// Compliance of drive j's transmission at parameters `theta`, rad/(N·m): a torque on
    /// the joint side (friction) winds it up and moves the arm against its encoder. Default 0.
    fn drive_compliance(&self, _theta: &[f64], _j: usize) -> f64 {
        0.0
    }
    /// The model with `torque` on the arms' side of its drives inside its own dynamics
    /// (friction found by a first pass moved into the model before it is linearised again:
    /// with compliant transmissions the friction winds them up nonlinearly), or None if the
    /// model cannot take one (the default: friction then stays a column of the candidate
    /// library).
    fn with_arm_torque(&self, _torque: ArmTorque) -> Option<Box<dyn InverseDynamicsModel + Send>> {
        None
    }
    /// An independent copy of the model that another thread may evaluate: the same model
    /// with caches of its own (the diagnosis then evaluates a recording's perturbed passes
    /// side by side), or None if the model cannot be copied (the default: the passes run
    /// one after another). The copy must give what the model gives, to its evaluations'
    /// tolerance.
    fn fork(&self) -> Option<Box<dyn InverseDynamicsModel + Send>> {
        None
    }
    /// The drive transmissions' dynamics at the sample the model last evaluated with
    /// [`evaluate_at`](Self::evaluate_at) (mass matrix in drive coordinates, compliances,
    /// dampings, the nominal wind-up rate and the joint torques' stiffness in the arms'
    /// positions), for a model that integrates its transmissions' wind-up along a
    /// recording: the candidate library then winds the transmissions up dynamically under a
    /// joint-side torque ([`crate::diagnose::transmission`]). Default None: quasi-static
    /// wind-up c·τ.
    fn transmission_dynamics(
        &self,
        _theta: &[f64],
    ) -> Option<crate::diagnose::transmission::TransmissionDynamics> {
        None
    }
    /// Whether the model integrates its transmissions' wind-up along a recording (then
    /// [`transmission_dynamics`](Self::transmission_dynamics) describes them at each sample
    /// it evaluates, for every compliant transmission). Default false.
    fn integrates_windup(&self) -> bool {
        false
    }
    /// The play sites' coupling to the drives ([`PlayDynamics`], in the order of
    /// [`play_sites`](Self::play_sites)) at the sample the model last evaluated with
    /// [`evaluate_at`](Self::evaluate_at) (or at a lone sample): for a reduced dynamic model
    /// of the play. Costs several inverse-dynamics evaluations per site, so it is asked for
    /// apart from [`output_sensitivities`](Self::output_sensitivities). Default None.
    fn play_dynamics(
        &self,
        _theta: &[f64],
        _q: &[f64],
        _qd: &[f64],
        _qdd: &[f64],
    ) -> Option<Vec<PlayDynamics>> {
        None
    }
    /// Play site `site`'s coupling re-linearised at a point of its motion ([`PlayPoint`]):
    /// the drives wound up by `windup` more (rad, or m), the joint's sides offset by `offset`
    /// (shift along base x, y, z in m; tilt about n in rad), at the sample the model last
    /// evaluated with [`evaluate_at`](Self::evaluate_at) (or at a lone sample). Costs
    /// [`play_dynamics`](Self::play_dynamics)'s differences for one site and two inverse
    /// dynamics more (at the sample and at the point). Default None.
    #[allow(clippy::too_many_arguments)]
    fn play_dynamics_at(
        &self,
        _theta: &[f64],
        _q: &[f64],
        _qd: &[f64],
        _qdd: &[f64],
        _site: usize,
        _windup: &[f64],
        _offset: [f64; 4],
    ) -> Option<PlayPoint> {
        None
    }
    /// The state a model with dynamics of its own (a compliant transmission's wind-up)
    /// carries along a recording, as the sample it last evaluated with
    /// [`evaluate_at`](Self::evaluate_at) left it: [`restore_sample`](Self::restore_sample)
    /// puts it back, so that a later question about that sample
    /// ([`play_dynamics_at`](Self::play_dynamics_at)) needs no walk from the recording's
    /// start to it. Default None (no such state, or none the model can give).
    fn sample_state(&self) -> Option<SampleState> {
        None
    }
    /// Puts back a state [`sample_state`](Self::sample_state) gave: the model then answers as
    /// at that sample of the walk it was taken on (to its analyses' tolerance: their warm
    /// starts differ). False where it cannot (another model's state; the default).
    fn restore_sample(&self, _state: &SampleState) -> bool {
        false
    }
    /// Joints with play (names), in the order of [`OutputSensitivities::play`]. Default:
    /// none.
    fn play_sites(&self) -> Vec<String> {
        vec![]
    }
    /// The parameters (indices into [`parameters`](Self::parameters)) that are the contact
    /// compliance of play site `site`'s joint in the nominal model's terms: what the
    /// compression of its balls under the joint's own load reads as where no play is
    /// resolved (a play estimate below that compression). Default: none.
    fn play_site_compliance(&self, _site: usize) -> Vec<usize> {
        vec![]
    }
    /// Clearance sites (names), in the order of [`OutputSensitivities::sites`].
    fn clearance_sites(&self) -> Vec<String> {
        vec![]
    }
    /// Load scale over which a clearance changes sides (smooth sign), in the unit of the site
    /// loads.
    fn clearance_load_scale(&self) -> f64 {
        1.0
    }
    /// Torque scale over which a drive backlash changes sides, N·m.
    fn backlash_torque_scale(&self) -> f64 {
        0.1
    }
    /// A tag naming the configuration at one sample when it matters (e.g. "near the
    /// direct-kinematics singularity"), for the localisation.
    fn configuration_tag(&self, _theta: &[f64], _q: &[f64], _y: &[f64]) -> Option<String> {
        None
    }
}

/// The DFKI double pendulum's nominal model ([`DoublePendulumParams`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoublePendulumModel {
    /// Nominal parameters.
    pub params: DoublePendulumParams,
}

impl DoublePendulumModel {
    /// A two-link arm of round numbers (0.6 kg links, 0.3 m and 0.2 m long, no gear), for
    /// tests.
    #[cfg(test)]
    pub(crate) fn example() -> Self {
        Self {
            params: DoublePendulumParams {
                m1: 0.6,
                m2: 0.6,
                l1: 0.3,
                l2: 0.2,
                r1: 0.3,
                r2: 0.2,
                i1: 0.054,
                i2: 0.024,
                g: 9.81,
                tilt: 0.0,
                payload: 0.0,
                gear_ratio: None,
            },
        }
    }

    fn with(&self, theta: &[f64]) -> DoublePendulumParams {
        let mut p = self.params;
        p.l1 = theta[0];
        p.r1 = theta[1];
        p.r2 = theta[2];
        p.m2 = theta[3];
        p.i1 = theta[4];
        p.i2 = theta[5];
        p.tilt = theta[6];
        p.payload = theta[7];
        p
    }
}

impl InverseDynamicsModel for DoublePendulumModel {
    fn name(&self) -> String {
        "DFKI double pendulum (nominal rigid model of its README)".into()
    }
    /// The DFKI recordings' column names ([`DFKI_COLUMNS`]).
    fn column_defaults(&self) -> ColumnDefaults {
        ColumnDefaults::Fixed(DFKI_COLUMNS.into())
    }
    fn joints(&self) -> usize {
        2
    }
    fn joint_name(&self, j: usize) -> String {
        ["joint 1 (shoulder)", "joint 2 (elbow)"][j.min(1)].into()
    }
    fn parameters(&self) -> Vec<ModelParameter> {
        let p = &self.params;
        let mk = |name: &str, unit: &str, nominal: f64, scale: f64, family| ModelParameter {
            name: name.into(),
            unit: unit.into(),
            nominal,
            scale,
            family,
        };
        use ParameterFamily::*;
        vec![
            mk(
                "link 1 length l1 (joint-2 location)",
                "m",
                p.l1,
                p.l1,
                LinkGeometry,
            ),
            mk("link 1 centre of mass r1", "m", p.r1, p.l1, MassProperties),
            mk("link 2 centre of mass r2", "m", p.r2, p.l2, MassProperties),
            mk("link 2 mass m2", "kg", p.m2, p.m2, MassProperties),
            mk("link 1 inertia I1", "kg m^2", p.i1, p.i1, MassProperties),
            mk("link 2 inertia I2", "kg m^2", p.i2, p.i2, MassProperties),
            mk("base tilt", "rad", 0.0, 0.1, BaseTilt),
            mk("payload at the link-2 tip", "kg", 0.0, p.m2, Payload),
        ]
    }
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        let t = self
            .with(theta)
            .torques([q[0], q[1]], [qd[0], qd[1]], [qdd[0], qdd[1]]);
        tau[..2].copy_from_slice(&t);
    }
    /// Drive 1 sits on the base. Drive 2 sits on link 1 at the elbow: its rotor turns at
    /// q̇1 + N·q̇2 (N the gear ratio), so with J = I_rotor·N² it adds J/N² to M11, J/N to M12
    /// and J to M22.
    fn rotor_regressor(&self, j: usize, qdd: &[f64], out: &mut [f64]) {
        match (j, self.params.gear_ratio) {
            (1, Some(n)) if n > 0.0 => {
                out[0] = qdd[0] / (n * n) + qdd[1] / n;
                out[1] = qdd[0] / n + qdd[1];
            }
            _ => {
                out.iter_mut().for_each(|v| *v = 0.0);
                out[j] = qdd[j];
            }
        }
    }
}

/// The MR2120 as the diagnosis sees it: drive torques by the closed-form rigid model
/// ([`LumpedModel`]) and, as output channels, the platform centre (x, y, z) predicted from
/// the drive encoders through the compliant transmissions and the forward kinematics (the
/// output-error simulation of a position-driven 3-DOF mechanism). Its parameters: the six
/// link lengths, the arm and forearm masses, a payload, the base tilt about x and y, and the
/// three drive compliances. Its clearance sites: the joints of each leg, radially (play
/// along the forearm, on the side its tension or compression pushes to) and axially (along
/// the drive axis, on the side the axial joint load pushes to).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mr2120Model {
    /// The nominal model.
    pub nominal: LumpedModel,
}

/// Load scale over which a leg's clearance changes sides, N.
pub const MR2120_CLEARANCE_LOAD_SCALE: f64 = 1.0;
/// Torque scale over which a drive's backlash changes sides, N·m.
pub const MR2120_BACKLASH_TORQUE_SCALE: f64 = 0.2;
/// Direct-singularity measure below which the localisation tags a configuration as near it.
pub const MR2120_NEAR_DIRECT: f64 = 0.3;

impl Mr2120Model {
    /// The lumped model with parameter values `theta`.
    pub fn with(&self, theta: &[f64]) -> LumpedModel {
        let mut m = self.nominal;
        m.arm_length.copy_from_slice(&theta[0..3]);
        m.forearm_length.copy_from_slice(&theta[3..6]);
        m.compliance.copy_from_slice(&theta[11..14]);
        m.arm_mass = theta[6];
        m.forearm_mass = theta[7];
        m.payload = theta[8];
        m.gravity = tilted_gravity(theta[9], theta[10]);
        m
    }

    fn guess(y: &[f64]) -> Vector3<f64> {
        if y.len() == 3 && y.iter().all(|v| v.is_finite()) && y[2] > 0.0 {
            Vector3::new(y[0], y[1], y[2])
        } else {
            Vector3::new(0.0, 0.0, 0.5)
        }
    }

    /// The state at the arm angles: encoder angles less the transmission wind-up under the
    /// drive torques (fixed-point passes until the wind-up settles to 1e-12 rad; the torques
    /// change with the arm angles, strongly near the direct singularity).
    fn arm_state(
        &self,
        m: &LumpedModel,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        y: &[f64],
    ) -> Option<LumpedState> {
        let qe = [q[0], q[1], q[2]];
        let (qd, qdd) = ([qd[0], qd[1], qd[2]], [qdd[0], qdd[1], qdd[2]]);
        let mut s = m.state(qe, qd, qdd, Self::guess(y)).ok()?;
        let mut qa = qe;
        for _ in 0..20 {
            let next: [f64; 3] = std::array::from_fn(|i| qe[i] - m.compliance[i] * s.torque[i]);
            let change = (0..3).map(|i| (next[i] - qa[i]).abs()).fold(0.0, f64::max);
            qa = next;
            s = m.state(qa, qd, qdd, s.m).ok()?;
            if change < 1e-12 {
                break;
            }
        }
        Some(s)
    }
}

impl InverseDynamicsModel for Mr2120Model {
    fn name(&self) -> String {
        "WUT MR2120 (closed-form rigid model, compliant drives, tracked platform centre)".into()
    }
    fn joints(&self) -> usize {
        3
    }
    fn joint_name(&self, j: usize) -> String {
        format!("drive {}", ["A", "B", "C"][j.min(2)])
    }
    fn parameters(&self) -> Vec<ModelParameter> {
        let n = &self.nominal;
        let mk = |name: String, unit: &str, nominal: f64, scale: f64, family| ModelParameter {
            name,
            unit: unit.into(),
            nominal,
            scale,
            family,
        };
        use ParameterFamily::*;
        let mut p = vec![];
        for (i, b) in ["A", "B", "C"].iter().enumerate() {
            p.push(mk(
                format!("arm {b} length"),
                "m",
                n.arm_length[i],
                n.arm_length[i],
                LinkGeometry,
            ));
        }
        for (i, b) in ["A", "B", "C"].iter().enumerate() {
            p.push(mk(
                format!("forearm {b} length"),
                "m",
                n.forearm_length[i],
                n.forearm_length[i],
                LinkGeometry,
            ));
        }
        p.push(mk(
            "arm mass".into(),
            "kg",
            n.arm_mass,
            n.arm_mass,
            MassProperties,
        ));
        p.push(mk(
            "forearm mass".into(),
            "kg",
            n.forearm_mass,
            n.forearm_mass,
            MassProperties,
        ));
        p.push(mk(
            "payload on the platform".into(),
            "kg",
            n.payload,
            n.platform_mass,
            Payload,
        ));
        p.push(mk("base tilt about x".into(), "rad", 0.0, 0.1, BaseTilt));
        p.push(mk("base tilt about y".into(), "rad", 0.0, 0.1, BaseTilt));
        for (i, b) in ["A", "B", "C"].iter().enumerate() {
            p.push(mk(
                format!("drive {b} compliance"),
                "rad/(N m)",
                n.compliance[i],
                n.compliance[i].max(1e-9),
                DriveCompliance,
            ));
        }
        p
    }
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        let mut y = [0.0; 3];
        self.evaluate(theta, q, qd, qdd, tau, &mut y);
    }
    fn outputs(&self) -> usize {
        3
    }
    fn output_name(&self, k: usize) -> String {
        format!("platform {}", ["x", "y", "z"][k.min(2)])
    }
    fn output_role(&self, k: usize) -> String {
        ["x", "y", "z"][k.min(2)].into()
    }
    /// Synthetic recordings at a few hundred hertz: short windows suffice.
    fn derivative_windows(&self) -> Vec<usize> {
        vec![4, 6, 8, 12, 16]
    }
    fn evaluate(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64], y: &mut [f64]) {
        let m = self.with(theta);
        match self.arm_state(&m, q, qd, qdd, y) {
            Some(s) => {
                tau[..3].copy_from_slice(&s.torque);
                y[..3].copy_from_slice(s.m.as_slice());
            }
            None => {
                tau[..3].iter_mut().for_each(|v| *v = f64::NAN);
                y[..3].iter_mut().for_each(|v| *v = f64::NAN);
            }
        }
    }
    fn output_sensitivities(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        y: &[f64],
    ) -> Option<OutputSensitivities> {
        let m = self.with(theta);
        let s = self.arm_state(&m, q, qd, qdd, y)?;
        // ∂M/∂L2_i = Jx⁻¹ e_i L2_i = (column i of ∂M/∂q) · L2_i / Jq_i, since ∂M/∂q = Jx⁻¹ diag(Jq).
        // Radial play (along the forearm, side set by its tension), then axial play (the
        // elbow centre along the drive axis: ∂M/∂δ = Jx⁻¹ e_i (f_i·n_i), side set by the
        // axial joint load).
        let mut sites: Vec<(Vec<f64>, f64)> = (0..3)
            .map(|i| {
                let dy: Vec<f64> = (0..3)
                    .map(|k| s.jm[(k, i)] * m.forearm_length[i] / s.jq[i])
                    .collect();
                (dy, s.tension[i])
            })
            .collect();
        sites.extend((0..3).map(|i| {
            let dy: Vec<f64> = (0..3).map(|k| s.jm[(k, i)] * s.f_dot_axis[i] / s.jq[i]).collect();
            (dy, s.axial_force[i])
        }));
        Some(OutputSensitivities { sites, play: vec![] })
    }
    fn drive_compliance(&self, theta: &[f64], j: usize) -> f64 {
        theta[11 + j]
    }
    fn clearance_sites(&self) -> Vec<String> {
        let legs = ["A", "B", "C"];
        legs.iter()
            .map(|b| format!("radial clearance in the joints of leg {b} (along the forearm)"))
            .chain(
                legs.iter()
                    .map(|b| format!("axial clearance in the joints of leg {b} (along the drive axis)")),
            )
            .collect()
    }
    fn clearance_load_scale(&self) -> f64 {
        MR2120_CLEARANCE_LOAD_SCALE
    }
    fn backlash_torque_scale(&self) -> f64 {
        MR2120_BACKLASH_TORQUE_SCALE
    }
    fn configuration_tag(&self, theta: &[f64], q: &[f64], y: &[f64]) -> Option<String> {
        let m = self.with(theta);
        let s = m
            .state([q[0], q[1], q[2]], [0.0; 3], [0.0; 3], Self::guess(y))
            .ok()?;
        (s.direct_measure < MR2120_NEAR_DIRECT)
            .then(|| format!("near the direct-kinematics singularity (measure below {MR2120_NEAR_DIRECT})"))
    }
}
