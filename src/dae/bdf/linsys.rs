//! The iteration matrices and their one set-up path: evaluation (analytic or coloured finite
//! differences), assembly into the declared pattern, and factorisation through the
//! [`LinearSolver`] seam. The Newton iteration, the consistency check at the start, and the
//! initial-condition solver all build their matrices through [`BdfSolver::setup_matrix_kind`],
//! which also does the bookkeeping (work counters, phase timers, error classes) once.

use super::newton::{NlsCause, NlsFailure};
use super::BdfSolver;
use crate::dae::error::DaeError;
use crate::dae::linear_solver::{LinearSolver, LinearSolverKind};
use crate::dae::options::{timed, PhaseTimes};
use crate::dae::problem::{DaeSystem, EvalError, JacobianSource, VarKind};
use crate::sparse::{column_colouring, CscPattern, LinearSolveError};

/// Which matrix a set-up builds.
#[derive(Debug, Clone, Copy)]
pub(crate) enum MatrixKind {
    /// The Newton iteration matrix J = dF/dy + α·dF/dy'.
    Iteration {
        /// α, the leading BDF coefficient c_j.
        alpha: f64,
    },
    /// The matrix of the initial-condition Newton iteration (IDA's YA_YDP_INIT): column j
    /// is dF/dy'_j for a differential unknown (its derivative is solved for) and dF/dy_j for
    /// an algebraic one. Built from two evaluations, at α = 0 and α = 1.
    InitialCondition,
}

impl MatrixKind {
    /// Jacobian evaluations the kind costs.
    fn evaluations(self) -> usize {
        match self {
            MatrixKind::Iteration { .. } => 1,
            MatrixKind::InitialCondition => 2,
        }
    }
}

/// Iteration matrix, its factorisation, and the finite-difference machinery.
#[derive(Debug)]
pub(crate) struct IterationMatrix {
    pub(crate) pattern: CscPattern,
    pub(crate) values: Vec<f64>,
    solver: Box<dyn LinearSolver>,
    /// The solver holds factors of `values`.
    factored: bool,
    source: JacobianSource,
    /// Colour of each column and the columns of each colour (finite differences only).
    groups: Vec<Vec<usize>>,
    /// α of the factorised iteration matrix (NaN after an initial-condition matrix).
    pub(crate) alpha: f64,
    y_work: Vec<f64>,
    yp_work: Vec<f64>,
    r_work: Vec<f64>,
    inc: Vec<f64>,
    /// dF/dy of the initial-condition matrix (allocated on first use).
    j0: Vec<f64>,
}

/// Why an iteration-matrix set-up failed.
#[derive(Debug)]
pub(crate) enum SetupError {
    Eval(EvalError),
    Linear(LinearSolveError),
}

impl IterationMatrix {
    pub(crate) fn new(
        pattern: CscPattern,
        source: JacobianSource,
        solver: LinearSolverKind,
        blocks: &[Vec<usize>],
    ) -> Result<Self, LinearSolveError> {
        let solver = solver.build(&pattern, blocks)?;
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
            solver,
            factored: false,
            source,
            groups,
            alpha: 0.0,
            y_work: vec![0.0; n],
            yp_work: vec![0.0; n],
            r_work: vec![0.0; n],
            inc: vec![0.0; n],
            j0: Vec::new(),
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
        let r = self.solver.factor(&self.pattern, &self.values);
        self.factored = r.is_ok();
        r
    }

    /// How the solver reached its latest factorisation.
    pub(crate) fn last_route(&self) -> crate::sparse::FactorRoute {
        self.solver.last_route()
    }

    /// The linear solver holds factors of the current values.
    pub(crate) fn is_factored(&self) -> bool {
        self.factored
    }

    /// Evaluates the matrix of `kind` at (t, y, yp) and factorises it (timed into `times`).
    ///
    /// `r0` must hold F(t, y, yp) (used by finite differences); `ewt` are the error weights
    /// and `h` the step size (or time scale), which scale the finite-difference increments.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn setup<P: DaeSystem>(
        &mut self,
        kind: MatrixKind,
        sys: &mut P,
        kinds: &[VarKind],
        t: f64,
        y: &[f64],
        yp: &[f64],
        p: &[f64],
        r0: &[f64],
        ewt: &[f64],
        h: f64,
        times: &mut PhaseTimes,
    ) -> Result<(), SetupError> {
        self.factored = false;
        timed(&mut times.jacobian_s, || match kind {
            MatrixKind::Iteration { alpha } => self.evaluate(sys, t, y, yp, p, alpha, r0, ewt, h),
            MatrixKind::InitialCondition => {
                // dF/dy (α = 0), then dF/dy + dF/dy' (α = 1); column by column, keep dF/dy'
                // for differential unknowns and dF/dy for algebraic ones.
                self.evaluate(sys, t, y, yp, p, 0.0, r0, ewt, h)?;
                self.j0.clone_from(&self.values);
                self.evaluate(sys, t, y, yp, p, 1.0, r0, ewt, h)?;
                for (c, kind) in kinds.iter().enumerate() {
                    let differential = *kind == VarKind::Differential;
                    for k in self.pattern.col_range(c) {
                        self.values[k] = if differential {
                            self.values[k] - self.j0[k]
                        } else {
                            self.j0[k]
                        };
                    }
                }
                // This factorisation is not an iteration matrix.
                self.alpha = f64::NAN;
                Ok(())
            }
        })
        .map_err(SetupError::Eval)?;
        timed(&mut times.factorisation_s, || self.factor()).map_err(SetupError::Linear)
    }

    /// Solves J·x = b in place.
    pub(crate) fn solve(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        self.solver.solve_in_place(b)
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

impl<P: DaeSystem> BdfSolver<P> {
    /// The one set-up path of every matrix the solver factorises: builds the matrix of `kind`
    /// at (t_n, `yy`, `yp`), with `delta` holding F there and `h` scaling the finite-difference
    /// increments, and factorises it.
    ///
    /// Counts the Jacobian evaluations (and the residuals of finite differences) whether or
    /// not they succeed, and a factorisation only when it succeeds. A recoverable evaluation
    /// failure and a singular matrix are recoverable; a fatal evaluation failure is fatal
    /// ([`DaeError::Evaluation`]). After an iteration matrix the next Newton iteration need
    /// not set up again; after an initial-condition matrix it must.
    pub(crate) fn setup_matrix_kind(&mut self, kind: MatrixKind, h: f64) -> Result<(), NlsFailure> {
        let evals = kind.evaluations();
        if let MatrixKind::InitialCondition = kind {
            // Whatever happens, the matrix will not be an iteration matrix.
            self.force_setup = true;
        }
        self.stats.jacobian_evals += evals;
        self.stats.residual_evals += evals * self.mat.fd_cost();
        let res = self.mat.setup(
            kind,
            &mut self.sys,
            &self.kinds,
            self.tn,
            &self.yy,
            &self.yp,
            &self.p,
            &self.delta,
            &self.ewt,
            h,
            &mut self.stats.time,
        );
        match res {
            Ok(()) => {
                self.stats.lu_factorisations += 1;
                match self.mat.last_route() {
                    crate::sparse::FactorRoute::Direct => {}
                    crate::sparse::FactorRoute::Equilibrated => self.stats.lu_equilibrated += 1,
                    crate::sparse::FactorRoute::PlainLu => self.stats.lu_plain_fallbacks += 1,
                }
                if let MatrixKind::Iteration { .. } = kind {
                    self.force_setup = false;
                    self.steps_since_jac = 0;
                }
                Ok(())
            }
            Err(SetupError::Eval(EvalError::Recoverable(m))) => {
                Err(NlsFailure::Recoverable(NlsCause::Eval(m)))
            }
            Err(SetupError::Eval(EvalError::Fatal(m))) => Err(NlsFailure::Fatal(DaeError::Evaluation {
                t: self.tn,
                message: m,
            })),
            Err(SetupError::Linear(e)) => Err(NlsFailure::Recoverable(NlsCause::Linear(
                e,
                self.singular_culprits(),
            ))),
        }
    }
}
