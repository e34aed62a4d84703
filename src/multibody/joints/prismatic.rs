//! Prismatic joint: a cylindrical joint whose rotation about z is locked (x_i ⟂ y_j).

use super::JointFrame;
use crate::multibody::constraints::Primitive;

pub(super) fn primitives(fi: &JointFrame, fj: &JointFrame) -> Vec<Primitive> {
    let mut p = super::cylindrical::primitives(fi, fj);
    p.push(Primitive::Dot1 {
        ai: fi.x(),
        aj: fj.y(),
        c: 0.0,
    });
    p
}
