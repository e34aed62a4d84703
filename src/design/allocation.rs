//! Allowable clearance per joint and per direction over a region, under a cost model, each
//! answer verified by the nonlinear equilibria.
//!
//! **First order.** At every pose of the region and in every static load case
//! ([`static_load_cases`](crate::mechanisms::mr2120::accuracy::static_load_cases)), each
//! universal joint's radial clearance h_LR,k and axial clearance h_LW,k move the platform by
//! h_LR,k · r_k + h_LW,k · a_k ([`linear_per_joint`], the play model of
//! [`crate::contact::play`]). A design meets the accuracy to first order if, for every pose,
//! case and error component c (d_x … δz, limit e_c),
//!
//! e⁰_c + Σ_k (|r_k,c| · h_LR,k + |a_k,c| · h_LW,k) ≤ e_c,
//!
//! the joints' contributions added in absolute value: no cancellation between joints is
//! relied upon (which side a joint's play sits on may differ from the ideal model's
//! prediction in a real machine), so the bound is conservative. e⁰_c is the contact
//! elasticity's share, which the play bound leaves out: the worst |error| of the 63-DOF
//! equilibria at that pose with a vanishing clearance ([`VANISHING_CLEARANCE`]); where it
//! alone exceeds the accuracy no clearance is allowable ([`DesignError::NoClearanceAllowable`]). Among the designs that meet
//! it, the allocation minimises the cost Σ_k (w_LR,k / h_LR,k + w_LW,k / h_LW,k) — a tighter
//! clearance costs more, as 1/h ([`CostModel`]). Three designs are compared
//! ([`Grouping`]): one clearance for everything, one per direction (radial, axial), one per
//! joint and direction. The problem is convex (a convex cost over linear constraints); it is
//! solved by a log-barrier interior-point method with Newton steps ([`min_inverse_cost`]).
//!
//! **Verified.** Each first-order design h is then scaled: the largest s with every static
//! equilibrium of the 63-DOF clearance model at s·h, at every pose of the region, meeting the
//! accuracy (growing or halving s, then bisection to [`BISECTION_TOLERANCE`]). s < 1 means
//! the first order promised too much (contact elasticity, or the first order's failure near
//! a singularity); s > 1 that the conservative bound left room. The verified cost is the
//! cost at s·h; the designs are compared there.
//!
//! Units: clearances in m, errors in m and rad, cost in 1/m (weights dimensionless).

use super::allowable::{Accuracy, DesignError, BISECTION_TOLERANCE, MAX_CLEARANCE};
use crate::mechanisms::mr2120::accuracy::{linear_per_joint, static_envelope_per_joint, Excitation};
use crate::mechanisms::mr2120::clearance::{JointClearances, UNIVERSAL_JOINTS};
use crate::mechanisms::mr2120::geometry::{Geometry, MassProperties};
use crate::mechanisms::mr2120::ideal::Mr2120Error;
use crate::mechanisms::mr2120::paper::Table2Point;
use crate::multibody::ModelError;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Smallest verification scale tried before a design is declared unverifiable: below it the
/// contact elasticity alone breaks the accuracy.
pub const MIN_SCALE: f64 = 1e-3;

/// The clearance at which the equilibria give the contact elasticity's share of the error
/// (m): small against any clearance a design allows.
pub const VANISHING_CLEARANCE: f64 = 1e-9;

/// How the twelve clearances (radial and axial in six joints) are tied together.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Grouping {
    /// One clearance for all: h_LR = h_LW in every joint.
    Uniform,
    /// One radial and one axial clearance, the same in every joint.
    PerDirection,
    /// A radial and an axial clearance per joint.
    PerJoint,
}

impl Grouping {
    /// The three groupings, coarsest first.
    pub const ALL: [Grouping; 3] = [Grouping::Uniform, Grouping::PerDirection, Grouping::PerJoint];

    /// Number of free clearances.
    pub fn count(self) -> usize {
        match self {
            Grouping::Uniform => 1,
            Grouping::PerDirection => 2,
            Grouping::PerJoint => 12,
        }
    }

    /// The free clearance that clearance `k` takes (k < 6: radial in joint k; k ≥ 6: axial in
    /// joint k − 6).
    fn group(self, k: usize) -> usize {
        match self {
            Grouping::Uniform => 0,
            Grouping::PerDirection => k / 6,
            Grouping::PerJoint => k,
        }
    }
}

/// The cost of a design: Σ_k (radial\[k\] / h_LR,k + axial\[k\] / h_LW,k), 1/m, joints in the
/// order of [`UNIVERSAL_JOINTS`]. Weights are positive and dimensionless; all 1 by default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CostModel {
    /// Weight of each joint's radial clearance.
    pub radial: [f64; 6],
    /// Weight of each joint's axial clearance.
    pub axial: [f64; 6],
}

impl Default for CostModel {
    fn default() -> Self {
        Self {
            radial: [1.0; 6],
            axial: [1.0; 6],
        }
    }
}

impl CostModel {
    fn weight(&self, k: usize) -> f64 {
        if k < 6 {
            self.radial[k]
        } else {
            self.axial[k - 6]
        }
    }

    /// The cost of `h`, 1/m.
    pub fn cost(&self, h: &JointClearances) -> f64 {
        (0..6)
            .map(|k| self.radial[k] / h.radial[k] + self.axial[k] / h.axial[k])
            .sum()
    }
}

/// Where a design's worst error sits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Limiting {
    /// Platform centre of the pose, m.
    pub m: [f64; 3],
    /// The error component ("d_x", …, "δz").
    pub component: &'static str,
    /// Its worst |value| over the load cases there (m or rad).
    pub value: f64,
}

/// One design (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Allocation {
    /// How the clearances are tied.
    pub grouping: Grouping,
    /// The first-order optimum, m.
    pub first_order: JointClearances,
    /// Its cost, 1/m.
    pub first_order_cost: f64,
    /// The largest scale of the first-order design that the nonlinear equilibria verify
    /// (`None`: not even [`MIN_SCALE`]).
    pub scale: Option<f64>,
    /// The verified design, scale × first order, m.
    pub clearances: Option<JointClearances>,
    /// Its cost, 1/m.
    pub cost: Option<f64>,
    /// Largest |error| per component over the region's equilibria at the verified design (or
    /// at the smallest scale tried): d in m, δ in rad.
    pub nonlinear_errors: [f64; 6],
    /// The pose and component closest to its limit there (relative to the accuracy).
    pub limiting: Option<Limiting>,
    /// The verified design meets the accuracy at every pose.
    pub verified: bool,
}

/// The designs for a region (see the [module docs](self)).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegionDesign {
    /// The required accuracy.
    pub accuracy: Accuracy,
    /// Number of poses.
    pub poses: usize,
    /// The cost model.
    pub cost_model: CostModel,
    /// Uniform, per direction, per joint (in the order of [`Grouping::ALL`]).
    pub allocations: Vec<Allocation>,
}

impl RegionDesign {
    /// The design of one grouping.
    pub fn get(&self, grouping: Grouping) -> Option<&Allocation> {
        self.allocations.iter().find(|a| a.grouping == grouping)
    }
}

/// The worst errors of a design over the region, and where it is closest to its limit.
type Worst = ([f64; 6], Option<Limiting>);

const NAMES: [&str; 6] = ["d_x", "d_y", "d_z", "δx", "δy", "δz"];

fn limit(acc: &Accuracy, c: usize) -> f64 {
    if c < 3 {
        acc.position
    } else {
        acc.rotation
    }
}

/// min Σ_g w_g / x_g over 0 < x ≤ x_max subject to rows · x ≤ 1 (every row non-negative,
/// some positive): a log-barrier interior-point method with damped Newton steps, to a
/// duality gap of 1e-10 of the cost. `None` if the problem is not of that form.
pub fn min_inverse_cost(rows: &[Vec<f64>], w: &[f64], x_max: f64) -> Option<Vec<f64>> {
    let n = w.len();
    let ok = |v: f64| v.is_finite() && v >= 0.0;
    if n == 0
        || !(x_max > 0.0 && x_max.is_finite())
        || w.iter().any(|&v| !(v > 0.0 && v.is_finite()))
        || rows.iter().any(|r| r.len() != n || !r.iter().all(|&v| ok(v)))
    {
        return None;
    }
    let rows: Vec<&Vec<f64>> = rows.iter().filter(|r| r.iter().any(|&v| v > 0.0)).collect();
    // Scale: x = x0 · y with x0 the largest feasible uniform value.
    let widest = rows.iter().map(|r| r.iter().sum::<f64>()).fold(0.0, f64::max);
    let x0 = if widest > 0.0 {
        (1.0 / widest).min(x_max)
    } else {
        x_max
    };
    let y_max = x_max / x0;
    let a: Vec<Vec<f64>> = rows.iter().map(|r| r.iter().map(|v| v * x0).collect()).collect();
    let mut y = vec![0.5; n];
    let slack = |y: &[f64]| -> Option<Vec<f64>> {
        let s: Vec<f64> = a
            .iter()
            .map(|r| 1.0 - r.iter().zip(y).map(|(a, y)| a * y).sum::<f64>())
            .collect();
        (s.iter().all(|&s| s > 0.0) && y.iter().all(|&v| v > 0.0 && v < y_max)).then_some(s)
    };
    let phi = |t: f64, y: &[f64]| -> Option<f64> {
        let s = slack(y)?;
        Some(
            t * w.iter().zip(y).map(|(w, y)| w / y).sum::<f64>()
                - s.iter().map(|s| s.ln()).sum::<f64>()
                - y.iter().map(|y| (y_max - y).ln()).sum::<f64>(),
        )
    };
    let m = (a.len() + n) as f64;
    let mut t = 1.0;
    for _outer in 0..60 {
        for _newton in 0..100 {
            let s = slack(&y)?;
            let mut g = DVector::<f64>::zeros(n);
            let mut h = DMatrix::<f64>::zeros(n, n);
            for i in 0..n {
                g[i] = -t * w[i] / (y[i] * y[i]) + 1.0 / (y_max - y[i]);
                h[(i, i)] = 2.0 * t * w[i] / (y[i] * y[i] * y[i]) + 1.0 / (y_max - y[i]).powi(2);
            }
            for (r, s) in a.iter().zip(&s) {
                for i in 0..n {
                    g[i] += r[i] / s;
                    for j in 0..n {
                        h[(i, j)] += r[i] * r[j] / (s * s);
                    }
                }
            }
            let step = h.clone().cholesky()?.solve(&(-&g));
            let decrement = -g.dot(&step);
            if decrement < 1e-12 {
                break;
            }
            let f0 = phi(t, &y)?;
            let mut alpha = 1.0;
            loop {
                let trial: Vec<f64> = (0..n).map(|i| y[i] + alpha * step[i]).collect();
                if let Some(f) = phi(t, &trial) {
                    if f <= f0 - 0.25 * alpha * decrement {
                        y = trial;
                        break;
                    }
                }
                alpha *= 0.5;
                if alpha < 1e-14 {
                    return None;
                }
            }
        }
        let cost: f64 = w.iter().zip(&y).map(|(w, y)| w / y).sum();
        if m / t < 1e-10 * cost {
            break;
        }
        t *= 20.0;
    }
    Some(y.iter().map(|y| y * x0).collect())
}

/// The first-order optimum of one grouping from the per-joint coefficients: clearances
/// (m), or `None` if the solver fails.
fn first_order(
    coefficients: &[Vec<Vec<crate::contact::play_bound::PlayPoseError>>],
    elastic: &[[f64; 6]],
    accuracy: &Accuracy,
    cost: &CostModel,
    grouping: Grouping,
) -> Option<JointClearances> {
    let n = grouping.count();
    let mut rows = vec![];
    for (pose, e0) in coefficients.iter().zip(elastic) {
        for case in pose {
            for c in 0..6 {
                let room = limit(accuracy, c) - e0[c];
                let mut row = vec![0.0; n];
                for (j, e) in case.iter().enumerate() {
                    row[grouping.group(j)] += e.radial[c].abs() / room;
                    row[grouping.group(6 + j)] += e.axial[c].abs() / room;
                }
                rows.push(row);
            }
        }
    }
    let mut w = vec![0.0; n];
    for k in 0..12 {
        w[grouping.group(k)] += cost.weight(k);
    }
    let x = min_inverse_cost(&rows, &w, MAX_CLEARANCE)?;
    Some(JointClearances {
        radial: std::array::from_fn(|k| x[grouping.group(k)]),
        axial: std::array::from_fn(|k| x[grouping.group(6 + k)]),
    })
}

/// The worst errors over the region's equilibria at clearances `h`, and the pose and
/// component closest to its limit. A pose whose equilibria fail counts as infinitely wrong.
fn nonlinear_worst(
    g: &Geometry,
    mp: &MassProperties,
    poses: &[Table2Point],
    h: &JointClearances,
    accuracy: &Accuracy,
    done: &(dyn Fn() + Sync),
) -> ([f64; 6], Option<Limiting>) {
    let per_pose: Vec<[f64; 6]> = poses
        .par_iter()
        .map(|p| {
            let e = pose_worst(g, mp, p, h);
            done();
            e
        })
        .collect();
    let mut worst = [0.0f64; 6];
    let mut limiting: Option<(f64, Limiting)> = None;
    for (p, e) in poses.iter().zip(&per_pose) {
        for c in 0..6 {
            worst[c] = worst[c].max(e[c]);
            let rel = e[c] / limit(accuracy, c);
            if limiting.as_ref().is_none_or(|(r, _)| rel > *r) {
                limiting = Some((
                    rel,
                    Limiting {
                        m: p.m,
                        component: NAMES[c],
                        value: e[c],
                    },
                ));
            }
        }
    }
    (worst, limiting.map(|(_, l)| l))
}

/// The worst |error| per component over the load cases' equilibria at one pose; infinite
/// if they fail.
fn pose_worst(g: &Geometry, mp: &MassProperties, p: &Table2Point, h: &JointClearances) -> [f64; 6] {
    match static_envelope_per_joint(g, mp, p, h, &Excitation::default()) {
        Ok((r, _)) => std::array::from_fn(|c| r[c].0.abs().max(r[c].1.abs())),
        Err(_) => [f64::INFINITY; 6],
    }
}

fn meets(e: &[f64; 6], acc: &Accuracy) -> bool {
    (0..6).all(|c| e[c] <= limit(acc, c))
}

/// The designs of every [`Grouping`] for `poses` (see the [module docs](self)).
/// `progress(done, total)` counts pose evaluations (total estimated). Errors: a bad accuracy
/// or cost model, no pose, a pose where the first order has no answer
/// ([`DesignError::SingularPose`]: a singular configuration), or a failed model.
pub fn allocate(
    g: &Geometry,
    mp: &MassProperties,
    poses: &[Table2Point],
    accuracy: Accuracy,
    cost: CostModel,
    progress: impl Fn(usize, usize) + Sync,
) -> Result<RegionDesign, DesignError> {
    super::allowable::check_accuracy(&accuracy)?;
    if poses.is_empty() {
        return Err(DesignError::BadRegion("no pose".into()));
    }
    if cost
        .radial
        .iter()
        .chain(&cost.axial)
        .any(|&w| !(w > 0.0 && w.is_finite()))
    {
        return Err(DesignError::BadCost(format!("{cost:?}")));
    }
    let total = poses.len() * (2 + 3 * 12);
    let count = AtomicUsize::new(0);
    let done = || {
        let k = count.fetch_add(1, Ordering::Relaxed) + 1;
        progress(k.min(total - 1), total);
    };
    let ex = Excitation::default();
    let coefficients: Vec<_> = poses
        .par_iter()
        .map(|p| {
            let r = linear_per_joint(g, mp, p, &ex).map_err(|e| match e {
                Mr2120Error::Model(ModelError::Singular { measure, .. }) => {
                    DesignError::SingularPose { m: p.m, measure }
                }
                other => DesignError::Model(other),
            });
            done();
            r
        })
        .collect::<Result<_, _>>()?;
    // The contact elasticity's share: the equilibria at a vanishing clearance.
    let vanishing = JointClearances {
        radial: [VANISHING_CLEARANCE; 6],
        axial: [VANISHING_CLEARANCE; 6],
    };
    let elastic: Vec<[f64; 6]> = poses
        .par_iter()
        .map(|p| {
            let e = pose_worst(g, mp, p, &vanishing);
            done();
            e
        })
        .collect();
    for (p, e0) in poses.iter().zip(&elastic) {
        if let Some(c) = (0..6).find(|&c| e0[c].is_nan() || e0[c] >= limit(&accuracy, c)) {
            return Err(DesignError::NoClearanceAllowable {
                m: p.m,
                component: NAMES[c],
                elastic: e0[c],
            });
        }
    }
    let mut allocations = vec![];
    for grouping in Grouping::ALL {
        let h1 = first_order(&coefficients, &elastic, &accuracy, &cost, grouping).ok_or_else(|| {
            DesignError::BadCost(format!(
                "the first-order allocation ({grouping:?}) has no solution for {cost:?}"
            ))
        })?;
        let eval = |s: f64| nonlinear_worst(g, mp, poses, &h1.scaled(s), &accuracy, &done);
        let largest = (0..6).map(|k| h1.radial[k].max(h1.axial[k])).fold(0.0, f64::max);
        let mut at_one = eval(1.0);
        // Bracket: lo meets (or none does), hi fails (or the largest clearance is reached).
        let (mut lo, mut hi): (Option<(f64, Worst)>, f64);
        if meets(&at_one.0, &accuracy) {
            lo = Some((1.0, at_one));
            hi = 2.0;
            loop {
                if hi * largest > MAX_CLEARANCE {
                    hi = f64::INFINITY;
                    break;
                }
                let e = eval(hi);
                if !meets(&e.0, &accuracy) {
                    break;
                }
                lo = Some((hi, e));
                hi *= 2.0;
            }
        } else {
            hi = 1.0;
            lo = None;
            let mut s = 0.5;
            while s >= MIN_SCALE {
                let e = eval(s);
                if meets(&e.0, &accuracy) {
                    lo = Some((s, e));
                    break;
                }
                at_one = e;
                hi = s;
                s *= 0.5;
            }
        }
        if let Some((l, _)) = &lo {
            if hi.is_finite() {
                let mut l = *l;
                while hi / l - 1.0 > BISECTION_TOLERANCE {
                    let mid = (l * hi).sqrt();
                    let e = eval(mid);
                    if meets(&e.0, &accuracy) {
                        l = mid;
                        lo = Some((mid, e));
                    } else {
                        hi = mid;
                    }
                }
            }
        }
        let (scale, (errors, limiting)) = match lo {
            Some((s, e)) => (Some(s), e),
            None => (None, at_one),
        };
        let clearances = scale.map(|s| h1.scaled(s));
        allocations.push(Allocation {
            grouping,
            first_order: h1,
            first_order_cost: cost.cost(&h1),
            scale,
            clearances,
            cost: clearances.map(|h| cost.cost(&h)),
            verified: scale.is_some() && meets(&errors, &accuracy),
            nonlinear_errors: errors,
            limiting,
        });
    }
    progress(total, total);
    Ok(RegionDesign {
        accuracy,
        poses: poses.len(),
        cost_model: cost,
        allocations,
    })
}

/// Joint names in the order of the clearances (re-exported for reports).
pub const JOINTS: [&str; 6] = UNIVERSAL_JOINTS;

#[cfg(test)]
mod tests {
    use super::*;

    /// The barrier solver against brute force: on a small problem no feasible point found by
    /// random search costs less than its optimum, and the optimum touches a constraint.
    #[test]
    fn the_barrier_solver_finds_the_cheapest_feasible_design() {
        let rows = vec![
            vec![1.0, 2.0, 0.0],
            vec![0.5, 0.1, 3.0],
            vec![2.0, 0.0, 0.2],
            vec![0.0, 0.0, 0.0],
        ];
        let w = [1.0, 2.0, 0.5];
        let x = min_inverse_cost(&rows, &w, 10.0).unwrap();
        let cost = |x: &[f64]| -> f64 { w.iter().zip(x).map(|(w, x)| w / x).sum() };
        let worst = |x: &[f64]| -> f64 {
            rows.iter()
                .map(|r| r.iter().zip(x).map(|(a, x)| a * x).sum::<f64>())
                .fold(0.0, f64::max)
        };
        assert!(worst(&x) <= 1.0 + 1e-9 && worst(&x) > 1.0 - 1e-6, "{x:?}");
        let best = cost(&x);
        // Deterministic pseudo-random search over directions, each scaled onto the boundary.
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..20_000 {
            let d: Vec<f64> = (0..3).map(|_| 0.01 + next()).collect();
            let s = 1.0 / worst(&d);
            let p: Vec<f64> = d.iter().map(|v| (v * s).min(10.0)).collect();
            assert!(
                cost(&p) >= best * (1.0 - 1e-9),
                "{p:?} costs {} < {best}",
                cost(&p)
            );
        }
        // A variable no constraint touches goes to its bound.
        let x = min_inverse_cost(&[vec![1.0, 0.0]], &[1.0, 1.0], 2.0).unwrap();
        assert!((x[0] - 1.0).abs() < 1e-6 && (x[1] - 2.0).abs() < 1e-6, "{x:?}");
        assert!(min_inverse_cost(&[vec![-1.0, 0.0]], &[1.0, 1.0], 2.0).is_none());
    }

    /// Over M1 and M2: each finer grouping costs no more at first order than a coarser one
    /// (it contains it); every design is verified, and re-solving the equilibria at its
    /// clearances pose by pose meets the accuracy; the first order, with the contact
    /// elasticity's share, is within a factor 2 of what the equilibria verify. A singular
    /// pose and a pose where elasticity alone breaks the accuracy are refused by name.
    #[test]
    fn per_joint_allocation_over_m1_and_m2_is_verified_and_cheapest() {
        use crate::mechanisms::mr2120::paper::TABLE2;
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let acc = Accuracy {
            position: 0.1e-3,
            rotation: 0.1f64.to_radians(),
        };
        let d = allocate(&g, &mp, &TABLE2[..2], acc, CostModel::default(), |_, _| {}).unwrap();
        let costs: Vec<f64> = d.allocations.iter().map(|a| a.first_order_cost).collect();
        assert!(
            costs[2] <= costs[1] * (1.0 + 1e-6) && costs[1] <= costs[0] * (1.0 + 1e-6),
            "{costs:?}"
        );
        assert!(
            costs[1] < 0.9 * costs[0],
            "axial play matters less than radial: {costs:?}"
        );
        for a in &d.allocations {
            assert!(a.verified, "{a:?}");
            let s = a.scale.unwrap();
            assert!((0.5..=2.0).contains(&s), "{a:?}");
            let h = a.clearances.unwrap();
            for p in &TABLE2[..2] {
                let e = pose_worst(&g, &mp, p, &h);
                assert!(meets(&e, &acc), "{:?} at {}: {e:?}", a.grouping, p.name);
            }
        }
        assert!(matches!(
            allocate(&g, &mp, &TABLE2[2..], acc, CostModel::default(), |_, _| {}),
            Err(DesignError::SingularPose { .. })
        ));
        let near = crate::design::Region::Path(vec![[0.0, 0.0, 0.256], [0.0, 0.0, 0.257]])
            .poses(&g, 2)
            .unwrap();
        let strict = Accuracy {
            position: 0.2e-3,
            rotation: 0.5f64.to_radians(),
        };
        assert!(matches!(
            allocate(&g, &mp, &near.poses, strict, CostModel::default(), |_, _| {}),
            Err(DesignError::NoClearanceAllowable { .. })
        ));
    }
}
