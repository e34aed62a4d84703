//! Sparse LU that reuses its pivot sequence across factorisations (the refactorisation of
//! KLU, `klu_refactor`, which SUNDIALS' KLU interface calls on every set-up after the first).
//!
//! A Newton iteration factorises many matrices with one pattern whose values drift. The
//! columns are taken in an approximate-minimum-degree order of A + Aᵀ (faer's AMD, computed
//! once). A *pivoting* factorisation (left-looking, Gilbert–Peierls) chooses in each column
//! the row of the column's own index when it is within [`CHOOSE_PIVOT_THRESHOLD`] of the
//! largest candidate, else the largest; the pivot sequence then fixes the structure of L and
//! U (a symbolic analysis, once per sequence), and later factorisations only recompute the
//! numbers, column by column, with no search for pivots and no supernode bookkeeping. On
//! small systems that bookkeeping is most of a general sparse LU's time: on one 114-unknown
//! reduced iteration matrix of the 63-DOF MR2120 (`BlockSchurLu`'s Schur complement, 2 106
//! nonzeros; 1 331 + 1 401 in L + U), 15 µs per refactorisation and 1.6 µs per solve against
//! faer's supernodal LU's 31 µs and 3.1 µs, measured on this machine.
//!
//! **Stability.** The rows are scaled to a largest entry of 1 before every factorisation
//! (as KLU scales by default), so the pivot tests compare like with like. A reused pivot
//! must be at least [`REUSE_PIVOT_THRESHOLD`] times the largest entry below it in its
//! column; when one is not, the next of the last [`PLANS_KEPT`] sequences is tried (stiff
//! terms that switch on and off — contacts — make the matrices alternate between a few),
//! and when none passes, the pivots are chosen anew. Every factorisation is therefore a
//! threshold-pivoted LU of the current values, never one with a stale pivot. A matrix the
//! pivoting factorisation finds singular goes to faer's LU ([`SparseLu`], built on first
//! use), which reports it.

use super::lu::{check_values, non_finite_bit};
use super::{CscPattern, LinearSolveError, SparseLu};

/// Smallest ratio of a reused pivot to the largest entry below it in its column of L before
/// the pivot sequence is chosen again (KLU's default partial-pivoting tolerance is 0.001,
/// UMFPACK's 0.1; the growth of the entries of L is bounded by its inverse).
pub const REUSE_PIVOT_THRESHOLD: f64 = 0.01;

/// Pivot sequences kept: matrices whose stiff terms switch on and off (contacts) alternate
/// between a few sequences, each tried before pivots are chosen anew.
pub const PLANS_KEPT: usize = 4;

/// The structure of L and U for one pivot sequence, and their values.
#[derive(Debug, Clone)]
struct Plan {
    /// Step k eliminates row `prow[k]` of A …
    prow: Vec<usize>,
    /// … in column `pcol[k]` of A.
    pcol: Vec<usize>,
    /// Entries of A by step: for step j, `a_pos[a_ptr[j]..a_ptr[j+1]]` are positions in A's
    /// values and `a_row` their permuted rows.
    a_ptr: Vec<usize>,
    a_pos: Vec<u32>,
    a_row: Vec<u32>,
    /// L by columns, strictly below the (unit) diagonal, permuted row indices.
    l_ptr: Vec<usize>,
    l_row: Vec<u32>,
    l_val: Vec<f64>,
    /// U by columns, strictly above the diagonal, permuted row indices ascending.
    u_ptr: Vec<usize>,
    u_row: Vec<u32>,
    u_val: Vec<f64>,
    /// Diagonal of U.
    u_diag: Vec<f64>,
    /// Whether column k of L (of U) has rows first, first + 1, … without a gap: the dense
    /// trailing part of a fill-reducing order, whose updates then run over slices of the
    /// work vector (vectorised) rather than through the row indices.
    l_contiguous: Vec<bool>,
    u_contiguous: Vec<bool>,
}

/// Whether sorted `rows` are a run of consecutive indices.
fn contiguous(rows: &[u32]) -> bool {
    match (rows.first(), rows.last()) {
        (Some(&a), Some(&b)) => (b - a) as usize + 1 == rows.len(),
        _ => false,
    }
}

/// Threshold of the pivoting factorisation: a column's pivot is its diagonal entry (in the
/// fill-reducing order) when that is at least this fraction of the largest candidate, else
/// the largest (threshold partial pivoting; UMFPACK's default 0.1).
pub const CHOOSE_PIVOT_THRESHOLD: f64 = 0.1;

/// Chooses the pivot rows of a left-looking LU (Gilbert–Peierls) of `values` on `pattern`,
/// taking the columns in the order `pcol` and, in each, the row of the column's own index
/// when it passes [`CHOOSE_PIVOT_THRESHOLD`] (so a fill-reducing symmetric order keeps its
/// fill), else the largest candidate. Returns the pivot rows in step order, or `None` when a
/// column has no nonzero candidate (singular).
fn choose_pivots(pattern: &CscPattern, values: &[f64], pcol: &[usize]) -> Option<Vec<usize>> {
    let n = pattern.ncols();
    let mut pinv = vec![usize::MAX; n];
    let mut prow = Vec::with_capacity(n);
    let (mut l_ptr, mut l_row, mut l_val) = (vec![0], Vec::<u32>::new(), Vec::<f64>::new());
    let mut x = vec![0.0; n];
    let mut mark = vec![usize::MAX; n];
    let (mut stack, mut reached, mut pivotal) = (Vec::new(), Vec::new(), Vec::new());
    for (j, &c) in pcol.iter().enumerate() {
        reached.clear();
        for k in pattern.col_range(c) {
            let r = pattern.row_idx()[k];
            x[r] += values[k];
            if mark[r] != j {
                mark[r] = j;
                stack.push(r);
            }
        }
        while let Some(r) = stack.pop() {
            reached.push(r);
            if pinv[r] != usize::MAX {
                let k = pinv[r];
                for &i in &l_row[l_ptr[k]..l_ptr[k + 1]] {
                    let i = i as usize;
                    if mark[i] != j {
                        mark[i] = j;
                        stack.push(i);
                    }
                }
            }
        }
        pivotal.clear();
        pivotal.extend(reached.iter().copied().filter(|&r| pinv[r] != usize::MAX));
        pivotal.sort_unstable_by_key(|&r| pinv[r]);
        for &r in &pivotal {
            let k = pinv[r];
            let xk = x[r];
            if xk != 0.0 {
                scatter_sub(
                    &mut x,
                    &l_row[l_ptr[k]..l_ptr[k + 1]],
                    &l_val[l_ptr[k]..l_ptr[k + 1]],
                    xk,
                );
            }
        }
        let mut best = usize::MAX;
        let mut largest = 0.0f64;
        for &r in reached.iter().filter(|&&r| pinv[r] == usize::MAX) {
            if x[r].abs() > largest || best == usize::MAX {
                largest = largest.max(x[r].abs());
                best = r;
            }
        }
        if best == usize::MAX || largest == 0.0 || !largest.is_finite() {
            return None;
        }
        let piv = if mark[c] == j && pinv[c] == usize::MAX && x[c].abs() >= CHOOSE_PIVOT_THRESHOLD * largest {
            c
        } else {
            best
        };
        pinv[piv] = j;
        prow.push(piv);
        let inv = 1.0 / x[piv];
        for &r in reached.iter().filter(|&&r| pinv[r] == usize::MAX) {
            l_row.push(r as u32);
            l_val.push(x[r] * inv);
        }
        l_ptr.push(l_row.len());
        for &r in &reached {
            x[r] = 0.0;
        }
    }
    Some(prow)
}

impl Plan {
    /// The symbolic factorisation of A with rows `prow` and columns `pcol` taken in step
    /// order (no pivoting); `None` when a step has no structural pivot.
    fn analyse(pattern: &CscPattern, prow: Vec<usize>, pcol: Vec<usize>) -> Option<Self> {
        let n = pattern.ncols();
        let mut pinv = vec![usize::MAX; n];
        for (k, &r) in prow.iter().enumerate() {
            pinv[r] = k;
        }
        let (mut a_ptr, mut a_pos, mut a_row) = (vec![0], vec![], vec![]);
        let (mut l_ptr, mut l_row) = (vec![0], vec![]);
        let (mut u_ptr, mut u_row) = (vec![0], vec![]);
        // Depth-first reach of each column's entries in the graph of L (edges k → i for the
        // rows i of column k of L, k < j).
        let mut mark = vec![usize::MAX; n];
        let mut stack = Vec::new();
        let mut reached = Vec::new();
        for (j, &c) in pcol.iter().enumerate() {
            reached.clear();
            for k in pattern.col_range(c) {
                let i = pinv[pattern.row_idx()[k]];
                a_pos.push(k as u32);
                a_row.push(i as u32);
                if mark[i] != j {
                    mark[i] = j;
                    stack.push(i);
                }
            }
            a_ptr.push(a_pos.len());
            while let Some(k) = stack.pop() {
                reached.push(k);
                if k < j {
                    for &i in &l_row[l_ptr[k]..l_ptr[k + 1]] {
                        let i = i as usize;
                        if mark[i] != j {
                            mark[i] = j;
                            stack.push(i);
                        }
                    }
                }
            }
            if mark[j] != j {
                return None;
            }
            reached.sort_unstable();
            // Rows above j: U (ascending, a valid elimination order since L's edges only go
            // down); below j: L.
            let split = reached.partition_point(|&k| k < j);
            u_row.extend(reached[..split].iter().map(|&k| k as u32));
            u_ptr.push(u_row.len());
            l_row.extend(reached[split + 1..].iter().map(|&k| k as u32));
            l_ptr.push(l_row.len());
        }
        let l_contiguous = (0..n)
            .map(|k| contiguous(&l_row[l_ptr[k]..l_ptr[k + 1]]))
            .collect();
        let u_contiguous = (0..n)
            .map(|k| contiguous(&u_row[u_ptr[k]..u_ptr[k + 1]]))
            .collect();
        Some(Self {
            prow,
            pcol,
            a_ptr,
            a_pos,
            a_row,
            l_val: vec![0.0; l_row.len()],
            l_ptr,
            l_row,
            u_val: vec![0.0; u_row.len()],
            u_ptr,
            u_row,
            u_diag: vec![0.0; n],
            l_contiguous,
            u_contiguous,
        })
    }

    /// The row scales `row_scale` (by original row) in this plan's step order, into `out`.
    fn step_scale(&self, row_scale: &[f64], out: &mut [f64]) {
        for (o, &r) in out.iter_mut().zip(&self.prow) {
            *o = row_scale[r];
        }
    }

    /// Numeric factorisation of `values` with the plan's pivots, row k of the plan's order
    /// scaled by `scale[k]` as it is gathered (`x`: zeroed scratch of length n, left
    /// zeroed). `false` when a pivot fails the reuse threshold.
    fn factor(&mut self, values: &[f64], scale: &[f64], x: &mut [f64], threshold: f64) -> bool {
        let n = self.u_diag.len();
        for j in 0..n {
            for (&k, &i) in self.a_pos[self.a_ptr[j]..self.a_ptr[j + 1]]
                .iter()
                .zip(&self.a_row[self.a_ptr[j]..self.a_ptr[j + 1]])
            {
                x[i as usize] += values[k as usize] * scale[i as usize];
            }
            let (us, ue) = (self.u_ptr[j], self.u_ptr[j + 1]);
            for p in us..ue {
                let k = self.u_row[p] as usize;
                let xk = x[k];
                x[k] = 0.0;
                self.u_val[p] = xk;
                if xk != 0.0 {
                    let (ls, le) = (self.l_ptr[k], self.l_ptr[k + 1]);
                    sub_column(
                        x,
                        &self.l_row[ls..le],
                        &self.l_val[ls..le],
                        xk,
                        self.l_contiguous[k],
                    );
                }
            }
            let pivot = x[j];
            x[j] = 0.0;
            let (ls, le) = (self.l_ptr[j], self.l_ptr[j + 1]);
            let below = self.l_row[ls..le]
                .iter()
                .fold(0.0f64, |m, &i| larger(m, x[i as usize].abs()));
            if !(pivot.abs() > 0.0 && pivot.abs() >= threshold * below && pivot.is_finite()) {
                for &i in &self.l_row[ls..le] {
                    x[i as usize] = 0.0;
                }
                return false;
            }
            self.u_diag[j] = pivot;
            let inv = 1.0 / pivot;
            for p in ls..le {
                let i = self.l_row[p] as usize;
                self.l_val[p] = x[i] * inv;
                x[i] = 0.0;
            }
        }
        true
    }

    /// Solves with the factors: `b` (original order) becomes x; `y` is scratch of length n.
    fn solve(&self, b: &mut [f64], y: &mut [f64]) {
        let n = self.u_diag.len();
        for (yk, &r) in y.iter_mut().zip(&self.prow) {
            *yk = b[r];
        }
        for k in 0..n {
            let yk = y[k];
            if yk != 0.0 {
                let (ls, le) = (self.l_ptr[k], self.l_ptr[k + 1]);
                sub_column(
                    y,
                    &self.l_row[ls..le],
                    &self.l_val[ls..le],
                    yk,
                    self.l_contiguous[k],
                );
            }
        }
        for j in (0..n).rev() {
            let yj = y[j] / self.u_diag[j];
            y[j] = yj;
            if yj != 0.0 {
                let (us, ue) = (self.u_ptr[j], self.u_ptr[j + 1]);
                sub_column(
                    y,
                    &self.u_row[us..ue],
                    &self.u_val[us..ue],
                    yj,
                    self.u_contiguous[j],
                );
            }
        }
        for (&yk, &c) in y.iter().zip(&self.pcol) {
            b[c] = yk;
        }
    }
}

/// `m.max(a)` for a running maximum `m` that is never NaN, as one comparison (`f64::max`'s
/// NaN handling costs a few instructions more per entry): a NaN `a` leaves `m`, as there.
#[inline]
fn larger(m: f64, a: f64) -> f64 {
    if a > m {
        a
    } else {
        m
    }
}

/// [`scatter_sub`], over the slice of `x` the rows span when they are `contiguous` (the
/// same operations in the same order, vectorised).
#[inline]
fn sub_column(x: &mut [f64], rows: &[u32], vals: &[f64], a: f64, contiguous: bool) {
    match rows.first() {
        Some(&first) if contiguous => {
            let first = first as usize;
            for (xi, &v) in x[first..first + vals.len()].iter_mut().zip(vals) {
                *xi -= v * a;
            }
        }
        _ => scatter_sub(x, rows, vals, a),
    }
}

/// x[rows[p]] −= vals[p]·a for every p: the inner loop of the factorisation and the solves.
#[inline]
fn scatter_sub(x: &mut [f64], rows: &[u32], vals: &[f64], a: f64) {
    for (&i, &v) in rows.iter().zip(vals) {
        x[i as usize] -= v * a;
    }
}

/// Approximate minimum degree order of the columns of `pattern` (faer's AMD on A + Aᵀ).
fn amd_order(pattern: &CscPattern) -> Result<Vec<usize>, LinearSolveError> {
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::sparse::linalg::amd;
    use faer::sparse::SymbolicSparseColMatRef;
    let n = pattern.ncols();
    let (mut perm, mut perm_inv) = (vec![0usize; n], vec![0usize; n]);
    let sym = SymbolicSparseColMatRef::new_checked(n, n, pattern.col_ptr(), None, pattern.row_idx());
    let mut buf = MemBuffer::try_new(amd::order_scratch::<usize>(n, pattern.nnz()))
        .map_err(|e| LinearSolveError::Backend(format!("{e:?}")))?;
    amd::order(
        &mut perm,
        &mut perm_inv,
        sym,
        amd::Control::default(),
        MemStack::new(&mut buf),
    )
    .map_err(|e| LinearSolveError::Backend(format!("{e:?}")))?;
    Ok(perm)
}

/// Which factors the last factorisation left.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Factors {
    None,
    /// Those of the first plan (a pivot sequence).
    Plan,
    /// faer's, when the pivoting factorisation found the matrix singular.
    Fallback,
}

/// Sparse LU of a square matrix with a fixed pattern that reuses the pivot sequence of its
/// last pivoting factorisation while the pivots stay acceptable (module documentation in
/// `src/sparse/refactor.rs`).
#[derive(Debug)]
pub struct RefactorLu {
    pattern: CscPattern,
    /// Fill-reducing column order (approximate minimum degree on A + Aᵀ).
    order: Vec<usize>,
    /// faer's LU, for a matrix the own pivoting finds singular (built on first use).
    fallback: Option<SparseLu>,
    /// Pivot sequences, most recently used first (at most [`PLANS_KEPT`]).
    plans: Vec<Plan>,
    /// Reciprocal of each row's largest |entry| in the last factorisation.
    row_scale: Vec<f64>,
    /// The value positions of each row (row r: `row_pos[row_ptr[r]..row_ptr[r + 1]]`), so
    /// a row's largest entry is a gather, not a scatter of maxima into `row_scale`.
    row_ptr: Vec<usize>,
    row_pos: Vec<u32>,
    /// The values scaled by rows (filled only to choose pivots).
    scaled: Vec<f64>,
    /// The row scales in a plan's step order (`row_scale[prow[k]]`).
    step_scale: Vec<f64>,
    threshold: f64,
    factors: Factors,
    work: Vec<f64>,
    refactorisations: usize,
    pivotings: usize,
}

impl RefactorLu {
    /// Prepares the factorisation of matrices on `pattern` (square), reusing pivots with
    /// [`REUSE_PIVOT_THRESHOLD`].
    pub fn new(pattern: &CscPattern) -> Result<Self, LinearSolveError> {
        if pattern.nrows() != pattern.ncols() {
            return Err(LinearSolveError::NotSquare {
                nrows: pattern.nrows(),
                ncols: pattern.ncols(),
            });
        }
        // Rows and value positions are kept as u32 (half the memory traffic of usize).
        if u32::try_from(pattern.nnz()).is_err() || u32::try_from(pattern.ncols()).is_err() {
            return Err(LinearSolveError::TooLarge {
                unknowns: pattern.ncols(),
                entries: pattern.nnz(),
            });
        }
        let n = pattern.ncols();
        let mut row_ptr = vec![0usize; n + 1];
        for &r in pattern.row_idx() {
            row_ptr[r + 1] += 1;
        }
        for r in 0..n {
            row_ptr[r + 1] += row_ptr[r];
        }
        let mut next = row_ptr.clone();
        let mut row_pos = vec![0u32; pattern.nnz()];
        for (k, &r) in pattern.row_idx().iter().enumerate() {
            row_pos[next[r]] = k as u32;
            next[r] += 1;
        }
        Ok(Self {
            pattern: pattern.clone(),
            order: amd_order(pattern)?,
            fallback: None,
            plans: Vec::new(),
            row_scale: vec![1.0; n],
            row_ptr,
            row_pos,
            scaled: vec![0.0; pattern.nnz()],
            step_scale: vec![1.0; n],
            threshold: REUSE_PIVOT_THRESHOLD,
            factors: Factors::None,
            work: vec![0.0; 2 * pattern.ncols()],
            refactorisations: 0,
            pivotings: 0,
        })
    }

    /// Dimension of the system.
    pub fn dim(&self) -> usize {
        self.pattern.ncols()
    }

    /// Entries of L and U (strictly below and above the diagonal) of the last used pivot
    /// sequence, and the multiply-adds of one refactorisation with it.
    pub fn fill(&self) -> Option<(usize, usize, usize)> {
        self.plans.first().map(|p| {
            let flops = p
                .u_row
                .iter()
                .map(|&k| p.l_ptr[k as usize + 1] - p.l_ptr[k as usize])
                .sum::<usize>();
            (p.l_row.len(), p.u_row.len(), flops)
        })
    }

    /// Factorisations that reused a pivot sequence, and those that chose one.
    pub fn counts(&self) -> (usize, usize) {
        (self.refactorisations, self.pivotings)
    }

    /// Numeric factorisation of the matrix with `values` on the pattern given to
    /// [`new`](Self::new).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        self.factors = Factors::None;
        if values.len() != self.pattern.nnz() {
            return check_values(&self.pattern, values);
        }
        let n = self.dim();
        // Row scaling (each row's largest entry 1, as KLU scales by default): the pivot
        // tests compare entries of different rows, whose units differ. The same pass looks
        // for NaN and infinities (every entry is in one row).
        let mut non_finite = 0u64;
        for (v, w) in self.row_scale.iter_mut().zip(self.row_ptr.windows(2)) {
            let largest = self.row_pos[w[0]..w[1]].iter().fold(0.0f64, |m, &k| {
                let x = values[k as usize];
                non_finite |= non_finite_bit(x);
                larger(m, x.abs())
            });
            *v = if largest > 0.0 { 1.0 / largest } else { 1.0 };
        }
        if non_finite != 0 {
            // Names the first non-finite entry.
            return check_values(&self.pattern, values);
        }
        // Each plan scales its rows as it gathers them (no scaled copy of the values).
        for i in 0..self.plans.len() {
            let plan = &mut self.plans[i];
            plan.step_scale(&self.row_scale, &mut self.step_scale);
            if plan.factor(values, &self.step_scale, &mut self.work[..n], self.threshold) {
                self.plans[..=i].rotate_right(1);
                self.refactorisations += 1;
                self.factors = Factors::Plan;
                return Ok(());
            }
        }
        // Choose the pivots again (on the scaled values), then take the sequence as the new
        // plan.
        self.pivotings += 1;
        for ((s, &r), v) in self.scaled.iter_mut().zip(self.pattern.row_idx()).zip(values) {
            *s = v * self.row_scale[r];
        }
        let plan = choose_pivots(&self.pattern, &self.scaled, &self.order)
            .and_then(|prow| Plan::analyse(&self.pattern, prow, self.order.clone()));
        // The chosen pivots pass the reuse threshold, so the plan reproduces them; should
        // it not (or no pivot sequence was found), faer's LU serves this solve and reports
        // a singular matrix.
        let reproduced = match plan {
            Some(mut plan) => {
                plan.step_scale(&self.row_scale, &mut self.step_scale);
                let ok = plan.factor(values, &self.step_scale, &mut self.work[..n], self.threshold);
                if ok {
                    self.plans.truncate(PLANS_KEPT - 1);
                    self.plans.insert(0, plan);
                }
                ok
            }
            None => false,
        };
        if reproduced {
            self.factors = Factors::Plan;
        } else {
            if self.fallback.is_none() {
                self.fallback = Some(SparseLu::new(&self.pattern)?);
            }
            self.fallback.as_mut().expect("built above").factor(values)?;
            self.factors = Factors::Fallback;
        }
        Ok(())
    }

    /// Solves A·x = b in place (`b` becomes `x`) with the current factors. A solution with a
    /// non-finite entry reports [`LinearSolveError::Singular`].
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        if b.len() != self.dim() {
            return Err(LinearSolveError::DimensionMismatch {
                expected: self.dim(),
                got: b.len(),
            });
        }
        match self.factors {
            Factors::None => return Err(LinearSolveError::Singular { column: None }),
            Factors::Fallback => {
                return self
                    .fallback
                    .as_mut()
                    .expect("factors of the fallback")
                    .solve_in_place(b)
            }
            Factors::Plan => {
                let n = self.dim();
                for (x, s) in b.iter_mut().zip(&self.row_scale) {
                    *x *= s;
                }
                let plan = self.plans.first().expect("factors of the plan");
                plan.solve(b, &mut self.work[n..]);
            }
        }
        if b.iter().any(|v| !v.is_finite()) {
            return Err(LinearSolveError::Singular { column: None });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{csc, residual};
    use super::*;

    /// A saddle-point matrix like the multibody iteration matrices (zero diagonal in the
    /// multiplier rows), values scaled by `s` in the coupling.
    fn saddle(s: f64) -> Vec<Vec<f64>> {
        vec![
            vec![4.0, 1.0, 0.0, 0.0, 1.0, 0.0],
            vec![1.0, 5.0, 1.0, 0.0, s, 1.0],
            vec![0.0, 1.0, 6.0, 2.0, 0.0, 0.0],
            vec![0.0, 0.0, 2.0, 7.0, 0.0, 1.0],
            vec![1.0, s, 0.0, 0.0, 0.0, 0.0],
            vec![0.0, 1.0, 0.0, 1.0, 0.0, 0.0],
        ]
    }

    #[test]
    fn refactorisations_reuse_the_pivots_and_solve_to_round_off() {
        let (p, _) = csc(&saddle(2.0), |_, _| false);
        let mut lu = RefactorLu::new(&p).unwrap();
        for (round, s) in [2.0, 2.1, 1.9, 2.05].into_iter().enumerate() {
            let dense = saddle(s);
            let (_, v) = csc(&dense, |_, _| false);
            lu.factor(&v).unwrap();
            let b: Vec<f64> = (0..6).map(|i| (i as f64 + 0.5).sin()).collect();
            let mut x = b.clone();
            lu.solve_in_place(&mut x).unwrap();
            assert!(residual(&dense, &x, &b) < 1e-13, "round {round}");
        }
        // The first chose the pivots; the three small changes reused them.
        assert_eq!(lu.counts(), (3, 1));
    }

    #[test]
    fn dense_trailing_columns_take_the_slice_path_and_give_the_same_numbers() {
        // A dense 7 × 7 matrix: every column of L and U is a run of rows, so the updates run
        // over slices; the solution is checked against the matrix and, bit for bit, against
        // the same factorisation through the row indices.
        let n = 7;
        let dense: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        if i == j {
                            10.0 + i as f64
                        } else {
                            ((i * n + j) as f64).sin()
                        }
                    })
                    .collect()
            })
            .collect();
        let (p, v) = csc(&dense, |_, _| false);
        let mut lu = RefactorLu::new(&p).unwrap();
        lu.factor(&v).unwrap();
        let plan = &lu.plans[0];
        let runs = plan.l_contiguous.iter().filter(|&&c| c).count();
        assert_eq!(runs, n - 1, "every column of L but the last (empty) is a run");
        let b: Vec<f64> = (0..n).map(|i| (i as f64).cos()).collect();
        let mut x = b.clone();
        lu.solve_in_place(&mut x).unwrap();
        assert!(residual(&dense, &x, &b) < 1e-13);
        // The same plan with every column marked scattered.
        let mut scattered = lu.plans[0].clone();
        scattered.l_contiguous.iter_mut().for_each(|c| *c = false);
        scattered.u_contiguous.iter_mut().for_each(|c| *c = false);
        let mut work = vec![0.0; n];
        let mut scale = vec![0.0; n];
        scattered.step_scale(&lu.row_scale, &mut scale);
        assert!(scattered.factor(&v, &scale, &mut work, lu.threshold));
        assert_eq!(scattered.l_val, lu.plans[0].l_val);
        assert_eq!(scattered.u_val, lu.plans[0].u_val);
        assert_eq!(scattered.u_diag, lu.plans[0].u_diag);
        let (mut y, mut z) = (b.clone(), b.clone());
        let mut scratch = vec![0.0; n];
        scattered.solve(&mut y, &mut scratch);
        lu.plans[0].solve(&mut z, &mut scratch);
        assert_eq!(y, z);
    }

    #[test]
    fn a_pivot_that_becomes_too_small_makes_it_pivot_again() {
        // Diagonally dominant first; then entry (0, 0) nearly vanishes against (1, 0), so
        // the first pivot no longer passes the threshold.
        let a = |d: f64| vec![vec![d, 2.0, 0.0], vec![1.0, 3.0, 1.0], vec![0.0, 1.0, 4.0]];
        let (p, _) = csc(&a(5.0), |_, _| false);
        let mut lu = RefactorLu::new(&p).unwrap();
        for d in [5.0, 1e-6] {
            let dense = a(d);
            let (_, v) = csc(&dense, |_, _| false);
            lu.factor(&v).unwrap();
            let b = vec![1.0, -2.0, 0.5];
            let mut x = b.clone();
            lu.solve_in_place(&mut x).unwrap();
            assert!(residual(&dense, &x, &b) < 1e-12, "d = {d}");
        }
        assert_eq!(lu.counts().1, 2);
    }

    #[test]
    fn singular_and_unfactored_are_errors_not_panics() {
        let (p, _) = csc(&saddle(2.0), |_, _| false);
        let mut lu = RefactorLu::new(&p).unwrap();
        let mut b = vec![1.0; 6];
        assert!(lu.solve_in_place(&mut b).is_err());
        let sing = vec![vec![1.0, 2.0], vec![2.0, 4.0]];
        let (p2, v2) = csc(&sing, |_, _| false);
        let mut lu2 = RefactorLu::new(&p2).unwrap();
        let r = lu2.factor(&v2).and_then(|_| {
            let mut b = vec![1.0, 1.0];
            lu2.solve_in_place(&mut b)
        });
        assert!(r.is_err());
        assert!(matches!(
            lu.factor(&[1.0]),
            Err(LinearSolveError::DimensionMismatch { .. })
        ));
        // A pattern that is not square is refused.
        let tall = CscPattern::from_entries(3, 2, vec![(0, 0), (1, 1), (2, 1)]).unwrap();
        assert!(matches!(
            RefactorLu::new(&tall),
            Err(LinearSolveError::NotSquare { nrows: 3, ncols: 2 })
        ));
        // A NaN or an infinity is named by its row and column, and leaves no factors.
        let (_, v) = csc(&saddle(2.0), |_, _| false);
        lu.factor(&v).unwrap();
        for (bad, (r, c)) in [(f64::NAN, (3, 5)), (f64::INFINITY, (1, 4))] {
            let mut w = v.clone();
            w[p.find(r, c).unwrap()] = bad;
            match lu.factor(&w) {
                Err(LinearSolveError::NonFiniteEntry { row, col, .. }) => assert_eq!((row, col), (r, c)),
                other => panic!("{bad} at ({r}, {c}): {other:?}"),
            }
            let mut b = vec![1.0; 6];
            assert!(lu.solve_in_place(&mut b).is_err());
        }
    }
}
