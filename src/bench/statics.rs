//! `lash bench statics`: the static envelope of the paper's Table 3 (method (b), 13 load
//! cases per point and clearance set) by the direct equilibrium solver
//! ([`crate::mechanisms::mr2120::accuracy::static_envelope`]) and by dynamic
//! relaxation ([`crate::mechanisms::mr2120::accuracy::relaxation_envelope`]),
//! side by side in one run: wall times, their ratio, and how far the two envelopes differ.

use crate::mechanisms::mr2120::accuracy::{relaxation_envelope, static_envelope, Excitation, Ranges};
use crate::mechanisms::mr2120::geometry::{Geometry, MassProperties};
use crate::mechanisms::mr2120::ideal::Mr2120Error;
use crate::mechanisms::mr2120::paper::{ClearanceSet, Table2Point};
use serde::Serialize;
use std::time::Instant;

/// One point and clearance set by both methods.
#[derive(Debug, Clone, Serialize)]
pub struct StaticsRow {
    /// Point (M1, M2, M3).
    pub point: String,
    /// Clearance set.
    pub set: String,
    /// Wall time of the direct solver for the 13 load cases, s (best of the repeats).
    pub direct_s: f64,
    /// Wall time of dynamic relaxation for the same 13 cases, s.
    pub relaxation_s: f64,
    /// relaxation_s / direct_s.
    pub speedup: f64,
    /// Pseudo-steps of the direct solver.
    pub direct_steps: usize,
    /// Integrator steps of dynamic relaxation.
    pub relaxation_steps: usize,
    /// Largest difference of a range end between the methods, relative to the range's width
    /// (max over the six errors and both ends).
    pub max_rel_difference: f64,
    /// The direct solver's ranges: d in m, δ in rad.
    pub direct: Ranges,
    /// Dynamic relaxation's ranges, same units.
    pub relaxation: Ranges,
}

/// The whole benchmark.
#[derive(Debug, Clone, Serialize)]
pub struct StaticsBench {
    /// Per point and set.
    pub rows: Vec<StaticsRow>,
    /// Sum of the direct solver's wall times, s.
    pub direct_total_s: f64,
    /// Sum of dynamic relaxation's wall times, s.
    pub relaxation_total_s: f64,
    /// relaxation_total_s / direct_total_s.
    pub speedup: f64,
    /// Direct wall time per load case (total / number of equilibria), s.
    pub direct_per_case_s: f64,
    /// Largest relative range difference over all rows.
    pub max_rel_difference: f64,
    /// Repeats per measurement (the best is kept).
    pub repeats: usize,
}

/// Relative difference of two envelopes: per error and end, |a − b| / max(width_a, width_b).
pub fn envelope_difference(a: &Ranges, b: &Ranges) -> f64 {
    let mut worst: f64 = 0.0;
    for k in 0..6 {
        let w = (a[k].1 - a[k].0).max(b[k].1 - b[k].0).max(f64::MIN_POSITIVE);
        worst = worst
            .max((a[k].0 - b[k].0).abs() / w)
            .max((a[k].1 - b[k].1).abs() / w);
    }
    worst
}

/// Runs both methods on every point × set, alternating them (direct, relaxation) `repeats`
/// times and keeping each one's best wall time. `progress(done, total)` after each pair.
pub fn statics_bench(
    g: &Geometry,
    mp: &MassProperties,
    points: &[Table2Point],
    sets: &[ClearanceSet],
    repeats: usize,
    mut progress: impl FnMut(usize, usize),
) -> Result<StaticsBench, Mr2120Error> {
    let ex = Excitation::default();
    let repeats = repeats.max(1);
    let total = points.len() * sets.len();
    let mut rows = vec![];
    for p in points {
        for s in sets {
            progress(rows.len(), total);
            let (mut direct_s, mut relaxation_s) = (f64::INFINITY, f64::INFINITY);
            let mut direct = None;
            let mut relaxation = None;
            for _ in 0..repeats {
                let t = Instant::now();
                direct = Some(static_envelope(g, mp, p, s, &ex)?);
                direct_s = direct_s.min(t.elapsed().as_secs_f64());
                let t = Instant::now();
                relaxation = Some(relaxation_envelope(g, mp, p, s, &ex)?);
                relaxation_s = relaxation_s.min(t.elapsed().as_secs_f64());
            }
            let (direct, direct_steps) = direct.expect("one repeat");
            let (relaxation, relaxation_steps) = relaxation.expect("one repeat");
            rows.push(StaticsRow {
                point: p.name.into(),
                set: s.name.into(),
                direct_s,
                relaxation_s,
                speedup: relaxation_s / direct_s,
                direct_steps,
                relaxation_steps,
                max_rel_difference: envelope_difference(&direct, &relaxation),
                direct,
                relaxation,
            });
        }
    }
    progress(total, total);
    let direct_total_s: f64 = rows.iter().map(|r| r.direct_s).sum();
    let relaxation_total_s: f64 = rows.iter().map(|r| r.relaxation_s).sum();
    let cases = crate::mechanisms::mr2120::accuracy::static_load_cases(&ex).len() * rows.len().max(1);
    Ok(StaticsBench {
        direct_total_s,
        relaxation_total_s,
        speedup: relaxation_total_s / direct_total_s,
        direct_per_case_s: direct_total_s / cases as f64,
        max_rel_difference: rows.iter().map(|r| r.max_rel_difference).fold(0.0, f64::max),
        rows,
        repeats,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_difference_is_relative_to_the_width() {
        let a: Ranges = [(0.0, 1.0); 6];
        let mut b = a;
        b[2].1 = 1.05;
        assert!((envelope_difference(&a, &b) - 0.05 / 1.05).abs() < 1e-12);
        assert_eq!(envelope_difference(&a, &a), 0.0);
    }
}
