//! Column colouring for compressed finite-difference Jacobians (Curtis–Powell–Reid).

use super::CscPattern;

/// Greedy column colouring: two columns get different colours when they share a row.
///
/// Returns `(colour of each column, number of colours)`. All columns of one colour can be
/// perturbed together in a finite-difference Jacobian, since their nonzeros never overlap.
/// Columns are visited in order of decreasing degree, which usually gives fewer colours.
pub fn column_colouring(pattern: &CscPattern) -> (Vec<usize>, usize) {
    let n = pattern.ncols();
    // Row → columns incidence.
    let mut row_cols: Vec<Vec<usize>> = vec![Vec::new(); pattern.nrows()];
    for c in 0..n {
        for &r in pattern.col_rows(c) {
            row_cols[r].push(c);
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&c| std::cmp::Reverse(pattern.col_rows(c).len()));
    let mut colour = vec![usize::MAX; n];
    let mut forbidden: Vec<usize> = Vec::new(); // forbidden[k] == c+1 marks colour k used near c
    let mut ncolours = 0;
    for &c in &order {
        for &r in pattern.col_rows(c) {
            for &other in &row_cols[r] {
                let k = colour[other];
                if k != usize::MAX {
                    forbidden[k] = c + 1;
                }
            }
        }
        let k = (0..ncolours).find(|&k| forbidden[k] != c + 1).unwrap_or_else(|| {
            forbidden.push(0);
            ncolours += 1;
            ncolours - 1
        });
        colour[c] = k;
    }
    (colour, ncolours)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tridiagonal_needs_three_colours() {
        let n = 10;
        let entries = (0..n).flat_map(|i| {
            let mut v = vec![(i, i)];
            if i > 0 {
                v.push((i - 1, i));
            }
            if i + 1 < n {
                v.push((i + 1, i));
            }
            v
        });
        let p = CscPattern::from_entries(n, n, entries).unwrap();
        let (colour, k) = column_colouring(&p);
        assert_eq!(k, 3);
        // No two columns of one colour share a row.
        for r in 0..n {
            let cols: Vec<usize> = (0..n).filter(|&c| p.find(r, c).is_some()).collect();
            for a in 0..cols.len() {
                for b in a + 1..cols.len() {
                    assert_ne!(colour[cols[a]], colour[cols[b]]);
                }
            }
        }
    }

    #[test]
    fn diagonal_needs_one_colour() {
        let p = CscPattern::from_entries(5, 5, (0..5).map(|i| (i, i))).unwrap();
        assert_eq!(column_colouring(&p).1, 1);
    }
}
