//! Measured motion and torques of one recording, ready for equation-error residuals.

use super::error::DiagnoseError;
use super::model::InverseDynamicsModel;
use super::recording::{Recording, RecordingError, MIN_SAMPLES};
use super::signal::{derivative_cubic, derivative_noise_measured, noise_floor};

/// A model's values along a recording: torques per joint, then outputs per output, each
/// per sample (as [`MotionData::model_all`] gives them).
pub type ModelValues = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// One recording in equation-error form.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionData {
    /// Recording name (file stem).
    pub name: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// Joint positions per joint, rad.
    pub q: Vec<Vec<f64>>,
    /// Joint rates per joint, rad/s.
    pub qd: Vec<Vec<f64>>,
    /// Joint accelerations per joint, rad/s²: the recorded `qdd` column where the
    /// recording maps one, else the differentiated rates.
    pub qdd: Vec<Vec<f64>>,
    /// Noise (standard deviation) of each joint's acceleration, rad/s² or m/s²: the noise
    /// floor of a recorded acceleration, or what the differentiation makes of the rate's
    /// noise floor; empty when unknown (taken as noise-free). The diagnosis adds what it
    /// passes through the model's inertia to each torque channel's noise floor.
    pub qdd_noise: Vec<f64>,
    /// Measured joint torques per joint, N·m (empty: the recording has no torque channels).
    pub tau: Vec<Vec<f64>>,
    /// Measured outputs per output channel (empty: none recorded), in the model's units.
    pub y: Vec<Vec<f64>>,
    /// Samples left out at each end of the recording ([`without_ends`](Self::without_ends);
    /// 0 when none were).
    pub ends_dropped: usize,
}

/// Roles a recording must map for an n-joint model: q1.., qd1.., tau1.. (1-based).
pub fn roles(joints: usize) -> Vec<String> {
    let mut r = vec![];
    for prefix in ["q", "qd", "tau"] {
        for j in 1..=joints {
            r.push(format!("{prefix}{j}"));
        }
    }
    r
}

/// Roles of a model: q1.., qd1.., tau1.., its output roles, then the optional recorded
/// accelerations qdd1.. (read instead of differentiating the rates where mapped).
pub fn model_roles(model: &dyn InverseDynamicsModel) -> Vec<String> {
    let mut r = roles(model.joints());
    r.extend((0..model.outputs()).map(|k| model.output_role(k)));
    r.extend((1..=model.joints()).map(|j| format!("qdd{j}")));
    r
}

/// What a role of a model reads: joint motion (q, qd), a joint torque, or an output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoleKind {
    /// A joint position or rate (q1.., qd1..): always read.
    Motion,
    /// A measured joint torque (tau1..).
    Torque,
    /// A model output (e.g. a tracked position).
    Output,
    /// A recorded joint acceleration (qdd1..): optional.
    Acceleration,
}

/// The kind of `role` among the [`model_roles`] of `model`; `None` when it is not one of them.
pub fn role_kind(model: &dyn InverseDynamicsModel, role: &str) -> Option<RoleKind> {
    let n = model.joints();
    let k = model_roles(model).iter().position(|r| r == role)?;
    Some(if k < 2 * n {
        RoleKind::Motion
    } else if k < 3 * n {
        RoleKind::Torque
    } else if k < 3 * n + model.outputs() {
        RoleKind::Output
    } else {
        RoleKind::Acceleration
    })
}

/// One residual channel: a joint torque or a model output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Torque of joint j.
    Torque(usize),
    /// Output k.
    Output(usize),
}

impl Channel {
    /// Name for reports.
    pub fn name(self, model: &dyn InverseDynamicsModel) -> String {
        match self {
            Channel::Torque(j) => format!("{} {}", model.joint_name(j), model.joint_motion(j).effort_word()),
            Channel::Output(k) => model.output_name(k),
        }
    }
    /// Unit.
    pub fn unit(self, model: &dyn InverseDynamicsModel) -> String {
        match self {
            Channel::Torque(j) => model.joint_motion(j).effort().into(),
            Channel::Output(k) => model.output_unit(k),
        }
    }
}

/// The channel mapped to `role`, or an error saying how to map it.
fn mapped(rec: &Recording, role: String) -> Result<Vec<f64>, RecordingError> {
    rec.channel(&role)
        .map(<[f64]>::to_vec)
        .ok_or(RecordingError::Unmapped {
            hint: format!("--map {role}=<column>"),
            role,
        })
}

impl MotionData {
    /// From a recording with the roles of [`roles`]; accelerations by local least-squares
    /// cubics over ±`half_window` samples of the rates (one-sided within `half_window` of
    /// either end: [`without_ends`](Self::without_ends) leaves those samples out).
    pub fn from_recording(
        rec: &Recording,
        joints: usize,
        half_window: usize,
    ) -> Result<Self, RecordingError> {
        let mut d = Self::motion(rec, joints, half_window, derivative_cubic)?;
        for j in 1..=joints {
            d.tau.push(mapped(rec, format!("tau{j}"))?);
        }
        Ok(d)
    }

    /// Joint positions, rates and their derivative (`diff` over ±`half_window` samples) of
    /// a recording; no torques or outputs yet.
    fn motion(
        rec: &Recording,
        joints: usize,
        half_window: usize,
        diff: fn(&[f64], &[f64], usize) -> Vec<f64>,
    ) -> Result<Self, RecordingError> {
        let mut d = MotionData {
            name: rec.name(),
            t: rec.time.clone(),
            q: vec![],
            qd: vec![],
            qdd: vec![],
            qdd_noise: vec![],
            tau: vec![],
            y: vec![],
            ends_dropped: 0,
        };
        for j in 1..=joints {
            d.q.push(mapped(rec, format!("q{j}"))?);
            let qd = mapped(rec, format!("qd{j}"))?;
            match rec.channel(&format!("qdd{j}")) {
                Some(a) => {
                    d.qdd_noise.push(noise_floor(a));
                    d.qdd.push(a.to_vec());
                }
                None => {
                    d.qdd_noise
                        .push(derivative_noise_measured(&rec.time, &qd, half_window));
                    d.qdd.push(diff(&rec.time, &qd, half_window));
                }
            }
            d.qd.push(qd);
        }
        Ok(d)
    }

    /// From a recording for a model with outputs: joint positions and rates are required;
    /// torque channels are used if any is mapped (then all must be), output channels likewise;
    /// at least one of the two sets must be present. Rates are differentiated by local cubics
    /// over ±`half_window` samples (no bias from fast, shaking motion).
    pub fn from_recording_with_outputs(
        rec: &Recording,
        model: &dyn InverseDynamicsModel,
        half_window: usize,
    ) -> Result<Self, RecordingError> {
        let nj = model.joints();
        let get = |role: String| mapped(rec, role);
        let mut d = Self::motion(rec, nj, half_window, derivative_cubic)?;
        let any_tau = (1..=nj).any(|j| rec.channel(&format!("tau{j}")).is_some());
        let any_y = (0..model.outputs()).any(|k| rec.channel(&model.output_role(k)).is_some());
        if any_tau || !any_y {
            for j in 1..=nj {
                d.tau.push(get(format!("tau{j}"))?);
            }
        }
        if any_y {
            for k in 0..model.outputs() {
                d.y.push(get(model.output_role(k))?);
            }
        }
        Ok(d)
    }

    /// The residual channels of this recording: torques (if recorded), then outputs.
    pub fn channels(&self) -> Vec<Channel> {
        (0..self.tau.len())
            .map(Channel::Torque)
            .chain((0..self.y.len()).map(Channel::Output))
            .collect()
    }

    /// Measured values of a channel.
    pub fn measured(&self, c: Channel) -> &[f64] {
        match c {
            Channel::Torque(j) => &self.tau[j],
            Channel::Output(k) => &self.y[k],
        }
    }

    /// The model's value of every channel of [`channels`](Self::channels) at every sample.
    pub fn model_channels(&self, model: &dyn InverseDynamicsModel, theta: &[f64]) -> Vec<Vec<f64>> {
        let (tau, y) = self.model_all(model, theta);
        self.channels_of(&tau, &y)
    }

    /// The values of every channel of [`channels`](Self::channels), picked from a model's
    /// torques (per joint) and outputs (per output), as [`model_all`](Self::model_all) gives
    /// them.
    pub fn channels_of(&self, tau: &[Vec<f64>], y: &[Vec<f64>]) -> Vec<Vec<f64>> {
        self.channels()
            .into_iter()
            .map(|c| match c {
                Channel::Torque(j) => tau[j].clone(),
                Channel::Output(k) => y[k].clone(),
            })
            .collect()
    }

    /// The model's torques (per joint) and outputs (per output) at every sample.
    pub fn model_all(&self, model: &dyn InverseDynamicsModel, theta: &[f64]) -> ModelValues {
        let nj = model.joints();
        let no = model.outputs();
        let mut out = vec![vec![0.0; self.len()]; nj];
        let mut outy = vec![vec![0.0; self.len()]; no];
        let (mut q, mut qd, mut qdd, mut tau) = (vec![0.0; nj], vec![0.0; nj], vec![0.0; nj], vec![0.0; nj]);
        let mut y = vec![0.0f64; no];
        for i in 0..self.len() {
            for j in 0..nj {
                q[j] = self.q[j][i];
                qd[j] = self.qd[j][i];
                qdd[j] = self.qdd[j][i];
            }
            if y.iter().any(|v| !v.is_finite()) {
                y.iter_mut().for_each(|v| *v = 0.0);
            }
            model.evaluate_at(self.t[i], theta, &q, &qd, &qdd, &mut tau, &mut y);
            for j in 0..nj {
                out[j][i] = tau[j];
            }
            for k in 0..no {
                outy[k][i] = y[k];
            }
        }
        (out, outy)
    }

    /// Joint positions, rates and accelerations at sample i.
    pub fn motion_at(&self, i: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        (
            self.q.iter().map(|v| v[i]).collect(),
            self.qd.iter().map(|v| v[i]).collect(),
            self.qdd.iter().map(|v| v[i]).collect(),
        )
    }

    /// Checks that this recording fits `model`: positions, rates and accelerations of every
    /// joint, torques of every joint or none, every output or none (at least one of the two),
    /// every series as long as the time column, at least [`MIN_SAMPLES`] samples, time finite
    /// and strictly increasing.
    pub fn check(&self, model: &dyn InverseDynamicsModel) -> Result<(), DiagnoseError> {
        let recording = || self.name.clone();
        let (nj, no, n) = (model.joints(), model.outputs(), self.len());
        for (what, series) in [
            ("positions", &self.q),
            ("rates", &self.qd),
            ("accelerations", &self.qdd),
        ] {
            if series.len() != nj {
                return Err(DiagnoseError::JointCount {
                    recording: recording(),
                    what,
                    found: series.len(),
                    joints: nj,
                });
            }
        }
        if !self.tau.is_empty() && self.tau.len() != nj {
            return Err(DiagnoseError::TorqueCount {
                recording: recording(),
                found: self.tau.len(),
                joints: nj,
            });
        }
        if !self.y.is_empty() && self.y.len() != no {
            return Err(DiagnoseError::OutputCount {
                recording: recording(),
                found: self.y.len(),
                outputs: no,
            });
        }
        if self.tau.is_empty() && self.y.is_empty() {
            return Err(DiagnoseError::NoChannels {
                recording: recording(),
            });
        }
        let roles = (0..nj)
            .flat_map(|j| {
                [
                    (format!("q{}", j + 1), &self.q[j]),
                    (format!("qd{}", j + 1), &self.qd[j]),
                    (format!("qdd{}", j + 1), &self.qdd[j]),
                ]
            })
            .chain(
                self.tau
                    .iter()
                    .enumerate()
                    .map(|(j, v)| (format!("tau{}", j + 1), v)),
            )
            .chain(self.y.iter().enumerate().map(|(k, v)| (model.output_role(k), v)));
        for (series, v) in roles {
            if v.len() != n {
                return Err(DiagnoseError::SeriesLength {
                    recording: recording(),
                    series,
                    found: v.len(),
                    expected: n,
                });
            }
        }
        if n < MIN_SAMPLES {
            return Err(DiagnoseError::TooFewSamples {
                recording: recording(),
                found: n,
                needed: MIN_SAMPLES,
            });
        }
        let mut previous = f64::NEG_INFINITY;
        for (index, &t) in self.t.iter().enumerate() {
            if !(t.is_finite() && t > previous) {
                return Err(DiagnoseError::TimeNotIncreasing {
                    recording: recording(),
                    index,
                    t,
                    previous,
                });
            }
            previous = t;
        }
        Ok(())
    }

    /// Samples.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// This recording without its first and last `k` samples, fewer where that would leave
    /// less than `keep` (at least [`MIN_SAMPLES`]): where the rates were differentiated over
    /// ±k samples, the accelerations there come from fits that reach past the recording's
    /// ends — one-sided, an extrapolation whose error is neither the noise floor the
    /// diagnosis assumes nor physics (and where a run starts with a step of torque, the fit
    /// smears it across the window). Adds what it left out to
    /// [`ends_dropped`](Self::ends_dropped). A recording whose series differ in length from
    /// its time column is returned whole, for the diagnosis's check to name.
    pub fn without_ends(mut self, k: usize, keep: usize) -> Self {
        let n = self.len();
        let k = k.min(n.saturating_sub(keep.max(MIN_SAMPLES)) / 2);
        let series = || {
            self.q
                .iter()
                .chain(&self.qd)
                .chain(&self.qdd)
                .chain(&self.tau)
                .chain(&self.y)
        };
        if k == 0 || series().any(|x| x.len() != n) {
            return self;
        }
        let cut = |x: &mut Vec<f64>| {
            x.truncate(n - k);
            x.drain(..k);
        };
        cut(&mut self.t);
        for x in self
            .q
            .iter_mut()
            .chain(&mut self.qd)
            .chain(&mut self.qdd)
            .chain(&mut self.tau)
            .chain(&mut self.y)
        {
            cut(x);
        }
        self.ends_dropped += k;
        self
    }

    /// This recording cut into `k` contiguous parts of (nearly) equal length, named
    /// "`name` [part i/k]", for cross-validation when only one recording is fitted.
    /// Derivatives were taken on the whole recording, so no part has edge effects of its own.
    pub fn folds(&self, k: usize) -> Vec<MotionData> {
        let n = self.len();
        let k = k.max(1);
        (0..k)
            .map(|i| {
                let (a, b) = (i * n / k, (i + 1) * n / k);
                let part = |v: &[Vec<f64>]| v.iter().map(|x| x[a..b].to_vec()).collect();
                MotionData {
                    name: format!("{} [part {}/{k}]", self.name, i + 1),
                    t: self.t[a..b].to_vec(),
                    q: part(&self.q),
                    qd: part(&self.qd),
                    qdd: part(&self.qdd),
                    qdd_noise: self.qdd_noise.clone(),
                    tau: part(&self.tau),
                    y: part(&self.y),
                    ends_dropped: self.ends_dropped,
                }
            })
            .collect()
    }

    /// True if there are no samples.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The model's torques per joint at every sample with parameters `theta`.
    pub fn model_torques(&self, model: &dyn InverseDynamicsModel, theta: &[f64]) -> Vec<Vec<f64>> {
        self.model_all(model, theta).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ends go from every series alike, never below the samples a recording needs (or
    /// the caller asks to keep), and the count is kept; mismatched series stay whole.
    #[test]
    fn without_ends_drops_the_same_samples_from_every_series_and_keeps_enough() {
        let n = 200;
        let series = |c: f64| (0..n).map(|i| c + i as f64).collect::<Vec<f64>>();
        let d = MotionData {
            name: "r".into(),
            t: series(0.0),
            q: vec![series(1.0), series(2.0)],
            qd: vec![series(3.0), series(4.0)],
            qdd: vec![series(5.0), series(6.0)],
            qdd_noise: vec![0.1, 0.2],
            tau: vec![series(7.0), series(8.0)],
            y: vec![series(9.0)],
            ends_dropped: 0,
        };
        let cut = d.clone().without_ends(16, 0);
        assert_eq!((cut.len(), cut.ends_dropped), (n - 32, 16));
        for (c, x) in [
            (0.0, &cut.t),
            (1.0, &cut.q[0]),
            (4.0, &cut.qd[1]),
            (5.0, &cut.qdd[0]),
        ]
        .into_iter()
        .chain([(8.0, &cut.tau[1]), (9.0, &cut.y[0])])
        {
            assert_eq!((x[0], x[x.len() - 1], x.len()), (c + 16.0, c + 183.0, n - 32));
        }
        assert_eq!(cut.qdd_noise, d.qdd_noise);
        // Asked to keep 150 of 200: 25 go from each end.
        let kept = d.clone().without_ends(50, 150);
        assert_eq!((kept.len(), kept.ends_dropped, kept.t[0]), (150, 25, 25.0));
        // 60 samples leave 5 to drop at each end: the rest is MIN_SAMPLES.
        let short = MotionData {
            t: series(0.0)[..60].to_vec(),
            q: vec![series(1.0)[..60].to_vec()],
            qd: vec![series(2.0)[..60].to_vec()],
            qdd: vec![series(3.0)[..60].to_vec()],
            qdd_noise: vec![],
            tau: vec![series(4.0)[..60].to_vec()],
            y: vec![],
            ..d.clone()
        };
        let cut = short.clone().without_ends(16, 0);
        assert_eq!((cut.len(), cut.t[0], cut.tau[0][0]), (MIN_SAMPLES, 5.0, 9.0));
        assert_eq!(cut.ends_dropped, 5);
        assert_eq!(d.clone().without_ends(0, 0), d);
        // A series shorter than the time column: left whole for the check to name.
        let mut bad = short;
        bad.tau[0].truncate(10);
        assert_eq!(bad.clone().without_ends(16, 0), bad);
    }
    use std::path::PathBuf;

    fn recording(with_qdd: bool) -> Recording {
        let time: Vec<f64> = (0..200).map(|k| k as f64 * 1e-3).collect();
        let qd: Vec<f64> = time.iter().map(|t| (3.0 * t).sin()).collect();
        let mut channels = vec![
            (
                "q1".to_string(),
                time.iter().map(|t| -(3.0 * t).cos() / 3.0).collect(),
            ),
            ("qd1".to_string(), qd),
            ("tau1".to_string(), vec![0.0; time.len()]),
        ];
        if with_qdd {
            channels.push(("qdd1".to_string(), vec![7.0; time.len()]));
        }
        Recording {
            source: PathBuf::from("r.csv"),
            time,
            channels,
        }
    }

    #[test]
    fn a_recorded_acceleration_is_read_not_differentiated() {
        let d = MotionData::from_recording(&recording(true), 1, 5).unwrap();
        assert!(d.qdd[0].iter().all(|&a| a == 7.0));
        let d = MotionData::from_recording(&recording(false), 1, 5).unwrap();
        // 3 cos(3t), differentiated from the rates.
        assert!(
            (d.qdd[0][100] - 3.0 * (0.3f64).cos()).abs() < 1e-6,
            "{}",
            d.qdd[0][100]
        );
    }

    #[test]
    fn folds_are_contiguous_parts_that_cover_the_recording() {
        let d = MotionData::from_recording(&recording(false), 1, 5).unwrap();
        let parts = d.folds(4);
        assert_eq!(parts.len(), 4);
        assert_eq!(parts.iter().map(MotionData::len).sum::<usize>(), d.len());
        assert_eq!(parts[1].name, "r [part 2/4]");
        assert_eq!(parts[1].t[0], d.t[50]);
        assert_eq!(parts[3].qd[0].last(), d.qd[0].last());
    }
}
