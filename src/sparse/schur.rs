//! Block elimination before the sparse LU: small diagonal blocks of unknowns are eliminated
//! exactly (a dense inverse each), and the Schur complement on the remaining unknowns is
//! factorised with [`RefactorLu`] (its pivot sequence reused while it stays acceptable).
//!
//! For a matrix partitioned into eliminated unknowns E (the union of the given groups; rows
//! and columns share the indices) and kept unknowns R,
//!
//! ```text
//! [ A_EE  A_ER ] [x_E]   [b_E]        S = A_RR − A_RE·A_EE⁻¹·A_ER
//! [ A_RE  A_RR ] [x_R] = [b_R],       S·x_R = b_R − A_RE·A_EE⁻¹·b_E,   x_E = A_EE⁻¹·(b_E − A_ER·x_R).
//! ```
//!
//! A_EE is taken block diagonal, one dense block per group: **entries coupling two different
//! groups are left out** of the factorisation (the solve is then that of a nearby matrix,
//! which a Newton iteration tolerates). The caller declares groups whose mutual coupling is
//! absent or vanishes at the solution — for the multibody GGL equations, each body's
//! kinematic and normalisation rows with its positions and normalisation multiplier, coupled
//! to other bodies only through stabilisation multipliers μ that are zero on the solution.
//!
//! When a block is singular (for example in a consistent-initialisation matrix, where a
//! group's rows hold derivatives that are not invertible on their own), the whole matrix is
//! factorised with a plain [`SparseLu`] instead, built on first use; its results are then
//! exact for the given values, cross-group entries included.

use super::{CscPattern, LinearSolveError, RefactorLu, SlotIndex, SparseLu};

/// Largest group (unknowns per eliminated block) accepted: blocks are inverted densely.
pub const MAX_GROUP: usize = 32;

/// One eliminated block and its couplings, with the addresses into the matrix values and the
/// reduced matrix computed once from the patterns.
#[derive(Debug, Clone)]
struct Group {
    /// Unknowns (= rows) of the block, full indices.
    idx: Vec<usize>,
    /// Block entries: (position in the values, local row · g + local column).
    ee: Vec<(u32, u32)>,
    /// A_RE entries: (position in the values, position in `u`: index into `urows` · g +
    /// local column).
    re: Vec<(u32, u32)>,
    /// A_ER entries: (position in the values, position in the block's V: index into
    /// `vcols` · g + local row); stored, like `w`, column after column.
    er: Vec<(u32, u32)>,
    /// Kept rows coupled to the block (reduced indices).
    urows: Vec<usize>,
    /// Kept columns coupled to the block (reduced indices).
    vcols: Vec<usize>,
    /// Position in the reduced values of S(urows[i], vcols[j]), row-major (i · nv + j).
    slots: Vec<u32>,
    /// A_EE⁻¹ of the block (g × g, row-major).
    inv: Vec<f64>,
    /// A_RE restricted to the block (nu × g, row-major).
    u: Vec<f64>,
    /// A_EE⁻¹·A_ER restricted to the block, one column after the other (nv × g: column j
    /// of the product is `w[j·g..(j+1)·g]`).
    w: Vec<f64>,
    /// A_EE⁻¹·b_E of the current solve (g).
    y: Vec<f64>,
}

/// Sparse LU of a square matrix after eliminating small diagonal blocks (see the
/// module documentation in `src/sparse/schur.rs`).
#[derive(Debug)]
pub struct BlockSchurLu {
    pattern: CscPattern,
    groups: Vec<Group>,
    /// Full index of each kept unknown.
    kept: Vec<usize>,
    /// A_RR entries: (position in the values, position in the reduced values).
    rr: Vec<(u32, u32)>,
    s_values: Vec<f64>,
    s_lu: RefactorLu,
    /// Reduced right-hand side.
    work: Vec<f64>,
    /// Scratch for one block's dense work (g × g and g × nv).
    scratch: Vec<f64>,
    /// Plain LU of the whole matrix, for values with a singular block.
    full: Option<SparseLu>,
    /// The last factorisation is the plain one.
    using_full: bool,
    factored: bool,
}

impl BlockSchurLu {
    /// Analyses `pattern` (square) with the eliminated `groups` (disjoint sets of unknowns,
    /// each of at most [`MAX_GROUP`]); with no groups it is a plain [`RefactorLu`].
    pub fn new(pattern: &CscPattern, groups: &[Vec<usize>]) -> Result<Self, LinearSolveError> {
        let n = pattern.ncols();
        if pattern.nrows() != n {
            return Err(LinearSolveError::NotSquare {
                nrows: pattern.nrows(),
                ncols: n,
            });
        }
        // Group of each unknown (usize::MAX: kept) and its place in the group.
        let mut group_of = vec![usize::MAX; n];
        let mut local = vec![0usize; n];
        for (g, idx) in groups.iter().enumerate() {
            if idx.is_empty() || idx.len() > MAX_GROUP {
                return Err(LinearSolveError::InvalidBlocks(format!(
                    "group {g} has {} unknowns (1 to {MAX_GROUP} allowed)",
                    idx.len()
                )));
            }
            for (l, &i) in idx.iter().enumerate() {
                if i >= n {
                    return Err(LinearSolveError::InvalidBlocks(format!(
                        "group {g} names unknown {i} of a {n}-unknown system"
                    )));
                }
                if group_of[i] != usize::MAX {
                    return Err(LinearSolveError::InvalidBlocks(format!(
                        "unknown {i} is in groups {} and {g}",
                        group_of[i]
                    )));
                }
                group_of[i] = g;
                local[i] = l;
            }
        }
        let kept: Vec<usize> = (0..n).filter(|&i| group_of[i] == usize::MAX).collect();
        let mut reduced = vec![usize::MAX; n];
        for (k, &i) in kept.iter().enumerate() {
            reduced[i] = k;
        }
        // Positions and addresses are kept as u32 (the elimination streams through them
        // at every factorisation: half the memory traffic of usize at large N).
        let nnz = pattern.nnz();
        let narrow = |v: usize| {
            u32::try_from(v).map_err(|_| LinearSolveError::TooLarge {
                unknowns: n,
                entries: v.max(nnz),
            })
        };
        narrow(pattern.nnz())?;
        // Per group, while analysing: block, A_RE and A_ER entries with full indices.
        type Entries = (
            Vec<(usize, usize)>,
            Vec<(usize, usize, usize)>,
            Vec<(usize, usize, usize)>,
        );
        let mut entries: Vec<Entries> = vec![(vec![], vec![], vec![]); groups.len()];
        let mut gs: Vec<Group> = groups
            .iter()
            .map(|idx| Group {
                idx: idx.clone(),
                ee: vec![],
                re: vec![],
                er: vec![],
                urows: vec![],
                vcols: vec![],
                slots: vec![],
                inv: vec![0.0; idx.len() * idx.len()],
                u: vec![],
                w: vec![],
                y: vec![0.0; idx.len()],
            })
            .collect();
        let mut rr_entries = Vec::new();
        // First pass: classify the entries; A_RE rows and A_ER columns by full index.
        for c in 0..n {
            for k in pattern.col_range(c) {
                let r = pattern.row_idx()[k];
                match (group_of[r], group_of[c]) {
                    (usize::MAX, usize::MAX) => rr_entries.push((k, reduced[r], reduced[c])),
                    (gr, gc) if gr == gc => {
                        entries[gr].0.push((k, local[r] * groups[gr].len() + local[c]));
                    }
                    (usize::MAX, gc) => entries[gc].1.push((k, r, local[c])),
                    (gr, usize::MAX) => entries[gr].2.push((k, local[r], c)),
                    // Coupling between two blocks: left out (see the module docs).
                    _ => {}
                }
            }
        }
        let mut s_entries: Vec<(usize, usize)> = rr_entries.iter().map(|&(_, r, c)| (r, c)).collect();
        s_entries.extend((0..kept.len()).map(|i| (i, i)));
        for (g, (ee, re, er)) in gs.iter_mut().zip(&entries) {
            let m = g.idx.len();
            let mut urows: Vec<usize> = re.iter().map(|e| reduced[e.1]).collect();
            urows.sort_unstable();
            urows.dedup();
            let mut vcols: Vec<usize> = er.iter().map(|e| reduced[e.2]).collect();
            vcols.sort_unstable();
            vcols.dedup();
            for &(k, l) in ee {
                g.ee.push((narrow(k)?, narrow(l)?));
            }
            for &(k, r, l) in re {
                let i = urows.binary_search(&reduced[r]).expect("row listed");
                g.re.push((narrow(k)?, narrow(i * m + l)?));
            }
            for &(k, l, c) in er {
                let j = vcols.binary_search(&reduced[c]).expect("column listed");
                g.er.push((narrow(k)?, narrow(j * m + l)?));
            }
            for &r in &urows {
                for &c in &vcols {
                    s_entries.push((r, c));
                }
            }
            g.u = vec![0.0; urows.len() * g.idx.len()];
            g.w = vec![0.0; g.idx.len() * vcols.len()];
            g.urows = urows;
            g.vcols = vcols;
        }
        let s_pattern = CscPattern::from_entries(kept.len(), kept.len(), s_entries)
            .map_err(|e| LinearSolveError::InvalidBlocks(e.to_string()))?;
        let slot = SlotIndex::new(&s_pattern);
        let at = |r: usize, c: usize| slot.get(r, c).expect("entry is in the reduced pattern");
        let rr = rr_entries
            .iter()
            .map(|&(k, r, c)| Ok((narrow(k)?, narrow(at(r, c))?)))
            .collect::<Result<_, LinearSolveError>>()?;
        let mut scratch_len = 0;
        for g in gs.iter_mut() {
            g.slots = g
                .urows
                .iter()
                .flat_map(|&r| g.vcols.iter().map(move |&c| (r, c)))
                .map(|(r, c)| narrow(at(r, c)))
                .collect::<Result<_, _>>()?;
            scratch_len = scratch_len.max(g.idx.len() * (g.idx.len() + g.vcols.len()));
        }
        let s_lu = RefactorLu::new(&s_pattern)?;
        Ok(Self {
            pattern: pattern.clone(),
            groups: gs,
            work: vec![0.0; kept.len()],
            kept,
            rr,
            s_values: vec![0.0; s_pattern.nnz()],
            s_lu,
            scratch: vec![0.0; scratch_len],
            full: None,
            using_full: false,
            factored: false,
        })
    }

    /// Unknowns left after the elimination (the order of the sparse LU).
    pub fn reduced_dim(&self) -> usize {
        self.kept.len()
    }

    /// Whether the last factorisation fell back to the plain LU (a singular block).
    pub fn used_plain_lu(&self) -> bool {
        self.using_full
    }

    /// Factorises the matrix with `values` on the pattern given to [`new`](Self::new).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        self.factored = false;
        self.using_full = false;
        super::lu::check_values(&self.pattern, values)?;
        self.s_values.iter_mut().for_each(|v| *v = 0.0);
        for &(k, s) in &self.rr {
            self.s_values[s as usize] += values[k as usize];
        }
        for g in self.groups.iter_mut() {
            let m = g.idx.len();
            let nv = g.vcols.len();
            let (block, v) = self.scratch[..m * (m + nv)].split_at_mut(m * m);
            block.iter_mut().for_each(|x| *x = 0.0);
            for &(k, l) in &g.ee {
                block[l as usize] = values[k as usize];
            }
            if !invert_in_place(block, &mut g.inv, m) {
                return self.factor_plain(values);
            }
            g.u.iter_mut().for_each(|x| *x = 0.0);
            for &(k, d) in &g.re {
                g.u[d as usize] = values[k as usize];
            }
            v.iter_mut().for_each(|x| *x = 0.0);
            for &(k, d) in &g.er {
                v[d as usize] = values[k as usize];
            }
            // W = A_EE⁻¹·V, column by column.
            for (wj, vj) in g.w.chunks_exact_mut(m).zip(v.chunks_exact(m)) {
                for (wl, inv_l) in wj.iter_mut().zip(g.inv.chunks_exact(m)) {
                    *wl = dot(inv_l, vj);
                }
            }
            // S −= U·W.
            for (ui, slots) in g.u.chunks_exact(m).zip(g.slots.chunks_exact(nv.max(1))) {
                for (wj, &slot) in g.w.chunks_exact(m).zip(slots) {
                    self.s_values[slot as usize] -= dot(ui, wj);
                }
            }
        }
        match self.s_lu.factor(&self.s_values) {
            Ok(()) => {
                self.factored = true;
                Ok(())
            }
            Err(LinearSolveError::Singular { column }) => Err(LinearSolveError::Singular {
                column: column.map(|c| self.kept[c]),
            }),
            Err(e) => Err(e),
        }
    }

    fn factor_plain(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        if self.full.is_none() {
            self.full = Some(SparseLu::new(&self.pattern)?);
        }
        let full = self.full.as_mut().expect("built above");
        full.factor(values)?;
        self.using_full = true;
        self.factored = true;
        Ok(())
    }

    /// Solves A·x = b in place (`b` becomes `x`) with the current factors.
    pub fn solve_in_place(&mut self, b: &mut [f64]) -> Result<(), LinearSolveError> {
        if !self.factored {
            return Err(LinearSolveError::Singular { column: None });
        }
        if b.len() != self.pattern.ncols() {
            return Err(LinearSolveError::DimensionMismatch {
                expected: self.pattern.ncols(),
                got: b.len(),
            });
        }
        if self.using_full {
            return self.full.as_mut().expect("factored").solve_in_place(b);
        }
        for (k, &i) in self.kept.iter().enumerate() {
            self.work[k] = b[i];
        }
        for g in self.groups.iter_mut() {
            let m = g.idx.len();
            let be = &mut self.scratch[..m];
            for (x, &i) in be.iter_mut().zip(&g.idx) {
                *x = b[i];
            }
            for (yl, inv_l) in g.y.iter_mut().zip(g.inv.chunks_exact(m)) {
                *yl = dot(inv_l, be);
            }
            for (ui, &r) in g.u.chunks_exact(m).zip(&g.urows) {
                self.work[r] -= dot(ui, &g.y);
            }
        }
        self.s_lu.solve_in_place(&mut self.work)?;
        for (k, &i) in self.kept.iter().enumerate() {
            b[i] = self.work[k];
        }
        for g in &self.groups {
            let m = g.idx.len();
            let xe = &mut self.scratch[..m];
            xe.copy_from_slice(&g.y);
            for (wj, &c) in g.w.chunks_exact(m).zip(&g.vcols) {
                let xc = self.work[c];
                for (x, w) in xe.iter_mut().zip(wj) {
                    *x -= w * xc;
                }
            }
            for (&x, &i) in xe.iter().zip(&g.idx) {
                b[i] = x;
            }
        }
        if b.iter().any(|v| !v.is_finite()) {
            return Err(LinearSolveError::Singular { column: None });
        }
        Ok(())
    }
}

/// Σ a_i·b_i over two slices of equal length, in four independent partial sums (a single
/// running sum is a chain of dependent additions that cannot be vectorised).
#[inline]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let (ac, bc) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ac
        .remainder()
        .iter()
        .zip(bc.remainder())
        .map(|(x, y)| x * y)
        .sum();
    let mut acc = [0.0; 4];
    for (x, y) in ac.zip(bc) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Inverts the m × m row-major matrix `a` into `inv` by Gauss–Jordan elimination with
/// partial pivoting (`a` is overwritten). Returns `false` when a pivot is below
/// m·ε·max|a|: the block is singular to working precision. The multibody blocks (m = 8: a
/// body's positions and normalisation multiplier) get the elimination compiled for that
/// size.
fn invert_in_place(a: &mut [f64], inv: &mut [f64], m: usize) -> bool {
    match m {
        // The same code inlined with m a constant, so the compiler unrolls its loops.
        8 => gauss_jordan(a, inv, 8),
        _ => gauss_jordan(a, inv, m),
    }
}

#[inline(always)]
fn gauss_jordan(a: &mut [f64], inv: &mut [f64], m: usize) -> bool {
    let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
    if scale == 0.0 {
        return false;
    }
    let tiny = m as f64 * f64::EPSILON * scale;
    inv.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..m {
        inv[i * m + i] = 1.0;
    }
    for col in 0..m {
        let piv = (col..m)
            .max_by(|&x, &y| a[x * m + col].abs().total_cmp(&a[y * m + col].abs()))
            .expect("non-empty range");
        if a[piv * m + col].abs() <= tiny {
            return false;
        }
        if piv != col {
            for j in 0..m {
                a.swap(piv * m + j, col * m + j);
                inv.swap(piv * m + j, col * m + j);
            }
        }
        let d = 1.0 / a[col * m + col];
        for j in 0..m {
            a[col * m + j] *= d;
            inv[col * m + j] *= d;
        }
        for r in 0..m {
            if r == col {
                continue;
            }
            let f = a[r * m + col];
            if f == 0.0 {
                continue;
            }
            for j in 0..m {
                a[r * m + j] -= f * a[col * m + j];
                inv[r * m + j] -= f * inv[col * m + j];
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{csc, residual};
    use super::*;

    /// A 6 × 6 test matrix: unknowns {0, 1} and {2} eliminated; entry (0, 2) couples the two
    /// groups.
    fn matrix(cross: f64) -> (CscPattern, Vec<f64>, Vec<Vec<f64>>) {
        let dense = vec![
            vec![5.0, 1.0, cross, 0.5, 0.0, 0.0],
            vec![1.0, 4.0, 0.0, 0.0, 1.0, 0.0],
            vec![0.0, 0.0, 3.0, 0.0, 0.0, 1.0],
            vec![0.5, 0.0, 0.0, 6.0, 1.0, 0.0],
            vec![0.0, 2.0, 0.0, 1.0, 0.0, 1.0],
            vec![0.0, 0.0, 1.0, 0.0, 1.0, 2.0],
        ];
        let (p, vals) = csc(&dense, |r, c| r == 0 && c == 2);
        (p, vals, dense)
    }

    #[test]
    fn eliminating_blocks_solves_the_same_system_as_a_plain_lu() {
        let (p, vals, dense) = matrix(0.0);
        let mut s = BlockSchurLu::new(&p, &[vec![0, 1], vec![2]]).unwrap();
        assert_eq!(s.reduced_dim(), 3);
        s.factor(&vals).unwrap();
        assert!(!s.used_plain_lu());
        let b = [1.0, -2.0, 0.5, 3.0, 1.0, -1.0];
        let mut x = b;
        s.solve_in_place(&mut x).unwrap();
        assert!(residual(&dense, &x, &b) < 1e-13, "{x:?}");
    }

    #[test]
    fn a_coupling_between_groups_is_left_out_and_a_singular_block_falls_back_to_the_plain_lu() {
        let (p, vals, dense) = matrix(0.3);
        let b = [1.0, -2.0, 0.5, 3.0, 1.0, -1.0];
        let mut s = BlockSchurLu::new(&p, &[vec![0, 1], vec![2]]).unwrap();
        s.factor(&vals).unwrap();
        let mut x = b;
        s.solve_in_place(&mut x).unwrap();
        // The solve is that of the matrix without the (0, 2) entry.
        let mut without = dense.clone();
        without[0][2] = 0.0;
        assert!(residual(&without, &x, &b) < 1e-13);
        assert!(residual(&dense, &x, &b) > 1e-3);
        // A zero block: the plain LU, exact for the full matrix.
        let mut singular = vals.clone();
        let k = p.find(2, 2).unwrap();
        singular[k] = 0.0;
        let mut dense0 = dense.clone();
        dense0[2][2] = 0.0;
        s.factor(&singular).unwrap();
        assert!(s.used_plain_lu());
        let mut x = b;
        s.solve_in_place(&mut x).unwrap();
        assert!(residual(&dense0, &x, &b) < 1e-12, "{x:?}");
    }

    /// Random systems: n unknowns, some in groups of 1–4, the others kept; random entries,
    /// none between two different groups (so the elimination is exact), a dominant diagonal
    /// (so every block and the whole matrix are invertible). The solve must satisfy A·x = b
    /// to round-off, as a plain sparse LU does. A fixed seed, so CI reproduces a failure.
    #[test]
    fn eliminated_solves_satisfy_random_sparse_systems() {
        use proptest::collection::vec;
        use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases: 300,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::deterministic_rng(RngAlgorithm::ChaCha),
        );
        let strategy = (
            3usize..24,
            vec(0usize..5, 24),
            vec((0usize..24, 0usize..24, -1.0f64..1.0), 0..120),
            vec(-1.0f64..1.0, 24),
        );
        runner
            .run(&strategy, |(n, sizes, entries, rhs)| {
                // Groups: consecutive runs of the given sizes (0: the unknown is kept).
                let mut groups: Vec<Vec<usize>> = vec![];
                let mut group_of = vec![usize::MAX; n];
                let mut i = 0;
                for &size in &sizes {
                    if i >= n {
                        break;
                    }
                    if size == 0 {
                        i += 1;
                        continue;
                    }
                    let g: Vec<usize> = (i..(i + size).min(n)).collect();
                    for &k in &g {
                        group_of[k] = groups.len();
                    }
                    i += g.len();
                    groups.push(g);
                }
                let mut dense = vec![vec![0.0; n]; n];
                for &(r, c, v) in &entries {
                    let (r, c) = (r % n, c % n);
                    let cross =
                        group_of[r] != usize::MAX && group_of[c] != usize::MAX && group_of[r] != group_of[c];
                    if !cross {
                        dense[r][c] += v;
                    }
                }
                for (r, row) in dense.iter_mut().enumerate() {
                    row[r] += 2.0 + n as f64;
                }
                let (p, vals) = csc(&dense, |_, _| false);
                let mut s = BlockSchurLu::new(&p, &groups).unwrap();
                assert_eq!(s.reduced_dim(), n - groups.iter().map(Vec::len).sum::<usize>());
                s.factor(&vals).unwrap();
                assert!(!s.used_plain_lu());
                let b = &rhs[..n];
                let mut x = b.to_vec();
                s.solve_in_place(&mut x).unwrap();
                let res = residual(&dense, &x, b);
                proptest::prop_assert!(res < 1e-12, "residual {res:e}, n {n}, groups {groups:?}");
                Ok(())
            })
            .unwrap();
    }

    #[test]
    fn invalid_groups_are_rejected() {
        let (p, _, _) = matrix(0.0);
        for groups in [vec![vec![0], vec![0]], vec![vec![7]], vec![vec![]]] {
            let e = BlockSchurLu::new(&p, &groups).unwrap_err();
            assert!(matches!(e, LinearSolveError::InvalidBlocks(_)), "{e}");
        }
    }
}
