//! Dense LU with partial pivoting for the multibody analyses' small systems: one
//! factorisation solves with both A and Aᵀ. The multibody analyses solve with the velocity
//! Jacobian B for the accelerations and with Bᵀ for the multipliers λ = B⁻ᵀ·r; the
//! transposed solve spares the second factorisation that took.
//!
//! The matrices are stored dense but are mostly zeros (a constraint row touches two bodies:
//! at most 14 of the MR2120 ideal model's 84 position unknowns), so the elimination skips
//! what a zero cannot change: a column whose entry in the pivot row is zero is not updated,
//! and a column is updated only in the rows where the pivot column's multiplier is nonzero.
//! The arithmetic on the entries that are updated is the textbook right-looking elimination
//! with LAPACK's unblocked `getf2`'s pivots (its multipliers are divided by the pivot, where
//! `getf2` multiplies by the reciprocal: the same to round-off). A matrix with a non-finite
//! entry is refused as singular: skipping a zero times a NaN would otherwise hide it. (History: nalgebra's LU took
//! 37 % of a multibody diagnosis; faer's dense LU was measured slower still at these sizes.)

use nalgebra::{DMatrix, DVector};

/// The LU factorisation of a square matrix, P·A = L·U (L unit lower triangular).
#[derive(Debug, Clone)]
pub struct DenseLu {
    n: usize,
    /// L below the diagonal and U on and above it, column-major (entry (i, j) at i + j·n).
    lu: Vec<f64>,
    /// Row interchanges: at step k, row k was swapped with row `swaps[k]` (≥ k).
    swaps: Vec<usize>,
    /// A pivot column was exactly zero on and below the diagonal: solves give None.
    singular: bool,
}

impl DenseLu {
    /// Factorises square `a` (None if it is not square). A matrix with an exactly zero pivot
    /// or a non-finite entry factorises and its solves come out None; a nearly singular one gives finite but
    /// inaccurate solves — callers test the backward error where it matters.
    pub fn new(a: &DMatrix<f64>) -> Option<Self> {
        if !a.is_square() {
            return None;
        }
        let n = a.nrows();
        // nalgebra stores column-major: the same layout as `lu`.
        let mut lu = Self {
            n,
            lu: a.as_slice().to_vec(),
            swaps: (0..n).collect(),
            singular: false,
        };
        if lu.lu.iter().all(|v| v.is_finite()) {
            lu.factorise();
        } else {
            lu.singular = true;
        }
        Some(lu)
    }

    /// Order of the matrix.
    pub fn order(&self) -> usize {
        self.n
    }

    fn factorise(&mut self) {
        let n = self.n;
        let a = &mut self.lu;
        // Rows (below the diagonal) where the current pivot column's multiplier is nonzero.
        let mut rows: Vec<usize> = Vec::with_capacity(n);
        for k in 0..n {
            let col = k * n;
            let mut p = k;
            let mut big = a[col + k].abs();
            for (i, v) in a[col + k + 1..col + n].iter().enumerate() {
                // `>` keeps the first largest, as LAPACK's idamax (the entries are finite).
                if v.abs() > big {
                    big = v.abs();
                    p = k + 1 + i;
                }
            }
            self.swaps[k] = p;
            if big == 0.0 {
                // Nothing to eliminate in this column: U's diagonal entry is zero.
                self.singular = true;
                continue;
            }
            if p != k {
                for c in a.chunks_exact_mut(n) {
                    c.swap(k, p);
                }
            }
            let (done, rest) = a.split_at_mut(col + n);
            let pivot_col = &mut done[col..];
            let pivot = pivot_col[k];
            rows.clear();
            for (i, v) in pivot_col.iter_mut().enumerate().skip(k + 1) {
                if *v != 0.0 {
                    *v /= pivot;
                    rows.push(i);
                }
            }
            if rows.is_empty() {
                continue;
            }
            for c in rest.chunks_exact_mut(n) {
                let u = c[k];
                if u == 0.0 {
                    continue;
                }
                for &i in &rows {
                    c[i] -= pivot_col[i] * u;
                }
            }
        }
    }

    /// x with A·x = b; None where b has the wrong length or A is singular (x not finite).
    pub fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let n = self.n;
        if b.len() != n || self.singular {
            return None;
        }
        let mut x = b.clone();
        if n == 0 {
            return Some(x);
        }
        let xs = x.as_mut_slice();
        for (k, &p) in self.swaps.iter().enumerate() {
            xs.swap(k, p);
        }
        // L·y = P·b, L unit lower triangular, by columns.
        for (k, col) in self.lu.chunks_exact(n).enumerate() {
            let xk = xs[k];
            if xk != 0.0 {
                for (xi, l) in xs[k + 1..].iter_mut().zip(&col[k + 1..]) {
                    *xi -= l * xk;
                }
            }
        }
        // U·x = y, by columns from the last.
        for (k, col) in self.lu.chunks_exact(n).enumerate().rev() {
            xs[k] /= col[k];
            let xk = xs[k];
            if xk != 0.0 {
                for (xi, u) in xs[..k].iter_mut().zip(&col[..k]) {
                    *xi -= u * xk;
                }
            }
        }
        xs.iter().all(|v| v.is_finite()).then_some(x)
    }

    /// x with Aᵀ·x = b (Aᵀ = Uᵀ·Lᵀ·P: x = Pᵀ·L⁻ᵀ·U⁻ᵀ·b); None as for [`solve`](Self::solve).
    pub fn solve_transpose(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let n = self.n;
        if b.len() != n || self.singular {
            return None;
        }
        let mut x = b.clone();
        if n == 0 {
            return Some(x);
        }
        let xs = x.as_mut_slice();
        // Uᵀ·y = b: row k of Uᵀ is column k of U above the diagonal.
        for (k, col) in self.lu.chunks_exact(n).enumerate() {
            let s: f64 = col[..k].iter().zip(&xs[..k]).map(|(u, y)| u * y).sum();
            xs[k] = (xs[k] - s) / col[k];
        }
        // Lᵀ·z = y: row k of Lᵀ is column k of L below the diagonal.
        for (k, col) in self.lu.chunks_exact(n).enumerate().rev() {
            let s: f64 = col[k + 1..].iter().zip(&xs[k + 1..]).map(|(l, z)| l * z).sum();
            xs[k] -= s;
        }
        // x = Pᵀ·z: the interchanges undone in reverse order.
        for (k, &p) in self.swaps.iter().enumerate().rev() {
            xs.swap(k, p);
        }
        xs.iter().all(|v| v.is_finite()).then_some(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against nalgebra's LU on a non-symmetric system that needs pivoting: A·x = b and
    /// Aᵀ·y = b; a singular matrix gives None.
    #[test]
    fn solves_with_the_matrix_and_its_transpose() {
        let a = DMatrix::from_row_slice(3, 3, &[0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 4.0]);
        let b = DVector::from_vec(vec![1.0, -2.0, 0.5]);
        let lu = DenseLu::new(&a).unwrap();
        let x = lu.solve(&b).unwrap();
        assert!((&a * &x - &b).amax() < 1e-14, "{x}");
        let y = lu.solve_transpose(&b).unwrap();
        assert!((a.transpose() * &y - &b).amax() < 1e-14, "{y}");
        let want = a.clone().lu().solve(&b).unwrap();
        assert!((x - want).amax() < 1e-14);
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 4.0]);
        let s = DenseLu::new(&singular).unwrap();
        assert!(s.solve(&DVector::from_vec(vec![1.0, 1.0])).is_none());
        assert!(s.solve_transpose(&DVector::from_vec(vec![1.0, 1.0])).is_none());
        assert!(DenseLu::new(&DMatrix::zeros(2, 3)).is_none());
        assert!(lu.solve(&DVector::zeros(2)).is_none());
    }

    /// On sparse matrices with many exact zeros (where the elimination skips work) of
    /// several sizes, against nalgebra's LU: the same solutions to round-off, for A and Aᵀ,
    /// and a zero column found singular.
    #[test]
    fn sparse_matrices_agree_with_nalgebra() {
        // A small deterministic generator (no test depends on a random crate's stream).
        let mut s: u64 = 0x2545_f491_4f6c_dd1d;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for n in [1usize, 2, 5, 17, 60] {
            let mut a = DMatrix::zeros(n, n);
            for i in 0..n {
                // A diagonal that need not be the pivot, and a few off-diagonal entries.
                a[(i, i)] = 0.1 + next();
                for _ in 0..3 {
                    let j = (next() * n as f64) as usize % n;
                    a[(i, j)] += 4.0 * next() - 2.0;
                }
            }
            let b = DVector::from_fn(n, |i, _| (i as f64).sin() + 0.5);
            let lu = DenseLu::new(&a).unwrap();
            assert_eq!(lu.order(), n);
            let x = lu.solve(&b).unwrap();
            let y = lu.solve_transpose(&b).unwrap();
            let want_x = a.clone().lu().solve(&b).unwrap();
            let want_y = a.transpose().lu().solve(&b).unwrap();
            let scale = 1.0 + want_x.amax() + want_y.amax();
            assert!((&x - &want_x).amax() < 1e-10 * scale, "n = {n}");
            assert!((&y - &want_y).amax() < 1e-10 * scale, "n = {n}");
            if n > 1 {
                let mut z = a.clone();
                z.column_mut(n / 2).fill(0.0);
                assert!(DenseLu::new(&z).unwrap().solve(&b).is_none(), "n = {n}");
            }
        }
        // A NaN or an infinity anywhere makes the solves None, even where the elimination
        // would only have multiplied it by zero (upper and lower triangle).
        for (a, b) in [
            ([1.0, f64::NAN, 0.0, 1.0], [1.0, 0.0]),
            ([1.0, 0.0, f64::NAN, 1.0], [0.0, 1.0]),
            ([1.0, f64::INFINITY, 0.0, 1.0], [1.0, 0.0]),
        ] {
            let lu = DenseLu::new(&DMatrix::from_row_slice(2, 2, &a)).unwrap();
            let b = DVector::from_column_slice(&b);
            assert!(
                lu.solve(&b).is_none() && lu.solve_transpose(&b).is_none(),
                "{a:?}"
            );
        }
    }
}
