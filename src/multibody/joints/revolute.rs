//! Revolute joint: origins coincide, z axes stay parallel (x_i ⟂ z_j, y_i ⟂ z_j).

use super::JointFrame;
use crate::multibody::constraints::Primitive;

pub(super) fn primitives(fi: &JointFrame, fj: &JointFrame) -> Vec<Primitive> {
    vec![
        Primitive::Point {
            si: fi.origin,
            sj: fj.origin,
        },
        Primitive::Dot1 {
            ai: fi.x(),
            aj: fj.z(),
            c: 0.0,
        },
        Primitive::Dot1 {
            ai: fi.y(),
            aj: fj.z(),
            c: 0.0,
        },
    ]
}
