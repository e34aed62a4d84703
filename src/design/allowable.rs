//! The largest uniform clearance h (radial h_LR = axial h_LW = h in every universal joint)
//! for which the MR2120's platform stays within a required accuracy at given poses, under
//! the load cases of the static accuracy study
//! ([`static_load_cases`](crate::mechanisms::mr2120::accuracy::static_load_cases)).
//!
//! Two answers per pose, side by side:
//! * **first order**: the play bound is linear in h ([`linear_envelope`]), so the allowable h is
//!   the accuracy divided by the largest error per metre of clearance over the load cases
//!   and the six errors of eq. (4.1). None at a singular configuration.
//! * **nonlinear**: the largest h at which every static equilibrium of the clearance model
//!   ([`static_envelope`]) meets the accuracy, by bisection on h (relative width
//!   [`BISECTION_TOLERANCE`]); it includes the contact elasticity the first order leaves out
//!   (which alone may break the accuracy: then no clearance is allowable, and it says so).
//!
//! Accuracy: every |d_x|, |d_y|, |d_z| ≤ `position` (m) and every |δx|, |δy|, |δz| ≤
//! `rotation` (rad), the errors measured from the ideal pose as in the paper.

use crate::mechanisms::mr2120::accuracy::{linear_envelope, static_envelope, Excitation};
use crate::mechanisms::mr2120::geometry::{Geometry, MassProperties};
use crate::mechanisms::mr2120::ideal::Mr2120Error;
use crate::mechanisms::mr2120::paper::{ClearanceSet, Table2Point};
use crate::multibody::ModelError;
use serde::Serialize;

/// Relative width of the bracket at which the nonlinear bisection stops.
pub const BISECTION_TOLERANCE: f64 = 0.01;
/// Largest clearance the nonlinear search considers, m (1 mm: far beyond any bearing).
pub const MAX_CLEARANCE: f64 = 1e-3;

/// A required positioning accuracy.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Accuracy {
    /// Largest |d_x|, |d_y|, |d_z| of the platform centre, m.
    pub position: f64,
    /// Largest |δx|, |δy|, |δz| of the platform, rad.
    pub rotation: f64,
}

/// Bad input or a failed model evaluation.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// A non-positive or non-finite accuracy.
    #[error("accuracy must be positive and finite: position {position} m, rotation {rotation} rad")]
    BadAccuracy {
        /// Position accuracy, m.
        position: f64,
        /// Rotation accuracy, rad.
        rotation: f64,
    },
    /// A map grid that is empty, not finite or too large.
    #[error("bad map grid: {0}")]
    BadGrid(String),
    /// A map whose every cell lies outside the work zone.
    #[error("no cell of the map is inside the work zone: {0}")]
    OutsideWorkZone(String),
    /// A shard that cannot be read, or parts that do not make one map.
    #[error("bad shard: {0}")]
    BadShard(String),
    /// A region that cannot be read or sampled.
    #[error("bad region: {0}")]
    BadRegion(String),
    /// A cost model that is not positive and finite, or that admits no allocation.
    #[error("bad cost model: {0}")]
    BadCost(String),
    /// A pose of the region where the first order has no answer (a singular configuration).
    #[error("the first-order play bound has no answer at the pose ({:.4}, {:.4}, {:.4}) m (singularity measure {measure:.2e}): a per-joint allocation needs a region that keeps off singular configurations (the nonlinear uniform answer per pose does not: allowable_uniform, the first table of `lash design clearance`)", m[0], m[1], m[2])]
    SingularPose {
        /// Platform centre, m.
        m: [f64; 3],
        /// The constraint Jacobian's singularity measure there.
        measure: f64,
    },
    /// A pose where the contact elasticity alone, at a vanishing clearance, breaks the
    /// accuracy: no clearance is allowable there.
    #[error("no clearance is allowable at the pose ({:.4}, {:.4}, {:.4}) m: with a vanishing clearance the contact elasticity alone gives |{component}| = {elastic:.4e} (m or rad), beyond the accuracy", m[0], m[1], m[2])]
    NoClearanceAllowable {
        /// Platform centre, m.
        m: [f64; 3],
        /// The component that breaks the accuracy ("d_x", …, "δz").
        component: &'static str,
        /// Its worst |value| there (m or rad).
        elastic: f64,
    },
    /// The model failed.
    #[error(transparent)]
    Model(#[from] Mr2120Error),
}

/// [`DesignError::BadAccuracy`] unless both limits are positive and finite.
pub fn check_accuracy(accuracy: &Accuracy) -> Result<(), DesignError> {
    if accuracy.position > 0.0
        && accuracy.position.is_finite()
        && accuracy.rotation > 0.0
        && accuracy.rotation.is_finite()
    {
        Ok(())
    } else {
        Err(DesignError::BadAccuracy {
            position: accuracy.position,
            rotation: accuracy.rotation,
        })
    }
}

/// The allowable uniform clearance at one pose.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AllowablePoint {
    /// Pose (M1, M2, M3; "region" for a pose of a path or a box).
    pub point: String,
    /// Platform centre, m.
    pub m: [f64; 3],
    /// First-order allowable h, m (`None` at a singular configuration).
    pub linear_h: Option<f64>,
    /// The error that limits the first-order answer ("d_x", …, "δz").
    pub linear_limit: Option<String>,
    /// Nonlinear allowable h, m (`None` when even the smallest clearance breaks the accuracy:
    /// contact elasticity alone does).
    pub nonlinear_h: Option<f64>,
    /// The largest |error| per component of the equilibria at `nonlinear_h` (d in m, δ in
    /// rad), or at the smallest clearance tried when none is allowable.
    pub nonlinear_errors: [f64; 6],
    /// The nonlinear answer meets the accuracy (checked at `nonlinear_h`).
    pub verified: bool,
}

const NAMES: [&str; 6] = ["d_x", "d_y", "d_z", "δx", "δy", "δz"];

fn limit(acc: &Accuracy, k: usize) -> f64 {
    if k < 3 {
        acc.position
    } else {
        acc.rotation
    }
}

fn worst(r: &[(f64, f64); 6]) -> [f64; 6] {
    std::array::from_fn(|k| r[k].0.abs().max(r[k].1.abs()))
}

fn meets(e: &[f64; 6], acc: &Accuracy) -> bool {
    (0..6).all(|k| e[k] <= limit(acc, k))
}

/// The allowable uniform clearance at each of `points` (see the [module docs](self)).
pub fn allowable_uniform(
    g: &Geometry,
    mp: &MassProperties,
    points: &[Table2Point],
    accuracy: Accuracy,
    progress: impl Fn(usize, usize) + Sync,
) -> Result<Vec<AllowablePoint>, DesignError> {
    use rayon::prelude::*;
    check_accuracy(&accuracy)?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    progress(0, points.len());
    let out = points
        .par_iter()
        .map(|p| {
            let r = allowable_at(g, mp, p, &accuracy);
            progress(
                done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1,
                points.len(),
            );
            r
        })
        .collect();
    out
}

/// [`allowable_uniform`] at one pose.
fn allowable_at(
    g: &Geometry,
    mp: &MassProperties,
    p: &Table2Point,
    accuracy: &Accuracy,
) -> Result<AllowablePoint, DesignError> {
    let accuracy = *accuracy;
    let ex = Excitation::default();
    let set = |h: f64| ClearanceSet {
        name: "uniform",
        radial: h,
        axial: h,
    };
    {
        // First order: the envelope is linear in h, so at h = 1 m it holds the errors per
        // metre of uniform clearance.
        let (linear_h, linear_limit) = match linear_envelope(g, mp, p, &set(1.0), &ex) {
            Ok(r) => {
                let per_m = worst(&r);
                let (k, h) = (0..6)
                    .map(|k| (k, limit(&accuracy, k) / per_m[k]))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .expect("six errors");
                (Some(h), Some(NAMES[k].to_string()))
            }
            Err(Mr2120Error::Model(ModelError::Singular { .. })) => (None, None),
            Err(e) => return Err(e.into()),
        };
        // Nonlinear: bisection on h between a clearance that meets the accuracy and one
        // that does not.
        let errors_at = |h: f64| -> Result<[f64; 6], DesignError> {
            let (r, _) = static_envelope(g, mp, p, &set(h), &ex)?;
            Ok(worst(&r))
        };
        let h_min = 1e-8;
        let e_min = errors_at(h_min)?;
        let (nonlinear_h, nonlinear_errors) = if !meets(&e_min, &accuracy) {
            (None, e_min)
        } else {
            let mut lo = (h_min, e_min);
            let mut hi = linear_h.unwrap_or(1e-5).clamp(2.0 * h_min, MAX_CLEARANCE);
            // Grow the upper end until it fails (or reaches the largest clearance).
            loop {
                let e = errors_at(hi)?;
                if !meets(&e, &accuracy) {
                    break;
                }
                lo = (hi, e);
                if hi >= MAX_CLEARANCE {
                    break;
                }
                hi = (hi * 2.0).min(MAX_CLEARANCE);
            }
            if lo.0 < hi {
                while (hi - lo.0) > BISECTION_TOLERANCE * lo.0 {
                    let mid = (lo.0 * hi).sqrt();
                    let e = errors_at(mid)?;
                    if meets(&e, &accuracy) {
                        lo = (mid, e);
                    } else {
                        hi = mid;
                    }
                }
            }
            (Some(lo.0), lo.1)
        };
        Ok(AllowablePoint {
            point: p.name.into(),
            m: p.m,
            linear_h,
            linear_limit,
            nonlinear_h,
            verified: nonlinear_h.is_some() && meets(&nonlinear_errors, &accuracy),
            nonlinear_errors,
        })
    }
}

/// One pose of [`allowable_along`]: the allowable uniform clearance against the distance to
/// the direct singularity M3.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CurvePoint {
    /// Platform centre height z_M, m (x_M = y_M = 0).
    pub z: f64,
    /// Distance to M3 along z, m.
    pub distance_to_m3: f64,
    /// Direct-singularity measure |det J_x| / L2³ of the ideal model (0 at M3).
    pub direct_measure: f64,
    /// First-order allowable h, m (`None` at a singular configuration).
    pub linear_h: Option<f64>,
    /// Nonlinear allowable h, m (`None`: no clearance meets the accuracy).
    pub nonlinear_h: Option<f64>,
    /// The nonlinear answer was checked at `nonlinear_h`.
    pub verified: bool,
}

/// The allowable uniform clearance along the paper's path on the z axis, at the given
/// distances above M3 (m): the curve the paper states only in words (accuracy needs tighter
/// clearances near a singular configuration).
pub fn allowable_along(
    g: &Geometry,
    mp: &MassProperties,
    distances: &[f64],
    accuracy: Accuracy,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<CurvePoint>, DesignError> {
    let m3 = crate::mechanisms::mr2120::paper::TABLE2[2].m[2];
    let mut out = vec![];
    for (i, &d) in distances.iter().enumerate() {
        progress(i, distances.len());
        let z = m3 + d;
        let m = nalgebra::Vector3::new(0.0, 0.0, z);
        let q = crate::mechanisms::mr2120::kinematics::inverse(g, m).map_err(Mr2120Error::from)?;
        let direct_measure = crate::mechanisms::mr2120::kinematics::singularity(g, q, m).direct_measure;
        let pose = Table2Point {
            name: "path",
            m: [0.0, 0.0, z],
            q_deg: q.map(f64::to_degrees),
        };
        let r = allowable_uniform(g, mp, &[pose], accuracy, |_, _| {})?;
        let p = &r[0];
        out.push(CurvePoint {
            z,
            distance_to_m3: d,
            direct_measure,
            linear_h: p.linear_h,
            nonlinear_h: p.nonlinear_h,
            verified: p.verified,
        });
    }
    progress(distances.len(), distances.len());
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanisms::mr2120::paper::TABLE2;

    #[test]
    fn a_non_positive_accuracy_is_an_error() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let bad = Accuracy {
            position: 0.0,
            rotation: 1e-3,
        };
        assert!(matches!(
            allowable_uniform(&g, &mp, &TABLE2[..1], bad, |_, _| {}),
            Err(DesignError::BadAccuracy { .. })
        ));
    }

    /// At M1 the first-order and the nonlinear allowable clearance agree within 30 %, and the
    /// nonlinear one meets the accuracy; at M3 (singular) there is no first-order answer.
    #[test]
    fn allowable_clearance_at_m1_and_m3() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let acc = Accuracy {
            position: 0.2e-3,
            rotation: 0.5f64.to_radians(),
        };
        let r = allowable_uniform(&g, &mp, &[TABLE2[0], TABLE2[2]], acc, |_, _| {}).unwrap();
        let (m1, m3) = (&r[0], &r[1]);
        let (l, n) = (m1.linear_h.unwrap(), m1.nonlinear_h.unwrap());
        assert!(m1.verified, "{m1:?}");
        assert!((l / n - 1.0).abs() < 0.3, "{m1:?}");
        assert!(m3.linear_h.is_none(), "{m3:?}");
    }

    /// Along the z path the allowable clearance shrinks towards M3, and near it the first
    /// order promises a clearance the equilibria refuse (contact elasticity alone breaks the
    /// accuracy within 5 mm of the singularity).
    #[test]
    fn allowable_clearance_shrinks_towards_the_singularity() {
        let (g, mp) = (Geometry::default(), MassProperties::default());
        let acc = Accuracy {
            position: 0.2e-3,
            rotation: 0.5f64.to_radians(),
        };
        let r = allowable_along(&g, &mp, &[5e-3, 0.1, 0.249], acc, |_, _| {}).unwrap();
        assert!(
            r[0].nonlinear_h.is_none() && r[0].linear_h.is_some(),
            "{:?}",
            r[0]
        );
        let (mid, far) = (r[1].nonlinear_h.unwrap(), r[2].nonlinear_h.unwrap());
        assert!(mid < far, "{r:?}");
        assert!(r[0].direct_measure < r[1].direct_measure && r[1].direct_measure < r[2].direct_measure);
    }
}
