//! Forward-mode derivatives for the contact force elements: a number carrying its gradient
//! with respect to the 26 state variables of a body pair (ball body r, p, v, ω', then socket
//! body r, p, v, ω'). The contact geometry is evaluated once in these numbers, which gives the
//! exact Jacobian of the loads — no difference increments to straddle contact onset.

use crate::multibody::forces::BodyState;
use std::ops::{Add, Mul, Neg, Sub};

/// Number of state variables of a body pair.
pub(crate) const N: usize = 26;

/// A value with its gradient.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct D {
    pub v: f64,
    pub g: [f64; N],
}

impl D {
    pub fn c(v: f64) -> Self {
        D { v, g: [0.0; N] }
    }
    fn var(v: f64, i: usize) -> Self {
        let mut g = [0.0; N];
        g[i] = 1.0;
        D { v, g }
    }
    fn map(self, v: f64, dv: f64) -> Self {
        let mut g = self.g;
        g.iter_mut().for_each(|x| *x *= dv);
        D { v, g }
    }
    pub fn sqrt(self) -> Self {
        let s = self.v.sqrt();
        self.map(s, if s > 0.0 { 0.5 / s } else { 0.0 })
    }
    pub fn recip(self) -> Self {
        self.map(1.0 / self.v, -1.0 / (self.v * self.v))
    }
}

impl Add for D {
    type Output = D;
    fn add(mut self, o: D) -> D {
        self.v += o.v;
        for (a, b) in self.g.iter_mut().zip(o.g) {
            *a += b;
        }
        self
    }
}
impl Sub for D {
    type Output = D;
    fn sub(self, o: D) -> D {
        self + (-o)
    }
}
impl Neg for D {
    type Output = D;
    fn neg(self) -> D {
        self.map(-self.v, -1.0)
    }
}
impl Mul for D {
    type Output = D;
    fn mul(self, o: D) -> D {
        let mut g = [0.0; N];
        for i in 0..N {
            g[i] = self.g[i] * o.v + self.v * o.g[i];
        }
        D { v: self.v * o.v, g }
    }
}
impl Mul<f64> for D {
    type Output = D;
    fn mul(self, s: f64) -> D {
        self.map(self.v * s, s)
    }
}

/// A 3-vector of such numbers.
pub(crate) type V3 = [D; 3];

pub fn add(a: &V3, b: &V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub fn sub(a: &V3, b: &V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn scale(a: &V3, s: D) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn dot(a: &V3, b: &V3) -> D {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn cross(a: &V3, b: &V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
pub fn constant(v: &nalgebra::Vector3<f64>) -> V3 {
    [D::c(v[0]), D::c(v[1]), D::c(v[2])]
}

/// A body's state as numbers carrying derivatives (offset 0: ball side, 13: socket side;
/// `None`: the ground, constant).
#[derive(Debug, Clone, Copy)]
pub(crate) struct DState {
    pub r: V3,
    /// Rotation matrix A(p) by rows (the polynomial form of `multibody::rotation::rotation`,
    /// so derivatives match the formulation's for non-unit p too).
    pub a: [V3; 3],
    pub v: V3,
    pub omega: V3,
}

impl DState {
    pub fn new(s: &BodyState, offset: Option<usize>) -> Self {
        let x = |val: f64, k: usize| match offset {
            Some(o) => D::var(val, o + k),
            None => D::c(val),
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
    pub fn rot(&self, s: &V3) -> V3 {
        [dot(&self.a[0], s), dot(&self.a[1], s), dot(&self.a[2], s)]
    }
    /// Aᵀ·f.
    pub fn rot_t(&self, f: &V3) -> V3 {
        let col = |j: usize| [self.a[0][j], self.a[1][j], self.a[2][j]];
        [dot(&col(0), f), dot(&col(1), f), dot(&col(2), f)]
    }
}
