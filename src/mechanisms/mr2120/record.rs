//! Synthetic recordings of the MR2120 from a truth model with hidden effects
//! (`lash mr2120 record`): what a lab would log — drive encoder angles and rates, drive
//! torques from the motor currents, the platform centre from a laser tracker — with stated
//! sensor noise and a seed.
//!
//! The truth is the closed-form rigid model ([`LumpedModel`]) evaluated without
//! linearisation, with these effects on top (all zero by default):
//!
//! * link-length errors, payload, base tilt, drive-compliance errors (the model itself);
//! * joint friction on the arm side of each drive (viscous and regularised Coulomb, the
//!   latter with [`FRICTION_VELOCITY`]): it loads the transmission like any other torque;
//! * reflected rotor inertia (motor side: seen by the current, not by the transmission);
//! * drive backlash: the arm lags the encoder by b·tanh(τ/τ_b) (τ_b = [`BACKLASH_SCALE`]);
//! * clearance in the joints of a leg: radial, the forearm acts h·tanh(T/T_c) longer under
//!   tension T (T_c = [`CLEARANCE_SCALE`]), shorter under compression; axial, the elbow
//!   centre shifts by h·tanh(F/T_c) along the drive axis under the axial joint load F;
//! * sensor errors: encoder offsets, torque offset and scale, tracker offset.
//!
//! The drives follow commanded encoder angles exactly (the inverse kinematics of the nominal
//! model along a smooth platform path): what the truth changes is the torque they need and
//! where the platform really is. Units SI; angles in rad.

use super::geometry::{Geometry, MassProperties};
use super::kinematics::{inverse, KinematicsError};
use super::lumped::{tilted_gravity, LumpedModel};
use nalgebra::Vector3;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;

/// Velocity scale of the truth's regularised Coulomb friction, rad/s.
pub const FRICTION_VELOCITY: f64 = 0.05;
/// Torque scale over which the truth's backlash changes sides, N·m.
pub const BACKLASH_SCALE: f64 = 0.2;
/// Force scale over which the truth's leg clearance changes sides, N.
pub const CLEARANCE_SCALE: f64 = 1.0;

/// Effects the nominal model leaves out; per-drive and per-leg arrays are ordered A, B, C.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct HiddenEffects {
    /// Payload on the platform, kg.
    pub payload: f64,
    /// Base tilt about x and y, rad.
    pub tilt: [f64; 2],
    /// Arm length errors, m.
    pub arm_length_error: [f64; 3],
    /// Forearm length errors, m.
    pub forearm_length_error: [f64; 3],
    /// Drive compliance errors, rad/(N·m).
    pub compliance_error: [f64; 3],
    /// Viscous joint friction, N·m·s/rad.
    pub viscous: [f64; 3],
    /// Coulomb joint friction, N·m.
    pub coulomb: [f64; 3],
    /// Reflected rotor inertia, kg·m².
    pub rotor_inertia: [f64; 3],
    /// Drive backlash (half the play), rad.
    pub backlash: [f64; 3],
    /// Radial clearance in the joints of each leg (play along the forearm), m.
    pub clearance: [f64; 3],
    /// Axial clearance in the joints of each leg (play along the drive axis), m.
    pub axial_clearance: [f64; 3],
    /// Encoder offsets (measured − true), rad.
    pub encoder_offset: [f64; 3],
    /// Torque-sensor offsets, N·m.
    pub torque_offset: [f64; 3],
    /// Torque-sensor scale errors (k − 1).
    pub torque_scale: [f64; 3],
    /// Tracker offset, m.
    pub tracker_offset: [f64; 3],
}

impl HiddenEffects {
    /// Sets one effect by name: `payload`, `tilt_x`, `tilt_y`, or one of `arm_length_error`,
    /// `forearm_length_error`, `compliance_error`, `viscous`, `coulomb`, `rotor_inertia`,
    /// `backlash`, `clearance`, `axial_clearance`, `encoder_offset`, `torque_offset`, `torque_scale` with the
    /// suffix `_a`, `_b` or `_c`, or `tracker_offset_x|y|z` (SI units).
    pub fn set(&mut self, key: &str, value: f64) -> Result<(), String> {
        if !value.is_finite() {
            return Err(format!("{key}: value must be finite"));
        }
        match key {
            "payload" => self.payload = value,
            "tilt_x" => self.tilt[0] = value,
            "tilt_y" => self.tilt[1] = value,
            _ => {
                let (base, suffix) = key
                    .rsplit_once('_')
                    .ok_or_else(|| format!("unknown effect '{key}'"))?;
                let idx = match (base, suffix) {
                    ("tracker_offset", "x") | (_, "a") => 0,
                    ("tracker_offset", "y") | (_, "b") => 1,
                    ("tracker_offset", "z") | (_, "c") => 2,
                    _ => {
                        return Err(format!(
                            "unknown effect '{key}' (suffix _a, _b, _c; _x, _y, _z for the tracker)"
                        ))
                    }
                };
                let field = match base {
                    "arm_length_error" => &mut self.arm_length_error,
                    "forearm_length_error" => &mut self.forearm_length_error,
                    "compliance_error" => &mut self.compliance_error,
                    "viscous" => &mut self.viscous,
                    "coulomb" => &mut self.coulomb,
                    "rotor_inertia" => &mut self.rotor_inertia,
                    "backlash" => &mut self.backlash,
                    "clearance" => &mut self.clearance,
                    "axial_clearance" => &mut self.axial_clearance,
                    "encoder_offset" => &mut self.encoder_offset,
                    "torque_offset" => &mut self.torque_offset,
                    "torque_scale" => &mut self.torque_scale,
                    "tracker_offset" => &mut self.tracker_offset,
                    _ => return Err(format!("unknown effect '{key}'")),
                };
                field[idx] = value;
            }
        }
        Ok(())
    }
}

/// Standard deviations of the white sensor noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SensorNoise {
    /// Encoder angle, rad.
    pub encoder: f64,
    /// Encoder rate, rad/s.
    pub rate: f64,
    /// Drive torque, N·m.
    pub torque: f64,
    /// Tracker position, m.
    pub tracker: f64,
}

impl Default for SensorNoise {
    /// 2 µrad encoders, 0.1 mrad/s rates, 0.02 N·m torques, a 5 µm laser tracker.
    fn default() -> Self {
        Self {
            encoder: 2e-6,
            rate: 1e-4,
            torque: 0.02,
            tracker: 5e-6,
        }
    }
}

impl SensorNoise {
    /// Every standard deviation times `factor` (0.1: ten times quieter sensors).
    pub fn scaled(self, factor: f64) -> Self {
        Self {
            encoder: factor * self.encoder,
            rate: factor * self.rate,
            torque: factor * self.torque,
            tracker: factor * self.tracker,
        }
    }
}

/// A platform path: p(t) = centre + Σ_k a_k ⊙ sin(ω_k t + φ_k), two harmonics per axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Excitation {
    /// Centre, m.
    pub centre: [f64; 3],
    /// Amplitudes per harmonic and axis, m.
    pub amplitude: [[f64; 3]; 2],
    /// Angular frequencies per harmonic and axis, rad/s.
    pub omega: [[f64; 3]; 2],
    /// Phases per harmonic and axis, rad.
    pub phase: [[f64; 3]; 2],
}

impl Excitation {
    /// A random path from `seed` that reaches down to `z_low` (m) — close to the direct
    /// singularity M3 (z = 0.2509 m) for low values — and up to about 0.65 m, with horizontal
    /// excursions of up to ±0.09 m. With `shake` > 0 the second vertical harmonic is a 2 Hz
    /// shake of that acceleration amplitude (m/s²): near g it unloads the forearms and
    /// reverses their forces and the drive torques.
    pub fn random(seed: u64, z_low: f64, shake: f64) -> Self {
        let mut r = Rng::new(seed ^ 0x005e_ed0f_ba11);
        let z_high = 0.65;
        let zc = 0.5 * (z_low + z_high);
        let za = 0.5 * (z_high - z_low);
        let split = 0.6 + 0.3 * r.uniform();
        let mut amplitude = [[0.0; 3]; 2];
        let mut omega = [[0.0; 3]; 2];
        let mut phase = [[0.0; 3]; 2];
        for axis in 0..3 {
            let total = if axis < 2 { 0.05 + 0.04 * r.uniform() } else { za };
            let s = if axis < 2 { 0.5 + 0.4 * r.uniform() } else { split };
            amplitude[0][axis] = total * s;
            amplitude[1][axis] = total * (1.0 - s);
            omega[0][axis] = 2.0 * std::f64::consts::PI * (0.25 + 0.35 * r.uniform());
            omega[1][axis] = 2.0 * std::f64::consts::PI * (1.0 + 1.0 * r.uniform());
            phase[0][axis] = 2.0 * std::f64::consts::PI * r.uniform();
            phase[1][axis] = 2.0 * std::f64::consts::PI * r.uniform();
        }
        if shake > 0.0 {
            let w = 2.0 * std::f64::consts::PI * 2.0;
            let a = (shake / (w * w)).min(0.5 * za);
            amplitude[1][2] = a;
            amplitude[0][2] = za - a;
            omega[1][2] = w;
        }
        Self {
            centre: [0.0, 0.0, zc],
            amplitude,
            omega,
            phase,
        }
    }

    /// Position, m.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        Vector3::from_fn(|axis, _| {
            self.centre[axis]
                + (0..2)
                    .map(|k| self.amplitude[k][axis] * (self.omega[k][axis] * t + self.phase[k][axis]).sin())
                    .sum::<f64>()
        })
    }
}

/// Recording settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RecordOptions {
    /// Duration, s.
    pub duration: f64,
    /// Sampling rate, Hz.
    pub rate: f64,
    /// Noise.
    pub noise: SensorNoise,
    /// Record the drive torques.
    pub torques: bool,
    /// Record the tracker.
    pub tracker: bool,
}

impl Default for RecordOptions {
    /// 8 s at 500 Hz, torques and tracker.
    fn default() -> Self {
        Self {
            duration: 8.0,
            rate: 500.0,
            noise: SensorNoise::default(),
            torques: true,
            tracker: true,
        }
    }
}

/// A synthetic recording (before it is written).
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    /// Time, s.
    pub t: Vec<f64>,
    /// Measured encoder angles per drive, rad.
    pub q: [Vec<f64>; 3],
    /// Measured encoder rates per drive, rad/s.
    pub qd: [Vec<f64>; 3],
    /// Measured drive torques per drive, N·m (empty if not recorded).
    pub tau: [Vec<f64>; 3],
    /// Measured platform centre per axis, m (empty if not recorded).
    pub pose: [Vec<f64>; 3],
    /// Per channel (torques A, B, C then x, y, z): the hidden effects' contribution, noise-free.
    pub contribution: [Vec<f64>; 6],
    /// Smallest direct-singularity measure along the path.
    pub min_direct_measure: f64,
    /// Sign changes of each drive's torque (nominal truth; beyond ±[`BACKLASH_SCALE`]).
    pub torque_reversals: [usize; 3],
    /// Sign changes of each forearm's force (nominal truth; beyond ±[`CLEARANCE_SCALE`]).
    pub tension_reversals: [usize; 3],
    /// Velocity reversals of each drive.
    pub velocity_reversals: [usize; 3],
}

/// Counts sign changes of a signal that pass beyond ±`scale` (hysteresis).
pub(crate) fn reversals(x: &[f64], scale: f64) -> usize {
    let mut last = 0.0f64;
    let mut n = 0;
    for &v in x {
        if v.abs() > scale {
            if last != 0.0 && v.signum() != last {
                n += 1;
            }
            last = v.signum();
        }
    }
    n
}

/// Why a recording could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RecordError {
    /// The path leaves the work zone or meets a singular configuration.
    #[error("t = {t:.3} s: {source}")]
    Kinematics {
        /// Time, s.
        t: f64,
        /// Cause.
        source: KinematicsError,
    },
    /// Invalid settings.
    #[error("invalid recording settings: {0}")]
    Invalid(String),
    /// Writing failed.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: String,
        /// Message.
        message: String,
    },
}

/// SplitMix64 with Box–Muller normals: reproducible noise from a seed, no dependency.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// From a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// The truth at one sample: (torque through each transmission + rotor torque as the current
/// sees it, platform centre). `h` selects the hidden effects (zero: the nominal truth).
fn truth_sample(
    nominal: &LumpedModel,
    e: &HiddenEffects,
    q_enc: [f64; 3],
    qd: [f64; 3],
    qdd: [f64; 3],
    guess: Vector3<f64>,
) -> Result<([f64; 3], Vector3<f64>), KinematicsError> {
    let mut m = *nominal;
    for i in 0..3 {
        m.arm_length[i] += e.arm_length_error[i];
        m.forearm_length[i] += e.forearm_length_error[i];
        m.compliance[i] += e.compliance_error[i];
    }
    m.payload += e.payload;
    m.gravity = tilted_gravity(e.tilt[0], e.tilt[1]);
    let friction: [f64; 3] =
        std::array::from_fn(|i| e.viscous[i] * qd[i] + e.coulomb[i] * (qd[i] / FRICTION_VELOCITY).tanh());
    // Transmission torque (joint side) and arm angles, by fixed-point passes.
    let mut gear = m.state(q_enc, qd, qdd, guess)?.torque;
    let mut state = None;
    for _ in 0..30 {
        let qa: [f64; 3] = std::array::from_fn(|i| {
            q_enc[i] - m.compliance[i] * gear[i] - e.backlash[i] * (gear[i] / BACKLASH_SCALE).tanh()
        });
        let s = m.state(qa, qd, qdd, guess)?;
        gear = std::array::from_fn(|i| s.torque[i] + friction[i]);
        state = Some((qa, s));
    }
    let (qa, s) = state.expect("three passes ran");
    // Clearance: each forearm acts longer under tension, shorter under compression.
    let mut mc = m;
    for i in 0..3 {
        mc.forearm_length[i] += e.clearance[i] * (s.tension[i] / CLEARANCE_SCALE).tanh();
        mc.axial_offset[i] += e.axial_clearance[i] * (s.axial_force[i] / CLEARANCE_SCALE).tanh();
    }
    let pose = mc.forward(qa, s.m)?;
    let current = std::array::from_fn(|i| gear[i] + e.rotor_inertia[i] * qdd[i]);
    Ok((current, pose))
}

/// Records one run of `excitation` on the truth `nominal` + `effects`, with noise from `seed`.
pub fn record(
    nominal: &LumpedModel,
    effects: &HiddenEffects,
    excitation: &Excitation,
    opts: &RecordOptions,
    seed: u64,
) -> Result<Recorded, RecordError> {
    let samples = opts.duration * opts.rate;
    let valid = opts.duration > 0.0 && opts.rate > 0.0 && (3.0..1e7).contains(&samples);
    if !valid {
        return Err(RecordError::Invalid(format!(
            "duration {} s at {} Hz",
            opts.duration, opts.rate
        )));
    }
    if !opts.torques && !opts.tracker {
        return Err(RecordError::Invalid("record torques, the tracker or both".into()));
    }
    let g = nominal.geometry;
    let n = (opts.duration * opts.rate).round() as usize + 1;
    let dt = 1.0 / opts.rate;
    let mut rng = Rng::new(seed);
    // Drive angles continuous in time (the inverse kinematics returns them modulo 2π).
    let enc = |t: f64, near: Option<[f64; 3]>| -> Result<[f64; 3], RecordError> {
        let q = inverse(&g, excitation.at(t)).map_err(|source| RecordError::Kinematics { t, source })?;
        Ok(std::array::from_fn(|i| match near {
            Some(r) => {
                r[i] + (q[i] - r[i] + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI)
                    - std::f64::consts::PI
            }
            None => q[i],
        }))
    };
    let mut previous: Option<[f64; 3]> = None;
    let mut out = Recorded {
        t: Vec::with_capacity(n),
        q: Default::default(),
        qd: Default::default(),
        tau: Default::default(),
        pose: Default::default(),
        contribution: Default::default(),
        min_direct_measure: f64::INFINITY,
        torque_reversals: [0; 3],
        tension_reversals: [0; 3],
        velocity_reversals: [0; 3],
    };
    let mut nominal_torque: [Vec<f64>; 3] = Default::default();
    let mut nominal_tension: [Vec<f64>; 3] = Default::default();
    let mut rates: [Vec<f64>; 3] = Default::default();
    let none = HiddenEffects::default();
    let mut guess = excitation.at(0.0);
    let h = 1e-4;
    for k in 0..n {
        let t = k as f64 * dt;
        let q0 = enc(t, previous)?;
        previous = Some(q0);
        let (qm, qp) = (enc(t - h, Some(q0))?, enc(t + h, Some(q0))?);
        let qd: [f64; 3] = std::array::from_fn(|i| (qp[i] - qm[i]) / (2.0 * h));
        let qdd: [f64; 3] = std::array::from_fn(|i| (qp[i] - 2.0 * q0[i] + qm[i]) / (h * h));
        let wrap = |source| RecordError::Kinematics { t, source };
        let (cur, pose) = truth_sample(nominal, effects, q0, qd, qdd, guess).map_err(wrap)?;
        // What the nominal truth gives at what the encoders read (noise-free).
        let q_read: [f64; 3] = std::array::from_fn(|i| q0[i] + effects.encoder_offset[i]);
        let (cur0, pose0) = truth_sample(nominal, &none, q_read, qd, qdd, guess).map_err(wrap)?;
        let st = nominal.state(q0, qd, qdd, guess).map_err(wrap)?;
        out.min_direct_measure = out.min_direct_measure.min(st.direct_measure);
        for i in 0..3 {
            nominal_torque[i].push(st.torque[i]);
            nominal_tension[i].push(st.tension[i]);
            rates[i].push(qd[i]);
        }
        guess = pose;
        out.t.push(t);
        for i in 0..3 {
            let measured_torque = (1.0 + effects.torque_scale[i]) * cur[i] + effects.torque_offset[i];
            out.contribution[i].push(measured_torque - cur0[i]);
            out.contribution[3 + i].push(pose[i] + effects.tracker_offset[i] - pose0[i]);
            out.q[i].push(q0[i] + effects.encoder_offset[i] + opts.noise.encoder * rng.normal());
            out.qd[i].push(qd[i] + opts.noise.rate * rng.normal());
            if opts.torques {
                out.tau[i].push(measured_torque + opts.noise.torque * rng.normal());
            }
            if opts.tracker {
                out.pose[i].push(pose[i] + effects.tracker_offset[i] + opts.noise.tracker * rng.normal());
            }
        }
    }
    for i in 0..3 {
        out.torque_reversals[i] = reversals(&nominal_torque[i], BACKLASH_SCALE);
        out.tension_reversals[i] = reversals(&nominal_tension[i], CLEARANCE_SCALE);
        out.velocity_reversals[i] = reversals(&rates[i], FRICTION_VELOCITY);
    }
    Ok(out)
}

impl Recorded {
    /// The CSV text: `time,q1,q2,q3,qd1,qd2,qd3[,tau1,tau2,tau3][,x,y,z]` (s, rad, rad/s,
    /// N·m, m).
    pub fn csv(&self) -> String {
        let mut s = String::from("time,q1,q2,q3,qd1,qd2,qd3");
        let torques = !self.tau[0].is_empty();
        let tracker = !self.pose[0].is_empty();
        if torques {
            s.push_str(",tau1,tau2,tau3");
        }
        if tracker {
            s.push_str(",x,y,z");
        }
        s.push('\n');
        for k in 0..self.t.len() {
            let _ = write!(s, "{:.6}", self.t[k]);
            for i in 0..3 {
                let _ = write!(s, ",{:.10e}", self.q[i][k]);
            }
            for i in 0..3 {
                let _ = write!(s, ",{:.8e}", self.qd[i][k]);
            }
            if torques {
                for i in 0..3 {
                    let _ = write!(s, ",{:.8e}", self.tau[i][k]);
                }
            }
            if tracker {
                for i in 0..3 {
                    let _ = write!(s, ",{:.10e}", self.pose[i][k]);
                }
            }
            s.push('\n');
        }
        s
    }

    /// Writes [`csv`](Self::csv) to `path`.
    pub fn write(&self, path: &Path) -> Result<(), RecordError> {
        std::fs::write(path, self.csv()).map_err(|e| RecordError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }
}

/// The nominal model of the recordings: the reconstructed geometry and documented masses.
pub fn nominal_model() -> LumpedModel {
    LumpedModel::nominal(&Geometry::default(), &MassProperties::default())
}

/// One recording written by [`write_recordings`], as `truth.json` lists it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WrittenRecording {
    /// The CSV file.
    pub file: String,
    /// Sign changes of each forearm's force ([`Recorded::tension_reversals`]).
    pub forearm_force_reversals: [usize; 3],
    /// Smallest direct-singularity measure along the path.
    pub min_direct_measure: f64,
    /// Number of samples.
    pub samples: usize,
    /// Sign changes of each drive's torque.
    pub torque_reversals: [usize; 3],
    /// Velocity reversals of each drive.
    pub velocity_reversals: [usize; 3],
}

/// The truth behind a set of recordings (`truth.json`; the diagnosis never reads it).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Truth {
    /// The hidden effects.
    pub effects: HiddenEffects,
    /// The sensor noise.
    pub noise: SensorNoise,
    /// The recordings, in order.
    pub recordings: Vec<WrittenRecording>,
    /// Seed of the first recording (recording r uses seed + r).
    pub seed: u64,
}

impl Truth {
    /// The truth as pretty JSON, every object's keys in alphabetical order (the text of
    /// `truth.json`).
    pub fn json(&self) -> String {
        let value = serde_json::to_value(self).expect("the truth serialises");
        serde_json::to_string_pretty(&value).expect("a JSON value prints")
    }
}

/// File name of recording `r` (from 0) in a folder of recordings: `recording-01.csv`, …
pub fn recording_file(r: usize) -> String {
    format!("recording-{:02}.csv", r + 1)
}

/// Name of the truth file [`write_recordings`] writes.
pub const TRUTH_FILE: &str = "truth.json";

/// Records one recording per excitation (recording r with noise seed `seed + r`), writes
/// them as `dir/recording-01.csv`, `-02`, … and the [`Truth`] as `dir/truth.json`
/// ([`TRUTH_FILE`]), creating `dir`. Returns the truth and the path of its file.
pub fn write_recordings(
    dir: &Path,
    nominal: &LumpedModel,
    hidden: &HiddenEffects,
    excitations: &[Excitation],
    opts: &RecordOptions,
    seed: u64,
) -> Result<(Truth, std::path::PathBuf), RecordError> {
    if excitations.is_empty() {
        return Err(RecordError::Invalid("no recording asked for".into()));
    }
    let io = |path: &Path, e: std::io::Error| RecordError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| io(dir, e))?;
    let mut recordings = vec![];
    for (r, ex) in excitations.iter().enumerate() {
        let rec = record(nominal, hidden, ex, opts, seed.wrapping_add(r as u64))?;
        let path = dir.join(recording_file(r));
        rec.write(&path)?;
        recordings.push(WrittenRecording {
            file: path.display().to_string(),
            forearm_force_reversals: rec.tension_reversals,
            min_direct_measure: rec.min_direct_measure,
            samples: rec.t.len(),
            torque_reversals: rec.torque_reversals,
            velocity_reversals: rec.velocity_reversals,
        });
    }
    let truth = Truth {
        effects: *hidden,
        noise: opts.noise,
        recordings,
        seed,
    };
    let path = dir.join(TRUTH_FILE);
    std::fs::write(&path, truth.json()).map_err(|e| io(&path, e))?;
    Ok((truth, path))
}
