//! Compressed-sparse-column patterns and matrices.

use std::sync::Arc;
use thiserror::Error;

/// Why a sparsity pattern was rejected.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PatternError {
    /// `col_ptr` must have `ncols + 1` entries, start at 0 and be non-decreasing.
    #[error("column pointer array is malformed: {0}")]
    ColPtr(String),
    /// A row index is out of range.
    #[error("row index {row} in column {col} is out of range (matrix has {nrows} rows)")]
    RowOutOfRange {
        /// Column holding the bad entry.
        col: usize,
        /// The offending row index.
        row: usize,
        /// Number of rows of the matrix.
        nrows: usize,
    },
    /// Row indices within a column must be strictly increasing (sorted, no duplicates).
    #[error("row indices of column {col} are not strictly increasing (row {row} repeated or out of order)")]
    Unsorted {
        /// Column holding the bad entry.
        col: usize,
        /// The offending row index.
        row: usize,
    },
}

/// A compressed-sparse-column sparsity pattern of an `nrows × ncols` matrix.
///
/// Row indices in each column are strictly increasing. Construct with [`CscPattern::new`]
/// (validated), [`CscPattern::from_entries`] (any order, duplicates merged) or
/// [`CscPattern::dense`].
#[derive(Debug, Clone, PartialEq)]
pub struct CscPattern {
    nrows: usize,
    ncols: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

impl CscPattern {
    /// Builds a pattern from CSC arrays, checking them.
    pub fn new(
        nrows: usize,
        ncols: usize,
        col_ptr: Vec<usize>,
        row_idx: Vec<usize>,
    ) -> Result<Self, PatternError> {
        if col_ptr.len() != ncols + 1 {
            return Err(PatternError::ColPtr(format!(
                "expected {} entries, got {}",
                ncols + 1,
                col_ptr.len()
            )));
        }
        if col_ptr[0] != 0 || col_ptr[ncols] != row_idx.len() {
            return Err(PatternError::ColPtr(format!(
                "must start at 0 and end at nnz = {}",
                row_idx.len()
            )));
        }
        for c in 0..ncols {
            if col_ptr[c + 1] < col_ptr[c] {
                return Err(PatternError::ColPtr(format!("decreases at column {c}")));
            }
            let mut prev: Option<usize> = None;
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                if r >= nrows {
                    return Err(PatternError::RowOutOfRange {
                        col: c,
                        row: r,
                        nrows,
                    });
                }
                if prev.is_some_and(|p| r <= p) {
                    return Err(PatternError::Unsorted { col: c, row: r });
                }
                prev = Some(r);
            }
        }
        Ok(Self {
            nrows,
            ncols,
            col_ptr,
            row_idx,
        })
    }

    /// Builds a pattern from (row, column) pairs in any order; duplicates are merged.
    pub fn from_entries(
        nrows: usize,
        ncols: usize,
        entries: impl IntoIterator<Item = (usize, usize)>,
    ) -> Result<Self, PatternError> {
        let mut cols: Vec<Vec<usize>> = vec![Vec::new(); ncols];
        for (r, c) in entries {
            if c >= ncols {
                return Err(PatternError::ColPtr(format!(
                    "column {c} out of range (matrix has {ncols} columns)"
                )));
            }
            if r >= nrows {
                return Err(PatternError::RowOutOfRange {
                    col: c,
                    row: r,
                    nrows,
                });
            }
            cols[c].push(r);
        }
        let mut col_ptr = Vec::with_capacity(ncols + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for mut c in cols {
            c.sort_unstable();
            c.dedup();
            row_idx.extend(c);
            col_ptr.push(row_idx.len());
        }
        Ok(Self {
            nrows,
            ncols,
            col_ptr,
            row_idx,
        })
    }

    /// A fully dense `nrows × ncols` pattern.
    pub fn dense(nrows: usize, ncols: usize) -> Self {
        let col_ptr = (0..=ncols).map(|c| c * nrows).collect();
        let row_idx = (0..ncols).flat_map(|_| 0..nrows).collect();
        Self {
            nrows,
            ncols,
            col_ptr,
            row_idx,
        }
    }

    /// Number of rows.
    pub fn nrows(&self) -> usize {
        self.nrows
    }
    /// Number of columns.
    pub fn ncols(&self) -> usize {
        self.ncols
    }
    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }
    /// Column pointers (`ncols + 1` entries).
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }
    /// Row indices of all stored entries, column by column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }
    /// Row indices of column `c`.
    pub fn col_rows(&self, c: usize) -> &[usize] {
        &self.row_idx[self.col_ptr[c]..self.col_ptr[c + 1]]
    }
    /// Range of value positions of column `c`.
    pub fn col_range(&self, c: usize) -> std::ops::Range<usize> {
        self.col_ptr[c]..self.col_ptr[c + 1]
    }
    /// Position of entry (r, c) in the value array, if it is in the pattern.
    pub fn find(&self, r: usize, c: usize) -> Option<usize> {
        let range = self.col_range(c);
        let start = range.start;
        self.row_idx[range].binary_search(&r).ok().map(|k| start + k)
    }
}

/// Entry lookup for assembling values on a [`CscPattern`]: (row, column) → position in the
/// value array.
///
/// [`CscPattern::find`] binary-searches the column, which dominated the assembly of the
/// MR2120 iteration matrix (13 % of a whole simulation, measured with `perf`). For patterns
/// of at most [`SlotIndex::DENSE_LIMIT`] cells the index is a dense table (one `u32` per
/// cell, one load per lookup); larger patterns keep the binary search, on `u32` copies of the
/// column starts and row indices (half the bytes a lookup touches, and no second copy of the
/// pattern's `usize` arrays: at N = 10 000 links of `lash bench scaling` the pattern holds
/// 8.6 million entries), whose memory stays proportional to the nonzeros.
#[derive(Debug, Clone)]
pub struct SlotIndex {
    nrows: usize,
    lookup: Lookup,
}

/// How [`SlotIndex`] finds an entry.
#[derive(Debug, Clone)]
enum Lookup {
    /// One `u32` per cell, column after column (`u32::MAX` where there is no entry).
    Dense(Vec<u32>),
    /// Binary search on `u32` column starts and row indices.
    Compact { col_ptr: Vec<u32>, rows: Vec<u32> },
    /// Binary search on the pattern itself (more than `u32::MAX` rows or entries).
    Wide(CscPattern),
}

impl SlotIndex {
    /// Largest nrows × ncols stored as a dense table (4 MB).
    pub const DENSE_LIMIT: usize = 1 << 20;

    /// The lookup for `pattern`.
    pub fn new(pattern: &CscPattern) -> Self {
        let cells = pattern.nrows.saturating_mul(pattern.ncols);
        let narrow = pattern.nnz() < u32::MAX as usize && pattern.nrows < u32::MAX as usize;
        let lookup = if cells <= Self::DENSE_LIMIT && narrow {
            let mut t = vec![u32::MAX; cells];
            for c in 0..pattern.ncols {
                for k in pattern.col_range(c) {
                    t[c * pattern.nrows + pattern.row_idx[k]] = k as u32;
                }
            }
            Lookup::Dense(t)
        } else if narrow {
            // Both fit: every start is at most nnz, every row below nrows.
            Lookup::Compact {
                col_ptr: pattern.col_ptr.iter().map(|&k| k as u32).collect(),
                rows: pattern.row_idx.iter().map(|&r| r as u32).collect(),
            }
        } else {
            Lookup::Wide(pattern.clone())
        };
        Self {
            nrows: pattern.nrows,
            lookup,
        }
    }

    /// Position of entry (r, c) in the value array, if it is in the pattern.
    #[inline]
    pub fn get(&self, r: usize, c: usize) -> Option<usize> {
        match &self.lookup {
            Lookup::Dense(t) => {
                if r >= self.nrows {
                    return None;
                }
                let k = *t.get(c.checked_mul(self.nrows)? + r)?;
                (k != u32::MAX).then_some(k as usize)
            }
            Lookup::Compact { col_ptr, rows } => {
                let (a, b) = (*col_ptr.get(c)? as usize, *col_ptr.get(c + 1)? as usize);
                let r = u32::try_from(r).ok()?;
                rows[a..b].binary_search(&r).ok().map(|k| a + k)
            }
            Lookup::Wide(p) => (c < p.ncols).then(|| p.find(r, c)).flatten(),
        }
    }
}

/// A sparse matrix: values on a shared [`CscPattern`].
#[derive(Debug, Clone)]
pub struct CscMatrix {
    pattern: Arc<CscPattern>,
    values: Vec<f64>,
}

impl CscMatrix {
    /// A zero matrix on `pattern`.
    pub fn zeros(pattern: Arc<CscPattern>) -> Self {
        let values = vec![0.0; pattern.nnz()];
        Self { pattern, values }
    }
    /// The pattern.
    pub fn pattern(&self) -> &Arc<CscPattern> {
        &self.pattern
    }
    /// The stored values, in pattern order.
    pub fn values(&self) -> &[f64] {
        &self.values
    }
    /// Mutable stored values, in pattern order.
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }
    /// y ← y + A·x.
    pub fn mul_add(&self, x: &[f64], y: &mut [f64]) {
        for (c, &xc) in x.iter().enumerate().take(self.pattern.ncols()) {
            if xc == 0.0 {
                continue;
            }
            for k in self.pattern.col_range(c) {
                y[self.pattern.row_idx[k]] += self.values[k] * xc;
            }
        }
    }
    /// Dense copy (row-major `Vec<Vec<f64>>`), for tests and small diagnostics.
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let mut d = vec![vec![0.0; self.pattern.ncols()]; self.pattern.nrows()];
        for c in 0..self.pattern.ncols() {
            for k in self.pattern.col_range(c) {
                d[self.pattern.row_idx[k]][c] = self.values[k];
            }
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn from_entries_sorts_and_merges() {
        let p = CscPattern::from_entries(3, 2, [(2, 0), (0, 0), (2, 0), (1, 1)]).unwrap();
        assert_eq!(p.col_ptr(), &[0, 2, 3]);
        assert_eq!(p.row_idx(), &[0, 2, 1]);
        assert_eq!(p.find(2, 0), Some(1));
        assert_eq!(p.find(1, 0), None);
        let idx = SlotIndex::new(&p);
        for c in 0..p.ncols() {
            for r in 0..p.nrows() {
                assert_eq!(idx.get(r, c), p.find(r, c));
            }
        }
    }

    #[test]
    fn every_lookup_agrees_with_the_search_of_the_pattern() {
        // A banded pattern with gaps, 1 500 × 1 500: more cells than the dense table takes,
        // so the compact search answers; the same pattern's first 1 000 rows and columns
        // fit the table. Every cell, present or not, and cells outside the matrix.
        let n: usize = 1_500;
        let entries = (0..n).flat_map(|c| {
            (c.saturating_sub(7)..(c + 9).min(n))
                .filter(move |r| (r * 7 + c * 3) % 5 != 0)
                .map(move |r| (r, c))
        });
        let big = CscPattern::from_entries(n, n, entries.clone()).unwrap();
        let small =
            CscPattern::from_entries(1_000, 1_000, entries.filter(|&(r, c)| r < 1_000 && c < 1_000)).unwrap();
        for (p, dense) in [(&big, false), (&small, true)] {
            assert_eq!(p.nrows() * p.ncols() <= SlotIndex::DENSE_LIMIT, dense);
            let idx = SlotIndex::new(p);
            assert_eq!(matches!(idx.lookup, Lookup::Dense(_)), dense);
            let mut found = 0;
            for c in 0..p.ncols() {
                for r in 0..p.nrows() {
                    assert_eq!(idx.get(r, c), p.find(r, c), "({r}, {c})");
                    found += usize::from(idx.get(r, c).is_some());
                }
                assert_eq!(idx.get(p.nrows(), c), None);
            }
            assert_eq!(found, p.nnz());
            assert_eq!(idx.get(0, p.ncols()), None);
            assert_eq!(idx.get(usize::MAX, 0), None);
        }
    }

    #[test]
    fn rejects_bad_arrays() {
        assert!(matches!(
            CscPattern::new(2, 2, vec![0, 1], vec![0]),
            Err(PatternError::ColPtr(_))
        ));
        assert!(matches!(
            CscPattern::new(2, 1, vec![0, 1], vec![5]),
            Err(PatternError::RowOutOfRange { .. })
        ));
        assert!(matches!(
            CscPattern::new(2, 1, vec![0, 2], vec![1, 0]),
            Err(PatternError::Unsorted { .. })
        ));
        assert!(CscPattern::from_entries(2, 2, [(0, 3)]).is_err());
    }

    #[test]
    fn mul_add_matches_dense() {
        let p = Arc::new(CscPattern::dense(2, 2));
        let mut m = CscMatrix::zeros(p);
        m.values_mut().copy_from_slice(&[1.0, 3.0, 2.0, 4.0]);
        let mut y = vec![0.0; 2];
        m.mul_add(&[1.0, 1.0], &mut y);
        assert_eq!(y, vec![3.0, 7.0]);
        assert_eq!(m.to_dense(), vec![vec![1.0, 2.0], vec![3.0, 4.0]]);
    }
}
