//! URDF import: a kinematic tree's links and joints as model-file tables.
//!
//! The URDF is read by the `urdf-rs` crate; this file turns it into the tables a model file
//! would hold, placed in the URDF's own text, so that every fault the builder finds (a link
//! without mass, an inertia that no rigid body has, a zero axis) names the URDF's file, line
//! and column.
//!
//! What is imported, in the URDF's zero configuration (every joint coordinate 0), which is the
//! model's build configuration:
//! - **links** → bodies: mass, centre of mass and inertia tensor (about the centre of mass, in
//!   the `<inertial>` frame, as URDF defines it) turned into the base frame. Links joined by
//!   `fixed` joints are one rigid body: their mass properties are summed into the moving link
//!   they hang from (parallel-axis theorem), and each becomes a marker of that body at its
//!   frame origin. The tree's root link (and every link fixed to it) is the ground.
//! - **joints** → `revolute` (from `revolute` and `continuous`) and `prismatic` joints at the
//!   child link's frame origin, along `<axis>` (default x) turned into the base frame; the
//!   positive sense is URDF's. `<limit lower upper>` of revolute and prismatic joints are kept
//!   as the joint's limits (reported by `lash check`, not enforced). `<dynamics damping
//!   friction>` that are not zero become a `friction` force on the joint.
//! - `floating` and `planar` joints are refused (lash models mechanisms, not free bases).
//!
//! A URDF read by itself gets, for each moving joint, the sensors `<joint>_position`,
//! `<joint>_velocity` and `<joint>_effort`.
//!
//! A side TOML references the URDF with `urdf = "robot.urdf"` and adds what URDF cannot say:
//! sensors, clearance, parameters, drivers, forces. A `[[body]]` in the side TOML named like
//! a link replaces that link's mass properties (for URDFs whose inertias need correcting).

use super::error::{ModelFileError, Problem, Source};
use super::read::Parsed;
use super::schema::{BodyDoc, FileDoc, ForceDoc, JointDoc, MarkerDoc, ModelDoc, Name, SensorDoc, Val};
use nalgebra::{Matrix3, Rotation3, Vector3};
use std::collections::HashMap;
use std::path::Path;
use toml::{Spanned, Value};

/// A rigid transform: rotation (base ← frame) and origin.
#[derive(Debug, Clone, Copy)]
struct Frame {
    r: Matrix3<f64>,
    p: Vector3<f64>,
}

impl Frame {
    fn identity() -> Self {
        Self {
            r: Matrix3::identity(),
            p: Vector3::zeros(),
        }
    }

    /// URDF `<origin xyz rpy>`: rotation Rz(yaw)·Ry(pitch)·Rx(roll), then the offset.
    fn of(pose: &urdf_rs::Pose) -> Self {
        let rpy = pose.rpy.0;
        Self {
            r: Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]).into_inner(),
            p: Vector3::from(pose.xyz.0),
        }
    }

    fn then(&self, local: &Frame) -> Frame {
        Frame {
            r: self.r * local.r,
            p: self.p + self.r * local.p,
        }
    }
}

/// The value of attribute `key` in a start tag's attribute text: `key="v"` or `key='v'`,
/// with any white space around the `=` (as XML allows).
fn attribute<'t>(attrs: &'t str, key: &str) -> Option<&'t str> {
    let mut from = 0;
    while let Some(k) = attrs[from..].find(key) {
        let at = from + k;
        from = at + key.len();
        if !attrs[..at].is_empty() && !attrs[..at].ends_with(char::is_whitespace) {
            continue;
        }
        let Some(rest) = attrs[from..].trim_start().strip_prefix('=') else {
            continue;
        };
        let rest = rest.trim_start();
        let quote = rest.chars().next().filter(|&q| q == '"' || q == '\'')?;
        let body = &rest[1..];
        return body.find(quote).map(|end| &body[..end]);
    }
    None
}

/// Where elements start in the URDF text (for messages).
struct Places<'a> {
    text: &'a str,
}

impl Places<'_> {
    /// Byte offset of the start tag `<tag … name="name" …>` (the first that also has the
    /// attribute `required`, if given), or 0.
    fn element(&self, tag: &str, name: &str, required: Option<&str>) -> usize {
        self.nth_element(tag, name, required, 0).unwrap_or(0)
    }

    /// Byte offset of the `n`-th (from 0) start tag `<tag … name="name" …>` that also has the
    /// attribute `required`, if given.
    fn nth_element(&self, tag: &str, name: &str, required: Option<&str>, n: usize) -> Option<usize> {
        let open = format!("<{tag}");
        let mut from = 0;
        let mut seen = 0;
        while let Some(k) = self.text[from..].find(&open) {
            let at = from + k;
            let rest = &self.text[at + open.len()..];
            from = at + open.len();
            if !rest.starts_with(|c: char| c.is_whitespace() || c == '>' || c == '/') {
                continue;
            }
            let end = rest.find('>').unwrap_or(rest.len());
            let attrs = &rest[..end];
            let named = attribute(attrs, "name") == Some(name);
            if named && required.is_none_or(|r| attribute(attrs, r).is_some()) {
                if seen == n {
                    return Some(at);
                }
                seen += 1;
            }
        }
        None
    }

    /// Byte offset of the first `<tag` inside the element starting at `start` (before its
    /// closing `</parent>`), or `start`.
    fn child(&self, start: usize, parent: &str, tag: &str) -> usize {
        let body = &self.text[start..];
        let end = body.find(&format!("</{parent}>")).unwrap_or(body.len());
        body[..end]
            .find(&format!("<{tag}"))
            .map(|k| start + k)
            .unwrap_or(start)
    }
}

fn spanned<T>(at: usize, v: T) -> Spanned<T> {
    Spanned::new(at..at + 1, v)
}

fn name(at: usize, s: &str) -> Name {
    spanned(at, s.to_string())
}

fn num(at: usize, x: f64) -> Val {
    spanned(at, Value::Float(x))
}

fn nums(at: usize, xs: &[f64]) -> Val {
    spanned(at, Value::Array(xs.iter().map(|x| Value::Float(*x)).collect()))
}

/// Deepest element nesting a URDF may have (a robot's links and joints nest a few levels;
/// the reader recurses once per level).
pub const MAX_NESTING: usize = 64;

/// Byte offset of the first start tag nested deeper than `limit` elements, if any (comments,
/// declarations and processing instructions do not nest; `<x/>` closes itself).
fn too_deep(text: &str, limit: usize) -> Option<usize> {
    let mut depth = 0usize;
    let mut from = 0;
    while let Some(k) = text[from..].find('<') {
        let at = from + k;
        let rest = &text[at + 1..];
        let end = rest.find('>').map_or(text.len(), |e| at + 1 + e);
        from = (at + 1).max(end);
        if rest.starts_with('/') {
            depth = depth.saturating_sub(1);
        } else if !(rest.starts_with('!') || rest.starts_with('?') || text[..end].ends_with('/')) {
            depth += 1;
            if depth > limit {
                return Some(at);
            }
        }
    }
    None
}

/// Reads a URDF file into model-file tables located in its text.
///
/// `alone`: the URDF is the model by itself (no side TOML), so each moving joint gets the
/// sensors a recording of it would have: `<joint>_position`, `<joint>_velocity` and
/// `<joint>_effort` (joint position, velocity and actuator effort).
pub(crate) fn import(path: &Path, text: String, alone: bool) -> Result<Parsed, ModelFileError> {
    let src = Source::new(path, text);
    // The URDF reader recurses once per nested element: refuse absurd nesting before it
    // overflows the stack.
    if let Some(at) = too_deep(&src.text, MAX_NESTING) {
        return Err(src.error(
            at,
            Problem::Syntax,
            format!("elements nested more than {MAX_NESTING} deep (a URDF nests a few levels)"),
        ));
    }
    let robot = urdf_rs::read_from_string(&src.text).map_err(|e| ModelFileError::File {
        file: src.file.clone(),
        problem: Problem::Syntax,
        message: format!("not a URDF that can be read: {e}"),
    })?;
    let mut doc = tables(&src, &robot)?;
    if alone {
        let joints: Vec<(String, usize)> = doc
            .joint
            .iter()
            .filter_map(|j| {
                j.get_ref()
                    .name
                    .as_ref()
                    .map(|n| (n.get_ref().clone(), j.span().start))
            })
            .collect();
        for (j, at) in joints {
            for (suffix, kind) in [
                ("position", "joint_position"),
                ("velocity", "joint_velocity"),
                ("effort", "joint_effort"),
            ] {
                doc.sensor.push(spanned(
                    at,
                    SensorDoc {
                        name: Some(name(at, &format!("{j}_{suffix}"))),
                        kind: Some(name(at, kind)),
                        joint: Some(name(at, &j)),
                        ..SensorDoc::default()
                    },
                ));
            }
        }
    }
    Ok(Parsed {
        dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
        src,
        doc,
        urdf: true,
    })
}

/// Mass properties summed in the base frame.
#[derive(Debug, Clone, Copy)]
struct Mass {
    m: f64,
    /// First moment Σ m c, kg m.
    first: Vector3<f64>,
    /// Σ (R I Rᵀ + m(|c|² E − c cᵀ)): inertia about the base origin, base axes, kg m².
    about_origin: Matrix3<f64>,
}

impl Mass {
    fn zero() -> Self {
        Self {
            m: 0.0,
            first: Vector3::zeros(),
            about_origin: Matrix3::zeros(),
        }
    }

    fn add(&mut self, m: f64, c: Vector3<f64>, inertia_base: Matrix3<f64>) {
        self.m += m;
        self.first += m * c;
        self.about_origin += inertia_base + m * (Matrix3::identity() * c.norm_squared() - c * c.transpose());
    }

    /// Centre of mass and inertia about it (base axes).
    fn about_centre(&self) -> (Vector3<f64>, Matrix3<f64>) {
        if self.m <= 0.0 {
            return (Vector3::zeros(), self.about_origin);
        }
        let c = self.first / self.m;
        let shift = self.m * (Matrix3::identity() * c.norm_squared() - c * c.transpose());
        (c, self.about_origin - shift)
    }
}

fn tables(src: &Source, robot: &urdf_rs::Robot) -> Result<FileDoc, ModelFileError> {
    let places = Places { text: &src.text };
    let link_at: HashMap<&str, usize> = robot
        .links
        .iter()
        .map(|l| (l.name.as_str(), places.element("link", &l.name, None)))
        .collect();
    let joint_at = |j: &urdf_rs::Joint| places.element("joint", &j.name, Some("type"));
    // Names: unique links and joints.
    for (k, l) in robot.links.iter().enumerate() {
        if robot.links[..k].iter().any(|o| o.name == l.name) {
            // The second `<link>` of that name.
            let at = places.nth_element("link", &l.name, None, 1).unwrap_or(0);
            return Err(src.error(at, Problem::Duplicate, format!("duplicate link '{}'", l.name)));
        }
    }
    for (k, j) in robot.joints.iter().enumerate() {
        if robot.joints[..k].iter().any(|o| o.name == j.name) {
            return Err(src.error(
                joint_at(j),
                Problem::Duplicate,
                format!("duplicate joint '{}'", j.name),
            ));
        }
    }
    // The tree: each link the child of at most one joint; one root.
    let mut parent_joint: HashMap<&str, usize> = HashMap::new();
    for (k, j) in robot.joints.iter().enumerate() {
        let child = j.child.link.as_str();
        if !link_at.contains_key(child) {
            return Err(src.error(
                joint_at(j),
                Problem::UnknownReference,
                format!("joint '{}': child link '{child}' is not declared", j.name),
            ));
        }
        if let Some(&other) = parent_joint.get(child) {
            return Err(src.error(
                joint_at(j),
                Problem::Model,
                format!(
                    "joint '{}': link '{child}' is already the child of joint '{}' (URDF describes a tree)",
                    j.name, robot.joints[other].name
                ),
            ));
        }
        parent_joint.insert(child, k);
    }
    let mut roots: Vec<&str> = robot
        .links
        .iter()
        .map(|l| l.name.as_str())
        .filter(|l| !parent_joint.contains_key(l))
        .collect();
    for j in &robot.joints {
        let p = j.parent.link.as_str();
        if !link_at.contains_key(p) && !roots.contains(&p) {
            roots.push(p);
        }
    }
    if roots.len() != 1 {
        return Err(ModelFileError::File {
            file: src.file.clone(),
            problem: Problem::Model,
            message: if roots.is_empty() {
                "the URDF has no root link (its joints form a loop)".into()
            } else {
                format!(
                    "the URDF has {} root links ({}); lash takes one tree whose root is the ground",
                    roots.len(),
                    roots.join(", ")
                )
            },
        });
    }
    let root = roots[0];
    // Frames at zero configuration, and the moving body each link belongs to, root first.
    let mut frame: HashMap<&str, Frame> = HashMap::new();
    let mut body_of: HashMap<&str, Option<&str>> = HashMap::new();
    frame.insert(root, Frame::identity());
    body_of.insert(root, None);
    let mut order: Vec<&str> = vec![root];
    let mut k = 0;
    while k < order.len() {
        let parent = order[k];
        for j in robot.joints.iter().filter(|j| j.parent.link == parent) {
            let child = j.child.link.as_str();
            frame.insert(child, frame[parent].then(&Frame::of(&j.origin)));
            let body = match j.joint_type {
                urdf_rs::JointType::Fixed => body_of[parent],
                _ => Some(child),
            };
            body_of.insert(child, body);
            order.push(child);
        }
        k += 1;
    }
    if let Some(l) = robot.links.iter().find(|l| !frame.contains_key(l.name.as_str())) {
        return Err(src.error(
            link_at[l.name.as_str()],
            Problem::Model,
            format!(
                "link '{}' is not connected to the root '{root}' (the joints form a loop)",
                l.name
            ),
        ));
    }
    let link = |n: &str| robot.links.iter().find(|l| l.name == n);
    // Bodies: the moving links with everything fixed to them.
    let mut doc = FileDoc {
        model: Some(spanned(
            0,
            ModelDoc {
                name: Some(name(0, &robot.name)),
                ..ModelDoc::default()
            },
        )),
        ..FileDoc::default()
    };
    for &b in order.iter().filter(|&&l| body_of[l] == Some(l)) {
        let mut mass = Mass::zero();
        for &l in order.iter().filter(|&&l| body_of[l] == Some(b)) {
            let Some(ld) = link(l) else { continue };
            let i = &ld.inertial;
            let f = frame[l].then(&Frame::of(&i.origin));
            let t = &i.inertia;
            let local = Matrix3::new(
                t.ixx, t.ixy, t.ixz, //
                t.ixy, t.iyy, t.iyz, //
                t.ixz, t.iyz, t.izz,
            );
            let values = [i.mass.value, t.ixx, t.iyy, t.izz, t.ixy, t.ixz, t.iyz];
            if values.iter().any(|x| !x.is_finite()) {
                let at = places.child(link_at[l], "link", "inertial");
                return Err(src.error(
                    at,
                    Problem::WrongType,
                    format!("link '{l}': a mass or inertia value is not a finite number"),
                ));
            }
            if i.mass.value < 0.0 {
                let at = places.child(link_at[l], "link", "mass");
                return Err(src.error(
                    at,
                    Problem::NotPositive,
                    format!("link '{l}' mass must not be negative, not {} kg", i.mass.value),
                ));
            }
            mass.add(i.mass.value, f.p, f.r * local * f.r.transpose());
        }
        let (c, inertia) = mass.about_centre();
        let at = link_at[b];
        let mass_at = places.child(at, "link", "mass");
        let inertia_at = places.child(at, "link", "inertia");
        doc.body.push(spanned(
            at,
            BodyDoc {
                name: Some(name(at, b)),
                mass: Some(num(mass_at, mass.m)),
                inertia: Some(nums(
                    inertia_at,
                    &[
                        inertia[(0, 0)],
                        inertia[(1, 1)],
                        inertia[(2, 2)],
                        inertia[(0, 1)],
                        inertia[(0, 2)],
                        inertia[(1, 2)],
                    ],
                )),
                position: Some(nums(places.child(at, "link", "inertial"), c.as_slice())),
                ..BodyDoc::default()
            },
        ));
        for &l in order.iter().filter(|&&l| l != b && body_of[l] == Some(b)) {
            let at = link_at.get(l).copied().unwrap_or(0);
            doc.marker.push(spanned(
                at,
                MarkerDoc {
                    name: Some(name(at, l)),
                    body: Some(name(at, b)),
                    point: Some(nums(at, frame[l].p.as_slice())),
                },
            ));
        }
    }
    // Joints between moving bodies (or a moving body and the ground).
    for j in &robot.joints {
        let at = joint_at(j);
        let kind = match j.joint_type {
            urdf_rs::JointType::Fixed => continue,
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => "revolute",
            urdf_rs::JointType::Prismatic => "prismatic",
            ref other => {
                return Err(src.error(
                    at,
                    Problem::NotApplicable,
                    format!(
                        "joint '{}': URDF joint type {other:?} is not imported (lash imports revolute, continuous, prismatic and fixed joints)",
                        j.name
                    ),
                ))
            }
        };
        if j.mimic.is_some() {
            return Err(src.error(
                at,
                Problem::NotApplicable,
                format!(
                    "joint '{}': mimic joints (one joint coupled to another) are not imported",
                    j.name
                ),
            ));
        }
        let child = j.child.link.as_str();
        let side = |l: &str| body_of.get(l).copied().flatten().unwrap_or("ground");
        let f = frame[child];
        let axis = f.r * Vector3::from(j.axis.xyz.0);
        let axis_at = places.child(at, "joint", "axis");
        let limits = match j.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Prismatic if j.limit.lower < j.limit.upper => {
                Some(nums(
                    places.child(at, "joint", "limit"),
                    &[j.limit.lower, j.limit.upper],
                ))
            }
            _ => None,
        };
        doc.joint.push(spanned(
            at,
            JointDoc {
                name: Some(name(at, &j.name)),
                kind: Some(name(at, kind)),
                i: Some(name(at, side(j.parent.link.as_str()))),
                j: Some(name(at, side(child))),
                point: Some(nums(at, f.p.as_slice())),
                axis: Some(nums(axis_at, axis.as_slice())),
                limits,
                ..JointDoc::default()
            },
        ));
        if let Some(d) = &j.dynamics {
            if d.damping != 0.0 || d.friction != 0.0 {
                let dat = places.child(at, "joint", "dynamics");
                doc.force.push(spanned(
                    dat,
                    ForceDoc {
                        name: Some(name(dat, &format!("{} dynamics", j.name))),
                        kind: Some(name(dat, "friction")),
                        joint: Some(name(dat, &j.name)),
                        coulomb: Some(num(dat, d.friction)),
                        viscous: Some(num(dat, d.damping)),
                        ..ForceDoc::default()
                    },
                ));
            }
        }
    }
    Ok(doc)
}
