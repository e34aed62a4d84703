//! Joints: one kind per file, each a list of constraint primitives between two joint frames.
//!
//! A joint connects side i (a body or the ground) and side j through a frame on each side:
//! an origin and orthonormal axes (x, y, z) in the body frame. The joint axis is z.

mod cylindrical;
mod fixed;
mod prismatic;
mod revolute;
mod spherical;
mod universal;

use super::body::Attach;
use super::constraints::Primitive;
use nalgebra::{Matrix3, Vector3};

/// A joint frame on one side: origin and orthonormal axes, both in that side's body frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointFrame {
    /// Origin, m (body frame).
    pub origin: Vector3<f64>,
    /// Axes as columns (x, y, z) (body frame).
    pub axes: Matrix3<f64>,
}

impl JointFrame {
    /// A frame at `origin` whose z axis is `z` (normalised); x, y complete it.
    pub fn new(origin: Vector3<f64>, z: Vector3<f64>) -> Self {
        let z = z.normalize();
        let helper = if z.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let x = (helper - z * helper.dot(&z)).normalize();
        let y = z.cross(&x);
        Self {
            origin,
            axes: Matrix3::from_columns(&[x, y, z]),
        }
    }
    /// A frame at `origin` with axes (x, z) given; y = z × x. `x` must be perpendicular to `z`.
    pub fn with_x(origin: Vector3<f64>, z: Vector3<f64>, x: Vector3<f64>) -> Self {
        let z = z.normalize();
        let x = (x - z * x.dot(&z)).normalize();
        Self {
            origin,
            axes: Matrix3::from_columns(&[x, z.cross(&x), z]),
        }
    }
    pub(crate) fn x(&self) -> Vector3<f64> {
        self.axes.column(0).into()
    }
    pub(crate) fn y(&self) -> Vector3<f64> {
        self.axes.column(1).into()
    }
    pub(crate) fn z(&self) -> Vector3<f64> {
        self.axes.column(2).into()
    }
}

/// Kinds of joints.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Point coincidence (3 constraints).
    Spherical,
    /// Rotation about the common z axis (5 constraints).
    Revolute,
    /// Cardan joint: point coincidence and z_i ⟂ z_j (4 constraints).
    Universal,
    /// Translation along z, no rotation (5 constraints).
    Prismatic,
    /// Translation along and rotation about z (4 constraints).
    Cylindrical,
    /// Rigid connection (6 constraints).
    Fixed,
}

/// Handle of a joint in a mechanism.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct JointHandle(pub(crate) usize);

impl JointHandle {
    /// Index of the joint.
    pub fn index(self) -> usize {
        self.0
    }
}

/// A joint between side i and side j.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name, used in reports and errors.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Side i.
    pub body_i: Attach,
    /// Side j.
    pub body_j: Attach,
    /// Frame on side i.
    pub frame_i: JointFrame,
    /// Frame on side j.
    pub frame_j: JointFrame,
}

impl Joint {
    /// The primitives of this joint.
    pub(crate) fn primitives(&self) -> Vec<Primitive> {
        let (fi, fj) = (&self.frame_i, &self.frame_j);
        match self.kind {
            JointKind::Spherical => spherical::primitives(fi, fj),
            JointKind::Revolute => revolute::primitives(fi, fj),
            JointKind::Universal => universal::primitives(fi, fj),
            JointKind::Prismatic => prismatic::primitives(fi, fj),
            JointKind::Cylindrical => cylindrical::primitives(fi, fj),
            JointKind::Fixed => fixed::primitives(fi, fj),
        }
    }

    /// Names of the joint's scalar constraints (for reports).
    pub(crate) fn constraint_names(&self) -> Vec<String> {
        let mut out = vec![];
        for (k, p) in self.primitives().iter().enumerate() {
            let label = match p {
                Primitive::Point { .. } => "point",
                Primitive::Dot1 { .. } => "orientation",
                Primitive::Dot2 { .. } => "line",
                Primitive::Angle { .. } => "angle",
            };
            for e in 0..p.len() {
                let axis = if p.len() == 3 { ["x", "y", "z"][e] } else { "" };
                out.push(format!("joint '{}' {label}{axis} #{k}", self.name));
            }
        }
        out
    }
}
