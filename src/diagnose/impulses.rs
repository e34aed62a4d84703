//! Impulsive events in a residual: jumps within one sample far beyond the sample-to-sample
//! noise that fall back within a few tens of milliseconds — a torque sensor's or a drive's
//! glitch, an impact no candidate carries. No candidate of the library has this shape, and a
//! few such events can carry a large share of a residual's power; the adequacy test counts
//! them and says how far from the noise the rest of the residual is, beside (never instead
//! of) the verdict on the whole residual.
//!
//! Found on the DFKI double pendulum's recordings (session 72, by hand): the measured torque
//! of the elbow drops by 0.3–0.65 N m within one sample and recovers over 10–20 ms while the
//! commanded torque moves by less than 0.013 N m, every 0.6–1.7 s, mostly while the joint
//! turns forward — also on the passive shoulder of trajectory 12, whose commanded torque is
//! zero.
//!
//! # Detection
//!
//! The residual's first differences d_k = r_k − r_(k−1) have a robust spread
//! σ_d = 1.4826·MAD(d) (white noise of σ gives √2·σ; a smooth misfit adds little). A jump
//! |d_k| > [`IMPULSE_THRESHOLD`]·σ_d starts an event if
//!
//! - the **measured** channel jumps with it (its own first difference is at least half of
//!   d_k, with d_k's sign): a jump of the model's alone — a friction law changing sign on a
//!   quantised rate, say — is the model's, counted apart ([`ImpulseSummary::model_jumps`]);
//! - and, within [`IMPULSE_RECOVERY_S`], the residual comes back to within half the jump of
//!   its level before it (r_(k−1)); a jump that does not come back is a step, not counted.
//!
//! The event ends at its first sample whose deviation from that level is below
//! [`IMPULSE_SETTLED`] of the jump, or at the recovery limit — then it is *unsettled*: a
//! residual that came back past half the jump but is still beyond a quarter of it 50 ms on
//! (a slow return or a slow swing, not a glitch that is over) — and the search goes on from
//! there, so events never overlap. Samples the model could not evaluate (residual exactly 0)
//! start no event and count in no share. With Gaussian noise a difference beyond 8 σ_d occurs
//! about once in 10¹⁵ samples.

use super::signal::upper_median;
use serde::Serialize;

/// A first difference beyond this many robust standard deviations of the first differences
/// starts an event.
pub const IMPULSE_THRESHOLD: f64 = 8.0;
/// The residual must come back to within half the jump in this time, s.
pub const IMPULSE_RECOVERY_S: f64 = 0.05;
/// An event ends where its deviation falls below this fraction of its jump.
pub const IMPULSE_SETTLED: f64 = 0.25;

/// One impulsive event in a series: samples `start..end` and the jump at `start` (in the
/// series' unit; signed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Impulse {
    /// First sample of the event (the one after the jump).
    pub start: usize,
    /// One past its last sample.
    pub end: usize,
    /// r_start − r_(start−1).
    pub jump: f64,
    /// Whether its deviation fell below [`IMPULSE_SETTLED`] of the jump within
    /// [`IMPULSE_RECOVERY_S`] (false: the event was cut at the recovery limit, or at the
    /// series' end before it).
    pub settled: bool,
}

/// What [`find_impulses`] found in one series.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Found {
    /// The impulsive events, in time order.
    pub events: Vec<Impulse>,
    /// Jumps beyond the threshold that the measured channel did not make (the model's own).
    pub model_jumps: usize,
}

/// The impulsive events of the residual `r` sampled at times `t` (module documentation);
/// `measured` is the measured channel the residual was taken from (None: every jump is taken
/// as the data's). None in a series of fewer than 8 samples or one whose first differences
/// are mostly zero.
pub fn find_impulses(t: &[f64], r: &[f64], measured: Option<&[f64]>) -> Found {
    let n = r
        .len()
        .min(t.len())
        .min(measured.map_or(usize::MAX, <[f64]>::len));
    let mut found = Found::default();
    if n < 8 {
        return found;
    }
    let d: Vec<f64> = r[..n].windows(2).map(|w| w[1] - w[0]).collect();
    let sigma = robust_sd(&d);
    if sigma.is_nan() || sigma <= 0.0 {
        return found;
    }
    let limit = IMPULSE_THRESHOLD * sigma;
    let mut k = 1;
    while k < n {
        let jump = r[k] - r[k - 1];
        if jump.is_nan() || jump.abs() <= limit || r[k] == 0.0 || r[k - 1] == 0.0 {
            k += 1;
            continue;
        }
        let (level, size, sign) = (r[k - 1], jump.abs(), jump.signum());
        if let Some(m) = measured {
            if (m[k] - m[k - 1]) * sign < 0.5 * size {
                found.model_jumps += 1;
                k += 1;
                continue;
            }
        }
        let deviation = |i: usize| (r[i] - level) * sign;
        let horizon = t[k] + IMPULSE_RECOVERY_S;
        let back = (k + 1..n)
            .take_while(|&i| t[i] <= horizon)
            .find(|&i| deviation(i) < 0.5 * size);
        let Some(half) = back else {
            k += 1;
            continue;
        };
        let mut end = half;
        while end < n && t[end] <= horizon && deviation(end) >= IMPULSE_SETTLED * size {
            end += 1;
        }
        let settled = end < n && t[end] <= horizon;
        found.events.push(Impulse {
            start: k,
            end,
            jump,
            settled,
        });
        k = end;
    }
    found
}

/// 1.4826 × the median absolute deviation from the median (σ for Gaussian samples).
fn robust_sd(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    let m = upper_median(&mut x.to_vec());
    let mut dev: Vec<f64> = x.iter().map(|v| (v - m).abs()).collect();
    1.4826 * upper_median(&mut dev)
}

/// The impulsive events of one channel's residual over the basis recordings. Medians are
/// upper medians (the middle one of an even count's two).
#[derive(Debug, Clone, Default, Serialize)]
pub struct ImpulseSummary {
    /// Events found.
    pub count: usize,
    /// Median |jump|, in the channel's unit (None without events).
    pub median_jump: Option<f64>,
    /// Median time from the last sample before the jump to the event's last sample, s (None
    /// without events).
    pub median_duration_s: Option<f64>,
    /// Share of the residual's power (sum of squares) in the events' samples, 0–1.
    pub power_share: f64,
    /// RMS of the residual without the events' samples over the channel's noise floor (the
    /// whole residual's when there are no events).
    pub noise_ratio_without: f64,
    /// Share of the events whose jump opposes the motion of the channel's own joint (a
    /// drop while it turns or slides forward, a rise while it moves back; a joint at rest
    /// counts as not opposed), 0–1 (None without events, or when the joint's rate is not
    /// known).
    pub against_motion_share: Option<f64>,
    /// Jumps beyond the threshold that the measured channel did not make: the model's own
    /// (for example a friction law changing sign where the recorded rate does), not counted
    /// as events.
    pub model_jumps: usize,
    /// Events cut at the recovery limit (or the series' end) still beyond [`IMPULSE_SETTLED`]
    /// of their jump: a slow return or swing rather than a glitch that is over.
    pub unsettled: usize,
}

/// One recording's series for [`summarise`].
#[derive(Debug, Clone, Copy)]
pub struct Segment<'a> {
    /// Time, s.
    pub t: &'a [f64],
    /// The residual (measured − model), in the channel's unit.
    pub residual: &'a [f64],
    /// The measured channel, if known.
    pub measured: Option<&'a [f64]>,
    /// The rate of the joint the channel belongs to, if known.
    pub rate: Option<&'a [f64]>,
}

/// Summarises the events of each segment against the noise floor `sigma`.
pub fn summarise(segments: &[Segment], sigma: f64) -> ImpulseSummary {
    let (mut jumps, mut durations) = (vec![], vec![]);
    let (mut inside, mut total, mut outside_n) = (0.0, 0.0, 0usize);
    let (mut against, mut with_rate, mut model_jumps, mut unsettled) = (0usize, 0usize, 0usize, 0usize);
    for s in segments {
        let (t, r) = (s.t, s.residual);
        let found = find_impulses(t, r, s.measured);
        model_jumps += found.model_jumps;
        let mut in_event = vec![false; r.len()];
        for e in &found.events {
            jumps.push(e.jump.abs());
            unsettled += usize::from(!e.settled);
            durations.push(t[e.end - 1] - t[e.start - 1]);
            in_event[e.start..e.end].iter_mut().for_each(|v| *v = true);
            if let Some(q) = s.rate.and_then(|q| q.get(e.start)) {
                with_rate += 1;
                against += usize::from(*q * e.jump < 0.0);
            }
        }
        for (v, &inn) in r.iter().zip(&in_event) {
            if *v == 0.0 {
                // A sample the model could not evaluate.
                continue;
            }
            total += v * v;
            if inn {
                inside += v * v;
            } else {
                outside_n += 1;
            }
        }
    }
    let outside_power = total - inside;
    let median = |v: &mut Vec<f64>| (!v.is_empty()).then(|| upper_median(v));
    ImpulseSummary {
        count: jumps.len(),
        median_jump: median(&mut jumps),
        median_duration_s: median(&mut durations),
        power_share: if total > 0.0 { inside / total } else { 0.0 },
        noise_ratio_without: (outside_power / outside_n.max(1) as f64).sqrt() / sigma.max(1e-300),
        against_motion_share: (with_rate > 0).then(|| against as f64 / with_rate as f64),
        model_jumps,
        unsettled,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gaussian-like noise from a fixed linear congruential sequence (sum of 12 uniforms).
    fn noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                let mut acc = 0.0;
                for _ in 0..12 {
                    s = s
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    acc += (s >> 11) as f64 / (1u64 << 53) as f64;
                }
                sigma * (acc - 6.0)
            })
            .collect()
    }

    fn segment<'a>(
        t: &'a [f64],
        residual: &'a [f64],
        measured: Option<&'a [f64]>,
        rate: Option<&'a [f64]>,
    ) -> Segment<'a> {
        Segment {
            t,
            residual,
            measured,
            rate,
        }
    }

    #[test]
    fn noise_and_a_smooth_misfit_have_no_impulses() {
        let t: Vec<f64> = (0..5000).map(|i| i as f64 * 0.002).collect();
        let r: Vec<f64> = noise(5000, 0.02, 7)
            .iter()
            .zip(&t)
            .map(|(e, t)| e + 0.3 * (3.0 * t).sin())
            .collect();
        assert!(find_impulses(&t, &r, None).events.is_empty());
        let s = summarise(&[segment(&t, &r, None, None)], 0.02);
        assert_eq!(s.count, 0);
        assert_eq!(s.power_share, 0.0);
        assert!(s.median_jump.is_none() && s.against_motion_share.is_none());
    }

    #[test]
    fn drops_that_recover_are_found_and_a_step_is_not() {
        let t: Vec<f64> = (0..5000).map(|i| i as f64 * 0.002).collect();
        let mut r = noise(5000, 0.02, 11);
        // Three drops of 0.5 recovering linearly over 8 samples (16 ms), and a step of 0.5
        // that stays.
        for &at in &[1000usize, 2200, 3500] {
            for j in 0..8 {
                r[at + j] -= 0.5 * (1.0 - j as f64 / 8.0);
            }
        }
        for v in &mut r[4500..] {
            *v += 0.5;
        }
        let found = find_impulses(&t, &r, None).events;
        assert_eq!(
            found.iter().map(|e| e.start).collect::<Vec<_>>(),
            vec![1000, 2200, 3500]
        );
        for e in &found {
            assert!((e.jump + 0.5).abs() < 0.1, "{e:?}");
            assert!(e.end > e.start + 3 && e.end <= e.start + 9, "{e:?}");
            assert!(e.settled, "{e:?}");
        }
        let rate: Vec<f64> = t.iter().map(|t| if *t < 5.0 { 1.0 } else { -1.0 }).collect();
        let s = summarise(&[segment(&t, &r[..4400], None, Some(&rate))], 0.02);
        assert_eq!((s.count, s.unsettled), (3, 0));
        assert!(s.power_share > 0.3 && s.power_share < 0.9, "{s:?}");
        assert!(s.noise_ratio_without < 1.1, "{s:?}");
        // Drops at t = 2.0 and 4.4 s while moving forward (against), at 7.0 s while moving
        // back (with the motion).
        assert_eq!(s.against_motion_share, Some(2.0 / 3.0));
        let d = s.median_duration_s.unwrap();
        assert!(d > 0.005 && d < 0.02, "{d}");
    }

    #[test]
    fn a_jump_the_measured_channel_did_not_make_is_the_models() {
        // The model's friction flips sign on a quantised rate: the residual steps, the
        // measurement does not; a drop in the measurement itself is an event.
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 0.002).collect();
        let measured = noise(3000, 0.01, 3);
        let mut model = vec![0.0; 3000];
        for i in [500usize, 1500] {
            model[i] = 0.2;
            model[i + 1] = 0.2;
        }
        let mut measured_with_drop = measured.clone();
        for j in 0..6 {
            measured_with_drop[2500 + j] -= 0.4 * (1.0 - j as f64 / 6.0);
        }
        let r: Vec<f64> = measured_with_drop
            .iter()
            .zip(&model)
            .map(|(m, f)| m - f)
            .collect();
        let found = find_impulses(&t, &r, Some(&measured_with_drop));
        assert_eq!(
            found.events.iter().map(|e| e.start).collect::<Vec<_>>(),
            vec![2500]
        );
        // Each bump's rise and fall are the model's.
        assert_eq!(found.model_jumps, 4);
        // Without the measured channel every jump counts.
        assert_eq!(find_impulses(&t, &r, None).events.len(), 3);
        let s = summarise(&[segment(&t, &r, Some(&measured_with_drop), None)], 0.01);
        assert_eq!((s.count, s.model_jumps), (1, 4));
    }

    #[test]
    fn a_slow_return_is_counted_unsettled() {
        // A kick of 0.5 that decays with a 50 ms time constant: back past half after 35 ms,
        // still beyond a quarter at the 50 ms limit (until 69 ms).
        let t: Vec<f64> = (0..3000).map(|i| i as f64 * 0.002).collect();
        let mut r = noise(3000, 0.01, 5);
        for (i, v) in r.iter_mut().enumerate().skip(1000) {
            *v += 0.5 * (-(t[i] - t[1000]) / 0.05).exp();
        }
        let found = find_impulses(&t, &r[..1100], None).events;
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(!found[0].settled, "{:?}", found[0]);
        // It is cut at the recovery limit: its last sample is the last within 50 ms of the jump.
        let e = found[0];
        assert_eq!((e.start, e.end), (1000, 1026), "{e:?}");
        let s = summarise(&[segment(&t, &r[..1100], None, None)], 0.01);
        assert_eq!((s.count, s.unsettled), (1, 1));
    }
}
