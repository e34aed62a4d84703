//! The model: bodies, joints, drivers, force elements and gravity, assembled with a builder
//! API in the style of rapier (sets with handles) and read through accessors. The model holds
//! no state: the state lives in a [`MechanismData`](super::MechanismData), in the solver and
//! in [`Snapshot`](super::Snapshot)s and [`Sample`](super::Sample)s.

use super::body::{Attach, BodyHandle, BodySet, RigidBody};
use super::constraints::Primitive;
use super::drivers::MotionLaw;
use super::error::ModelError;
use super::forces::ForceElement;
use super::joints::{Joint, JointFrame, JointHandle, JointKind};
use super::layout::Layout;
use super::rotation::rotation;
use nalgebra::{Matrix3, Vector3};
use std::sync::atomic::{AtomicU64, Ordering};

/// Standard gravity, m/s² (along −z by default).
pub const STANDARD_GRAVITY: f64 = 9.81;

/// A driver: a joint coordinate prescribed as a function of time.
#[derive(Debug, Clone)]
pub struct Driver {
    /// Name.
    pub name: String,
    /// The driven joint (revolute or cylindrical: rotation; prismatic: translation).
    pub joint: JointHandle,
    /// Prescribed coordinate, rad or m.
    pub law: MotionLaw,
    /// Value of the coordinate in the configuration the joint frames were built in.
    pub reference: f64,
}

/// Handle of a driver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct DriverHandle(pub(crate) usize);

impl DriverHandle {
    /// Index of the driver (its constraint follows all joint constraints).
    pub fn index(self) -> usize {
        self.0
    }
}

/// A marker: a frame fixed on a body (or the ground), for outputs and force elements.
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// Name.
    pub name: String,
    /// The body it is fixed to.
    pub attach: Attach,
    /// Origin and axes in the body frame.
    pub frame: JointFrame,
}

/// Handle of a marker.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MarkerHandle(pub(crate) usize);

/// Handle of a force element.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ForceHandle(pub(crate) usize);

impl ForceHandle {
    /// Index of the force element's slot (removed elements keep their slot).
    pub fn index(self) -> usize {
        self.0
    }
}

/// A mechanism: the model of a multibody system (constant during a simulation; the state
/// lives in [`MechanismData`](super::MechanismData)).
///
/// Built with the `add_*`, `*_at` and `drive` methods, read through accessors. Joints and
/// force elements can be replaced or removed later; a removed element leaves an empty slot,
/// so every other handle stays valid. Build a new [`MechanismData`](super::MechanismData)
/// after changing the model.
#[derive(Debug, Default)]
pub struct Mechanism {
    markers: Vec<Marker>,
    bodies: BodySet,
    /// Joint slots, in insertion order (`None`: removed).
    joints: Vec<Option<Joint>>,
    drivers: Vec<Driver>,
    /// Force-element slots (`None`: removed).
    forces: Vec<Option<Box<dyn ForceElement>>>,
    gravity: Vector3<f64>,
    /// The index layout of the state vectors (kept up to date by every change of the model).
    layout: Layout,
    /// Identifies this version of the model (0: empty; a fresh number on every change of
    /// bodies, joints, drivers or force elements), so analyses can refuse a stale
    /// [`MechanismData`](super::MechanismData).
    version: u64,
}

/// Source of model versions, unique within the process.
static NEXT_VERSION: AtomicU64 = AtomicU64::new(1);

/// True for the joint kinds a driver can drive.
fn drivable(k: JointKind) -> bool {
    !matches!(k, JointKind::Spherical | JointKind::Universal | JointKind::Fixed)
}

fn missing(kind: &'static str, index: usize) -> ModelError {
    ModelError::BadElement {
        kind,
        name: format!("#{index}"),
        reason: format!("{kind} handle {index} does not exist or was removed"),
    }
}

/// One scalar constraint of the assembled model: its sides, primitive and owner.
#[derive(Debug, Clone)]
pub(crate) struct ConstraintBlock {
    pub i: Attach,
    pub j: Attach,
    pub prim: Primitive,
    pub names: Vec<String>,
}

impl Mechanism {
    /// An empty mechanism with standard gravity along −z.
    pub fn new() -> Self {
        Self {
            gravity: Vector3::new(0.0, 0.0, -STANDARD_GRAVITY),
            ..Default::default()
        }
    }

    /// Records a change of bodies, joints, drivers or force elements: the layout is
    /// recomputed and the model gets a new version (data made before become stale).
    fn changed(&mut self) {
        self.layout = Layout::of(self);
        self.version = NEXT_VERSION.fetch_add(1, Ordering::Relaxed);
    }

    /// This version of the model: a number that changes with every change of bodies,
    /// joints, drivers or force elements (not with gravity, markers or a body's mass
    /// properties, which no [`MechanismData`](super::MechanismData) holds).
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Checks that `data` was made for this version of the model.
    pub fn check_data(&self, data: &super::MechanismData) -> Result<(), ModelError> {
        if data.model_version == self.version && data.layout() == &self.layout {
            Ok(())
        } else {
            Err(ModelError::StaleData)
        }
    }

    /// Adds a body.
    pub fn add_body(&mut self, b: RigidBody) -> BodyHandle {
        let h = self.bodies.insert(b);
        self.changed();
        h
    }

    /// Adds a marker at base-frame `point` with z axis `z` on side `a` (from its initial pose).
    pub fn add_marker(
        &mut self,
        name: &str,
        a: impl Into<Attach>,
        point: Vector3<f64>,
        z: Vector3<f64>,
    ) -> MarkerHandle {
        let a = a.into();
        let x = JointFrame::new(point, z).x();
        let frame = self.local_frame(a, &point, &z, &x);
        self.markers.push(Marker {
            name: name.into(),
            attach: a,
            frame,
        });
        MarkerHandle(self.markers.len() - 1)
    }

    /// Adds a force element.
    pub fn add_force(&mut self, f: Box<dyn ForceElement>) -> ForceHandle {
        self.forces.push(Some(f));
        self.changed();
        ForceHandle(self.forces.len() - 1)
    }

    /// Replaces a force element, returning the old one; other handles stay valid.
    pub fn replace_force(
        &mut self,
        h: ForceHandle,
        f: Box<dyn ForceElement>,
    ) -> Result<Box<dyn ForceElement>, ModelError> {
        let old = match self.forces.get_mut(h.0) {
            Some(slot @ Some(_)) => slot.replace(f).expect("slot checked to be occupied"),
            _ => return Err(missing("force", h.0)),
        };
        self.changed();
        Ok(old)
    }

    /// Removes a force element, returning it; its slot stays empty, so other handles stay
    /// valid.
    pub fn remove_force(&mut self, h: ForceHandle) -> Result<Box<dyn ForceElement>, ModelError> {
        let old = self
            .forces
            .get_mut(h.0)
            .and_then(Option::take)
            .ok_or_else(|| missing("force", h.0))?;
        self.changed();
        Ok(old)
    }

    /// Adds a joint given by frames in each side's body frame.
    pub fn add_joint(&mut self, joint: Joint) -> JointHandle {
        self.joints.push(Some(joint));
        self.changed();
        JointHandle(self.joints.len() - 1)
    }

    /// Replaces a joint, returning the old one; other handles stay valid. A driven joint
    /// can only be replaced by a joint that can be driven the same way (revolute or
    /// cylindrical for a rotation driver, prismatic for a translation driver).
    pub fn replace_joint(&mut self, h: JointHandle, joint: Joint) -> Result<Joint, ModelError> {
        let old = self.joint(h).ok_or_else(|| missing("joint", h.0))?;
        if let Some(d) = self.drivers.iter().find(|d| d.joint == h) {
            let translation = |k: JointKind| k == JointKind::Prismatic;
            if !drivable(joint.kind) || translation(joint.kind) != translation(old.kind) {
                return Err(ModelError::BadElement {
                    kind: "joint",
                    name: old.name.clone(),
                    reason: format!(
                        "driven by driver '{}': cannot be replaced by the {:?} joint '{}'",
                        d.name, joint.kind, joint.name
                    ),
                });
            }
        }
        let old = self.joints[h.0]
            .replace(joint)
            .expect("slot checked to be occupied");
        self.changed();
        Ok(old)
    }

    /// Removes a joint, returning it; its slot stays empty, so other handles stay valid. A
    /// driven joint cannot be removed (the error names the joint and its driver).
    pub fn remove_joint(&mut self, h: JointHandle) -> Result<Joint, ModelError> {
        let j = self.joint(h).ok_or_else(|| missing("joint", h.0))?;
        if let Some(d) = self.drivers.iter().find(|d| d.joint == h) {
            return Err(ModelError::BadElement {
                kind: "joint",
                name: j.name.clone(),
                reason: format!(
                    "driven by driver '{}': remove cannot leave the driver without its joint",
                    d.name
                ),
            });
        }
        let old = self.joints[h.0].take().expect("slot checked to be occupied");
        self.changed();
        Ok(old)
    }

    /// The bodies.
    pub fn bodies(&self) -> &BodySet {
        &self.bodies
    }

    /// The body of a handle.
    pub fn body(&self, h: BodyHandle) -> Option<&RigidBody> {
        self.bodies.get(h)
    }

    /// Mutable access to a body (its mass properties and initial state), while building.
    pub fn body_mut(&mut self, h: BodyHandle) -> Option<&mut RigidBody> {
        self.bodies.get_mut(h)
    }

    /// The joints present, with their handles, in insertion order.
    pub fn joints(&self) -> impl Iterator<Item = (JointHandle, &Joint)> {
        self.joints
            .iter()
            .enumerate()
            .filter_map(|(i, j)| j.as_ref().map(|j| (JointHandle(i), j)))
    }

    /// The joint of a handle (`None` if it was removed or never existed).
    pub fn joint(&self, h: JointHandle) -> Option<&Joint> {
        self.joints.get(h.0).and_then(Option::as_ref)
    }

    /// The drivers, with their handles, in insertion order.
    pub fn drivers(&self) -> impl Iterator<Item = (DriverHandle, &Driver)> {
        self.drivers.iter().enumerate().map(|(i, d)| (DriverHandle(i), d))
    }

    /// The driver of a handle.
    pub fn driver(&self, h: DriverHandle) -> Option<&Driver> {
        self.drivers.get(h.0)
    }

    /// The force elements present, with their handles, in insertion order.
    pub fn forces(&self) -> impl Iterator<Item = (ForceHandle, &dyn ForceElement)> {
        self.forces
            .iter()
            .enumerate()
            .filter_map(|(i, f)| f.as_deref().map(|f| (ForceHandle(i), f)))
    }

    /// The force element of a handle (`None` if it was removed or never existed).
    pub fn force(&self, h: ForceHandle) -> Option<&dyn ForceElement> {
        self.forces.get(h.0).and_then(|f| f.as_deref())
    }

    /// Gravity, m/s² (base frame).
    pub fn gravity(&self) -> Vector3<f64> {
        self.gravity
    }

    /// Sets gravity, m/s² (base frame).
    pub fn set_gravity(&mut self, g: Vector3<f64>) {
        self.gravity = g;
    }

    /// The markers, with their handles.
    pub fn markers(&self) -> impl Iterator<Item = (MarkerHandle, &Marker)> {
        self.markers.iter().enumerate().map(|(i, m)| (MarkerHandle(i), m))
    }

    /// The marker of a handle.
    pub fn marker(&self, h: MarkerHandle) -> Option<&Marker> {
        self.markers.get(h.0)
    }

    /// The index layout of this model's state vectors (see [`Layout`]).
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The bodies' initial positions q = (r, p) and velocities w = (v, ω') as given in the
    /// model (not yet assembled).
    pub fn initial_guess(&self) -> (Vec<f64>, Vec<f64>) {
        let nb = self.bodies.len();
        let mut q = Vec::with_capacity(Layout::Q_PER_BODY * nb);
        let mut w = Vec::with_capacity(Layout::W_PER_BODY * nb);
        for b in &self.bodies.bodies {
            q.extend(b.position.iter());
            q.extend(b.orientation.normalize().iter());
            w.extend(b.velocity.iter());
            w.extend(b.angular_velocity.iter());
        }
        (q, w)
    }

    /// The pose side `a` was built at: its origin (m) and rotation (body frame to base
    /// frame); the ground's is the base frame. `None` for a body not in this mechanism.
    pub fn initial_pose(&self, a: Attach) -> Option<(Vector3<f64>, Matrix3<f64>)> {
        match a {
            Attach::Ground => Some((Vector3::zeros(), Matrix3::identity())),
            Attach::Body(h) => {
                let b = self.bodies.bodies.get(h.0)?;
                Some((b.position, rotation(&b.orientation.normalize())))
            }
        }
    }

    fn pose0(&self, a: Attach) -> (Vector3<f64>, Matrix3<f64>) {
        self.initial_pose(a)
            .expect("joint sides are bodies of this mechanism")
    }

    /// A joint frame on side `a` from a base-frame point and axes, using the side's initial
    /// pose.
    fn local_frame(&self, a: Attach, point: &Vector3<f64>, z: &Vector3<f64>, x: &Vector3<f64>) -> JointFrame {
        let (r, rot) = self.pose0(a);
        JointFrame::with_x(
            rot.transpose() * (point - r),
            rot.transpose() * z,
            rot.transpose() * x,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn joint_at(
        &mut self,
        name: &str,
        kind: JointKind,
        i: Attach,
        j: Attach,
        point: Vector3<f64>,
        zi: Vector3<f64>,
        zj: Vector3<f64>,
    ) -> JointHandle {
        let xi = JointFrame::new(point, zi).x();
        let fi = self.local_frame(i, &point, &zi, &xi);
        let xj = if kind == JointKind::Universal { zi } else { xi };
        let fj = self.local_frame(j, &point, &zj, &xj);
        self.add_joint(Joint {
            name: name.into(),
            kind,
            body_i: i,
            body_j: j,
            frame_i: fi,
            frame_j: fj,
        })
    }

    /// Spherical joint at base-frame `point` (m), from the bodies' initial poses.
    pub fn spherical_at(
        &mut self,
        name: &str,
        i: impl Into<Attach>,
        j: impl Into<Attach>,
        point: Vector3<f64>,
    ) -> JointHandle {
        self.joint_at(
            name,
            JointKind::Spherical,
            i.into(),
            j.into(),
            point,
            Vector3::z(),
            Vector3::z(),
        )
    }

    /// Revolute joint at `point` (m) about the base-frame `axis`.
    pub fn revolute_at(
        &mut self,
        name: &str,
        i: impl Into<Attach>,
        j: impl Into<Attach>,
        point: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> JointHandle {
        self.joint_at(name, JointKind::Revolute, i.into(), j.into(), point, axis, axis)
    }

    /// Universal joint at `point`: `axis_i` is fixed to side i, `axis_j` to side j; they must
    /// be perpendicular in the initial configuration.
    pub fn universal_at(
        &mut self,
        name: &str,
        i: impl Into<Attach>,
        j: impl Into<Attach>,
        point: Vector3<f64>,
        axis_i: Vector3<f64>,
        axis_j: Vector3<f64>,
    ) -> JointHandle {
        self.joint_at(
            name,
            JointKind::Universal,
            i.into(),
            j.into(),
            point,
            axis_i,
            axis_j,
        )
    }

    /// Prismatic joint through `point` along `axis`.
    pub fn prismatic_along(
        &mut self,
        name: &str,
        i: impl Into<Attach>,
        j: impl Into<Attach>,
        point: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> JointHandle {
        self.joint_at(name, JointKind::Prismatic, i.into(), j.into(), point, axis, axis)
    }

    /// Cylindrical joint through `point` along `axis`.
    pub fn cylindrical_along(
        &mut self,
        name: &str,
        i: impl Into<Attach>,
        j: impl Into<Attach>,
        point: Vector3<f64>,
        axis: Vector3<f64>,
    ) -> JointHandle {
        self.joint_at(
            name,
            JointKind::Cylindrical,
            i.into(),
            j.into(),
            point,
            axis,
            axis,
        )
    }

    /// Fixed joint at `point`.
    pub fn fixed_at(
        &mut self,
        name: &str,
        i: impl Into<Attach>,
        j: impl Into<Attach>,
        point: Vector3<f64>,
    ) -> JointHandle {
        self.joint_at(
            name,
            JointKind::Fixed,
            i.into(),
            j.into(),
            point,
            Vector3::z(),
            Vector3::z(),
        )
    }

    /// Drives a joint coordinate: the rotation of a revolute or cylindrical joint (rad), or
    /// the translation of a prismatic joint (m). `reference` is the coordinate's value in the
    /// configuration the joint was built in. The driver's effort (the torque or force it
    /// applies on the coordinate, positive towards increasing coordinate) is read by handle:
    /// [`Sample::driver_effort`](super::Sample::driver_effort),
    /// [`MechanismData::driver_effort`](super::MechanismData::driver_effort); the sign
    /// convention is stated in [`data`](super::data).
    pub fn drive(
        &mut self,
        name: &str,
        joint: JointHandle,
        law: MotionLaw,
        reference: f64,
    ) -> Result<DriverHandle, ModelError> {
        let j = self.joint(joint).ok_or_else(|| ModelError::BadElement {
            kind: "driver",
            name: name.into(),
            reason: format!("joint handle {} does not exist", joint.0),
        })?;
        if !drivable(j.kind) {
            return Err(ModelError::BadElement {
                kind: "driver",
                name: name.into(),
                reason: format!(
                    "joint '{}' is {:?}; only revolute, cylindrical and prismatic joints can be driven",
                    j.name, j.kind
                ),
            });
        }
        self.drivers.push(Driver {
            name: name.into(),
            joint,
            law,
            reference,
        });
        self.changed();
        Ok(DriverHandle(self.drivers.len() - 1))
    }

    /// Number of scalar constraint equations (joints and drivers; not the Euler-parameter
    /// normalisations).
    pub fn constraint_count(&self) -> usize {
        self.constraint_blocks().iter().map(|c| c.prim.len()).sum()
    }

    /// Degrees of freedom: 6 per body minus the joint constraints (drivers not counted),
    /// assuming independent constraints.
    pub fn degrees_of_freedom(&self) -> isize {
        let joint_eqs: usize = self
            .joints()
            .map(|(_, j)| j)
            .map(|j| j.primitives().iter().map(|p| p.len()).sum::<usize>())
            .sum();
        6 * self.bodies.len() as isize - joint_eqs as isize
    }

    /// Checks bodies and references, naming what is wrong.
    pub fn validate(&self) -> Result<(), ModelError> {
        if self.bodies.is_empty() {
            return Err(ModelError::BadElement {
                kind: "joint",
                name: "-".into(),
                reason: "the mechanism has no bodies".into(),
            });
        }
        for (_, b) in self.bodies.iter() {
            b.validate()?;
        }
        let nb = self.bodies.len();
        for (_, j) in self.joints() {
            for a in [j.body_i, j.body_j] {
                if let Attach::Body(h) = a {
                    if h.0 >= nb {
                        return Err(ModelError::BadElement {
                            kind: "joint",
                            name: j.name.clone(),
                            reason: format!("body handle {} does not exist", h.0),
                        });
                    }
                }
            }
            if j.body_i == j.body_j {
                return Err(ModelError::BadElement {
                    kind: "joint",
                    name: j.name.clone(),
                    reason: "connects a body to itself".into(),
                });
            }
        }
        for (_, f) in self.forces() {
            if let Some(h) = f.bodies().iter().find(|h| h.0 >= nb) {
                return Err(ModelError::BadElement {
                    kind: "force",
                    name: f.name().into(),
                    reason: format!("body handle {} does not exist", h.0),
                });
            }
        }
        for d in &self.drivers {
            if self.joint(d.joint).is_none() {
                return Err(ModelError::BadElement {
                    kind: "driver",
                    name: d.name.clone(),
                    reason: format!("joint handle {} does not exist", d.joint.0),
                });
            }
        }
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(ModelError::BadElement {
                kind: "force",
                name: "gravity".into(),
                reason: "gravity must be finite".into(),
            });
        }
        Ok(())
    }

    /// All constraint blocks: joint primitives, then one per driver.
    pub(crate) fn constraint_blocks(&self) -> Vec<ConstraintBlock> {
        let mut out = vec![];
        for (_, j) in self.joints() {
            let names = j.constraint_names();
            let mut k = 0;
            for prim in j.primitives() {
                let n = prim.len();
                out.push(ConstraintBlock {
                    i: j.body_i,
                    j: j.body_j,
                    names: names[k..k + n].to_vec(),
                    prim,
                });
                k += n;
            }
        }
        for d in &self.drivers {
            let Some(j) = self.joint(d.joint) else {
                continue; // validate() reports it; removal of a driven joint is refused
            };
            let law = MotionLaw::Sum(vec![d.law.clone(), MotionLaw::Constant(-d.reference)]);
            let (fi, fj) = (&j.frame_i, &j.frame_j);
            let prim = match j.kind {
                JointKind::Prismatic => Primitive::Dot2 {
                    ai: fi.z(),
                    si: fi.origin,
                    sj: fj.origin,
                    law: Some(law),
                },
                _ => Primitive::Angle {
                    xi: fi.x(),
                    yi: fi.y(),
                    xj: fj.x(),
                    law,
                },
            };
            out.push(ConstraintBlock {
                i: j.body_i,
                j: j.body_j,
                prim,
                names: vec![format!("driver '{}'", d.name)],
            });
        }
        out
    }
}
