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
use super::rotation::{d2_rot, d_rot, rotation};
use nalgebra::{Matrix3, Matrix4, SMatrix, Vector3, Vector4};

/// Second derivatives of one scalar constraint with respect to (r_i, p_i, r_j, p_j).
pub(crate) type Hess14 = SMatrix<f64, 14, 14>;

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

/// The motion of one side that [`Primitive::velocity_rate`] needs: its pose, the rates its
/// velocities w = (v, ω') give the coordinates, and the direction q̇ = (ṙ, ṗ) the
/// coordinates move along (which may differ from the rates by a stabilisation term).
#[derive(Debug, Clone, Copy)]
pub(crate) struct SideMotion {
    pub pose: Pose,
    /// ṙ by the velocities: v, m/s.
    pub v: Vector3<f64>,
    /// ṙ along the motion (the r part of q̇), m/s.
    pub rd: Vector3<f64>,
    /// ṗ by the velocities: u = ½·L(p)ᵀ·ω', 1/s.
    pub u: Vector4<f64>,
    /// ṗ along the motion (the p part of q̇), 1/s.
    pub pd: Vector4<f64>,
    /// The rate of u along the motion at fixed ω': ½·L(ṗ)ᵀ·ω', 1/s².
    pub ud: Vector4<f64>,
}

impl SideMotion {
    /// The ground: at rest.
    pub(crate) fn ground() -> Self {
        Self {
            pose: Pose::ground(),
            v: Vector3::zeros(),
            rd: Vector3::zeros(),
            u: Vector4::zeros(),
            pd: Vector4::zeros(),
            ud: Vector4::zeros(),
        }
    }

    /// The body vector s in the world and its rates: [g, g_u, g_d, g_du] with g = A(p)·s,
    /// g_u = ∂g/∂p·u (its rate by the velocities), g_d = ∂g/∂p·ṗ (along the motion) and
    /// g_du the rate of g_u along the motion, ∂²g/∂p²[ṗ, u] + ∂g/∂p·u̇ (A(p)·s is quadratic
    /// in p, so ∂g/∂p is linear in p and the second derivative is exact).
    fn vector(&self, s: &Vector3<f64>) -> [Vector3<f64>; 4] {
        let b = d_rot(&self.pose.p, s);
        [
            self.pose.a * s,
            b * self.u,
            b * self.pd,
            d_rot(&self.pd, s) * self.u + b * self.ud,
        ]
    }
}

impl Primitive {
    /// The rate of each equation's velocity constraint c = Φ_q·H(q)·w + Φ_t along the motion
    /// (q moving with q̇, t with 1) at fixed velocities w, into `out`: −γ in closed form
    /// (the second derivatives of the rotated body vectors and the drivers' accelerations;
    /// Haug, ch. 6 and 11).
    pub(crate) fn velocity_rate(&self, mi: &SideMotion, mj: &SideMotion, t: f64, out: &mut [f64]) {
        match self {
            Primitive::Point { si, sj } => {
                let (a, b) = (mi.vector(si), mj.vector(sj));
                let d = b[3] - a[3];
                out[..3].copy_from_slice(d.as_slice());
            }
            Primitive::Dot1 { ai, aj, .. } => {
                let [g, gu, gd, gdu] = mi.vector(ai);
                let [h, hu, hd, hdu] = mj.vector(aj);
                out[0] = gdu.dot(&h) + gu.dot(&hd) + gd.dot(&hu) + g.dot(&hdu);
            }
            Primitive::Dot2 { ai, si, sj, law } => {
                let [g, gu, gd, gdu] = mi.vector(ai);
                let (a, b) = (mi.vector(si), mj.vector(sj));
                let d = mj.pose.r + b[0] - mi.pose.r - a[0];
                let du = mj.v + b[1] - mi.v - a[1];
                let dd = mj.rd + b[2] - mi.rd - a[2];
                let ddu = b[3] - a[3];
                let ctt = law.as_ref().map_or(0.0, |l| l.eval(t)[2]);
                out[0] = gdu.dot(&d) + gu.dot(&dd) + gd.dot(&du) + g.dot(&ddu) - ctt;
            }
            Primitive::Angle { xi, yi, xj, law } => {
                // Φ = (A_i·a)·(A_j·x_j) with a(θ) = y_i·cos θ − x_i·sin θ; Φ_t = θ̇·(A_i·b)·(A_j·x_j)
                // with b = ∂a/∂θ = −y_i·sin θ − x_i·cos θ, and ∂b/∂θ = −a.
                let [th, thd, thdd] = law.eval(t);
                let (s, c) = th.sin_cos();
                let av = yi * c - xi * s;
                let bv = -(yi * s) - xi * c;
                let [g, gu, gd, gdu] = mi.vector(&av);
                let [k, ku, kd, _] = mi.vector(&bv);
                let [h, hu, hd, hdu] = mj.vector(xj);
                out[0] = gdu.dot(&h)
                    + gu.dot(&hd)
                    + gd.dot(&hu)
                    + g.dot(&hdu)
                    + thd * (ku.dot(&h) + k.dot(&hu) + kd.dot(&h) + k.dot(&hd))
                    + thdd * k.dot(&h)
                    - thd * thd * g.dot(&h);
            }
        }
    }
}

/// Offsets of the (r_i, p_i, r_j, p_j) blocks in a 14-vector.
const RI: usize = 0;
const PI: usize = 3;
const RJ: usize = 7;
const PJ: usize = 10;

fn put4(h: &mut Hess14, r: usize, c: usize, m: &Matrix4<f64>) {
    h.fixed_view_mut::<4, 4>(r, c).copy_from(m);
}

impl Primitive {
    /// Hessians ∇²Φ_e (14 × 14 over (r_i, p_i, r_j, p_j)) of each equation, into `out`.
    pub(crate) fn hessians(&self, pi: &Pose, pj: &Pose, t: f64, out: &mut [Hess14]) {
        for h in out.iter_mut() {
            // On the contiguous slice: a memset (nalgebra's `fill` walks the matrix's iterator).
            h.as_mut_slice().fill(0.0);
        }
        match self {
            Primitive::Point { si, sj } => {
                for (k, h) in out.iter_mut().enumerate().take(3) {
                    let mut e = Vector3::zeros();
                    e[k] = 1.0;
                    put4(h, PI, PI, &(-d2_rot(&e, si)));
                    put4(h, PJ, PJ, &d2_rot(&e, sj));
                }
            }
            Primitive::Dot1 { ai, aj, .. } => {
                let h = &mut out[0];
                put4(h, PI, PI, &d2_rot(&(pj.a * aj), ai));
                put4(h, PJ, PJ, &d2_rot(&(pi.a * ai), aj));
                let c = d_rot(&pi.p, ai).transpose() * d_rot(&pj.p, aj);
                put4(h, PI, PJ, &c);
                put4(h, PJ, PI, &c.transpose());
            }
            Primitive::Dot2 { ai, si, sj, .. } => {
                let h = &mut out[0];
                let g = pi.a * ai;
                let d = pj.r + pj.a * sj - pi.r - pi.a * si;
                let (ba, bs) = (d_rot(&pi.p, ai), d_rot(&pi.p, si));
                let bsj = d_rot(&pj.p, sj);
                // r_i–p_i and r_j–p_i.
                h.fixed_view_mut::<3, 4>(RI, PI).copy_from(&(-ba));
                h.fixed_view_mut::<4, 3>(PI, RI).copy_from(&(-ba.transpose()));
                h.fixed_view_mut::<3, 4>(RJ, PI).copy_from(&ba);
                h.fixed_view_mut::<4, 3>(PI, RJ).copy_from(&ba.transpose());
                let cross = ba.transpose() * bs;
                put4(
                    h,
                    PI,
                    PI,
                    &(d2_rot(&d, ai) - d2_rot(&g, si) - cross - cross.transpose()),
                );
                let c = ba.transpose() * bsj;
                put4(h, PI, PJ, &c);
                put4(h, PJ, PI, &c.transpose());
                put4(h, PJ, PJ, &d2_rot(&g, sj));
            }
            Primitive::Angle { xi, yi, xj, law } => {
                let h = &mut out[0];
                let (s, c) = law.value(t).sin_cos();
                let ai = yi * c - xi * s;
                put4(h, PI, PI, &d2_rot(&(pj.a * xj), &ai));
                put4(h, PJ, PJ, &d2_rot(&(pi.a * ai), xj));
                let m = d_rot(&pi.p, &ai).transpose() * d_rot(&pj.p, xj);
                put4(h, PI, PJ, &m);
                put4(h, PJ, PI, &m.transpose());
            }
        }
    }

    /// Gradient of ∂Φ/∂t with respect to (r_i, p_i, r_j, p_j) (non-zero only for angle
    /// drivers, whose Φ_t depends on the configuration).
    pub(crate) fn phi_t_gradient(&self, pi: &Pose, pj: &Pose, t: f64) -> Option<SMatrix<f64, 14, 1>> {
        match self {
            Primitive::Angle { xi, yi, xj, law } => {
                let (th, thd) = (law.value(t), law.rate(t));
                let (s, c) = th.sin_cos();
                // Φ_t = −θ̇·(A_i(s·y_i + c·x_i))·(A_j·x_j).
                let ai = yi * s + xi * c;
                let mut g = SMatrix::<f64, 14, 1>::zeros();
                let dpi = d_rot(&pi.p, &ai).transpose() * (pj.a * xj) * (-thd);
                let dpj = d_rot(&pj.p, xj).transpose() * (pi.a * ai) * (-thd);
                g.fixed_view_mut::<4, 1>(PI, 0).copy_from(&dpi);
                g.fixed_view_mut::<4, 1>(PJ, 0).copy_from(&dpj);
                Some(g)
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::rotation::{from_axis_angle, l_matrix};

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

    /// One primitive of each kind, the drivers following `law`.
    fn primitives(law: MotionLaw) -> [Primitive; 4] {
        [
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
        ]
    }

    #[test]
    fn gradients_and_time_derivatives_match_finite_differences() {
        let (pi, pj) = poses();
        let law = MotionLaw::Polynomial {
            coeffs: vec![0.3, 0.8, -0.5],
        };
        let prims = primitives(law);
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
            // Hessians against differences of the analytic gradients.
            let mut hs = vec![Hess14::zeros(); n];
            prim.hessians(&pi, &pj, t, &mut hs);
            let grad = |r: &Row| {
                let mut g = [0.0; 14];
                g[0..3].copy_from_slice(r.d_ri.as_slice());
                g[3..7].copy_from_slice(r.d_pi.as_slice());
                g[7..10].copy_from_slice(r.d_rj.as_slice());
                g[10..14].copy_from_slice(r.d_pj.as_slice());
                g
            };
            for col in 0..14 {
                let bump = |h: f64| {
                    let (mut a, mut b) = (pi, pj);
                    match col {
                        0..=2 => a.r[col] += h,
                        3..=6 => a.p[col - 3] += h,
                        7..=9 => b.r[col - 7] += h,
                        _ => b.p[col - 10] += h,
                    }
                    (Pose::new(a.r, a.p), Pose::new(b.r, b.p))
                };
                let (ap, bp) = bump(eps);
                let (am, bm) = bump(-eps);
                prim.eval(&ap, &bp, t, &mut plus);
                prim.eval(&am, &bm, t, &mut minus);
                for e in 0..n {
                    let (gp, gm) = (grad(&plus[e]), grad(&minus[e]));
                    for row in 0..14 {
                        let fd = (gp[row] - gm[row]) / (2.0 * eps);
                        assert!(
                            (fd - hs[e][(row, col)]).abs() < 1e-7,
                            "{prim:?} eq {e} H({row},{col}): fd {fd} analytic {}",
                            hs[e][(row, col)]
                        );
                    }
                    if let Some(gt) = prim.phi_t_gradient(&pi, &pj, t) {
                        let fd = (plus[e].phi_t - minus[e].phi_t) / (2.0 * eps);
                        assert!((fd - gt[col]).abs() < 1e-7, "{prim:?} phi_t gradient {col}");
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

    /// The closed-form rate of the velocity constraint against central differences of
    /// c = Φ_r·v + Φ_p·u(p) + Φ_t along (q̇, 1) built from the rows' gradients, on poses whose
    /// Euler parameters are off the unit sphere and a q̇ with a stabilisation-like term (so
    /// the rate's two directions differ), drivers with accelerating laws.
    #[test]
    fn the_velocity_constraint_rate_matches_differences_along_the_motion() {
        let (p0, p1) = poses();
        let law = MotionLaw::Polynomial {
            coeffs: vec![0.3, 0.8, -0.5, 0.7],
        };
        let prims = primitives(law);
        let side = |pose: &Pose, scale: f64, v: Vector3<f64>, om: Vector3<f64>, kappa: f64| {
            let p = pose.p * scale;
            let u = 0.5 * l_matrix(&p).transpose() * om;
            let pd = u - kappa * (p.norm_squared() - 1.0) * p;
            SideMotion {
                pose: Pose::new(pose.r, p),
                v,
                rd: v,
                u,
                pd,
                ud: 0.5 * l_matrix(&pd).transpose() * om,
            }
        };
        let mi = side(
            &p0,
            1.01,
            Vector3::new(0.3, -0.1, 0.2),
            Vector3::new(1.5, -0.7, 2.1),
            5.0,
        );
        let mj = side(
            &p1,
            0.98,
            Vector3::new(-0.2, 0.4, 0.1),
            Vector3::new(-0.8, 1.2, 0.4),
            5.0,
        );
        // c(ε) at q + ε·q̇, t + ε, fixed (v, ω').
        let c = |prim: &Primitive, eps: f64, out: &mut Vec<f64>| {
            let at = |m: &SideMotion| Pose::new(m.pose.r + eps * m.rd, m.pose.p + eps * m.pd);
            let (a, b) = (at(&mi), at(&mj));
            let omega = |m: &SideMotion| 2.0 * l_matrix(&m.pose.p) * m.u / m.pose.p.norm_squared();
            let (ua, ub) = (
                0.5 * l_matrix(&a.p).transpose() * omega(&mi),
                0.5 * l_matrix(&b.p).transpose() * omega(&mj),
            );
            let mut rows = vec![Row::default(); prim.len()];
            prim.eval(&a, &b, 0.37 + eps, &mut rows);
            out.clear();
            out.extend(rows.iter().map(|r| {
                r.d_ri.dot(&mi.v) + r.d_pi.dot(&ua) + r.d_rj.dot(&mj.v) + r.d_pj.dot(&ub) + r.phi_t
            }));
        };
        let (mut plus, mut minus, mut plus2, mut minus2) = (vec![], vec![], vec![], vec![]);
        let h = 1e-3;
        for prim in &prims {
            let mut rate = vec![0.0; prim.len()];
            prim.velocity_rate(&mi, &mj, 0.37, &mut rate);
            c(prim, h, &mut plus);
            c(prim, -h, &mut minus);
            c(prim, 0.5 * h, &mut plus2);
            c(prim, -0.5 * h, &mut minus2);
            for e in 0..prim.len() {
                let d1 = (plus[e] - minus[e]) / (2.0 * h);
                let d2 = (plus2[e] - minus2[e]) / h;
                let fd = (4.0 * d2 - d1) / 3.0;
                assert!(
                    (fd - rate[e]).abs() < 1e-9 * (1.0 + fd.abs()),
                    "{prim:?} eq {e}: differences {fd}, closed form {}",
                    rate[e]
                );
                assert!(
                    rate[e].abs() > 1e-3,
                    "{prim:?} eq {e}: a rate this small tests little"
                );
            }
        }
    }
}
