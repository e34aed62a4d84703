//! The linear-solver interface: the iteration matrix J = dF/dy + α·dF/dy', evaluated
//! analytically or by coloured finite differences, and factorised with the sparse LU.

use crate::dae::options::{timed, PhaseTimes};
use crate::dae::problem::{DaeSystem, EvalError, JacobianSource};
use crate::sparse::{column_colouring, CscPattern, LinearSolveError, SparseLu};

/// Iteration matrix, its factorisation, and the finite-difference machinery.
#[derive(Debug)]
pub(crate) struct IterationMatrix {
    pub(crate) pattern: CscPattern,
    pub(crate) values: Vec<f64>,
    lu: SparseLu,
    source: JacobianSource,
    /// Colour of each column and the columns of each colour (finite differences only).
    groups: Vec<Vec<usize>>,
    /// α used at the last factorisation.
    pub(crate) alpha: f64,
    y_work: Vec<f64>,
    yp_work: Vec<f64>,
    r_work: Vec<f64>,
    inc: Vec<f64>,
}

/// Why an iteration-matrix set-up failed.
#[derive(Debug)]
pub(crate) enum SetupError {
    Eval(EvalError),
    Linear(LinearSolveError),
}

impl IterationMatrix {
    pub(crate) fn new(pattern: CscPattern, source: JacobianSource) -> Result<Self, LinearSolveError> {
        let lu = SparseLu::new(&pattern)?;
        let n = pattern.ncols();
        let groups = if source == JacobianSource::FiniteDifference {
            let (colour, k) = column_colouring(&pattern);
            let mut g = vec![Vec::new(); k];
            for (c, &col) in colour.iter().enumerate() {
                g[col].push(c);
            }
            g
        } else {
            Vec::new()
        };
        Ok(Self {
            values: vec![0.0; pattern.nnz()],
            pattern,
            lu,
            source,
            groups,
            alpha: 0.0,
            y_work: vec![0.0; n],
            yp_work: vec![0.0; n],
            r_work: vec![0.0; n],
            inc: vec![0.0; n],
        })
    }

    /// Number of residual evaluations one finite-difference Jacobian costs (0 if analytic).
    pub(crate) fn fd_cost(&self) -> usize {
        self.groups.len()
    }

    /// Evaluates J = dF/dy + α·dF/dy' at (t, y, yp) into `self.values`.
    ///
    /// `r0` must hold F(t, y, yp) (used by finite differences); `ewt` are the error weights and
    /// `h` the step size, which scale the finite-difference increments as in IDA.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn evaluate<P: DaeSystem>(
        &mut self,
        sys: &mut P,
        t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        alpha: f64,
        r0: &[f64],
        ewt: &[f64],
        h: f64,
    ) -> Result<(), EvalError> {
        match self.source {
            JacobianSource::Analytic => {
                sys.jacobian(t, y, yp, p, alpha, &mut self.values)?;
            }
            JacobianSource::FiniteDifference => {
                let srur = f64::EPSILON.sqrt();
                self.y_work.copy_from_slice(y);
                self.yp_work.copy_from_slice(yp);
                for g in 0..self.groups.len() {
                    for &j in &self.groups[g] {
                        let mut inc = (srur * y[j].abs().max((h * yp[j]).abs())).max(1.0 / ewt[j]);
                        if h * yp[j] < 0.0 {
                            inc = -inc;
                        }
                        inc = (y[j] + inc) - y[j];
                        self.inc[j] = inc;
                        self.y_work[j] += inc;
                        self.yp_work[j] += alpha * inc;
                    }
                    sys.residual(t, &self.y_work, &self.yp_work, p, &mut self.r_work)?;
                    for &j in &self.groups[g] {
                        let inc = self.inc[j];
                        for k in self.pattern.col_range(j) {
                            let r = self.pattern.row_idx()[k];
                            self.values[k] = (self.r_work[r] - r0[r]) / inc;
                        }
                        self.y_work[j] = y[j];
                        self.yp_work[j] = yp[j];
                    }
                }
            }
        }
        self.alpha = alpha;
        Ok(())
    }

    /// Factorises the current values.
    pub(crate) fn factor(&mut self) -> Result<(), LinearSolveError> {
        self.lu.factor(&self.values)
    }

    /// Evaluates and factorises: one Newton-matrix set-up (timed into `times`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn setup<P: DaeSystem>(
        &mut self,
        sys: &mut P,
        t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        alpha: f64,
        r0: &[f64],
        ewt: &[f64],
        h: f64,
        times: &mut PhaseTimes,
    ) -> Result<(), SetupError> {
        timed(&mut times.jacobian_s, || {
            self.evaluate(sys, t, y, yp, p, alpha, r0, ewt, h)
        })
        .map_err(SetupError::Eval)?;
        timed(&mut times.factorisation_s, || self.factor()).map_err(SetupError::Linear)
    }

    /// Solves J·x = b in place.
    pub(crate) fn solve(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        self.lu.solve_in_place(b)
    }

    /// Columns whose entries are all zero in the current values (diagnostics for a singular
    /// matrix).
    pub(crate) fn zero_columns(&self) -> Vec<usize> {
        (0..self.pattern.ncols())
            .filter(|&c| self.pattern.col_range(c).all(|k| self.values[k] == 0.0))
            .collect()
    }

    /// Rows whose entries are all zero in the current values.
    pub(crate) fn zero_rows(&self) -> Vec<usize> {
        let mut nz = vec![false; self.pattern.nrows()];
        for (k, &r) in self.pattern.row_idx().iter().enumerate() {
            if self.values[k] != 0.0 {
                nz[r] = true;
            }
        }
        (0..nz.len()).filter(|&r| !nz[r]).collect()
    }
}
