//! Rigid bodies in absolute coordinates: position of the centre of mass and Euler
//! parameters, body-frame angular velocity, constant body-frame mass matrix.

use super::error::ModelError;
use super::rotation;
use nalgebra::{Matrix3, Vector3, Vector4};

/// Handle of a body in a [`BodySet`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct BodyHandle(pub(crate) usize);

impl BodyHandle {
    /// Index of the body in its set (state vectors are laid out in this order).
    pub fn index(self) -> usize {
        self.0
    }
    /// The handle of the body at `index` in its set (for a body found by name).
    pub fn from_index(index: usize) -> Self {
        Self(index)
    }
}

/// Where a marker or joint side is attached: the fixed ground frame or a body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Attach {
    /// The ground (inertial frame).
    Ground,
    /// A moving body.
    Body(BodyHandle),
}

impl Attach {
    /// The body, if this is not the ground.
    pub fn body(self) -> Option<BodyHandle> {
        match self {
            Attach::Ground => None,
            Attach::Body(h) => Some(h),
        }
    }
}

impl From<BodyHandle> for Attach {
    fn from(h: BodyHandle) -> Self {
        Attach::Body(h)
    }
}

/// A rigid body. The body frame has its origin at the centre of mass.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidBody {
    /// Name, used in reports and errors.
    pub name: String,
    /// Mass, kg (> 0).
    pub mass: f64,
    /// Inertia tensor about the centre of mass in the body frame, kg·m² (symmetric positive
    /// definite).
    pub inertia: Matrix3<f64>,
    /// Initial (approximate) position of the centre of mass, m.
    pub position: Vector3<f64>,
    /// Initial (approximate) orientation as Euler parameters.
    pub orientation: Vector4<f64>,
    /// Initial velocity of the centre of mass, m/s.
    pub velocity: Vector3<f64>,
    /// Initial angular velocity in the body frame, rad/s.
    pub angular_velocity: Vector3<f64>,
}

impl RigidBody {
    /// A body at rest at the origin with identity orientation.
    pub fn new(name: impl Into<String>, mass: f64, inertia: Matrix3<f64>) -> Self {
        Self {
            name: name.into(),
            mass,
            inertia,
            position: Vector3::zeros(),
            orientation: Vector4::new(1.0, 0.0, 0.0, 0.0),
            velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
        }
    }

    /// Sets the initial position of the centre of mass, m.
    pub fn at(mut self, position: Vector3<f64>) -> Self {
        self.position = position;
        self
    }

    /// Sets the initial orientation from a rotation matrix (body → base).
    pub fn oriented(mut self, a: &Matrix3<f64>) -> Self {
        self.orientation = rotation::from_matrix(a);
        self
    }

    /// Sets the initial velocity, m/s.
    pub fn moving(mut self, v: Vector3<f64>) -> Self {
        self.velocity = v;
        self
    }

    /// Sets the initial body-frame angular velocity, rad/s.
    pub fn spinning(mut self, w: Vector3<f64>) -> Self {
        self.angular_velocity = w;
        self
    }

    /// Slender rod of length `l` (m) along the body x axis: I = m·l²/12 about y and z.
    pub fn rod(name: impl Into<String>, mass: f64, length: f64) -> Self {
        let i = mass * length * length / 12.0;
        // A tiny axial inertia keeps the mass matrix regular.
        Self::new(name, mass, Matrix3::from_diagonal(&Vector3::new(i * 1e-3, i, i)))
    }

    /// Solid box with edges (a, b, c) along body x, y, z, m.
    pub fn cuboid(name: impl Into<String>, mass: f64, a: f64, b: f64, c: f64) -> Self {
        let k = mass / 12.0;
        Self::new(
            name,
            mass,
            Matrix3::from_diagonal(&Vector3::new(
                k * (b * b + c * c),
                k * (a * a + c * c),
                k * (a * a + b * b),
            )),
        )
    }

    /// Checks mass and inertia, naming the body on failure.
    pub fn validate(&self) -> Result<(), ModelError> {
        if !(self.mass > 0.0 && self.mass.is_finite()) {
            return Err(ModelError::BadBody {
                body: self.name.clone(),
                reason: format!("mass must be positive, got {} kg", self.mass),
            });
        }
        let sym = (self.inertia - self.inertia.transpose()).norm();
        if !self.inertia.iter().all(|v| v.is_finite()) || sym > 1e-12 * self.inertia.norm() {
            return Err(ModelError::BadBody {
                body: self.name.clone(),
                reason: "inertia must be a finite symmetric matrix".into(),
            });
        }
        let eig = self.inertia.symmetric_eigenvalues();
        let min = eig.iter().copied().fold(f64::INFINITY, f64::min);
        if min <= 0.0 {
            return Err(ModelError::BadBody {
                body: self.name.clone(),
                reason: format!("inertia must be positive definite, smallest principal moment {min:e} kg·m²"),
            });
        }
        let p = &self.orientation;
        if !p.iter().all(|v| v.is_finite()) || p.norm() < 1e-12 {
            return Err(ModelError::BadBody {
                body: self.name.clone(),
                reason: "orientation must be a non-zero finite quaternion".into(),
            });
        }
        Ok(())
    }
}

/// A set of bodies addressed by handles.
#[derive(Debug, Clone, Default)]
pub struct BodySet {
    pub(crate) bodies: Vec<RigidBody>,
}

impl BodySet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }
    /// Adds a body and returns its handle.
    pub fn insert(&mut self, b: RigidBody) -> BodyHandle {
        self.bodies.push(b);
        BodyHandle(self.bodies.len() - 1)
    }
    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }
    /// True if there are no bodies.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }
    /// The body of a handle.
    pub fn get(&self, h: BodyHandle) -> Option<&RigidBody> {
        self.bodies.get(h.0)
    }
    /// Mutable access to the body of a handle.
    pub fn get_mut(&mut self, h: BodyHandle) -> Option<&mut RigidBody> {
        self.bodies.get_mut(h.0)
    }
    /// Iterates over (handle, body).
    pub fn iter(&self) -> impl Iterator<Item = (BodyHandle, &RigidBody)> {
        self.bodies.iter().enumerate().map(|(i, b)| (BodyHandle(i), b))
    }
}
