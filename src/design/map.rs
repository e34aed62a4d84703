//! Worst-case error maps over a slice of the MR2120's work zone: at every pose of a grid in a
//! horizontal plane z = const, the largest |d_x|, |d_y|, |d_z|, |δx|, |δy|, |δz| (eq. 4.1)
//! over the static load cases for one clearance set, by the first-order play bound
//! ([`linear_envelope`]) at every cell and, on every k-th cell in both directions, by the
//! nonlinear equilibria of the clearance model ([`static_envelope`]); where both exist, how
//! far they part.
//!
//! A cell the platform cannot reach (no inverse kinematics) is outside the work zone; a
//! reachable cell where the first order has no answer sits on a singular locus (the
//! assembly's sensitivity is singular there). Cells are evaluated in parallel (rayon).

use super::allowable::{Accuracy, DesignError};
use crate::mechanisms::mr2120::accuracy::{linear_envelope, static_envelope, Excitation, Ranges};
use crate::mechanisms::mr2120::geometry::{Geometry, MassProperties};
use crate::mechanisms::mr2120::ideal::Mr2120Error;
use crate::mechanisms::mr2120::kinematics::{inverse, singularity};
use crate::mechanisms::mr2120::paper::{ClearanceSet, Table2Point};
use crate::multibody::ModelError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Most cells a map may have in either direction.
pub const MAX_CELLS_PER_SIDE: usize = 1000;

/// Largest |coordinate| of a map's grid, m (the mechanism spans decimetres; the plots draw
/// millimetres).
pub const MAX_GRID_COORDINATE: f64 = 1e3;

/// A grid of platform-centre positions in the plane z = `z` (base frame, m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MapGrid {
    /// Height of the plane, m.
    pub z: f64,
    /// x range [min, max], m.
    pub x: [f64; 2],
    /// y range [min, max], m.
    pub y: [f64; 2],
    /// Cells along x (≥ 2).
    pub nx: usize,
    /// Cells along y (≥ 2).
    pub ny: usize,
    /// The nonlinear equilibria are solved on every `nonlinear_every`-th cell in both
    /// directions (0: none).
    pub nonlinear_every: usize,
}

impl MapGrid {
    /// The x coordinate of column `i`, m.
    pub fn x_at(&self, i: usize) -> f64 {
        self.x[0] + (self.x[1] - self.x[0]) * i as f64 / (self.nx - 1) as f64
    }
    /// The y coordinate of row `k`, m.
    pub fn y_at(&self, k: usize) -> f64 {
        self.y[0] + (self.y[1] - self.y[0]) * k as f64 / (self.ny - 1) as f64
    }
}

/// What a cell is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CellKind {
    /// Reachable, the first order has an answer.
    Regular,
    /// Reachable, but the first-order sensitivity is singular there.
    Singular,
    /// Outside the work zone (no inverse kinematics).
    Unreachable,
}

/// One cell of a map.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MapCell {
    /// Platform centre x, m.
    pub x: f64,
    /// Platform centre y, m.
    pub y: f64,
    /// What the cell is.
    pub kind: CellKind,
    /// Direct-kinematics singularity measure (0 at a direct singularity), if reachable.
    pub direct_measure: Option<f64>,
    /// First-order worst |error| per component over the load cases (d in m, δ in rad).
    pub linear: Option<[f64; 6]>,
    /// Nonlinear worst |error| per component (on the nonlinear sub-grid only).
    pub nonlinear: Option<[f64; 6]>,
}

/// Where the two methods part most.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Disagreement {
    /// The largest |nonlinear − linear| worst position error (max of |d_x|, |d_y|, |d_z|)
    /// over the cells that have both, m.
    pub position_m: f64,
    /// The same as a fraction of the nonlinear value there.
    pub relative: f64,
    /// Where (platform centre x, y), m.
    pub at: [f64; 2],
}

/// A worst-case error map (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ErrorMap {
    /// The grid.
    pub grid: MapGrid,
    /// The clearance set: name, radial and axial clearance (m).
    pub clearance: (String, f64, f64),
    /// Cells, row by row (y outer, x inner).
    pub cells: Vec<MapCell>,
    /// Where the first order and the equilibria part most (`None` without nonlinear cells).
    pub max_disagreement: Option<Disagreement>,
}

impl ErrorMap {
    /// The cell at column `i`, row `k`.
    pub fn cell(&self, i: usize, k: usize) -> &MapCell {
        &self.cells[k * self.grid.nx + i]
    }
}

/// The inverse question on a map: where a required accuracy holds for the map's clearances.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct AccuracyRegion {
    /// The accuracy asked for.
    pub accuracy: Accuracy,
    /// Cells inside the work zone.
    pub reachable: usize,
    /// Cells where the first order holds the accuracy.
    pub holds_first_order: usize,
    /// Reachable cells without a first-order answer (singular).
    pub singular: usize,
    /// Cells with a nonlinear answer.
    pub nonlinear_cells: usize,
    /// Of those, cells where the equilibria hold the accuracy.
    pub holds_nonlinear: usize,
    /// Cells with both answers where they disagree on whether the accuracy holds.
    pub methods_disagree: usize,
}

/// The largest error of `e` relative to its limit in `accuracy` (≤ 1: the accuracy holds).
pub fn accuracy_ratio(e: &[f64; 6], accuracy: &Accuracy) -> f64 {
    (0..6)
        .map(|c| {
            e[c] / if c < 3 {
                accuracy.position
            } else {
                accuracy.rotation
            }
        })
        .fold(0.0, f64::max)
}

impl ErrorMap {
    /// Where `accuracy` holds over the map (see [`AccuracyRegion`]).
    pub fn where_accuracy_holds(&self, accuracy: &Accuracy) -> AccuracyRegion {
        let holds = |e: &Option<[f64; 6]>| e.map(|e| accuracy_ratio(&e, accuracy) <= 1.0);
        let mut r = AccuracyRegion {
            accuracy: *accuracy,
            reachable: 0,
            holds_first_order: 0,
            singular: 0,
            nonlinear_cells: 0,
            holds_nonlinear: 0,
            methods_disagree: 0,
        };
        for c in &self.cells {
            r.reachable += usize::from(c.kind != CellKind::Unreachable);
            r.singular += usize::from(c.kind == CellKind::Singular);
            let (l, n) = (holds(&c.linear), holds(&c.nonlinear));
            r.holds_first_order += usize::from(l == Some(true));
            r.nonlinear_cells += usize::from(n.is_some());
            r.holds_nonlinear += usize::from(n == Some(true));
            r.methods_disagree += usize::from(matches!((l, n), (Some(a), Some(b)) if a != b));
        }
        r
    }
}

fn worst(r: &Ranges) -> [f64; 6] {
    std::array::from_fn(|k| r[k].0.abs().max(r[k].1.abs()))
}

/// The worst position error of a cell's errors, m.
pub fn worst_position(e: &[f64; 6]) -> f64 {
    e[0].max(e[1]).max(e[2])
}

/// One of `count` parts of a map ([`Shard::cells`]): the cells of the nonlinear sub-grid (the
/// expensive ones) and the others are each dealt out in turn in row-major order, so every
/// part gets an equal share of both and of each region of the slice. Written `index/count`
/// (e.g. `3/8`; Slurm's `$SLURM_ARRAY_TASK_ID` with `--array=0-7`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// This part, from 0.
    pub index: usize,
    /// Number of parts.
    pub count: usize,
}

impl MapGrid {
    /// Whether cell (column `i`, row `k`) is one of the nonlinear sub-grid's.
    pub fn is_nonlinear(&self, i: usize, k: usize) -> bool {
        let every = self.nonlinear_every;
        every > 0 && i % every == 0 && k % every == 0
    }
}

impl Shard {
    /// The part (0 ≤ part < `count`) that holds each cell of `grid`, by row-major number:
    /// the nonlinear sub-grid's cells and the others are each dealt out in turn.
    pub fn owners(grid: &MapGrid, count: usize) -> Vec<usize> {
        let (mut heavy, mut light) = (0usize, 0usize);
        (0..grid.nx * grid.ny)
            .map(|c| {
                let dealt = if grid.is_nonlinear(c % grid.nx, c / grid.nx) {
                    &mut heavy
                } else {
                    &mut light
                };
                *dealt += 1;
                (*dealt - 1) % count.max(1)
            })
            .collect()
    }

    /// The row-major numbers of this part's cells of `grid`, in increasing order.
    pub fn cells(&self, grid: &MapGrid) -> Vec<usize> {
        Self::owners(grid, self.count)
            .into_iter()
            .enumerate()
            .filter(|&(_, part)| part == self.index)
            .map(|(c, _)| c)
            .collect()
    }
}

impl std::str::FromStr for Shard {
    type Err = DesignError;
    fn from_str(s: &str) -> Result<Self, DesignError> {
        let bad = || DesignError::BadShard(format!("'{s}': expected K/N with 0 <= K < N, e.g. 0/4"));
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            k.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

/// Format tag of a [`MapPart`] file.
pub const MAP_PART_FORMAT: &str = "lash-map-part/1";

/// The cells of one shard of a map ([`error_map_part`]), to be joined by [`merge_parts`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapPart {
    /// [`MAP_PART_FORMAT`].
    pub format: String,
    /// The whole map's grid.
    pub grid: MapGrid,
    /// The clearance set: name, radial and axial clearance (m).
    pub clearance: (String, f64, f64),
    /// Which part.
    pub shard: Shard,
    /// The part's cells with their row-major numbers.
    pub cells: Vec<(usize, MapCell)>,
    /// Wall time of the part, s.
    pub wall_s: f64,
}

fn check_grid(grid: &MapGrid) -> Result<(), DesignError> {
    let sides_ok = |n: usize| (2..=MAX_CELLS_PER_SIDE).contains(&n);
    let finite = [grid.z, grid.x[0], grid.x[1], grid.y[0], grid.y[1]]
        .iter()
        .all(|v| v.is_finite() && v.abs() <= MAX_GRID_COORDINATE);
    if !(sides_ok(grid.nx) && sides_ok(grid.ny) && finite && grid.x[0] < grid.x[1] && grid.y[0] < grid.y[1]) {
        return Err(DesignError::BadGrid(format!(
            "x [{}, {}] m, y [{}, {}] m, z {} m, {} × {} cells: the ranges must be increasing and within ±{MAX_GRID_COORDINATE} m, 2 to {MAX_CELLS_PER_SIDE} cells a side",
            grid.x[0], grid.x[1], grid.y[0], grid.y[1], grid.z, grid.nx, grid.ny
        )));
    }
    Ok(())
}

/// The cells numbered `numbers` (row-major), in parallel.
fn cells_of(
    g: &Geometry,
    mp: &MassProperties,
    grid: &MapGrid,
    set: &ClearanceSet,
    numbers: Vec<usize>,
    progress: impl Fn(usize, usize) + Sync,
) -> Result<Vec<MapCell>, DesignError> {
    let ex = Excitation::default();
    let total = numbers.len();
    let done = AtomicUsize::new(0);
    numbers
        .into_par_iter()
        .map(|c| {
            let (i, k) = (c % grid.nx, c / grid.nx);
            let (x, y) = (grid.x_at(i), grid.y_at(k));
            let cell = evaluate(g, mp, grid, set, &ex, i, k, x, y);
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            cell
        })
        .collect()
}

/// The map of `set` over `grid` (see the [module docs](self)). `progress(done, total)` is
/// called as cells finish (from the worker threads).
pub fn error_map(
    g: &Geometry,
    mp: &MassProperties,
    grid: &MapGrid,
    set: &ClearanceSet,
    progress: impl Fn(usize, usize) + Sync,
) -> Result<ErrorMap, DesignError> {
    check_grid(grid)?;
    let cells = cells_of(g, mp, grid, set, (0..grid.nx * grid.ny).collect(), progress)?;
    assemble(*grid, (set.name.to_string(), set.radial, set.axial), cells)
}

/// One shard of [`error_map`]: the cells of part `shard` only (no check that the slice
/// meets the work zone: [`merge_parts`] makes it on the whole map).
pub fn error_map_part(
    g: &Geometry,
    mp: &MassProperties,
    grid: &MapGrid,
    set: &ClearanceSet,
    shard: Shard,
    progress: impl Fn(usize, usize) + Sync,
) -> Result<MapPart, DesignError> {
    check_grid(grid)?;
    if shard.count == 0 || shard.index >= shard.count {
        return Err(DesignError::BadShard(format!("{}/{}", shard.index, shard.count)));
    }
    let started = std::time::Instant::now();
    let numbers = shard.cells(grid);
    let cells = cells_of(g, mp, grid, set, numbers.clone(), progress)?;
    Ok(MapPart {
        format: MAP_PART_FORMAT.into(),
        grid: *grid,
        clearance: (set.name.to_string(), set.radial, set.axial),
        shard,
        cells: numbers.into_iter().zip(cells).collect(),
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// Joins the parts of a sharded map into the map [`error_map`] makes unsharded (the same
/// cells, bit for bit). Errors ([`DesignError::BadShard`]): no parts, another format, parts
/// of different grids, clearances or part counts, a part missing or given twice, a cell
/// missing or outside the grid.
pub fn merge_parts(parts: &[MapPart]) -> Result<ErrorMap, DesignError> {
    let bad = |why: String| Err(DesignError::BadShard(why));
    let Some(first) = parts.first() else {
        return bad("no parts to merge".into());
    };
    check_grid(&first.grid)?;
    let count = first.shard.count;
    let total = first.grid.nx * first.grid.ny;
    if count == 0 || count > total {
        return bad(format!("{count} parts for a map of {total} cells"));
    }
    let mut seen = vec![false; count];
    let mut cells: Vec<Option<MapCell>> = vec![None; total];
    let own = Shard::owners(&first.grid, count);
    for p in parts {
        if p.format != MAP_PART_FORMAT {
            return bad(format!("format '{}', expected '{MAP_PART_FORMAT}'", p.format));
        }
        if p.grid != first.grid || p.clearance != first.clearance || p.shard.count != count {
            return bad(format!(
                "part {}/{} is of another map (grid, clearance set or number of parts differ from part {}/{})",
                p.shard.index, p.shard.count, first.shard.index, count
            ));
        }
        if p.shard.index >= count || std::mem::replace(&mut seen[p.shard.index], true) {
            return bad(format!(
                "part {}/{count} is out of range or given twice",
                p.shard.index
            ));
        }
        for (c, cell) in &p.cells {
            if *c >= total || own[*c] != p.shard.index || cells[*c].is_some() {
                return bad(format!(
                    "part {}/{count} holds cell {c}, not one of its own",
                    p.shard.index
                ));
            }
            cells[*c] = Some(*cell);
        }
    }
    if let Some(k) = seen.iter().position(|s| !s) {
        return bad(format!("part {k}/{count} is missing"));
    }
    let cells: Option<Vec<MapCell>> = cells.into_iter().collect();
    let Some(cells) = cells else {
        return bad("a part lacks some of its cells".into());
    };
    assemble(first.grid, first.clearance.clone(), cells)
}

/// The map of `cells` (all of `grid`, row-major): the work-zone check and where the methods
/// part most.
fn assemble(
    grid: MapGrid,
    clearance: (String, f64, f64),
    cells: Vec<MapCell>,
) -> Result<ErrorMap, DesignError> {
    let total = cells.len();
    if cells.iter().all(|c| c.kind == CellKind::Unreachable) {
        return Err(DesignError::OutsideWorkZone(format!(
            "z {} m, x [{}, {}] m, y [{}, {}] m: the platform reaches none of its {} cells",
            grid.z, grid.x[0], grid.x[1], grid.y[0], grid.y[1], total
        )));
    }
    let max_disagreement = cells
        .iter()
        .filter_map(|c| match (c.linear, c.nonlinear) {
            (Some(l), Some(n)) => {
                let (l, n) = (worst_position(&l), worst_position(&n));
                Some(Disagreement {
                    position_m: (n - l).abs(),
                    relative: (n - l).abs() / n.max(f64::MIN_POSITIVE),
                    at: [c.x, c.y],
                })
            }
            _ => None,
        })
        .max_by(|a, b| a.position_m.total_cmp(&b.position_m));
    Ok(ErrorMap {
        grid,
        clearance,
        cells,
        max_disagreement,
    })
}

#[allow(clippy::too_many_arguments)]
fn evaluate(
    g: &Geometry,
    mp: &MassProperties,
    grid: &MapGrid,
    set: &ClearanceSet,
    ex: &Excitation,
    i: usize,
    k: usize,
    x: f64,
    y: f64,
) -> Result<MapCell, DesignError> {
    let m = nalgebra::Vector3::new(x, y, grid.z);
    let Ok(q) = inverse(g, m) else {
        return Ok(MapCell {
            x,
            y,
            kind: CellKind::Unreachable,
            direct_measure: None,
            linear: None,
            nonlinear: None,
        });
    };
    let direct_measure = Some(singularity(g, q, m).direct_measure);
    let pose = Table2Point {
        name: "map",
        m: [x, y, grid.z],
        q_deg: q.map(f64::to_degrees),
    };
    let (kind, linear) = match linear_envelope(g, mp, &pose, set, ex) {
        Ok(r) => (CellKind::Regular, Some(worst(&r))),
        Err(Mr2120Error::Model(ModelError::Singular { .. })) => (CellKind::Singular, None),
        // A pose the ideal model cannot assemble or evaluate counts as singular: the
        // first order has no answer there either.
        Err(Mr2120Error::Model(_)) => (CellKind::Singular, None),
        Err(e) => return Err(e.into()),
    };
    let nonlinear = if grid.is_nonlinear(i, k) {
        static_envelope(g, mp, &pose, set, ex)
            .ok()
            .map(|(r, _)| worst(&r))
    } else {
        None
    };
    Ok(MapCell {
        x,
        y,
        kind,
        direct_measure,
        linear,
        nonlinear,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanisms::mr2120::clearance::clearance_set;

    /// A grid out to ±1e306 m (finite, but not in millimetres) is refused.
    #[test]
    fn a_grid_beyond_the_largest_coordinate_is_refused() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let set = clearance_set("L1").unwrap();
        let grid = MapGrid {
            z: 0.5,
            x: [-1e306, 1e306],
            y: [-1.0, 1.0],
            nx: 2,
            ny: 2,
            nonlinear_every: 2,
        };
        let e = error_map(&g, &mp, &grid, &set, |_, _| {})
            .unwrap_err()
            .to_string();
        assert!(e.contains("within ±1000 m"), "{e}");
    }

    /// A small map at the height of M1: the centre cell is M1 itself and agrees with the
    /// first-order envelope there; cells far outside are unreachable; the nonlinear cells
    /// exist where asked and part from the first order by less than their own value at this
    /// regular height.
    #[test]
    fn a_map_at_m1_height_holds_m1_and_the_work_zone_edge() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let set = clearance_set("L1").unwrap();
        let grid = MapGrid {
            z: 0.5,
            x: [-2.0, 0.0],
            y: [-2.0, 0.0],
            nx: 3,
            ny: 3,
            nonlinear_every: 2,
        };
        let map = error_map(&g, &mp, &grid, &set, |_, _| {}).unwrap();
        assert_eq!(map.cells.len(), 9);
        let m1 = map.cell(2, 2);
        assert_eq!((m1.x, m1.y), (0.0, 0.0));
        assert_eq!(m1.kind, CellKind::Regular);
        let direct = linear_envelope(
            &g,
            &mp,
            &crate::mechanisms::mr2120::paper::TABLE2[0],
            &set,
            &Excitation::default(),
        )
        .unwrap();
        assert_eq!(m1.linear.unwrap(), worst(&direct));
        assert_eq!(map.cell(0, 0).kind, CellKind::Unreachable, "2 m off the axis");
        let n = m1.nonlinear.expect("a nonlinear cell");
        let d = map.max_disagreement.expect("one cell has both");
        assert!(d.relative < 1.0, "{d:?} (nonlinear {n:?})");
        // The inverse question: a loose accuracy holds wherever there is an answer, a
        // needlessly tight one nowhere.
        let loose = map.where_accuracy_holds(&Accuracy {
            position: 1.0,
            rotation: 1.0,
        });
        assert!(loose.reachable >= 1 && loose.reachable < 9, "{loose:?}");
        assert_eq!(loose.holds_first_order, loose.reachable - loose.singular);
        assert_eq!(loose.holds_nonlinear, loose.nonlinear_cells);
        let tight = map.where_accuracy_holds(&Accuracy {
            position: 1e-9,
            rotation: 1e-9,
        });
        assert_eq!((tight.holds_first_order, tight.holds_nonlinear), (0, 0));
        // Sharded in 2 and 4 parts, written as JSON and read back, merged: the same map.
        for count in [2, 4] {
            let parts: Vec<MapPart> = (0..count)
                .map(|index| {
                    let part =
                        error_map_part(&g, &mp, &grid, &set, Shard { index, count }, |_, _| {}).unwrap();
                    serde_json::from_str(&serde_json::to_string(&part).unwrap()).unwrap()
                })
                .collect();
            assert_eq!(merge_parts(&parts).unwrap(), map);
            let mut reversed = parts.clone();
            reversed.reverse();
            assert_eq!(merge_parts(&reversed).unwrap(), map);
            assert!(matches!(merge_parts(&parts[1..]), Err(DesignError::BadShard(_))));
            let twice = [parts.clone(), vec![parts[0].clone()]].concat();
            assert!(matches!(merge_parts(&twice), Err(DesignError::BadShard(_))));
        }
        let other = error_map_part(&g, &mp, &grid, &set, Shard { index: 1, count: 3 }, |_, _| {}).unwrap();
        let first = error_map_part(&g, &mp, &grid, &set, Shard { index: 0, count: 2 }, |_, _| {}).unwrap();
        assert!(matches!(
            merge_parts(&[first, other]),
            Err(DesignError::BadShard(_))
        ));
        assert!(matches!(merge_parts(&[]), Err(DesignError::BadShard(_))));
        // Every cell in exactly one part; the nonlinear cells spread evenly.
        let big = MapGrid {
            nx: 101,
            ny: 101,
            nonlinear_every: 10,
            ..grid
        };
        let mut owner = vec![0usize; 101 * 101];
        let mut heavy = vec![];
        for index in 0..4 {
            let cells = Shard { index, count: 4 }.cells(&big);
            heavy.push(
                cells
                    .iter()
                    .filter(|&&c| big.is_nonlinear(c % 101, c / 101))
                    .count(),
            );
            for c in cells {
                owner[c] += 1;
            }
        }
        assert!(owner.iter().all(|&o| o == 1));
        assert!(
            heavy.iter().max().unwrap() - heavy.iter().min().unwrap() <= 1,
            "{heavy:?}"
        );
        for bad in ["", "3", "2/2", "a/4", "0/0", "-1/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        assert_eq!("3/8".parse::<Shard>().unwrap(), Shard { index: 3, count: 8 });
        let bad = MapGrid { nx: 1, ..grid };
        assert!(matches!(
            error_map(&g, &mp, &bad, &set, |_, _| {}),
            Err(DesignError::BadGrid(_))
        ));
        let outside = MapGrid { z: 5.0, ..grid };
        assert!(matches!(
            error_map(&g, &mp, &outside, &set, |_, _| {}),
            Err(DesignError::OutsideWorkZone(_))
        ));
    }
}
