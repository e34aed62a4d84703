//! Adequacy: after the selection, is what remains noise? And uncertainties that include the
//! misfit.
//!
//! Everything here is measured on the **basis** recordings: the held-out recordings if there
//! are any (the fit never saw them), else the fit recordings (in sample, so optimistic).
//!
//! # Per channel
//!
//! - **Noise ratio** R = RMS / σ, σ the channel's noise floor (`signal::noise_floor`, the
//!   median over the fit recordings), before (nominal model) and after the fit.
//! - **Explained fraction.** The mismatch power above the noise is σ²·max(0, R² − 1); the
//!   explained fraction is the share of it the selected physics removes,
//!   e = 1 − max(0, R_after² − 1) / (R_before² − 1), clamped to [0, 1]. When the nominal
//!   model is already at noise (R_before ≤ [`UNEXPLAINED_NOISE_RATIO`]) there is nothing above
//!   the noise tolerance to explain: e = 1 if the fit keeps it there, 0 if the fit pushes
//!   the channel above the tolerance. A fit that makes the channel worse gives 0.
//! - **Whiteness.** The normalised autocorrelation r_k of the residual after the fit at lags
//!   k = 1..=L, L = [`WHITENESS_LAGS`] (fewer if the basis has under 5·L samples), pooled
//!   over the basis recordings (each centred on its own mean, `signal::autocorrelation`), and
//!   the Ljung–Box statistic Q = n(n+2)·Σ r_k²/(n−k), χ² with L degrees of freedom if the
//!   residual is white (`stats::ljung_box`; exact in distribution for held-out data, where
//!   no parameter was fitted to the series; on the fit basis it is slightly optimistic). Its
//!   p-value is `whiteness_p`. With thousands of samples Q detects the faintest colour, so
//!   "far from white" also asks for size: p < [`WHITENESS_ALPHA`] **and**
//!   r_1 > [`FAR_FROM_WHITE_LAG1`]. White noise of variance σ² plus a smooth misfit of power
//!   m has r_1 ≈ m/(σ² + m); at the ratio tolerance, m = (1.2² − 1)·σ², r_1 ≈ 0.31, so the two
//!   criteria agree on where noise ends.
//! - **Windows that stay significant**: the basis recordings cut into the localisation's
//!   windows (`LocateOptions::window_s`, tagged with the mechanism's state by
//!   `locate::tagged_windows`); a window is significant when its RMS after the fit exceeds
//!   `LocateOptions::threshold` noise floors. The worst window (largest RMS/σ) and the
//!   state tag whose windows carry the largest residual (mean RMS with the tag / without,
//!   at least 3 windows each) say where and when the remaining mismatch is largest.
//! - A channel is **unexplained** when R_after > [`UNEXPLAINED_NOISE_RATIO`] or its residual
//!   is far from white.
//!
//! # Whole diagnosis
//!
//! `unexplained` if any channel is. The overall explained fraction sums the excess powers in
//! noise units over the channels (so channels of different units add up, each weighted by
//! how far above its own noise it lies): 1 − Σ max(0, R_after² − 1) / Σ max(0, R_before² − 1),
//! clamped to [0, 1]; 1 when every channel's nominal residual is at noise.
//!
//! # Uncertainty that includes the misfit
//!
//! The least-squares standard deviation (`Estimate::std_noise_only`) treats the residual as
//! random noise with effective samples. Systematic misfit is not random: it biases the
//! estimates by an amount that does not shrink with more samples. Two allowances, the larger
//! one is `Estimate::std`:
//!
//! 1. **Inflation** by the residual-to-noise ratio of the channels the parameter acts on:
//!    the least-squares std already takes the residual's own RMS as its noise level (the
//!    channels are weighted by their misfit) and corrects for autocorrelation with effective
//!    samples, yet a systematic misfit biases the estimate by an amount no resampling of
//!    recordings that share it can see; the inflation is a deliberate allowance for that
//!    bias, of the size of the misfit relative to the noise (it is 1 at noise):
//!    f = √(Σ_j s_j·max(1, R_j)²), s_j the share of the parameter's information (the energy
//!    of its weighted column) in channel j, and R_j the larger of the fit and basis noise
//!    ratios after the fit. It covers misfit that is the same in every recording (which the
//!    jackknife cannot see).
//! 2. **Sandwich across recordings**: the leave-one-recording-out jackknife
//!    √((R−1)/R·Σ_r (x₋ᵣ − x̄)²) over the R fit recordings (each fold refits the final selection
//!    on the other recordings; a small solve on the accumulated Gram matrices). It measures
//!    how much the estimate depends on which recordings it was fitted to, whatever the
//!    residual's structure — the robust (sandwich) covariance with recordings as the
//!    independent units.
//!
//! **Stability.** An estimate is unstable (`Estimate::stable` false) when the range of its
//! leave-one-recording-out values exceeds both its inflated standard deviation (allowance
//! 1: the jackknife is that range itself, comparing with it would be circular) and
//! [`UNSTABLE_FRACTION`] of its magnitude: dropping one recording moves it more than the
//! noise and the misfit allow, so it soaks up model error rather than measuring physics.

use super::impulses::{summarise, ImpulseSummary, Segment};
use super::outcome::{ChannelFit, Diagnosis, Estimate};
use super::signal::{autocorrelation, rms};
use super::stats::ljung_box;
use serde::Serialize;

/// A channel whose RMS after the fit exceeds this many noise floors is unexplained (and one
/// whose nominal RMS is below it was already at noise).
pub const UNEXPLAINED_NOISE_RATIO: f64 = 1.2;
/// Lags of the residual autocorrelation in the whiteness test.
pub const WHITENESS_LAGS: usize = 20;
/// Significance level of the Ljung–Box whiteness test.
pub const WHITENESS_ALPHA: f64 = 1e-3;
/// Lag-1 autocorrelation above which a significantly coloured residual counts as far from
/// white (white noise plus a smooth misfit at [`UNEXPLAINED_NOISE_RATIO`] noise floors has
/// about 0.31).
pub const FAR_FROM_WHITE_LAG1: f64 = 0.3;
/// Relative movement between leave-one-recording-out folds above which an estimate (that
/// also moves by more than its inflated uncertainty) is unstable.
pub const UNSTABLE_FRACTION: f64 = 0.3;

/// A window of the residual after the fit.
#[derive(Debug, Clone, Serialize)]
pub struct ResidualWindow {
    /// Recording.
    pub recording: String,
    /// Window start, s.
    pub t0: f64,
    /// Window end, s.
    pub t1: f64,
    /// Residual RMS after the fit in the window (in the channel's unit).
    pub rms: f64,
    /// That RMS / the channel's noise floor.
    pub noise_ratio: f64,
    /// State tags of the window (reversals, peaks, configuration).
    pub tags: Vec<String>,
}

/// A state tag whose windows carry a larger residual after the fit.
#[derive(Debug, Clone, Serialize)]
pub struct StateExcess {
    /// State tag.
    pub tag: String,
    /// Mean window RMS with the tag / without it.
    pub ratio: f64,
    /// Windows with the tag.
    pub windows: usize,
}

/// Whether what remains in one channel after the fit is noise.
#[derive(Debug, Clone, Serialize)]
pub struct ChannelAdequacy {
    /// Channel.
    pub channel: String,
    /// Unit of the RMS values.
    pub unit: String,
    /// Noise floor (in `unit`).
    pub noise_floor: f64,
    /// RMS of the nominal model's residual on the basis recordings.
    pub rms_before: f64,
    /// RMS after the fit on the basis recordings.
    pub rms_after: f64,
    /// `rms_before` / noise floor.
    pub noise_ratio_before: f64,
    /// `rms_after` / noise floor.
    pub noise_ratio_after: f64,
    /// Fraction of the mismatch power above the noise that the fit removes (module doc).
    pub explained_fraction: f64,
    /// Normalised autocorrelation of the residual after the fit at lags 1..=L.
    pub autocorrelation: Vec<f64>,
    /// Ljung–Box statistic over those lags.
    pub ljung_box: f64,
    /// Its p-value (χ² with L degrees of freedom).
    pub whiteness_p: f64,
    /// Far from white: p below [`WHITENESS_ALPHA`] and lag-1 autocorrelation above
    /// [`FAR_FROM_WHITE_LAG1`].
    pub far_from_white: bool,
    /// Windows of the basis recordings.
    pub windows: usize,
    /// Windows whose RMS after the fit stays above the localisation threshold.
    pub significant_windows: usize,
    /// Where the remaining mismatch is largest.
    pub worst_window: Option<ResidualWindow>,
    /// The state whose windows carry the largest remaining residual (ratio above 1).
    pub strongest_state: Option<StateExcess>,
    /// Impulsive events in the residual after the fit ([`super::impulses`]): a share of its
    /// power no candidate models, and how far from the noise the rest is.
    pub impulsive_events: ImpulseSummary,
    /// RMS above [`UNEXPLAINED_NOISE_RATIO`] noise floors or far from white.
    pub unexplained: bool,
}

/// Whether what remains after the fit is noise, per channel and overall.
#[derive(Debug, Clone, Serialize)]
pub struct Adequacy {
    /// "held-out" or "fit": the recordings the numbers come from.
    pub basis: String,
    /// [`UNEXPLAINED_NOISE_RATIO`].
    pub unexplained_noise_ratio: f64,
    /// [`WHITENESS_LAGS`].
    pub whiteness_lags: usize,
    /// [`WHITENESS_ALPHA`].
    pub whiteness_alpha: f64,
    /// [`FAR_FROM_WHITE_LAG1`].
    pub far_from_white_lag1: f64,
    /// Window length, s, and the threshold in noise floors of a significant window.
    pub window: (f64, f64),
    /// Per channel.
    pub channels: Vec<ChannelAdequacy>,
    /// Overall explained fraction (module doc).
    pub explained_fraction: f64,
    /// Any channel unexplained.
    pub unexplained: bool,
    /// Estimates marked unstable, as "candidate (parameter)".
    pub unstable: Vec<String>,
}

/// The residual after the fit of one basis recording: its name, time, per channel the
/// series (in the channel's unit), and its tagged windows [a, b).
pub(super) struct BasisResidual<'a> {
    /// Recording.
    pub name: &'a str,
    /// Time, s.
    pub t: &'a [f64],
    /// Per channel, the residual after the fit.
    pub after: Vec<Vec<f64>>,
    /// Windows as sample ranges with their state tags.
    pub windows: Vec<(usize, usize, Vec<String>)>,
    /// Per channel, the measured series the residual was taken from.
    pub measured: Vec<&'a [f64]>,
    /// Per channel, the rate of the joint a torque channel belongs to (None for an output).
    pub rates: Vec<Option<&'a [f64]>>,
}

/// Excess power above the noise in noise units.
fn excess(ratio: f64) -> f64 {
    (ratio * ratio - 1.0).max(0.0)
}

/// The explained fraction of one channel from its noise ratios before and after the fit.
pub fn explained_fraction(before: f64, after: f64) -> f64 {
    if before <= UNEXPLAINED_NOISE_RATIO {
        return if after <= UNEXPLAINED_NOISE_RATIO {
            1.0
        } else {
            0.0
        };
    }
    (1.0 - excess(after) / excess(before)).clamp(0.0, 1.0)
}

/// The overall explained fraction over channels with noise ratios (before, after).
pub fn overall_explained_fraction(ratios: &[(f64, f64)]) -> f64 {
    let den: f64 = ratios.iter().map(|r| excess(r.0)).sum();
    let num: f64 = ratios.iter().map(|r| excess(r.1)).sum();
    if ratios.iter().all(|r| r.0 <= UNEXPLAINED_NOISE_RATIO) {
        return if ratios.iter().all(|r| r.1 <= UNEXPLAINED_NOISE_RATIO) {
            1.0
        } else {
            0.0
        };
    }
    (1.0 - num / den.max(1e-300)).clamp(0.0, 1.0)
}

/// Assesses the residual after the fit on the basis recordings (`held_out` says which they
/// are) and writes the per-channel results into `channels` (whose RMS values must be those
/// of the same basis); `window` is (window length in s, significance threshold in noise
/// floors) of the windows in `basis`.
pub(super) fn assess(
    channels: &mut [ChannelFit],
    basis: &[BasisResidual],
    held_out: bool,
    window: (f64, f64),
) -> Adequacy {
    let mut out = vec![];
    for (j, c) in channels.iter_mut().enumerate() {
        let sigma = c.noise_floor.max(1e-300);
        let (before, after) = if held_out {
            (c.holdout_before, c.holdout_after)
        } else {
            (c.fit_before, c.fit_after)
        };
        let segs: Vec<&[f64]> = basis.iter().map(|b| b.after[j].as_slice()).collect();
        let n: usize = segs.iter().map(|s| s.len()).sum();
        let r = autocorrelation(&segs, WHITENESS_LAGS.min(n.saturating_sub(1) / 5).max(1));
        let (q, p) = ljung_box(&r, n);
        let far = p < WHITENESS_ALPHA && r.first().copied().unwrap_or(0.0) > FAR_FROM_WHITE_LAG1;
        // Windows after the fit.
        let mut wins: Vec<(f64, &[String], ResidualWindow)> = vec![];
        for b in basis {
            for (a, e, tags) in &b.windows {
                let w = rms(&b.after[j][*a..*e]);
                wins.push((
                    w,
                    tags,
                    ResidualWindow {
                        recording: b.name.to_string(),
                        t0: b.t[*a],
                        t1: b.t[e - 1],
                        rms: w,
                        noise_ratio: w / sigma,
                        tags: tags.clone(),
                    },
                ));
            }
        }
        let significant = wins.iter().filter(|w| w.0 > window.1 * sigma).count();
        let segments: Vec<Segment> = basis
            .iter()
            .map(|b| Segment {
                t: b.t,
                residual: &b.after[j],
                measured: b.measured.get(j).copied(),
                rate: b.rates.get(j).copied().flatten(),
            })
            .collect();
        let impulsive_events = summarise(&segments, sigma);
        let worst = wins
            .iter()
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|w| w.2.clone());
        let mut tags: Vec<&String> = wins.iter().flat_map(|w| w.1.iter()).collect();
        tags.sort();
        tags.dedup();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        let strongest = tags
            .iter()
            .filter_map(|tag| {
                let with: Vec<f64> = wins.iter().filter(|w| w.1.contains(tag)).map(|w| w.0).collect();
                let without: Vec<f64> = wins.iter().filter(|w| !w.1.contains(tag)).map(|w| w.0).collect();
                (with.len() >= 3 && without.len() >= 3).then(|| StateExcess {
                    tag: (*tag).clone(),
                    ratio: mean(&with) / mean(&without).max(1e-300),
                    windows: with.len(),
                })
            })
            .filter(|s| s.ratio > 1.0)
            .max_by(|a, b| a.ratio.total_cmp(&b.ratio));
        let (rb, ra) = (before / sigma, after / sigma);
        let unexplained = ra > UNEXPLAINED_NOISE_RATIO || far;
        c.explained_fraction = explained_fraction(rb, ra);
        c.noise_ratio_after = ra;
        c.whiteness_p = p;
        c.unexplained = unexplained;
        c.worst_window = worst.clone();
        out.push(ChannelAdequacy {
            channel: c.channel.clone(),
            unit: c.unit.clone(),
            noise_floor: c.noise_floor,
            rms_before: before,
            rms_after: after,
            noise_ratio_before: rb,
            noise_ratio_after: ra,
            explained_fraction: c.explained_fraction,
            autocorrelation: r,
            ljung_box: q,
            whiteness_p: p,
            far_from_white: far,
            windows: wins.len(),
            significant_windows: significant,
            worst_window: worst,
            strongest_state: strongest,
            impulsive_events,
            unexplained,
        });
    }
    let ratios: Vec<(f64, f64)> = out
        .iter()
        .map(|c| (c.noise_ratio_before, c.noise_ratio_after))
        .collect();
    Adequacy {
        basis: if held_out { "held-out" } else { "fit" }.into(),
        unexplained_noise_ratio: UNEXPLAINED_NOISE_RATIO,
        whiteness_lags: WHITENESS_LAGS,
        whiteness_alpha: WHITENESS_ALPHA,
        far_from_white_lag1: FAR_FROM_WHITE_LAG1,
        window,
        explained_fraction: overall_explained_fraction(&ratios),
        unexplained: out.iter().any(|c| c.unexplained),
        channels: out,
        unstable: vec![],
    }
}

/// Recomputes the explained fractions and the unexplained flags from the channels' RMS
/// values (after the "before" values were replaced by the nominal model's, e.g. by the
/// re-linearisation); the whiteness and window results stay.
pub(super) fn refresh(d: &mut Diagnosis) {
    let held_out = d.adequacy.basis == "held-out";
    for (c, a) in d.channels.iter_mut().zip(d.adequacy.channels.iter_mut()) {
        let sigma = c.noise_floor.max(1e-300);
        let (before, after) = if held_out {
            (c.holdout_before, c.holdout_after)
        } else {
            (c.fit_before, c.fit_after)
        };
        a.rms_before = before;
        a.rms_after = after;
        a.noise_ratio_before = before / sigma;
        a.noise_ratio_after = after / sigma;
        a.explained_fraction = explained_fraction(a.noise_ratio_before, a.noise_ratio_after);
        a.unexplained = a.noise_ratio_after > UNEXPLAINED_NOISE_RATIO || a.far_from_white;
        c.explained_fraction = a.explained_fraction;
        c.noise_ratio_after = a.noise_ratio_after;
        c.unexplained = a.unexplained;
    }
    let ratios: Vec<(f64, f64)> = d
        .adequacy
        .channels
        .iter()
        .map(|c| (c.noise_ratio_before, c.noise_ratio_after))
        .collect();
    d.adequacy.explained_fraction = overall_explained_fraction(&ratios);
    d.adequacy.unexplained = d.adequacy.channels.iter().any(|c| c.unexplained);
    d.adequacy.unstable = unstable_names(&d.estimates);
    d.found = found_effects(&d.selected, &d.estimates, &d.unresolved_play);
    d.explained_fraction = d.adequacy.explained_fraction;
    d.unexplained = d.adequacy.unexplained;
    d.no_significant_mismatch = no_significant_mismatch(&d.found, d.unexplained);
}

/// Nothing found and nothing left unexplained: a mismatch the library cannot name is still a
/// mismatch.
pub(super) fn no_significant_mismatch(found: &[String], unexplained: bool) -> bool {
    found.is_empty() && !unexplained
}

/// The selected effects whose estimates are all stable, in selection order, each under the
/// name it is claimed by ([`claimed_name`](super::outcome::claimed_name): a play that
/// resolved no play is its joint's contact compliance).
pub(super) fn found_effects(
    selected: &[String],
    estimates: &[Estimate],
    unresolved: &[super::outcome::UnresolvedPlay],
) -> Vec<String> {
    selected
        .iter()
        .filter(|s| estimates.iter().filter(|e| &e.candidate == *s).all(|e| e.stable))
        .map(|s| super::outcome::claimed_name(s, unresolved))
        .collect()
}

/// "candidate (parameter)" of every unstable estimate.
pub(super) fn unstable_names(estimates: &[Estimate]) -> Vec<String> {
    estimates
        .iter()
        .filter(|e| !e.stable)
        .map(|e| format!("{} ({})", e.candidate, e.parameter))
        .collect()
}

/// Uncertainty including the misfit (module doc): inflates `std_noise_only` by the
/// information-weighted residual-to-noise ratio (`shares[p][j]`: parameter p's share of its
/// information in channel j; `ratio[j]`: the channel's noise ratio after the fit), takes the
/// larger of that and the jackknife as `std`, and marks the unstable estimates.
pub(super) fn honest_uncertainty(estimates: &mut [Estimate], shares: &[Vec<f64>], ratio: &[f64]) {
    for (e, s) in estimates.iter_mut().zip(shares) {
        let f2: f64 = s
            .iter()
            .zip(ratio)
            .map(|(sj, r)| sj * r.max(1.0).powi(2))
            .sum::<f64>();
        let total: f64 = s.iter().sum();
        e.inflation = if total > 0.0 { (f2 / total).sqrt() } else { 1.0 };
        let inflated = e.std_noise_only * e.inflation;
        e.std = inflated.max(e.std_jackknife.unwrap_or(0.0));
        let (lo, hi) = e
            .folds
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
                (lo.min(v), hi.max(v))
            });
        let range = if e.folds.len() >= 2 { hi - lo } else { 0.0 };
        e.stable = !(range > inflated && range > UNSTABLE_FRACTION * e.value.abs());
    }
}

/// The largest relative movement of an estimate between its leave-one-recording-out folds
/// (range of the fold values / |value|).
pub fn fold_movement(e: &Estimate) -> f64 {
    if e.folds.len() < 2 {
        return 0.0;
    }
    let (lo, hi) = e
        .folds
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (hi - lo) / e.value.abs().max(1e-300)
}

/// Up to two state tags of a window, those naming the channel's own joint (the channel name
/// up to its last word, e.g. "joint 1 (shoulder)" of "joint 1 (shoulder) torque") first.
fn short_tags(channel: &str, tags: &[String]) -> String {
    let own = channel.rsplit_once(' ').map(|(a, _)| a).unwrap_or(channel);
    let mut t: Vec<&String> = tags.iter().filter(|t| t.contains(own)).collect();
    t.extend(tags.iter().filter(|t| !t.contains(own)));
    if t.is_empty() {
        return "no distinctive state".into();
    }
    t.iter()
        .take(2)
        .map(|s| s.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The opening of the verdict: whether what remains is noise, with numbers per channel.
/// `selected_any`: the selection added at least one effect. The text ends with a full stop
/// and a space (empty if there are no channels).
pub(super) fn opening(a: &Adequacy, selected_any: bool) -> String {
    if a.channels.is_empty() {
        return String::new();
    }
    let basis = if a.basis == "held-out" {
        "held-out"
    } else {
        "fitted (no recording held out)"
    };
    if !a.unexplained {
        let worst = a.channels.iter().map(|c| c.noise_ratio_after).fold(0.0, f64::max);
        let min_p = a.channels.iter().map(|c| c.whiteness_p).fold(1.0, f64::min);
        let white = if min_p >= WHITENESS_ALPHA {
            format!("white (Ljung–Box p ≥ {min_p:.2})")
        } else {
            let r1 = a
                .channels
                .iter()
                .map(|c| c.autocorrelation.first().copied().unwrap_or(0.0))
                .fold(0.0, f64::max);
            format!("nearly white (lag-1 autocorrelation ≤ {r1:.2})")
        };
        let (head, what) = if selected_any {
            ("What remains is noise", "after the fit")
        } else {
            (
                "No significant mismatch; what remains is noise",
                "of the nominal model",
            )
        };
        return format!(
            "{head}: the {basis} residual {what} is ≤ {worst:.2}× the noise floor on every channel and {white}. "
        );
    }
    let parts: Vec<String> = a
        .channels
        .iter()
        .map(|c| {
            if !c.unexplained {
                let what = if c.noise_ratio_before <= UNEXPLAINED_NOISE_RATIO {
                    "nothing above the noise to explain".to_string()
                } else {
                    format!("{} % explained", percent_text(c.explained_fraction))
                };
                return format!(
                    "the {} is at noise ({:.2}× the noise floor; {what})",
                    c.channel, c.noise_ratio_after
                );
            }
            let mut s = format!(
                "{:.1}× the noise floor remains unexplained in the {} ({} % explained)",
                c.noise_ratio_after,
                c.channel,
                percent_text(c.explained_fraction)
            );
            if let Some(w) = &c.worst_window {
                s.push_str(&format!(
                    ", largest in {} at t = {:.2}–{:.2} s ({}, {:.1}× the noise)",
                    w.recording,
                    w.t0,
                    w.t1,
                    short_tags(&c.channel, &w.tags),
                    w.noise_ratio
                ));
            }
            s
        })
        .collect();
    let lead = if selected_any {
        format!(
            "the selected physics explains {} % of the {basis} mismatch above the noise",
            percent_text(a.explained_fraction)
        )
    } else {
        "no candidate physics explains the mismatch".to_string()
    };
    let mut s = format!("Unexplained mismatch remains: {lead}; {}. ", parts.join("; "));
    // Second sentence: structure, per unexplained channel.
    let detail: Vec<String> = a
        .channels
        .iter()
        .filter(|c| c.unexplained)
        .map(|c| {
            let mut t = format!(
                "in the {} the residual is {} (lag-1 autocorrelation {:.2}, Ljung–Box p {}) and {} of {} windows stay above {} noise floors",
                c.channel,
                whiteness_text(c),
                c.autocorrelation.first().copied().unwrap_or(0.0),
                p_text(c.whiteness_p),
                c.significant_windows,
                c.windows,
                a.window.1
            );
            if let Some(st) = c.strongest_state.as_ref().filter(|s| s.ratio > 1.2) {
                t.push_str(&format!(
                    ", {:.1}× larger in windows {}",
                    st.ratio,
                    super::locate::windows_phrase(&st.tag)
                ));
            }
            if let Some(text) = impulses_text(c) {
                t.push_str(&format!("; {text}"));
            }
            t
        })
        .collect();
    if !detail.is_empty() {
        let text = detail.join("; ");
        let mut cs = text.chars();
        let first = cs
            .next()
            .map(|c| c.to_uppercase().collect::<String>())
            .unwrap_or_default();
        s.push_str(&format!("{first}{}. ", cs.as_str()));
    }
    s
}

/// The impulsive events of a channel in words ("33 impulsive events (one-sample jumps of
/// median size 0.4583 N m falling back over a median 10 ms, 91 % of them against the joint's
/// motion) that no candidate models carry 24 % of the residual's power, the rest being 3.1×
/// the noise floor"), or None without events.
pub fn impulses_text(c: &ChannelAdequacy) -> Option<String> {
    let e = &c.impulsive_events;
    if e.count == 0 {
        return None;
    }
    let size = super::format::number(e.median_jump.unwrap_or(0.0));
    let ms = |d: f64| {
        let v = 1e3 * d;
        if v < 1.0 {
            format!("{v:.1}")
        } else {
            format!("{v:.0}")
        }
    };
    let (head, verb) = if e.count == 1 {
        let mut h = format!("a one-sample jump of {size} {}", c.unit);
        if let Some(d) = e.median_duration_s {
            h.push_str(&format!(" falling back over {} ms", ms(d)));
        }
        if let Some(f) = e.against_motion_share {
            h.push_str(if f > 0.5 {
                ", against the joint's motion"
            } else {
                ", with the joint's motion"
            });
        }
        (
            format!("1 impulsive event ({h}) that no candidate models"),
            "carries",
        )
    } else {
        let mut h = format!("one-sample jumps of median size {size} {}", c.unit);
        if let Some(d) = e.median_duration_s {
            h.push_str(&format!(" falling back over a median {} ms", ms(d)));
        }
        if let Some(f) = e.against_motion_share {
            h.push_str(&format!(
                ", {} % of them against the joint's motion",
                percent_text(f)
            ));
        }
        (
            format!("{} impulsive events ({h}) that no candidate models", e.count),
            "carry",
        )
    };
    let mut text = format!(
        "{head} {verb} {} % of the residual's power, the rest being {:.1}× the noise floor",
        percent_text(e.power_share),
        e.noise_ratio_without
    );
    if e.unsettled > 0 {
        let which = if e.count == 1 {
            "it is".to_string()
        } else if e.unsettled == e.count {
            "all are".to_string()
        } else {
            format!("{} of them are", e.unsettled)
        };
        text.push_str(&format!(
            "; {which} still beyond a quarter of the jump {} ms on (a slow return or swing, not a glitch that is over)",
            (1e3 * super::impulses::IMPULSE_RECOVERY_S).round()
        ));
    }
    Some(text)
}

/// A fraction as a percentage without the % sign: whole per cent, but never rounded up to
/// 100 (or down to 0) when it is not: 0.9954 is "99.5", 0.99996 "99.9", 0.002 "0.2".
pub fn percent_text(fraction: f64) -> String {
    let p = 100.0 * fraction;
    if (99.5..100.0).contains(&p) {
        format!("{:.1}", (p * 10.0).floor() / 10.0)
    } else if p > 0.0 && p < 0.5 {
        format!("{:.1}", ((p * 10.0).ceil() / 10.0).min(0.4))
    } else {
        format!("{p:.0}")
    }
}

/// How white a residual reads in words: "far from white" ([`ChannelAdequacy::far_from_white`]),
/// "coloured, but weakly" where Ljung–Box rejects whiteness at [`WHITENESS_ALPHA`] with a
/// lag-1 autocorrelation at most [`FAR_FROM_WHITE_LAG1`], else "close to white".
pub fn whiteness_text(c: &ChannelAdequacy) -> &'static str {
    if c.far_from_white {
        "far from white"
    } else if c.whiteness_p < WHITENESS_ALPHA {
        "coloured, but weakly"
    } else {
        "close to white"
    }
}

/// A p-value with its relation: "< 1e-300" for an underflow, "= " and two significant
/// digits otherwise.
pub fn p_text(p: f64) -> String {
    if p <= 1e-300 {
        "< 1e-300".into()
    } else if p < 0.01 {
        format!("= {p:.1e}")
    } else {
        format!("= {p:.2}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fraction_short_of_the_whole_is_never_printed_as_100_percent() {
        assert_eq!(percent_text(0.9954), "99.5");
        assert_eq!(percent_text(0.99996), "99.9");
        assert_eq!(percent_text(1.0), "100");
        assert_eq!(percent_text(0.62), "62");
        assert_eq!(percent_text(0.002), "0.2");
        assert_eq!(percent_text(0.0), "0");
    }

    #[test]
    fn explained_fraction_is_the_share_of_the_power_above_noise_removed() {
        // 10× → 5×: excess 99 → 24, explained 1 − 24/99.
        assert!((explained_fraction(10.0, 5.0) - (1.0 - 24.0 / 99.0)).abs() < 1e-12);
        // To the noise: all of it.
        assert_eq!(explained_fraction(10.0, 1.0), 1.0);
        // Worse after the fit: nothing.
        assert_eq!(explained_fraction(3.0, 4.0), 0.0);
        // Already at noise: nothing to explain, unless the fit pushes it above.
        assert_eq!(explained_fraction(1.1, 1.05), 1.0);
        assert_eq!(explained_fraction(1.1, 1.5), 0.0);
        // Overall: excess powers add in noise units.
        let e = overall_explained_fraction(&[(10.0, 5.0), (2.0, 1.0)]);
        assert!((e - (1.0 - 24.0 / 102.0)).abs() < 1e-12, "{e}");
        assert_eq!(overall_explained_fraction(&[(1.0, 1.0), (1.1, 1.0)]), 1.0);
    }

    #[test]
    fn the_impulses_sentence_says_how_many_events_did_not_settle() {
        let mut c = ChannelAdequacy {
            channel: "joint 2 (elbow) torque".into(),
            unit: "N m".into(),
            noise_floor: 0.02,
            rms_before: 0.2,
            rms_after: 0.07,
            noise_ratio_before: 10.0,
            noise_ratio_after: 3.5,
            explained_fraction: 0.9,
            autocorrelation: vec![0.5],
            ljung_box: 1e3,
            whiteness_p: 0.0,
            far_from_white: true,
            windows: 10,
            significant_windows: 4,
            impulsive_events: ImpulseSummary::default(),
            worst_window: None,
            strongest_state: None,
            unexplained: true,
        };
        assert_eq!(impulses_text(&c), None);
        c.impulsive_events = ImpulseSummary {
            count: 3,
            median_jump: Some(0.45),
            median_duration_s: Some(0.01),
            power_share: 0.24,
            noise_ratio_without: 3.1,
            against_motion_share: Some(0.9),
            model_jumps: 0,
            unsettled: 0,
        };
        let settled = impulses_text(&c).unwrap();
        assert!(settled.starts_with("3 impulsive events"), "{settled}");
        assert!(!settled.contains("still beyond"), "{settled}");
        c.impulsive_events.unsettled = 2;
        let two = impulses_text(&c).unwrap();
        assert!(
            two.ends_with("; 2 of them are still beyond a quarter of the jump 50 ms on (a slow return or swing, not a glitch that is over)"),
            "{two}"
        );
        c.impulsive_events.count = 1;
        c.impulsive_events.unsettled = 1;
        assert!(impulses_text(&c).unwrap().contains("; it is still beyond"));
    }

    fn estimate(value: f64, std: f64, folds: Vec<f64>) -> Estimate {
        Estimate {
            candidate: "c".into(),
            parameter: "p".into(),
            value,
            std,
            std_noise_only: std,
            std_jackknife: None,
            inflation: 1.0,
            folds,
            stable: true,
        }
    }

    #[test]
    fn uncertainty_inflates_by_the_channels_ratio_and_flags_moving_estimates() {
        // Acting 3/4 on a channel at 4× the noise and 1/4 on one at noise.
        let mut e = vec![
            estimate(1.0, 0.01, vec![0.99, 1.0, 1.01]),
            estimate(1.0, 0.01, vec![0.6, 1.0, 1.3]),
        ];
        let shares = vec![vec![3.0, 1.0], vec![3.0, 1.0]];
        honest_uncertainty(&mut e, &shares, &[4.0, 0.9]);
        let f = (0.75f64 * 16.0 + 0.25).sqrt();
        assert!((e[0].inflation - f).abs() < 1e-12);
        assert!((e[0].std - 0.01 * f).abs() < 1e-12 && e[0].std_noise_only == 0.01);
        assert!(e[0].stable);
        // Moves by 70 %: more than its inflated std (0.035) and more than 30 %.
        assert!(!e[1].stable);
        assert!((fold_movement(&e[1]) - 0.7).abs() < 1e-12);
        // A jackknife larger than the inflation wins.
        let mut j = vec![estimate(1.0, 0.01, vec![1.0, 1.0])];
        j[0].std_jackknife = Some(0.2);
        honest_uncertainty(&mut j, &[vec![1.0]], &[1.0]);
        assert_eq!(j[0].std, 0.2);
    }
}
