//! Locate: where the nominal residual rises above the noise floor, and which state of the
//! mechanism those places share (velocity reversals, load reversals, acceleration peaks,
//! high speed).

use super::data::{ModelValues, MotionData};
use super::model::{on_copies, InverseDynamicsModel};
use super::signal::rms;
use serde::Serialize;

/// Every tunable of the localisation.
#[derive(Debug, Clone, PartialEq)]
pub struct LocateOptions {
    /// Window length, s.
    pub window_s: f64,
    /// A window is significant when its residual RMS exceeds this many noise floors.
    pub threshold: f64,
    /// Most windows reported.
    pub max_findings: usize,
    /// Speed below which a joint counts as at rest (velocity reversals need more), rad/s.
    pub rest_speed: f64,
}

impl Default for LocateOptions {
    fn default() -> Self {
        Self {
            window_s: 0.5,
            threshold: 3.0,
            max_findings: 6,
            rest_speed: 0.05,
        }
    }
}

/// One significant window.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// Recording.
    pub recording: String,
    /// Channel (joint torque).
    pub channel: String,
    /// Window start, s.
    pub t0: f64,
    /// Window end, s.
    pub t1: f64,
    /// Residual RMS in the window, N·m.
    pub rms: f64,
    /// Noise floor of the channel, N·m.
    pub noise_floor: f64,
    /// State tags of the window.
    pub tags: Vec<String>,
    /// The finding in words.
    pub text: String,
}

/// How strongly a state tag goes with a large residual on a channel.
#[derive(Debug, Clone, Serialize)]
pub struct Association {
    /// Channel.
    pub channel: String,
    /// State tag.
    pub tag: String,
    /// Mean residual RMS in windows with the tag / without it.
    pub ratio: f64,
    /// Windows with the tag.
    pub windows: usize,
}

/// How closely a channel's residual follows a state signal (Pearson correlation over all
/// samples): a residual following the sign of a joint's velocity looks like friction, one
/// following an acceleration like inertia, one following the measured load like a scale error.
#[derive(Debug, Clone, Serialize)]
pub struct StateCorrelation {
    /// Channel.
    pub channel: String,
    /// State signal.
    pub state: String,
    /// Correlation coefficient.
    pub r: f64,
}

/// Result of the localisation.
#[derive(Debug, Clone, Serialize, Default)]
pub struct Location {
    /// Per channel, the state signals the residual follows most closely (|r| ≥ 0.3), strongest
    /// first.
    pub correlations: Vec<StateCorrelation>,
    /// Strongest significant windows.
    pub findings: Vec<Finding>,
    /// Per channel, the state tags that go with large residuals, strongest first.
    pub associations: Vec<Association>,
    /// Fraction of windows significant, per channel.
    pub significant_fraction: Vec<(String, f64)>,
}

/// The windows a state tag names, as a phrase after "in windows": "with a load reversal in
/// drive C", "with an acceleration peak of drive A", "with drive B at high speed", "with drive
/// A at rest"; a configuration tag that carries its own preposition as it is ("near the
/// direct-kinematics singularity (measure below 0.3)").
pub(super) fn windows_phrase(tag: &str) -> String {
    if tag.starts_with("near ") {
        tag.to_string()
    } else if let Some(joint) = tag.strip_prefix("high speed of ") {
        format!("with {joint} at high speed")
    } else if tag.starts_with("acceleration peak") {
        format!("with an {tag}")
    } else if tag.starts_with("velocity reversal") || tag.starts_with("load reversal") {
        format!("with a {tag}")
    } else {
        format!("with {tag}")
    }
}

/// `phrase` with a note in brackets, merged into the phrase's own closing bracket where it
/// ends in one: "near the singularity (measure below 0.3; 1.6×)", not "(…) (1.6×)".
pub(super) fn with_note(phrase: &str, note: &str) -> String {
    match phrase.strip_suffix(')') {
        Some(open) => format!("{open}; {note})"),
        None => format!("{phrase} ({note})"),
    }
}

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    if n < 2.0 {
        return 0.0;
    }
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    if saa == 0.0 || sbb == 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

fn percentile(mut v: Vec<f64>, p: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * p).round() as usize]
}

/// Per joint, the acceleration (90th percentile of |q̈|) and speed (75th percentile of |q̇|)
/// above which a window counts as an acceleration peak or high speed, over a set of
/// recordings.
pub(super) struct StateScales {
    acc_hi: Vec<f64>,
    spd_hi: Vec<f64>,
}

impl StateScales {
    /// The scales of `data`.
    pub(super) fn of(model: &dyn InverseDynamicsModel, data: &[MotionData]) -> Self {
        let nj = model.joints();
        let pick = |f: &dyn Fn(&MotionData) -> &Vec<Vec<f64>>, p: f64| -> Vec<f64> {
            (0..nj)
                .map(|j| {
                    percentile(
                        data.iter()
                            .flat_map(|d| f(d)[j].iter().map(|v| v.abs()))
                            .collect(),
                        p,
                    )
                })
                .collect()
        };
        Self {
            acc_hi: pick(&|d| &d.qdd, 0.9),
            spd_hi: pick(&|d| &d.qd, 0.75),
        }
    }
}

/// The windows of `opts.window_s` of one recording as sample ranges [a, b) with the state
/// tags of each (velocity and load reversals, acceleration peaks, high speed, rest, and the
/// model's configuration tags at parameters `theta`, from its torques and outputs
/// `model_values` there, as [`MotionData::model_all`] gives them); `sigma` are the channels'
/// noise floors (torque channels first), which set when a measured load counts as reversing.
pub(super) fn tagged_windows(
    model: &dyn InverseDynamicsModel,
    d: &MotionData,
    theta: &[f64],
    model_values: &ModelValues,
    sigma: &[f64],
    scales: &StateScales,
    opts: &LocateOptions,
) -> Vec<(usize, usize, Vec<String>)> {
    let nj = model.joints();
    let (acc_hi, spd_hi) = (&scales.acc_hi, &scales.spd_hi);
    let (tau_model, y_model) = model_values;
    // Configuration tags per sample (e.g. near a singular configuration).
    let config: Vec<Option<String>> = (0..d.len())
        .map(|i| {
            let q: Vec<f64> = d.q.iter().map(|v| v[i]).collect();
            let y: Vec<f64> = y_model.iter().map(|v| v[i]).collect();
            model.configuration_tag(theta, &q, &y)
        })
        .collect();
    let mut out = vec![];
    let mut a = 0;
    while a < d.len() {
        let t_end = d.t[a] + opts.window_s;
        let b = d.t.iter().position(|&t| t >= t_end).unwrap_or(d.len());
        if b - a < 5 {
            break;
        }
        let mut tags = vec![];
        for k in 0..nj {
            let qd = &d.qd[k][a..b];
            let moving: Vec<f64> = qd.iter().copied().filter(|v| v.abs() > opts.rest_speed).collect();
            if moving.windows(2).any(|w| w[0] * w[1] < 0.0) {
                tags.push(format!("velocity reversal of {}", model.joint_name(k)));
            }
            // The measured load if recorded, else the model's.
            let tau = if d.tau.is_empty() {
                &tau_model[k][a..b]
            } else {
                &d.tau[k][a..b]
            };
            let load_noise = if d.tau.is_empty() {
                0.01 * tau.iter().fold(0.0f64, |m, v| m.max(v.abs()))
            } else {
                sigma[k]
            };
            let loaded: Vec<f64> = tau
                .iter()
                .copied()
                .filter(|v| v.abs() > 3.0 * load_noise)
                .collect();
            if loaded.windows(2).any(|w| w[0] * w[1] < 0.0) {
                tags.push(format!("load reversal in {}", model.joint_name(k)));
            }
            if d.qdd[k][a..b].iter().any(|v| v.abs() > acc_hi[k]) {
                tags.push(format!("acceleration peak of {}", model.joint_name(k)));
            }
            if qd.iter().map(|v| v.abs()).sum::<f64>() / qd.len() as f64 > spd_hi[k] {
                tags.push(format!("high speed of {}", model.joint_name(k)));
            }
            if qd.iter().all(|v| v.abs() <= opts.rest_speed) {
                tags.push(format!("{} at rest", model.joint_name(k)));
            }
        }
        for tag in config[a..b].iter().flatten() {
            if !tags.contains(tag) {
                tags.push(tag.clone());
            }
        }
        out.push((a, b, tags));
        a = b;
    }
    out
}

/// Windows of the nominal residual (parameters `theta`) of every recording.
pub fn locate(
    model: &dyn InverseDynamicsModel,
    data: &[MotionData],
    theta: &[f64],
    sigma: &[f64],
    opts: &LocateOptions,
) -> Location {
    let nj = model.joints();
    let chans = data.first().map(MotionData::channels).unwrap_or_default();
    let nc = chans.len();
    let scales = StateScales::of(model, data);
    // (channel, rms, tags, finding)
    let mut windows: Vec<(usize, f64, Vec<String>, Finding)> = vec![];
    // The nominal model along every recording, once (each evaluation is a pass of the
    // model's analyses along the recording).
    let values: Vec<ModelValues> = on_copies(data, model, &|d, m| d.model_all(m, theta));
    for (d, v) in data.iter().zip(&values) {
        let nominal = d.channels_of(&v.0, &v.1);
        for (a, b, tags) in tagged_windows(model, d, theta, v, sigma, &scales, opts) {
            for j in 0..nc {
                let meas = d.measured(chans[j]);
                let res: Vec<f64> = (a..b)
                    .map(|i| meas[i] - nominal[j][i])
                    .filter(|v| v.is_finite())
                    .collect();
                let r = rms(&res);
                let f = Finding {
                    recording: d.name.clone(),
                    channel: chans[j].name(model),
                    t0: d.t[a],
                    t1: d.t[b - 1],
                    rms: r,
                    noise_floor: sigma[j],
                    tags: tags.clone(),
                    text: String::new(),
                };
                windows.push((j, r, tags.clone(), f));
            }
        }
    }
    let mut out = Location::default();
    for j in 0..nc {
        let mut res = vec![];
        let mut states: Vec<(String, Vec<f64>)> = (0..nj)
            .flat_map(|k| {
                [
                    format!("sign of the {} velocity", model.joint_name(k)),
                    format!("{} velocity", model.joint_name(k)),
                    format!("{} acceleration", model.joint_name(k)),
                    format!("{} {}", model.joint_name(k), model.joint_motion(k).effort_word()),
                ]
            })
            .map(|n| (n, vec![]))
            .collect();
        for (d, v) in data.iter().zip(&values) {
            let nominal = d.channels_of(&v.0, &v.1);
            let tau_model = &v.0;
            let meas = d.measured(chans[j]);
            res.extend((0..d.len()).map(|i| {
                let v = meas[i] - nominal[j][i];
                if v.is_finite() {
                    v
                } else {
                    0.0
                }
            }));
            for k in 0..nj {
                states[4 * k]
                    .1
                    .extend(d.qd[k].iter().map(|v| (v / opts.rest_speed).tanh()));
                states[4 * k + 1].1.extend(&d.qd[k]);
                states[4 * k + 2].1.extend(&d.qdd[k]);
                states[4 * k + 3].1.extend(if d.tau.is_empty() {
                    &tau_model[k]
                } else {
                    &d.tau[k]
                });
            }
        }
        let mut cs: Vec<StateCorrelation> = states
            .into_iter()
            .map(|(name, x)| StateCorrelation {
                channel: chans[j].name(model),
                state: name,
                r: pearson(&res, &x),
            })
            .filter(|c| c.r.abs() >= 0.3)
            .collect();
        cs.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
        out.correlations.extend(cs.into_iter().take(3));
    }
    for j in 0..nc {
        let ch: Vec<&(usize, f64, Vec<String>, Finding)> = windows.iter().filter(|w| w.0 == j).collect();
        if ch.is_empty() {
            continue;
        }
        let sig = ch.iter().filter(|w| w.1 > opts.threshold * sigma[j]).count();
        out.significant_fraction
            .push((chans[j].name(model), sig as f64 / ch.len() as f64));
        let mut tags: Vec<String> = ch.iter().flat_map(|w| w.2.clone()).collect();
        tags.sort();
        tags.dedup();
        let mut assoc: Vec<Association> = tags
            .iter()
            .filter_map(|tag| {
                let with: Vec<f64> = ch.iter().filter(|w| w.2.contains(tag)).map(|w| w.1).collect();
                let without: Vec<f64> = ch.iter().filter(|w| !w.2.contains(tag)).map(|w| w.1).collect();
                if with.len() < 3 || without.len() < 3 {
                    return None;
                }
                let m = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
                Some(Association {
                    channel: chans[j].name(model),
                    tag: tag.clone(),
                    ratio: m(&with) / m(&without).max(1e-300),
                    windows: with.len(),
                })
            })
            .collect();
        assoc.sort_by(|a, b| b.ratio.total_cmp(&a.ratio));
        out.associations.extend(assoc.into_iter().take(3));
    }
    let mut sig: Vec<_> = windows
        .into_iter()
        .filter(|w| w.1 > opts.threshold * sigma[w.0])
        .collect();
    sig.sort_by(|a, b| (b.1 / sigma[b.0]).total_cmp(&(a.1 / sigma[a.0])));
    for (ch, _, tags, mut f) in sig.into_iter().take(opts.max_findings) {
        let state = if tags.is_empty() {
            "no distinctive state".to_string()
        } else {
            tags.join(", ")
        };
        let unit = chans[ch].unit(model);
        f.text = format!(
            "in the {} of {}, t = {:.2}–{:.2} s ({state}): residual {} {unit} RMS against a {} {unit} noise floor",
            f.channel,
            f.recording,
            f.t0,
            f.t1,
            super::format::number(f.rms),
            super::format::number(f.noise_floor)
        );
        out.findings.push(f);
    }
    out
}
