//! Dense output, the output-time driver, stop times, event location and restarts.

use super::BdfSolver;
use crate::dae::error::DaeError;
use crate::dae::problem::DaeSystem;

/// Why [`BdfSolver::solve_to`] returned.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// The requested output time was reached.
    Reached,
    /// The stop time was reached (it lay before the requested output time).
    StopTime,
    /// Event functions changed sign; the solution is returned at the located root.
    Event {
        /// Indices of the event functions that changed sign there.
        indices: Vec<usize>,
    },
}

/// Root-finding state of the event functions.
#[derive(Debug, Clone)]
pub(crate) struct EventState {
    n: usize,
    /// Left end of the interval still to be searched, and g there.
    tlo: f64,
    glo: Vec<f64>,
    /// g at the current internal time `tn`.
    ghi: Vec<f64>,
    pending: Option<(f64, Vec<usize>)>,
}

impl EventState {
    pub(crate) fn new(n: usize) -> Self {
        Self {
            n,
            tlo: 0.0,
            glo: vec![0.0; n],
            ghi: vec![0.0; n],
            pending: None,
        }
    }
}

impl<P: DaeSystem> BdfSolver<P> {
    /// Interpolates the solution and its derivative at `t` from the history (IDAGetSolution).
    /// Valid for t within the last step, [tn − h_used, tn].
    pub(crate) fn interpolate_into(&self, t: f64, y: &mut [f64], yp: &mut [f64]) {
        if self.nst_local == 0 {
            y.copy_from_slice(&self.phi[0]);
            yp.copy_from_slice(&self.yp);
            return;
        }
        let delt = t - self.tn;
        let mut c = 1.0;
        let mut d = 0.0;
        let mut gam = delt / self.psi[0];
        y.copy_from_slice(&self.phi[0]);
        yp.iter_mut().for_each(|v| *v = 0.0);
        let kord = self.kused.max(1);
        for j in 1..=kord {
            d = d * gam + c / self.psi[j - 1];
            c *= gam;
            gam = (delt + self.psi[j - 1]) / self.psi[j];
            for ((a, b), ph) in y.iter_mut().zip(yp.iter_mut()).zip(&self.phi[j]) {
                *a += c * ph;
                *b += d * ph;
            }
        }
    }

    /// Solution and derivative at `t` by dense output within the last internal step
    /// [t_n − h_used, t_n].
    pub fn dense_output(&self, t: f64) -> Result<(Vec<f64>, Vec<f64>), DaeError> {
        let lo = self.tn - self.hused;
        let hi = self.tn;
        let (a, b) = if lo <= hi { (lo, hi) } else { (hi, lo) };
        let fuzz = 100.0 * f64::EPSILON * (self.tn.abs() + self.hused.abs());
        if !(t >= a - fuzz && t <= b + fuzz) {
            return Err(DaeError::OutOfRange { t, lo: a, hi: b });
        }
        let mut y = vec![0.0; self.n];
        let mut yp = vec![0.0; self.n];
        self.interpolate_into(t, &mut y, &mut yp);
        Ok((y, yp))
    }

    fn set_return(&mut self, t: f64) {
        let mut y = std::mem::take(&mut self.yret);
        let mut yp = std::mem::take(&mut self.ypret);
        if t == self.tn {
            y.copy_from_slice(&self.yy);
            yp.copy_from_slice(&self.yp);
        } else {
            self.interpolate_into(t, &mut y, &mut yp);
        }
        self.yret = y;
        self.ypret = yp;
        self.tret = t;
    }

    /// First call: initial step, step-size floor, consistency check, events at t0.
    fn start(&mut self, tout: f64) -> Result<(), DaeError> {
        let t0 = self.tn;
        let tdist = (tout - t0).abs();
        if tdist == 0.0 {
            return Err(DaeError::InvalidInput(format!(
                "t_out = {tout:e} equals the initial time"
            )));
        }
        let dir = (tout - t0).signum();
        self.h_min = self.opts.h_min.unwrap_or(0.0);
        self.yy.copy_from_slice(&self.phi[0]);
        self.yp.copy_from_slice(&self.phi[1]);
        let y0 = self.yy.clone();
        self.update_weights_from(&y0);
        let mut h = match self.opts.h_init {
            Some(h) => h.abs() * dir,
            None => {
                let mut h = 0.001 * tdist;
                let ypnorm = Self::wrms(&self.yp, &self.ewt_err);
                if ypnorm > 0.5 / h {
                    h = 0.5 / ypnorm;
                }
                h * dir
            }
        };
        if h.abs() > self.opts.h_max {
            h = self.opts.h_max * dir;
        }
        if let Some(ts) = self.opts.stop_time {
            if (ts - t0) * dir < 0.0 {
                return Err(DaeError::InvalidInput(format!(
                    "stop time {ts:e} lies behind the initial time {t0:e}"
                )));
            }
            if (t0 + h - ts) * dir > 0.0 {
                h = ts - t0;
            }
        }
        self.hh = h;
        self.check_consistency()?;
        for v in self.phi[1].iter_mut() {
            *v *= h;
        }
        self.nst_local = 0;
        self.started = true;
        if self.events.n > 0 {
            let (y, yp) = (self.yy.clone(), self.yp.clone());
            self.sys.events(t0, &y, &yp, &self.p, &mut self.events.glo);
            self.stats.event_evals += 1;
            self.events.tlo = t0;
            self.events.pending = None;
        }
        Ok(())
    }

    /// Integrates until `tout`, the stop time, or an event, whichever comes first, and returns
    /// the solution there ([`t`](Self::t), [`y`](Self::y), [`yp`](Self::yp)).
    pub fn solve_to(&mut self, tout: f64) -> Result<Outcome, DaeError> {
        if !tout.is_finite() {
            return Err(DaeError::InvalidInput(format!("t_out = {tout} is not finite")));
        }
        if !self.started {
            self.start(tout)?;
        }
        let dir = self.hh.signum();
        if (tout - self.tret) * dir < 0.0 {
            // Backwards within the last step is allowed (dense output); further is not.
            let (y, yp) = self.dense_output(tout)?;
            self.yret = y;
            self.ypret = yp;
            self.tret = tout;
            return Ok(Outcome::Reached);
        }
        let mut nsteps = 0usize;
        loop {
            if let Some((tr, idx)) = self.events.pending.clone() {
                if (tr - tout) * dir <= 0.0 {
                    self.events.pending = None;
                    self.set_return(tr);
                    self.events.tlo = tr;
                    let (y, yp) = (self.yret.clone(), self.ypret.clone());
                    self.sys.events(tr, &y, &yp, &self.p, &mut self.events.glo);
                    self.stats.event_evals += 1;
                    self.search_roots();
                    return Ok(Outcome::Event { indices: idx });
                }
            }
            if self.nst_local > 0 && (self.tn - tout) * dir >= 0.0 {
                self.set_return(tout);
                return Ok(Outcome::Reached);
            }
            if let Some(ts) = self.opts.stop_time {
                if self.nst_local > 0 && self.tn == ts {
                    self.set_return(ts);
                    return Ok(Outcome::StopTime);
                }
                if (self.tn + self.hh - ts) * dir > 0.0 {
                    self.hh = ts - self.tn;
                }
            }
            if nsteps >= self.opts.max_steps {
                self.set_return(self.tn);
                return Err(DaeError::TooManySteps {
                    t: self.tn,
                    h: self.hh,
                    max_steps: self.opts.max_steps,
                    t_out: tout,
                });
            }
            self.take_step()?;
            nsteps += 1;
            if self.events.n > 0 {
                let (y, yp) = (self.yy.clone(), self.yp.clone());
                self.sys.events(self.tn, &y, &yp, &self.p, &mut self.events.ghi);
                self.stats.event_evals += 1;
                self.search_roots();
            }
        }
    }

    /// Takes one internal step (or returns a pending event) and returns the solution at the
    /// time reached: the one-step mode, for progress reporting and custom drivers.
    pub fn step(&mut self, tout: f64) -> Result<Outcome, DaeError> {
        if !self.started {
            self.start(tout)?;
        }
        let saved = self.opts.max_steps;
        self.opts.max_steps = 1;
        let r = self.solve_to(tout);
        self.opts.max_steps = saved;
        match r {
            Err(DaeError::TooManySteps { .. }) => Ok(Outcome::Reached),
            other => other,
        }
    }

    /// Looks for sign changes of the event functions in (tlo, tn]; records the earliest root.
    fn search_roots(&mut self) {
        let ev = &self.events;
        let changed: Vec<usize> = (0..ev.n)
            .filter(|&i| {
                let (a, b) = (ev.glo[i], ev.ghi[i]);
                a != 0.0 && (b == 0.0 || (a > 0.0) != (b > 0.0))
            })
            .collect();
        if changed.is_empty() || self.events.tlo == self.tn {
            self.events.tlo = self.tn;
            self.events.glo.copy_from_slice(&self.events.ghi.clone());
            return;
        }
        let ttol = 100.0 * f64::EPSILON * (self.tn.abs() + self.hh.abs());
        let mut best: Option<(f64, Vec<usize>)> = None;
        let dir = self.hh.signum();
        let mut g = vec![0.0; self.events.n];
        let mut y = vec![0.0; self.n];
        let mut yp = vec![0.0; self.n];
        for &i in &changed {
            let (mut lo, mut flo) = (self.events.tlo, self.events.glo[i]);
            let (mut hi, mut fhi) = (self.tn, self.events.ghi[i]);
            let mut side = 0i8;
            for _ in 0..200 {
                if (hi - lo).abs() <= ttol || fhi == 0.0 {
                    break;
                }
                let mut c = hi - fhi * (hi - lo) / (fhi - flo);
                let span = hi - lo;
                if !c.is_finite() || (c - lo) * dir <= 0.1 * ttol || (hi - c) * dir <= 0.1 * ttol {
                    c = lo + 0.5 * span;
                }
                self.interpolate_into(c, &mut y, &mut yp);
                self.sys.events(c, &y, &yp, &self.p, &mut g);
                self.stats.event_evals += 1;
                let fc = g[i];
                if fc == 0.0 {
                    hi = c;
                    break;
                }
                if (fc > 0.0) == (flo > 0.0) {
                    lo = c;
                    flo = fc;
                    if side == -1 {
                        fhi *= 0.5;
                    }
                    side = -1;
                } else {
                    hi = c;
                    fhi = fc;
                    if side == 1 {
                        flo *= 0.5;
                    }
                    side = 1;
                }
            }
            best = match best {
                None => Some((hi, vec![i])),
                Some((tb, mut v)) => {
                    if (hi - tb).abs() <= ttol {
                        v.push(i);
                        Some((if (hi - tb) * dir < 0.0 { hi } else { tb }, v))
                    } else if (hi - tb) * dir < 0.0 {
                        Some((hi, vec![i]))
                    } else {
                        Some((tb, v))
                    }
                }
            };
        }
        self.events.pending = best;
        if self.events.pending.is_none() {
            self.events.tlo = self.tn;
            self.events.glo.copy_from_slice(&self.events.ghi.clone());
        }
    }

    /// Restarts the integration at order 1 from (t, y, y'): call after a discontinuity (an
    /// impact, a switched input) so no history is carried across it. Statistics are kept.
    pub fn restart_from(&mut self, t: f64, y: &[f64], yp: &[f64]) -> Result<(), DaeError> {
        if y.len() != self.n || yp.len() != self.n {
            return Err(DaeError::InvalidInput(format!(
                "restart state has lengths {} and {}, expected {}",
                y.len(),
                yp.len(),
                self.n
            )));
        }
        if !t.is_finite() || y.iter().chain(yp).any(|v| !v.is_finite()) {
            return Err(DaeError::InvalidInput("restart state is not finite".into()));
        }
        self.tn = t;
        self.tret = t;
        self.phi[0].copy_from_slice(y);
        self.phi[1].copy_from_slice(yp);
        self.yy.copy_from_slice(y);
        self.yp.copy_from_slice(yp);
        self.yret.copy_from_slice(y);
        self.ypret.copy_from_slice(yp);
        self.nst_local = 0;
        self.started = false;
        self.force_setup = true;
        // No step ceiling carried across the discontinuity either.
        self.h_ceiling = f64::INFINITY;
        self.events.pending = None;
        Ok(())
    }

    /// Restarts at order 1 from the solution last returned (see [`restart_from`](Self::restart_from)).
    pub fn restart(&mut self) -> Result<(), DaeError> {
        let (t, y, yp) = (self.tret, self.yret.clone(), self.ypret.clone());
        self.restart_from(t, &y, &yp)
    }
}
