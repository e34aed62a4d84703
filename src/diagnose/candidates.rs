//! The library of candidate physics. Each candidate is a parameterised extension of the
//! nominal model that vanishes at zero; in equation-error form it adds regressor columns to
//! the torque residual, exactly for effects linear in their parameters and to first order in
//! the others (model-parameter perturbations, delay):
//!
//! | effect | torque term on joint j |
//! |---|---|
//! | viscous friction | b·q̇_j |
//! | direction-dependent viscous friction | b₊·max(q̇_j, 0) + b₋·min(q̇_j, 0) (nests viscous) |
//! | Coulomb friction | c·tanh(q̇_j/v_c) for each v_c of the grid |
//! | Stribeck friction | s·tanh(q̇_j/v_c)·exp(−(q̇_j/v_s)²) for each v_s of the grid |
//! | direction-asymmetric friction | c₊·max(tanh(q̇_j/v_c), 0) + c₋·min(tanh(q̇_j/v_c), 0) (nests Coulomb) for each v_c |
//! | reflected rotor inertia | J·q̈_j, plus the coupling of a drive carried by a moving link (model-specific) |
//!
//! Units follow the joint ([`JointMotion`]): a prismatic joint's friction is in N and N s/m,
//! its velocity scales in m/s, its reflected inertia in kg. Its velocity scales v_c are chosen
//! from the data: fractions ([`LibraryOptions::relative_coulomb_velocities`]) of the joint's
//! typical speed in the fit recordings ([`LibraryOptions::speed_scales`]), as no fixed speed
//! suits every axis; a revolute joint keeps the absolute grid.
//! | torque-sensor offset | o |
//! | torque-sensor scale | (k − 1)·τ_j,nominal |
//! | torque-sensor delay | −d·dτ_j,nominal/dt |
//! | model parameter θ_k (link length, centre of mass, mass, inertia, base tilt, payload, drive compliance) | Δθ_k·∂τ/∂θ_k (all joints) and Δθ_k·∂y/∂θ_k (all outputs) |
//!
//! Models with outputs y (output-error channels, e.g. a tracked platform position predicted
//! from the joint positions) add candidates that act on them, and every joint-side torque
//! (friction) also winds up the drive's transmission, moving the outputs by
//! −∂y/∂q_j·c_j·τ (c_j the drive's compliance):
//!
//! | effect | output term |
//! |---|---|
//! | joint-position sensor offset o_j | −o_j·∂(τ, y)/∂q_j (torques too) |
//! | drive backlash b_j (half the play) | −b_j·∂y/∂q_j·tanh(τ_j/τ_b) for each τ_b of the grid ([`LibraryOptions::backlash_scale_factors`]); with the transmissions' dynamics, the wind-up's response δw to the joint-side torque b_j·K_j·tanh(τ_j/τ_b) instead, the outputs moved by it and the torque sensors reading K·δw + D·δẇ less that torque (the ringing where the transmission crosses its play); in the second pass ([`LibraryOptions::backlash_reference`]) the dead zone itself at the first pass's b_ref, b·response(b_ref)/b_ref ([`transmission::backlash_response`]), its play at the output or in the spring ([`LibraryOptions::backlash_place`], chosen by cross-validation) |
//! | clearance h at a site (e.g. the joints of a leg) | h·∂y/∂s·tanh(F/F_c), F the site's load |
//! | play h of a universal joint, radial or axial ([`crate::contact::play`]) | h·∂y/∂(shift, tilt)·(the shift toward the joint's load per unit clearance, over load scale F_c) |
//! | the same play, with its dynamics (the selection's second pass, or the play-dynamics check) | drive torques too: h·Δτ(h_ref)/h_ref, Δτ the reduced dynamic play model's response ([`super::play_dynamics`]) at a reference play h_ref of the same direction ([`LibraryOptions::dynamic_play_clearance`], [`LibraryOptions::dynamic_axial_play`]); in the second pass the tracker too, h·Δy(h_ref)/h_ref from the model's play coordinates and extra wind-up ([`LibraryOptions::dynamic_play_tracker`]) |
//! | output-sensor offset | o_k on output k |
//! | output-sensor delay | −d·dy_k/dt on output k |
use super::data::{Channel, ModelValues, MotionData};
use super::model::{
    on_copies, on_forks, DeclaredCandidate, InverseDynamicsModel, JointMotion, OutputSensitivities,
    ParameterFamily, PlayData, PlayDynamics, PlayPoint, SampleState,
};
use super::play_dynamics::{
    expanded_about, respond_stepped, BallContact, ContactDamping, ExpansionPoint, HertzBalls, Interpolation,
    JointPlay, PlayResponse, PlaySample, Stepping, BALL_CONTACT,
};
use super::signal::derivative;
use super::transmission::{self, TransmissionDynamics};
use serde::Serialize;

/// Every tunable of the candidate library.
#[derive(Debug, Clone, PartialEq)]
pub struct LibraryOptions {
    /// Velocity scales of the smooth sign in the friction laws, rad/s: how sharply friction
    /// changes sign as a joint reverses is not known, so Coulomb and direction-asymmetric
    /// friction get one candidate each per scale and cross-validation picks among them;
    /// Stribeck friction uses the first.
    pub coulomb_velocities: Vec<f64>,
    /// Stribeck velocities tried, rad/s (one candidate each).
    pub stribeck_velocities: Vec<f64>,
    /// Stribeck velocities for prismatic joints, as fractions of the joint's typical speed
    /// ([`speed_scales`](Self::speed_scales)).
    pub relative_stribeck_velocities: Vec<f64>,
    /// Load scales over which a joint with play moves across its clearance, N (one
    /// candidate each per joint and direction; cross-validation picks among them).
    pub play_load_scales: Vec<f64>,
    /// Torque scales over which a drive's backlash changes sides, as factors of the model's
    /// [`InverseDynamicsModel::backlash_torque_scale`] (one candidate each per drive;
    /// cross-validation picks among them): how sharply a transmission crosses its play as
    /// its torque reverses is not known beforehand.
    pub backlash_scale_factors: Vec<f64>,
    /// Backlash b_ref (half the play, rad) at which the backlash candidates' columns are the
    /// dead zone's secant response(b_ref)/b_ref ([`transmission::backlash_response`]: the
    /// transmission free within its play, integrated through each sample interval), where
    /// the model integrates its transmissions' wind-up
    /// ([`InverseDynamicsModel::integrates_windup`]) and the drive is compliant: one candidate
    /// per such drive then, named without a torque scale. `None` (the default), and for the
    /// other drives: first order in b, one candidate per torque scale of
    /// [`backlash_scale_factors`](Self::backlash_scale_factors). Set by the diagnosis'
    /// second pass to the backlash its first pass selected: the first-order form smooths the
    /// crossing of the play over a fixed torque scale, where the sensor reads nothing while
    /// the arm flies across it and then the strike (measured on the multibody suite's
    /// backlash case, diagnosis log).
    pub backlash_reference: Option<f64>,
    /// Where the play of a backlash taken at [`backlash_reference`](Self::backlash_reference)
    /// sits: in the transmission's spring (a dead zone) or between the spring and the arm
    /// (at the output, a gear mesh), [`transmission::PlayPlace`].
    pub backlash_place: transmission::PlayPlace,
    /// Velocity scales of the smooth sign for prismatic joints, as fractions of the joint's
    /// typical speed ([`speed_scales`](Self::speed_scales)).
    pub relative_coulomb_velocities: Vec<f64>,
    /// Typical speed of each joint in the fit recordings (its 95th-percentile |q̇|, rad/s or
    /// m/s), filled by the diagnosis from the data; empty: unknown (absolute grid).
    pub speed_scales: Vec<f64>,
    /// Candidates left out: every candidate whose name contains one of these texts
    /// (ignoring case). Each text must match at least one candidate
    /// ([`excluded_unknown`]).
    pub exclude: Vec<String>,
    /// Radial clearance h_ref (m) at which the radial-play candidates take drive-torque rows
    /// from the reduced dynamic play model ([`play_dynamics`](super::play_dynamics)): the
    /// secant response(h_ref)/h_ref, so a fitted h near h_ref reproduces the model's
    /// response at that clearance (the contact is nonlinear in h). `None` (the
    /// default): the play candidates have tracker rows only, the quasi-static shift. Set by
    /// the diagnosis' second pass or its play-dynamics check to the estimate of the radial
    /// play it selected; needs a model
    /// with [`play_dynamics`](InverseDynamicsModel::play_dynamics) and
    /// [`transmission_dynamics`](InverseDynamicsModel::transmission_dynamics).
    pub dynamic_play_clearance: Option<f64>,
    /// Axial play h_a,ref (m, total) at which the axial-play candidates take drive-torque
    /// rows from the reduced dynamic play model without radial clearance: the secant
    /// (response(h_a,ref) − response(0))/h_a,ref (the balls' radial compliance, which a ball
    /// that fits its bore does not have, taken out), as
    /// [`dynamic_play_clearance`](Self::dynamic_play_clearance) does for the radial ones.
    pub dynamic_axial_play: Option<f64>,
    /// The balls' contact damping in the reduced dynamic play model; `None`: that of
    /// [`BALL_CONTACT`].
    pub play_contact_damping: Option<ContactDamping>,
    /// Hertz's law per direction for the balls in the reduced dynamic play model, with the
    /// constants of the joint's own bearings at the reference play
    /// ([`HertzBalls::of`](super::play_dynamics::HertzBalls::of): a ball in a bore of that
    /// clearance, a ball on the bore's end face) instead of [`BALL_CONTACT`]'s one linear
    /// stiffness; the radial columns are then the response with the play less the response
    /// without (the balls' own compliance does not scale with the play), and each joint's
    /// compliance at zero play is a candidate of its own ([`Effect::ContactCompliance`], the
    /// response without play). Off in these options' own default; on in
    /// [`DiagnoseOptions::default`](super::DiagnoseOptions) since 2026-12-01 (the bearing
    /// preset, [`with_bearing_play`](super::DiagnoseOptions::with_bearing_play)). Alone,
    /// the model's joint follows the truth's (example `play_dynamics`), but in the suite's
    /// clearance-F case the diagnosis did worse (held out 3.35× against 3.01×, diagnosis log);
    /// with the rest of the preset, better.
    pub play_contact_hertz: bool,
    /// The linear law's stiffness of a ball on its bore's end face (N/m) in the reduced
    /// dynamic play model; `None`: [`BALL_CONTACT`]'s. Unused with
    /// [`play_contact_hertz`](Self::play_contact_hertz).
    pub play_axial_stiffness: Option<f64>,
    /// Re-linearise the reduced dynamic play model once about its own motion
    /// ([`InverseDynamicsModel::play_dynamics_at`], [`PlaySample::about`]) at the samples
    /// where its first response on some drive reaches [`RELINEARIZE_FRACTION`] of its
    /// largest over the data (near a singular position, where the play moves the mechanism
    /// far enough that the derivatives at the nominal configuration no longer carry the
    /// torques). Off in these options' own default; on in
    /// [`DiagnoseOptions::default`](super::DiagnoseOptions) since 2026-12-01 (the bearing
    /// preset). Alone: in the example `play_dynamics` (joint F, 6 µm, recording 5,
    /// Hertz balls) it took the load peak's window 2.60–2.77 s on drive A from 5.28 to 1.47
    /// torque-noise units, but in the suite's clearance-F case (linear balls) the diagnosis
    /// held out 3.10× against 3.01× without it, and the tracker got worse (platform z 1.9×
    /// against 1.5×): the tracker rows took the re-linearised play coordinates through the
    /// sample's output sensitivities (diagnosis log). Since 2026-11-30 they read the outputs at the
    /// expansion point to all orders and about it to first order ([`PlayPoint::outputs`],
    /// [`PlayResponse::point`]). Costs the play derivatives again at those samples
    /// (clearance-F: 28.6 against 16.7 CPU minutes).
    pub play_relinearize: bool,
    /// How the reduced dynamic play model's linearised mechanics varies within a sample
    /// interval ([`Interpolation`]). Held at each interval's end in these options' own
    /// default; blended in [`DiagnoseOptions::default`](super::DiagnoseOptions) since
    /// 2026-12-01 (the bearing preset). Alone, with linear
    /// balls and constant dampings (the defaults) the suite's bearing cases held out worse
    /// blended (clearance-F 3.70× against 3.18×, diagnosis log "Where the play sits: a gear mesh as
    /// the truth"), and with Hertz balls and a load-proportional damping not better either
    /// (diagnosis log "The rattle reproduced at the truth's play").
    pub play_interpolation: Interpolation,
    /// How the reduced dynamic play model steps through each sample interval
    /// ([`Stepping`]): resolved substeps by default, stiff ones with `lash diagnose
    /// --play-stiff-substeps` (about 4× less time in the model at 40 per interval). Not the
    /// default until the bearing cases have been run with them at every seed: at seed 2026
    /// clearance-F held out at 1.302× with them against 1.169× resolved, the diagnosis
    /// having chosen another of the contact dampings the fit recordings cannot tell apart
    /// (diagnosis log, "Stiff substeps for the reduced play model" and "The clearance-F miss
    /// with stiff substeps").
    pub play_stepping: Stepping,
    /// Whether the play candidates that take drive-torque rows from the reduced dynamic play
    /// model ([`dynamic_play_clearance`](Self::dynamic_play_clearance),
    /// [`dynamic_axial_play`](Self::dynamic_axial_play)) take their tracker rows from it too:
    /// its play coordinates through the nominal model's output sensitivities to the joint's
    /// shift and tilt, and its transmissions' extra wind-up through the outputs' sensitivity
    /// to the arms. Then there is one candidate per joint and direction, named "… (reduced
    /// dynamic model)", with no load-scale grid (the model carries the joint's load); at
    /// samples where the model gives no response the quasi-static shift at the grid's middle
    /// load scale stands in. Default true: measured against the truth's effect on the
    /// tracker (example `play_dynamics`, joint F, 6 µm; recording 5 platform z whole record
    /// 8.30 → 2.01 tracker-noise units left, against 4.66 by the quasi-static shift; diagnosis log).
    pub dynamic_play_tracker: bool,
    /// Only these candidates (exact names), if any: a fixed selection refitted.
    pub only: Vec<String>,
}

/// The first text of `opts.exclude` that matches no candidate of `model`'s full library, if
/// any (a misspelt exclusion would otherwise silently exclude nothing).
pub fn excluded_unknown(model: &dyn InverseDynamicsModel, opts: &LibraryOptions) -> Option<String> {
    let mut o = LibraryOptions {
        exclude: vec![],
        ..opts.clone()
    };
    let mut all = library(model, &o);
    // With the second pass's candidates too (the reduced dynamic model's, at a reference
    // play the first pass sets).
    if o.dynamic_play_clearance.is_none() {
        o.dynamic_play_clearance = Some(1e-6);
        all.extend(library(model, &o));
    }
    opts.exclude
        .iter()
        .find(|x| !all.iter().any(|c| excludes(x, &c.name)))
        .cloned()
}

fn excludes(text: &str, name: &str) -> bool {
    name.to_lowercase().contains(&text.to_lowercase())
}

impl LibraryOptions {
    /// The velocity scales of the smooth sign for joint `j` of `model`: for a prismatic joint
    /// with a known typical speed, fractions of it (rounded to two significant digits, so
    /// reports read cleanly); else the absolute grid.
    pub fn coulomb_velocities_for(&self, model: &dyn InverseDynamicsModel, j: usize) -> Vec<f64> {
        self.relative_for(
            model,
            j,
            &self.relative_coulomb_velocities,
            &self.coulomb_velocities,
        )
    }

    /// The Stribeck velocities for joint `j` of `model`: for a prismatic joint with a known
    /// typical speed, fractions of it; else the absolute grid.
    pub fn stribeck_velocities_for(&self, model: &dyn InverseDynamicsModel, j: usize) -> Vec<f64> {
        self.relative_for(
            model,
            j,
            &self.relative_stribeck_velocities,
            &self.stribeck_velocities,
        )
    }

    fn relative_for(
        &self,
        model: &dyn InverseDynamicsModel,
        j: usize,
        relative: &[f64],
        absolute: &[f64],
    ) -> Vec<f64> {
        match (model.joint_motion(j), self.speed_scales.get(j)) {
            (JointMotion::Linear, Some(&v)) if v > 0.0 && v.is_finite() && !relative.is_empty() => {
                relative.iter().map(|f| round2(f * v)).collect()
            }
            _ => absolute.to_vec(),
        }
    }
}

/// `x` rounded to two significant digits.
fn round2(x: f64) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.1e}").parse().unwrap_or(x)
}

impl LibraryOptions {
    /// The reference play (m) at which the candidates of a play `direction` take drive
    /// torques from the reduced dynamic play model, if set and positive.
    pub fn dynamic_play_reference(&self, direction: PlayDirection) -> Option<f64> {
        match direction {
            PlayDirection::Radial => self.dynamic_play_clearance,
            PlayDirection::Axial => self.dynamic_axial_play,
        }
        .filter(|h| *h > 0.0 && h.is_finite())
    }

    /// Whether the candidates of a play `direction` take their tracker rows from the reduced
    /// dynamic play model too ([`dynamic_play_tracker`](Self::dynamic_play_tracker)).
    pub fn dynamic_play_tracker_for(&self, direction: PlayDirection) -> bool {
        self.dynamic_play_tracker && self.dynamic_play_reference(direction).is_some()
    }
}

impl LibraryOptions {
    /// The backlash at which drive `j`'s backlash column is the dead zone's secant
    /// ([`backlash_reference`](Self::backlash_reference), where positive and finite), if the
    /// model integrates its transmissions' wind-up and drive j is compliant at `theta`.
    pub fn dead_zone_backlash(
        &self,
        model: &dyn InverseDynamicsModel,
        theta: &[f64],
        j: usize,
    ) -> Option<f64> {
        self.backlash_reference
            .filter(|b| *b > 0.0 && b.is_finite())
            .filter(|_| model.integrates_windup() && model.drive_compliance(theta, j) > 0.0)
    }
}

impl Default for LibraryOptions {
    /// v_c = 0.05 and 0.01 rad/s (above the rate noise of encoder-differentiated
    /// velocities, well below typical motion; a simulated Stribeck law regularised at
    /// 0.004 rad/s was named as Stribeck friction with 0.05 alone, as Coulomb friction with
    /// 0.01); Stribeck velocities 0.1, 0.3 and 1 rad/s; play load
    /// scales 1, 5 and 20 N; for prismatic joints v_c = 10 %, 3 % and 1 % of the joint's
    /// typical speed.
    fn default() -> Self {
        Self {
            coulomb_velocities: vec![0.05, 0.01],
            stribeck_velocities: vec![0.1, 0.3, 1.0],
            relative_stribeck_velocities: vec![0.1, 0.3, 1.0],
            play_load_scales: vec![1.0, 5.0, 20.0],
            backlash_scale_factors: vec![0.3, 1.0, 3.0],
            backlash_reference: None,
            backlash_place: transmission::PlayPlace::Output,
            relative_coulomb_velocities: vec![0.1, 0.03, 0.01],
            speed_scales: vec![],
            exclude: vec![],
            dynamic_play_clearance: None,
            dynamic_axial_play: None,
            play_contact_damping: None,
            play_contact_hertz: false,
            play_axial_stiffness: None,
            play_relinearize: false,
            play_interpolation: Interpolation::Held,
            play_stepping: Stepping::Resolved,
            dynamic_play_tracker: true,
            only: vec![],
        }
    }
}

/// Where the reduced dynamic play model is re-linearised about its own motion
/// ([`LibraryOptions::play_relinearize`]): at the samples whose first response on some drive
/// reaches this fraction of its largest over the data. A tenth: the samples near a singular
/// position, where the response peaks, and few others (each costs the play derivatives of
/// one site again).
pub const RELINEARIZE_FRACTION: f64 = 0.1;

/// What kind of physics a candidate is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum Effect {
    /// Viscous joint friction, N·m·s/rad (N·s/m for a prismatic joint).
    Viscous,
    /// Viscous friction that differs with the direction of motion (two coefficients).
    AsymmetricViscous,
    /// Coulomb joint friction, N·m.
    Coulomb {
        /// Velocity scale of the smooth sign, rad/s.
        v_c: f64,
    },
    /// Stribeck friction (extra static friction decaying with speed), N·m, at velocity v_s.
    Stribeck {
        /// Stribeck velocity, rad/s.
        v_s: f64,
    },
    /// Direction-asymmetric Coulomb friction (two levels), N·m.
    AsymmetricFriction {
        /// Velocity scale of the smooth sign, rad/s.
        v_c: f64,
    },
    /// Reflected rotor inertia of the drive, kg·m².
    RotorInertia,
    /// Torque-sensor offset, N·m.
    TorqueOffset,
    /// Torque-sensor scale error (k − 1), dimensionless.
    TorqueScale,
    /// Torque-sensor delay, s.
    TorqueDelay,
    /// Offset of a joint-position sensor (encoder), rad.
    PositionOffset,
    /// Backlash of a drive (half the play), rad, changing sides over the joint-side torque
    /// scale `scale` (N·m, or N for a prismatic drive).
    Backlash {
        /// Torque scale τ_b of the smooth sign tanh(τ/τ_b).
        scale: f64,
    },
    /// Clearance at a site of the model (index into its clearance sites), m.
    Clearance {
        /// Site index.
        site: usize,
    },
    /// Clearance in a joint with play (index into the model's play sites), in one direction,
    /// m; the joint sits where its load pushes it ([`crate::contact::play`]).
    Play {
        /// Play-site index.
        site: usize,
        /// Radial clearance (shift across the trunnion axes and the tilt it allows) or
        /// axial play (along them).
        direction: PlayDirection,
        /// Load scale over which the joint moves across its clearance, N.
        load_scale: f64,
    },
    /// The contact compliance of a joint with play (index into the model's play sites): its
    /// balls without clearance under Hertz's law, in the reduced dynamic play model, as a
    /// multiple of the response its bearing design gives (dimensionless; 1 = the design's
    /// compression under the joint's loads — Hertz's compression grows as the load to the
    /// 2/3, so this is not a scale of the contact constant). Only with
    /// [`LibraryOptions::play_contact_hertz`]: what the plays' columns (with the play less
    /// without) leave out.
    ContactCompliance {
        /// Play-site index.
        site: usize,
    },
    /// Offset of an output sensor (index of the output), in its unit.
    OutputOffset {
        /// Output index.
        output: usize,
    },
    /// Delay of an output sensor (index of the output), s.
    OutputDelay {
        /// Output index.
        output: usize,
    },
    /// Error of a nominal model parameter (index into the model's parameters).
    Parameter {
        /// Index.
        index: usize,
        /// Family.
        family: ParameterFamily,
    },
    /// A candidate the model declares (index into its
    /// [`declared_candidates`](InverseDynamicsModel::declared_candidates)): its parameters
    /// perturbed together.
    Declared {
        /// Index.
        group: usize,
    },
}

/// Which clearance of a joint with play a candidate fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlayDirection {
    /// Radial clearance h of the bearings: the shift across the trunnion axes and the tilt
    /// 4h/s it allows.
    Radial,
    /// Axial play h_a of the bearings: the shift along the trunnion axes.
    Axial,
}

/// One candidate: an effect, where it acts, and its parameter names/units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Candidate {
    /// Name for reports, e.g. "Coulomb friction in joint 2 (elbow)".
    pub name: String,
    /// The effect.
    pub effect: Effect,
    /// Joint it acts in (None: all joints, as model parameters do).
    pub joint: Option<usize>,
    /// Parameter names with units, one per regressor column.
    pub parameters: Vec<String>,
    /// Hyper-parameters chosen from a grid (counted in the information criterion).
    pub grid_parameters: usize,
    /// Physically plausible range of each parameter (friction and inertia are not negative,
    /// a torque sensor is not off by more than 50 %, a part is not off by more than half
    /// its size); a fit outside it is rejected as implausible.
    pub bounds: Vec<(f64, f64)>,
}

/// A one-parameter candidate acting in no particular joint, for tests: `name`, `effect`,
/// parameter "x", bounds ±1 (or 0…1 with `positive`).
#[cfg(test)]
pub(crate) fn test_candidate(name: &str, effect: Effect, positive: bool) -> Candidate {
    Candidate {
        name: name.into(),
        effect,
        joint: None,
        parameters: vec!["x".into()],
        grid_parameters: 0,
        bounds: vec![(if positive { 0.0 } else { -1.0 }, 1.0)],
    }
}

/// Per candidate, the candidates (indices into `cands`) that are the compliance of a play
/// candidate's joint: the model parameters it declares
/// ([`InverseDynamicsModel::play_site_compliance`]) and the joint's own contact compliance
/// under Hertz's law ([`Effect::ContactCompliance`] at the same play site); empty for the
/// others.
pub fn compliance_of(model: &dyn InverseDynamicsModel, cands: &[Candidate]) -> Vec<Vec<usize>> {
    cands
        .iter()
        .map(|c| match c.effect {
            Effect::Play { site, .. } => {
                let params = model.play_site_compliance(site);
                cands
                    .iter()
                    .enumerate()
                    .filter(|(_, d)| match d.effect {
                        Effect::Parameter { index, .. } => params.contains(&index),
                        Effect::ContactCompliance { site: s } => s == site,
                        _ => false,
                    })
                    .map(|(k, _)| k)
                    .collect()
            }
            _ => vec![],
        })
        .collect()
}

/// Builds the candidate library for a model.
pub fn library(model: &dyn InverseDynamicsModel, opts: &LibraryOptions) -> Vec<Candidate> {
    let mut out = vec![];
    let theta0: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    for j in 0..model.joints() {
        let jn = model.joint_name(j);
        let motion = model.joint_motion(j);
        let (effort, damping, rate) = (motion.effort(), motion.damping(), motion.rate());
        let inf = f64::INFINITY;
        let mk = |name: &str, effect, params: &[String], grid, bounds: &[(f64, f64)]| Candidate {
            name: format!("{name} in {jn}"),
            effect,
            joint: Some(j),
            parameters: params.to_vec(),
            grid_parameters: grid,
            bounds: bounds.to_vec(),
        };
        let pos = (0.0, inf);
        out.push(mk(
            "viscous friction",
            Effect::Viscous,
            &[format!("b [{damping}]")],
            0,
            &[pos],
        ));
        out.push(mk(
            "direction-dependent viscous friction",
            Effect::AsymmetricViscous,
            &[format!("b+ [{damping}]"), format!("b- [{damping}]")],
            0,
            &[pos, pos],
        ));
        let velocities = opts.coulomb_velocities_for(model, j);
        let sharpness = |v_c: f64| {
            if velocities.len() > 1 {
                (format!(" (v_c = {v_c} {rate})"), 1)
            } else {
                (String::new(), 0)
            }
        };
        for &v_c in &velocities {
            let (suffix, grid) = sharpness(v_c);
            let mut c = mk(
                "Coulomb friction",
                Effect::Coulomb { v_c },
                &[format!("c [{effort}]")],
                grid,
                &[pos],
            );
            c.name += &suffix;
            out.push(c);
        }
        for &v_s in &opts.stribeck_velocities_for(model, j) {
            out.push(mk(
                &format!("Stribeck friction (v_s = {v_s} {rate})"),
                Effect::Stribeck { v_s },
                &[format!("s [{effort}]")],
                1,
                &[pos],
            ));
        }
        for &v_c in &velocities {
            let (suffix, grid) = sharpness(v_c);
            let mut c = mk(
                "direction-asymmetric friction",
                Effect::AsymmetricFriction { v_c },
                &[format!("c+ [{effort}]"), format!("c- [{effort}]")],
                grid,
                &[pos, pos],
            );
            c.name += &suffix;
            out.push(c);
        }
        out.push(mk(
            "reflected rotor inertia",
            Effect::RotorInertia,
            &[format!("J [{}]", motion.inertia())],
            0,
            &[pos],
        ));
        out.push(mk(
            &format!("{}-sensor offset", motion.effort_word()),
            Effect::TorqueOffset,
            &[format!("o [{effort}]")],
            0,
            &[(-inf, inf)],
        ));
        out.push(mk(
            &format!("{}-sensor scale error", motion.effort_word()),
            Effect::TorqueScale,
            &["k-1 [-]".to_string()],
            0,
            &[(-0.5, 0.5)],
        ));
        out.push(mk(
            &format!("{}-sensor delay", motion.effort_word()),
            Effect::TorqueDelay,
            &["d [s]".to_string()],
            0,
            &[(-0.05, 0.05)],
        ));
        if model.outputs() > 0 {
            out.push(mk(
                "joint-position sensor offset",
                Effect::PositionOffset,
                &[format!("o [{}]", motion.position())],
                0,
                &[(-0.05, 0.05)],
            ));
            let base = model.backlash_torque_scale();
            // At a reference backlash the dead zone's secant (no torque scale).
            let scales: Vec<f64> = if opts.dead_zone_backlash(model, &theta0, j).is_some() {
                vec![base]
            } else {
                opts.backlash_scale_factors.iter().map(|f| f * base).collect()
            };
            for &scale in &scales {
                let mut c = mk(
                    "drive backlash",
                    Effect::Backlash { scale },
                    &[format!("b [{}]", motion.position())],
                    usize::from(scales.len() > 1),
                    &[(0.0, 0.05)],
                );
                if scales.len() > 1 {
                    // (Rounded to a millionth: 0.3 × 0.1 prints as 0.03.)
                    c.name += &format!(" (τ_b = {} {effort})", (scale * 1e6).round() / 1e6);
                }
                out.push(c);
            }
        }
    }
    for (site, name) in model.clearance_sites().iter().enumerate() {
        out.push(Candidate {
            name: name.clone(),
            effect: Effect::Clearance { site },
            joint: None,
            parameters: vec!["h [m]".into()],
            grid_parameters: 0,
            bounds: vec![(0.0, 0.01)],
        });
    }
    if model.outputs() > 0 {
        let grid = usize::from(opts.play_load_scales.len() > 1);
        for (site, joint) in model.play_sites().iter().enumerate() {
            for (direction, what) in [
                (PlayDirection::Radial, "radial clearance"),
                (PlayDirection::Axial, "axial play"),
            ] {
                if opts.dynamic_play_tracker_for(direction) {
                    // The reduced dynamic model gives every row: one candidate, its
                    // quasi-static stand-in at the grid's middle load scale.
                    let scales = &opts.play_load_scales;
                    out.push(Candidate {
                        name: format!("{what} in joint {joint} (reduced dynamic model)"),
                        effect: Effect::Play {
                            site,
                            direction,
                            load_scale: scales.get(scales.len() / 2).copied().unwrap_or(5.0),
                        },
                        joint: None,
                        parameters: vec!["h [m]".into()],
                        grid_parameters: 0,
                        bounds: vec![(0.0, 0.01)],
                    });
                    continue;
                }
                for &load_scale in &opts.play_load_scales {
                    out.push(Candidate {
                        name: format!("{what} in joint {joint} (load scale {load_scale} N)"),
                        effect: Effect::Play {
                            site,
                            direction,
                            load_scale,
                        },
                        joint: None,
                        parameters: vec!["h [m]".into()],
                        grid_parameters: grid,
                        bounds: vec![(0.0, 0.01)],
                    });
                }
            }
        }
    }
    // Under Hertz's law the plays' columns leave out the joints' compliance at zero play (a
    // ball that fits its bore, compressed by the joint's load): its own candidate per joint,
    // the reduced model's response without play.
    let hertz_dynamic = opts.play_contact_hertz
        && (opts.dynamic_play_reference(PlayDirection::Radial).is_some()
            || opts.dynamic_play_reference(PlayDirection::Axial).is_some());
    if model.outputs() > 0 && hertz_dynamic {
        for (site, joint) in model.play_sites().iter().enumerate() {
            out.push(Candidate {
                name: format!("contact compliance of joint {joint} (Hertz balls without clearance, reduced dynamic model)"),
                effect: Effect::ContactCompliance { site },
                joint: None,
                parameters: vec!["s [1]".into()],
                grid_parameters: 0,
                bounds: vec![(0.0, 10.0)],
            });
        }
    }
    for k in 0..model.outputs() {
        out.push(Candidate {
            name: format!("{} sensor offset", model.output_name(k)),
            effect: Effect::OutputOffset { output: k },
            joint: None,
            parameters: vec![format!("o [{}]", model.output_unit(k))],
            grid_parameters: 0,
            bounds: vec![(-f64::INFINITY, f64::INFINITY)],
        });
        out.push(Candidate {
            name: format!("{} sensor delay", model.output_name(k)),
            effect: Effect::OutputDelay { output: k },
            joint: None,
            parameters: vec!["d [s]".into()],
            grid_parameters: 0,
            bounds: vec![(-0.05, 0.05)],
        });
    }
    let declared = model.declared_candidates();
    let params = model.parameters();
    for (group, g) in declared.iter().enumerate() {
        out.push(Candidate {
            name: g.name.clone(),
            effect: Effect::Declared { group },
            joint: None,
            parameters: g
                .parameters
                .iter()
                .map(|&k| {
                    let p = &params[k];
                    format!("{} [{}]", p.name, p.unit)
                })
                .collect(),
            grid_parameters: 0,
            bounds: g.bounds.clone(),
        });
    }
    for (k, p) in params.iter().enumerate() {
        if declared.iter().any(|g| g.parameters.contains(&k)) {
            continue;
        }
        out.push(Candidate {
            name: format!("error in {}", p.name),
            effect: Effect::Parameter {
                index: k,
                family: p.family,
            },
            joint: None,
            parameters: vec![format!("delta [{}]", p.unit)],
            grid_parameters: 0,
            bounds: vec![match p.family {
                ParameterFamily::LinkGeometry => (-0.1 * p.scale, 0.1 * p.scale),
                ParameterFamily::MassProperties => (-0.5 * p.scale, 0.5 * p.scale),
                ParameterFamily::Payload => (0.0, p.scale),
                ParameterFamily::BaseTilt => (-0.2, 0.2),
                ParameterFamily::DriveCompliance => (-0.9 * p.scale, 10.0 * p.scale),
                // A joint's contact can only add compliance.
                ParameterFamily::JointCompliance => (0.0, p.scale),
            }],
        });
    }
    out.retain(|c| !opts.exclude.iter().any(|x| excludes(x, &c.name)));
    if !opts.only.is_empty() {
        out.retain(|c| opts.only.contains(&c.name));
    }
    out
}

/// The candidates' regressor columns on one recording ([`columns`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    /// `cols[c][k]` is column k of candidate c, stacked channel by channel in the order of
    /// [`MotionData::channels`] (the first channel's samples, then the second's, ...).
    pub cols: Vec<Vec<Vec<f64>>>,
    /// The nominal model's value of every channel (as [`MotionData::model_channels`]),
    /// which the columns are built around.
    pub nominal: Vec<Vec<f64>>,
    /// Per candidate, where its column carries its joint's contact compliance (a radial play
    /// in the reduced dynamic model on linear ball contacts: the balls' compression comes
    /// with the clearance and scales with it): the RMS over the recording of the most
    /// compressed ball's penetration under the joint's own load, m ([`compression_rms`]).
    /// A play estimate below it resolves no play: what the column fits is that compliance.
    pub compression: Vec<Option<f64>>,
}

/// RMS over the samples (those with a response) of the largest penetration of a joint's
/// balls, m: each ball's wall force (N) over the linear `stiffness` (N/m).
pub fn compression_rms(responses: &[Option<PlayResponse>], stiffness: f64) -> Option<f64> {
    let (ss, count) = responses
        .iter()
        .flatten()
        .map(|r| r.radial_forces.iter().fold(0.0f64, |m, f| m.max(*f)) / stiffness)
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(ss, k), v| (ss + v * v, k + 1));
    (count > 0 && stiffness > 0.0).then(|| (ss / count as f64).sqrt())
}

/// The reduced dynamic play model's run without play at one play site along one recording
/// ([`columns_with`]), made on first use: it does not depend on the play's size, so a search
/// over sizes computes it once.
pub type TightRun = std::sync::OnceLock<Vec<Option<PlayResponse>>>;

/// One [`TightRun`] per play site.
pub type TightRuns = Vec<TightRun>;

/// The nominal model's linearisations along one recording that [`columns_with`] builds on,
/// per sample: its output sensitivities, its transmissions' dynamics and its play sites'
/// dynamics ([`InverseDynamicsModel::play_dynamics`]). They depend on the model, its
/// nominal parameters and the recording, not on the reference plays or the contact laws
/// (`LibraryOptions::dynamic_play_clearance`, `play_contact_damping`), so the play-size and
/// damping searches' refits (`diagnose::play_size::HeldPlay`) walk each recording once: in
/// their phase of a diagnosis the play sites' dynamics were two thirds of the time (`perf`
/// on the seed-7 clearance-under-length case, session 65).
#[derive(Debug, Clone)]
pub struct NominalWalk {
    /// What was walked for: outputs recorded, a compliant drive, the play's derivatives.
    needs: (bool, bool, bool),
    sens: Vec<Option<OutputSensitivities>>,
    dynamics: Vec<Option<TransmissionDynamics>>,
    play_dyn: Vec<Option<Vec<PlayDynamics>>>,
    /// Per sample, the model's state after it ([`InverseDynamicsModel::sample_state`]), where
    /// a re-linearised play's run will ask about samples along the recording
    /// ([`LibraryOptions::play_relinearize`]) and the model gives it: the run then puts the
    /// model at each sample it asks about instead of walking the recording again (empty
    /// otherwise).
    states: std::sync::Arc<Vec<Option<SampleState>>>,
}

/// A fingerprint of a recording's motion (times, joint positions, rates and accelerations)
/// and a model's parameter values, to the bit: what the nominal channels depend on.
fn motion_key(d: &MotionData, theta: &[f64]) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let series = std::iter::once(&d.t[..])
        .chain(d.q.iter().chain(&d.qd).chain(&d.qdd).map(|v| &v[..]))
        .chain(std::iter::once(theta));
    for v in series {
        v.len().hash(&mut h);
        v.iter().for_each(|x| x.to_bits().hash(&mut h));
    }
    h.finish()
}

/// The [`NominalWalk`]s of one recording, each made on first use: one with the play sites'
/// dynamics and one without. An assembly that needs none (no play or contact-compliance
/// candidate among its columns) does not pay for them, and one that needs them is not handed
/// a walk made without them.
#[derive(Debug, Default)]
pub struct NominalWalkCache {
    /// The model's torques and outputs at every sample (the nominal channels), with the
    /// fingerprint of the motion and parameter values they were walked for
    /// ([`nominal_of`](Self::nominal_of)).
    nominal: std::sync::Mutex<Option<(u64, std::sync::Arc<ModelValues>)>>,
    with_play: std::sync::OnceLock<NominalWalk>,
    without_play: std::sync::OnceLock<NominalWalk>,
    /// The columns of the model passes made on the recording, kept for the later assemblies
    /// on the same recording and model ([`KeptPasses`]).
    passes: std::sync::Mutex<KeptPasses>,
}

/// Columns of whole model passes over one recording ([`pass_column`]: a parameter's
/// difference, an arm's lag), each made on a fresh copy of the model, with the nominal
/// channels they were made about. A pass's column depends only on the recording, the model
/// and those channels, so an assembly about the same channels (to the bit) takes it from
/// here rather than walking the recording twice more: the passes of a linearisation point's
/// contact dampings, end-face stiffnesses and resized reference plays, and their refits, are
/// then made once.
#[derive(Debug, Default)]
struct KeptPasses {
    nominal: Vec<Vec<f64>>,
    columns: std::collections::HashMap<Pass, Vec<f64>>,
}

impl KeptPasses {
    /// Whether the columns were made about `nominal` (the same numbers to the bit).
    fn about(&self, nominal: &[Vec<f64>]) -> bool {
        self.nominal.len() == nominal.len()
            && self
                .nominal
                .iter()
                .zip(nominal)
                .all(|(a, b)| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()))
    }
}

impl NominalWalkCache {
    /// Empty: nothing walked yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The slot for walks with (`play`) or without the play sites' dynamics.
    fn slot(&self, play: bool) -> &std::sync::OnceLock<NominalWalk> {
        if play {
            &self.with_play
        } else {
            &self.without_play
        }
    }

    /// The nominal channels kept under `key` ([`motion_key`]), else `make`'s, kept under it
    /// (in place of any kept under another key).
    fn nominal_of(&self, key: u64, make: impl FnOnce() -> ModelValues) -> std::sync::Arc<ModelValues> {
        if let Ok(kept) = self.nominal.lock() {
            if let Some((_, v)) = kept.as_ref().filter(|(k, _)| *k == key) {
                return v.clone();
            }
        }
        let made = std::sync::Arc::new(make());
        if let Ok(mut kept) = self.nominal.lock() {
            *kept = Some((key, made.clone()));
        }
        made
    }

    /// Whether the walk with the play sites' dynamics is in the cache.
    pub fn has_play_walk(&self) -> bool {
        self.with_play.get().is_some()
    }

    /// How many model passes' columns (a parameter's difference, an arm's lag) are kept for the
    /// later assemblies on the same recording and model.
    pub fn passes_kept(&self) -> usize {
        self.passes.lock().map_or(0, |k| k.columns.len())
    }

    /// The columns of `passes` kept from an assembly about `nominal` (None where not kept),
    /// the channels compared once.
    fn kept_passes(&self, passes: &[Pass], nominal: &[Vec<f64>]) -> Vec<Option<Vec<f64>>> {
        match self.passes.lock() {
            Ok(kept) if kept.about(nominal) => passes.iter().map(|p| kept.columns.get(p).cloned()).collect(),
            _ => vec![None; passes.len()],
        }
    }

    /// Keeps the columns `made` about `nominal` (those kept about other channels dropped).
    fn keep_passes<'a>(&self, nominal: &[Vec<f64>], made: impl Iterator<Item = (Pass, &'a Vec<f64>)>) {
        let Ok(mut kept) = self.passes.lock() else {
            return;
        };
        if !kept.about(nominal) {
            kept.nominal = nominal.to_vec();
            kept.columns.clear();
        }
        for (pass, col) in made {
            kept.columns.insert(pass, col.clone());
        }
    }
}

/// Regressor columns of every candidate on one recording, with the nominal model's value of
/// every channel and the play candidates' compressions ([`Columns`]).
pub fn columns(
    cands: &[Candidate],
    d: &MotionData,
    model: &dyn InverseDynamicsModel,
    opts: &LibraryOptions,
) -> Columns {
    columns_with(cands, d, model, opts, None, None)
}

/// [`columns`], taking the reduced play model's runs without play from `tight` (one per play
/// site of `model`, filled on first use) where given: a cache for calls on the same recording,
/// model and options but for the reference plays (`LibraryOptions::dynamic_play_clearance`,
/// `dynamic_axial_play`) and the candidates asked for (`LibraryOptions::only`, `cands`), which
/// those runs do not depend on (they read the candidates only for whether the play's
/// derivatives are needed at all, and are read only where they are). A cache of another
/// length is not used.
///
/// `walk`, where given, keeps the nominal model's linearisations along the recording
/// ([`NominalWalk`]) for later calls on the same recording and model; a walk made for other
/// needs (outputs, compliant drives, the play's derivatives) is not used.
pub fn columns_with(
    cands: &[Candidate],
    d: &MotionData,
    model: &dyn InverseDynamicsModel,
    opts: &LibraryOptions,
    tight: Option<&[TightRun]>,
    walk: Option<&NominalWalkCache>,
) -> Columns {
    columns_needed(cands, d, model, opts, tight, walk, None)
}

/// [`columns_with`], where `needed` is given (one flag per candidate), without computing the
/// columns of the parameter, play and contact-compliance candidates not needed: they come
/// out zero (and their compressions None). A parameter's column is a difference of two whole
/// passes of the model over the recording, a play's a run of the reduced play model (most of
/// a recording's columns' time), and each is finite at every sample (a non-finite value is
/// set to zero), so leaving them out changes neither which samples a
/// [`Prepared`](super::residuals::Prepared) leaves out nor, to the bit, any other column but
/// a play's re-linearised about its own motion ([`LibraryOptions::play_relinearize`]): that
/// run evaluates the model, whose position analyses start from the configuration it last
/// evaluated, so it may move within their tolerance (1e-12 m; on the suite's axial-D case the
/// held-out residuals moved by at most 8e-12 N·m and m). The held-out residual, which reads
/// only the selected candidates' columns, uses this.
pub(super) fn columns_needed(
    cands: &[Candidate],
    d: &MotionData,
    model: &dyn InverseDynamicsModel,
    opts: &LibraryOptions,
    tight: Option<&[TightRun]>,
    walk: Option<&NominalWalkCache>,
    needed: Option<&[bool]>,
) -> Columns {
    let needed = |c: usize| needed.is_none_or(|m| m.get(c).copied().unwrap_or(true));
    let chans = d.channels();
    let nc = chans.len();
    let n = d.len();
    let params = model.parameters();
    let theta0: Vec<f64> = params.iter().map(|p| p.nominal).collect();
    let declared_groups = model.declared_candidates();
    // (The same on every assembly on this recording and model: walked once where a cache
    // is given.)
    let nominal = match walk {
        Some(w) => w.nominal_of(motion_key(d, &theta0), || d.model_all(model, &theta0)),
        None => std::sync::Arc::new(d.model_all(model, &theta0)),
    };
    let (tau_nom, y_nom) = (&nominal.0, &nominal.1);
    let torque_row = |j: usize| chans.iter().position(|&c| c == Channel::Torque(j));
    let output_rows: Vec<(usize, usize)> = chans
        .iter()
        .enumerate()
        .filter_map(|(r, c)| match c {
            Channel::Output(k) => Some((r, *k)),
            Channel::Torque(_) => None,
        })
        .collect();
    // Output sensitivities and the transmissions' dynamics per sample (walking the
    // recording again, so a model with internal dynamics answers at each sample's state;
    // only when outputs are recorded or a transmission is compliant).
    // The drives whose transmissions are compliant (their arms lag their encoders).
    let compliant_drives: Vec<usize> = (0..model.joints())
        .filter(|&j| model.drive_compliance(&theta0, j) != 0.0)
        .collect();
    let compliant = !compliant_drives.is_empty();
    // Each output's row among the channels, if recorded.
    let output_row: Vec<Option<usize>> = (0..model.outputs())
        .map(|k| output_rows.iter().find(|(_, kk)| *kk == k).map(|(r, _)| *r))
        .collect();
    // The reduced dynamic play model's data, only where its torque rows are asked for: the
    // reference play per direction (radial, axial).
    let has_torques = chans.iter().any(|c| matches!(c, Channel::Torque(_)));
    let reference_for = |dir: PlayDirection| {
        opts.dynamic_play_reference(dir).filter(|_| {
            has_torques
                && cands
                    .iter()
                    .any(|c| matches!(c.effect, Effect::Play { direction, .. } if direction == dir))
        })
    };
    let play_references = [
        reference_for(PlayDirection::Radial),
        reference_for(PlayDirection::Axial),
    ];
    // Whether the play derivatives are needed: for a play's torque rows, or a joint's contact
    // compliance (the response at no play).
    let play_needed = play_references.iter().any(Option::is_some)
        || (has_torques
            && cands
                .iter()
                .any(|c| matches!(c.effect, Effect::ContactCompliance { .. })));
    // The nominal model placed at sample i (it walks the data in time order: its wind-up
    // state is sequential): the encoders' motion there and the nominal outputs.
    let model_at = |i: usize| {
        let (q, qd, qdd) = d.motion_at(i);
        let y: Vec<f64> = y_nom.iter().map(|v| v[i]).collect();
        let (mut tau, mut yy) = (vec![0.0; model.joints()], y.clone());
        model.evaluate_at(d.t[i], &theta0, &q, &qd, &qdd, &mut tau, &mut yy);
        (q, qd, qdd, y)
    };
    let needs = (!output_rows.is_empty(), compliant, play_needed);
    let walk_now = || {
        let mut w = NominalWalk {
            needs,
            sens: vec![],
            dynamics: vec![],
            play_dyn: vec![],
            states: Default::default(),
        };
        let keep_states = play_needed && opts.play_relinearize;
        let mut states = vec![];
        if !output_rows.is_empty() || compliant {
            for i in 0..n {
                let (q, qd, qdd, y) = model_at(i);
                if keep_states {
                    states.push(model.sample_state());
                }
                // (In this order: the play's derivatives perturb the model's cached sample.)
                w.sens.push(if output_rows.is_empty() {
                    None
                } else {
                    model.output_sensitivities(&theta0, &q, &qd, &qdd, &y)
                });
                let td = model.transmission_dynamics(&theta0);
                w.play_dyn.push(match &td {
                    Some(_) if play_needed => model.play_dynamics(&theta0, &q, &qd, &qdd),
                    _ => None,
                });
                w.dynamics.push(td);
            }
        }
        // (Kept only where the model gave a state at every sample.)
        if states.len() == n && states.iter().all(Option::is_some) {
            w.states = std::sync::Arc::new(states);
        }
        w
    };
    let fresh: NominalWalk;
    let walked: &NominalWalk = match walk.map(|c| c.slot(play_needed).get_or_init(walk_now)) {
        Some(w) if w.needs == needs && (w.sens.is_empty() || w.sens.len() == n) => w,
        _ => {
            fresh = walk_now();
            &fresh
        }
    };
    let (sens, dynamics, play_dyn, states) =
        (&walked.sens, &walked.dynamics, &walked.play_dyn, &walked.states);
    // Per play site and direction, the play's effect on the drive torques in the reduced
    // dynamic play model at the reference play along the recording. Radial: its response
    // (the balls' compliance comes with the clearance: a ball that fits its bore is a
    // conformal, much stiffer contact). Axial, where the radial clearance is zero: its
    // response with the play less its response without, which takes out the balls' radial
    // compliance that a ball fitting its bore does not have (measured, diagnosis log). Under Hertz's
    // law the radial response too is taken less the response without play: the balls' axial
    // contact on the bores' end faces is soft at any play, and that compliance must not scale
    // with the play (it is the joints' contact-compliance candidates': `ContactCompliance`,
    // and the legs' joint compliances).
    let contact = BallContact {
        axial_stiffness: opts.play_axial_stiffness.unwrap_or(BALL_CONTACT.axial_stiffness),
        ..BALL_CONTACT.with_damping(
            opts.play_contact_damping
                .unwrap_or(BALL_CONTACT.contact_damping()),
        )
    };
    let run = |site: usize, play: &JointPlay| -> Vec<Option<PlayResponse>> {
        // Hertz's law: the joint's own balls at this play's radial clearance.
        let hertz = opts
            .play_contact_hertz
            .then(|| play_dyn.iter().flatten().find_map(|p| p.get(site)))
            .flatten()
            .and_then(|p| HertzBalls::of(&p.play, play.radial).ok());
        let contact = BallContact { hertz, ..contact };
        let samples: Vec<Option<PlaySample>> = (0..n)
            .map(|i| match (play_dyn.get(i)?, dynamics.get(i)?) {
                (Some(p), Some(transmission)) => Some(PlaySample {
                    t: d.t[i],
                    play: p.get(site)?,
                    transmission,
                    about: None,
                }),
                _ => None,
            })
            .collect();
        let first = respond_stepped(
            &samples,
            play,
            &contact,
            opts.play_interpolation,
            opts.play_stepping,
        );
        if !opts.play_relinearize {
            return first;
        }
        // Once more, expanded about the first response's own motion where it is large.
        let size = |r: &PlayResponse| r.torque.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let largest = first.iter().flatten().map(size).fold(0.0, f64::max);
        if !(largest > 0.0 && largest.is_finite()) {
            return first;
        }
        // The model at each sample asked about: put there from the walk's states where it
        // kept them, else walked there from the recording's start.
        let restored = states.len() == n;
        let points: Vec<Option<PlayPoint>> = (0..n)
            .map(|i| {
                // (Walked through every sample; put back at those asked about only.)
                let walked = (!restored).then(|| model_at(i));
                let r = first[i]
                    .as_ref()
                    .filter(|r| size(r) >= RELINEARIZE_FRACTION * largest)?;
                let (q, qd, qdd) = match walked {
                    Some((q, qd, qdd, _)) => (q, qd, qdd),
                    None => d.motion_at(i),
                };
                if restored && !states[i].as_ref().is_some_and(|s| model.restore_sample(s)) {
                    return None;
                }
                model.play_dynamics_at(&theta0, &q, &qd, &qdd, site, &r.windup, r.offset)
            })
            .collect();
        if points.iter().all(Option::is_none) {
            return first;
        }
        let about = expanded_about(&samples, &points);
        respond_stepped(
            &about,
            play,
            &contact,
            opts.play_interpolation,
            opts.play_stepping,
        )
    };
    // Per sample, the play's effect in the reduced model: drive torques, play coordinates
    // and the transmissions' extra wind-up.
    type EffectSeries = Vec<Option<PlayResponse>>;
    let sites = model.play_sites().len();
    let own: TightRuns;
    let tight: &[TightRun] = match tight {
        Some(t) if t.len() == sites => t,
        _ => {
            own = (0..sites).map(|_| Default::default()).collect();
            &own
        }
    };
    // The run without play at a site (None: no such site).
    let without_play = |site: usize| {
        tight
            .get(site)
            .map(|cell| cell.get_or_init(|| run(site, &JointPlay::default())))
    };
    let play_effect: Vec<[std::cell::OnceCell<EffectSeries>; 2]> =
        (0..sites).map(|_| Default::default()).collect();
    let response_of = |site: usize, direction: PlayDirection| -> Option<(f64, &EffectSeries)> {
        let slot = match direction {
            PlayDirection::Radial => 0,
            PlayDirection::Axial => 1,
        };
        let reference = play_references[slot]?;
        let play = match direction {
            PlayDirection::Radial => JointPlay::radial(reference),
            PlayDirection::Axial => JointPlay::axial(reference),
        };
        let effect = play_effect.get(site)?[slot].get_or_init(|| {
            let with = run(site, &play);
            if direction == PlayDirection::Radial && !opts.play_contact_hertz {
                return with;
            }
            let Some(without) = without_play(site) else {
                return with;
            };
            let less = |a: &[f64], b: &[f64]| -> Vec<f64> { a.iter().zip(b).map(|(x, y)| x - y).collect() };
            with.iter()
                .zip(without)
                .map(|(a, b)| {
                    let (a, b) = (a.as_ref()?, b.as_ref()?);
                    Some(PlayResponse {
                        torque: less(&a.torque, &b.torque),
                        windup: less(&a.windup, &b.windup),
                        offset: std::array::from_fn(|c| a.offset[c] - b.offset[c]),
                        radial_forces: a.radial_forces,
                        point: ExpansionPoint::less(a.point.as_ref(), b.point.as_ref()),
                    })
                })
                .collect()
        });
        Some((reference, effect))
    };
    let dynamic = dynamics.iter().any(|x| x.is_some());
    let arm_rate: Vec<Vec<f64>> = (0..model.joints())
        .map(|j| {
            (0..n)
                .map(|i| {
                    let lag = dynamics
                        .get(i)
                        .and_then(|x| x.as_ref())
                        .and_then(|dy| dy.windup_rate.get(j).copied())
                        .unwrap_or(0.0);
                    d.qd[j][i] - lag
                })
                .collect()
        })
        .collect();
    let sgn_at = |v: f64, v_c: f64| (v / v_c).tanh();
    let first_vc = |j: usize| {
        opts.coulomb_velocities_for(model, j)
            .first()
            .copied()
            .unwrap_or(0.05)
    };
    // The columns that take whole passes of the model over the recording — a parameter's
    // difference, an arm's lag behind its encoder (−∂(every channel)/∂q_j: how the model's
    // channels move when arm j lags its encoder, wind-up included) — up front, side by side
    // on copies of the model where it makes them ([`InverseDynamicsModel::fork`]).
    // The nominal channels, for one-sided differences (a model that asks for them: each
    // evaluation costs a pass through an iterative model).
    let nom_channels: Vec<Vec<f64>> = chans
        .iter()
        .map(|c| match *c {
            Channel::Torque(j) => tau_nom[j].clone(),
            Channel::Output(k) => y_nom[k].clone(),
        })
        .collect();
    // The compliant drives' lags, where a torque through a drive moves channels by them:
    // every channel with the quasi-static wind-up, the outputs with the dynamic one.
    let drive_lags: &[usize] = if dynamic && output_rows.is_empty() {
        &[]
    } else {
        &compliant_drives
    };
    let passes = passes_of(cands, &needed, &declared_groups, drive_lags);
    // (Those a walk cache kept from an assembly on the same recording and model taken from
    // it; the others made, each on a fresh copy of the model as a whole batch's are, and
    // kept there.)
    let kept = walk.map_or_else(
        || vec![None; passes.len()],
        |w| w.kept_passes(&passes, &nom_channels),
    );
    let missing: Vec<Pass> = passes
        .iter()
        .zip(&kept)
        .filter(|(_, k)| k.is_none())
        .map(|(p, _)| *p)
        .collect();
    let column = |&pass: &Pass, m: &dyn InverseDynamicsModel| pass_column(pass, d, m, &theta0, &nom_channels);
    let made = if missing.len() == passes.len() {
        on_copies(&missing, model, &column)
    } else {
        on_forks(&missing, model, &column)
    };
    if let Some(w) = walk {
        w.keep_passes(&nom_channels, missing.iter().copied().zip(&made));
    }
    let mut made = made.into_iter();
    let mut passed: Vec<Vec<f64>> = kept
        .into_iter()
        .map(|k| k.or_else(|| made.next()).unwrap_or_default())
        .collect();
    let lag: Vec<std::cell::OnceCell<Vec<f64>>> =
        (0..model.joints()).map(|_| std::cell::OnceCell::new()).collect();
    let mut parameter_columns = std::collections::HashMap::new();
    for (pass, col) in passes.iter().zip(passed.drain(..)) {
        match *pass {
            Pass::Lag(j) => {
                let _ = lag[j].set(col);
            }
            Pass::Parameter(k) => {
                parameter_columns.insert(k, col);
            }
        }
    }
    // (Any other lag a column asks for, in turn on the model itself.)
    let lag_of = |j: usize| -> &Vec<f64> {
        lag[j].get_or_init(|| pass_column(Pass::Lag(j), d, model, &theta0, &nom_channels))
    };
    let parameter_column = |index: usize| -> Vec<f64> {
        parameter_columns
            .get(&index)
            .cloned()
            .unwrap_or_else(|| pass_column(Pass::Parameter(index), d, model, &theta0, &nom_channels))
    };
    // A torque g(i) acting on the joint side of drive j: the torque channel, and — through
    // the wind-up of the transmission — every channel as the arm lags its encoder. With the
    // transmissions' dynamics known, the wind-up is their linear response δw (every drive's:
    // the mass matrix couples them), the torque sensors read K·δw + D·δẇ, and the outputs
    // move by Σ_k δw_k·(−∂y/∂q_k) as the arms lag their encoders (the torques' own
    // configuration coupling is left out, see `transmission`); else the quasi-static wind-up
    // c_j·g. `share` of g is taken off drive j's torque sensor: 0 for a torque on the arm
    // (friction), 1 for a torque the transmission's spring itself loses (backlash), which
    // the sensor on the motor side does not read.
    // The columns of a transmission response (δw, δẇ and the torque taken off drive j's
    // sensor, per sample), times `per`: the torque sensors read K·δw + D·δẇ (less that
    // torque on drive j), the outputs move as the arms lag by δw.
    let from_response = |j: usize, response: &[transmission::Response], per: f64| {
        let mut c = vec![0.0; nc * n];
        let nj = model.joints();
        // (The arms' lag moves only the outputs here: none recorded, no lag walks.)
        let drives: &[usize] = if output_rows.is_empty() {
            &[]
        } else {
            &compliant_drives
        };
        for (i, x) in response.iter().enumerate() {
            let Some((w, wd, off)) = x else { continue };
            let Some(dy) = &dynamics[i] else { continue };
            let k = dy.stiffness();
            if k.len() != nj || dy.damping.len() != nj || w.len() != nj || wd.len() != nj {
                continue;
            }
            for a in 0..nj {
                if let Some(r) = torque_row(a) {
                    c[r * n + i] = per * (k[a] * w[a] + dy.damping[a] * wd[a]);
                    if a == j {
                        c[r * n + i] -= per * off;
                    }
                }
            }
            for &b in drives {
                let l = lag_of(b);
                for &(r, _) in &output_rows {
                    c[r * n + i] += per * w[b] * l[r * n + i];
                }
            }
        }
        c
    };
    let joint_torque_with_share = |j: usize, g: &dyn Fn(usize) -> f64, share: f64| {
        let mut c = vec![0.0; nc * n];
        if dynamic {
            let response: Vec<_> = transmission::joint_torque_response(&d.t, dynamics, j, g)
                .into_iter()
                .enumerate()
                .map(|(i, x)| x.map(|(w, wd)| (w, wd, share * g(i))))
                .collect();
            return from_response(j, &response, 1.0);
        }
        if let Some(r) = torque_row(j) {
            for i in 0..n {
                c[r * n + i] = (1.0 - share) * g(i);
            }
        }
        let cj = model.drive_compliance(&theta0, j);
        if cj != 0.0 {
            let l = lag_of(j);
            for r in 0..nc {
                for i in 0..n {
                    c[r * n + i] += cj * g(i) * l[r * n + i];
                }
            }
        }
        c
    };
    let joint_torque = |j: usize, g: &dyn Fn(usize) -> f64| joint_torque_with_share(j, g, 0.0);
    // The side a drive's backlash sits on at sample i, tanh(τ_j/τ_b) (0 where the nominal
    // torque is not finite).
    let backlash_side = |j: usize, scale: f64, i: usize| {
        let side = tau_nom[j][i] / scale;
        if side.is_finite() {
            side.tanh()
        } else {
            0.0
        }
    };
    // A torque seen by the torque sensor only.
    let sensor_torque = |j: usize, g: &dyn Fn(usize) -> f64| {
        let mut c = vec![0.0; nc * n];
        if let Some(r) = torque_row(j) {
            for i in 0..n {
                c[r * n + i] = g(i);
            }
        }
        c
    };
    let outputs_only = |g: &dyn Fn(usize, &OutputSensitivities, usize) -> f64| {
        let mut c = vec![0.0; nc * n];
        for &(r, k) in &output_rows {
            for i in 0..n {
                if let Some(s) = &sens[i] {
                    c[r * n + i] = g(k, s, i);
                }
            }
        }
        c
    };
    // Output k at sample i moved by play coordinates `offset` and extra wind-up `windup` of
    // play site `p`, to first order: through the output's sensitivities and the arms' lag.
    let linear_tracker = |k: usize, p: &PlayData, offset: &[f64; 4], windup: &[f64], i: usize| -> f64 {
        (0..3).map(|c| p.dy_dshift[c][k] * offset[c]).sum::<f64>()
            + p.dy_dtilt[k] * offset[3]
            + output_row[k].map_or(0.0, |ro| {
                compliant_drives
                    .iter()
                    .filter_map(|&b| Some(windup.get(b)? * lag_of(b)[ro * n + i]))
                    .sum::<f64>()
            })
    };
    // Output k at sample i moved by a reduced-model response `r` ([`PlayResponse::output`]).
    let dynamic_tracker = |k: usize, p: &PlayData, r: &PlayResponse, i: usize| -> f64 {
        r.output(k, |offset, windup| linear_tracker(k, p, offset, windup, i))
    };
    // A reduced-model response's drive torques, over `per`, into a column's torque rows.
    let torque_rows = |col: &mut [f64], response: &[Option<PlayResponse>], per: f64| {
        for (i, x) in response.iter().enumerate() {
            let Some(x) = x else { continue };
            for (a, v) in x.torque.iter().enumerate() {
                if let Some(r) = torque_row(a) {
                    col[r * n + i] = if v.is_finite() { v / per } else { 0.0 };
                }
            }
        }
    };
    let cols = cands
        .iter()
        .enumerate()
        .map(|(ci, c)| match (c.effect, c.joint) {
            // (Zeros, as many columns as the candidate has.)
            _ if !needed(ci) && finite_everywhere(c) => match c.effect {
                Effect::Declared { group } => declared_groups
                    .get(group)
                    .map(|g| vec![vec![0.0; nc * n]; g.parameters.len()])
                    .unwrap_or_default(),
                _ => vec![vec![0.0; nc * n]],
            },
            (Effect::Parameter { index, .. }, _) => vec![parameter_column(index)],
            (Effect::Declared { group }, _) => declared_groups
                .get(group)
                .map(|g| {
                    g.parameters
                        .iter()
                        .map(|&index| parameter_column(index))
                        .collect()
                })
                .unwrap_or_default(),
            (Effect::PositionOffset, Some(j)) => {
                // Measured = true + o, so the model sees q − o: column −∂(τ, y)/∂q_j.
                vec![lag_of(j).clone()]
            }
            (Effect::Backlash { .. }, Some(j))
                if dynamic && opts.dead_zone_backlash(model, &theta0, j).is_some() =>
            {
                // The dead zone's secant at the reference backlash: its response there,
                // integrated through each sample interval, per radian of it.
                let b = opts.dead_zone_backlash(model, &theta0, j).unwrap_or(1.0);
                let response = transmission::backlash_response(&d.t, dynamics, j, b, opts.backlash_place);
                vec![from_response(j, &response, 1.0 / b)]
            }
            (Effect::Backlash { scale }, Some(j)) if dynamic && model.drive_compliance(&theta0, j) > 0.0 => {
                // With the transmissions' dynamics: backlash b takes K_j·clip(w_j, ±b) out
                // of the spring's torque K_j·w_j, i.e. adds that much joint-side torque to
                // the wind-up's equation, M·δẅ + D·δẇ + (K + S)·δw = K_j·clip(w_j, ±b)·e_j;
                // to first order in b, with the wind-up's sign smoothed as the quasi-static
                // form has it, the forcing is b·K_j·tanh(τ_j/τ_b). The arms lag by δw (b
                // in drive j at rest), the torque sensors read K·δw + D·δẇ less the
                // forcing itself on drive j (nothing at rest, the ringing when the
                // transmission crosses its play as its torque reverses).
                let kj = 1.0 / model.drive_compliance(&theta0, j);
                vec![joint_torque_with_share(
                    j,
                    &|i| kj * backlash_side(j, scale, i),
                    1.0,
                )]
            }
            (Effect::Backlash { scale }, Some(j)) => {
                // The arm lags its encoder by b·tanh(τ_j/τ_b).
                let l = lag_of(j);
                let side: Vec<f64> = (0..n).map(|i| backlash_side(j, scale, i)).collect();
                let col = (0..nc * n).map(|k| side[k % n] * l[k]).collect();
                vec![col]
            }
            (Effect::Clearance { site }, _) => {
                let fc = model.clearance_load_scale();
                vec![outputs_only(&|k, s, _| {
                    s.sites
                        .get(site)
                        .map(|(dy, load)| dy[k] * (load / fc).tanh())
                        .unwrap_or(0.0)
                })]
            }
            (
                Effect::Play {
                    site,
                    direction,
                    load_scale,
                },
                _,
            ) => {
                // The tracker: the quasi-static shift toward the load, or where asked, the
                // reduced dynamic model's play coordinates and extra wind-up (the
                // quasi-static shift where the model gave no response).
                let dynamic_effect = response_of(site, direction).filter(|_| opts.dynamic_play_tracker);
                let mut col = outputs_only(&|k, s, i| {
                    let Some(p) = s.play.get(site) else { return 0.0 };
                    if let Some((h, Some(r))) =
                        dynamic_effect.map(|(h, e)| (h, e.get(i).and_then(|x| x.as_ref())))
                    {
                        let v = dynamic_tracker(k, p, r, i) / h;
                        return if v.is_finite() { v } else { 0.0 };
                    }
                    let sh = p.play.shift_with_cross_weight(
                        &p.z_i,
                        &p.z_j,
                        &p.force,
                        &p.moment,
                        &p.cross_load,
                        load_scale,
                    );
                    let v = match direction {
                        PlayDirection::Radial => {
                            (0..3)
                                .map(|c| p.dy_dshift[c][k] * sh.radial_translation[c])
                                .sum::<f64>()
                                + p.dy_dtilt[k] * sh.radial_tilt
                        }
                        PlayDirection::Axial => {
                            (0..3).map(|c| p.dy_dshift[c][k] * sh.axial_translation[c]).sum()
                        }
                    };
                    if v.is_finite() {
                        v
                    } else {
                        0.0
                    }
                });
                // The drive torques: the reduced dynamic model's secant at the reference play.
                if let Some((h, effect)) = response_of(site, direction) {
                    torque_rows(&mut col, effect, h);
                }
                vec![col]
            }
            (Effect::ContactCompliance { site }, _) => {
                // The reduced model's run without play: drive torques, and on the outputs its
                // play coordinates and extra wind-up (whatever the plays' tracker rows).
                let Some(without) = without_play(site) else {
                    return vec![vec![0.0; nc * n]];
                };
                let mut col = outputs_only(&|k, s, i| {
                    let (Some(p), Some(Some(r))) = (s.play.get(site), without.get(i)) else {
                        return 0.0;
                    };
                    let v = dynamic_tracker(k, p, r, i);
                    if v.is_finite() {
                        v
                    } else {
                        0.0
                    }
                });
                torque_rows(&mut col, without, 1.0);
                vec![col]
            }
            (Effect::OutputDelay { output }, _) => {
                let mut col = vec![0.0; nc * n];
                if let Some(r) = chans.iter().position(|&c| c == Channel::Output(output)) {
                    let dy = derivative(&d.t, &y_nom[output], 2);
                    for i in 0..n {
                        col[r * n + i] = if dy[i].is_finite() { -dy[i] } else { 0.0 };
                    }
                }
                vec![col]
            }
            (Effect::OutputOffset { output }, _) => {
                let mut col = vec![0.0; nc * n];
                if let Some(r) = chans.iter().position(|&c| c == Channel::Output(output)) {
                    col[r * n..(r + 1) * n].iter_mut().for_each(|v| *v = 1.0);
                }
                vec![col]
            }
            (e, Some(j)) => {
                // Friction acts at the arm's rate: the encoder's less the nominal wind-up
                // rate where the model carries one.
                let qd = &arm_rate[j];
                match e {
                    Effect::Viscous => vec![joint_torque(j, &|i| qd[i])],
                    Effect::AsymmetricViscous => vec![
                        joint_torque(j, &|i| qd[i].max(0.0)),
                        joint_torque(j, &|i| qd[i].min(0.0)),
                    ],
                    Effect::Coulomb { v_c } => vec![joint_torque(j, &|i| sgn_at(qd[i], v_c))],
                    Effect::Stribeck { v_s } => vec![joint_torque(j, &|i| {
                        sgn_at(qd[i], first_vc(j)) * (-(qd[i] / v_s).powi(2)).exp()
                    })],
                    Effect::AsymmetricFriction { v_c } => vec![
                        joint_torque(j, &|i| sgn_at(qd[i], v_c).max(0.0)),
                        joint_torque(j, &|i| sgn_at(qd[i], v_c).min(0.0)),
                    ],
                    Effect::RotorInertia => {
                        let mut col = vec![0.0; nc * n];
                        let (mut a, mut out) = (vec![0.0; model.joints()], vec![0.0; model.joints()]);
                        for i in 0..n {
                            for k in 0..model.joints() {
                                a[k] = d.qdd[k][i];
                            }
                            model.rotor_regressor(j, &a, &mut out);
                            for k in 0..model.joints() {
                                if let Some(r) = torque_row(k) {
                                    col[r * n + i] = out[k];
                                }
                            }
                        }
                        vec![col]
                    }
                    Effect::TorqueOffset => vec![sensor_torque(j, &|_| 1.0)],
                    Effect::TorqueScale => vec![sensor_torque(j, &|i| tau_nom[j][i])],
                    Effect::TorqueDelay => {
                        let dt = derivative(&d.t, &tau_nom[j], 2);
                        vec![sensor_torque(j, &|i| -dt[i])]
                    }
                    _ => vec![vec![0.0; nc * n]],
                }
            }
            (_, None) => vec![vec![0.0; nc * n]],
        })
        .collect();
    // A radial play's column on linear contacts carries the balls' compression (under
    // Hertz's law, or axially, the response is taken less the joint's without play).
    let compression = cands
        .iter()
        .enumerate()
        .map(|(ci, c)| match c.effect {
            _ if !needed(ci) => None,
            Effect::Play {
                site,
                direction: PlayDirection::Radial,
                ..
            } if !opts.play_contact_hertz => {
                compression_rms(response_of(site, PlayDirection::Radial)?.1, contact.stiffness)
            }
            _ => None,
        })
        .collect();
    Columns {
        cols,
        nominal: nom_channels,
        compression,
    }
}

/// Whether a candidate's columns are finite at every sample (where the model or the reduced
/// play model gives no number, zero), so that leaving them out of an assembly changes no
/// sample it leaves out ([`columns_needed`]): a parameter's differences ([`pass_column`]), a
/// play's and a contact compliance's responses. These are also the costly ones: whole
/// passes of the model, or runs of the reduced play model, over the recording.
fn finite_everywhere(c: &Candidate) -> bool {
    matches!(
        c.effect,
        Effect::Parameter { .. }
            | Effect::Declared { .. }
            | Effect::Play { .. }
            | Effect::ContactCompliance { .. }
    )
}

/// A sensitivity column that takes whole passes of the model over a recording.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Pass {
    /// The difference in parameter k.
    Parameter(usize),
    /// The lag of arm j behind its encoder: −∂(every channel)/∂q_j.
    Lag(usize),
}

/// Step of the lag's central difference, rad (or m).
const LAG_STEP: f64 = 1e-6;

/// The passes the candidates' columns will ask for: every parameter a `needed` candidate
/// perturbs, every arm whose encoder offset or backlash is a candidate, and — where friction
/// or play acts through the drives — the lags of `drive_lags`.
fn passes_of(
    cands: &[Candidate],
    needed: &dyn Fn(usize) -> bool,
    declared: &[DeclaredCandidate],
    drive_lags: &[usize],
) -> Vec<Pass> {
    let mut out: Vec<Pass> = vec![];
    let mut add = |p: Pass| {
        if !out.contains(&p) {
            out.push(p);
        }
    };
    let mut through_drives = false;
    for (ci, c) in cands.iter().enumerate() {
        match (c.effect, c.joint) {
            _ if !needed(ci) && finite_everywhere(c) => {}
            (Effect::Parameter { index, .. }, _) => add(Pass::Parameter(index)),
            (Effect::Declared { group }, _) => {
                for &index in declared.get(group).map_or(&[][..], |g| &g.parameters[..]) {
                    add(Pass::Parameter(index));
                }
            }
            (Effect::PositionOffset | Effect::Backlash { .. }, Some(j)) => add(Pass::Lag(j)),
            (
                Effect::Viscous
                | Effect::AsymmetricViscous
                | Effect::Coulomb { .. }
                | Effect::Stribeck { .. }
                | Effect::AsymmetricFriction { .. }
                | Effect::Play { .. }
                | Effect::ContactCompliance { .. },
                _,
            ) => through_drives = true,
            _ => {}
        }
    }
    if through_drives {
        for &j in drive_lags {
            add(Pass::Lag(j));
        }
    }
    out
}

/// One pass's column (channels stacked as in [`columns`]): central differences, or
/// one-sided ones from `nominal` where the model asks for them.
fn pass_column(
    pass: Pass,
    d: &MotionData,
    model: &dyn InverseDynamicsModel,
    theta0: &[f64],
    nominal: &[Vec<f64>],
) -> Vec<f64> {
    let h = match pass {
        Pass::Parameter(k) => model.parameter_step(k),
        Pass::Lag(_) => LAG_STEP,
    };
    let side = |sign: f64| match pass {
        Pass::Parameter(k) => {
            let mut theta = theta0.to_vec();
            theta[k] += sign * h;
            d.model_channels(model, &theta)
        }
        Pass::Lag(j) => {
            // The arm lags: the model sees the encoder less the lag.
            let mut moved = d.clone();
            moved.q[j].iter_mut().for_each(|v| *v -= sign * h);
            moved.model_channels(model, theta0)
        }
    };
    let plus = side(1.0);
    let (minus, width) = if model.one_sided_differences() {
        (None, h)
    } else {
        (Some(side(-1.0)), 2.0 * h)
    };
    let minus = minus.as_deref().unwrap_or(nominal);
    let n = d.len();
    let mut col = vec![0.0; plus.len() * n];
    for (r, (a, b)) in plus.iter().zip(minus).enumerate() {
        for i in 0..n {
            let v = (a[i] - b[i]) / width;
            col[r * n + i] = if v.is_finite() { v } else { 0.0 };
        }
    }
    col
}

/// The recording that would separate two candidates the data cannot tell apart, as a clause
/// ("… would separate them"), or why none can on a mechanism of `joints` joints.
pub fn separating_experiment(a: &Candidate, b: &Candidate, joints: usize) -> String {
    use Effect::*;
    let inertia_like = |e: Effect| {
        matches!(
            e,
            RotorInertia
                | Parameter {
                    family: super::model::ParameterFamily::MassProperties,
                    ..
                }
        )
    };
    if joints == 1 && inertia_like(a.effect) && inertia_like(b.effect) {
        return "no recording separates them on a one-joint mechanism: the drive's reflected inertia moves with the mass it drives, so the two are one effect in different units".into();
    }
    format!("{} would separate them", recording_for(a, b))
}

/// The recording that separates two candidates (a noun phrase).
fn recording_for(a: &Candidate, b: &Candidate) -> String {
    use Effect::*;
    let joint = |c: &Candidate| match (c.joint, c.effect) {
        (Some(j), _) => format!("joint {}", j + 1),
        // A play or clearance names its place: "radial clearance in joint F (…)", "contact
        // compliance of joint F (…)".
        (None, Play { .. } | Clearance { .. } | ContactCompliance { .. }) => c
            .name
            .split(" (")
            .next()
            .and_then(|head| head.rsplit_once(" in ").or_else(|| head.rsplit_once(" of ")))
            .map_or("the joints".into(), |(_, place)| place.to_string()),
        (None, _) => "the joints".into(),
    };
    let friction = |e: Effect| {
        matches!(
            e,
            Viscous | AsymmetricViscous | Coulomb { .. } | Stribeck { .. } | AsymmetricFriction { .. }
        )
    };
    let play = |e: Effect| matches!(e, Backlash { .. } | Clearance { .. } | Play { .. });
    match (a.effect, b.effect) {
        (ContactCompliance { .. }, Play { .. } | Clearance { .. }) | (Play { .. } | Clearance { .. }, ContactCompliance { .. }) => format!(
            "a run that raises the load on {} slowly from small to large without reversing it, then reverses it (the contact's compression grows with the load, the play is taken up at the reversal)",
            joint(if matches!(a.effect, ContactCompliance { .. }) { a } else { b })
        ),
        (ContactCompliance { .. }, ContactCompliance { .. }) => format!(
            "a motion that loads {} and {} in different proportions (two joints in series on one link, as the two joints of a leg, carry the same force in every motion: for them only a sensor between the two, such as a tracker on that link, or a load applied to that link)",
            joint(a),
            joint(b)
        ),
        (ContactCompliance { .. }, Parameter { .. }) | (Parameter { .. }, ContactCompliance { .. }) => format!(
            "a run that loads {} from small to large forces at one pose (a Hertz contact stiffens with its load, a linear compliance does not)",
            joint(if matches!(a.effect, ContactCompliance { .. }) { a } else { b })
        ),
        (x, y) if (friction(x) && play(y)) || (play(x) && friction(y)) => format!(
            "a slow motion that reverses the velocity of {} while the loads keep their sign, then one that reverses the loads at constant velocity (friction flips with the velocity, play with the load)",
            joint(if a.joint.is_some() { a } else { b })
        ),
        (Backlash { .. }, Clearance { .. }) | (Clearance { .. }, Backlash { .. }) => format!(
            "a motion that reverses the torque of {} while the forces in the other links keep their sign (backlash follows the drive torque, clearance the joint's own load)",
            joint(if a.joint.is_some() { a } else { b })
        ),
        (x, y) if friction(x) && friction(y) => format!(
            "a run holding {} at several constant speeds, slow and fast, in both directions (friction against speed)",
            joint(a)
        ),
        (RotorInertia, y) | (y, RotorInertia) if friction(y) => format!(
            "a run moving {} at several frequencies, and one at constant speeds (inertia acts with the acceleration, friction with the velocity)",
            joint(if a.joint.is_some() { a } else { b })
        ),
        (x, Parameter { .. }) | (Parameter { .. }, x) if friction(x) => format!(
            "a run holding {} at several constant speeds in both directions (friction acts with the speed, masses and lengths through gravity and acceleration)",
            joint(if a.joint.is_some() { a } else { b })
        ),
        (RotorInertia, Parameter { .. }) | (Parameter { .. }, RotorInertia) => format!(
            "a run accelerating {} hard while the other joints stay still (rotor inertia acts on that joint alone)",
            joint(if a.joint.is_some() { a } else { b })
        ),
        (x, TorqueOffset) | (TorqueOffset, x) if friction(x) => format!(
            "a motion that reverses {} under a load that does not (friction flips sign with the velocity, an offset does not)",
            joint(a)
        ),
        (Parameter { .. }, Parameter { .. }) => {
            "poses spanning the whole range of both joints, held still (gravity torques separate masses, lengths and tilt)"
                .into()
        }
        (TorqueScale, _) | (_, TorqueScale) => {
            "a run with a known external load (a calibrated weight or force) to calibrate the effort sensor".into()
        }
        _ if a.joint.is_some() && a.joint == b.joint => format!(
            "a run moving {} through a wider range of speeds, accelerations and loads, each varied on its own",
            joint(a)
        ),
        _ => format!(
            "a motion that reverses the load in {} and in {} at different times",
            joint(a),
            joint(b)
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::play::UniversalPlay;
    use crate::diagnose::model::{ModelParameter, PlayData};
    use crate::diagnose::play_dynamics::fixtures;
    use nalgebra::Vector3;

    /// Two joints' plays are told apart by a recording that names both joints (the
    /// candidates carry no drive index: the place comes from the name).
    #[test]
    fn the_experiment_separating_two_plays_names_their_joints() {
        let play = |joint: &str, site| {
            test_candidate(
                &format!("radial clearance in joint {joint} (reduced dynamic model)"),
                Effect::Play {
                    site,
                    direction: PlayDirection::Radial,
                    load_scale: 5.0,
                },
                true,
            )
        };
        let text = separating_experiment(&play("F", 2), &play("R", 5), 3);
        assert!(text.contains("in joint F and in joint R"), "{text}");
        // A joint's contact compliance against its own play: one place, loaded without and
        // then with a reversal.
        let own = test_candidate(
            "contact compliance of joint F (Hertz balls without clearance, reduced dynamic model)",
            Effect::ContactCompliance { site: 2 },
            true,
        );
        let text = separating_experiment(&own, &play("F", 2), 3);
        assert!(text.contains("the load on joint F slowly"), "{text}");
        assert!(!text.contains("the joints"), "{text}");
        // Two joints' compliances: loaded in different proportions, which no motion gives
        // two joints in series on one link (the text says so, not "reverse the loads").
        let other = test_candidate(
            "contact compliance of joint R (Hertz balls without clearance, reduced dynamic model)",
            Effect::ContactCompliance { site: 5 },
            true,
        );
        let text = separating_experiment(&own, &other, 3);
        assert!(
            text.contains("loads joint F and joint R in different proportions"),
            "{text}"
        );
        assert!(text.contains("in series") && !text.contains("reverses"), "{text}");
    }

    /// A play's compliance is its joint's own contact compliance (same play site) beside
    /// the parameters the model declares; another site's is not.
    #[test]
    fn a_plays_compliance_is_its_own_sites_contact_compliance() {
        let play = test_candidate(
            "radial clearance in joint F (reduced dynamic model)",
            Effect::Play {
                site: 0,
                direction: PlayDirection::Radial,
                load_scale: 5.0,
            },
            true,
        );
        let contact = |site| test_candidate("contact compliance", Effect::ContactCompliance { site }, true);
        let cands = vec![
            play,
            contact(0),
            contact(1),
            test_candidate("torque offset", Effect::TorqueOffset, false),
        ];
        assert_eq!(
            compliance_of(&Carried, &cands),
            vec![vec![1], vec![], vec![], vec![]]
        );
    }

    /// Torque on the drive per metre of the joint's shift along z, N·m/m.
    const TAU_PER_M: f64 = 1000.0;

    /// One compliant drive carrying a universal joint with play (axes x and y, n = z) whose
    /// load along z follows the drive's angle, 200 N · tanh(q / 0.01 rad): it reverses where
    /// q crosses zero. One output, the drive's angle.
    struct Carried;

    fn load(q: f64) -> f64 {
        200.0 * (q / 0.01).tanh()
    }

    impl InverseDynamicsModel for Carried {
        fn name(&self) -> String {
            "carried".into()
        }
        fn joints(&self) -> usize {
            1
        }
        fn joint_name(&self, _j: usize) -> String {
            "drive".into()
        }
        fn parameters(&self) -> Vec<ModelParameter> {
            vec![]
        }
        fn torques(&self, _theta: &[f64], _q: &[f64], _qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
            tau[0] = 0.1 * qdd[0];
        }
        fn outputs(&self) -> usize {
            1
        }
        fn evaluate(
            &self,
            theta: &[f64],
            q: &[f64],
            qd: &[f64],
            qdd: &[f64],
            tau: &mut [f64],
            y: &mut [f64],
        ) {
            self.torques(theta, q, qd, qdd, tau);
            y[0] = q[0];
        }
        fn output_sensitivities(
            &self,
            _theta: &[f64],
            q: &[f64],
            _qd: &[f64],
            _qdd: &[f64],
            _y: &[f64],
        ) -> Option<OutputSensitivities> {
            Some(OutputSensitivities {
                sites: vec![],
                play: vec![PlayData {
                    dy_dshift: [vec![0.0], vec![0.0], vec![1.0]],
                    dy_dtilt: vec![0.0],
                    z_i: Vector3::x(),
                    z_j: Vector3::y(),
                    force: Vector3::new(0.0, 0.0, load(q[0])),
                    moment: Vector3::zeros(),
                    cross_load: Vector3::zeros(),
                    play: UniversalPlay {
                        ball_spacing: 0.024,
                        ball_radius: 0.004,
                        material: crate::contact::Material::steel(),
                    },
                }],
            })
        }
        fn drive_compliance(&self, _theta: &[f64], _j: usize) -> f64 {
            1e-4
        }
        fn transmission_dynamics(&self, _theta: &[f64]) -> Option<TransmissionDynamics> {
            Some(fixtures::one_drive())
        }
        fn integrates_windup(&self) -> bool {
            true
        }
        fn play_dynamics(
            &self,
            _theta: &[f64],
            q: &[f64],
            _qd: &[f64],
            _qdd: &[f64],
        ) -> Option<Vec<PlayDynamics>> {
            WALKED.with(|c| c.set(c.get() + 1));
            Some(vec![fixtures::hanging_joint(load(q[0]), TAU_PER_M)])
        }
        /// The exact expansion of this mechanism (linear in the play: the same coupling, the
        /// torques moved by T_e·e), counting the calls.
        fn play_dynamics_at(
            &self,
            _theta: &[f64],
            q: &[f64],
            _qd: &[f64],
            _qdd: &[f64],
            _site: usize,
            windup: &[f64],
            offset: [f64; 4],
        ) -> Option<PlayPoint> {
            EXPANSIONS.with(|c| c.set(c.get() + 1));
            Some(PlayPoint {
                windup: windup.to_vec(),
                offset,
                dynamics: fixtures::hanging_joint(load(q[0]), TAU_PER_M),
                torque: vec![TAU_PER_M * offset[2]],
                load_stiffness: nalgebra::DMatrix::zeros(1, 1),
                mass: nalgebra::DMatrix::from_element(1, 1, 0.01),
                outputs: vec![],
            })
        }
        fn play_sites(&self) -> Vec<String> {
            vec!["F".into()]
        }
    }

    /// [`Carried`] swung as 0.3 rad · cos(π t) over `n` samples 2 ms apart, its torque
    /// read as zero.
    fn carried_swing(n: usize) -> MotionData {
        let t: Vec<f64> = (0..n).map(|i| 0.002 * i as f64).collect();
        let w = std::f64::consts::PI;
        let q: Vec<f64> = t.iter().map(|t| 0.3 * (w * t).cos()).collect();
        MotionData {
            name: "carried".into(),
            t: t.clone(),
            q: vec![q.clone()],
            qd: vec![t.iter().map(|t| -0.3 * w * (w * t).sin()).collect()],
            qdd: vec![t.iter().map(|t| -0.3 * w * w * (w * t).cos()).collect()],
            qdd_noise: vec![],
            tau: vec![vec![0.0; n]],
            y: vec![q],
            ends_dropped: 0,
        }
    }

    /// Weights and noise floors (torque, output) of the held-play tests.
    const HELD_WEIGHTS: [f64; 2] = [0.01, 1e-6];
    const HELD_FLOORS: [f64; 2] = [0.002, 2e-7];

    /// The size search's refit on `Carried` for the play `name` among `selected`.
    fn held_play<'a>(
        recordings: &'a [MotionData],
        o: &crate::diagnose::DiagnoseOptions,
        selected: &[String],
        name: &str,
    ) -> crate::diagnose::play_size::HeldPlay<'a> {
        crate::diagnose::play_size::HeldPlay::new(
            &Carried,
            recordings,
            o,
            selected,
            name,
            &HELD_WEIGHTS,
            &HELD_FLOORS,
            None,
        )
        .expect("assembled")
        .expect("the play is a candidate")
    }

    /// The held-play tests' library: plays at one load scale, the radial ones with their
    /// dynamics at a reference play `h` (m).
    fn held_library(h: f64) -> LibraryOptions {
        LibraryOptions {
            play_load_scales: vec![5.0],
            dynamic_play_clearance: Some(h),
            ..LibraryOptions::default()
        }
    }

    /// The carried joint's radial play with its dynamics (the held-play tests' play).
    const HELD_PLAY: &str = "radial clearance in joint F (reduced dynamic model)";

    /// [`HELD_PLAY`]'s candidate at reference play `h` (m), alone.
    fn held_play_candidate(h: f64) -> Vec<Candidate> {
        let play: Vec<Candidate> = library(&Carried, &held_library(h))
            .into_iter()
            .filter(|c| c.name == HELD_PLAY)
            .collect();
        assert_eq!(play.len(), 1);
        play
    }

    /// The play-size search's refit ([`HeldPlay`](crate::diagnose::play_size::HeldPlay))
    /// holds the play's effect at the reduced model's at each trial size: on recordings
    /// whose channels are the nominal model's plus that effect at 5 µm, nothing remains at
    /// 5 µm, and at 5.5 µm exactly the difference of the model's two responses remains.
    #[test]
    fn a_play_held_at_its_size_leaves_nothing_and_at_another_the_difference_of_the_responses() {
        let h0 = 5e-6;
        let opts = held_library;
        let name = HELD_PLAY;
        let play = held_play_candidate(h0);
        let n = 401;
        // The effect, h·column at reference h, per channel (torque, then output).
        let effect = |d: &MotionData, h: f64| {
            let c = columns(&play, d, &Carried, &opts(h));
            let col = &c.cols[0][0];
            (c.nominal, col.iter().map(|v| h * v).collect::<Vec<f64>>())
        };
        let recordings: Vec<MotionData> = (0..2)
            .map(|r| {
                let mut d = carried_swing(n + 100 * r);
                d.name = format!("carried-{r}");
                let m = d.len();
                let (nominal, e) = effect(&d, h0);
                d.tau[0] = (0..m).map(|i| nominal[0][i] + e[i]).collect();
                d.y[0] = (0..m).map(|i| nominal[1][i] + e[m + i]).collect();
                d
            })
            .collect();
        let o = crate::diagnose::DiagnoseOptions {
            library: opts(h0),
            ..crate::diagnose::DiagnoseOptions::default()
        };
        let floors = HELD_FLOORS;
        let held = held_play(&recordings, &o, &[name.to_string()], name);
        let at_size = held.cv(h0).expect("assembled").expect("one column");
        let off = held.cv(1.1 * h0).expect("assembled").expect("one column");
        // What remains at 5.5 µm, in noise floors, from the responses directly.
        let (mut ss, mut count) = (0.0, 0);
        for d in &recordings {
            let m = d.len();
            let (_, a) = effect(d, h0);
            let (_, b) = effect(d, 1.1 * h0);
            for (k, (x, y)) in a.iter().zip(&b).enumerate() {
                ss += ((x - y) / floors[k / m]).powi(2);
                count += 1;
            }
        }
        let expected = (ss / count as f64).sqrt();
        assert!(expected > 1.0, "a size 10 % off shows: {expected}");
        assert!(
            at_size < 1e-9 * expected,
            "{at_size} at the size, {expected} off it"
        );
        assert!(
            (off - expected).abs() < 1e-9 * expected,
            "{off} against {expected}"
        );
    }

    /// The probe tests' two recordings: `Carried`'s swings with the nominal channels plus
    /// `play`'s effect at `truth` (m), its columns taken with `lib`.
    fn probe_recordings(play: &[Candidate], lib: &LibraryOptions, truth: f64) -> Vec<MotionData> {
        (0..2)
            .map(|r| {
                let mut d = carried_swing(201 + 50 * r);
                d.name = format!("carried-{r}");
                let m = d.len();
                let c = columns(play, &d, &Carried, lib);
                let col = &c.cols[0][0];
                d.tau[0] = (0..m).map(|i| c.nominal[0][i] + truth * col[i]).collect();
                d.y[0] = (0..m).map(|i| c.nominal[1][i] + truth * col[m + i]).collect();
                d
            })
            .collect()
    }

    /// [`probe_play`](crate::diagnose::play_size::probe_play) of [`HELD_PLAY`] alone on
    /// `Carried`'s `recordings` with library `lib` and contact dampings `dampings`, `tries`
    /// counting its refits.
    fn probe(
        recordings: &[MotionData],
        lib: LibraryOptions,
        dampings: &[crate::diagnose::play_dynamics::ContactDamping],
        tries: &mut usize,
    ) -> crate::diagnose::play_size::ProbeRefits {
        let o = crate::diagnose::DiagnoseOptions {
            library: lib,
            ..crate::diagnose::DiagnoseOptions::default()
        };
        crate::diagnose::play_size::probe_play(
            &Carried,
            recordings,
            &o,
            &[],
            HELD_PLAY,
            dampings,
            &HELD_WEIGHTS,
            &HELD_FLOORS,
            None,
            &mut || *tries += 1,
        )
        .expect("assembled")
        .expect("the play is a candidate")
    }

    /// The probe for a play the first pass did not see
    /// ([`probe_play`](crate::diagnose::play_size::probe_play)): on recordings whose channels
    /// are the nominal model's plus the reduced model's effect at 6.2 µm — between two of the
    /// grid's sizes — it refits at every size of the grid in order, then refines about the
    /// best to within the size search's last step, calls its progress once per refit with
    /// the play, and the refit without the play is worse than the best.
    #[test]
    fn the_play_probe_walks_its_grid_then_refines_to_the_size_that_made_the_data() {
        let truth = 6.2e-6;
        let opts = held_library;
        let play = held_play_candidate(truth);
        let recordings = probe_recordings(&play, &opts(truth), truth);
        let mut tries = 0;
        let refits = probe(
            &recordings,
            opts(crate::diagnose::PROBE_PLAY_SIZES.0),
            &[],
            &mut tries,
        );
        let (without, log) = (refits.without, refits.sizes);
        assert!(refits.dampings.is_empty());
        let grid = crate::diagnose::probe_play_sizes();
        assert_eq!(tries, log.len());
        assert!(log.len() > grid.len(), "refined after the grid: {log:?}");
        let own = crate::diagnose::play_dynamics::BALL_CONTACT.contact_damping();
        assert!(tries <= crate::diagnose::play_size::probe_refits_most(own, &[]));
        for (k, h) in grid.iter().enumerate() {
            assert_eq!(log[k].0, *h);
        }
        let (best, cv) = crate::diagnose::play_size::best_size(&log).expect("a refit");
        let last = crate::diagnose::PLAY_SIZE_STEPS[crate::diagnose::PLAY_SIZE_STEPS.len() - 1] - 1.0;
        assert!((best / truth - 1.0).abs() <= last, "{best} from {log:?}");
        // The grid's nearest sizes are 6.12 and 6.73 µm: the refinement did better than both.
        let grid_best = crate::diagnose::play_size::best_size(&log[..grid.len()]).expect("a refit");
        assert!(cv < grid_best.1, "{cv} against the grid's {grid_best:?}");
        assert!(without > 10.0 * cv, "without the play {without}, with it {cv}");
    }

    /// The probe searches the size at each other contact damping of the grid
    /// ([`probe_play`](crate::diagnose::play_size::probe_play)): on recordings made with the
    /// reduced model's effect at 6.2 µm under a load-proportional damping (20 N·s/m +
    /// 500 s/m × F), the grid at the options' own damping (2000 N·s/m) and its refinement
    /// are followed by a size search at the load-proportional damping from the best size there,
    /// which finds the size within the search's last step and refits better than any size
    /// at the own damping; the baseline without the play is worse.
    #[test]
    fn the_play_probe_searches_the_size_at_each_other_damping_and_keeps_the_best_pair() {
        use crate::diagnose::play_dynamics::ContactDamping;
        let truth = 6.2e-6;
        let made_with = ContactDamping::load_proportional(500.0);
        let own = ContactDamping::constant(2000.0);
        let opts = |h: f64, c: ContactDamping| LibraryOptions {
            play_contact_damping: Some(c),
            ..held_library(h)
        };
        let play: Vec<Candidate> = library(&Carried, &opts(truth, made_with))
            .into_iter()
            .filter(|c| c.name == HELD_PLAY)
            .collect();
        let recordings = probe_recordings(&play, &opts(truth, made_with), truth);
        let mut tries = 0;
        let refits = probe(
            &recordings,
            opts(crate::diagnose::PROBE_PLAY_SIZES.0, own),
            &[own, made_with],
            &mut tries,
        );
        assert_eq!(tries, refits.sizes.len() + refits.dampings.len());
        // Within the count the probe's progress label gives as its most.
        assert!(tries <= crate::diagnose::play_size::probe_refits_most(own, &[own, made_with]));
        // The own damping is not searched twice.
        assert!(!refits.dampings.is_empty() && refits.dampings.iter().all(|x| x.0 == made_with));
        let (_, own_best) = crate::diagnose::play_size::best_size(&refits.sizes).expect("a refit");
        let (c, h, cv) = refits.best().expect("a refit");
        let last = crate::diagnose::PLAY_SIZE_STEPS[crate::diagnose::PLAY_SIZE_STEPS.len() - 1] - 1.0;
        assert_eq!(c, made_with, "{refits:?}");
        assert!((h / truth - 1.0).abs() <= last, "{h} from {:?}", refits.dampings);
        assert!(cv < own_best, "{cv} against {own_best} at the own damping");
        assert!(
            refits.without > 10.0 * cv,
            "without the play {}, with it {cv}",
            refits.without
        );
        // The baseline on the best refit's samples: at its damping and size.
        let at = crate::diagnose::DiagnoseOptions {
            library: opts(crate::diagnose::PROBE_PLAY_SIZES.0, made_with),
            ..crate::diagnose::DiagnoseOptions::default()
        };
        let baseline = held_play(&recordings, &at, &[HELD_PLAY.to_string()], HELD_PLAY)
            .cv_without(h)
            .expect("assembled")
            .expect("one column");
        assert_eq!(refits.without, baseline);
    }

    /// A first pass (no re-linearisation) on the carried joint's recordings of a 5 µm play,
    /// one load scale, and its candidate library: the diagnosis the probe's gate tests edit.
    fn carried_first_pass() -> (crate::diagnose::Diagnosis, Vec<Candidate>) {
        let recordings = carried_recordings(5e-6);
        let opts = crate::diagnose::DiagnoseOptions {
            library: LibraryOptions {
                play_load_scales: vec![5.0],
                ..LibraryOptions::default()
            },
            relinearize: false,
            ..crate::diagnose::DiagnoseOptions::default()
        };
        let d = crate::diagnose::diagnose(&Carried, &recordings[..3], &recordings[3..], &opts, |_, _| {})
            .expect("a diagnosis");
        (d, library(&Carried, &opts.library))
    }

    /// The probe runs on one signature only
    /// ([`unseen_play`](crate::diagnose::relinearize::unseen_play)): a first pass that
    /// selected no play, whose best candidate alone by cross-validation is a play (either
    /// direction) with an estimate outside its bounds that cross-validates better than
    /// nothing.
    #[test]
    fn the_play_probe_runs_only_where_an_implausible_play_is_best_alone_and_none_was_selected() {
        let (d, cands) = carried_first_pass();
        let play = "radial clearance in joint F (load scale 5 N)";
        assert!(cands.iter().any(|c| c.name == play));
        let other = cands
            .iter()
            .find(|c| !matches!(c.effect, Effect::Play { .. }))
            .expect("a candidate other than a play")
            .name
            .clone();
        let ranked = |candidate: &str, cv_ratio: f64, plausible: bool| crate::diagnose::Ranked {
            candidate: candidate.into(),
            statistic: 100.0,
            p_value: 0.0,
            cv_ratio,
            plausible,
        };
        let with = |selected: Vec<String>, ranking: Vec<crate::diagnose::Ranked>| {
            let mut e = d.clone();
            (e.selected, e.ranking) = (selected, ranking);
            crate::diagnose::relinearize::unseen_play(&Carried, &e, &cands)
        };
        // The signature: the play first, implausible, better than nothing; nothing selected
        // or something else selected.
        let signature = vec![ranked(play, 0.8, false), ranked(&other, 0.9, true)];
        assert_eq!(with(vec![], signature.clone()), Some((play.to_string(), 0)));
        assert_eq!(
            with(vec![other.clone()], signature.clone()),
            Some((play.to_string(), 0))
        );
        // A play selected: the first pass saw one.
        assert_eq!(with(vec![play.to_string()], signature), None);
        // The play plausible, or not first, or no better than nothing: no probe.
        assert_eq!(with(vec![], vec![ranked(play, 0.8, true)]), None);
        assert_eq!(
            with(vec![], vec![ranked(play, 0.8, false), ranked(&other, 0.7, true)]),
            None
        );
        assert_eq!(with(vec![], vec![ranked(play, 1.0, false)]), None);
        // An axial play's signature probes its joint too; a ratio that is not a number is
        // passed over; an empty ranking or a name the library does not have: no probe.
        let axial = cands
            .iter()
            .find(|c| {
                matches!(
                    c.effect,
                    Effect::Play {
                        direction: PlayDirection::Axial,
                        ..
                    }
                )
            })
            .expect("an axial play candidate")
            .name
            .clone();
        assert_eq!(
            with(vec![], vec![ranked(&axial, 0.8, false)]),
            Some((axial.clone(), 0))
        );
        assert_eq!(
            with(
                vec![],
                vec![ranked(&other, f64::NAN, true), ranked(play, 0.8, false)]
            ),
            Some((play.to_string(), 0))
        );
        assert_eq!(with(vec![], vec![]), None);
        assert_eq!(with(vec![], vec![ranked("no such candidate", 0.5, false)]), None);
        // Something other than a play first, implausible: no probe.
        assert_eq!(
            with(vec![], vec![ranked(&other, 0.5, false), ranked(play, 0.8, false)]),
            None
        );
    }

    /// The probe's second signature
    /// ([`play_behind_backlash`](crate::diagnose::relinearize::play_behind_backlash)): a
    /// first pass that selected a drive backlash and no play, beside an unstable estimate,
    /// probes the play that cross-validated best alone among the plays below 1, in its own
    /// direction, whatever ranks above it and however plausible it is; with every estimate
    /// stable it does not.
    #[test]
    fn a_backlash_selected_without_a_play_probes_the_best_play_alone_in_its_direction() {
        let (d, cands) = carried_first_pass();
        let name_of = |f: &dyn Fn(&Effect) -> bool| {
            cands
                .iter()
                .find(|c| f(&c.effect))
                .map(|c| c.name.clone())
                .expect("the candidate")
        };
        let backlash = name_of(&|e| matches!(e, Effect::Backlash { .. }));
        let radial = name_of(&|e| {
            matches!(
                e,
                Effect::Play {
                    direction: PlayDirection::Radial,
                    ..
                }
            )
        });
        let axial = name_of(&|e| {
            matches!(
                e,
                Effect::Play {
                    direction: PlayDirection::Axial,
                    ..
                }
            )
        });
        let other = name_of(&|e| !matches!(e, Effect::Play { .. } | Effect::Backlash { .. }));
        let ranked = |candidate: &str, cv_ratio: f64| crate::diagnose::Ranked {
            candidate: candidate.into(),
            statistic: 100.0,
            p_value: 0.0,
            cv_ratio,
            plausible: true,
        };
        // Estimates of the selection: the last selected effect's `stable` as given.
        let estimates = |selected: &[String], last_stable: bool| -> Vec<crate::diagnose::Estimate> {
            selected
                .iter()
                .enumerate()
                .map(|(i, n)| crate::diagnose::Estimate {
                    candidate: n.clone(),
                    parameter: "p [1]".into(),
                    value: 1.0,
                    std: 0.1,
                    std_noise_only: 0.1,
                    std_jackknife: None,
                    inflation: 1.0,
                    folds: vec![],
                    stable: last_stable || i + 1 < selected.len(),
                })
                .collect()
        };
        let judged = |selected: Vec<String>, ranking: Vec<crate::diagnose::Ranked>, stable: bool| {
            let mut e = d.clone();
            e.estimates = estimates(&selected, stable);
            (e.selected, e.ranking) = (selected, ranking);
            crate::diagnose::relinearize::play_behind_backlash(&Carried, &e, &cands)
        };
        let with = |selected, ranking| judged(selected, ranking, false);
        // Backlash and a compliance ahead of the plays; the axial play the best of them.
        let ranking = vec![
            ranked(&other, 0.6),
            ranked(&backlash, 0.7),
            ranked(&radial, 0.95),
            ranked(&axial, 0.9),
        ];
        assert_eq!(
            with(vec![backlash.clone(), other.clone()], ranking.clone()),
            Some((backlash.clone(), axial.clone(), 0, PlayDirection::Axial))
        );
        // The radial one the best: probed radially.
        let radial_best = vec![ranked(&radial, 0.8), ranked(&axial, 0.9)];
        assert_eq!(
            with(vec![backlash.clone()], radial_best),
            Some((backlash.clone(), radial.clone(), 0, PlayDirection::Radial))
        );
        // Every selected estimate stable: no sign of a missing effect, no probe.
        assert_eq!(
            judged(vec![backlash.clone(), other.clone()], ranking.clone(), true),
            None
        );
        // No backlash selected, or a play selected beside it: no probe on this signature.
        assert_eq!(with(vec![other.clone()], ranking.clone()), None);
        assert_eq!(with(vec![backlash.clone(), axial.clone()], ranking.clone()), None);
        // No play better than nothing, or none with a number: no probe.
        assert_eq!(
            with(
                vec![backlash.clone()],
                vec![ranked(&axial, 1.0), ranked(&radial, f64::NAN)]
            ),
            None
        );
        assert_eq!(with(vec![backlash.clone()], vec![]), None);
    }

    /// The size search's refits share the reduced model's runs without play across trial
    /// sizes (they do not depend on it): under Hertz's law, where the play's columns are its
    /// response less that run, a refit after others gives to the last bit what a first refit
    /// at that size gives, and the runs are in the cache after the first.
    #[test]
    fn the_size_search_computes_the_run_without_play_once_and_gets_the_same_refits() {
        let h0 = 5e-6;
        let library = LibraryOptions {
            play_load_scales: vec![5.0],
            dynamic_play_clearance: Some(h0),
            play_contact_hertz: true,
            ..LibraryOptions::default()
        };
        let name = "radial clearance in joint F (reduced dynamic model)";
        assert!(super::library(&Carried, &library).iter().any(|c| c.name == name));
        let recordings: Vec<MotionData> = (0..2)
            .map(|r| {
                let mut d = carried_swing(401 + 100 * r);
                d.name = format!("carried-{r}");
                // Something to fit: the nominal torque and output, offset.
                d.tau[0] = d.q[0].iter().map(|q| 0.5 + 2.0 * q).collect();
                d
            })
            .collect();
        let o = crate::diagnose::DiagnoseOptions {
            library,
            ..crate::diagnose::DiagnoseOptions::default()
        };
        let held = || held_play(&recordings, &o, &[name.to_string()], name);
        let first = held();
        assert!(
            first.tight_runs_cached() == 0,
            "nothing run before the first refit"
        );
        assert_eq!(
            first.walks_cached(),
            0,
            "no walk with the play's dynamics before the first refit"
        );
        let a0 = first.cv(h0).expect("assembled").expect("one column");
        let cached = first.tight_runs_cached();
        assert_eq!(cached, recordings.len(), "one run without play per recording");
        assert_eq!(
            first.walks_cached(),
            recordings.len(),
            "one nominal walk per recording"
        );
        WALKED.with(|c| c.set(0));
        let a1 = first.cv(1.1 * h0).expect("assembled").expect("one column");
        assert_eq!(WALKED.with(|c| c.get()), 0, "the second refit walks nothing");
        assert_eq!(first.tight_runs_cached(), cached);
        let b1 = held().cv(1.1 * h0).expect("assembled").expect("one column");
        assert!(a0.is_finite() && a1.is_finite() && a0 != a1, "{a0} {a1}");
        assert_eq!(a1.to_bits(), b1.to_bits(), "{a1} against a fresh refit's {b1}");
        // A refit at another contact damping made with the first's walks (as the damping
        // search's refits and the passes on one model are) walks nothing, in its own
        // assembly or its refit, and gets a fresh refit's number.
        let at = |damping: f64, walks: Option<&crate::diagnose::play_size::Walks>| {
            let mut o = o.clone();
            o.library.play_contact_damping = Some(super::ContactDamping {
                constant: damping,
                load: 0.0,
            });
            crate::diagnose::play_size::HeldPlay::new(
                &Carried,
                &recordings,
                &o,
                &[name.to_string()],
                name,
                &HELD_WEIGHTS,
                &HELD_FLOORS,
                walks,
            )
            .expect("assembled")
            .expect("the play is a candidate")
        };
        WALKED.with(|c| c.set(0));
        let shared = at(50.0, Some(&first.walks));
        assert_eq!(shared.walks_cached(), recordings.len());
        let d_shared = shared.cv(1.1 * h0).expect("assembled").expect("one column");
        assert_eq!(
            WALKED.with(|c| c.get()),
            0,
            "a refit sharing the walks walks nothing"
        );
        let d_fresh = at(50.0, None)
            .cv(1.1 * h0)
            .expect("assembled")
            .expect("one column");
        assert!(WALKED.with(|c| c.get()) > 0, "a fresh refit walks");
        assert!(d_shared.is_finite() && d_shared != a1, "{d_shared} {a1}");
        assert_eq!(
            d_shared.to_bits(),
            d_fresh.to_bits(),
            "{d_shared} against {d_fresh}"
        );
        // With the joint's contact compliance selected beside the play, the assembly of the
        // other columns (the compliance's column is that run) fills the cache, and the
        // refits that follow read it.
        let compliance =
            "contact compliance of joint F (Hertz balls without clearance, reduced dynamic model)";
        assert!(super::library(&Carried, &o.library)
            .iter()
            .any(|c| c.name == compliance));
        let selected = [name.to_string(), compliance.to_string()];
        let with_compliance = held_play(&recordings, &o, &selected, name);
        assert_eq!(with_compliance.tight_runs_cached(), recordings.len());
        let c1 = with_compliance
            .cv(1.1 * h0)
            .expect("assembled")
            .expect("one column");
        assert_eq!(with_compliance.tight_runs_cached(), recordings.len());
        assert!(c1.is_finite(), "{c1}");
    }

    thread_local! {
        /// [`Carried::play_dynamics_at`]'s calls on this test's thread.
        static EXPANSIONS: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
        /// [`Carried::play_dynamics`]'s calls on this test's thread (`Carried` has no fork:
        /// its recordings are walked on the caller's thread).
        static WALKED: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
    }

    /// The reduced play model is re-linearised about its own motion where its first response
    /// is large ([`LibraryOptions::play_relinearize`], [`RELINEARIZE_FRACTION`]): the model
    /// is asked for the expansion at exactly those samples, and for a mechanism linear in the
    /// play (whose expansion anywhere is the sample's) the columns stay as they were.
    #[test]
    fn the_play_model_is_re_linearised_where_its_response_is_large() {
        let h = 5e-6;
        let n = 1001;
        let d = carried_swing(n);
        let t = d.t.clone();
        let mut opts = LibraryOptions {
            play_load_scales: vec![5.0],
            dynamic_play_tracker: false,
            dynamic_play_clearance: Some(h),
            play_relinearize: false,
            ..LibraryOptions::default()
        };
        let cands = library(&Carried, &opts);
        let radial = cands
            .iter()
            .position(|c| c.name.starts_with("radial clearance in joint F"))
            .expect("a radial play candidate");
        EXPANSIONS.with(|c| c.set(0));
        let once = columns(&cands, &d, &Carried, &opts).cols;
        assert_eq!(EXPANSIONS.with(|c| c.get()), 0, "not asked to");
        opts.play_relinearize = true;
        let twice = columns(&cands, &d, &Carried, &opts).cols;
        let (a, b) = (&once[radial][0][..n], &twice[radial][0][..n]);
        // The samples whose first response reaches a tenth of its largest.
        let largest = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let large = a
            .iter()
            .filter(|v| v.abs() >= RELINEARIZE_FRACTION * largest)
            .count();
        let asked = EXPANSIONS.with(|c| c.get());
        assert_eq!(asked, large, "expansions asked for");
        assert!(large > 0, "{large} of {n}");
        for i in 0..n {
            assert!(
                (a[i] - b[i]).abs() <= 1e-9 * largest,
                "t = {} s: {} re-linearised, {} not",
                t[i],
                b[i],
                a[i]
            );
        }
    }

    /// A drive's backlash with the transmission's dynamics known (one drive of 1e4 N·m/rad
    /// on 0.01 kg·m², damping ratio 0.25, so a 159 Hz mode): while the torque holds its
    /// sign the arm lags its encoder by b (the output, the drive's angle, moves by
    /// −tanh(τ/τ_b) per unit b) and the motor-side torque sensor reads nothing more (the
    /// spring carries the same torque); when the torque reverses within a sample, the
    /// transmission crosses its play and rings — the sensor reads the overshoot of a damped
    /// oscillator whose rest position jumped by 2b (at most 0.44 of the jump for ζ = 0.25,
    /// i.e. 0.89·K per unit b; less for a jump spread over the 2 ms sample interval, and the
    /// samples, 2 ms apart on a 6.3 ms period, miss the crest: 0.35·K here), gone 50 ms later
    /// (without the dynamics the torque row would be zero throughout). One candidate per
    /// torque scale of the grid.
    #[test]
    fn a_drive_backlash_lags_the_arm_at_rest_and_rings_the_torque_sensor_at_a_reversal() {
        let n = 1001;
        let t: Vec<f64> = (0..n).map(|i| 0.002 * i as f64).collect();
        // Carried's torque is 0.1·q̈: it reverses from −0.3 to 0.3 N·m at t = 1 s.
        let qdd: Vec<f64> = t.iter().map(|t| 3.0 * ((t - 1.0) / 5e-4).tanh()).collect();
        let d = MotionData {
            name: "reversal".into(),
            t: t.clone(),
            q: vec![vec![0.0; n]],
            qd: vec![vec![0.0; n]],
            qdd: vec![qdd.clone()],
            qdd_noise: vec![],
            tau: vec![vec![0.0; n]],
            y: vec![vec![0.0; n]],
            ends_dropped: 0,
        };
        let opts = LibraryOptions::default();
        let cands = library(&Carried, &opts);
        let backlash: Vec<usize> = (0..cands.len())
            .filter(|&c| matches!(cands[c].effect, Effect::Backlash { .. }))
            .collect();
        let names: Vec<&str> = backlash.iter().map(|&c| cands[c].name.as_str()).collect();
        assert_eq!(
            names,
            [
                "drive backlash in drive (τ_b = 0.03 N m)",
                "drive backlash in drive (τ_b = 0.1 N m)",
                "drive backlash in drive (τ_b = 0.3 N m)",
            ]
        );
        let cols = columns(&cands, &d, &Carried, &opts).cols;
        let k = 1e4;
        let c = backlash[0];
        let (torque, output) = (&cols[c][0][..n], &cols[c][0][n..2 * n]);
        let mut peak = 0.0f64;
        for i in 0..n {
            let side = (0.1 * qdd[i] / 0.03).tanh();
            if (t[i] - 1.0).abs() > 0.05 {
                assert!(
                    (output[i] + side).abs() < 1e-3,
                    "t = {} s: output {} against {}",
                    t[i],
                    output[i],
                    -side
                );
                assert!(torque[i].abs() < 1e-3 * k, "t = {} s: torque {}", t[i], torque[i]);
            } else if t[i] > 1.0 {
                peak = peak.max(torque[i].abs());
            }
        }
        assert!(
            (0.2 * k..=0.89 * k).contains(&peak),
            "peak {peak} N·m per rad of backlash"
        );
        // At a reference backlash (the second pass): one candidate per drive, no torque
        // scale, its column the dead zone's secant.
        let b = 1e-5;
        let second = LibraryOptions {
            backlash_reference: Some(b),
            ..LibraryOptions::default()
        };
        let cands = library(&Carried, &second);
        let names: Vec<&str> = cands
            .iter()
            .filter(|c| matches!(c.effect, Effect::Backlash { .. }))
            .map(|c| c.name.as_str())
            .collect();
        assert_eq!(names, ["drive backlash in drive"]);
        let c = cands
            .iter()
            .position(|c| matches!(c.effect, Effect::Backlash { .. }))
            .unwrap();
        let col = &columns(&cands, &d, &Carried, &second).cols[c][0];
        let dynamics = vec![Some(fixtures::one_drive()); n];
        // (At the place the options give: by default the output, between spring and arm.)
        assert_eq!(second.backlash_place, transmission::PlayPlace::Output);
        let response = transmission::backlash_response(&t, &dynamics, 0, b, second.backlash_place);
        for i in (0..n).step_by(50) {
            let (w, wd, lost) = response[i].as_ref().unwrap();
            let torque = (k * w[0] + fixtures::one_drive().damping[0] * wd[0] - lost) / b;
            assert!(
                (col[i] - torque).abs() <= 1e-9 * k,
                "t = {} s: {} against {torque}",
                t[i],
                col[i]
            );
        }
    }

    /// Asked to (the play-dynamics check, [`LibraryOptions::dynamic_play_clearance`]), the
    /// radial-play candidate gets drive-torque rows from the reduced dynamic play model: where
    /// the load has held its sign for a while, the joint sits against its wall, 2h + F/k from
    /// the centre (each trunnion pair takes half the shift along n; the four balls' stiffness
    /// along n is k), and the drive reads T_e times that — per metre of clearance, the
    /// column. The load reverses and the column with it. Without the option the candidate
    /// moves the tracker only; without [`LibraryOptions::dynamic_play_tracker`] the tracker
    /// rows are the same either way, and axial play gets
    /// no torque rows until asked to
    /// ([`LibraryOptions::dynamic_axial_play`]): then, the load being across both trunnion
    /// axes, its effect — with the play less without — is nil. With
    /// [`LibraryOptions::dynamic_play_tracker`] the one radial candidate left reads the
    /// tracker from the reduced model too: the joint's shift at its wall less the arm's extra
    /// lag, the drive's torque T_e·e over its stiffness.
    #[test]
    fn a_radial_play_with_dynamic_rows_reads_the_reduced_model_in_the_torques() {
        let h = 5e-6;
        let n = 1001;
        let d = carried_swing(n);
        let t = d.t.clone();
        let mut opts = LibraryOptions {
            play_load_scales: vec![5.0],
            dynamic_play_tracker: false,
            ..LibraryOptions::default()
        };
        let cands = library(&Carried, &opts);
        let radial = cands
            .iter()
            .position(|c| c.name.starts_with("radial clearance in joint F"))
            .expect("a radial play candidate");
        let axial = cands
            .iter()
            .position(|c| c.name.starts_with("axial play in joint F"))
            .expect("an axial play candidate");
        let radial_before = radial;
        let quasi_static = columns(&cands, &d, &Carried, &opts).cols;
        opts.dynamic_play_clearance = Some(h);
        let dynamic = columns(&cands, &d, &Carried, &opts).cols;
        // Rows: the torque's samples, then the tracker's.
        let torque = |cols: &Vec<Vec<Vec<f64>>>, c: usize| cols[c][0][..n].to_vec();
        let tracker = |cols: &Vec<Vec<Vec<f64>>>, c: usize| cols[c][0][n..].to_vec();
        assert!(torque(&quasi_static, radial).iter().all(|v| *v == 0.0));
        assert!(torque(&dynamic, axial).iter().all(|v| *v == 0.0));
        assert_eq!(tracker(&quasi_static, radial), tracker(&dynamic, radial));
        assert!(tracker(&dynamic, radial).iter().any(|v| *v != 0.0));
        let wall = TAU_PER_M * (2.0 * h + 200.0 / BALL_CONTACT.stiffness) / h;
        let col = torque(&dynamic, radial);
        // At t = 0.4 s (load +200 N since the start) and t = 1 s (−200 N since 0.5 s).
        for (i, expected) in [(200, -wall), (500, wall)] {
            assert!(
                (col[i] - expected).abs() < 0.01 * wall,
                "t = {} s: column {} N·m/m, the wall gives {expected}",
                t[i],
                col[i]
            );
        }
        // On Hertz's law (the joint's own balls in bores of clearance h): at the wall the
        // two balls in series under 100 N each add 2·(100 N/K)^(2/3) (1.86 µm) to the 2h
        // instead of the linear law's 200 N/k (2.00 µm), less what the same balls give
        // without play (conformal, far stiffer): the column is the play's own part.
        opts.play_contact_hertz = true;
        let hertz = columns(&cands, &d, &Carried, &opts).cols;
        let balls = |h: f64| {
            HertzBalls::of(&fixtures::hanging_joint(0.0, 0.0).play, h)
                .unwrap()
                .radial
        };
        let squeeze_at = |h: f64| 2.0 * (100.0 / balls(h)).powf(2.0 / 3.0);
        let squeeze = squeeze_at(h) - squeeze_at(0.0);
        assert!(
            squeeze > 0.5 * squeeze_at(h),
            "the conformal balls are the stiffer"
        );
        let hertz_col = torque(&hertz, radial);
        for (i, sign) in [(200, -1.0), (500, 1.0)] {
            let got = sign * hertz_col[i] * h / TAU_PER_M - 2.0 * h;
            assert!(
                (got - squeeze).abs() < 0.02 * squeeze,
                "Hertz, t = {} s: the balls add {got:e} m, Hertz gives {squeeze:e}",
                t[i]
            );
        }
        // What the play's column leaves out is the joint's own candidate under Hertz's law
        // (none on the linear law): its contact compliance, the conformal balls' compression
        // at no play — T_e times it in the torque and, on the tracker, the shift less the
        // arm's extra lag.
        let linear = LibraryOptions {
            play_contact_hertz: false,
            ..opts.clone()
        };
        assert!(!library(&Carried, &linear)
            .iter()
            .any(|c| c.name.starts_with("contact compliance of joint")));
        let with_tracker = LibraryOptions {
            dynamic_play_tracker: true,
            ..opts.clone()
        };
        let cands_h = library(&Carried, &with_tracker);
        let own: Vec<&Candidate> = cands_h
            .iter()
            .filter(|c| c.name.starts_with("contact compliance of joint F"))
            .collect();
        assert_eq!(own.len(), 1);
        assert_eq!(own[0].effect, Effect::ContactCompliance { site: 0 });
        let cols_h = columns(
            &own.into_iter().cloned().collect::<Vec<_>>(),
            &d,
            &Carried,
            &with_tracker,
        )
        .cols;
        let tight = squeeze_at(0.0);
        for (i, sign) in [(200, -1.0), (500, 1.0)] {
            let got = sign * torque(&cols_h, 0)[i] / TAU_PER_M;
            assert!(
                (got - tight).abs() < 0.02 * tight,
                "contact compliance, t = {} s: torque column gives {got:e} m, Hertz {tight:e}",
                t[i]
            );
            let got = sign * tracker(&cols_h, 0)[i] / (1.0 - 1e-4 * TAU_PER_M);
            assert!(
                (got - tight).abs() < 0.02 * tight,
                "contact compliance, t = {} s: tracker column gives {got:e} m, Hertz {tight:e}",
                t[i]
            );
        }
        opts.play_contact_hertz = false;
        let h_a = 2.0 * h;
        opts.dynamic_axial_play = Some(h_a);
        let both = columns(&cands, &d, &Carried, &opts).cols;
        assert_eq!(torque(&both, radial), col);
        let col = torque(&both, axial);
        assert!(
            col.iter().all(|v| v.abs() < 1e-3 * wall),
            "largest {}",
            col.iter().fold(0.0f64, |m, v| m.max(v.abs()))
        );

        // The tracker from the reduced model: one radial candidate, no load-scale grid.
        opts.dynamic_play_tracker = true;
        opts.dynamic_axial_play = None;
        let cands = library(&Carried, &opts);
        let radial: Vec<usize> = (0..cands.len())
            .filter(|&c| cands[c].name.starts_with("radial clearance in joint F"))
            .collect();
        assert_eq!(radial.len(), 1);
        let radial = radial[0];
        assert_eq!(
            cands[radial].name,
            "radial clearance in joint F (reduced dynamic model)"
        );
        assert_eq!(cands[radial].grid_parameters, 0);
        let dynamic = columns(&cands, &d, &Carried, &opts).cols;
        let col = tracker(&dynamic, radial);
        // The shift at the wall (per metre of clearance) less the arm's lag c·T_e·shift.
        let shift = (2.0 * h + 200.0 / BALL_CONTACT.stiffness) / h;
        let lagged = shift * (1.0 - 1e-4 * TAU_PER_M);
        for (i, expected) in [(200, -lagged), (500, lagged)] {
            assert!(
                (col[i] - expected).abs() < 0.01 * shift,
                "t = {} s: tracker column {}, expected {expected}",
                t[i],
                col[i]
            );
        }
        assert_eq!(torque(&dynamic, radial), torque(&both, radial_before));
    }

    /// The plays' dynamics in the selection, end to end on the carried joint: a radial play
    /// that moves the tracker by 2h against the load and the drive's torque with it (a
    /// sign-of-load shift plus uniform noise, not the library's smooth form) is found by the
    /// first pass; the re-linearised pass — though no parameter moves the model — runs once
    /// per contact damping of the grid, reports each one's cross-validated error and keeps
    /// the smallest.
    /// Four recordings of the carried joint ([`Carried`]) with a play of `h` (m) in it,
    /// its load swinging with the motion, torque and tracker noise from a fixed seed.
    fn carried_recordings(h: f64) -> Vec<MotionData> {
        let mut seed = 12345u64;
        let mut noise = move |sigma: f64| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            sigma * 3f64.sqrt() * (2.0 * ((seed >> 11) as f64 / (1u64 << 53) as f64) - 1.0)
        };
        (0..4)
            .map(|r| {
                let n = 501;
                let t: Vec<f64> = (0..n).map(|i| 0.002 * i as f64).collect();
                let w = std::f64::consts::PI * (2.0 + 0.5 * r as f64);
                let q: Vec<f64> = t.iter().map(|t| 0.3 * (w * t + 0.4 * r as f64).cos()).collect();
                let qdd: Vec<f64> = q.iter().map(|q| -w * w * q).collect();
                let shift: Vec<f64> = q.iter().map(|q| -2.0 * h * load(*q).signum()).collect();
                MotionData {
                    name: format!("carried-{r}"),
                    t: t.clone(),
                    qd: vec![t
                        .iter()
                        .map(|t| -0.3 * w * (w * t + 0.4 * r as f64).sin())
                        .collect()],
                    tau: vec![(0..n)
                        .map(|i| 0.1 * qdd[i] + TAU_PER_M * shift[i] + noise(0.002))
                        .collect()],
                    y: vec![(0..n).map(|i| q[i] + shift[i] + noise(2e-7)).collect()],
                    ends_dropped: 0,
                    q: vec![q],
                    qdd: vec![qdd],
                    qdd_noise: vec![],
                }
            })
            .collect()
    }

    /// The stiff substeps end to end on the carried joint: with `play_stepping` stiff, the
    /// diagnosis names the radial play in joint F first, reports the stepping it ran with and
    /// sizes the play as the resolved substeps do (the two estimates within 2 % of each
    /// other).
    #[test]
    fn a_diagnosis_with_stiff_substeps_finds_the_play_as_the_resolved_one_does() {
        let recordings = carried_recordings(5e-6);
        let run = |stepping: Stepping| {
            let opts = crate::diagnose::DiagnoseOptions {
                library: LibraryOptions {
                    play_load_scales: vec![5.0],
                    play_stepping: stepping,
                    ..LibraryOptions::default()
                },
                play_contact_dampings: vec![ContactDamping::load_proportional(500.0)],
                play_size_search: true,
                play_damping_search: false,
                ..crate::diagnose::DiagnoseOptions::default()
            };
            crate::diagnose::diagnose(&Carried, &recordings[..3], &recordings[3..], &opts, |_, _| {})
                .expect("a diagnosis")
        };
        let play = |d: &crate::diagnose::Diagnosis| {
            assert!(
                d.found
                    .first()
                    .is_some_and(|f| f.starts_with("radial clearance in joint F")),
                "{:?}",
                d.found
            );
            d.estimate_named("radial clearance in joint F")
                .expect("the play's estimate")
                .value
        };
        let stiff = Stepping::Stiff { per_sample: 40 };
        let (a, b) = (run(Stepping::Resolved), run(stiff));
        assert_eq!(b.dynamic_play_stepping, Some(stiff));
        assert_eq!(a.dynamic_play_stepping, Some(Stepping::Resolved));
        let (ha, hb) = (play(&a), play(&b));
        // (Measured: 4.6296 µm resolved, 4.6300 µm stiff; the truth's 5 µm is a sign-of-load
        // shift, not the model's contact, so neither is 5.)
        assert!((hb / ha - 1.0).abs() < 0.02, "resolved {ha:e} m, stiff {hb:e} m");
    }

    #[test]
    fn the_damping_search_tries_constant_parts_then_load_factors_each_with_its_size_refined() {
        let recordings = carried_recordings(5e-6);
        let start = ContactDamping::load_proportional(500.0);
        let opts = crate::diagnose::DiagnoseOptions {
            library: LibraryOptions {
                play_load_scales: vec![5.0],
                ..LibraryOptions::default()
            },
            play_contact_dampings: vec![start],
            play_size_search: true,
            play_damping_search: true,
            ..crate::diagnose::DiagnoseOptions::default()
        };
        let d = crate::diagnose::diagnose(&Carried, &recordings[..3], &recordings[3..], &opts, |_, _| {})
            .expect("a diagnosis");
        let log = &d.dynamic_play_size_cv;
        let best_of = |part: &[(ContactDamping, f64, f64)]| {
            part.iter()
                .filter(|x| x.2.is_finite())
                .min_by(|a, b| a.2.total_cmp(&b.2))
                .copied()
        };
        // The sizes at the grid's damping first, then the damping searched: its constant part
        // (γ the grid's), then γ (over one constant part, the best one's); each part to three
        // significant digits, each damping once.
        let first_other = log
            .iter()
            .position(|x| x.0 != start)
            .expect("another damping tried");
        let mut blocks: Vec<(usize, usize)> = vec![];
        for k in first_other..log.len() {
            match blocks.last_mut() {
                Some((from, to)) if log[*from].0 == log[k].0 => *to = k + 1,
                _ => blocks.push((k, k + 1)),
            }
        }
        let constants = blocks
            .iter()
            .take_while(|b| log[b.0].0.load == start.load)
            .count();
        // (Each search's start is known, not tried again.)
        assert!(constants < crate::diagnose::MAX_CONSTANT_DAMPINGS, "{log:?}");
        assert!(
            constants >= 1 && blocks.len() > constants,
            "both searched: {log:?}"
        );
        assert!(
            blocks.len() - constants < crate::diagnose::MAX_LOAD_DAMPINGS,
            "{log:?}"
        );
        // γ searched over the best constant part the first search found.
        let best_constant = best_of(&log[..blocks[constants].0]).expect("one").0.constant;
        let three = |x: f64| {
            let digits = 10f64.powi(2 - x.log10().floor() as i32);
            (x * digits - (x * digits).round()).abs() < 1e-9
        };
        for (k, &(from, to)) in blocks.iter().enumerate() {
            let c = log[from].0;
            assert!(
                c != start && blocks[..k].iter().all(|b| log[b.0].0 != c),
                "{log:?}"
            );
            assert!(three(c.constant) && three(c.load), "{log:?}");
            if k >= constants {
                assert_eq!(c.constant, best_constant, "{log:?}");
            }
            // Its sizes: from the best size before it, in the finest step, a few.
            assert!(to - from <= crate::diagnose::PROFILE_SIZES, "{log:?}");
            let before = best_of(&log[..from]).expect("a size tried before");
            assert_eq!(log[from].1, before.1, "{log:?}");
            for x in &log[from + 1..to] {
                let step = (x.1 / log[from].1).ln().abs() / crate::diagnose::PROFILE_STEPS[0].ln();
                assert!(
                    (step - step.round()).abs() < 1e-6 && step.round() >= 1.0,
                    "{log:?}"
                );
            }
        }
        // No (damping, size) twice.
        for (k, (c, h, _)) in log.iter().enumerate() {
            assert!(log[..k].iter().all(|(c2, g, _)| (c2, g) != (c, h)), "{log:?}");
        }
        // The selection runs at the best pair, or, where a whole selection there did not
        // cross-validate better, at the damping it had.
        let best = best_of(log).expect("one");
        assert!(
            (d.dynamic_play_damping, d.dynamic_play_reference) == (Some(best.0), Some(best.1))
                || d.dynamic_play_damping == Some(start),
            "{:?} at {:?}: {log:?}",
            d.dynamic_play_damping,
            d.dynamic_play_reference
        );
        // The reduced model ran: its interpolation is reported (null where none ran).
        assert_eq!(
            d.dynamic_play_interpolation,
            Some(opts.library.play_interpolation)
        );
    }

    #[test]
    fn the_play_dynamics_pass_tries_each_contact_damping_and_end_face_stiffness_and_keeps_the_best() {
        let h = 5e-6;
        let recordings = carried_recordings(h);
        let opts = crate::diagnose::DiagnoseOptions {
            library: LibraryOptions {
                play_load_scales: vec![5.0],
                ..LibraryOptions::default()
            },
            play_size_search: true,
            // The grid's dampings alone: the damping search (on by default since session 69)
            // adds its own refits to the size search's record and has a test of its own.
            play_damping_search: false,
            ..crate::diagnose::DiagnoseOptions::default()
        };
        let d = crate::diagnose::diagnose(&Carried, &recordings[..3], &recordings[3..], &opts, |_, _| {})
            .expect("a diagnosis");
        assert!(
            d.selected
                .iter()
                .any(|s| s.starts_with("radial clearance in joint F")),
            "{:?}",
            d.selected
        );
        assert!(d.dynamic_play_reference.is_some());
        // Each value tried, in the options' order, and the one with the smallest error kept:
        // the damping, then the end faces' stiffness at the kept damping.
        fn tried_and_best<T: Copy>(cv: &[(T, f64)]) -> (Vec<T>, Option<T>) {
            let best = cv.iter().min_by(|a, b| a.1.total_cmp(&b.1)).map(|(v, _)| *v);
            (cv.iter().map(|(v, _)| *v).collect(), best)
        }
        let (tried, best) = tried_and_best(&d.dynamic_play_damping_cv);
        assert_eq!(tried, opts.play_contact_dampings);
        // (Or the damping the play-size search's refits chose at the searched size, below.)
        let searched = d
            .dynamic_play_size_cv
            .iter()
            .filter(|x| x.2.is_finite())
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .map(|x| x.0);
        assert!(
            d.dynamic_play_damping == best || d.dynamic_play_damping == searched,
            "{:?}",
            d.dynamic_play_damping
        );
        // Whether the dampings were told apart, from the same record, at the diagnosis's
        // confounding tolerance (a play was selected and two dampings or more tried).
        assert_eq!(
            d.dynamic_play_damping_identified,
            crate::diagnose::play_size::damping_identified(
                &d.dynamic_play_damping_cv,
                &d.dynamic_play_size_cv,
                opts.confound_tolerance
            )
        );
        assert!(d.dynamic_play_damping_identified.is_some());
        let (tried, best) = tried_and_best(&d.dynamic_play_axial_stiffness_cv);
        assert_eq!(tried, opts.play_axial_stiffnesses);
        assert_eq!(d.dynamic_play_axial_stiffness, best);
        // The reference plays: the first pass's first; another set only if the selection
        // before sized a play more than the factor away from its own, and only after a
        // pass that cross-validated better than the one before it; the kept one
        // cross-validates best.
        let refs = &d.dynamic_play_reference_cv;
        assert!(
            !refs.is_empty() && refs.len() <= 1 + crate::diagnose::MAX_RESIZES,
            "{refs:?}"
        );
        for (k, w) in refs.windows(2).enumerate() {
            let [(r0, a0, cv0), (r1, a1, _)] = w else {
                unreachable!()
            };
            let moved = |x: Option<f64>, y: Option<f64>| match (x, y) {
                (Some(x), Some(y)) => {
                    y > x * crate::diagnose::RESIZE_FACTOR || y < x / crate::diagnose::RESIZE_FACTOR
                }
                _ => false,
            };
            assert!(moved(*r0, *r1) || moved(*a0, *a1), "{refs:?}");
            if k > 0 {
                assert!(
                    cv0 < &refs[k - 1].2,
                    "a pass after one that did not improve: {refs:?}"
                );
            }
        }
        let kept = refs.iter().min_by(|a, b| a.2.total_cmp(&b.2)).expect("one");
        // Then the radial play's size searched at the kept damping, every other damping of
        // the grid at the best size, and the size again at a damping better there: distinct
        // (damping, size) pairs, each damping one tried; where a whole selection at the best
        // pair was kept, it cross-validates no worse than the reference plays' best, else
        // the reference plays' best stays.
        let sizes = &d.dynamic_play_size_cv;
        let grid: Vec<ContactDamping> = opts.play_contact_dampings.clone();
        assert!(
            !sizes.is_empty() && sizes.len() <= crate::diagnose::MAX_PLAY_SIZES * 2 + grid.len(),
            "{sizes:?}"
        );
        for c in &grid {
            assert!(sizes.iter().any(|x| x.0 == *c), "{c} not tried: {sizes:?}");
        }
        for (k, (c, h, _)) in sizes.iter().enumerate() {
            assert!(grid.contains(c), "{sizes:?}");
            assert!(sizes[..k].iter().all(|(c2, g, _)| (c2, g) != (c, h)), "{sizes:?}");
        }
        let best = sizes
            .iter()
            .filter(|x| x.2.is_finite())
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .expect("one");
        if (d.dynamic_play_reference, d.dynamic_play_damping) == (Some(best.1), Some(best.0)) {
            assert_eq!(d.dynamic_axial_play_reference, kept.1);
            // (Equal where the reference plays' best was already at the best pair.)
            assert!(
                d.cv_rms_noise_units <= kept.2,
                "{} against {refs:?}",
                d.cv_rms_noise_units
            );
        } else {
            assert_eq!(
                (kept.0, kept.1),
                (d.dynamic_play_reference, d.dynamic_axial_play_reference)
            );
        }
    }
}
