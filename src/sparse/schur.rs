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
//! When a block fails the inversion's singularity test (a pivot at most m·ε times the block's
//! largest entry), the elimination is redone with every block equilibrated — rows and
//! columns scaled by powers of two so each one's largest entry is in [1, 2), exact — since a
//! body's Newton block is usually only badly scaled: gyroscopic terms of 1e13–1e18 beside its
//! normalisation gradient 2·p (the chain of `lash bench scaling` at N = 10, the MR2120 L1
//! run's 34th factorisation of 4 379). Only a block singular after that too (for example in a
//! consistent-initialisation matrix, where a group's rows hold derivatives that are not
//! invertible on their own) sends the whole matrix to a plain [`SparseLu`], built on first
//! use; its results are then exact for the given values, cross-group entries included.
//! Measured (`lash bench scaling`, session 51, one run each, a diagnosis on the other core):
//! the chain fell back once or twice per run, and each fallback built the whole matrix's LU
//! and kept it — resident memory at N = 10 000 1 572 MB before, **1 157 MB** with the
//! equilibration (N = 1 000: 161 → 122 MB), the same steps and factorisations, time per step
//! 254 → 249 ms (N = 1 000: 17.1 → 15.9 ms). The L1 run keeps its steps and factorisations at
//! rtol 1e-4 (3 981, 4 379), its motion changed at round-off from that factorisation on, and
//! its time (7 alternated whole-process pairs on issue #16's command: 1.004×).
//!
//! At large N the elimination is bound by memory latency, not by arithmetic: everything a
//! factorisation and a solve read lies in two arenas (numbers and u32 addresses), group after
//! group in the order they are visited. Each block is gathered, inverted and folded into S
//! in one visit, while its numbers are in the nearest cache (a body's columns lie together,
//! so the values are still read nearly forward); gathering every block first, in increasing
//! position of the values, then eliminating them took 4 % more CPU time at N = 3 000
//! (`lash bench scaling --links 3000`, 5 alternated whole-process pairs, 0.961× for the
//! one-visit elimination, a diagnosis on the other core; the MR2120 L1 run, 114 kept
//! unknowns in cache, 0.992×, 9 pairs; both bit-identical). Storing the numbers a solve
//! reads (A_EE⁻¹, U, y, W) apart from the factorisation's own measured 1.003× at
//! N = 3 000: not kept. A solve checks its result for NaN as it writes it, not in a pass
//! of its own over the whole vector: 0.968× CPU at N = 1 000 (11 pairs), 0.980× at
//! N = 3 000 (5 pairs). Against nine small allocations per group, alternated
//! (`lash bench scaling`, a chain of N links, session 36): with another process loading the
//! memory, 14 % less time per step at N = 1 000 (6.4–6.7 ms against 7.6 ms) and 12 % at
//! N = 10 000 (107 ms against 122 ms); on the idle machine 6.3–7.4 ms against 7.3–7.7 ms and
//! 112–114 ms against 116–118 ms (about 4 % at N = 10 000); the MR2120 L1 run (114 kept
//! unknowns, all in cache) 1.5 % faster (9 alternated whole-process pairs on the issue's
//! command, 0.985×; the same steps and factorisations).

use super::{CscPattern, LinearSolveError, RefactorLu, SlotIndex, SparseLu};

/// Largest group (unknowns per eliminated block) accepted: blocks are inverted densely.
pub const MAX_GROUP: usize = 32;

/// How many blocks ahead a solve asks the memory for the numbers it will read (a hint,
/// [`prefetch`]; the results are the same to the bit). At large N a solve streams each
/// block's A_EE⁻¹ and U (forward) and W and y (back) from beyond the caches, and `perf`
/// put half its time on the first loads of each block's dot products (the profiling build,
/// chain of 1 000 links, session 73). Measured with `lash bench scaling` (session 73, one binary, the distance
/// alternated, the machine otherwise idle; medians of per-step times): N = 1 000 7.57 ms at
/// 4 against 7.95 ms without (5 runs each), N = 10 000 119.2 against 123.0 ms (3 runs each;
/// 8 blocks ahead 119.6 ms), N = 100 0.644 against 0.646 ms. The same hint in the
/// elimination (the next blocks' gathered values, their numbers and S's positions) made
/// N = 1 000 slower (8.1–8.2 against 7.5 ms) and is not taken.
const PREFETCH_AHEAD: usize = 4;

/// One eliminated block: its sizes and where its numbers and addresses sit in the two
/// arenas of [`BlockSchurLu`], laid out group after group in the order the factorisation and
/// the solves visit them (at large N the elimination is bound by memory latency: one
/// forward stream through each arena instead of nine small allocations per group).
#[derive(Debug, Clone, Copy)]
struct Group {
    /// Unknowns of the block (g).
    m: usize,
    /// Kept rows coupled to the block.
    nu: usize,
    /// Kept columns coupled to the block.
    nv: usize,
    /// Start in `BlockSchurLu::numbers`: the block A_EE (g × g, row-major; gathered, then
    /// overwritten by the inversion), A_RE restricted to the block (`u`: nu × g, row-major,
    /// row i for kept row i), A_ER restricted to it (V: nv × g, column after column, column j
    /// for kept column j), A_EE⁻¹ (g × g, row-major), W = A_EE⁻¹·V (nv × g, column after
    /// column) and y = A_EE⁻¹·b_E of the current solve (g).
    num: usize,
    /// Start in `BlockSchurLu::addresses`: the block's unknowns (full indices, g), its kept
    /// rows (reduced indices, nu), its kept columns (reduced indices, nv) and the position in
    /// the reduced values of S(row i, column j), row-major (nu · nv).
    adr: usize,
    /// The block's entries in `BlockSchurLu::group_gather`: `gat..gat + ng`.
    gat: usize,
    /// How many entries the block gathers (its A_EE, A_RE and A_ER entries in the pattern).
    ng: usize,
}

impl Group {
    /// Numbers of the group in the arena.
    fn numbers(&self) -> usize {
        let (m, nu, nv) = (self.m, self.nu, self.nv);
        2 * m * m + nu * m + 2 * nv * m + m
    }

    /// Addresses of the group in the arena.
    fn addresses(&self) -> usize {
        self.m + self.nu + self.nv + self.nu * self.nv
    }
}

/// A group's numbers, split by role (see [`Group::num`]).
struct Numbers<'a> {
    block: &'a mut [f64],
    u: &'a mut [f64],
    v: &'a mut [f64],
    inv: &'a mut [f64],
    w: &'a mut [f64],
    y: &'a mut [f64],
}

impl<'a> Numbers<'a> {
    fn split(g: &Group, all: &'a mut [f64]) -> Self {
        let (m, nu, nv) = (g.m, g.nu, g.nv);
        let (block, r) = all[..g.numbers()].split_at_mut(m * m);
        let (u, r) = r.split_at_mut(nu * m);
        let (v, r) = r.split_at_mut(nv * m);
        let (inv, r) = r.split_at_mut(m * m);
        let (w, y) = r.split_at_mut(nv * m);
        Self {
            block,
            u,
            v,
            inv,
            w,
            y,
        }
    }
}

/// A group's addresses, split by role (see [`Group::adr`]).
struct Addresses<'a> {
    idx: &'a [u32],
    urows: &'a [u32],
    vcols: &'a [u32],
    slots: &'a [u32],
}

impl<'a> Addresses<'a> {
    fn split(g: &Group, all: &'a [u32]) -> Self {
        let all = &all[g.adr..g.adr + g.addresses()];
        let (idx, r) = all.split_at(g.m);
        let (urows, r) = r.split_at(g.nu);
        let (vcols, slots) = r.split_at(g.nv);
        Self {
            idx,
            urows,
            vcols,
            slots,
        }
    }
}

/// Sparse LU of a square matrix after eliminating small diagonal blocks (see the
/// module documentation in `src/sparse/schur.rs`).
#[derive(Debug)]
pub struct BlockSchurLu {
    pattern: CscPattern,
    groups: Vec<Group>,
    /// Full index of each kept unknown.
    kept: Vec<usize>,
    /// The reduced matrix's own entries (A_RR): (position in the values, position in
    /// `numbers`), in increasing order of the first.
    gather: Vec<(u32, u32)>,
    /// Each block's entries (A_EE, A_RE, A_ER): (position in the values, position in the
    /// block's own numbers), block after block in the order they are eliminated
    /// ([`Group::gat`]), each block's in increasing position in the values: a
    /// block is gathered, inverted and folded into S while its numbers are in the nearest
    /// cache, and the values are still read nearly forward (a body's columns lie together).
    group_gather: Vec<(u32, u32)>,
    /// Positions in the values of the entries between two groups, which the factors leave
    /// out (the module documentation), so that a NaN there is still reported.
    left_out: Vec<u32>,
    /// The reduced matrix's values (the first `s_nnz`: A_RR, then − U·W), then each group's
    /// numbers ([`Group::num`]).
    numbers: Vec<f64>,
    /// Each group's addresses ([`Group::adr`]).
    addresses: Vec<u32>,
    /// Entries of the reduced matrix.
    s_nnz: usize,
    s_lu: RefactorLu,
    /// Reduced right-hand side.
    work: Vec<f64>,
    /// Scratch for one block's right-hand side (g).
    scratch: Vec<f64>,
    /// Plain LU of the whole matrix, for values with a block singular even equilibrated.
    full: Option<SparseLu>,
    /// How the last factorisation was reached (the plain LU's factors are the ones to solve
    /// with when it is [`FactorRoute::PlainLu`]).
    route: FactorRoute,
    factored: bool,
}

/// How a factorisation of [`BlockSchurLu`] was reached (module docs), for callers that count
/// how often a run needed each fallback.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum FactorRoute {
    /// Every block eliminated as it is (or a solver without fallbacks).
    #[default]
    Direct,
    /// A block failed the singularity test; every block eliminated equilibrated.
    Equilibrated,
    /// A block singular even equilibrated: the plain sparse LU of the whole matrix.
    PlainLu,
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
        let mut rr_entries = Vec::new();
        let mut left_out = Vec::new();
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
                    _ => left_out.push(narrow(k)?),
                }
            }
        }
        let mut s_entries: Vec<(usize, usize)> = rr_entries.iter().map(|&(_, r, c)| (r, c)).collect();
        s_entries.extend((0..kept.len()).map(|i| (i, i)));
        // Per group: kept rows and columns, and (position in the values, position in the
        // group's numbers) of each gathered entry.
        let mut couplings: Vec<(Vec<usize>, Vec<usize>)> = Vec::with_capacity(groups.len());
        let mut group_gather: Vec<Vec<(usize, usize)>> = Vec::with_capacity(groups.len());
        for (idx, (ee, re, er)) in groups.iter().zip(&entries) {
            let m = idx.len();
            let mut urows: Vec<usize> = re.iter().map(|e| reduced[e.1]).collect();
            urows.sort_unstable();
            urows.dedup();
            let mut vcols: Vec<usize> = er.iter().map(|e| reduced[e.2]).collect();
            vcols.sort_unstable();
            vcols.dedup();
            let (u_at, v_at) = (m * m, m * m + urows.len() * m);
            let mut gg: Vec<(usize, usize)> = ee.clone();
            for &(k, r, l) in re {
                let i = urows.binary_search(&reduced[r]).expect("row listed");
                gg.push((k, u_at + i * m + l));
            }
            for &(k, l, c) in er {
                let j = vcols.binary_search(&reduced[c]).expect("column listed");
                gg.push((k, v_at + j * m + l));
            }
            for &r in &urows {
                for &c in &vcols {
                    s_entries.push((r, c));
                }
            }
            // (In increasing position in the values: the block's gather reads them forward.)
            gg.sort_unstable();
            group_gather.push(gg);
            couplings.push((urows, vcols));
        }
        let s_pattern = CscPattern::from_entries(kept.len(), kept.len(), s_entries)
            .map_err(|e| LinearSolveError::InvalidBlocks(e.to_string()))?;
        let slot = SlotIndex::new(&s_pattern);
        let at = |r: usize, c: usize| slot.get(r, c).expect("entry is in the reduced pattern");
        let s_nnz = s_pattern.nnz();
        let mut gather: Vec<(usize, usize)> = rr_entries.iter().map(|&(k, r, c)| (k, at(r, c))).collect();
        let mut all_group_gather: Vec<(u32, u32)> = Vec::new();
        let (mut num, mut addresses) = (s_nnz, Vec::new());
        let mut gs = Vec::with_capacity(groups.len());
        let mut scratch_len = 0;
        for ((idx, (urows, vcols)), gg) in groups.iter().zip(&couplings).zip(&group_gather) {
            let g = Group {
                m: idx.len(),
                nu: urows.len(),
                nv: vcols.len(),
                num,
                adr: addresses.len(),
                gat: all_group_gather.len(),
                ng: gg.len(),
            };
            for &(k, d) in gg {
                all_group_gather.push((narrow(k)?, narrow(d)?));
            }
            for &i in idx.iter().chain(urows).chain(vcols) {
                addresses.push(narrow(i)?);
            }
            for &r in urows {
                for &c in vcols {
                    addresses.push(narrow(at(r, c))?);
                }
            }
            num += g.numbers();
            scratch_len = scratch_len.max(g.m);
            gs.push(g);
        }
        narrow(num)?;
        gather.sort_unstable();
        let gather = gather
            .into_iter()
            .map(|(k, d)| Ok((narrow(k)?, narrow(d)?)))
            .collect::<Result<_, LinearSolveError>>()?;
        let s_lu = RefactorLu::new(&s_pattern)?;
        Ok(Self {
            pattern: pattern.clone(),
            groups: gs,
            work: vec![0.0; kept.len()],
            kept,
            gather,
            group_gather: all_group_gather,
            left_out,
            numbers: vec![0.0; num],
            addresses,
            s_nnz,
            s_lu,
            scratch: vec![0.0; scratch_len],
            full: None,
            route: FactorRoute::Direct,
            factored: false,
        })
    }

    /// Unknowns left after the elimination (the order of the sparse LU).
    pub fn reduced_dim(&self) -> usize {
        self.kept.len()
    }

    /// Whether the last factorisation fell back to the plain LU (a block singular even
    /// equilibrated).
    pub fn used_plain_lu(&self) -> bool {
        self.route == FactorRoute::PlainLu
    }

    /// How the last factorisation was reached ([`FactorRoute::Direct`] before any and after
    /// a failed one).
    pub fn route(&self) -> FactorRoute {
        self.route
    }

    /// Factorises the matrix with `values` on the pattern given to [`new`](Self::new).
    pub fn factor(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        self.factored = false;
        self.route = FactorRoute::Direct;
        if values.len() != self.pattern.nnz() {
            return super::lu::check_values(&self.pattern, values);
        }
        // A block that fails the singularity test: every block redone equilibrated, then the
        // plain LU (module docs).
        let route = if self.eliminate(values, false)? {
            FactorRoute::Direct
        } else if self.eliminate(values, true)? {
            FactorRoute::Equilibrated
        } else {
            return self.factor_plain(values);
        };
        match self.s_lu.factor(&self.numbers[..self.s_nnz]) {
            Ok(()) => {
                self.factored = true;
                self.route = route;
                Ok(())
            }
            Err(LinearSolveError::Singular { column }) => Err(LinearSolveError::Singular {
                column: column.map(|c| self.kept[c]),
            }),
            Err(e) => Err(e),
        }
    }

    /// Gathers `values` and eliminates the blocks into the Schur complement's numbers, each
    /// block's inverse computed as it is or `equilibrated` ([`invert_equilibrated`]); false
    /// if a block is singular (the numbers are then incomplete).
    fn eliminate(&mut self, values: &[f64], equilibrated: bool) -> Result<bool, LinearSolveError> {
        // Zeros where the pattern has no entry, then S's own entries (A_RR). The values are
        // checked for NaN and infinities as they are gathered (a second pass over them costs
        // as much as the gather at large N, where they no longer fit in cache); the entries
        // the elimination leaves out are checked too, from their own list. A non-finite
        // value is reported (the first in the matrix, by `check_values`) as soon as its block
        // is gathered, and before a block's singularity is, so the numbers' state then does
        // not matter.
        self.numbers[..self.s_nnz].iter_mut().for_each(|v| *v = 0.0);
        let mut non_finite = 0u64;
        for &(k, d) in &self.gather {
            let v = values[k as usize];
            non_finite |= super::lu::non_finite_bit(v);
            self.numbers[d as usize] = v;
        }
        for &k in &self.left_out {
            non_finite |= super::lu::non_finite_bit(values[k as usize]);
        }
        if non_finite != 0 {
            // Names the first non-finite entry.
            super::lu::check_values(&self.pattern, values)?;
        }
        let (s_values, rest) = self.numbers.split_at_mut(self.s_nnz);
        for g in &self.groups {
            let m = g.m;
            // The block's entries, gathered into cleared numbers. Only the block is cleared
            // each time (the inversion overwrites it); U's and V's positions outside the
            // pattern are zero from the start and nothing but the gather, always to the
            // same positions, writes U and V; A_EE⁻¹, W and y are written whole.
            let own = &mut rest[g.num - self.s_nnz..];
            own[..m * m].iter_mut().for_each(|v| *v = 0.0);
            for &(k, d) in &self.group_gather[g.gat..g.gat + g.ng] {
                let v = values[k as usize];
                non_finite |= super::lu::non_finite_bit(v);
                own[d as usize] = v;
            }
            if non_finite != 0 {
                super::lu::check_values(&self.pattern, values)?;
            }
            let x = Numbers::split(g, own);
            let a = Addresses::split(g, &self.addresses);
            let inverted = if equilibrated {
                invert_equilibrated(x.block, x.inv, m)
            } else {
                invert_in_place(x.block, x.inv, m)
            };
            if !inverted {
                // (A later block's non-finite value is the error, not this block.)
                super::lu::check_values(&self.pattern, values)?;
                return Ok(false);
            }
            // W = A_EE⁻¹·V, column by column.
            for (wj, vj) in x.w.chunks_exact_mut(m).zip(x.v.chunks_exact(m)) {
                for (wl, inv_l) in wj.iter_mut().zip(x.inv.chunks_exact(m)) {
                    *wl = dot(inv_l, vj);
                }
            }
            // S −= U·W.
            for (ui, slots) in x.u.chunks_exact(m).zip(a.slots.chunks_exact(g.nv.max(1))) {
                for (wj, &slot) in x.w.chunks_exact(m).zip(slots) {
                    s_values[slot as usize] -= dot(ui, wj);
                }
            }
        }
        Ok(true)
    }

    fn factor_plain(&mut self, values: &[f64]) -> Result<(), LinearSolveError> {
        if self.full.is_none() {
            self.full = Some(SparseLu::new(&self.pattern)?);
        }
        let full = self.full.as_mut().expect("built above");
        full.factor(values)?;
        self.route = FactorRoute::PlainLu;
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
        if self.route == FactorRoute::PlainLu {
            return self.full.as_mut().expect("factored").solve_in_place(b);
        }
        for (k, &i) in self.kept.iter().enumerate() {
            self.work[k] = b[i];
        }
        for (gi, g) in self.groups.iter().enumerate() {
            if let Some(h) = self.groups.get(gi + PREFETCH_AHEAD) {
                // A_RE's and A_EE⁻¹'s rows of a later block, and its addresses.
                prefetch(&self.numbers[h.num + h.m * h.m..h.num + h.m * h.m + h.nu * h.m]);
                let inv_at = h.num + h.m * h.m + (h.nu + h.nv) * h.m;
                prefetch(&self.numbers[inv_at..inv_at + h.m * h.m]);
                prefetch(&self.addresses[h.adr..h.adr + h.m + h.nu]);
            }
            let m = g.m;
            let x = Numbers::split(g, &mut self.numbers[g.num..]);
            let a = Addresses::split(g, &self.addresses);
            let be = &mut self.scratch[..m];
            for (v, &i) in be.iter_mut().zip(a.idx) {
                *v = b[i as usize];
            }
            for (yl, inv_l) in x.y.iter_mut().zip(x.inv.chunks_exact(m)) {
                *yl = dot(inv_l, be);
            }
            for (ui, &r) in x.u.chunks_exact(m).zip(a.urows) {
                self.work[r as usize] -= dot(ui, x.y);
            }
        }
        self.s_lu.solve_in_place(&mut self.work)?;
        // (Every unknown is written once below, kept or eliminated: the result is checked
        // for NaN and infinities as it is written, not in a pass of its own.)
        let mut non_finite = 0u64;
        for (k, &i) in self.kept.iter().enumerate() {
            let v = self.work[k];
            non_finite |= super::lu::non_finite_bit(v);
            b[i] = v;
        }
        for (gi, g) in self.groups.iter().enumerate() {
            if let Some(h) = self.groups.get(gi + PREFETCH_AHEAD) {
                let w_at = h.num + 2 * h.m * h.m + (h.nu + h.nv) * h.m;
                prefetch(&self.numbers[w_at..w_at + h.nv * h.m + h.m]);
                prefetch(&self.addresses[h.adr..h.adr + h.m + h.nu + h.nv]);
            }
            let m = g.m;
            let x = Numbers::split(g, &mut self.numbers[g.num..]);
            let a = Addresses::split(g, &self.addresses);
            let xe = &mut self.scratch[..m];
            // x_E = y − W·x_R. The first column's update writes y − w·x straight (the
            // same operations as copying y and subtracting; a copy of a few numbers is a
            // call to memcpy per block).
            let mut columns = x.w.chunks_exact(m).zip(a.vcols);
            match columns.next() {
                Some((w0, &c0)) => {
                    let xc = self.work[c0 as usize];
                    for ((v, &yl), w) in xe.iter_mut().zip(x.y.iter()).zip(w0) {
                        *v = yl - w * xc;
                    }
                }
                None => xe.copy_from_slice(x.y),
            }
            for (wj, &c) in columns {
                let xc = self.work[c as usize];
                for (v, w) in xe.iter_mut().zip(wj) {
                    *v -= w * xc;
                }
            }
            for (&v, &i) in xe.iter().zip(a.idx) {
                non_finite |= super::lu::non_finite_bit(v);
                b[i as usize] = v;
            }
        }
        if non_finite != 0 {
            return Err(LinearSolveError::Singular { column: None });
        }
        Ok(())
    }
}

/// Asks for the cache lines of `v` ahead of their use (a hint; no effect on the numbers).
#[inline]
fn prefetch<T>(v: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // Every 64-byte line the slice touches, from the line its first byte lies in.
        let p = v.as_ptr() as *const i8;
        let lead = p as usize % 64;
        let bytes = std::mem::size_of_val(v) + lead;
        let first = p.wrapping_sub(lead);
        let mut o = 0;
        while o < bytes {
            // SAFETY: a prefetch never faults and reads nothing the program sees.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(first.wrapping_add(o)) };
            o += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v;
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

/// 2^k for k in −1074 … 1023, built from its bits (exact; subnormal below −1022).
fn pow2(k: i32) -> f64 {
    debug_assert!((-1074..=1023).contains(&k));
    if k >= -1022 {
        f64::from_bits(((k + 1023) as u64) << 52)
    } else {
        f64::from_bits(1u64 << (k + 1074))
    }
}

/// The binary exponent e of a normal number x (|x| = 2^e · [1, 2)); None for 0, a
/// subnormal, an infinity or NaN.
fn exponent(x: f64) -> Option<i32> {
    x.is_normal().then(|| ((x.to_bits() >> 52) & 0x7ff) as i32 - 1023)
}

/// x · 2^k for k in −2046 … 2044 (the sum of two exponents of normal numbers, negated), in
/// two exact halves: 2^k alone may not be representable.
fn scale2(x: f64, k: i32) -> f64 {
    let h = k / 2;
    x * pow2(h) * pow2(k - h)
}

/// [`invert_in_place`] of R·A·C, R and C diagonal powers of two that bring each row's
/// largest magnitude and then each column's into [1, 2), and A⁻¹ = C·(R·A·C)⁻¹·R: a block
/// whose entries span many decades passes the singularity test when it is singular only in
/// its scaling. The scaling is exact unless it takes an entry below the normal range (one
/// 2^1022 times smaller than its row's largest). False for a zero row or column (or one
/// whose largest entry is subnormal) or a singular scaled block. `a` is overwritten.
fn invert_equilibrated(a: &mut [f64], inv: &mut [f64], m: usize) -> bool {
    debug_assert!(m <= MAX_GROUP);
    // The scales' exponents: row i multiplied by 2^row[i], column j by 2^col[j].
    let (mut row, mut col) = ([0i32; MAX_GROUP], [0i32; MAX_GROUP]);
    for (i, r) in a.chunks_exact_mut(m).enumerate() {
        let Some(e) = exponent(r.iter().fold(0.0f64, |s, v| s.max(v.abs()))) else {
            return false;
        };
        row[i] = -e;
        let p = pow2(-e);
        r.iter_mut().for_each(|v| *v *= p);
    }
    for (j, cj) in col.iter_mut().enumerate().take(m) {
        let Some(e) = exponent((0..m).fold(0.0f64, |s, i| s.max(a[i * m + j].abs()))) else {
            return false;
        };
        *cj = -e;
        let p = pow2(-e);
        (0..m).for_each(|i| a[i * m + j] *= p);
    }
    if !invert_in_place(a, inv, m) {
        return false;
    }
    for (i, r) in inv.chunks_exact_mut(m).enumerate() {
        for (v, rj) in r.iter_mut().zip(&row[..m]) {
            *v = scale2(*v, col[i] + rj);
        }
    }
    true
}

/// Inverts the m × m row-major matrix `a` into `inv` by Gauss–Jordan elimination with
/// partial pivoting (`a` is overwritten). Returns `false` when a pivot is at most
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
        assert_eq!(s.route(), FactorRoute::Direct);
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
        assert_eq!(s.route(), FactorRoute::PlainLu);
        let mut x = b;
        s.solve_in_place(&mut x).unwrap();
        assert!(residual(&dense0, &x, &b) < 1e-12, "{x:?}");
    }

    /// A body's block from the chain of `bench scaling` (N = 10, its 16th factorisation):
    /// the gyroscopic terms (6.3e13) beside the normalisation gradient (2·p) fail the
    /// unscaled elimination's singularity test, m·ε·max|a| = 0.11, though the block is
    /// regular; equilibrated it is eliminated without the plain LU, and the solve's
    /// componentwise backward error is at round-off.
    #[test]
    fn a_badly_scaled_block_is_equilibrated_instead_of_falling_back_to_the_plain_lu() {
        let (g, c, k) = (
            6.342_369_791_702_406e13,
            3_200.479_471_631_937_5,
            1.651_411_360_891_187_3e10,
        );
        let block = [
            [c, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, c, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, c, 0.0, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, c, 0.0, g, 0.0, 2.0],
            [0.0, 0.0, 0.0, 0.0, c, 0.0, g, 0.0],
            [0.0, 0.0, 0.0, -g, 0.0, c, 0.0, 2.0 * k],
            [0.0, 0.0, 0.0, 0.0, -g, 0.0, c, 0.0],
            [0.0, 0.0, 0.0, 1.0, 0.0, k, 0.0, 0.0],
        ];
        let mut flat: Vec<f64> = block.iter().flatten().copied().collect();
        let mut inv = vec![0.0; 64];
        assert!(
            !invert_in_place(&mut flat, &mut inv, 8),
            "the unscaled test passes it"
        );
        // A regular group {0, 1} first (so the failed pass has already updated the Schur
        // complement when the block fails), the block as unknowns 2–9, and an eleventh
        // unknown, kept, coupled to both groups.
        let mut dense = vec![vec![0.0; 11]; 11];
        dense[0][0] = 4.0;
        dense[0][1] = 1.0;
        dense[1][0] = 1.0;
        dense[1][1] = 3.0;
        for (i, row) in block.iter().enumerate() {
            dense[2 + i][2..10].copy_from_slice(row);
        }
        for (i, j) in [(0, 10), (10, 0), (2, 10), (10, 2)] {
            dense[i][j] = 1.0;
        }
        dense[10][10] = 5.0;
        let (p, vals) = csc(&dense, |_, _| false);
        let mut s = BlockSchurLu::new(&p, &[vec![0, 1], (2..10).collect()]).unwrap();
        s.factor(&vals).unwrap();
        assert!(!s.used_plain_lu());
        assert_eq!(s.route(), FactorRoute::Equilibrated);
        let b = [0.5, -1.0, 1.0, -2.0, 0.5, 3.0, 1.0, -1.0, 2.0, 0.25, 4.0];
        let mut x = b;
        s.solve_in_place(&mut x).unwrap();
        for (i, (row, bi)) in dense.iter().zip(&b).enumerate() {
            let r: f64 = row.iter().zip(&x).map(|(a, x)| a * x).sum::<f64>() - bi;
            let size: f64 = row.iter().zip(&x).map(|(a, x)| (a * x).abs()).sum::<f64>() + bi.abs();
            assert!(r.abs() <= 1e-13 * size, "row {i}: {r:e} of {size:e}");
        }
    }

    /// The power-of-two helpers: exact over the whole exponent range, subnormals included,
    /// and a product whose factor 2^k alone would overflow.
    #[test]
    fn powers_of_two_are_exact_across_the_exponent_range() {
        for k in [-1074, -1050, -1023, -1022, -1, 0, 1, 52, 1023] {
            assert_eq!(pow2(k), 2.0f64.powf(k as f64), "2^{k}");
        }
        assert_eq!(exponent(1.0), Some(0));
        assert_eq!(exponent(-3.0), Some(1));
        assert_eq!(exponent(6.3e13), Some(45));
        assert_eq!(exponent(f64::MAX), Some(1023));
        assert_eq!(exponent(f64::MIN_POSITIVE), Some(-1022));
        assert_eq!(exponent(0.0), None);
        assert_eq!(exponent(f64::MIN_POSITIVE / 4.0), None);
        assert_eq!(exponent(f64::NAN), None);
        assert_eq!(
            scale2(1.5e-300, 1500),
            1.5e-300 * 2.0f64.powi(750) * 2.0f64.powi(750)
        );
        assert_eq!(scale2(3.0, -2), 0.75);
    }

    #[test]
    fn a_nan_anywhere_is_reported_with_its_row_and_column_even_where_the_factors_leave_it_out() {
        let (p, vals, _) = matrix(0.3);
        let mut s = BlockSchurLu::new(&p, &[vec![0, 1], vec![2]]).unwrap();
        // (4, 1): a kept row against a group's column (gathered into U); (0, 2): the coupling
        // between the two groups, which the factors leave out; (5, 5): the reduced matrix;
        // (2, 2): the second group's block, gathered after the first group is eliminated.
        for (r, c) in [(4, 1), (0, 2), (5, 5), (2, 2)] {
            let mut bad = vals.clone();
            bad[p.find(r, c).unwrap()] = f64::NAN;
            match s.factor(&bad) {
                Err(LinearSolveError::NonFiniteEntry { row, col, .. }) => assert_eq!((row, col), (r, c)),
                other => panic!("({r}, {c}): {other:?}"),
            }
            let mut x = [1.0; 6];
            assert!(
                s.solve_in_place(&mut x).is_err(),
                "no factors after a refused matrix"
            );
        }
        // The first group's block singular and a NaN in the second's: the NaN is the error,
        // not the singular block (which would send the matrix to the plain LU).
        let mut bad = vals.clone();
        for (r, c) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            bad[p.find(r, c).unwrap()] = 0.0;
        }
        bad[p.find(2, 2).unwrap()] = f64::NAN;
        assert!(matches!(
            s.factor(&bad),
            Err(LinearSolveError::NonFiniteEntry { row: 2, col: 2, .. })
        ));
        assert!(!s.used_plain_lu());
        assert!(matches!(
            s.factor(&vals[1..]),
            Err(LinearSolveError::DimensionMismatch { .. })
        ));
        s.factor(&vals).unwrap();
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
