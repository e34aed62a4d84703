//! Spherical joint: the two frame origins coincide.

use super::JointFrame;
use crate::multibody::constraints::Primitive;

pub(super) fn primitives(fi: &JointFrame, fj: &JointFrame) -> Vec<Primitive> {
    vec![Primitive::Point {
        si: fi.origin,
        sj: fj.origin,
    }]
}
