//! Constraint primitives every joint and driver is assembled from (Haug's catalogue):
//!
//! * `Point` — the points s_i on body i and s_j on body j coincide (3 equations):
//!   Φ = r_j + A_j·s_j − r_i − A_i·s_i.
//! * `Dot1` — the body vectors a_i and a_j keep a fixed dot product c (usually 0):
//!   Φ = (A_i·a_i)·(A_j·a_j) − c.
//! * `Dot2` — the vector a_i keeps a dot product c(t) with the line between the points:
//!   Φ = (A_i·a_i)·(r_j + A_j·s_j − r_i − A_i·s_i) − c(t).
//! * `Angle` — rotation of x_j about the common axis z, from x_i, follows θ(t):
//!   Φ = (A_i·y_i)·(A_j·x_j)·cos θ − (A_i·x_i)·(A_j·x_j)·sin θ  (= sin(θ_actual − θ)).
//!
//! Each scalar equation is evaluated with its gradient with respect to (r_i, p_i, r_j, p_j)
//! and its partial time derivative.

use super::drivers::MotionLaw;
use super::rotation::{d_rot, rotation};
use nalgebra::{Matrix3, Vector3, Vector4};

/// Position, Euler parameters and rotation matrix of one side (the ground has r = 0,
/// p = (1, 0, 0, 0), A = I).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pose {
    pub r: Vector3<f64>,
    pub p: Vector4<f64>,
    pub a: Matrix3<f64>,
}

impl Pose {
    pub(crate) fn ground() -> Self {
        Self {
            r: Vector3::zeros(),
            p: Vector4::new(1.0, 0.0, 0.0, 0.0),
            a: Matrix3::identity(),
        }
    }
    pub(crate) fn new(r: Vector3<f64>, p: Vector4<f64>) -> Self {
        Self {
            r,
            p,
            a: rotation(&p),
        }
    }
}

/// One scalar constraint with its derivatives.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Row {
    pub phi: f64,
    pub d_ri: Vector3<f64>,
    pub d_pi: Vector4<f64>,
    pub d_rj: Vector3<f64>,
    pub d_pj: Vector4<f64>,
    /// ∂Φ/∂t.
    pub phi_t: f64,
}

/// A primitive constraint between sides i and j (body-frame vectors).
#[derive(Debug, Clone)]
pub(crate) enum Primitive {
    Point {
        si: Vector3<f64>,
        sj: Vector3<f64>,
    },
    Dot1 {
        ai: Vector3<f64>,
        aj: Vector3<f64>,
        c: f64,
    },
    Dot2 {
        ai: Vector3<f64>,
        si: Vector3<f64>,
        sj: Vector3<f64>,
        law: Option<MotionLaw>,
    },
    Angle {
        xi: Vector3<f64>,
        yi: Vector3<f64>,
        xj: Vector3<f64>,
        law: MotionLaw,
    },
}

impl Primitive {
    /// Number of scalar equations.
    pub(crate) fn len(&self) -> usize {
        match self {
            Primitive::Point { .. } => 3,
            _ => 1,
        }
    }

    /// Evaluates the equations into `out` (length [`len`](Self::len)).
    pub(crate) fn eval(&self, pi: &Pose, pj: &Pose, t: f64, out: &mut [Row]) {
        match self {
            Primitive::Point { si, sj } => {
                let d = pj.r + pj.a * sj - pi.r - pi.a * si;
                let bi = d_rot(&pi.p, si);
                let bj = d_rot(&pj.p, sj);
                for k in 0..3 {
                    let mut e = Vector3::zeros();
                    e[k] = 1.0;
                    out[k] = Row {
                        phi: d[k],
                        d_ri: -e,
                        d_pi: -bi.row(k).transpose(),
                        d_rj: e,
                        d_pj: bj.row(k).transpose(),
                        phi_t: 0.0,
                    };
                }
            }
            Primitive::Dot1 { ai, aj, c } => {
                let (gi, gj) = (pi.a * ai, pj.a * aj);
                out[0] = Row {
                    phi: gi.dot(&gj) - c,
                    d_ri: Vector3::zeros(),
                    d_pi: d_rot(&pi.p, ai).transpose() * gj,
                    d_rj: Vector3::zeros(),
                    d_pj: d_rot(&pj.p, aj).transpose() * gi,
                    phi_t: 0.0,
                };
            }
            Primitive::Dot2 { ai, si, sj, law } => {
                let g = pi.a * ai;
                let d = pj.r + pj.a * sj - pi.r - pi.a * si;
                let (c, ct) = law
                    .as_ref()
                    .map(|l| (l.value(t), l.rate(t)))
                    .unwrap_or((0.0, 0.0));
                out[0] = Row {
                    phi: g.dot(&d) - c,
                    d_ri: -g,
                    d_pi: d_rot(&pi.p, ai).transpose() * d - d_rot(&pi.p, si).transpose() * g,
                    d_rj: g,
                    d_pj: d_rot(&pj.p, sj).transpose() * g,
                    phi_t: -ct,
                };
            }
            Primitive::Angle { xi, yi, xj, law } => {
                let (th, thd) = (law.value(t), law.rate(t));
                let (s, c) = th.sin_cos();
                let (gx, gy, hx) = (pi.a * xi, pi.a * yi, pj.a * xj);
                let (sy, sx) = (gy.dot(&hx), gx.dot(&hx));
                let dpi = (d_rot(&pi.p, yi).transpose() * c - d_rot(&pi.p, xi).transpose() * s) * hx;
                let dpj = d_rot(&pj.p, xj).transpose() * (gy * c - gx * s);
                out[0] = Row {
                    phi: sy * c - sx * s,
                    d_ri: Vector3::zeros(),
                    d_pi: dpi,
                    d_rj: Vector3::zeros(),
                    d_pj: dpj,
                    phi_t: -(sy * s + sx * c) * thd,
                };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::rotation::from_axis_angle;

    fn poses() -> (Pose, Pose) {
        (
            Pose::new(
                Vector3::new(0.1, -0.2, 0.3),
                from_axis_angle(&Vector3::new(1.0, 2.0, -0.5), 0.7),
            ),
            Pose::new(
                Vector3::new(-0.4, 0.5, 0.9),
                from_axis_angle(&Vector3::new(-0.3, 0.2, 1.0), -1.1),
            ),
        )
    }

    #[test]
    fn gradients_and_time_derivatives_match_finite_differences() {
        let (pi, pj) = poses();
        let law = MotionLaw::Polynomial {
            coeffs: vec![0.3, 0.8, -0.5],
        };
        let prims = [
            Primitive::Point {
                si: Vector3::new(0.1, 0.2, -0.3),
                sj: Vector3::new(-0.5, 0.1, 0.4),
            },
            Primitive::Dot1 {
                ai: Vector3::x(),
                aj: Vector3::new(0.0, 0.6, 0.8),
                c: 0.1,
            },
            Primitive::Dot2 {
                ai: Vector3::y(),
                si: Vector3::new(0.2, 0.0, 0.1),
                sj: Vector3::new(0.0, -0.3, 0.2),
                law: Some(law.clone()),
            },
            Primitive::Angle {
                xi: Vector3::x(),
                yi: Vector3::y(),
                xj: Vector3::x(),
                law,
            },
        ];
        let t = 0.37;
        let eps = 1e-6;
        for prim in &prims {
            let n = prim.len();
            let mut rows = vec![Row::default(); n];
            prim.eval(&pi, &pj, t, &mut rows);
            let mut plus = vec![Row::default(); n];
            let mut minus = vec![Row::default(); n];
            // Positions and Euler parameters of both sides.
            for side in 0..2 {
                for k in 0..7 {
                    let bump = |pose: &Pose, h: f64| {
                        let mut r = pose.r;
                        let mut p = pose.p;
                        if k < 3 {
                            r[k] += h;
                        } else {
                            p[k - 3] += h;
                        }
                        Pose::new(r, p)
                    };
                    let (a_p, b_p, a_m, b_m) = if side == 0 {
                        (bump(&pi, eps), pj, bump(&pi, -eps), pj)
                    } else {
                        (pi, bump(&pj, eps), pi, bump(&pj, -eps))
                    };
                    prim.eval(&a_p, &b_p, t, &mut plus);
                    prim.eval(&a_m, &b_m, t, &mut minus);
                    for e in 0..n {
                        let fd = (plus[e].phi - minus[e].phi) / (2.0 * eps);
                        let an = match (side, k) {
                            (0, 0..=2) => rows[e].d_ri[k],
                            (0, _) => rows[e].d_pi[k - 3],
                            (1, 0..=2) => rows[e].d_rj[k],
                            _ => rows[e].d_pj[k - 3],
                        };
                        assert!(
                            (fd - an).abs() < 1e-8,
                            "{prim:?} eq {e} side {side} coord {k}: fd {fd} analytic {an}"
                        );
                    }
                }
            }
            prim.eval(&pi, &pj, t + eps, &mut plus);
            prim.eval(&pi, &pj, t - eps, &mut minus);
            for e in 0..n {
                let fd = (plus[e].phi - minus[e].phi) / (2.0 * eps);
                assert!((fd - rows[e].phi_t).abs() < 1e-8, "{prim:?} phi_t");
            }
        }
    }
}
