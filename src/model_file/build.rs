//! From parsed tables to a [`Mechanism`]: bodies, markers, joints (ideal, or with clearance as
//! contact), drivers, force elements and sensors, every fault located in its file.

use super::error::{ModelFileError, Problem};
use super::read::{short, Ctx, Parameter, Parsed};
use super::schema::{DriverDoc, ForceDoc, JointDoc, Name, TransmissionDoc, Val};
use super::sensors::{Sensor, SensorKind, SensorTarget};
use super::series::read_columns;
use super::units::{parse_quantity, Dimension};
use crate::contact::joints::{
    revolute_with_clearance, spherical_with_clearance, universal_with_clearance, BearingDesign, Damping,
};
use crate::multibody::forces::{
    RelativeRotation, RelativeTranslation, RotationalSpringDamper, RotationalTorque, TranslationalForce,
};
use crate::multibody::rotation::{from_axis_angle, rotation};
use crate::multibody::{
    Attach, BodyHandle, DriverHandle, JointFrame, JointHandle, JointKind, MarkerHandle, Mechanism, MotionLaw,
    PointForce, Profile, RigidBody, SpringDamper,
};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use std::sync::Arc;

/// How to build the mechanism.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BuildOptions {
    /// Build the joints that declare a `clearance` as joints with clearance (trunnion
    /// bearings with Hertz contact, `contact::joints`) instead of ideal joints.
    pub clearance: bool,
    /// Joints whose motion is measured and prescribed by the caller (inverse dynamics): the
    /// file's drivers and `effort` forces on them are left out; the caller drives them.
    pub measured_joints: Vec<String>,
}

/// A time law of an effort (N or N m) applied along a joint's coordinate.
pub type EffortLaw = Arc<dyn Fn(f64) -> f64 + Send + Sync>;

/// A joint as the file declares it, with what sensors and efforts need.
#[derive(Clone)]
pub struct JointInfo {
    /// Name.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Side i.
    pub i: Attach,
    /// Side j.
    pub j: Attach,
    /// Frame on side i (body frame): origin at the joint point, z along the axis.
    pub frame_i: JointFrame,
    /// Frame on side j (body frame).
    pub frame_j: JointFrame,
    /// The joint's coordinate in the configuration the file describes (rad or m).
    pub coordinate0: f64,
    /// The ideal joint's handle (`None` when it was built with clearance).
    pub handle: Option<JointHandle>,
    /// The driver on it, if any.
    pub driver: Option<DriverHandle>,
    /// Commanded efforts along its coordinate (force elements of type `effort`).
    pub efforts: Vec<EffortLaw>,
    /// Its bearing design, if it declares a clearance.
    pub clearance: Option<BearingDesign>,
    /// Lower and upper limit of its coordinate (rad or m), if declared (reported, not
    /// enforced).
    pub limits: Option<[f64; 2]>,
    /// The compliant transmission that drives it, if declared (`[[transmission]]`).
    pub transmission: Option<Transmission>,
}

/// A compliant transmission between a motor and the joint it drives (`[[transmission]]`),
/// built as a rotor: a body on a joint of the driven joint's kind, coaxial with it on its
/// side i, and a spring of compliance c with a damper from the rotor to the joint's side j.
/// The file's driver and `effort` forces on the joint act on the rotor (the motor turns the
/// rotor; the joint follows through the spring), a `joint_effort` sensor reads the motor's
/// effort, and a sensor with `side = "motor"` reads the rotor's coordinate. All values are
/// reflected to the joint (no gear ratio).
#[derive(Debug, Clone)]
pub struct Transmission {
    /// Compliance c, rad/(N m) (m/N on a prismatic joint).
    pub compliance: f64,
    /// The declared parameter the compliance names, if any (index into
    /// [`ModelFile::parameters`](super::ModelFile::parameters)).
    pub compliance_parameter: Option<usize>,
    /// Rotor inertia about the axis, kg m² (on a prismatic joint: the rotor's mass, kg).
    pub rotor_inertia: f64,
    /// Damping of the compliance, N m s/rad (N s/m on a prismatic joint).
    pub damping: f64,
    /// The motor's joint (side i to the rotor); `None` where the joint is measured
    /// ([`BuildOptions::measured_joints`]): the caller drives the joint and models the
    /// transmission itself.
    pub motor: Option<Box<JointInfo>>,
}

/// Mass of a revolute transmission's rotor body when the file gives no `rotor_mass`, kg: a
/// body needs one, and its centre sits on the axis, so it only adds to the joint reactions
/// (a motor's mass is normally counted in the body that carries it).
pub const DEFAULT_ROTOR_MASS: f64 = 1e-3;

/// Radius of gyration of a prismatic transmission's rotor about its centre, m (its rotations
/// are locked by its joint; the value only keeps its inertia regular).
const PRISMATIC_ROTOR_GYRATION: f64 = 0.01;

impl std::fmt::Debug for JointInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "JointInfo({} {:?})", self.name, self.kind)
    }
}

impl JointInfo {
    /// The dimension of its coordinate: angle for revolute and cylindrical joints (the
    /// rotation), length for prismatic ones; `None` for joints without one.
    pub fn coordinate_dimension(&self) -> Option<Dimension> {
        match self.kind {
            JointKind::Revolute | JointKind::Cylindrical => Some(Dimension::Angle),
            JointKind::Prismatic => Some(Dimension::Length),
            _ => None,
        }
    }
}

/// A mechanism built from a model file, with its elements by name.
#[derive(Debug)]
pub struct BuiltModel {
    /// The multibody model.
    pub mechanism: Mechanism,
    /// Bodies by name, in file order.
    pub bodies: Vec<(String, BodyHandle)>,
    /// Markers by name.
    pub markers: Vec<(String, MarkerHandle, BodyHandle, Vector3<f64>)>,
    /// Joints in file order.
    pub joints: Vec<JointInfo>,
    /// Drivers by name with the joint index they drive.
    pub drivers: Vec<(String, DriverHandle, usize)>,
    /// Force elements by name and type.
    pub forces: Vec<(String, String)>,
    /// Sensors in file order.
    pub sensors: Vec<Sensor>,
}

impl BuiltModel {
    /// A body by name.
    pub fn body(&self, name: &str) -> Option<BodyHandle> {
        self.bodies.iter().find(|(n, _)| n == name).map(|(_, h)| *h)
    }
    /// A joint by name.
    pub fn joint(&self, name: &str) -> Option<&JointInfo> {
        self.joints.iter().find(|j| j.name == name)
    }
    /// A driver by name.
    pub fn driver(&self, name: &str) -> Option<DriverHandle> {
        self.drivers
            .iter()
            .find(|(n, _, _)| n == name)
            .map(|(_, h, _)| *h)
    }
}

const JOINT_TYPES: &str = "revolute, prismatic, universal, spherical, cylindrical, fixed";
const LAWS: &str = "constant, polynomial, rest_to_rest, sampled";
const FORCE_TYPES: &str = "spring_damper, rotational_spring_damper, friction, effort, point_force";
const SENSOR_TYPES: &str =
    "joint_position, joint_velocity, joint_acceleration, joint_effort, body_position, body_orientation";

/// Most bodies a model file may declare.
const MAX_BODIES: usize = 10_000;

/// Builds the mechanism from parsed files with parameter `values` (one per parameter).
pub(crate) fn build(
    files: &[Parsed],
    params: &[Parameter],
    values: &[f64],
    opts: &BuildOptions,
) -> Result<BuiltModel, ModelFileError> {
    let mut b = Builder {
        mech: Mechanism::new(),
        out_bodies: vec![],
        body_places: vec![],
        markers: vec![],
        joints: vec![],
        joint_places: vec![],
        drivers: vec![],
        forces: vec![],
        sensors: vec![],
        sensor_names: vec![],
        opts: opts.clone(),
    };
    // Gravity: the last [model] table that sets it (the including file after its includes).
    for (cx, f) in contexts(files, params, values) {
        if let Some(m) = &f.doc.model {
            if let Some(g) = &m.get_ref().gravity {
                b.mech
                    .set_gravity(cx.vec3(g, Dimension::Acceleration, "gravity")?);
            }
        }
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.body {
            let replaced = f.urdf
                && d.get_ref().name.as_ref().is_some_and(|n| {
                    files.iter().filter(|g| !g.urdf).any(|g| {
                        g.doc
                            .body
                            .iter()
                            .any(|e| e.get_ref().name.as_ref().map(|m| m.get_ref()) == Some(n.get_ref()))
                    })
                });
            if !replaced {
                b.body(&cx, d.span().start, d.get_ref())?;
            }
        }
    }
    if b.out_bodies.is_empty() {
        let f = files.last().expect("read_tree returns the root file");
        return Err(ModelFileError::File {
            file: f.src.file.clone(),
            problem: Problem::Missing,
            message: "the model declares no [[body]]".into(),
        });
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.marker {
            let d2 = d.get_ref();
            let at = d.span().start;
            let name = cx.need_name(&d2.name, "name", "a [[marker]]", at)?;
            let owner = format!("marker '{}'", name.get_ref());
            if b.markers.iter().any(|(n, ..)| n == name.get_ref()) {
                return Err(cx.err(
                    name.span().start,
                    Problem::Duplicate,
                    format!("duplicate {owner}"),
                ));
            }
            let body = cx.need_name(&d2.body, "body", &owner, at)?;
            let Attach::Body(h) = b.attach(&cx, body, &owner)? else {
                return Err(cx.err(
                    body.span().start,
                    Problem::NotApplicable,
                    format!("{owner}: a marker goes on a body, not the ground"),
                ));
            };
            let p = match &d2.point {
                Some(v) => cx.vec3(v, Dimension::Length, &format!("{owner} point"))?,
                None => b.mech.body(h).map(|x| x.position).unwrap_or_default(),
            };
            let local = b.to_local(Attach::Body(h), p);
            let mh = b
                .mech
                .add_marker(name.get_ref(), Attach::Body(h), p, Vector3::z());
            b.markers.push((name.get_ref().clone(), mh, h, local));
        }
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.joint {
            b.joint(&cx, d.span().start, d.get_ref())?;
        }
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.transmission {
            b.transmission(&cx, d.span().start, d.get_ref())?;
        }
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.driver {
            b.driver(&cx, &f.dir, d.span().start, d.get_ref())?;
        }
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.force {
            b.force(&cx, &f.dir, d.span().start, d.get_ref())?;
        }
    }
    for (cx, f) in contexts(files, params, values) {
        for d in &f.doc.sensor {
            b.sensor(&cx, d.span().start, d.get_ref())?;
        }
    }
    if let Err(e) = b.mech.validate() {
        let f = files.last().expect("read_tree returns the root file");
        return Err(ModelFileError::File {
            file: f.src.file.clone(),
            problem: Problem::Model,
            message: e.to_string(),
        });
    }
    Ok(BuiltModel {
        mechanism: b.mech,
        bodies: b.out_bodies,
        markers: b.markers,
        joints: b.joints,
        drivers: b.drivers,
        forces: b.forces,
        sensors: b.sensors,
    })
}

/// Each file with its reading context (its source, the parameters and their values).
fn contexts<'a>(
    files: &'a [Parsed],
    params: &'a [Parameter],
    values: &'a [f64],
) -> impl Iterator<Item = (Ctx<'a>, &'a Parsed)> {
    files.iter().map(move |f| {
        (
            Ctx {
                src: &f.src,
                params,
                values,
            },
            f,
        )
    })
}

/// Where each joint was declared (for assembly errors): (joint name, file, byte offset).
pub(crate) fn joint_places(files: &[Parsed]) -> Vec<(String, usize, usize)> {
    let mut out = vec![];
    for (k, f) in files.iter().enumerate() {
        for d in &f.doc.joint {
            if let Some(n) = &d.get_ref().name {
                out.push((n.get_ref().clone(), k, d.span().start));
            }
        }
        for d in &f.doc.driver {
            if let Some(n) = &d.get_ref().name {
                out.push((n.get_ref().clone(), k, d.span().start));
            }
        }
    }
    out
}

struct Builder {
    mech: Mechanism,
    out_bodies: Vec<(String, BodyHandle)>,
    body_places: Vec<String>,
    markers: Vec<(String, MarkerHandle, BodyHandle, Vector3<f64>)>,
    joints: Vec<JointInfo>,
    joint_places: Vec<String>,
    drivers: Vec<(String, DriverHandle, usize)>,
    forces: Vec<(String, String)>,
    sensors: Vec<Sensor>,
    sensor_names: Vec<String>,
    opts: BuildOptions,
}

impl Builder {
    fn attach(&self, cx: &Ctx, name: &Name, owner: &str) -> Result<Attach, ModelFileError> {
        let n = name.get_ref();
        if n == "ground" {
            return Ok(Attach::Ground);
        }
        self.out_bodies
            .iter()
            .find(|(b, _)| b == n)
            .map(|(_, h)| Attach::Body(*h))
            .ok_or_else(|| {
                let known: Vec<&str> = self.out_bodies.iter().map(|(b, _)| b.as_str()).collect();
                cx.err(
                    name.span().start,
                    Problem::UnknownReference,
                    format!("{owner}: no body '{n}' (bodies: ground, {})", known.join(", ")),
                )
            })
    }

    fn pose(&self, a: Attach) -> (Vector3<f64>, Matrix3<f64>) {
        match a {
            Attach::Ground => (Vector3::zeros(), Matrix3::identity()),
            Attach::Body(h) => {
                let b = self.mech.body(h).expect("handles come from this builder");
                (b.position, rotation(&b.orientation.normalize()))
            }
        }
    }

    /// A base-frame point in side `a`'s body frame (build configuration).
    fn to_local(&self, a: Attach, p: Vector3<f64>) -> Vector3<f64> {
        let (r, rot) = self.pose(a);
        rot.transpose() * (p - r)
    }

    fn body(&mut self, cx: &Ctx, at: usize, d: &super::schema::BodyDoc) -> Result<(), ModelFileError> {
        let name = cx.need_name(&d.name, "name", "a [[body]]", at)?;
        let owner = format!("body '{}'", name.get_ref());
        if name.get_ref() == "ground" {
            return Err(cx.err(
                name.span().start,
                Problem::Duplicate,
                "'ground' is reserved for the fixed base",
            ));
        }
        if self.body_places.iter().any(|n| n == name.get_ref()) {
            return Err(cx.err(
                name.span().start,
                Problem::Duplicate,
                format!("duplicate {owner}"),
            ));
        }
        if self.out_bodies.len() >= MAX_BODIES {
            return Err(cx.err(
                at,
                Problem::Inconsistent,
                format!("more than {MAX_BODIES} bodies"),
            ));
        }
        let mass = cx.positive(
            cx.need(&d.mass, "mass", &owner, at)?,
            Dimension::Mass,
            &format!("{owner} mass"),
        )?;
        let iv = cx.need(&d.inertia, "inertia", &owner, at)?;
        let what = format!("{owner} inertia");
        let x = cx.list(iv, Dimension::Inertia, &[3, 6], &what)?;
        let inertia = if x.len() == 3 {
            Matrix3::from_diagonal(&Vector3::new(x[0], x[1], x[2]))
        } else {
            Matrix3::new(x[0], x[3], x[4], x[3], x[1], x[5], x[4], x[5], x[2])
        };
        let eig = SymmetricEigen::new(inertia).eigenvalues;
        let (lo, hi, sum) = (eig.min(), eig.max(), eig.sum());
        if lo <= 0.0 {
            return Err(cx.err(
                iv.span().start,
                Problem::Inertia,
                format!(
                    "{what} is not positive definite (principal moments {:.3e}, {:.3e}, {:.3e} kg m^2)",
                    eig[0], eig[1], eig[2]
                ),
            ));
        }
        if hi > (sum - hi) * (1.0 + 1e-9) {
            return Err(cx.err(
                iv.span().start,
                Problem::Inertia,
                format!(
                    "{what}: the largest principal moment {hi:.3e} kg m^2 exceeds the sum of the other two {:.3e} (no rigid body has such an inertia)",
                    sum - hi
                ),
            ));
        }
        let mut body = RigidBody::new(name.get_ref().clone(), mass, inertia);
        if let Some(p) = &d.position {
            body = body.at(cx.vec3(p, Dimension::Length, &format!("{owner} position"))?);
        }
        if let Some(o) = &d.orientation {
            body = body.oriented(&orientation(cx, &owner, o.span().start, o.get_ref())?);
        }
        if let Some(v) = &d.velocity {
            body = body.moving(cx.vec3(v, Dimension::Velocity, &format!("{owner} velocity"))?);
        }
        if let Some(w) = &d.angular_velocity {
            let w = cx.vec3(
                w,
                Dimension::AngularVelocity,
                &format!("{owner} angular velocity"),
            )?;
            let rot = rotation(&body.orientation.normalize());
            body = body.spinning(rot.transpose() * w);
        }
        let h = self.mech.add_body(body);
        self.out_bodies.push((name.get_ref().clone(), h));
        self.body_places.push(name.get_ref().clone());
        Ok(())
    }

    fn joint(&mut self, cx: &Ctx, at: usize, d: &JointDoc) -> Result<(), ModelFileError> {
        let name = cx.need_name(&d.name, "name", "a [[joint]]", at)?;
        let owner = format!("joint '{}'", name.get_ref());
        if self.joint_places.iter().any(|n| n == name.get_ref()) {
            return Err(cx.err(
                name.span().start,
                Problem::Duplicate,
                format!("duplicate {owner}"),
            ));
        }
        let kind_name = cx.need_name(&d.kind, "type", &owner, at)?;
        let kind = match kind_name.get_ref().as_str() {
            "revolute" => JointKind::Revolute,
            "prismatic" => JointKind::Prismatic,
            "universal" => JointKind::Universal,
            "spherical" => JointKind::Spherical,
            "cylindrical" => JointKind::Cylindrical,
            "fixed" => JointKind::Fixed,
            other => {
                return Err(cx.err(
                    kind_name.span().start,
                    Problem::UnknownType,
                    format!("{owner}: unknown joint type '{other}' (types: {JOINT_TYPES})"),
                ))
            }
        };
        let iname = cx.need_name(&d.i, "i", &owner, at)?;
        let jname = cx.need_name(&d.j, "j", &owner, at)?;
        let i = self.attach(cx, iname, &owner)?;
        let j = self.attach(cx, jname, &owner)?;
        if i == j {
            return Err(cx.err(
                jname.span().start,
                Problem::SelfJoint,
                format!("{owner} connects '{}' to itself", jname.get_ref()),
            ));
        }
        let point = cx.vec3(
            cx.need(&d.point, "point", &owner, at)?,
            Dimension::Length,
            &format!("{owner} point"),
        )?;
        let not_for = |v: &Option<Val>, key: &str| -> Result<(), ModelFileError> {
            match v {
                Some(v) => Err(cx.err(
                    v.span().start,
                    Problem::NotApplicable,
                    format!("{owner}: a {} joint has no '{key}'", kind_name.get_ref()),
                )),
                None => Ok(()),
            }
        };
        let (ai, aj) = match kind {
            JointKind::Revolute | JointKind::Prismatic | JointKind::Cylindrical => {
                not_for(&d.axis_i, "axis_i")?;
                not_for(&d.axis_j, "axis_j")?;
                let a = cx.direction(cx.need(&d.axis, "axis", &owner, at)?, &format!("{owner} axis"))?;
                (a, a)
            }
            JointKind::Universal => {
                not_for(&d.axis, "axis (a universal joint has axis_i and axis_j)")?;
                let vi = cx.need(&d.axis_i, "axis_i", &owner, at)?;
                let vj = cx.need(&d.axis_j, "axis_j", &owner, at)?;
                let a = cx.direction(vi, &format!("{owner} axis_i"))?;
                let b2 = cx.direction(vj, &format!("{owner} axis_j"))?;
                if a.dot(&b2).abs() > 1e-6 {
                    return Err(cx.err(
                        vj.span().start,
                        Problem::NotPerpendicular,
                        format!(
                            "{owner}: axis_i and axis_j must be perpendicular (cosine {:.3e})",
                            a.dot(&b2)
                        ),
                    ));
                }
                (a, b2)
            }
            JointKind::Spherical | JointKind::Fixed => {
                not_for(&d.axis, "axis")?;
                not_for(&d.axis_i, "axis_i")?;
                not_for(&d.axis_j, "axis_j")?;
                (Vector3::z(), Vector3::z())
            }
        };
        let info_dim = match kind {
            JointKind::Revolute | JointKind::Cylindrical => Some(Dimension::Angle),
            JointKind::Prismatic => Some(Dimension::Length),
            _ => None,
        };
        let coordinate0 = match (&d.coordinate, info_dim) {
            (Some(v), Some(dim)) => cx.scalar(v, dim, &format!("{owner} coordinate"))?,
            (Some(v), None) => {
                return Err(cx.err(
                    v.span().start,
                    Problem::NotApplicable,
                    format!("{owner}: a {} joint has no coordinate", kind_name.get_ref()),
                ))
            }
            (None, _) => 0.0,
        };
        let limits = match (&d.limits, info_dim) {
            (None, _) => None,
            (Some(v), None) => {
                return Err(cx.err(
                    v.span().start,
                    Problem::NotApplicable,
                    format!(
                        "{owner}: a {} joint has no coordinate to limit",
                        kind_name.get_ref()
                    ),
                ))
            }
            (Some(v), Some(dim)) => {
                let x = cx.list(v, dim, &[2], &format!("{owner} limits"))?;
                if x[0] >= x[1] {
                    return Err(cx.err(
                        v.span().start,
                        Problem::Inconsistent,
                        format!(
                            "{owner}: limits [{}, {}] are not increasing",
                            short(x[0]),
                            short(x[1])
                        ),
                    ));
                }
                Some([x[0], x[1]])
            }
        };
        let clearance = match &d.clearance {
            None => None,
            Some(c) => {
                if !matches!(
                    kind,
                    JointKind::Universal | JointKind::Revolute | JointKind::Spherical
                ) {
                    return Err(cx.err(
                        c.span().start,
                        Problem::NotApplicable,
                        format!("{owner}: clearance is modelled for universal, revolute and spherical joints, not {}", kind_name.get_ref()),
                    ));
                }
                let cd = c.get_ref();
                let cat = c.span().start;
                let co = format!("{owner} clearance");
                let radial = cx.non_negative(
                    cx.need(&cd.radial, "radial", &co, cat)?,
                    Dimension::Length,
                    &format!("{co} radial"),
                )?;
                let axial = match &cd.axial {
                    Some(v) => cx.non_negative(v, Dimension::Length, &format!("{co} axial"))?,
                    None => 0.0,
                };
                let mut design = BearingDesign::mr2120(radial, axial, Damping::Elastic);
                if let Some(v) = &cd.ball_radius {
                    design.ball_radius = cx.positive(v, Dimension::Length, &format!("{co} ball_radius"))?;
                }
                if let Some(v) = &cd.ball_spacing {
                    design.ball_spacing = cx.positive(v, Dimension::Length, &format!("{co} ball_spacing"))?;
                }
                if let Some(v) = &cd.damping {
                    let alpha = cx.non_negative(
                        v,
                        Dimension::Ratio,
                        &format!("{co} damping (Hunt-Crossley factor, s/m)"),
                    )?;
                    design.damping = Damping::HuntCrossley(alpha);
                }
                if let Some(v) = &cd.cross_mass {
                    if kind != JointKind::Universal {
                        return Err(cx.err(
                            v.span().start,
                            Problem::NotApplicable,
                            format!("{co}: only a universal joint has a cross"),
                        ));
                    }
                }
                Some((design, cd.cross_mass.as_ref()))
            }
        };
        let frame_i = JointFrame::with_x(
            self.to_local(i, point),
            self.pose(i).1.transpose() * ai,
            self.pose(i).1.transpose() * perpendicular(&ai),
        );
        let frame_j = JointFrame::with_x(
            self.to_local(j, point),
            self.pose(j).1.transpose() * aj,
            self.pose(j).1.transpose() * perpendicular(&ai),
        );
        let nm = name.get_ref().as_str();
        let handle = match (&clearance, self.opts.clearance) {
            (Some((design, cross)), true) => {
                let fail =
                    |e: crate::contact::ContactError| cx.err(at, Problem::Model, format!("{owner}: {e}"));
                match kind {
                    JointKind::Universal => {
                        let cross_mass = match cross {
                            Some(v) => {
                                cx.positive(v, Dimension::Mass, &format!("{owner} clearance cross_mass"))?
                            }
                            None => 0.05,
                        };
                        universal_with_clearance(&mut self.mech, nm, i, j, point, ai, aj, design, cross_mass)
                            .map_err(fail)?;
                    }
                    JointKind::Revolute => {
                        revolute_with_clearance(&mut self.mech, nm, i, j, point, ai, design).map_err(fail)?
                    }
                    _ => spherical_with_clearance(&mut self.mech, nm, i, j, point, design).map_err(fail)?,
                }
                None
            }
            _ => Some(match kind {
                JointKind::Revolute => self.mech.revolute_at(nm, i, j, point, ai),
                JointKind::Prismatic => self.mech.prismatic_along(nm, i, j, point, ai),
                JointKind::Cylindrical => self.mech.cylindrical_along(nm, i, j, point, ai),
                JointKind::Universal => self.mech.universal_at(nm, i, j, point, ai, aj),
                JointKind::Spherical => self.mech.spherical_at(nm, i, j, point),
                JointKind::Fixed => self.mech.fixed_at(nm, i, j, point),
            }),
        };
        self.joints.push(JointInfo {
            name: nm.to_string(),
            kind,
            i,
            j,
            frame_i,
            frame_j,
            coordinate0,
            handle,
            driver: None,
            efforts: vec![],
            clearance: clearance.map(|(d, _)| d),
            limits,
            transmission: None,
        });
        self.joint_places.push(nm.to_string());
        Ok(())
    }

    fn transmission(&mut self, cx: &Ctx, at: usize, d: &TransmissionDoc) -> Result<(), ModelFileError> {
        let jn = cx.need_name(&d.joint, "joint", "a [[transmission]]", at)?;
        let owner = format!("transmission of joint '{}'", jn.get_ref());
        let k = self.joint_ref(cx, jn, &owner)?;
        let kind = self.joints[k].kind;
        if !matches!(kind, JointKind::Revolute | JointKind::Prismatic) {
            return Err(cx.err(
                jn.span().start,
                Problem::NotApplicable,
                format!(
                    "{owner}: joint '{}' is {}; a transmission drives a revolute or prismatic joint",
                    jn.get_ref(),
                    format!("{kind:?}").to_lowercase()
                ),
            ));
        }
        if self.joints[k].transmission.is_some() {
            return Err(cx.err(
                jn.span().start,
                Problem::Duplicate,
                format!("{owner}: joint '{}' has a transmission already", jn.get_ref()),
            ));
        }
        let rotary = kind == JointKind::Revolute;
        let (cdim, jdim, ddim) = if rotary {
            (
                Dimension::RotationalCompliance,
                Dimension::Inertia,
                Dimension::RotationalDamping,
            )
        } else {
            (Dimension::Compliance, Dimension::Mass, Dimension::Damping)
        };
        let cv = cx.need(&d.compliance, "compliance", &owner, at)?;
        let compliance = cx.positive(cv, cdim, &format!("{owner} compliance"))?;
        let compliance_parameter = cx.parameter_index(cv);
        let rotor_inertia = cx.positive(
            cx.need(&d.rotor_inertia, "rotor_inertia", &owner, at)?,
            jdim,
            &format!("{owner} rotor_inertia"),
        )?;
        let damping = match &d.damping {
            Some(v) => cx.non_negative(v, ddim, &format!("{owner} damping"))?,
            None => 0.0,
        };
        let rotor_mass = match (&d.rotor_mass, rotary) {
            (Some(v), true) => cx.positive(v, Dimension::Mass, &format!("{owner} rotor_mass"))?,
            (Some(v), false) => {
                return Err(cx.err(
                    v.span().start,
                    Problem::NotApplicable,
                    format!("{owner}: on a prismatic joint the rotor's mass is its rotor_inertia (kg); give no rotor_mass"),
                ))
            }
            (None, _) => DEFAULT_ROTOR_MASS,
        };
        let motor = if self.opts.measured_joints.contains(jn.get_ref()) {
            None
        } else {
            let joint = self.joints[k].clone();
            let rotor_name = format!("{} rotor", joint.name);
            let motor_name = format!("{} motor", joint.name);
            if self.out_bodies.iter().any(|(n, _)| *n == rotor_name)
                || self.joint_places.contains(&motor_name)
            {
                return Err(cx.err(
                    jn.span().start,
                    Problem::Duplicate,
                    format!("{owner}: its rotor is built as body '{rotor_name}' on joint '{motor_name}', but the file already has one of those names"),
                ));
            }
            let (pi, roti) = self.pose(joint.i);
            let point = pi + roti * joint.frame_i.origin;
            let axis: Vector3<f64> = roti * joint.frame_i.axes.column(2);
            let x: Vector3<f64> = roti * joint.frame_i.axes.column(0);
            let (mass, inertia) = if rotary {
                let jp = rotor_inertia / 2.0;
                (
                    rotor_mass,
                    Matrix3::identity() * jp + axis * axis.transpose() * (rotor_inertia - jp),
                )
            } else {
                (
                    rotor_inertia,
                    Matrix3::identity() * rotor_inertia * PRISMATIC_ROTOR_GYRATION.powi(2),
                )
            };
            let rotor = self
                .mech
                .add_body(RigidBody::new(rotor_name, mass, inertia).at(point));
            let h = if rotary {
                self.mech
                    .revolute_at(&motor_name, joint.i, Attach::Body(rotor), point, axis)
            } else {
                self.mech
                    .prismatic_along(&motor_name, joint.i, Attach::Body(rotor), point, axis)
            };
            let stiffness = 1.0 / compliance;
            let fail = || {
                cx.err(
                    at,
                    Problem::Model,
                    format!("{owner}: the joint has no finite axis in the build configuration"),
                )
            };
            let spring = format!("{} transmission", joint.name);
            self.forces.push((spring.clone(), "transmission".into()));
            if rotary {
                let rotation =
                    RelativeRotation::from_initial_poses(&self.mech, Attach::Body(rotor), joint.j, axis)
                        .ok_or_else(fail)?;
                self.mech.add_force(Box::new(RotationalSpringDamper {
                    name: spring,
                    rotation,
                    stiffness,
                    damping,
                    free_angle: 0.0,
                }));
            } else {
                let translation = RelativeTranslation::from_initial_poses(
                    &self.mech,
                    Attach::Body(rotor),
                    joint.j,
                    point,
                    axis,
                )
                .ok_or_else(fail)?;
                self.mech.add_force(Box::new(TranslationalForce {
                    name: spring,
                    translation,
                    law: Arc::new(move |_t, x, v| -stiffness * x - damping * v),
                }));
            }
            Some(Box::new(JointInfo {
                name: motor_name,
                kind,
                i: joint.i,
                j: Attach::Body(rotor),
                frame_i: joint.frame_i,
                frame_j: JointFrame::with_x(Vector3::zeros(), axis, x),
                coordinate0: joint.coordinate0,
                handle: Some(h),
                driver: None,
                efforts: vec![],
                clearance: None,
                limits: None,
                transmission: None,
            }))
        };
        self.joints[k].transmission = Some(Transmission {
            compliance,
            compliance_parameter,
            rotor_inertia,
            damping,
            motor,
        });
        Ok(())
    }

    fn joint_ref(&self, cx: &Ctx, name: &Name, owner: &str) -> Result<usize, ModelFileError> {
        self.joints
            .iter()
            .position(|j| j.name == *name.get_ref())
            .ok_or_else(|| {
                let known: Vec<&str> = self.joints.iter().map(|j| j.name.as_str()).collect();
                cx.err(
                    name.span().start,
                    Problem::UnknownReference,
                    format!(
                        "{owner}: no joint '{}' (joints: {})",
                        name.get_ref(),
                        known.join(", ")
                    ),
                )
            })
    }

    /// A joint with a coordinate (revolute, cylindrical, prismatic).
    fn coordinate_joint(
        &self,
        cx: &Ctx,
        name: &Name,
        owner: &str,
        role: &str,
    ) -> Result<(usize, Dimension), ModelFileError> {
        let k = self.joint_ref(cx, name, owner)?;
        let dim = self.joints[k].coordinate_dimension().ok_or_else(|| {
            cx.err(
                name.span().start,
                Problem::NotApplicable,
                format!(
                    "{owner}: joint '{}' is {:?}, which has no coordinate to {role} (revolute, cylindrical and prismatic joints have one)",
                    name.get_ref(),
                    self.joints[k].kind
                ),
            )
        })?;
        Ok((k, dim))
    }

    /// A sampled series named by `file`, `time_column` (default "t") and `column`.
    #[allow(clippy::too_many_arguments)]
    fn series(
        &self,
        cx: &Ctx,
        dir: &std::path::Path,
        file: &Name,
        time_column: &Option<Name>,
        column: &Option<Name>,
        unit: &Option<Name>,
        dim: Dimension,
        owner: &str,
        at: usize,
    ) -> Result<(Vec<f64>, Vec<f64>), ModelFileError> {
        let col = cx.need_name(column, "column", owner, at)?;
        let tcol = time_column.as_ref().map(|s| s.get_ref().as_str()).unwrap_or("t");
        let (t, mut v) = read_columns(&dir.join(file.get_ref()), tcol, col.get_ref())
            .map_err(|m| cx.err(file.span().start, Problem::Series, format!("{owner}: {m}")))?;
        if let Some(u) = unit {
            let f = parse_quantity(&format!("1 {}", u.get_ref()), dim)
                .map_err(|m| cx.err(u.span().start, Problem::Unit, format!("{owner} unit: {m}")))?;
            v.iter_mut().for_each(|x| *x *= f);
        }
        Ok((t, v))
    }

    fn driver(
        &mut self,
        cx: &Ctx,
        dir: &std::path::Path,
        at: usize,
        d: &DriverDoc,
    ) -> Result<(), ModelFileError> {
        let name = cx.need_name(&d.name, "name", "a [[driver]]", at)?;
        let owner = format!("driver '{}'", name.get_ref());
        if self.drivers.iter().any(|(n, ..)| n == name.get_ref()) {
            return Err(cx.err(
                name.span().start,
                Problem::Duplicate,
                format!("duplicate {owner}"),
            ));
        }
        let jn = cx.need_name(&d.joint, "joint", &owner, at)?;
        let (k, dim) = self.coordinate_joint(cx, jn, &owner, "drive")?;
        if self.opts.measured_joints.contains(jn.get_ref()) {
            return Ok(());
        }
        let joint = &self.joints[k];
        // With a transmission the motor turns the rotor, and the joint follows.
        let motor = joint
            .transmission
            .as_ref()
            .and_then(|t| t.motor.as_ref())
            .and_then(|m| m.handle);
        let Some(jh) = motor.or(joint.handle) else {
            return Err(cx.err(
                jn.span().start,
                Problem::NotApplicable,
                format!("{owner}: joint '{}' is built with clearance (contact), which has no coordinate to drive; drive a joint without clearance", joint.name),
            ));
        };
        if joint.driver.is_some() {
            return Err(cx.err(
                jn.span().start,
                Problem::Duplicate,
                format!("{owner}: joint '{}' is driven twice", joint.name),
            ));
        }
        let law_name = cx.need_name(&d.law, "law", &owner, at)?;
        let keys: [(&str, bool); 10] = [
            ("value", d.value.is_some()),
            ("coefficients", d.coefficients.is_some()),
            ("t0", d.t0.is_some()),
            ("t1", d.t1.is_some()),
            ("from", d.from.is_some()),
            ("to", d.to.is_some()),
            ("profile", d.profile.is_some()),
            ("file", d.file.is_some()),
            ("column", d.column.is_some()),
            ("time_column", d.time_column.is_some()),
        ];
        let allowed: &[&str] = match law_name.get_ref().as_str() {
            "constant" => &["value"],
            "polynomial" => &["coefficients"],
            "rest_to_rest" => &["t0", "t1", "from", "to", "profile"],
            "sampled" => &["file", "column", "time_column"],
            other => {
                return Err(cx.err(
                    law_name.span().start,
                    Problem::UnknownType,
                    format!("{owner}: unknown law '{other}' (laws: {LAWS})"),
                ))
            }
        };
        if let Some((key, _)) = keys.iter().find(|(k, set)| *set && !allowed.contains(k)) {
            return Err(cx.err(
                at,
                Problem::NotApplicable,
                format!(
                    "{owner}: a {} law has no '{key}' (it takes: {})",
                    law_name.get_ref(),
                    allowed.join(", ")
                ),
            ));
        }
        let law = match law_name.get_ref().as_str() {
            "constant" => MotionLaw::Constant(cx.scalar(
                cx.need(&d.value, "value", &owner, at)?,
                dim,
                &format!("{owner} value"),
            )?),
            "polynomial" => {
                let c = cx.need(&d.coefficients, "coefficients", &owner, at)?;
                let toml::Value::Array(items) = c.get_ref() else {
                    return Err(cx.err(
                        c.span().start,
                        Problem::WrongType,
                        format!("{owner}: coefficients must be an array"),
                    ));
                };
                if items.is_empty() {
                    return Err(cx.err(
                        c.span().start,
                        Problem::WrongType,
                        format!("{owner}: coefficients must not be empty"),
                    ));
                }
                // c_k has units of the coordinate per s^k: numbers only (SI).
                let coeffs = cx.list(
                    c,
                    Dimension::Ratio,
                    &[],
                    &format!("{owner} coefficients (SI: coordinate per s^k)"),
                )?;
                MotionLaw::Polynomial { coeffs }
            }
            "rest_to_rest" => {
                let t0 = cx.scalar(
                    cx.need(&d.t0, "t0", &owner, at)?,
                    Dimension::Time,
                    &format!("{owner} t0"),
                )?;
                let t1v = cx.need(&d.t1, "t1", &owner, at)?;
                let t1 = cx.scalar(t1v, Dimension::Time, &format!("{owner} t1"))?;
                if t1 <= t0 {
                    return Err(cx.err(
                        t1v.span().start,
                        Problem::Inconsistent,
                        format!("{owner}: t1 = {t1} s must be after t0 = {t0} s"),
                    ));
                }
                let from = cx.scalar(
                    cx.need(&d.from, "from", &owner, at)?,
                    dim,
                    &format!("{owner} from"),
                )?;
                let to = cx.scalar(cx.need(&d.to, "to", &owner, at)?, dim, &format!("{owner} to"))?;
                let profile = match d.profile.as_ref().map(|p| (p.get_ref().as_str(), p.span().start)) {
                    None | Some(("quintic", _)) => Profile::Quintic,
                    Some(("cycloidal", _)) => Profile::Cycloidal,
                    Some((other, pat)) => {
                        return Err(cx.err(
                            pat,
                            Problem::UnknownType,
                            format!("{owner}: unknown profile '{other}' (quintic, cycloidal)"),
                        ))
                    }
                };
                MotionLaw::RestToRest {
                    t0,
                    t1,
                    from,
                    to,
                    profile,
                }
            }
            _ => {
                let file = cx.need_name(&d.file, "file", &owner, at)?;
                let (t, v) =
                    self.series(cx, dir, file, &d.time_column, &d.column, &d.unit, dim, &owner, at)?;
                MotionLaw::sampled(t, v)
                    .map_err(|m| cx.err(file.span().start, Problem::Series, format!("{owner}: {m}")))?
            }
        };
        let reference = self.joints[k].coordinate0;
        let h = self
            .mech
            .drive(name.get_ref(), jh, law, reference)
            .map_err(|e| cx.err(at, Problem::NotApplicable, e.to_string()))?;
        self.joints[k].driver = Some(h);
        self.drivers.push((name.get_ref().clone(), h, k));
        Ok(())
    }

    fn force(
        &mut self,
        cx: &Ctx,
        dir: &std::path::Path,
        at: usize,
        d: &ForceDoc,
    ) -> Result<(), ModelFileError> {
        let name = cx.need_name(&d.name, "name", "a [[force]]", at)?;
        let owner = format!("force '{}'", name.get_ref());
        if self.forces.iter().any(|(n, _)| n == name.get_ref()) {
            return Err(cx.err(
                name.span().start,
                Problem::Duplicate,
                format!("duplicate {owner}"),
            ));
        }
        let kind = cx.need_name(&d.kind, "type", &owner, at)?;
        let set: [(&str, bool); 21] = [
            ("i", d.i.is_some()),
            ("j", d.j.is_some()),
            ("point_i", d.point_i.is_some()),
            ("point_j", d.point_j.is_some()),
            ("stiffness", d.stiffness.is_some()),
            ("damping", d.damping.is_some()),
            ("free_length", d.free_length.is_some()),
            ("free_angle", d.free_angle.is_some()),
            ("joint", d.joint.is_some()),
            ("coulomb", d.coulomb.is_some()),
            ("viscous", d.viscous.is_some()),
            ("viscous_backward", d.viscous_backward.is_some()),
            ("velocity_scale", d.velocity_scale.is_some()),
            ("smoothing", d.smoothing.is_some()),
            ("value", d.value.is_some()),
            ("file", d.file.is_some()),
            ("column", d.column.is_some()),
            ("time_column", d.time_column.is_some()),
            ("body", d.body.is_some()),
            ("point", d.point.is_some()),
            ("force", d.force.is_some()),
        ];
        let allowed: &[&str] = match kind.get_ref().as_str() {
            "spring_damper" => &[
                "i",
                "j",
                "point_i",
                "point_j",
                "stiffness",
                "damping",
                "free_length",
            ],
            "rotational_spring_damper" => &["joint", "stiffness", "damping", "free_angle"],
            "friction" => &[
                "joint",
                "coulomb",
                "viscous",
                "viscous_backward",
                "velocity_scale",
                "smoothing",
            ],
            "effort" => &["joint", "value", "file", "column", "time_column"],
            "point_force" => &["body", "point", "force"],
            other => {
                return Err(cx.err(
                    kind.span().start,
                    Problem::UnknownType,
                    format!("{owner}: unknown force type '{other}' (types: {FORCE_TYPES})"),
                ))
            }
        };
        if let Some((key, _)) = set.iter().find(|(k, s)| *s && !allowed.contains(k)) {
            return Err(cx.err(
                at,
                Problem::NotApplicable,
                format!(
                    "{owner}: a {} has no '{key}' (it takes: {})",
                    kind.get_ref(),
                    allowed.join(", ")
                ),
            ));
        }
        let nm = name.get_ref().clone();
        match kind.get_ref().as_str() {
            "spring_damper" => {
                let i = self.attach(cx, cx.need_name(&d.i, "i", &owner, at)?, &owner)?;
                let j = self.attach(cx, cx.need_name(&d.j, "j", &owner, at)?, &owner)?;
                let pi = cx.vec3(
                    cx.need(&d.point_i, "point_i", &owner, at)?,
                    Dimension::Length,
                    &format!("{owner} point_i"),
                )?;
                let pj = cx.vec3(
                    cx.need(&d.point_j, "point_j", &owner, at)?,
                    Dimension::Length,
                    &format!("{owner} point_j"),
                )?;
                let stiffness = cx.non_negative(
                    cx.need(&d.stiffness, "stiffness", &owner, at)?,
                    Dimension::Stiffness,
                    &format!("{owner} stiffness"),
                )?;
                let damping = match &d.damping {
                    Some(v) => cx.non_negative(v, Dimension::Damping, &format!("{owner} damping"))?,
                    None => 0.0,
                };
                let free_length = match &d.free_length {
                    Some(v) => cx.non_negative(v, Dimension::Length, &format!("{owner} free_length"))?,
                    None => (pj - pi).norm(),
                };
                let (li, lj) = (self.to_local(i, pi), self.to_local(j, pj));
                self.mech.add_force(Box::new(SpringDamper {
                    name: nm.clone(),
                    i: (i, li),
                    j: (j, lj),
                    stiffness,
                    damping,
                    free_length,
                }));
            }
            "rotational_spring_damper" => {
                let jn = cx.need_name(&d.joint, "joint", &owner, at)?;
                let (k, _) = self.coordinate_joint(cx, jn, &owner, "act on")?;
                let joint = self.joints[k].clone();
                if joint.kind == JointKind::Prismatic {
                    return Err(cx.err(
                        jn.span().start,
                        Problem::NotApplicable,
                        format!(
                            "{owner}: joint '{}' is prismatic; use a spring_damper along it",
                            joint.name
                        ),
                    ));
                }
                let stiffness = cx.non_negative(
                    cx.need(&d.stiffness, "stiffness", &owner, at)?,
                    Dimension::RotationalStiffness,
                    &format!("{owner} stiffness"),
                )?;
                let damping = match &d.damping {
                    Some(v) => {
                        cx.non_negative(v, Dimension::RotationalDamping, &format!("{owner} damping"))?
                    }
                    None => 0.0,
                };
                let free_angle = match &d.free_angle {
                    Some(v) => {
                        cx.scalar(v, Dimension::Angle, &format!("{owner} free_angle"))? - joint.coordinate0
                    }
                    None => 0.0,
                };
                let rotation = self.rotation_of(&joint);
                self.mech.add_force(Box::new(RotationalSpringDamper {
                    name: nm.clone(),
                    rotation,
                    stiffness,
                    damping,
                    free_angle,
                }));
            }
            "friction" => {
                let jn = cx.need_name(&d.joint, "joint", &owner, at)?;
                let (k, dim) = self.coordinate_joint(cx, jn, &owner, "act on")?;
                let joint = self.joints[k].clone();
                let (fdim, ddim, vdim) = if dim == Dimension::Angle {
                    (
                        Dimension::Torque,
                        Dimension::RotationalDamping,
                        Dimension::AngularVelocity,
                    )
                } else {
                    (Dimension::Force, Dimension::Damping, Dimension::Velocity)
                };
                let coulomb = match &d.coulomb {
                    Some(v) => cx.non_negative(v, fdim, &format!("{owner} coulomb"))?,
                    None => 0.0,
                };
                let viscous = match &d.viscous {
                    Some(v) => cx.non_negative(v, ddim, &format!("{owner} viscous"))?,
                    None => 0.0,
                };
                let backward = match &d.viscous_backward {
                    Some(v) => cx.non_negative(v, ddim, &format!("{owner} viscous_backward"))?,
                    None => viscous,
                };
                let vs = match &d.velocity_scale {
                    Some(v) => cx.positive(v, vdim, &format!("{owner} velocity_scale"))?,
                    None if coulomb > 0.0 => {
                        return Err(cx.err(at, Problem::Missing, format!("{owner} has Coulomb friction but no 'velocity_scale' (the speed over which its sign is smoothed, in {vdim})")))
                    }
                    None => 1.0,
                };
                // How the sign of the velocity is smoothed: tanh(v/v_s), or the algebraic
                // v/√(v² + v_s²) (slower tails: a law of another form than tanh).
                let algebraic = match d
                    .smoothing
                    .as_ref()
                    .map(|s| (s.get_ref().as_str(), s.span().start))
                {
                    None | Some(("tanh", _)) => false,
                    Some(("algebraic", _)) => true,
                    Some((other, sat)) => {
                        return Err(cx.err(
                            sat,
                            Problem::UnknownType,
                            format!("{owner}: unknown smoothing '{other}' (tanh, algebraic)"),
                        ))
                    }
                };
                let law = move |_t: f64, _x: f64, v: f64| -> f64 {
                    let c = if v >= 0.0 { viscous } else { backward };
                    let sign = if algebraic {
                        v / (v * v + vs * vs).sqrt()
                    } else {
                        (v / vs).tanh()
                    };
                    -(coulomb * sign + c * v)
                };
                self.coordinate_force(&joint, nm.clone(), Arc::new(law))
                    .map_err(|m| cx.err(at, Problem::Model, format!("{owner}: {m}")))?;
            }
            "effort" => {
                let jn = cx.need_name(&d.joint, "joint", &owner, at)?;
                let (k, dim) = self.coordinate_joint(cx, jn, &owner, "act on")?;
                let joint = self.joints[k].clone();
                let fdim = if dim == Dimension::Angle {
                    Dimension::Torque
                } else {
                    Dimension::Force
                };
                let law: EffortLaw = match (&d.value, &d.file) {
                    (Some(v), None) => {
                        let x = cx.scalar(v, fdim, &format!("{owner} value"))?;
                        Arc::new(move |_t| x)
                    }
                    (None, Some(file)) => {
                        let (t, v) = self.series(
                            cx,
                            dir,
                            file,
                            &d.time_column,
                            &d.column,
                            &d.unit,
                            fdim,
                            &owner,
                            at,
                        )?;
                        let MotionLaw::Sampled(s) = MotionLaw::sampled(t, v).map_err(|m| {
                            cx.err(file.span().start, Problem::Series, format!("{owner}: {m}"))
                        })?
                        else {
                            unreachable!("MotionLaw::sampled returns a sampled law")
                        };
                        Arc::new(move |t| s.eval(t)[0])
                    }
                    (Some(v), Some(_)) => {
                        return Err(cx.err(
                            v.span().start,
                            Problem::Inconsistent,
                            format!("{owner}: give either 'value' or 'file', not both"),
                        ))
                    }
                    (None, None) => {
                        return Err(cx.err(at, Problem::Missing, format!("{owner} has no 'value' or 'file'")))
                    }
                };
                if !self.opts.measured_joints.contains(&joint.name) {
                    let l2 = law.clone();
                    // With a transmission the effort acts on the rotor.
                    let on = match joint.transmission.as_ref().and_then(|t| t.motor.as_deref()) {
                        Some(m) => m.clone(),
                        None => joint.clone(),
                    };
                    self.coordinate_force(&on, nm.clone(), Arc::new(move |t, _x, _v| l2(t)))
                        .map_err(|m| cx.err(at, Problem::Model, format!("{owner}: {m}")))?;
                    self.joints[k].efforts.push(law);
                }
            }
            _ => {
                let bn = cx.need_name(&d.body, "body", &owner, at)?;
                let a = self.attach(cx, bn, &owner)?;
                let Attach::Body(h) = a else {
                    return Err(cx.err(
                        bn.span().start,
                        Problem::NotApplicable,
                        format!("{owner}: a force on the ground does nothing"),
                    ));
                };
                let p = match &d.point {
                    Some(v) => cx.vec3(v, Dimension::Length, &format!("{owner} point"))?,
                    None => self.pose(a).0,
                };
                let f = cx.vec3(
                    cx.need(&d.force, "force", &owner, at)?,
                    Dimension::Force,
                    &format!("{owner} force"),
                )?;
                let point = self.to_local(a, p);
                self.mech.add_force(Box::new(PointForce {
                    name: nm.clone(),
                    body: h,
                    point,
                    force: Arc::new(move |_t| f),
                }));
            }
        }
        self.forces.push((nm, kind.get_ref().clone()));
        Ok(())
    }

    fn rotation_of(&self, joint: &JointInfo) -> RelativeRotation {
        let (_, roti) = self.pose(joint.i);
        let (_, rotj) = self.pose(joint.j);
        RelativeRotation {
            i: joint.i,
            j: joint.j,
            axis_i: joint.frame_i.axes.column(2).into(),
            reference_i: joint.frame_i.axes.column(0).into(),
            reference_j: rotj.transpose() * (roti * joint.frame_i.axes.column(0)),
        }
    }

    /// A force element acting along a joint's coordinate with law F(t, x, ẋ) (x from the
    /// file's configuration).
    fn coordinate_force(
        &mut self,
        joint: &JointInfo,
        name: String,
        law: Arc<dyn Fn(f64, f64, f64) -> f64 + Send + Sync>,
    ) -> Result<(), String> {
        if joint.kind == JointKind::Prismatic {
            let (_, roti) = self.pose(joint.i);
            let point = self.pose(joint.i).0 + roti * joint.frame_i.origin;
            let axis = roti * joint.frame_i.axes.column(2);
            let translation =
                RelativeTranslation::from_initial_poses(&self.mech, joint.i, joint.j, point, axis)
                    .ok_or_else(|| {
                        format!(
                            "joint '{}' has no finite axis in the build configuration (a body's position or orientation is not finite)",
                            joint.name
                        )
                    })?;
            self.mech.add_force(Box::new(TranslationalForce {
                name,
                translation,
                law,
            }));
        } else {
            let rotation = self.rotation_of(joint);
            self.mech
                .add_force(Box::new(RotationalTorque { name, rotation, law }));
        }
        Ok(())
    }

    fn sensor(&mut self, cx: &Ctx, at: usize, d: &super::schema::SensorDoc) -> Result<(), ModelFileError> {
        let name = cx.need_name(&d.name, "name", "a [[sensor]]", at)?;
        let owner = format!("sensor '{}'", name.get_ref());
        if self.sensor_names.iter().any(|n| n == name.get_ref()) {
            return Err(cx.err(
                name.span().start,
                Problem::Duplicate,
                format!("duplicate {owner}"),
            ));
        }
        let kind_name = cx.need_name(&d.kind, "type", &owner, at)?;
        let kind = match kind_name.get_ref().as_str() {
            "joint_position" => SensorKind::JointPosition,
            "joint_velocity" => SensorKind::JointVelocity,
            "joint_acceleration" => SensorKind::JointAcceleration,
            "joint_effort" => SensorKind::JointEffort,
            "body_position" => SensorKind::BodyPosition,
            "body_orientation" => SensorKind::BodyOrientation,
            other => {
                return Err(cx.err(
                    kind_name.span().start,
                    Problem::UnknownType,
                    format!("{owner}: unknown sensor type '{other}' (types: {SENSOR_TYPES})"),
                ))
            }
        };
        let motor_side = match d.side.as_ref().map(|s| (s.get_ref().as_str(), s.span().start)) {
            None | Some(("arm" | "joint", _)) => false,
            Some(("motor", _)) => true,
            Some((other, sat)) => {
                return Err(cx.err(
                    sat,
                    Problem::UnknownType,
                    format!("{owner}: unknown side '{other}' (joint, motor)"),
                ))
            }
        };
        let target = match kind {
            SensorKind::BodyPosition | SensorKind::BodyOrientation => {
                if let Some(j) = &d.joint {
                    return Err(cx.err(
                        j.span().start,
                        Problem::NotApplicable,
                        format!(
                            "{owner}: a {} sensor reads a body or marker, not a joint",
                            kind_name.get_ref()
                        ),
                    ));
                }
                match (&d.body, &d.marker) {
                    (Some(bn), None) => match self.attach(cx, bn, &owner)? {
                        Attach::Body(h) => SensorTarget::Body(h, Vector3::zeros()),
                        Attach::Ground => {
                            return Err(cx.err(
                                bn.span().start,
                                Problem::NotApplicable,
                                format!("{owner}: the ground does not move"),
                            ))
                        }
                    },
                    (None, Some(mn)) => {
                        if kind == SensorKind::BodyOrientation {
                            return Err(cx.err(
                                mn.span().start,
                                Problem::NotApplicable,
                                format!("{owner}: orientation is a body's; name the body"),
                            ));
                        }
                        let (_, _, h, p) =
                            self.markers
                                .iter()
                                .find(|(n, ..)| n == mn.get_ref())
                                .ok_or_else(|| {
                                    cx.err(
                                        mn.span().start,
                                        Problem::UnknownReference,
                                        format!("{owner}: no marker '{}'", mn.get_ref()),
                                    )
                                })?;
                        SensorTarget::Body(*h, *p)
                    }
                    (Some(bn), Some(_)) => {
                        return Err(cx.err(
                            bn.span().start,
                            Problem::Inconsistent,
                            format!("{owner}: give either 'body' or 'marker', not both"),
                        ))
                    }
                    (None, None) => {
                        return Err(cx.err(
                            at,
                            Problem::Missing,
                            format!("{owner} has no 'body' or 'marker' (a sensor on nothing)"),
                        ))
                    }
                }
            }
            _ => {
                for (key, v) in [("body", &d.body), ("marker", &d.marker)] {
                    if let Some(v) = v {
                        return Err(cx.err(
                            v.span().start,
                            Problem::NotApplicable,
                            format!(
                                "{owner}: a {} sensor reads a joint, not a {key}",
                                kind_name.get_ref()
                            ),
                        ));
                    }
                }
                let jn = d.joint.as_ref().ok_or_else(|| {
                    cx.err(
                        at,
                        Problem::Missing,
                        format!("{owner} has no 'joint' (a sensor on nothing)"),
                    )
                })?;
                let (k, _) = self.coordinate_joint(cx, jn, &owner, "measure")?;
                SensorTarget::Joint(k)
            }
        };
        if motor_side {
            let side = d.side.as_ref().expect("motor_side comes from a side");
            match target {
                SensorTarget::Joint(k) if self.joints[k].transmission.is_some() => {}
                SensorTarget::Joint(k) => {
                    return Err(cx.err(
                        side.span().start,
                        Problem::NotApplicable,
                        format!(
                            "{owner}: joint '{}' has no [[transmission]], so it has no motor side; declare one (joint, compliance, rotor_inertia, damping) or use side = \"joint\"",
                            self.joints[k].name
                        ),
                    ))
                }
                SensorTarget::Body(..) => {
                    return Err(cx.err(
                        side.span().start,
                        Problem::NotApplicable,
                        format!("{owner}: only a joint sensor has a motor side"),
                    ))
                }
            }
        }
        self.sensors.push(Sensor {
            name: name.get_ref().clone(),
            kind,
            target,
            motor_side,
        });
        self.sensor_names.push(name.get_ref().clone());
        Ok(())
    }
}

/// A body's orientation (body axes in the base frame, as columns): a rotation by `angle`
/// about `axis`, or the body's x axis along `x` and its z axis along `z` made perpendicular
/// to x (y = z × x).
fn orientation(
    cx: &Ctx,
    owner: &str,
    at: usize,
    od: &super::schema::OrientationDoc,
) -> Result<Matrix3<f64>, ModelFileError> {
    let what = format!("{owner} orientation");
    if od.x.is_none() && od.z.is_none() {
        let axis = cx.direction(cx.need(&od.axis, "axis", &what, at)?, &format!("{what} axis"))?;
        let angle = cx.scalar(
            cx.need(&od.angle, "angle", &what, at)?,
            Dimension::Angle,
            &format!("{what} angle"),
        )?;
        return Ok(rotation(&from_axis_angle(&axis, angle)));
    }
    if let Some(v) = od.axis.as_ref().or(od.angle.as_ref()) {
        return Err(cx.err(
            v.span().start,
            Problem::Inconsistent,
            format!("{what}: give either 'axis' and 'angle' or 'x' and 'z', not both"),
        ));
    }
    let xv = cx.need(&od.x, "x", &what, at)?;
    let zv = cx.need(&od.z, "z", &what, at)?;
    // Unit x, then z less its component along x: the same arithmetic as lash's built-in
    // mechanisms, so equal vectors give equal orientations to the last bit.
    let x = cx.nonzero(xv, &format!("{what} x"))?.normalize();
    let z = cx.nonzero(zv, &format!("{what} z"))?;
    let z_perp = z - x * z.dot(&x);
    if z_perp.norm() <= 1e-6 * z.norm() {
        return Err(cx.err(
            zv.span().start,
            Problem::Inconsistent,
            format!("{what}: z is parallel to x, so it fixes no second axis"),
        ));
    }
    let z = z_perp.normalize();
    Ok(Matrix3::from_columns(&[x, z.cross(&x), z]))
}

/// A unit vector perpendicular to `a`.
fn perpendicular(a: &Vector3<f64>) -> Vector3<f64> {
    let helper = if a.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    (helper - a * helper.dot(a)).normalize()
}

#[cfg(test)]
mod tests {
    use crate::model_file::{ModelFile, ModelFileError, Problem};
    use crate::multibody::rotation::rotation;
    use nalgebra::Matrix3;

    fn body(orientation: &str) -> Result<Matrix3<f64>, ModelFileError> {
        let text =
            format!("[[body]]\nname = \"b\"\nmass = 1\ninertia = [1, 1, 1]\norientation = {orientation}\n");
        let built = ModelFile::from_text("o.toml", &text)?.build()?;
        let h = built.body("b").expect("body b");
        Ok(rotation(&built.mechanism.body(h).expect("body").orientation))
    }

    #[test]
    fn an_orientation_by_axes_is_the_rotation_with_those_columns() {
        // Body x along base y, body z along base x (given with a part along y): a rotation by
        // 120° about (1, 1, 1).
        let by_axes = body("{ x = [0, 2, 0], z = [1, 0.5, 0] }").unwrap();
        let by_angle = body("{ axis = [1, 1, 1], angle = \"120 deg\" }").unwrap();
        let want = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        assert!((by_axes - want).abs().max() < 1e-15, "{by_axes}");
        assert!((by_angle - want).abs().max() < 1e-15, "{by_angle}");
    }

    #[test]
    fn orientation_faults_are_located() {
        let fault = |o: &str| {
            let e = body(o).unwrap_err();
            (e.problem(), e.place().map(|(_, c)| c), e.to_string())
        };
        // Both forms at once: at the first key of the other form.
        let (p, c, m) = fault("{ axis = [0, 0, 1], x = [1, 0, 0], z = [0, 0, 1] }");
        assert_eq!((p, c), (Problem::Inconsistent, Some(24)), "{m}");
        assert!(m.contains("either 'axis' and 'angle' or 'x' and 'z'"), "{m}");
        // z along x fixes nothing.
        let (p, c, m) = fault("{ x = [1, 0, 0], z = [-2, 0, 0] }");
        assert_eq!((p, c), (Problem::Inconsistent, Some(36)), "{m}");
        assert!(m.contains("z is parallel to x"), "{m}");
        // x alone.
        let (p, _, m) = fault("{ x = [1, 0, 0] }");
        assert_eq!(p, Problem::Missing, "{m}");
        assert!(m.contains("body 'b' orientation has no 'z'"), "{m}");
        // A zero axis.
        let (p, c, m) = fault("{ x = [0, 0, 0], z = [0, 0, 1] }");
        assert_eq!((p, c), (Problem::ZeroVector, Some(21)), "{m}");
    }
}
