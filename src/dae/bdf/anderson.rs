//! Anderson acceleration of the modified Newton iteration (Walker & Ni, SIAM J. Numer. Anal.
//! 49, 2011; the fixed-point accelerator of SUNDIALS KINSOL).
//!
//! The corrector iteration with a frozen matrix J is the fixed-point map
//! g(e) = e − J⁻¹·F(e). Where the true Jacobian has moved away from J — stiff contact forces
//! whose stiffness changes from step to step — g contracts slowly. Anderson's method keeps
//! the last `depth` differences of the map's values Δg and of its residuals Δf (f = g(e) − e
//! = −J⁻¹·F, the plain Newton correction) and takes
//! e⁺ = g(e) − ΔG·γ, γ = argmin ‖f − ΔF·γ‖ (weighted 2-norm);
//! on a linear problem this is GMRES preconditioned by J (Walker & Ni), so a matrix that
//! differs from the true one by a few stiff directions still converges in a few iterations,
//! at the cost of one residual and one solve per iteration, as before, plus a least-squares
//! problem of `depth` columns.

/// The accelerator's history and scratch, sized once.
#[derive(Debug, Clone)]
pub(crate) struct Anderson {
    /// Weighted differences of the residuals f, newest last (its length is the depth; the
    /// first `used` are filled).
    df: Vec<Vec<f64>>,
    /// Differences of the map's values g, in the same order.
    dg: Vec<Vec<f64>>,
    /// Columns in use.
    used: usize,
    /// f and g of the previous iterate (weighted f), when there is one.
    f_prev: Vec<f64>,
    g_prev: Vec<f64>,
    have_prev: bool,
    /// Scratch: the weighted residual, the Gram–Schmidt factors.
    fw: Vec<f64>,
    q: Vec<Vec<f64>>,
}

impl Anderson {
    /// An accelerator for `n` unknowns keeping `depth` differences (0: plain iteration; at
    /// most [`MAX_DEPTH`], which the solver's options are checked against).
    pub(crate) fn new(n: usize, depth: usize) -> Self {
        let depth = depth.min(MAX_DEPTH);
        Anderson {
            df: vec![vec![0.0; n]; depth],
            dg: vec![vec![0.0; n]; depth],
            used: 0,
            f_prev: vec![0.0; n],
            g_prev: vec![0.0; n],
            have_prev: false,
            fw: vec![0.0; n],
            q: vec![vec![0.0; n]; depth],
        }
    }

    /// Forgets the history (a new matrix or a new solve: another fixed-point map).
    pub(crate) fn reset(&mut self) {
        self.used = 0;
        self.have_prev = false;
    }

    /// Advances `e` (the current iterate) given the plain correction `delta` = J⁻¹·F(e)
    /// (so g(e) = e − delta), with error weights `w` for the least-squares norm: `e` becomes
    /// the accelerated iterate.
    pub(crate) fn advance(&mut self, e: &mut [f64], delta: &[f64], w: &[f64]) {
        let n = e.len();
        let depth = self.df.len();
        if depth == 0 {
            for i in 0..n {
                e[i] -= delta[i];
            }
            return;
        }
        // Weighted residual f = −delta·w and g = e − delta.
        for i in 0..n {
            self.fw[i] = -delta[i] * w[i];
            e[i] -= delta[i];
        }
        if self.have_prev {
            // Drop the oldest column when full (rotate it to the end and overwrite).
            if self.used == depth {
                self.df.rotate_left(1);
                self.dg.rotate_left(1);
                self.used -= 1;
            }
            let k = self.used;
            for i in 0..n {
                self.df[k][i] = self.fw[i] - self.f_prev[i];
                self.dg[k][i] = e[i] - self.g_prev[i];
            }
            self.used += 1;
        }
        self.f_prev.copy_from_slice(&self.fw);
        self.g_prev.copy_from_slice(e);
        self.have_prev = true;
        if self.used == 0 {
            return;
        }
        // Least squares by modified Gram–Schmidt on the columns of ΔF, dropping a column
        // that is (nearly) a combination of the earlier ones.
        let m = self.used;
        let mut r = [[0.0f64; MAX_DEPTH]; MAX_DEPTH];
        let mut keep = [false; MAX_DEPTH];
        for j in 0..m {
            self.q[j].copy_from_slice(&self.df[j]);
            let norm0 = dot(&self.q[j], &self.q[j]).sqrt();
            for i in 0..j {
                if !keep[i] {
                    continue;
                }
                let rij = dot(&self.q[i], &self.q[j]);
                r[i][j] = rij;
                let (qi, qj) = split_pair(&mut self.q, i, j);
                axpy(qj, qi, -rij);
            }
            let rjj = dot(&self.q[j], &self.q[j]).sqrt();
            if rjj > 1e-10 * norm0 && rjj > 0.0 {
                keep[j] = true;
                r[j][j] = rjj;
                let inv = 1.0 / rjj;
                self.q[j].iter_mut().for_each(|v| *v *= inv);
            }
        }
        // γ from R·γ = Qᵀ·f (back substitution over the kept columns).
        let mut gamma = [0.0f64; MAX_DEPTH];
        for j in (0..m).rev() {
            if !keep[j] {
                continue;
            }
            let mut s = dot(&self.q[j], &self.fw);
            for l in j + 1..m {
                if keep[l] {
                    s -= r[j][l] * gamma[l];
                }
            }
            gamma[j] = s / r[j][j];
        }
        for j in 0..m {
            if keep[j] && gamma[j] != 0.0 {
                axpy(e, &self.dg[j], -gamma[j]);
            }
        }
    }
}

/// Largest history kept.
pub(crate) const MAX_DEPTH: usize = 8;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// y += a·x.
fn axpy(y: &mut [f64], x: &[f64], a: f64) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += a * xi;
    }
}

/// Column i (read) and column j (written) of `q`, i < j.
fn split_pair(q: &mut [Vec<f64>], i: usize, j: usize) -> (&[f64], &mut [f64]) {
    let (lo, hi) = q.split_at_mut(j);
    (&lo[i], &mut hi[0])
}

#[cfg(test)]
mod tests {
    use super::Anderson;

    /// The modified Newton map of a linear system A·e = b with a frozen diagonal matrix M ≠ A:
    /// delta = M⁻¹·(A·e − b). Returns the iterations to reach |A·e − b| ≤ 1e-10 (200: not).
    fn iterations(a: &[Vec<f64>], m: &[f64], depth: usize) -> usize {
        let n = m.len();
        let b: Vec<f64> = (0..n).map(|i| 1.0 + i as f64).collect();
        let w = vec![1.0; n];
        let mut acc = Anderson::new(n, depth);
        let mut e = vec![0.0; n];
        for k in 0..200 {
            let res: Vec<f64> = (0..n)
                .map(|i| (0..n).map(|j| a[i][j] * e[j]).sum::<f64>() - b[i])
                .collect();
            if res.iter().map(|v| v * v).sum::<f64>().sqrt() <= 1e-10 {
                return k;
            }
            let delta: Vec<f64> = (0..n).map(|i| res[i] / m[i]).collect();
            acc.advance(&mut e, &delta, &w);
        }
        200
    }

    #[test]
    fn acceleration_solves_a_linear_system_with_a_wrong_matrix_in_few_iterations() {
        // A = diag(1, 10, 100) plus a coupling; M its diagonal, wrong by 1.8× in the two stiff
        // directions (a contact's stiffness that has moved): the plain iteration contracts
        // at about 0.8, so it needs well over a hundred iterations.
        let a = vec![vec![1.0, 0.2, 0.0], vec![0.2, 10.0, 0.5], vec![0.0, 0.5, 100.0]];
        let m = [1.0, 10.0 / 1.8, 100.0 / 1.8];
        let plain = iterations(&a, &m, 0);
        assert!(plain > 100, "plain {plain}");
        // Three differences: GMRES on a 3 × 3 system, done within n + 1 iterations.
        let three = iterations(&a, &m, 3);
        assert!(three <= 5, "depth 3: {three}");
        // Two differences: the oldest is dropped as new ones come (the ring buffer turns).
        let two = iterations(&a, &m, 2);
        assert!(two <= 12, "depth 2: {two}");
        // One difference (a secant step) still beats the plain iteration.
        let one = iterations(&a, &m, 1);
        assert!(one < plain / 2, "depth 1: {one}, plain {plain}");
    }

    #[test]
    fn a_difference_that_repeats_earlier_ones_is_dropped_not_divided_by() {
        // Residuals f0..f3 whose differences are (1, 0), (0, 1) and (1, 1): the third is the
        // sum of the first two, so its Gram–Schmidt remainder is zero and it is dropped; the
        // least squares over the first two fits f3 = (3, 3) exactly with γ = (3, 3), and the
        // iterate is g3 − 3·(g1 − g0) − 3·(g2 − g1), g_k = e_k + f_k.
        let fs = [[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
        let mut acc = Anderson::new(2, 3);
        let mut e = [0.0f64; 2];
        let mut g = vec![];
        for f in &fs {
            let before = e;
            acc.advance(&mut e, &[-f[0], -f[1]], &[1.0, 1.0]);
            g.push([before[0] + f[0], before[1] + f[1]]);
        }
        for i in 0..2 {
            let expected = g[3][i] - 3.0 * (g[1][i] - g[0][i]) - 3.0 * (g[2][i] - g[1][i]);
            assert!(e[i].is_finite() && (e[i] - expected).abs() < 1e-12, "{e:?}");
        }
    }
}
