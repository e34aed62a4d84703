//! Forward-mode derivatives for the contact force elements: a number carrying its gradient
//! with respect to the state variables of a body pair — all 26 (ball body r, p, v, ω', then
//! socket body r, p, v, ω': [`FULL`]) or, at rest, the 14 positions (ball r, p, socket r, p:
//! [`POSITIONS`]). The contact geometry is evaluated once in these numbers, which gives the
//! exact Jacobian of the loads — no difference increments to straddle contact onset.

use crate::multibody::forces::BodyState;
use std::ops::{Add, Mul, Neg, Sub};

/// Number of state variables of a body pair.
pub(crate) const FULL: usize = 26;
/// Number of position variables of a body pair (derivatives at rest).
pub(crate) const POSITIONS: usize = 14;

/// A value with its gradient with respect to N variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct D<const N: usize> {
    pub v: f64,
    pub g: [f64; N],
}

impl<const N: usize> D<N> {
    #[inline]
    pub fn c(v: f64) -> Self {
        D { v, g: [0.0; N] }
    }
    #[inline]
    fn var(v: f64, i: usize) -> Self {
        let mut g = [0.0; N];
        g[i] = 1.0;
        D { v, g }
    }
    #[inline]
    fn map(self, v: f64, dv: f64) -> Self {
        let mut g = self.g;
        g.iter_mut().for_each(|x| *x *= dv);
        D { v, g }
    }
    #[inline]
    pub fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.map(s, if s > 0.0 { 0.5 / s } else { 0.0 })
    }
    #[inline]
    pub fn recip(self) -> Self {
        self.map(1.0 / self.v, -1.0 / (self.v * self.v))
    }
}

impl<const N: usize> Add for D<N> {
    type Output = D<N>;
    #[inline]
    fn add(mut self, o: D<N>) -> D<N> {
        self.v += o.v;
        for (a, b) in self.g.iter_mut().zip(o.g) {
            *a += b;
        }
        self
    }
}
impl<const N: usize> Sub for D<N> {
    type Output = D<N>;
    #[inline]
    fn sub(self, o: D<N>) -> D<N> {
        self + (-o)
    }
}
impl<const N: usize> Neg for D<N> {
    type Output = D<N>;
    #[inline]
    fn neg(self) -> D<N> {
        self.map(-self.v, -1.0)
    }
}
impl<const N: usize> Mul for D<N> {
    type Output = D<N>;
    #[inline]
    fn mul(self, o: D<N>) -> D<N> {
        let mut g = [0.0; N];
        for i in 0..N {
            g[i] = self.g[i] * o.v + self.v * o.g[i];
        }
        D { v: self.v * o.v, g }
    }
}
impl<const N: usize> Mul<f64> for D<N> {
    type Output = D<N>;
    #[inline]
    fn mul(self, s: f64) -> D<N> {
        self.map(self.v * s, s)
    }
}

/// A 3-vector of such numbers.
pub(crate) type V3<const N: usize> = [D<N>; 3];

#[inline]
pub fn add<const N: usize>(a: &V3<N>, b: &V3<N>) -> V3<N> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
#[inline]
pub fn sub<const N: usize>(a: &V3<N>, b: &V3<N>) -> V3<N> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
#[inline]
pub fn scale<const N: usize>(a: &V3<N>, s: D<N>) -> V3<N> {
    [a[0] * s, a[1] * s, a[2] * s]
}
#[inline]
pub fn dot<const N: usize>(a: &V3<N>, b: &V3<N>) -> D<N> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
pub fn cross<const N: usize>(a: &V3<N>, b: &V3<N>) -> V3<N> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// A body's state as numbers carrying derivatives (offset 0: ball side; 13 (all
/// variables) or 7 (positions only): socket side; `None`: the ground, constant). With
/// N = [`POSITIONS`] the velocities are constants.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DState<const N: usize> {
    pub r: V3<N>,
    /// Rotation matrix A(p) by rows (the polynomial form of `multibody::rotation::rotation`,
    /// so derivatives match the formulation's for non-unit p too).
    pub a: [V3<N>; 3],
    pub v: V3<N>,
    pub omega: V3<N>,
}

impl<const N: usize> DState<N> {
    /// Variables per body: 13 (r, p, v, ω') when N = [`FULL`], 7 (r, p) otherwise.
    pub const PER_BODY: usize = if N == FULL { 13 } else { 7 };

    #[inline]
    pub fn new(s: &BodyState, offset: Option<usize>) -> Self {
        let x = |val: f64, k: usize| match offset {
            Some(o) if k < Self::PER_BODY => D::var(val, o + k),
            _ => D::c(val),
        };
        let r = [x(s.r[0], 0), x(s.r[1], 1), x(s.r[2], 2)];
        let p = [x(s.p[0], 3), x(s.p[1], 4), x(s.p[2], 5), x(s.p[3], 6)];
        let v = [x(s.v[0], 7), x(s.v[1], 8), x(s.v[2], 9)];
        let omega = [x(s.omega[0], 10), x(s.omega[1], 11), x(s.omega[2], 12)];
        let (e0, e) = (p[0], [p[1], p[2], p[3]]);
        let diag = e0 * e0 - dot(&e, &e);
        let mut a = [[D::c(0.0); 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                let mut m = e[i] * e[j] * 2.0;
                if i == j {
                    m = m + diag;
                }
                a[i][j] = m;
            }
        }
        // + 2·e0·skew(e)
        a[0][1] = a[0][1] - e0 * e[2] * 2.0;
        a[0][2] = a[0][2] + e0 * e[1] * 2.0;
        a[1][0] = a[1][0] + e0 * e[2] * 2.0;
        a[1][2] = a[1][2] - e0 * e[0] * 2.0;
        a[2][0] = a[2][0] - e0 * e[1] * 2.0;
        a[2][1] = a[2][1] + e0 * e[0] * 2.0;
        Self { r, a, v, omega }
    }
    /// A·s.
    #[inline]
    pub fn rot(&self, s: &V3<N>) -> V3<N> {
        [dot(&self.a[0], s), dot(&self.a[1], s), dot(&self.a[2], s)]
    }
    /// A·s for a constant s (cheaper than [`rot`](Self::rot) of a constant).
    #[inline]
    pub fn rot_c(&self, s: &nalgebra::Vector3<f64>) -> V3<N> {
        let row = |i: usize| self.a[i][0] * s[0] + self.a[i][1] * s[1] + self.a[i][2] * s[2];
        [row(0), row(1), row(2)]
    }
    /// Aᵀ·f.
    #[inline]
    pub fn rot_t(&self, f: &V3<N>) -> V3<N> {
        let col = |j: usize| [self.a[0][j], self.a[1][j], self.a[2][j]];
        [dot(&col(0), f), dot(&col(1), f), dot(&col(2), f)]
    }
}
