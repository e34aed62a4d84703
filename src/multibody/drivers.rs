//! Drivers: joint coordinates prescribed as functions of time (motion laws).

use std::fmt;
use std::sync::Arc;

/// Shape of a rest-to-rest motion (zero velocity at both ends).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Profile {
    /// s(τ) = 10τ³ − 15τ⁴ + 6τ⁵: zero velocity and acceleration at both ends.
    Quintic,
    /// s(τ) = τ − sin(2πτ)/(2π): zero velocity and acceleration at both ends.
    Cycloidal,
}

/// A prescribed coordinate x(t) with its first two derivatives (units of the coordinate:
/// rad for rotations, m for translations; t in s).
#[derive(Clone)]
pub enum MotionLaw {
    /// Constant value.
    Constant(f64),
    /// Σ c_k·t^k.
    Polynomial {
        /// Coefficients c_0, c_1, …
        coeffs: Vec<f64>,
    },
    /// From `from` at `t0` to `to` at `t1`, at rest before, at and after.
    RestToRest {
        /// Start time, s.
        t0: f64,
        /// End time, s.
        t1: f64,
        /// Value before t0.
        from: f64,
        /// Value after t1.
        to: f64,
        /// Shape.
        profile: Profile,
    },
    /// The sum of several laws (e.g. consecutive rest-to-rest legs).
    Sum(Vec<MotionLaw>),
    /// A sampled time series, interpolated by a natural cubic spline (constant outside).
    Sampled(Arc<Spline>),
    /// Any function t ↦ (x, ẋ, ẍ).
    Custom(Arc<dyn Fn(f64) -> [f64; 3] + Send + Sync>),
}

impl fmt::Debug for MotionLaw {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MotionLaw::Constant(c) => write!(f, "Constant({c})"),
            MotionLaw::Polynomial { coeffs } => write!(f, "Polynomial({coeffs:?})"),
            MotionLaw::RestToRest {
                t0,
                t1,
                from,
                to,
                profile,
            } => {
                write!(f, "RestToRest({from} at {t0} s → {to} at {t1} s, {profile:?})")
            }
            MotionLaw::Sum(v) => write!(f, "Sum({v:?})"),
            MotionLaw::Sampled(s) => write!(f, "Sampled({} points)", s.t.len()),
            MotionLaw::Custom(_) => write!(f, "Custom(..)"),
        }
    }
}

impl MotionLaw {
    /// A sampled law from times (strictly increasing) and values.
    pub fn sampled(times: Vec<f64>, values: Vec<f64>) -> Result<Self, String> {
        Spline::natural(times, values).map(|s| MotionLaw::Sampled(Arc::new(s)))
    }

    /// (x, ẋ, ẍ) at t.
    pub fn eval(&self, t: f64) -> [f64; 3] {
        match self {
            MotionLaw::Constant(c) => [*c, 0.0, 0.0],
            MotionLaw::Polynomial { coeffs } => {
                let (mut x, mut v, mut a) = (0.0, 0.0, 0.0);
                let mut tk = 1.0; // t^k
                for (k, c) in coeffs.iter().enumerate() {
                    x += c * tk;
                    if k >= 1 {
                        v += k as f64 * c * t.powi(k as i32 - 1);
                    }
                    if k >= 2 {
                        a += (k * (k - 1)) as f64 * c * t.powi(k as i32 - 2);
                    }
                    tk *= t;
                }
                [x, v, a]
            }
            MotionLaw::RestToRest {
                t0,
                t1,
                from,
                to,
                profile,
            } => {
                let span = t1 - t0;
                if t <= *t0 || span <= 0.0 {
                    return [if t <= *t0 { *from } else { *to }, 0.0, 0.0];
                }
                if t >= *t1 {
                    return [*to, 0.0, 0.0];
                }
                let tau = (t - t0) / span;
                let (s, ds, dds) = match profile {
                    Profile::Quintic => (
                        tau.powi(3) * (10.0 - 15.0 * tau + 6.0 * tau * tau),
                        30.0 * tau * tau * (1.0 - tau).powi(2),
                        60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau),
                    ),
                    Profile::Cycloidal => {
                        let w = 2.0 * std::f64::consts::PI;
                        (
                            tau - (w * tau).sin() / w,
                            1.0 - (w * tau).cos(),
                            w * (w * tau).sin(),
                        )
                    }
                };
                let d = to - from;
                [from + d * s, d * ds / span, d * dds / (span * span)]
            }
            MotionLaw::Sum(v) => v
                .iter()
                .map(|l| l.eval(t))
                .fold([0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]),
            MotionLaw::Sampled(s) => s.eval(t),
            MotionLaw::Custom(f) => f(t),
        }
    }

    /// x(t).
    pub fn value(&self, t: f64) -> f64 {
        self.eval(t)[0]
    }
    /// ẋ(t).
    pub fn rate(&self, t: f64) -> f64 {
        self.eval(t)[1]
    }
}

/// A natural cubic spline through (t_k, x_k), held constant outside [t_0, t_n]. At t_0 itself
/// it has the first interval's rate and acceleration (a motion that starts at t_0 starts
/// consistently with the spline that follows).
#[derive(Debug, Clone)]
pub struct Spline {
    t: Vec<f64>,
    x: Vec<f64>,
    /// Second derivatives at the knots.
    m: Vec<f64>,
}

impl Spline {
    /// Builds the spline; times must be strictly increasing, at least two points, finite.
    pub fn natural(t: Vec<f64>, x: Vec<f64>) -> Result<Self, String> {
        let n = t.len();
        if n < 2 || x.len() != n {
            return Err(format!(
                "need at least two samples and as many values as times ({} times, {} values)",
                n,
                x.len()
            ));
        }
        if let Some(k) = (1..n).find(|&k| t[k] <= t[k - 1] || !t[k].is_finite()) {
            return Err(format!(
                "sample times must increase strictly: t[{}] = {} after t[{}] = {}",
                k,
                t[k],
                k - 1,
                t[k - 1]
            ));
        }
        if let Some(k) = x.iter().position(|v| !v.is_finite()) {
            return Err(format!("sample value {k} is not finite"));
        }
        // Tridiagonal system for the interior second derivatives (Thomas algorithm).
        let mut m = vec![0.0; n];
        if n > 2 {
            let mut c = vec![0.0; n];
            let mut d = vec![0.0; n];
            for i in 1..n - 1 {
                let h0 = t[i] - t[i - 1];
                let h1 = t[i + 1] - t[i];
                let rhs = 6.0 * ((x[i + 1] - x[i]) / h1 - (x[i] - x[i - 1]) / h0);
                let diag = 2.0 * (h0 + h1) - h0 * c[i - 1];
                c[i] = h1 / diag;
                d[i] = (rhs - h0 * d[i - 1]) / diag;
            }
            for i in (1..n - 1).rev() {
                m[i] = d[i] - c[i] * m[i + 1];
            }
        }
        Ok(Self { t, x, m })
    }

    /// (x, ẋ, ẍ) at `s`.
    pub fn eval(&self, s: f64) -> [f64; 3] {
        let n = self.t.len();
        if s < self.t[0] {
            return [self.x[0], 0.0, 0.0];
        }
        if s >= self.t[n - 1] {
            return [self.x[n - 1], 0.0, 0.0];
        }
        let k = self.t.partition_point(|&v| v <= s).clamp(1, n - 1) - 1;
        let h = self.t[k + 1] - self.t[k];
        let a = (self.t[k + 1] - s) / h;
        let b = (s - self.t[k]) / h;
        let (m0, m1) = (self.m[k], self.m[k + 1]);
        let x =
            a * self.x[k] + b * self.x[k + 1] + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
        let v = (self.x[k + 1] - self.x[k]) / h - (3.0 * a * a - 1.0) * h * m0 / 6.0
            + (3.0 * b * b - 1.0) * h * m1 / 6.0;
        let acc = a * m0 + b * m1;
        [x, v, acc]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_derivatives(l: &MotionLaw, ts: &[f64]) {
        let e = 1e-6;
        for &t in ts {
            let [_, v, a] = l.eval(t);
            let fd_v = (l.value(t + e) - l.value(t - e)) / (2.0 * e);
            let fd_a = (l.rate(t + e) - l.rate(t - e)) / (2.0 * e);
            assert!((fd_v - v).abs() < 1e-6 * (1.0 + v.abs()), "{l:?} v at {t}");
            assert!((fd_a - a).abs() < 1e-5 * (1.0 + a.abs()), "{l:?} a at {t}");
        }
    }

    #[test]
    fn laws_have_consistent_derivatives_and_rest_at_the_ends() {
        for profile in [Profile::Quintic, Profile::Cycloidal] {
            let l = MotionLaw::RestToRest {
                t0: 1.0,
                t1: 3.0,
                from: 0.5,
                to: -1.0,
                profile,
            };
            check_derivatives(&l, &[1.3, 2.0, 2.9]);
            assert_eq!(l.eval(1.0), [0.5, 0.0, 0.0]);
            let end = l.eval(3.0 - 1e-12);
            assert!((end[0] + 1.0).abs() < 1e-9 && end[1].abs() < 1e-9);
        }
        check_derivatives(
            &MotionLaw::Polynomial {
                coeffs: vec![1.0, -2.0, 0.5, 0.25],
            },
            &[0.0, 0.7, 2.0],
        );
        let legs = MotionLaw::Sum(vec![
            MotionLaw::RestToRest {
                t0: 0.0,
                t1: 2.0,
                from: 1.0,
                to: 2.0,
                profile: Profile::Quintic,
            },
            MotionLaw::RestToRest {
                t0: 2.0,
                t1: 4.0,
                from: 0.0,
                to: -0.5,
                profile: Profile::Quintic,
            },
        ]);
        assert!((legs.value(2.0) - 2.0).abs() < 1e-15 && (legs.value(4.0) - 1.5).abs() < 1e-15);
    }

    #[test]
    fn spline_interpolates_smooth_data_accurately() {
        let t: Vec<f64> = (0..=200).map(|k| k as f64 * 0.01).collect();
        let x: Vec<f64> = t.iter().map(|v| v.sin()).collect();
        let l = MotionLaw::sampled(t, x).unwrap();
        for s in [0.333, 1.0, 1.777] {
            let [x, v, a] = l.eval(s);
            assert!((x - s.sin()).abs() < 1e-9, "x");
            assert!((v - s.cos()).abs() < 1e-5, "v");
            assert!((a + s.sin()).abs() < 1e-3, "a");
        }
        assert!(MotionLaw::sampled(vec![0.0, 1.0, 1.0], vec![0.0; 3]).is_err());
        assert!(MotionLaw::sampled(vec![0.0], vec![0.0]).is_err());
    }
}
