//! Equation-error diagnosis: measured motion → nominal inverse dynamics → torque residual;
//! rank the candidate physics, select greedily by cross-validated error and an information
//! criterion, estimate with uncertainty, flag what the data cannot separate, and show the
//! held-out improvement.
//!
//! Statistics. Residuals are weighted by each channel's noise floor. Model misfit is smooth,
//! so residual samples are not independent: tests and the information criterion use an
//! effective sample count n·(1 − ρ)/(1 + ρ), ρ the lag-1 autocorrelation of the residual left
//! after fitting the whole library (what remains is closest to the noise). Candidates are
//! ranked by the likelihood-ratio statistic n_eff·ln(RSS₀/RSS₁) (χ² with as many degrees of
//! freedom as columns). A candidate joins the model only if (1) its test is significant,
//! (2) the leave-one-recording-out cross-validated residual falls by at least `min_gain`,
//! and (3) the effective BIC falls.

use super::candidates::{columns, library, separating_experiment, Candidate, Effect, LibraryOptions};
use super::data::MotionData;
use super::locate::{locate, LocateOptions, Location};
use super::model::InverseDynamicsModel;
use super::signal::{effective_samples, lag1, noise_floor, rms};
use super::stats::{chi2_sf, Gram};
use serde::Serialize;

/// Every tunable of the diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct DiagnoseOptions {
    /// Candidate library settings.
    pub library: LibraryOptions,
    /// Significance level of the likelihood-ratio tests.
    pub significance: f64,
    /// Smallest relative fall of the cross-validated residual RMS for a candidate to join.
    pub min_gain: f64,
    /// Most effects combined.
    pub max_effects: usize,
    /// Candidates (by test statistic) whose cross-validated error is computed at each step.
    pub shortlist: usize,
    /// Two models whose cross-validated RMS differ by less than this (relative) cannot be
    /// told apart with the data.
    pub confound_tolerance: f64,
    /// Localisation settings.
    pub locate: LocateOptions,
    /// Re-weigh the channels once by the residual the first selection leaves, then select
    /// again.
    pub reweight: bool,
    /// Re-linearise once: move the selected model-parameter and sensor-offset estimates into
    /// the model, recompute every column around them and select again (one Gauss–Newton
    /// step for effects that are not linear in their parameters).
    pub relinearize: bool,
    /// The linearisation point, set by the re-linearisation: candidates whose values the
    /// model already contains (name, value). Residuals are taken as if from the nominal
    /// model (r + Σ value·column), so estimates are totals and any effect can still drop out.
    pub shift: Vec<(String, f64)>,
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            library: LibraryOptions::default(),
            significance: 1e-3,
            min_gain: 0.002,
            max_effects: 6,
            shortlist: 6,
            confound_tolerance: 0.005,
            locate: LocateOptions::default(),
            reweight: true,
            relinearize: true,
            shift: vec![],
        }
    }
}

/// A candidate's test at the nominal model.
#[derive(Debug, Clone, Serialize)]
pub struct Ranked {
    /// Candidate.
    pub candidate: String,
    /// Likelihood-ratio statistic against the nominal model (effective samples).
    pub statistic: f64,
    /// Its p-value.
    pub p_value: f64,
    /// Cross-validated residual RMS with this candidate alone, relative to nominal.
    pub cv_ratio: f64,
    /// Its fitted parameters alone lie in their physically plausible ranges.
    pub plausible: bool,
}

/// One step of the greedy selection.
#[derive(Debug, Clone, Serialize)]
pub struct Step {
    /// Candidate added.
    pub added: String,
    /// Likelihood-ratio statistic of the addition.
    pub statistic: f64,
    /// p-value.
    pub p_value: f64,
    /// Cross-validated weighted residual RMS after adding it (noise-floor units).
    pub cv_rms: f64,
    /// Effective BIC after adding it.
    pub bic: f64,
}

/// An estimated parameter.
#[derive(Debug, Clone, Serialize)]
pub struct Estimate {
    /// Candidate.
    pub candidate: String,
    /// Parameter with unit.
    pub parameter: String,
    /// Value.
    pub value: f64,
    /// Standard deviation (effective-sample corrected).
    pub std: f64,
}

/// A pair of effects the data cannot tell apart.
#[derive(Debug, Clone, Serialize)]
pub struct Confound {
    /// The selected effect.
    pub selected: String,
    /// An alternative that fits (cross-validated) as well.
    pub alternative: String,
    /// Cross-validated RMS with the alternative / with the selection.
    pub cv_ratio: f64,
    /// The recording that would separate them.
    pub experiment: String,
}

/// Residual of one torque channel before and after the fit.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelFit {
    /// Channel name.
    pub channel: String,
    /// Unit of the values below (N m for torques).
    pub unit: String,
    /// Noise floor of the measured channel (in `unit`).
    pub noise_floor: f64,
    /// RMS on the fit recordings, nominal model, N·m.
    pub fit_before: f64,
    /// RMS on the fit recordings, fitted model, N·m.
    pub fit_after: f64,
    /// RMS on the held-out recordings, nominal model, N·m.
    pub holdout_before: f64,
    /// RMS on the held-out recordings, fitted model, N·m.
    pub holdout_after: f64,
    /// 1 − after/before on the held-out recordings.
    pub holdout_reduction: f64,
}

/// Residual time series of one held-out recording and channel (for plots).
#[derive(Debug, Clone, Serialize)]
pub struct ResidualTrace {
    /// Recording.
    pub recording: String,
    /// Channel.
    pub channel: String,
    /// Unit of the residuals.
    pub unit: String,
    /// Time, s.
    pub t: Vec<f64>,
    /// Nominal residual, N·m.
    pub before: Vec<f64>,
    /// Fitted residual, N·m.
    pub after: Vec<f64>,
}

/// The outcome.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// Model.
    pub model: String,
    /// Fit recordings.
    pub fit_recordings: Vec<String>,
    /// Held-out recordings.
    pub holdout_recordings: Vec<String>,
    /// Samples × channels in the fit.
    pub samples: usize,
    /// Effective independent samples.
    pub effective_samples: f64,
    /// Where the nominal residual is significant, tied to the mechanism's state.
    pub location: Location,
    /// Every candidate's test at the nominal model, strongest first.
    pub ranking: Vec<Ranked>,
    /// Greedy steps.
    pub steps: Vec<Step>,
    /// Selected effects, in order.
    pub selected: Vec<String>,
    /// Estimates.
    pub estimates: Vec<Estimate>,
    /// Estimate pairs correlated beyond ±0.8: (a, b, correlation).
    pub correlations: Vec<(String, String, f64)>,
    /// Effects the data cannot separate.
    pub confounded: Vec<Confound>,
    /// Per channel, before/after.
    pub channels: Vec<ChannelFit>,
    /// True if nothing significant is missing.
    pub no_significant_mismatch: bool,
    /// One-paragraph verdict.
    pub verdict: String,
    /// Leave-one-recording-out residual RMS of the final model on the fit recordings, in
    /// noise-floor units (comparable between pre-processing choices).
    pub cv_rms_noise_units: f64,
    /// Half-width (samples) of the rate differentiation, and the cross-validated RMS of each
    /// half-width tried (empty if it was given).
    pub derivative_window: (usize, Vec<(usize, f64)>),
    /// Held-out residual traces.
    #[serde(skip)]
    pub traces: Vec<ResidualTrace>,
}

struct Prepared {
    cands: Vec<Candidate>,
    /// Global column indices of each candidate.
    cols_of: Vec<Vec<usize>>,
    /// Per recording: columns (all candidates, flattened) and weighted residual.
    blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)>,
    grams: Vec<Gram>,
}

fn prepare(
    model: &dyn InverseDynamicsModel,
    data: &[MotionData],
    sigma: &[f64],
    cands: &[Candidate],
    opts: &DiagnoseOptions,
) -> Prepared {
    let mut cols_of = vec![];
    let mut blocks = vec![];
    for d in data {
        let n = d.len();
        let chans = d.channels();
        let nc = chans.len();
        let (mut per, nominal) = columns(cands, d, model, &opts.library);
        let mut b = vec![0.0; nc * n];
        for (j, &c) in chans.iter().enumerate() {
            let meas = d.measured(c);
            for i in 0..n {
                b[j * n + i] = (meas[i] - nominal[j][i]) / sigma[j];
            }
        }
        // Samples the model cannot evaluate (e.g. beyond a singular configuration) carry no
        // weight.
        for i in 0..n {
            if (0..nc).any(|j| !b[j * n + i].is_finite()) {
                for j in 0..nc {
                    b[j * n + i] = 0.0;
                    for cc in per.iter_mut() {
                        for col in cc.iter_mut() {
                            col[j * n + i] = 0.0;
                        }
                    }
                }
            }
        }
        // Residual as if from the nominal model, linearised at the shifted point.
        for (name, value) in &opts.shift {
            if let Some(c) = cands.iter().position(|x| &x.name == name) {
                for col in &per[c] {
                    for (i, (bi, ci)) in b.iter_mut().zip(col).enumerate() {
                        *bi += value * ci / sigma[i / n];
                    }
                }
            }
        }
        let mut flat = vec![];
        let mut idx = vec![];
        for cc in per {
            let mut ids = vec![];
            for mut col in cc {
                for j in 0..nc {
                    for v in &mut col[j * n..(j + 1) * n] {
                        *v /= sigma[j];
                    }
                }
                ids.push(flat.len());
                flat.push(col);
            }
            idx.push(ids);
        }
        cols_of = idx;
        blocks.push((flat, b));
    }
    let grams = blocks.iter().map(|(c, b)| Gram::new(c, b)).collect();
    Prepared {
        cands: cands.to_vec(),
        cols_of,
        blocks,
        grams,
    }
}

impl Prepared {
    /// The same columns and residual with channel j divided by `w[j]` (recording r has
    /// `lens[r]` samples per channel).
    fn reweighed(&self, w: &[f64], lens: &[usize]) -> Prepared {
        let blocks: Vec<(Vec<Vec<f64>>, Vec<f64>)> = self
            .blocks
            .iter()
            .zip(lens)
            .map(|((cols, b), &n)| {
                let scale =
                    |v: &[f64]| -> Vec<f64> { v.iter().enumerate().map(|(i, x)| x / w[i / n]).collect() };
                (cols.iter().map(|c| scale(c)).collect(), scale(b))
            })
            .collect();
        let grams = blocks.iter().map(|(c, b)| Gram::new(c, b)).collect();
        Prepared {
            cands: self.cands.clone(),
            cols_of: self.cols_of.clone(),
            blocks,
            grams,
        }
    }
    fn idx(&self, set: &[usize]) -> Vec<usize> {
        set.iter().flat_map(|&c| self.cols_of[c].clone()).collect()
    }
    fn total(&self) -> Gram {
        Gram::sum(&self.grams).expect("at least one recording")
    }
    fn rss(&self, set: &[usize]) -> f64 {
        let g = self.total();
        let idx = self.idx(set);
        let x = g.solve(&idx);
        g.rss(&idx, &x)
    }
    /// Leave-one-recording-out cross-validated RSS (plain RSS with one recording).
    fn cv_rss(&self, set: &[usize]) -> f64 {
        let idx = self.idx(set);
        let total = self.total();
        if self.grams.len() < 2 {
            return total.rss(&idx, &total.solve(&idx));
        }
        self.grams
            .iter()
            .map(|fold| {
                let train = total.minus(fold);
                fold.rss(&idx, &train.solve(&idx))
            })
            .sum()
    }
    /// Leave-one-recording-out residual RMS of `set` with channel j rescaled by `factor[j]`
    /// (e.g. to noise-floor units, comparable between pre-processing choices).
    fn cv_rms_rescaled(&self, set: &[usize], factor: &[f64], lens: &[usize]) -> f64 {
        let idx = self.idx(set);
        let total = self.total();
        let (mut ss, mut n) = (0.0, 0usize);
        for (r, fold) in self.grams.iter().enumerate() {
            let train = if self.grams.len() > 1 {
                total.minus(fold)
            } else {
                total.clone()
            };
            let x = train.solve(&idx);
            let res = self.residual(r, set, &x);
            for (j, f) in factor.iter().enumerate() {
                for v in &res[j * lens[r]..(j + 1) * lens[r]] {
                    ss += (v * f).powi(2);
                    n += 1;
                }
            }
        }
        (ss / n.max(1) as f64).sqrt()
    }
    /// True if every coefficient of a fit of `set` lies within its candidate's bounds.
    fn plausible(&self, set: &[usize]) -> bool {
        let g = self.total();
        let x = g.solve(&self.idx(set));
        let mut p = 0;
        for &c in set {
            for &(lo, hi) in &self.cands[c].bounds {
                if !(x[p] >= lo && x[p] <= hi) {
                    return false;
                }
                p += 1;
            }
        }
        true
    }
    fn dof(&self, set: &[usize]) -> usize {
        set.iter()
            .map(|&c| self.cols_of[c].len() + self.cands[c].grid_parameters)
            .sum()
    }
    /// Weighted residual series of a fit of `set` on recording r, per joint.
    fn residual(&self, r: usize, set: &[usize], x: &[f64]) -> Vec<f64> {
        let (cols, b) = &self.blocks[r];
        let idx = self.idx(set);
        let mut out = b.clone();
        for (p, &i) in idx.iter().enumerate() {
            for (o, c) in out.iter_mut().zip(&cols[i]) {
                *o -= x[p] * c;
            }
        }
        out
    }
}

/// Runs the equation-error diagnosis of `model` on the `fit` recordings, checked on
/// `holdout`. `progress` receives (stage, fraction done).
pub fn diagnose(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    mut progress: impl FnMut(&str, f64),
) -> Diagnosis {
    let first = diagnose_once(model, fit, holdout, opts, |s, f| progress(s, 0.5 * f));
    if !opts.relinearize {
        progress("done", 1.0);
        return first;
    }
    // Shift the model by the selected parameter and sensor-offset estimates.
    let cands = library(model, &opts.library);
    let mut delta = vec![0.0; model.parameters().len()];
    let mut q_offset = vec![0.0; model.joints()];
    let mut moved: Vec<(String, f64)> = vec![];
    for e in &first.estimates {
        let Some(c) = cands.iter().find(|c| c.name == e.candidate) else {
            continue;
        };
        match (c.effect, c.joint) {
            (Effect::Parameter { index, .. }, _) => delta[index] += e.value,
            (Effect::PositionOffset, Some(j)) => q_offset[j] += e.value,
            _ => continue,
        }
        moved.push((c.name.clone(), e.value));
    }
    if moved.is_empty() {
        progress("done", 1.0);
        return first;
    }
    let shifted = Shifted {
        inner: model,
        delta,
        q_offset,
    };
    let mut o2 = opts.clone();
    o2.relinearize = false;
    o2.shift = moved;
    let mut second = diagnose_once(&shifted, fit, holdout, &o2, |s, f| progress(s, 0.5 + 0.5 * f));
    // "Before" is the nominal model's, and so are the localisation and the score tests.
    for (c2, c1) in second.channels.iter_mut().zip(&first.channels) {
        c2.fit_before = c1.fit_before;
        c2.holdout_before = c1.holdout_before;
        c2.holdout_reduction = if c1.holdout_before > 0.0 {
            1.0 - c2.holdout_after / c1.holdout_before
        } else {
            0.0
        };
    }
    for (t2, t1) in second.traces.iter_mut().zip(&first.traces) {
        t2.before = t1.before.clone();
    }
    second.location = first.location;
    second.ranking = first.ranking;
    second.model = first.model;
    second.no_significant_mismatch = second.selected.is_empty();
    second.verdict = verdict_text(model, &second, &cands);
    progress("done", 1.0);
    second
}

/// The nominal model with its parameters moved by `delta` and its joint positions read with
/// `q_offset` removed.
struct Shifted<'a> {
    inner: &'a dyn InverseDynamicsModel,
    delta: Vec<f64>,
    q_offset: Vec<f64>,
}

impl Shifted<'_> {
    fn q(&self, q: &[f64]) -> Vec<f64> {
        q.iter().zip(&self.q_offset).map(|(a, b)| a - b).collect()
    }
}

impl InverseDynamicsModel for Shifted<'_> {
    fn name(&self) -> String {
        self.inner.name()
    }
    fn joints(&self) -> usize {
        self.inner.joints()
    }
    fn joint_name(&self, j: usize) -> String {
        self.inner.joint_name(j)
    }
    fn parameters(&self) -> Vec<super::model::ModelParameter> {
        let mut p = self.inner.parameters();
        for (x, d) in p.iter_mut().zip(&self.delta) {
            x.nominal += d;
        }
        p
    }
    fn torques(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64]) {
        self.inner.torques(theta, &self.q(q), qd, qdd, tau)
    }
    fn rotor_regressor(&self, j: usize, qdd: &[f64], out: &mut [f64]) {
        self.inner.rotor_regressor(j, qdd, out)
    }
    fn outputs(&self) -> usize {
        self.inner.outputs()
    }
    fn output_name(&self, k: usize) -> String {
        self.inner.output_name(k)
    }
    fn output_unit(&self, k: usize) -> String {
        self.inner.output_unit(k)
    }
    fn output_role(&self, k: usize) -> String {
        self.inner.output_role(k)
    }
    fn evaluate(&self, theta: &[f64], q: &[f64], qd: &[f64], qdd: &[f64], tau: &mut [f64], y: &mut [f64]) {
        self.inner.evaluate(theta, &self.q(q), qd, qdd, tau, y)
    }
    fn output_sensitivities(
        &self,
        theta: &[f64],
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        y: &[f64],
    ) -> Option<super::model::OutputSensitivities> {
        self.inner.output_sensitivities(theta, &self.q(q), qd, qdd, y)
    }
    fn clearance_sites(&self) -> Vec<String> {
        self.inner.clearance_sites()
    }
    fn clearance_load_scale(&self) -> f64 {
        self.inner.clearance_load_scale()
    }
    fn backlash_torque_scale(&self) -> f64 {
        self.inner.backlash_torque_scale()
    }
    fn drive_compliance(&self, theta: &[f64], j: usize) -> f64 {
        self.inner.drive_compliance(theta, j)
    }
    fn configuration_tag(&self, theta: &[f64], q: &[f64], y: &[f64]) -> Option<String> {
        self.inner.configuration_tag(theta, &self.q(q), y)
    }
}

/// One pass of the diagnosis at the model's nominal parameters.
fn diagnose_once(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    opts: &DiagnoseOptions,
    mut progress: impl FnMut(&str, f64),
) -> Diagnosis {
    let chans = fit.first().map(MotionData::channels).unwrap_or_default();
    let nj = chans.len();
    progress("noise floor", 0.0);
    // Noise floor per channel: median over the fit recordings.
    let sigma: Vec<f64> = chans
        .iter()
        .map(|&c| {
            let mut v: Vec<f64> = fit.iter().map(|d| noise_floor(d.measured(c))).collect();
            v.sort_by(f64::total_cmp);
            v[v.len() / 2].max(1e-12)
        })
        .collect();
    let theta0: Vec<f64> = model.parameters().iter().map(|p| p.nominal).collect();
    progress("locate", 0.1);
    let location = locate(model, fit, &theta0, &sigma, &opts.locate);
    let cands = library(model, &opts.library);
    progress("candidate regressors", 0.2);
    // Channel weights: the larger of the noise floor and the nominal misfit of the channel,
    // so a channel whose misfit dwarfs its noise does not drown the others (one step of
    // feasible generalised least squares).
    let lens: Vec<usize> = fit.iter().map(MotionData::len).collect();
    let raw = prepare(model, fit, &vec![1.0; nj], &cands, opts);
    let mut weight_scale: Vec<f64> = (0..nj)
        .map(|j| {
            let (ss, cnt) = raw
                .blocks
                .iter()
                .zip(&lens)
                .fold((0.0, 0usize), |(ss, cnt), ((_, b), &n)| {
                    (
                        ss + b[j * n..(j + 1) * n].iter().map(|v| v * v).sum::<f64>(),
                        cnt + n,
                    )
                });
            (ss / cnt.max(1) as f64).sqrt().max(sigma[j])
        })
        .collect();
    let mut pass = 0;
    let (prep, set, steps, cv_cur, ranking, n, n_eff, total) = loop {
        let prep = raw.reweighed(&weight_scale, &lens);
        let n: usize = prep.grams.iter().map(|g| g.n).sum();
        // Effective samples from the residual left by the whole library.
        let all: Vec<usize> = (0..cands.len()).collect();
        let total = prep.total();
        let x_all = total.solve(&prep.idx(&all));
        let rhos: Vec<f64> = (0..fit.len())
            .flat_map(|r| {
                let res = prep.residual(r, &all, &x_all);
                let len = fit[r].len();
                (0..nj)
                    .map(move |j| lag1(&res[j * len..(j + 1) * len]))
                    .collect::<Vec<_>>()
            })
            .collect();
        let rho = rhos.iter().sum::<f64>() / rhos.len() as f64;
        let n_eff = effective_samples(n, rho);
        let lr = |rss0: f64, rss1: f64| n_eff * (rss0.max(1e-300) / rss1.max(1e-300)).ln();
        let bic = |set: &[usize]| n_eff * (prep.rss(set) / n as f64).ln() + prep.dof(set) as f64 * n_eff.ln();
        // Ranking at the nominal model.
        progress("score tests", 0.3);
        let rss0 = total.bb;
        let cv0 = prep.cv_rss(&[]);
        let mut ranking: Vec<(usize, Ranked)> = (0..cands.len())
            .map(|c| {
                let stat = lr(rss0, prep.rss(&[c]));
                let k = prep.cols_of[c].len() + cands[c].grid_parameters;
                (
                    c,
                    Ranked {
                        candidate: cands[c].name.clone(),
                        statistic: stat,
                        p_value: chi2_sf(stat, k),
                        cv_ratio: (prep.cv_rss(&[c]) / cv0).sqrt(),
                        plausible: prep.plausible(&[c]),
                    },
                )
            })
            .collect();
        ranking.sort_by(|a, b| b.1.statistic.total_cmp(&a.1.statistic));
        // Greedy selection.
        let mut set: Vec<usize> = vec![];
        let mut steps = vec![];
        let mut cv_cur = cv0;
        let mut bic_cur = bic(&[]);
        while set.len() < opts.max_effects {
            progress(
                "selection",
                0.4 + 0.4 * set.len() as f64 / opts.max_effects as f64,
            );
            let rss_cur = prep.rss(&set);
            let mut tests: Vec<(usize, f64)> = (0..cands.len())
                .filter(|c| !set.contains(c))
                .map(|c| {
                    let mut s = set.clone();
                    s.push(c);
                    (c, lr(rss_cur, prep.rss(&s)))
                })
                .collect();
            tests.sort_by(|a, b| b.1.total_cmp(&a.1));
            let short: Vec<(usize, f64, f64, f64)> = tests
                .iter()
                .filter(|&&(c, _)| {
                    let mut s = set.clone();
                    s.push(c);
                    prep.plausible(&s)
                })
                .take(opts.shortlist)
                .map(|&(c, stat)| {
                    let mut s = set.clone();
                    s.push(c);
                    (c, stat, prep.cv_rss(&s), bic(&s))
                })
                .collect();
            // Smallest cross-validated error; among those the data cannot tell from it
            // (within the confounding tolerance), the smallest information criterion — the
            // simpler law (Coulomb before Stribeck or asymmetric friction) unless the data
            // ask for more.
            let cv_min = short.iter().map(|x| x.2).fold(f64::INFINITY, f64::min);
            let tol = (1.0 + opts.confound_tolerance).powi(2);
            let best = short
                .iter()
                .filter(|x| x.2 <= cv_min * tol)
                .min_by(|a, b| a.3.total_cmp(&b.3))
                .copied();
            let Some((c, stat, cv, b)) = best else { break };
            let k = prep.cols_of[c].len() + cands[c].grid_parameters;
            let p = chi2_sf(stat, k);
            let gain = 1.0 - (cv / cv_cur).sqrt();
            if p > opts.significance || gain < opts.min_gain || b >= bic_cur {
                break;
            }
            set.push(c);
            cv_cur = cv;
            bic_cur = b;
            steps.push(Step {
                added: cands[c].name.clone(),
                statistic: stat,
                p_value: p,
                cv_rms: (cv / n as f64).sqrt(),
                bic: b,
            });
        }
        // Simplify: an effect chosen early may have absorbed part of one found later; if a
        // simpler law of the same family (Coulomb for asymmetric or Stribeck friction) now
        // fits as well (cross-validated, within the confounding tolerance) with a smaller
        // information criterion, it replaces the richer one.
        let tol = (1.0 + opts.confound_tolerance).powi(2);
        for pos in 0..set.len() {
            let c = set[pos];
            let cost = |k: usize| prep.cols_of[k].len() + cands[k].grid_parameters;
            let simpler = (0..cands.len())
                .filter(|&d| !set.contains(&d) && same_family(&cands[c], &cands[d]) && cost(d) < cost(c))
                .filter_map(|d| {
                    let mut s2 = set.clone();
                    s2[pos] = d;
                    if !prep.plausible(&s2) {
                        return None;
                    }
                    let (cv2, b2) = (prep.cv_rss(&s2), bic(&s2));
                    (cv2 <= cv_cur * tol && b2 < bic_cur).then_some((d, cv2, b2))
                })
                .min_by(|a, b| a.2.total_cmp(&b.2));
            if let Some((d, cv2, b2)) = simpler {
                set[pos] = d;
                steps[pos].added = cands[d].name.clone();
                cv_cur = cv2;
                bic_cur = b2;
            }
        }
        // Re-weigh once: the channel scales the selected physics leaves (a large effect
        // found first no longer inflates its channel's weight, so what hides under it can
        // show).
        if pass == 0 && opts.reweight && !set.is_empty() {
            let x = total.solve(&prep.idx(&set));
            let mut ss = vec![0.0; nj];
            let mut cnt = vec![0usize; nj];
            for r in 0..fit.len() {
                let res = prep.residual(r, &set, &x);
                for j in 0..nj {
                    for v in &res[j * lens[r]..(j + 1) * lens[r]] {
                        ss[j] += (v * weight_scale[j]).powi(2);
                        cnt[j] += 1;
                    }
                }
            }
            let new_w: Vec<f64> = (0..nj)
                .map(|j| (ss[j] / cnt[j].max(1) as f64).sqrt().max(sigma[j]))
                .collect();
            if new_w.iter().zip(&weight_scale).any(|(a, b)| a / b < 0.8) {
                weight_scale = new_w;
                pass += 1;
                continue;
            }
        }
        break (prep, set, steps, cv_cur, ranking, n, n_eff, total);
    };
    progress("estimates", 0.85);
    // Estimates with uncertainty.
    let idx = prep.idx(&set);
    let x = total.solve(&idx);
    let dof = (n as f64 - idx.len() as f64).max(1.0);
    let s2 = total.rss(&idx, &x) / dof;
    let cov = total.inverse(&idx) * (s2 * n as f64 / n_eff);
    let mut estimates = vec![];
    let mut labels = vec![];
    let mut p = 0;
    for &c in &set {
        for name in &cands[c].parameters {
            // Columns are weighted like the residual, so coefficients are in physical units.
            estimates.push(Estimate {
                candidate: cands[c].name.clone(),
                parameter: name.clone(),
                value: x[p],
                std: cov[(p, p)].max(0.0).sqrt(),
            });
            labels.push(format!("{} ({})", cands[c].name, name));
            p += 1;
        }
    }
    let mut correlations = vec![];
    for a in 0..idx.len() {
        for b in 0..a {
            let r = cov[(a, b)] / (cov[(a, a)] * cov[(b, b)]).sqrt();
            if r.abs() > 0.8 {
                correlations.push((labels[a].clone(), labels[b].clone(), r));
            }
        }
    }
    // Confounding: swapping a selected effect for another fits (cross-validated) as well.
    let mut confounded = vec![];
    for (pos, &c) in set.iter().enumerate() {
        for d in 0..cands.len() {
            if set.contains(&d) || same_family(&cands[c], &cands[d]) {
                continue;
            }
            let mut s = set.clone();
            s[pos] = d;
            if !prep.plausible(&s) {
                continue;
            }
            let ratio = (prep.cv_rss(&s) / cv_cur).sqrt();
            if ratio < 1.0 + opts.confound_tolerance {
                confounded.push(Confound {
                    selected: cands[c].name.clone(),
                    alternative: cands[d].name.clone(),
                    cv_ratio: ratio,
                    experiment: separating_experiment(&cands[c], &cands[d]),
                });
            }
        }
    }
    progress("held-out check", 0.9);
    let (channels, traces) = channel_fits(model, fit, holdout, &prep, &set, &x, &weight_scale, &sigma, opts);
    let lens: Vec<usize> = fit.iter().map(MotionData::len).collect();
    let factor: Vec<f64> = (0..nj).map(|j| weight_scale[j] / sigma[j]).collect();
    let cv_rms_noise_units = prep.cv_rms_rescaled(&set, &factor, &lens);
    let no_mismatch = set.is_empty();
    let verdict = verdict(
        model,
        &set,
        &prep.cands,
        &estimates,
        &channels,
        &confounded,
        &location,
    );
    progress("done", 1.0);
    Diagnosis {
        model: model.name(),
        fit_recordings: fit.iter().map(|d| d.name.clone()).collect(),
        holdout_recordings: holdout.iter().map(|d| d.name.clone()).collect(),
        samples: n,
        effective_samples: n_eff,
        location,
        ranking: ranking.into_iter().map(|(_, r)| r).collect(),
        steps,
        selected: set.iter().map(|&c| cands[c].name.clone()).collect(),
        estimates,
        correlations,
        confounded,
        channels,
        no_significant_mismatch: no_mismatch,
        verdict,
        cv_rms_noise_units,
        derivative_window: (0, vec![]),
        traces,
    }
}

/// Chooses the half-width of the rate differentiation by leave-one-recording-out
/// cross-validation of the whole diagnosis on the fit recordings (the held-out recordings
/// play no part), then diagnoses with it. Short windows pass acceleration noise into the
/// inertial regressors; long ones bias fast motion: the cross-validated torque prediction
/// error measures both.
pub fn diagnose_recordings(
    model: &dyn InverseDynamicsModel,
    fit: &[super::recording::Recording],
    holdout: &[super::recording::Recording],
    windows: &[usize],
    opts: &DiagnoseOptions,
    mut progress: impl FnMut(&str, f64),
) -> Result<Diagnosis, super::recording::RecordingError> {
    let nj = model.joints();
    let load = |recs: &[super::recording::Recording], w: usize| -> Result<Vec<MotionData>, _> {
        recs.iter()
            .map(|r| {
                if model.outputs() > 0 {
                    MotionData::from_recording_with_outputs(r, model, w)
                } else {
                    MotionData::from_recording(r, nj, w)
                }
            })
            .collect()
    };
    let mut scores = vec![];
    if windows.len() > 1 {
        for (k, &w) in windows.iter().enumerate() {
            progress(
                "choosing the differentiation window",
                k as f64 / windows.len() as f64 * 0.5,
            );
            let d = diagnose(model, &load(fit, w)?, &[], opts, |_, _| {});
            scores.push((w, d.cv_rms_noise_units));
        }
    }
    let w = scores
        .iter()
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|s| s.0)
        .unwrap_or(windows.first().copied().unwrap_or(5));
    let mut d = diagnose(model, &load(fit, w)?, &load(holdout, w)?, opts, |s, f| {
        progress(s, 0.5 + 0.5 * f)
    });
    d.derivative_window = (w, scores);
    Ok(d)
}

/// Variants of one effect in one joint (e.g. Stribeck velocities, or Coulomb within
/// asymmetric friction) are refinements, not rival explanations.
fn same_family(a: &Candidate, b: &Candidate) -> bool {
    use Effect::*;
    let fam = |e: Effect| match e {
        Coulomb | Stribeck { .. } | AsymmetricFriction => 1,
        Viscous => 2,
        RotorInertia => 3,
        TorqueOffset => 4,
        TorqueScale => 5,
        TorqueDelay => 6,
        Parameter { .. } => 7,
        PositionOffset => 8,
        Backlash => 9,
        Clearance { .. } => 10,
        OutputOffset { .. } => 11,
        OutputDelay { .. } => 12,
    };
    a.joint == b.joint && fam(a.effect) == fam(b.effect) && fam(a.effect) != 7
}

#[allow(clippy::too_many_arguments)]
fn channel_fits(
    model: &dyn InverseDynamicsModel,
    fit: &[MotionData],
    holdout: &[MotionData],
    prep: &Prepared,
    set: &[usize],
    x: &[f64],
    sigma: &[f64],
    noise: &[f64],
    opts: &DiagnoseOptions,
) -> (Vec<ChannelFit>, Vec<ResidualTrace>) {
    let chans = fit.first().map(MotionData::channels).unwrap_or_default();
    let nj = chans.len();
    let mut fit_b = vec![vec![]; nj];
    let mut fit_a = vec![vec![]; nj];
    for r in 0..fit.len() {
        let n = fit[r].len();
        let before = &prep.blocks[r].1;
        let after = prep.residual(r, set, x);
        for j in 0..nj {
            fit_b[j].extend(before[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]));
            fit_a[j].extend(after[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]));
        }
    }
    let mut ho_b = vec![vec![]; nj];
    let mut ho_a = vec![vec![]; nj];
    let mut traces = vec![];
    if !holdout.is_empty() {
        let hp = prepare(model, holdout, sigma, &prep.cands, opts);
        for r in 0..holdout.len() {
            let n = holdout[r].len();
            let before = &hp.blocks[r].1;
            let after = hp.residual(r, set, x);
            for j in 0..nj {
                let b: Vec<f64> = before[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]).collect();
                let a: Vec<f64> = after[j * n..(j + 1) * n].iter().map(|v| v * sigma[j]).collect();
                ho_b[j].extend(&b);
                ho_a[j].extend(&a);
                traces.push(ResidualTrace {
                    recording: holdout[r].name.clone(),
                    channel: chans[j].name(model),
                    unit: chans[j].unit(model),
                    t: holdout[r].t.clone(),
                    before: b,
                    after: a,
                });
            }
        }
    }
    let channels = (0..nj)
        .map(|j| {
            let (hb, ha) = (rms(&ho_b[j]), rms(&ho_a[j]));
            ChannelFit {
                channel: chans[j].name(model),
                unit: chans[j].unit(model),
                noise_floor: noise[j],
                fit_before: rms(&fit_b[j]),
                fit_after: rms(&fit_a[j]),
                holdout_before: hb,
                holdout_after: ha,
                holdout_reduction: if hb > 0.0 { 1.0 - ha / hb } else { 0.0 },
            }
        })
        .collect();
    (channels, traces)
}

/// A value with four significant-looking digits: fixed for ordinary magnitudes, exponent
/// for small ones (µm-scale outputs).
pub fn number(v: f64) -> String {
    if v == 0.0 || (1e-2..1e4).contains(&v.abs()) {
        format!("{v:.4}")
    } else {
        format!("{v:.3e}")
    }
}

/// The verdict of a finished diagnosis (after its estimates were moved back to the nominal
/// model).
fn verdict_text(model: &dyn InverseDynamicsModel, d: &Diagnosis, cands: &[Candidate]) -> String {
    let set: Vec<usize> = d
        .selected
        .iter()
        .filter_map(|n| cands.iter().position(|c| &c.name == n))
        .collect();
    verdict(
        model,
        &set,
        cands,
        &d.estimates,
        &d.channels,
        &d.confounded,
        &d.location,
    )
}

fn verdict(
    model: &dyn InverseDynamicsModel,
    set: &[usize],
    cands: &[Candidate],
    estimates: &[Estimate],
    channels: &[ChannelFit],
    confounded: &[Confound],
    location: &Location,
) -> String {
    let mut s = String::new();
    if set.is_empty() {
        s.push_str(&format!(
            "No significant mismatch: no candidate physics improves the cross-validated fit of the {} beyond the noise.",
            model.name()
        ));
        return s;
    }
    if let Some(f) = location.findings.first() {
        s.push_str(&format!("The nominal model disagrees most {}. ", f.text));
    }
    for c in &location.correlations {
        s.push_str(&format!(
            "The {} residual follows the {} (r = {:+.2}). ",
            c.channel, c.state, c.r
        ));
    }
    for a in location.associations.iter().filter(|a| a.ratio > 1.5) {
        s.push_str(&format!(
            "In the {} the residual is {:.1}× larger in windows with {}. ",
            a.channel, a.ratio, a.tag
        ));
    }
    s.push_str("Missing physics, in order of evidence: ");
    let parts: Vec<String> = set
        .iter()
        .map(|&c| {
            let est: Vec<String> = estimates
                .iter()
                .filter(|e| e.candidate == cands[c].name)
                .map(|e| format!("{} = {} ± {}", e.parameter, number(e.value), number(e.std)))
                .collect();
            format!("{} ({})", cands[c].name, est.join(", "))
        })
        .collect();
    s.push_str(&parts.join("; "));
    s.push_str(". ");
    for c in channels {
        if c.holdout_before > 0.0 {
            let u = &c.unit;
            s.push_str(&format!(
                "Held out, the {} residual falls from {} to {} {u} RMS ({:+.1} %; noise floor {} {u}). ",
                c.channel,
                number(c.holdout_before),
                number(c.holdout_after),
                -100.0 * c.holdout_reduction,
                number(c.noise_floor)
            ));
        }
    }
    for c in confounded {
        s.push_str(&format!(
            "The data cannot tell {} from {} (cross-validated fits within {:.1} %); {} would separate them. ",
            c.selected,
            c.alternative,
            100.0 * (c.cv_ratio - 1.0).abs(),
            c.experiment
        ));
    }
    s.trim_end().to_string()
}
