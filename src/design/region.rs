//! The region a clearance design must hold over: named poses, a path through poses, or a box
//! of the work zone. `Region::from_str` reads the form `lash design clearance --region`
//! takes:
//!
//! * `M1,M2` — the poses of Table 2 by name;
//! * `path:M1,M2,M3` — the straight path through the named poses (or `x y z` positions in m,
//!   e.g. `path:0 0 0.5,0.1 0 0.45`), sampled at `per_segment` poses a leg (ends included);
//! * `box:xmin,xmax,ymin,ymax,zmin,zmax` — a box of platform-centre positions (m), sampled at
//!   `per_side` poses a side; poses outside the work zone are left out (and counted).
//!
//! ```
//! use lash::design::region::Region;
//! let r: Region = "path:M1,M2".parse().unwrap();
//! let poses = r.poses(&lash::mechanisms::mr2120::Geometry::default(), 5).unwrap();
//! assert_eq!(poses.poses.len(), 5);
//! assert!("box:0,1".parse::<Region>().is_err());
//! ```

use super::allowable::DesignError;
use crate::mechanisms::mr2120::geometry::Geometry;
use crate::mechanisms::mr2120::kinematics::inverse;
use crate::mechanisms::mr2120::paper::{Table2Point, TABLE2};
use nalgebra::Vector3;
use serde::Serialize;

/// Most poses a region may hold.
pub const MAX_POSES: usize = 100_000;

/// A region of the work zone (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// Named poses of Table 2.
    Points(Vec<Table2Point>),
    /// The straight path through these platform-centre positions (m), in order.
    Path(Vec<[f64; 3]>),
    /// A box of platform-centre positions: lower and upper corners (m).
    Box([f64; 3], [f64; 3]),
}

/// The poses of a region.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionPoses {
    /// The poses inside the work zone (platform centre in m, drive angles in degrees).
    pub poses: Vec<Table2Point>,
    /// Sampled positions left out because the platform cannot reach them.
    pub unreachable: usize,
}

fn bad(s: &str, why: &str) -> DesignError {
    DesignError::BadRegion(format!("'{s}': {why}"))
}

fn named(name: &str) -> Option<Table2Point> {
    TABLE2
        .iter()
        .copied()
        .find(|p| p.name.eq_ignore_ascii_case(name.trim()))
}

fn numbers(s: &str, sep: char) -> Option<Vec<f64>> {
    s.split(sep)
        .map(|v| v.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect()
}

impl std::str::FromStr for Region {
    type Err = DesignError;

    fn from_str(s: &str) -> Result<Self, DesignError> {
        let t = s.trim();
        if let Some(rest) = t.strip_prefix("path:") {
            let through: Option<Vec<[f64; 3]>> = rest
                .split(',')
                .map(|p| {
                    named(p).map(|p| p.m).or_else(|| {
                        numbers(p.trim(), ' ')
                            .filter(|v| v.len() == 3)
                            .map(|v| [v[0], v[1], v[2]])
                    })
                })
                .collect();
            let through = through.ok_or_else(|| {
                bad(s, "a path goes through named poses (M1, M2, M3) or 'x y z' positions in m, separated by commas")
            })?;
            if through.len() < 2 {
                return Err(bad(s, "a path needs at least two poses"));
            }
            return Ok(Region::Path(through));
        }
        if let Some(rest) = t.strip_prefix("box:") {
            let v = numbers(rest, ',')
                .filter(|v| v.len() == 6)
                .ok_or_else(|| bad(s, "a box is xmin,xmax,ymin,ymax,zmin,zmax in m"))?;
            let (lo, hi) = ([v[0], v[2], v[4]], [v[1], v[3], v[5]]);
            if (0..3).any(|k| lo[k] > hi[k]) {
                return Err(bad(s, "each minimum must not exceed its maximum"));
            }
            return Ok(Region::Box(lo, hi));
        }
        let points: Option<Vec<Table2Point>> = t.split(',').map(named).collect();
        match points {
            Some(p) if !p.is_empty() => Ok(Region::Points(p)),
            _ => Err(bad(
                s,
                "expected pose names (M1, M2, M3), 'path:…' or 'box:xmin,xmax,ymin,ymax,zmin,zmax'",
            )),
        }
    }
}

impl Region {
    /// The region's poses: a path sampled at `samples` poses a leg, a box at `samples` a
    /// side (named poses ignore it). Errors: fewer than 2 samples for a path or a box, more
    /// than [`MAX_POSES`] poses, or no pose inside the work zone.
    pub fn poses(&self, g: &Geometry, samples: usize) -> Result<RegionPoses, DesignError> {
        let positions: Vec<[f64; 3]> = match self {
            Region::Points(p) => {
                return Ok(RegionPoses {
                    poses: p.clone(),
                    unreachable: 0,
                })
            }
            Region::Path(through) => {
                if samples < 2 {
                    return Err(DesignError::BadRegion(format!(
                        "a path needs at least 2 samples a leg, not {samples}"
                    )));
                }
                let mut out = vec![through[0]];
                for leg in through.windows(2) {
                    let (a, b) = (Vector3::from(leg[0]), Vector3::from(leg[1]));
                    for k in 1..samples {
                        let p = a + (b - a) * (k as f64 / (samples - 1) as f64);
                        out.push(p.into());
                    }
                }
                out
            }
            Region::Box(lo, hi) => {
                if samples < 2 || samples.saturating_pow(3) > MAX_POSES {
                    return Err(DesignError::BadRegion(format!(
                        "a box takes 2 to {} samples a side, not {samples}",
                        (MAX_POSES as f64).cbrt().floor()
                    )));
                }
                let at = |k: usize, i: usize| lo[k] + (hi[k] - lo[k]) * i as f64 / (samples - 1) as f64;
                let mut out = vec![];
                for iz in 0..samples {
                    for iy in 0..samples {
                        for ix in 0..samples {
                            out.push([at(0, ix), at(1, iy), at(2, iz)]);
                        }
                    }
                }
                out.dedup();
                out
            }
        };
        if positions.len() > MAX_POSES {
            return Err(DesignError::BadRegion(format!(
                "{} poses; at most {MAX_POSES}",
                positions.len()
            )));
        }
        let mut poses = vec![];
        let mut unreachable = 0;
        for m in positions {
            match inverse(g, Vector3::from(m)) {
                Ok(q) => poses.push(Table2Point {
                    name: "region",
                    m,
                    q_deg: q.map(f64::to_degrees),
                }),
                Err(_) => unreachable += 1,
            }
        }
        if poses.is_empty() {
            return Err(DesignError::OutsideWorkZone(format!(
                "the platform reaches none of the region's {unreachable} poses"
            )));
        }
        Ok(RegionPoses { poses, unreachable })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn regions_parse_and_sample() {
        let g = Geometry::default();
        let r: Region = "M1, m2".parse().unwrap();
        assert_eq!(r.poses(&g, 2).unwrap().poses.len(), 2);
        let path: Region = "path:M1,0 0 0.4,M2".parse().unwrap();
        let p = path.poses(&g, 3).unwrap();
        assert_eq!(p.poses.len(), 5);
        assert_eq!(p.poses[1].m, [0.0, 0.0, 0.45]);
        assert_eq!(p.poses[4].m, TABLE2[1].m);
        let b: Region = "box:-0.05,0.05,-0.05,0.05,0.45,0.5".parse().unwrap();
        let p = b.poses(&g, 3).unwrap();
        assert_eq!(p.poses.len() + p.unreachable, 27);
        for bad in [
            "",
            "M7",
            "path:M1",
            "path:M1,1 2",
            "box:1,0,0,1,0,1",
            "box:0,1",
            "box:a,1,0,1,0,1",
        ] {
            assert!(
                matches!(bad.parse::<Region>(), Err(DesignError::BadRegion(_))),
                "{bad}"
            );
        }
        assert!(matches!(path.poses(&g, 1), Err(DesignError::BadRegion(_))));
        assert!(matches!(b.poses(&g, 1000), Err(DesignError::BadRegion(_))));
        let far: Region = "box:5,6,5,6,5,6".parse().unwrap();
        assert!(matches!(far.poses(&g, 2), Err(DesignError::OutsideWorkZone(_))));
    }
}
