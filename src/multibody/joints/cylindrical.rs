//! Cylindrical joint: z axes parallel and the origin of j on the z axis of i.

use super::JointFrame;
use crate::multibody::constraints::Primitive;

pub(super) fn primitives(fi: &JointFrame, fj: &JointFrame) -> Vec<Primitive> {
    vec![
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
        Primitive::Dot2 {
            ai: fi.x(),
            si: fi.origin,
            sj: fj.origin,
            law: None,
        },
        Primitive::Dot2 {
            ai: fi.y(),
            si: fi.origin,
            sj: fj.origin,
            law: None,
        },
    ]
}
