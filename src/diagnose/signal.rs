//! Signal tools: noise floor, derivatives on irregular time grids, windows, correlation.

/// Noise floor (standard deviation of white measurement noise) of a densely sampled channel:
/// the median absolute second difference scaled to σ (1.4826·MAD/√6), or the same of the
/// fourth difference (1.4826·MAD/√70) if smaller — fast smooth motion (a shaken platform
/// tracked at µm noise) leaks into second differences, much less into fourth ones.
/// Quantisation shows up as its step/√12.
pub fn noise_floor(x: &[f64]) -> f64 {
    if x.len() < 3 {
        return 0.0;
    }
    let mut d2: Vec<f64> = x.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).abs()).collect();
    let mad = upper_median(&mut d2);
    if mad > 0.0 {
        let est2 = 1.4826 * mad / 6f64.sqrt();
        if x.len() >= 5 {
            let mut d4: Vec<f64> = x
                .windows(5)
                .map(|w| (w[4] - 4.0 * w[3] + 6.0 * w[2] - 4.0 * w[1] + w[0]).abs())
                .collect();
            let mad4 = upper_median(&mut d4);
            if mad4 > 0.0 {
                return est2.min(1.4826 * mad4 / 70f64.sqrt());
            }
        }
        return est2;
    }
    // Coarse quantisation (more than half the second differences vanish): use the RMS
    // instead of the median.
    let rms = (x
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).powi(2))
        .sum::<f64>()
        / (x.len() - 2) as f64)
        .sqrt();
    rms / 6f64.sqrt()
}

/// dx/dt by a local least-squares line over ±`half` samples (works on irregular time grids;
/// the window shrinks at the ends).
pub fn derivative(t: &[f64], x: &[f64], half: usize) -> Vec<f64> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let a = i.saturating_sub(half);
            let b = i.saturating_add(half).saturating_add(1).min(n);
            let m = (b - a) as f64;
            let tm = t[a..b].iter().sum::<f64>() / m;
            let xm = x[a..b].iter().sum::<f64>() / m;
            let (mut sxy, mut sxx) = (0.0, 0.0);
            for k in a..b {
                sxy += (t[k] - tm) * (x[k] - xm);
                sxx += (t[k] - tm).powi(2);
            }
            if sxx > 0.0 {
                sxy / sxx
            } else {
                0.0
            }
        })
        .collect()
}

/// dx/dt by a local least-squares cubic over ±`half` samples (a Savitzky–Golay derivative
/// on any time grid): no bias from the curvature of fast motion (the line's bias grows with
/// (ω·window)²), at the price of more noise for the same window.
pub fn derivative_cubic(t: &[f64], x: &[f64], half: usize) -> Vec<f64> {
    let n = t.len();
    (0..n)
        .map(|i| {
            let a = i.saturating_sub(half);
            let b = i.saturating_add(half).saturating_add(1).min(n);
            if b - a < 5 {
                return derivative(&t[a..b], &x[a..b], half)[i - a];
            }
            let s = t[a..b]
                .iter()
                .map(|tk| (tk - t[i]).abs())
                .fold(0.0, f64::max)
                .max(1e-300);
            let mut m = nalgebra::Matrix4::<f64>::zeros();
            let mut r = nalgebra::Vector4::<f64>::zeros();
            for k in a..b {
                let u = (t[k] - t[i]) / s;
                let p = [1.0, u, u * u, u * u * u];
                for (r_i, &pi) in p.iter().enumerate() {
                    r[r_i] += pi * x[k];
                    for (c, &pc) in p.iter().enumerate() {
                        m[(r_i, c)] += pi * pc;
                    }
                }
            }
            match m.lu().solve(&r) {
                Some(c) => c[1] / s,
                None => 0.0,
            }
        })
        .collect()
}

/// The standard deviation of what [`derivative_cubic`] over ±`half` samples makes of white
/// noise of standard deviation `sigma` in x, on the time grid `t` (read on its first full
/// window): √(Σ w_k²)·σ, the derivative filter's weights w_k found by differentiating unit
/// impulses. In x's unit per second.
pub fn derivative_noise(t: &[f64], half: usize, sigma: f64) -> f64 {
    let m = half.saturating_mul(2).saturating_add(1).min(t.len());
    if m < 2 || sigma == 0.0 {
        return 0.0;
    }
    let tw = &t[..m];
    let centre = m / 2;
    let mut e = vec![0.0; m];
    let mut sum = 0.0;
    for k in 0..m {
        e[k] = 1.0;
        sum += derivative_cubic(tw, &e, half)[centre].powi(2);
        e[k] = 0.0;
    }
    sum.sqrt() * sigma
}

/// The noise (standard deviation) of [`derivative_cubic`] over ±`half` samples of `x`,
/// measured on the data: the derivative is taken twice more, on the even and on the odd
/// samples alone over the same time span (±`half`/2 of each), which share the signal and the
/// bias but not the noise of white measurement errors; their difference (the odd one moved
/// to the even times) is ~√2 times the noise of each, and each has ~√2 times the noise of the
/// full estimate. Robust (median absolute deviation). Noise that is correlated from sample to
/// sample (filtered rates) is partly shared by both and not counted: what is counted is what
/// the estimate cannot tell from the signal it differentiates. In x's unit per second.
pub fn derivative_noise_measured(t: &[f64], x: &[f64], half: usize) -> f64 {
    let n = t.len().min(x.len());
    let h = (half / 2).max(2);
    if n < 4 * (2 * h + 1) {
        return 0.0;
    }
    let pick = |k: usize| -> (Vec<f64>, Vec<f64>) { (0..n).skip(k).step_by(2).map(|i| (t[i], x[i])).unzip() };
    let (te, xe) = pick(0);
    let (to, xo) = pick(1);
    let de = derivative_cubic(&te, &xe, h);
    let dob = derivative_cubic(&to, &xo, h);
    // Odd estimates at the even times (linear interpolation), away from the ends.
    let mut diff: Vec<f64> = (h + 1..de.len().min(dob.len()).saturating_sub(h + 1))
        .map(|k| {
            let (t0, t1) = (to[k - 1], to[k]);
            let w = if t1 > t0 { (te[k] - t0) / (t1 - t0) } else { 0.5 };
            (de[k] - (dob[k - 1] + w * (dob[k] - dob[k - 1]))).abs()
        })
        .filter(|d| d.is_finite())
        .collect();
    if diff.is_empty() {
        return 0.0;
    }
    1.4826 * upper_median(&mut diff) / 2.0
}

/// The upper median of `v` (the middle value; of an even count's two middle values the
/// larger), reordering `v`. NaN for an empty slice.
pub fn upper_median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, f64::total_cmp);
    *m
}

/// Root mean square.
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Lag-1 autocorrelation.
pub fn lag1(x: &[f64]) -> f64 {
    if x.len() < 3 {
        return 0.0;
    }
    let m = x.iter().sum::<f64>() / x.len() as f64;
    let v: f64 = x.iter().map(|a| (a - m).powi(2)).sum();
    if v == 0.0 {
        return 0.0;
    }
    x.windows(2).map(|w| (w[0] - m) * (w[1] - m)).sum::<f64>() / v
}

/// Effective number of independent samples of an AR(1)-like residual: n·(1 − ρ)/(1 + ρ),
/// at least 1.
pub fn effective_samples(n: usize, rho: f64) -> f64 {
    let r = rho.clamp(0.0, 0.999);
    (n as f64 * (1.0 - r) / (1.0 + r)).max(1.0)
}

/// Normalised autocorrelation r_k, k = 1..=`max_lag`, pooled over several segments (e.g. one
/// residual per recording): each segment is centred on its own mean, and
/// r_k = Σ_segments Σ_i e_i·e_(i+k) / Σ_segments Σ_i e_i², so no product straddles two
/// segments. Segments shorter than k + 1 samples add nothing at lag k. All zeros if the
/// segments carry no variance.
pub fn autocorrelation(segments: &[&[f64]], max_lag: usize) -> Vec<f64> {
    let centred: Vec<Vec<f64>> = segments
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| {
            let m = s.iter().sum::<f64>() / s.len() as f64;
            s.iter().map(|v| v - m).collect()
        })
        .collect();
    let var: f64 = centred.iter().flat_map(|s| s.iter().map(|v| v * v)).sum();
    (1..=max_lag)
        .map(|k| {
            if var <= 0.0 {
                return 0.0;
            }
            centred
                .iter()
                .filter(|s| s.len() > k)
                .map(|s| s.iter().zip(&s[k..]).map(|(a, b)| a * b).sum::<f64>())
                .sum::<f64>()
                / var
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A window wider than the recording (up to usize::MAX samples, from `--derivative-window`)
    /// is the whole recording: no index wraps around.
    #[test]
    fn a_window_wider_than_the_recording_is_the_whole_recording() {
        let t: Vec<f64> = (0..40).map(|k| k as f64 * 0.01).collect();
        let x: Vec<f64> = t.iter().map(|t| 3.0 * t + t * t * t).collect();
        assert_eq!(derivative(&t, &x, usize::MAX), derivative(&t, &x, 40));
        assert_eq!(derivative_cubic(&t, &x, usize::MAX), derivative_cubic(&t, &x, 40));
        assert!(derivative_noise(&t, usize::MAX, 1.0).is_finite());
    }

    /// Deterministic standard normal numbers (an LCG and Box–Muller) from `seed`.
    fn gaussians(mut s: u64) -> impl FnMut() -> f64 {
        move || {
            let mut u = || {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()
        }
    }

    #[test]
    fn noise_floor_sees_noise_not_a_smooth_signal() {
        // Deterministic pseudo-noise of known σ on a slow sine.
        let mut gauss = gaussians(12345);
        let x: Vec<f64> = (0..5000)
            .map(|k| (k as f64 * 1e-3).sin() + 0.01 * gauss())
            .collect();
        let nf = noise_floor(&x);
        assert!((nf / 0.01 - 1.0).abs() < 0.1, "noise floor {nf}");
    }

    #[test]
    fn derivative_noise_is_what_the_cubic_derivative_makes_of_white_noise() {
        let mut gauss = gaussians(777);
        let t: Vec<f64> = (0..20000).map(|k| k as f64 * 2e-3).collect();
        let x: Vec<f64> = t.iter().map(|_| 0.01 * gauss()).collect();
        for half in [3, 12] {
            let d = derivative_cubic(&t, &x, half);
            let inner = &d[half..d.len() - half];
            let sd = rms(inner);
            let predicted = derivative_noise(&t, half, 0.01);
            assert!(
                (sd / predicted - 1.0).abs() < 0.05,
                "half {half}: {sd} vs {predicted}"
            );
        }
    }

    #[test]
    fn autocorrelation_of_white_noise_is_small_and_of_a_sine_is_large() {
        let mut s = 7u64;
        let mut u = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 + 0.5) / (1u64 << 53) as f64 - 0.5
        };
        let white: Vec<f64> = (0..4000).map(|_| u()).collect();
        let r = autocorrelation(&[&white[..2000], &white[2000..]], 5);
        // 1/√4000 ≈ 0.016: white noise stays within a few of those.
        assert!(r.iter().all(|v| v.abs() < 0.06), "{r:?}");
        let sine: Vec<f64> = (0..2000).map(|k| (k as f64 * 0.01).sin()).collect();
        let r = autocorrelation(&[&sine], 3);
        assert!((r[0] - 1.0).abs() < 0.01, "{r:?}");
    }

    #[test]
    fn derivative_of_a_line_on_an_irregular_grid_is_exact() {
        let t: Vec<f64> = (0..100)
            .map(|k| k as f64 * 0.01 + 0.003 * ((k * 7) % 3) as f64)
            .collect();
        let x: Vec<f64> = t.iter().map(|v| 2.0 * v - 1.0).collect();
        for d in derivative(&t, &x, 4) {
            assert!((d - 2.0).abs() < 1e-9);
        }
    }
}
