//! Sensors declared in a model file: what a recording column measures, and its value at a
//! simulated sample.

use super::build::{BuiltModel, JointInfo};
use crate::multibody::{Attach, BodyHandle, JointKind, Sample};
use nalgebra::{Matrix3, Vector3};

/// What a sensor measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorKind {
    /// A joint's coordinate (rad or m), from the file's configuration plus its `coordinate`.
    JointPosition,
    /// Its rate (rad/s or m/s).
    JointVelocity,
    /// Its second derivative (rad/s² or m/s²).
    JointAcceleration,
    /// The effort along it (N m or N): the driver's effort if driven, else the commanded
    /// efforts of its `effort` forces.
    JointEffort,
    /// A body point's position (base frame, m): the centre of mass or a marker.
    BodyPosition,
    /// A body's orientation as Euler parameters (e0, e1, e2, e3).
    BodyOrientation,
}

/// What a sensor is on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SensorTarget {
    /// A joint (index into [`BuiltModel::joints`]).
    Joint(usize),
    /// A body and a point on it (body frame, m).
    Body(BodyHandle, Vector3<f64>),
}

/// A declared sensor.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Name (the recording column, or its prefix for vectors).
    pub name: String,
    /// What it measures.
    pub kind: SensorKind,
    /// What it is on.
    pub target: SensorTarget,
    /// A joint sensor on the motor side of the joint's transmission (`side = "motor"`): it
    /// reads the rotor's coordinate (an effort sensor reads the motor's effort either way).
    pub motor_side: bool,
}

/// Kinematics of one side at a sample: position, rotation, velocity, angular velocity and
/// their rates (base frame).
struct Side {
    r: Vector3<f64>,
    a: Matrix3<f64>,
    v: Vector3<f64>,
    omega: Vector3<f64>,
    acc: Vector3<f64>,
    alpha: Vector3<f64>,
}

impl Side {
    fn ground() -> Self {
        Self {
            r: Vector3::zeros(),
            a: Matrix3::identity(),
            v: Vector3::zeros(),
            omega: Vector3::zeros(),
            acc: Vector3::zeros(),
            alpha: Vector3::zeros(),
        }
    }
    fn point(&self, s: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let rho = self.a * s;
        let w = self.omega;
        (
            self.r + rho,
            self.v + w.cross(&rho),
            self.acc + self.alpha.cross(&rho) + w.cross(&w.cross(&rho)),
        )
    }
}

impl BuiltModel {
    /// The column names and units of every sensor, in order (vectors get `_x`, `_y`, `_z`,
    /// Euler parameters `_e0` … `_e3`).
    pub fn sensor_columns(&self) -> Vec<(String, &'static str)> {
        let mut out = vec![];
        for s in &self.sensors {
            let rot = match s.target {
                SensorTarget::Joint(k) => self.joints[k].kind != JointKind::Prismatic,
                SensorTarget::Body(..) => false,
            };
            let unit = match (s.kind, rot) {
                (SensorKind::JointPosition, true) => "rad",
                (SensorKind::JointPosition, false) => "m",
                (SensorKind::JointVelocity, true) => "rad/s",
                (SensorKind::JointVelocity, false) => "m/s",
                (SensorKind::JointAcceleration, true) => "rad/s^2",
                (SensorKind::JointAcceleration, false) => "m/s^2",
                (SensorKind::JointEffort, true) => "N m",
                (SensorKind::JointEffort, false) => "N",
                (SensorKind::BodyPosition, _) => "m",
                (SensorKind::BodyOrientation, _) => "1",
            };
            match s.kind {
                SensorKind::BodyPosition => {
                    for c in ["x", "y", "z"] {
                        out.push((format!("{}_{c}", s.name), unit));
                    }
                }
                SensorKind::BodyOrientation => {
                    for c in ["e0", "e1", "e2", "e3"] {
                        out.push((format!("{}_{c}", s.name), unit));
                    }
                }
                _ => out.push((s.name.clone(), unit)),
            }
        }
        out
    }

    /// True if a sensor needs accelerations (pass `wdot` to [`read_sensors`](Self::read_sensors)).
    pub fn needs_accelerations(&self) -> bool {
        self.sensors
            .iter()
            .any(|s| s.kind == SensorKind::JointAcceleration)
    }

    fn side(&self, a: Attach, s: &Sample, wdot: Option<&[f64]>) -> Side {
        let Attach::Body(h) = a else {
            return Side::ground();
        };
        let lay = self.mechanism.layout();
        let rot = s.body_rotation(h);
        let omega = rot * s.body_angular_velocity(h);
        let (acc, alpha) = match wdot {
            Some(wd) => {
                let r = &wd[lay.body_w(h)];
                (
                    Vector3::new(r[0], r[1], r[2]),
                    rot * Vector3::new(r[3], r[4], r[5]),
                )
            }
            None => (Vector3::zeros(), Vector3::zeros()),
        };
        Side {
            r: s.body_position(h),
            a: rot,
            v: s.body_velocity(h),
            omega,
            acc,
            alpha,
        }
    }

    /// (coordinate, rate, second derivative) of a joint at a sample (the last is 0 without
    /// `wdot`). Rotations are in (−π, π] around the file's coordinate; unwrap series.
    pub fn joint_coordinate(&self, joint: &JointInfo, s: &Sample, wdot: Option<&[f64]>) -> [f64; 3] {
        let (si, sj) = (self.side(joint.i, s, wdot), self.side(joint.j, s, wdot));
        let z = si.a * joint.frame_i.axes.column(2);
        if joint.kind == JointKind::Prismatic {
            let (pi, vi, ai) = si.point(&joint.frame_i.origin);
            let (pj, vj, aj) = sj.point(&joint.frame_j.origin);
            let (d, dd, ddd) = (pj - pi, vj - vi, aj - ai);
            let zd = si.omega.cross(&z);
            let zdd = si.alpha.cross(&z) + si.omega.cross(&zd);
            [
                joint.coordinate0 + z.dot(&d),
                zd.dot(&d) + z.dot(&dd),
                zdd.dot(&d) + 2.0 * zd.dot(&dd) + z.dot(&ddd),
            ]
        } else {
            let xi = si.a * joint.frame_i.axes.column(0);
            let xj = sj.a * joint.frame_j.axes.column(0);
            let theta = z.dot(&xi.cross(&xj)).atan2(xi.dot(&xj));
            [
                joint.coordinate0 + theta,
                z.dot(&(sj.omega - si.omega)),
                z.dot(&(sj.alpha - si.alpha)),
            ]
        }
    }

    /// Every sensor's value at sample `s`, in [`sensor_columns`](Self::sensor_columns) order.
    /// `wdot` (the accelerations of the sample, see [`crate::multibody::Analysis::accelerations`])
    /// is needed for acceleration sensors; without it they read 0.
    pub fn read_sensors(&self, s: &Sample, wdot: Option<&[f64]>) -> Vec<f64> {
        let mut out = vec![];
        for sensor in &self.sensors {
            match (sensor.kind, sensor.target) {
                (SensorKind::BodyPosition, SensorTarget::Body(h, p)) => {
                    let x = s.body_position(h) + s.body_rotation(h) * p;
                    out.extend(x.iter());
                }
                (SensorKind::BodyOrientation, SensorTarget::Body(h, _)) => {
                    out.extend(s.body_euler_parameters(h).iter());
                }
                (kind, SensorTarget::Joint(k)) => {
                    let effort = kind == SensorKind::JointEffort;
                    let joint = match (&self.joints[k].transmission, sensor.motor_side && !effort) {
                        (Some(t), true) => match t.motor.as_deref() {
                            Some(m) => m,
                            None => {
                                // Not built (a measured joint): nothing to read.
                                out.push(f64::NAN);
                                continue;
                            }
                        },
                        _ => &self.joints[k],
                    };
                    let v = match kind {
                        SensorKind::JointEffort => match joint.driver {
                            Some(d) => s.driver_effort(&self.mechanism, d).unwrap_or(f64::NAN),
                            None => joint.efforts.iter().map(|f| f(s.t)).sum(),
                        },
                        SensorKind::JointPosition => self.joint_coordinate(joint, s, None)[0],
                        SensorKind::JointVelocity => self.joint_coordinate(joint, s, None)[1],
                        _ => self.joint_coordinate(joint, s, wdot)[2],
                    };
                    out.push(v);
                }
                // The builder pairs body kinds with body targets and joint kinds with joints.
                _ => out.push(f64::NAN),
            }
        }
        out
    }
}
