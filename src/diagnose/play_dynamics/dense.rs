//! Small dense linear algebra for the play model's substeps: products with nalgebra's
//! arithmetic on slices, the play block's Schur complement and its fixed-size LU.

use super::NP;
use nalgebra::{DMatrix, DVector, SMatrix};

/// y ← α·A·x + β·y for the column-major `a` (rows: y's length), with nalgebra's `gemv`'s
/// arithmetic — column by column, y_i = (α·a_ij)·x_j + β·y_i with β on the first column only
/// and y not read when β = 0 — so the results are the same to the bit, on slices the
/// compiler vectorises (the play model's substeps, most of a bearing diagnosis).
pub(super) fn gemv(y: &mut [f64], alpha: f64, a: &[f64], x: &[f64], beta: f64) {
    gemv_block(y, alpha, a, y.len(), x, beta);
}

/// [`gemv`] with the block of a column-major matrix whose leading dimension is `lda`, from
/// `a`'s first entry: column j is `a[j·lda..j·lda + y.len()]`.
pub(super) fn gemv_block(y: &mut [f64], alpha: f64, a: &[f64], lda: usize, x: &[f64], beta: f64) {
    let n = y.len();
    debug_assert!(x.is_empty() || a.len() >= (x.len() - 1) * lda + n);
    for (j, &xj) in x.iter().enumerate() {
        let col = &a[j * lda..j * lda + n];
        if j > 0 {
            y.iter_mut()
                .zip(col)
                .for_each(|(yi, &aij)| *yi += alpha * aij * xj);
        } else if beta == 0.0 {
            y.iter_mut()
                .zip(col)
                .for_each(|(yi, &aij)| *yi = alpha * aij * xj);
        } else {
            y.iter_mut()
                .zip(col)
                .for_each(|(yi, &aij)| *yi = alpha * aij * xj + beta * *yi);
        }
    }
}

/// The size m of the leading block of the square, column-major matrices `mats` outside of
/// which every entry is zero (the play model's stiffness and damping act on the drives and the
/// play coordinates, not on the cross's).
pub(super) fn leading_block(n: usize, mats: &[&DMatrix<f64>]) -> usize {
    (0..=n)
        .find(|&m| {
            mats.iter()
                .all(|a| (0..n).all(|j| (0..n).all(|i| (i < m && j < m) || a[(i, j)] == 0.0)))
        })
        .unwrap_or(n)
}

/// The smallest m (0 < m < n) such that the square `a` is zero outside its leading m × m
/// block and the trailing block after it; 0 when there is none.
pub(super) fn two_blocks(a: &DMatrix<f64>) -> usize {
    let n = a.nrows();
    (1..n)
        .find(|&m| (0..m).all(|i| (m..n).all(|j| a[(i, j)] == 0.0 && a[(j, i)] == 0.0)))
        .unwrap_or(0)
}

/// y ← α·A·x + β·y (as [`gemv`], to the bit for finite x) for a square `a` that is zero
/// outside its leading m × m block and the trailing block after it.
pub(super) fn gemv_two_blocks(y: &mut [f64], alpha: f64, a: &[f64], m: usize, x: &[f64], beta: f64) {
    let n = y.len();
    if m == 0 || m == n {
        return gemv(y, alpha, a, x, beta);
    }
    let (y1, y2) = y.split_at_mut(m);
    gemv_block(y1, alpha, a, n, &x[..m], beta);
    gemv_block(y2, alpha, &a[m * n + m..], n, &x[m..], beta);
}

/// x ← x + dt·v (nalgebra's `axpy(dt, v, 1)`, the same arithmetic).
pub(super) fn step_positions(x: &mut [f64], dt: f64, v: &[f64]) {
    for (xi, &vi) in x.iter_mut().zip(v) {
        *xi += dt * vi;
    }
}

/// The symmetric part of `m`.
pub(super) fn sym(m: &DMatrix<f64>) -> DMatrix<f64> {
    (m + m.transpose()) * 0.5
}

/// The largest eigenvalue of M⁻¹·A for a symmetric A (of the symmetric part of the mass
/// `mass`, through its Cholesky factor L: of L⁻¹·A·L⁻ᵀ), as a function of A; None if the
/// mass is not positive definite.
pub(super) fn largest_by_mass(mass: &DMatrix<f64>) -> Option<impl Fn(DMatrix<f64>) -> f64> {
    let linv = sym(mass).cholesky()?.l().try_inverse()?;
    Some(move |m: DMatrix<f64>| {
        let a = sym(&(&linv * m * linv.transpose()));
        a.symmetric_eigenvalues().iter().fold(0.0f64, |x, &v| x.max(v))
    })
}

/// The implicit substep's matrix A = B + dt·C_c, B = M + dt·C held over a sample interval and
/// the contacts' damping C_c on the play and cross coordinates only (the last [`NP`]): the
/// drives' block B₁₁ is eliminated once per interval, and each substep in contact factorises
/// only the play block's Schur complement S = B₂₂ − B₂₁·B₁₁⁻¹·B₁₂ + dt·C_c, a fixed-size
/// [`NP`] × [`NP`] LU on the stack instead of a dense LU of all the unknowns. With
/// z = B₁₁⁻¹·r₁: S·y = r₂ − B₂₁·z, then x₁ = z − B₁₁⁻¹·B₁₂·y.
pub(super) struct PlaySchur {
    /// B₁₁⁻¹ (drives × drives).
    pub(super) b11_inv: DMatrix<f64>,
    /// B₂₁ (play × drives).
    pub(super) b21: DMatrix<f64>,
    /// B₁₁⁻¹·B₁₂ (drives × play).
    pub(super) q: DMatrix<f64>,
    /// B₂₂ − B₂₁·B₁₁⁻¹·B₁₂.
    pub(super) s0: SMatrix<f64, NP, NP>,
    /// z = B₁₁⁻¹·r₁ (drives).
    pub(super) z: DVector<f64>,
    /// The factors of S + w·C_c of the last [`factor`](Self::factor), and its swaps.
    pub(super) lu: [[f64; NP]; NP],
    pub(super) swaps: Swaps,
}

impl PlaySchur {
    /// The elimination in `slot`, made there from `b` on first use ([`new`](Self::new)).
    pub(super) fn of<'a>(slot: &'a mut Option<Self>, b: &DMatrix<f64>, nj: usize) -> Option<&'a mut Self> {
        if slot.is_none() {
            *slot = Some(Self::new(b, nj)?);
        }
        slot.as_mut()
    }

    /// The elimination of `b`'s first `nj` unknowns; None if their block is singular.
    pub(super) fn new(b: &DMatrix<f64>, nj: usize) -> Option<Self> {
        let b11_inv = b.view((0, 0), (nj, nj)).clone_owned().try_inverse()?;
        let b12 = b.view((0, nj), (nj, NP));
        let b21 = b.view((nj, 0), (NP, nj)).clone_owned();
        let q = &b11_inv * b12;
        let s0 = SMatrix::<f64, NP, NP>::from_fn(|r, c| {
            b[(nj + r, nj + c)] - (0..nj).map(|k| b21[(r, k)] * q[(k, c)]).sum::<f64>()
        });
        Some(Self {
            b11_inv,
            b21,
            q,
            s0,
            z: DVector::zeros(nj),
            lu: [[0.0; NP]; NP],
            swaps: ([(0, 0); NP], 0),
        })
    }

    /// Solves (B + dt·C_c)·Δv = `rhs` into `dv`, C_c = `cc` on the play block; None if the
    /// Schur complement is singular.
    pub(super) fn solve(
        &mut self,
        cc: &[[f64; NP]; NP],
        dt: f64,
        rhs: &DVector<f64>,
        dv: &mut DVector<f64>,
    ) -> Option<()> {
        self.factor(cc, dt);
        self.solve_factored(rhs, dv)
    }

    /// Factorises S = B₂₂ − B₂₁·B₁₁⁻¹·B₁₂ + w·`cc` for [`solve_factored`](Self::solve_factored).
    pub(super) fn factor(&mut self, cc: &[[f64; NP]; NP], w: f64) {
        self.lu = std::array::from_fn(|c| std::array::from_fn(|r| self.s0[(r, c)] + w * cc[r][c]));
        self.swaps = lu_factor(&mut self.lu);
    }

    /// [`solve`](Self::solve) with the factors of the last [`factor`](Self::factor).
    pub(super) fn solve_factored(&mut self, rhs: &DVector<f64>, dv: &mut DVector<f64>) -> Option<()> {
        let nj = self.b11_inv.nrows();
        let (r1, r2) = rhs.as_slice().split_at(nj);
        gemv(self.z.as_mut_slice(), 1.0, self.b11_inv.as_slice(), r1, 0.0);
        let mut y: [f64; NP] = std::array::from_fn(|r| r2[r]);
        gemv(&mut y, -1.0, self.b21.as_slice(), self.z.as_slice(), 1.0);
        if !lu_apply(&self.lu, &self.swaps, &mut y) {
            return None;
        }
        let (x1, x2) = dv.as_mut_slice().split_at_mut(nj);
        x1.copy_from_slice(self.z.as_slice());
        gemv(x1, -1.0, self.q.as_slice(), &y, 1.0);
        x2.copy_from_slice(&y);
        Some(())
    }
}

/// Solves A·x = `b` in place (`b` becomes x) for the [`NP`] × [`NP`] matrix `a`, given by
/// columns (a[c][r]) and overwritten by its factors: the LU with partial pivoting of
/// nalgebra's `LU::new` and `solve_mut` for fixed-size matrices, their operations in their
/// order (the first largest |entry| as the pivot, a column of zeros skipped, the multipliers
/// scaled by the pivot's reciprocal), so the result is theirs to the bit, without their
/// generic views — the implicit substep's solve, in the play model's innermost loop. False
/// where a pivot is zero.
#[cfg(test)]
pub(super) fn lu_solve(a: &mut [[f64; NP]; NP], b: &mut [f64; NP]) -> bool {
    let swaps = lu_factor(a);
    lu_apply(a, &swaps, b)
}

/// The row swaps of [`lu_factor`]: the pairs, and how many.
pub(super) type Swaps = ([(usize, usize); NP], usize);

/// The factorisation of `lu_solve`, in place: `a` becomes its factors.
pub(super) fn lu_factor(a: &mut [[f64; NP]; NP]) -> Swaps {
    let mut swaps = [(0usize, 0usize); NP];
    let mut nswaps = 0;
    for i in 0..NP {
        let mut piv = i;
        let mut largest = a[i][i].abs();
        for r in i + 1..NP {
            let v = a[i][r].abs();
            if v > largest {
                largest = v;
                piv = r;
            }
        }
        let diag = a[i][piv];
        if diag == 0.0 {
            continue;
        }
        if piv != i {
            swaps[nswaps] = (i, piv);
            nswaps += 1;
            for col in a.iter_mut().take(i) {
                col.swap(i, piv);
            }
            a[i].swap(i, piv);
        }
        let inv_diag = 1.0 / diag;
        for v in &mut a[i][i + 1..] {
            *v *= inv_diag;
        }
        let (left, right) = a.split_at_mut(i + 1);
        let coeffs = &left[i];
        for col in right.iter_mut() {
            if piv != i {
                col.swap(i, piv);
            }
            let p = -col[i];
            for (v, &c) in col[i + 1..].iter_mut().zip(&coeffs[i + 1..]) {
                *v += p * c;
            }
        }
    }
    (swaps, nswaps)
}

/// The solve of `lu_solve` with the factors of [`lu_factor`]: `b` becomes x; false where
/// a pivot is zero.
pub(super) fn lu_apply(a: &[[f64; NP]; NP], (swaps, nswaps): &Swaps, b: &mut [f64; NP]) -> bool {
    for &(i1, i2) in &swaps[..*nswaps] {
        b.swap(i1, i2);
    }
    // L (unit diagonal), then U.
    for i in 0..NP - 1 {
        let coeff = -b[i];
        for r in i + 1..NP {
            b[r] += coeff * a[i][r];
        }
    }
    for i in (0..NP).rev() {
        let diag = a[i][i];
        if diag == 0.0 {
            return false;
        }
        let coeff = b[i] / diag;
        b[i] = coeff;
        for r in 0..i {
            b[r] += -coeff * a[i][r];
        }
    }
    true
}
