//! Fixed joint: origins coincide and the frames keep their relative orientation.

use super::JointFrame;
use crate::multibody::constraints::Primitive;

pub(super) fn primitives(fi: &JointFrame, fj: &JointFrame) -> Vec<Primitive> {
    let mut p = super::revolute::primitives(fi, fj);
    p.push(Primitive::Dot1 {
        ai: fi.x(),
        aj: fj.y(),
        c: 0.0,
    });
    p
}
