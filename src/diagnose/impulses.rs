//! Impulsive events in a residual: jumps within one sample far beyond the sample-to-sample
//! noise that fall back within a few tens of milliseconds — a torque sensor's or a drive's
//! glitch, an impact no candidate carries. No candidate of the library has this shape, and a
//! few such events can carry a large share of a residual's power; the adequacy test counts
//! them and says how far from the noise the residual is without them, beside (never instead
//! of) the verdict on the whole residual.
//!
//! Found on the DFKI double pendulum's recordings (session 72, by hand): the measured torque
//! of either joint drops by 0.3–0.65 N m within one sample and recovers over 10–20 ms while
//! the commanded torque moves by less than 0.013 N m, every 0.6–1.7 s, with the joint turning
//! forward — also on the passive shoulder of trajectory 12, whose commanded torque is zero.
//!
//! # Detection
//!
//! The residual's first differences d_k = r_k − r_(k−1) have a robust spread
//! σ_d = 1.4826·MAD(d) (white noise of σ gives √2·σ; a smooth misfit adds little). A jump
//! |d_k| > [`IMPULSE_THRESHOLD`]·σ_d starts an event if, within [`IMPULSE_RECOVERY_S`], the
//! residual comes back to within half the jump of its level before it (r_(k−1)); the event
//! ends at the first sample whose deviation from that level is below [`IMPULSE_SETTLED`] of
//! the jump (or at the recovery limit). A jump that does not come back is a step, not an
//! impulse, and is not counted. With Gaussian noise a difference beyond 8 σ_d occurs about
//! once in 10¹⁵ samples.

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
}

/// The impulsive events of `r` sampled at times `t` (module documentation), in time order.
/// None in a series of fewer than 8 samples or one whose first differences are mostly zero.
pub fn find_impulses(t: &[f64], r: &[f64]) -> Vec<Impulse> {
    let n = r.len().min(t.len());
    if n < 8 {
        return vec![];
    }
    let d: Vec<f64> = r[..n].windows(2).map(|w| w[1] - w[0]).collect();
    let sigma = robust_sd(&d);
    if sigma.is_nan() || sigma <= 0.0 {
        return vec![];
    }
    let limit = IMPULSE_THRESHOLD * sigma;
    let mut out = vec![];
    let mut k = 1;
    while k < n {
        let jump = r[k] - r[k - 1];
        if jump.is_nan() || jump.abs() <= limit {
            k += 1;
            continue;
        }
        let (level, size, sign) = (r[k - 1], jump.abs(), jump.signum());
        let deviation = |i: usize| (r[i] - level) * sign;
        let horizon = t[k] + IMPULSE_RECOVERY_S;
        let mut back = None;
        let mut i = k + 1;
        while i < n && t[i] <= horizon {
            if deviation(i) < 0.5 * size {
                back = Some(i);
                break;
            }
            i += 1;
        }
        let Some(half) = back else {
            k += 1;
            continue;
        };
        let mut end = half;
        while end < n && t[end] <= horizon && deviation(end) >= IMPULSE_SETTLED * size {
            end += 1;
        }
        out.push(Impulse {
            start: k,
            end: end.max(half + 1).min(n),
            jump,
        });
        k = end.max(k + 1);
    }
    out
}

/// 1.4826 × the median absolute deviation from the median (σ for Gaussian samples).
fn robust_sd(x: &[f64]) -> f64 {
    let median = |mut v: Vec<f64>| -> f64 {
        let mid = v.len() / 2;
        let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
        *m
    };
    if x.is_empty() {
        return 0.0;
    }
    let m = median(x.to_vec());
    1.4826 * median(x.iter().map(|v| (v - m).abs()).collect())
}

/// The impulsive events of one channel's residual over the basis recordings.
#[derive(Debug, Clone, Default, Serialize)]
pub struct ImpulseSummary {
    /// Events found.
    pub count: usize,
    /// Median |jump|, in the channel's unit (None without events).
    pub median_jump: Option<f64>,
    /// Median time from the jump to the event's end, s (None without events).
    pub median_duration_s: Option<f64>,
    /// Share of the residual's power (sum of squares) in the events' samples, 0–1.
    pub power_share: f64,
    /// RMS of the residual without the events' samples over the channel's noise floor.
    pub noise_ratio_without: f64,
    /// Share of the events whose jump opposes the motion of the channel's own joint (a
    /// drop while it turns or slides forward, a rise while it moves back), 0–1 (None without
    /// events, or when the joint's rate is not known).
    pub against_motion_share: Option<f64>,
}

/// One recording's series for [`summarise`]: time (s), the residual, and the rate of the
/// joint the channel belongs to if known.
pub type Segment<'a> = (&'a [f64], &'a [f64], Option<&'a [f64]>);

/// Summarises the events of each segment against the noise floor `sigma`.
pub fn summarise(segments: &[Segment], sigma: f64) -> ImpulseSummary {
    let (mut jumps, mut durations) = (vec![], vec![]);
    let (mut inside, mut total, mut outside_n) = (0.0, 0.0, 0usize);
    let (mut against, mut with_rate) = (0usize, 0usize);
    for &(t, r, rate) in segments {
        let events = find_impulses(t, r);
        let mut in_event = vec![false; r.len()];
        for e in &events {
            jumps.push(e.jump.abs());
            durations.push(t[e.end.min(t.len()) - 1] - t[e.start - 1]);
            in_event[e.start..e.end].iter_mut().for_each(|v| *v = true);
            if let Some(q) = rate.and_then(|q| q.get(e.start)) {
                with_rate += 1;
                against += usize::from(*q * e.jump < 0.0);
            }
        }
        for (v, &inn) in r.iter().zip(&in_event) {
            total += v * v;
            if inn {
                inside += v * v;
            } else {
                outside_n += 1;
            }
        }
    }
    let outside_power = total - inside;
    let median = |v: &mut Vec<f64>| -> Option<f64> {
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    };
    ImpulseSummary {
        count: jumps.len(),
        median_jump: median(&mut jumps),
        median_duration_s: median(&mut durations),
        power_share: if total > 0.0 { inside / total } else { 0.0 },
        noise_ratio_without: (outside_power / outside_n.max(1) as f64).sqrt() / sigma.max(1e-300),
        against_motion_share: (with_rate > 0).then(|| against as f64 / with_rate as f64),
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

    #[test]
    fn noise_and_a_smooth_misfit_have_no_impulses() {
        let t: Vec<f64> = (0..5000).map(|i| i as f64 * 0.002).collect();
        let r: Vec<f64> = noise(5000, 0.02, 7)
            .iter()
            .zip(&t)
            .map(|(e, t)| e + 0.3 * (3.0 * t).sin())
            .collect();
        assert!(find_impulses(&t, &r).is_empty());
        let s = summarise(&[(&t, &r, None)], 0.02);
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
        let found = find_impulses(&t, &r);
        assert_eq!(
            found.iter().map(|e| e.start).collect::<Vec<_>>(),
            vec![1000, 2200, 3500]
        );
        for e in &found {
            assert!((e.jump + 0.5).abs() < 0.1, "{e:?}");
            assert!(e.end > e.start + 3 && e.end <= e.start + 9, "{e:?}");
        }
        let rate: Vec<f64> = t.iter().map(|t| if *t < 5.0 { 1.0 } else { -1.0 }).collect();
        let s = summarise(&[(&t, &r[..4400], Some(&rate))], 0.02);
        assert_eq!(s.count, 3);
        assert!(s.power_share > 0.3 && s.power_share < 0.9, "{s:?}");
        assert!(s.noise_ratio_without < 1.1, "{s:?}");
        // Drops at t = 2.0 and 4.4 s while moving forward (against), at 7.0 s while moving
        // back (with the motion).
        assert_eq!(s.against_motion_share, Some(2.0 / 3.0));
        let d = s.median_duration_s.unwrap();
        assert!(d > 0.005 && d < 0.02, "{d}");
    }
}
