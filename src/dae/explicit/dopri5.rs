//! Dormand–Prince 5(4) (Hairer, Nørsett & Wanner I, sec. II.5), adaptive, FSAL.

use super::{ExplicitError, ExplicitStats, OdeSystem};
use crate::dae::problem::EvalError;

/// Options of [`Dopri5`].
#[derive(Debug, Clone, PartialEq)]
pub struct Dopri5Options {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance.
    pub atol: f64,
    /// Initial step (`None`: Hairer's starting-step heuristic).
    pub h_init: Option<f64>,
    /// Largest step size.
    pub h_max: f64,
    /// Maximum number of steps (accepted + rejected).
    pub max_steps: usize,
}

impl Default for Dopri5Options {
    fn default() -> Self {
        Self {
            rtol: 1e-6,
            atol: 1e-6,
            h_init: None,
            h_max: f64::INFINITY,
            max_steps: 10_000_000,
        }
    }
}

const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

/// Adaptive Dormand–Prince 5(4) integrator state.
#[derive(Debug)]
pub struct Dopri5<S: OdeSystem> {
    sys: S,
    p: Vec<f64>,
    opts: Dopri5Options,
    t: f64,
    y: Vec<f64>,
    h: f64,
    k: Vec<Vec<f64>>,
    fsal_valid: bool,
    err_old: f64,
    stats: ExplicitStats,
}

fn eval_err(t: f64, e: EvalError) -> ExplicitError {
    match e {
        EvalError::Recoverable(m) | EvalError::Fatal(m) => ExplicitError::Evaluation { t, message: m },
    }
}

impl<S: OdeSystem> Dopri5<S> {
    /// Creates the integrator at (t0, y0) with parameters `p`.
    pub fn new(sys: S, t0: f64, y0: &[f64], p: &[f64], opts: Dopri5Options) -> Result<Self, ExplicitError> {
        let n = sys.dim();
        if y0.len() != n {
            return Err(ExplicitError::InvalidInput(format!(
                "y0 has length {}, expected {n}",
                y0.len()
            )));
        }
        if !(opts.rtol > 0.0 && opts.atol > 0.0) {
            return Err(ExplicitError::InvalidInput(format!(
                "tolerances must be positive (rtol = {}, atol = {})",
                opts.rtol, opts.atol
            )));
        }
        Ok(Self {
            sys,
            p: p.to_vec(),
            opts,
            t: t0,
            y: y0.to_vec(),
            h: 0.0,
            k: vec![vec![0.0; n]; 7],
            fsal_valid: false,
            err_old: 1e-4,
            stats: ExplicitStats::default(),
        })
    }

    /// Current time.
    pub fn t(&self) -> f64 {
        self.t
    }
    /// Current solution.
    pub fn y(&self) -> &[f64] {
        &self.y
    }
    /// Work counters.
    pub fn stats(&self) -> &ExplicitStats {
        &self.stats
    }

    fn weight(&self, i: usize, ynew: f64) -> f64 {
        self.opts.atol + self.opts.rtol * self.y[i].abs().max(ynew.abs())
    }

    fn initial_step(&mut self, dir: f64) -> Result<f64, ExplicitError> {
        // Hairer's heuristic (HNW I, II.4).
        let n = self.y.len();
        let f0 = self.k[0].clone();
        let sc: Vec<f64> = (0..n)
            .map(|i| self.opts.atol + self.opts.rtol * self.y[i].abs())
            .collect();
        let d0 = (self.y.iter().zip(&sc).map(|(a, s)| (a / s).powi(2)).sum::<f64>() / n as f64).sqrt();
        let d1 = (f0.iter().zip(&sc).map(|(a, s)| (a / s).powi(2)).sum::<f64>() / n as f64).sqrt();
        let h0 = if d0 < 1e-5 || d1 < 1e-5 {
            1e-6
        } else {
            0.01 * d0 / d1
        };
        let y1: Vec<f64> = (0..n).map(|i| self.y[i] + dir * h0 * f0[i]).collect();
        let mut f1 = vec![0.0; n];
        self.sys
            .rhs(self.t + dir * h0, &y1, &self.p, &mut f1)
            .map_err(|e| eval_err(self.t, e))?;
        self.stats.rhs_evals += 1;
        let d2 = ((0..n).map(|i| ((f1[i] - f0[i]) / sc[i]).powi(2)).sum::<f64>() / n as f64).sqrt() / h0;
        let h1 = if d1.max(d2) <= 1e-15 {
            (h0 * 1e-3).max(1e-6)
        } else {
            (0.01 / d1.max(d2)).powf(0.2)
        };
        Ok((100.0 * h0).min(h1).min(self.opts.h_max) * dir)
    }

    /// Integrates to `t_end`, landing on it exactly.
    pub fn solve_to(&mut self, t_end: f64) -> Result<(), ExplicitError> {
        let n = self.y.len();
        let dir = if t_end >= self.t { 1.0 } else { -1.0 };
        if !self.fsal_valid {
            let mut k0 = std::mem::take(&mut self.k[0]);
            self.sys
                .rhs(self.t, &self.y, &self.p, &mut k0)
                .map_err(|e| eval_err(self.t, e))?;
            self.k[0] = k0;
            self.stats.rhs_evals += 1;
            self.fsal_valid = true;
        }
        if self.h == 0.0 {
            self.h = match self.opts.h_init {
                Some(h) => h.abs() * dir,
                None => self.initial_step(dir)?,
            };
        }
        let mut ytmp = vec![0.0; n];
        let mut ynew = vec![0.0; n];
        let (beta, expo) = (0.04, 0.2 - 0.04 * 0.75);
        let mut last = false;
        while (t_end - self.t) * dir > 0.0 {
            if self.stats.steps + self.stats.rejected >= self.opts.max_steps {
                return Err(ExplicitError::TooManySteps {
                    t: self.t,
                    h: self.h,
                    max_steps: self.opts.max_steps,
                });
            }
            let mut h = self.h;
            if (self.t + h - t_end) * dir >= 0.0 {
                h = t_end - self.t;
                last = true;
            }
            if h.abs() < 16.0 * f64::EPSILON * self.t.abs().max(1e-300) {
                return Err(ExplicitError::StepTooSmall { t: self.t, h });
            }
            let mut recoverable = false;
            for s in 1..7 {
                for i in 0..n {
                    let mut acc = self.y[i];
                    for j in 0..s {
                        acc += h * A[s][j] * self.k[j][i];
                    }
                    ytmp[i] = acc;
                }
                let mut ks = std::mem::take(&mut self.k[s]);
                let r = self.sys.rhs(self.t + C[s] * h, &ytmp, &self.p, &mut ks);
                self.k[s] = ks;
                self.stats.rhs_evals += 1;
                match r {
                    Ok(()) => {}
                    // A stage outside the model's domain: reject the step and retry smaller.
                    Err(EvalError::Recoverable(_)) => {
                        recoverable = true;
                        break;
                    }
                    Err(e) => return Err(eval_err(self.t + C[s] * h, e)),
                }
                if s == 6 {
                    ynew.copy_from_slice(&ytmp);
                }
            }
            if recoverable {
                self.stats.rejected += 1;
                self.h = h * 0.25;
                last = false;
                continue;
            }
            let mut err = 0.0;
            for i in 0..n {
                let mut e = 0.0;
                for (j, ej) in E.iter().enumerate() {
                    e += ej * self.k[j][i];
                }
                err += (h * e / self.weight(i, ynew[i])).powi(2);
            }
            let err = (err / n as f64).sqrt();
            if !err.is_finite() {
                self.stats.rejected += 1;
                self.h = h * 0.2;
                last = false;
                continue;
            }
            if err <= 1.0 {
                let fac = (err.max(1e-10).powf(expo) / self.err_old.powf(beta)) / 0.9;
                let fac = fac.clamp(1.0 / 10.0, 1.0 / 0.2);
                self.err_old = err.max(1e-4);
                self.t = if last { t_end } else { self.t + h };
                std::mem::swap(&mut self.y, &mut ynew);
                self.k.swap(0, 6);
                self.stats.steps += 1;
                if let Some(i) = self.y.iter().position(|v| !v.is_finite()) {
                    return Err(ExplicitError::NonFinite { t: self.t, index: i });
                }
                let hn = h / fac;
                self.h = if hn.abs() > self.opts.h_max {
                    self.opts.h_max * dir
                } else {
                    hn
                };
                if last {
                    // Keep the controller's proposal rather than the shortened final step.
                    self.h = self.h.abs().max(h.abs()) * dir;
                }
            } else {
                let fac = (err.powf(expo) / 0.9).min(1.0 / 0.2);
                self.h = h / fac;
                self.stats.rejected += 1;
                last = false;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Osc;
    impl OdeSystem for Osc {
        fn dim(&self) -> usize {
            2
        }
        fn rhs(&mut self, _t: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) -> Result<(), EvalError> {
            dy[0] = y[1];
            dy[1] = -y[0];
            Ok(())
        }
    }

    #[test]
    fn harmonic_oscillator_is_accurate_and_converges() {
        let mut errs = vec![];
        for tol in [1e-6, 1e-9] {
            let mut s = Dopri5::new(
                Osc,
                0.0,
                &[1.0, 0.0],
                &[],
                Dopri5Options {
                    rtol: tol,
                    atol: tol,
                    ..Default::default()
                },
            )
            .unwrap();
            s.solve_to(10.0).unwrap();
            assert_eq!(s.t(), 10.0);
            errs.push((s.y()[0] - 10f64.cos()).abs());
        }
        assert!(errs[0] < 1e-4 && errs[1] < 1e-7, "{errs:?}");
        assert!(errs[1] < errs[0] / 100.0);
    }
}
