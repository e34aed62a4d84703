//! Dense LU with partial pivoting on nalgebra matrices: one factorisation solves with both A
//! and Aᵀ. The multibody analyses solve with the velocity Jacobian B for the accelerations
//! and with Bᵀ for the multipliers λ = B⁻ᵀ·r; the transposed solve spares the second
//! factorisation that took. (faer's dense LU was measured slower at these sizes — some 70
//! unknowns for the MR2120's ideal model: the reduced multibody suite's null case 95 s
//! against 89 s with nalgebra's, one run each, 2026-11-27.)

use nalgebra::{DMatrix, DVector, Dyn, LU};
use std::cell::OnceCell;

/// The LU factorisation of a square matrix, P·A = L·U.
pub struct DenseLu {
    lu: LU<f64, Dyn, Dyn>,
    n: usize,
    /// L and U, taken out at the first transposed solve.
    factors: OnceCell<(DMatrix<f64>, DMatrix<f64>)>,
}

impl DenseLu {
    /// Factorises square `a` (None if it is not square). A matrix with an exactly zero pivot
    /// factorises and its solves come out None; a nearly singular one gives finite but
    /// inaccurate solves — callers test the backward error where it matters.
    pub fn new(a: &DMatrix<f64>) -> Option<Self> {
        a.is_square().then(|| Self {
            lu: a.clone().lu(),
            n: a.nrows(),
            factors: OnceCell::new(),
        })
    }

    /// x with A·x = b; None where b has the wrong length or A is singular (x not finite).
    pub fn solve(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        if b.len() != self.n {
            return None;
        }
        self.lu.solve(b).filter(|x| x.iter().all(|v| v.is_finite()))
    }

    /// x with Aᵀ·x = b (Aᵀ = Uᵀ·Lᵀ·P: x = Pᵀ·L⁻ᵀ·U⁻ᵀ·b); None as for [`solve`](Self::solve).
    pub fn solve_transpose(&self, b: &DVector<f64>) -> Option<DVector<f64>> {
        let (l, u) = self.factors.get_or_init(|| (self.lu.l(), self.lu.u()));
        if b.len() != self.n {
            return None;
        }
        let mut x = b.clone();
        if !u.tr_solve_upper_triangular_mut(&mut x) || !l.tr_solve_lower_triangular_mut(&mut x) {
            return None;
        }
        self.lu.p().inv_permute_rows(&mut x);
        x.iter().all(|v| v.is_finite()).then_some(x)
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
        assert!(DenseLu::new(&singular)
            .unwrap()
            .solve(&DVector::from_vec(vec![1.0, 1.0]))
            .is_none());
        assert!(DenseLu::new(&DMatrix::zeros(2, 3)).is_none());
    }
}
