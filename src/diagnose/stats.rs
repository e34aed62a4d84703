//! Least squares on accumulated Gram matrices, and the χ² tail for the tests.
//!
//! Every recording contributes G = AᵀWA, g = AᵀWb and bᵀWb over the whole candidate library
//! once; any subset fit, leave-one-recording-out cross-validation and every likelihood-ratio
//! test then costs a small dense solve, independent of the number of samples.

use nalgebra::{DMatrix, DVector};

/// Accumulated normal equations of one recording (or a sum of them).
#[derive(Debug, Clone, PartialEq)]
pub struct Gram {
    /// AᵀA (weighted).
    pub g: DMatrix<f64>,
    /// Aᵀb.
    pub ab: DVector<f64>,
    /// bᵀb.
    pub bb: f64,
    /// Rows.
    pub n: usize,
}

impl Gram {
    /// From the columns (each of length n) and the right-hand side.
    pub fn new(cols: &[Vec<f64>], b: &[f64]) -> Self {
        let m = cols.len();
        let mut g = DMatrix::zeros(m, m);
        let mut ab = DVector::zeros(m);
        for i in 0..m {
            ab[i] = dot(&cols[i], b);
            for k in 0..=i {
                let v = dot(&cols[i], &cols[k]);
                g[(i, k)] = v;
                g[(k, i)] = v;
            }
        }
        Self {
            g,
            ab,
            bb: dot(b, b),
            n: b.len(),
        }
    }

    /// Sum of several.
    pub fn sum<'a>(parts: impl IntoIterator<Item = &'a Gram>) -> Option<Gram> {
        let mut it = parts.into_iter();
        let mut s = it.next()?.clone();
        for p in it {
            s.g += &p.g;
            s.ab += &p.ab;
            s.bb += p.bb;
            s.n += p.n;
        }
        Some(s)
    }

    /// Difference (for leave-one-out folds).
    pub fn minus(&self, o: &Gram) -> Gram {
        Gram {
            g: &self.g - &o.g,
            ab: &self.ab - &o.ab,
            bb: self.bb - o.bb,
            n: self.n - o.n,
        }
    }

    /// Least-squares coefficients on the columns `idx` (column-scaled Cholesky with a tiny
    /// ridge; SVD pseudo-inverse if that fails).
    pub fn solve(&self, idx: &[usize]) -> Vec<f64> {
        let k = idx.len();
        if k == 0 {
            return vec![];
        }
        let s: Vec<f64> = idx
            .iter()
            .map(|&i| 1.0 / self.g[(i, i)].max(1e-300).sqrt())
            .collect();
        let mut a = DMatrix::zeros(k, k);
        let mut r = DVector::zeros(k);
        for (p, &i) in idx.iter().enumerate() {
            r[p] = self.ab[i] * s[p];
            for (q, &j) in idx.iter().enumerate() {
                a[(p, q)] = self.g[(i, j)] * s[p] * s[q];
            }
            a[(p, p)] += 1e-12;
        }
        // (nalgebra's SVD does not return on non-finite input.)
        if !(a.iter().all(|v| v.is_finite()) && r.iter().all(|v| v.is_finite())) {
            return vec![f64::NAN; k];
        }
        let x = match a.clone().cholesky() {
            Some(c) => c.solve(&r),
            None => a
                .svd(true, true)
                .solve(&r, 1e-12)
                .unwrap_or_else(|_| DVector::zeros(k)),
        };
        x.iter().zip(&s).map(|(v, sc)| v * sc).collect()
    }

    /// Residual sum of squares of coefficients `x` on columns `idx`.
    pub fn rss(&self, idx: &[usize], x: &[f64]) -> f64 {
        let mut v = self.bb;
        for (p, &i) in idx.iter().enumerate() {
            v -= 2.0 * x[p] * self.ab[i];
            for (q, &j) in idx.iter().enumerate() {
                v += x[p] * x[q] * self.g[(i, j)];
            }
        }
        v.max(0.0)
    }

    /// Inverse of the Gram block on `idx` (for covariances).
    pub fn inverse(&self, idx: &[usize]) -> DMatrix<f64> {
        let k = idx.len();
        let a = DMatrix::from_fn(k, k, |p, q| self.g[(idx[p], idx[q])]);
        if !a.iter().all(|v| v.is_finite()) {
            return DMatrix::from_element(k, k, f64::NAN);
        }
        a.clone()
            .try_inverse()
            .unwrap_or_else(|| a.pseudo_inverse(1e-14).unwrap_or_else(|_| DMatrix::zeros(k, k)))
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// ln Γ(x) (Lanczos, g = 7).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (k, c) in C.iter().enumerate().skip(1) {
        a += c / (x + k as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Upper regularised incomplete gamma Q(a, x) (series or continued fraction).
fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let lg = ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut del, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..500 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - lg).exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..500 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        (-x + a * x.ln() - lg).exp() * h
    }
}

/// P(χ²_k > x).
pub fn chi2_sf(x: f64, k: usize) -> f64 {
    gamma_q(k as f64 / 2.0, x / 2.0).clamp(0.0, 1.0)
}

/// Ljung–Box portmanteau test of whiteness: Q = n(n+2)·Σ_(k=1..L) r_k²/(n−k) from the
/// normalised autocorrelations `r` = (r_1..r_L) of a series of `n` samples; under the
/// hypothesis that the series is white, Q is χ² with L degrees of freedom (no parameter was
/// fitted to the series, e.g. a held-out residual). Returns (Q, P(χ²_L > Q)); (0, 1) for an
/// empty `r` or n ≤ L.
pub fn ljung_box(r: &[f64], n: usize) -> (f64, f64) {
    let l = r.len();
    if l == 0 || n <= l {
        return (0.0, 1.0);
    }
    let nf = n as f64;
    let q = nf
        * (nf + 2.0)
        * r.iter()
            .enumerate()
            .map(|(k, rk)| rk * rk / (nf - (k + 1) as f64))
            .sum::<f64>();
    (q, chi2_sf(q, l))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_tail_matches_tables() {
        assert!((chi2_sf(3.841, 1) - 0.05).abs() < 1e-3);
        assert!((chi2_sf(10.828, 1) - 0.001).abs() < 1e-4);
        assert!((chi2_sf(5.991, 2) - 0.05).abs() < 1e-3);
        assert!((chi2_sf(1.0, 3) - 0.8013).abs() < 1e-3);
    }

    #[test]
    fn ljung_box_of_zero_autocorrelation_is_not_significant_and_of_a_large_one_is() {
        assert_eq!(ljung_box(&[0.0; 10], 1000), (0.0, 1.0));
        let (q, p) = ljung_box(&[0.5; 10], 1000);
        // 1000·1002·Σ 0.25/(1000−k) ≈ 2518.9 on 10 degrees of freedom.
        assert!((q - 2518.9).abs() < 0.1 && p < 1e-100, "{q} {p}");
        // r = 0.03 at 10 lags of 1000 samples: Q ≈ 9.0, p ≈ 0.53.
        let (q, p) = ljung_box(&[0.03; 10], 1000);
        assert!((q - 9.06).abs() < 0.05 && (p - 0.53).abs() < 0.02, "{q} {p}");
    }

    #[test]
    fn gram_fit_recovers_coefficients_and_folds_subtract() {
        let x: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        let c0: Vec<f64> = x.iter().map(|v| v.sin()).collect();
        let c1: Vec<f64> = x.iter().map(|v| v.cos()).collect();
        let b: Vec<f64> = (0..100).map(|k| 2.0 * c0[k] - 0.5 * c1[k]).collect();
        let g = Gram::new(&[c0.clone(), c1.clone()], &b);
        let th = g.solve(&[0, 1]);
        assert!((th[0] - 2.0).abs() < 1e-9 && (th[1] + 0.5).abs() < 1e-9);
        assert!(g.rss(&[0, 1], &th) < 1e-12);
        let half = Gram::new(&[c0[..50].to_vec(), c1[..50].to_vec()], &b[..50]);
        let rest = g.minus(&half);
        assert_eq!(rest.n, 50);
        let th = rest.solve(&[0]);
        assert!(th[0].is_finite());
    }
}
