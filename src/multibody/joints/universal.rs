//! Universal (Cardan) joint: origins coincide, the first axis (z_i, fixed to side i) stays
//! perpendicular to the second (z_j, fixed to side j).

use super::JointFrame;
use crate::multibody::constraints::Primitive;

pub(super) fn primitives(fi: &JointFrame, fj: &JointFrame) -> Vec<Primitive> {
    vec![
        Primitive::Point {
            si: fi.origin,
            sj: fj.origin,
        },
        Primitive::Dot1 {
            ai: fi.z(),
            aj: fj.z(),
            c: 0.0,
        },
    ]
}
