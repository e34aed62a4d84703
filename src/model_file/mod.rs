//! Mechanisms from model files (TOML): bodies, joints (ideal or with clearance), drivers,
//! forces, sensors and named parameters, so a mechanism needs no Rust.
//!
//! | file | concern |
//! |---|---|
//! | `schema.rs` | the tables as serde reads them (every value with its place) |
//! | `read.rs` | files and includes, values with units, parameters |
//! | `units.rs` | quantities: SI numbers, or strings with a unit (`"30 deg"`, `"5 mm"`) |
//! | `series.rs` | sampled series (CSV) for drivers and efforts |
//! | `build.rs` | tables → [`Mechanism`](crate::multibody::Mechanism), every fault located |
//! | `sensors.rs` | what each recording column measures, read at a simulated sample |
//! | `simulate.rs` | a simulation's sensor series, CSV and charts (`lash simulate`) |
//! | `urdf.rs` | URDF import: links and joints as tables placed in the URDF's text |
//! | `error.rs` | [`ModelFileError`]: file, line, column, [`Problem`] and message |
//!
//! # The format
//!
//! Every quantity is SI. A number is taken as SI; a string is a number with a unit whose
//! dimension must fit the field (`"30 deg"`, `"5 mm"`, `"12 N"`), or the name of a declared
//! `[[parameter]]`. Positions and axes are in the base frame, in the configuration the file
//! describes (the *build configuration*); the joints must (nearly) hold there — assembly
//! corrects small errors and names the joints it cannot satisfy.
//!
//! ```toml
//! include = ["common.toml"]             # optional: tables of other files, read first
//!
//! [model]
//! name = "slider-crank"
//! gravity = [0, -9.81, 0]                # m/s^2 (default [0, 0, -9.81])
//!
//! [[parameter]]                          # a value the diagnosis may perturb
//! name = "m_rod"
//! nominal = 0.2                          # SI, in `unit`
//! unit = "kg"                            # an SI unit: kg, m, rad, s, N, N m, N/m, N s/m, …
//! bounds = [0.1, 0.4]                    # optional
//!
//! [[body]]
//! name = "crank"
//! mass = 0.5                             # kg (> 0), or a parameter's name
//! inertia = [1e-4, 1e-3, 1e-3]           # kg m^2 about the centre of mass, body axes:
//!                                        # [Ixx, Iyy, Izz] or [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]
//! position = ["50 mm", 0, 0]             # centre of mass, m
//! orientation = { axis = [0, 0, 1], angle = "0 deg" }   # optional (body axes = base axes);
//!                                        # or { x = [...], z = [...] }: body x along x, body z
//!                                        # along z less its part along x (y = z × x)
//! velocity = [0, 0, 0]                   # optional, m/s
//! angular_velocity = [0, 0, 0]           # optional, rad/s, base frame
//!
//! [[marker]]                             # a named point on a body
//! name = "pin"
//! body = "crank"
//! point = [0.1, 0, 0]                    # m
//!
//! [[joint]]
//! name = "A"
//! type = "revolute"                      # revolute, prismatic, universal, spherical,
//!                                        # cylindrical, fixed
//! i = "ground"                           # side i: a body or "ground"
//! j = "crank"
//! point = [0, 0, 0]                      # m
//! axis = [0, 0, 1]                       # revolute, prismatic, cylindrical
//! # axis_i = [...], axis_j = [...]       # universal: one fixed in each side, perpendicular
//! coordinate = "0 deg"                   # the joint's coordinate in this configuration
//! # limits = ["-90 deg", "90 deg"]       # optional: reported by `lash check`, not enforced
//! # clearance = { radial = "10 um", axial = "5 um", ball_radius = "4 mm",
//! #               ball_spacing = "24 mm", damping = 300 }    # universal, revolute, spherical
//!
//! [[driver]]                             # prescribes a revolute/cylindrical angle or a
//! name = "motor"                         # prismatic translation
//! joint = "A"
//! law = "polynomial"                     # constant (value), polynomial (coefficients, SI),
//! coefficients = [0, 6.283]              # rest_to_rest (t0, t1, from, to, profile),
//!                                        # sampled (file, column, time_column = "t", unit)
//!
//! [[force]]
//! name = "bearing friction"
//! type = "friction"                      # spring_damper (i, j, point_i, point_j, stiffness,
//! joint = "A"                            #   damping, free_length), rotational_spring_damper
//! coulomb = "0.02 N m"                   #   (joint, stiffness, damping, free_angle),
//! viscous = 1e-3                         #   friction (joint, coulomb, viscous,
//! velocity_scale = "0.01 rad/s"          #   viscous_backward, velocity_scale,
//! smoothing = "tanh"                     #   smoothing = tanh | algebraic: v/√(v²+v_s²)),
//!                                        #   effort (joint, value | file + column),
//!                                        #   point_force (body, point, force)
//!
//! [[transmission]]                     # optional: a compliant drive between a motor and a
//! joint = "A"                            # revolute or prismatic joint; built as a rotor on
//! compliance = "5e-4 rad/(N m)"          # a joint of the same kind beside it, coupled to the
//! rotor_inertia = "2e-3 kg m^2"          # joint's side j by a spring (1/compliance) and a
//! damping = "3.5 N m s/rad"              # damper; the joint's driver and efforts turn the
//! # rotor_mass = "1 g"                   # rotor. Values reflected to the joint; prismatic:
//!                                        # m/N, kg (its mass), N s/m
//!
//! [[sensor]]
//! name = "q"                             # the recording column (vectors: q_x, q_y, q_z)
//! type = "joint_position"                # joint_position, joint_velocity,
//! joint = "A"                            # joint_acceleration, joint_effort (joint: the
//!                                        # actuator's effort, 0 on a passive joint; behind a
//!                                        # transmission the motor's);
//!                                        # body_position (body or marker), body_orientation
//! # side = "motor"                       # joint sensors behind a [[transmission]]: read the
//!                                        # rotor (an encoder on the motor); default "joint"
//!
//! [[candidate]]                          # optional: an effect of your own for the diagnosis:
//! name = "direction-dependent damping"   # force elements in the file whose parameters
//! parameters = ["b_fwd", "b_bwd"]        # (nominal 0 here) it fits together; they get no
//!                                        # "error in" candidates of their own
//!
//! [recordings]                           # optional: recordings of this machine, the
//! fit = ["run1.csv", "run2.csv"]         # defaults of `lash diagnose --model FILE`
//! holdout = ["run3.csv"]                 # (paths relative to this file)
//! ```
//!
//! # URDF
//!
//! A URDF file is a model by itself (`lash check robot.urdf`), or the base of a side TOML
//! that names it with `urdf = "robot.urdf"` (beside `include`) and adds sensors, parameters,
//! clearance, drivers and forces; a `[[body]]` named like a link replaces that link's mass
//! properties. What is imported and how: `urdf.rs`; `models/dfki_pendulum.toml` is an
//! example.
//!
//! A fault names file, line and column and its kind ([`Problem`]); nothing in a file can make
//! lash panic.
//!
//! ```
//! use lash::model_file::ModelFile;
//! let text = r#"
//! [[body]]
//! name = "bob"
//! mass = 1.0
//! inertia = [1e-3, 1e-3, 1e-3]
//! position = [0, 0, -0.5]
//! [[joint]]
//! name = "pivot"
//! type = "revolute"
//! i = "ground"
//! j = "bob"
//! point = [0, 0, 0]
//! axis = [0, 1, 0]
//! [[sensor]]
//! name = "angle"
//! type = "joint_position"
//! joint = "pivot"
//! "#;
//! let file = ModelFile::from_text("pendulum.toml", text).unwrap();
//! let check = file.check().unwrap();
//! assert_eq!(check.dof, 1);
//!
//! let bad = text.replace("mass = 1.0", "mass = -1.0");
//! let e = ModelFile::from_text("pendulum.toml", &bad).and_then(|f| f.build()).unwrap_err();
//! assert_eq!(e.to_string(), "pendulum.toml:4:8: body 'bob' mass must be positive, not -1 kg");
//! # Ok::<(), lash::model_file::ModelFileError>(())
//! ```

mod build;
mod error;
mod read;
mod schema;
mod sensors;
mod series;
mod simulate;
pub mod units;
mod urdf;

pub use build::{BuildOptions, BuiltModel, EffortLaw, JointInfo, Transmission, DEFAULT_ROTOR_MASS};
pub use error::{ModelFileError, Problem};
pub use read::{FileCandidate, Parameter};
pub use sensors::{Sensor, SensorKind, SensorTarget};
pub use simulate::{simulate, SensorRecord};

use crate::multibody::{Analysis, MechanismData, ModelError};
use error::Source;
use read::Parsed;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// A model file read with its includes: parsed, parameters read, ready to build.
#[derive(Debug)]
pub struct ModelFile {
    /// The file.
    pub path: PathBuf,
    /// `[model] name` (else the file's stem).
    pub name: String,
    /// `[model] description`.
    pub description: String,
    /// Declared parameters, in file order.
    pub parameters: Vec<Parameter>,
    /// `[[candidate]]`s: effects of the file's own the diagnosis may fit, each perturbing
    /// some of the declared parameters together.
    pub candidates: Vec<FileCandidate>,
    /// `[recordings] fit`: recordings of this machine a diagnosis fits on by default (paths
    /// resolved against the file that names them).
    pub fit_recordings: Vec<PathBuf>,
    /// `[recordings] holdout`: recordings a diagnosis holds out by default.
    pub holdout_recordings: Vec<PathBuf>,
    files: Vec<Parsed>,
}

/// What `lash check` reports of a model.
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    /// Model name.
    pub name: String,
    /// The file.
    pub file: String,
    /// Whether joints that declare a clearance were built as bearings (contact, a cross
    /// body per universal joint) rather than as ideal joints.
    pub clearance: bool,
    /// Degrees of freedom (6 per body minus the joints' constraints; drivers not counted).
    pub dof: isize,
    /// Degrees of freedom left once the drivers act.
    pub dof_driven: isize,
    /// Bodies: name, mass (kg); the file's, then those a clearance build adds (crosses).
    pub bodies: Vec<CheckBody>,
    /// Joints.
    pub joints: Vec<CheckJoint>,
    /// Drivers: name and joint.
    pub drivers: Vec<CheckDriver>,
    /// Force elements: name and type; the file's, then the contacts of a clearance build
    /// (type `contact`).
    pub forces: Vec<CheckForce>,
    /// Sensors: column, unit.
    pub sensors: Vec<CheckSensor>,
    /// Parameters.
    pub parameters: Vec<Parameter>,
    /// Largest constraint residual after assembly at t = 0 (m or rad).
    pub assembly_residual: f64,
}

/// A body in a [`CheckReport`].
#[derive(Debug, Clone, Serialize)]
pub struct CheckBody {
    /// Name.
    pub name: String,
    /// Mass, kg.
    pub mass_kg: f64,
}

/// A joint in a [`CheckReport`].
#[derive(Debug, Clone, Serialize)]
pub struct CheckJoint {
    /// Name.
    pub name: String,
    /// Kind (lower case).
    #[serde(rename = "type")]
    pub kind: String,
    /// Side i.
    pub i: String,
    /// Side j.
    pub j: String,
    /// Radial and axial clearance (m), if declared.
    pub clearance_m: Option<[f64; 2]>,
    /// Lower and upper limit of the joint's coordinate (rad or m), if declared (reported,
    /// not enforced).
    pub limits: Option<[f64; 2]>,
    /// Its compliant transmission, if declared.
    pub transmission: Option<CheckTransmission>,
}

/// A compliant transmission in a [`CheckReport`] (SI, by the joint's type: revolute in
/// rad/(N m), kg m², N m s/rad; prismatic in m/N, kg, N s/m).
#[derive(Debug, Clone, Serialize)]
pub struct CheckTransmission {
    /// Compliance.
    pub compliance: f64,
    /// Rotor inertia (prismatic: mass).
    pub rotor_inertia: f64,
    /// Damping.
    pub damping: f64,
    /// The declared parameter the compliance names, if any.
    pub compliance_parameter: Option<String>,
}

/// A driver in a [`CheckReport`].
#[derive(Debug, Clone, Serialize)]
pub struct CheckDriver {
    /// Name.
    pub name: String,
    /// The driven joint.
    pub joint: String,
}

/// A force element in a [`CheckReport`].
#[derive(Debug, Clone, Serialize)]
pub struct CheckForce {
    /// Name.
    pub name: String,
    /// Type.
    #[serde(rename = "type")]
    pub kind: String,
}

/// A sensor in a [`CheckReport`].
#[derive(Debug, Clone, Serialize)]
pub struct CheckSensor {
    /// Sensor name.
    pub name: String,
    /// Type.
    #[serde(rename = "type")]
    pub kind: SensorKind,
    /// Recording columns and their units.
    pub columns: Vec<[String; 2]>,
    /// `"motor"` for a joint sensor on the motor side of a transmission, else `"joint"`
    /// (body sensors too).
    pub side: &'static str,
}

impl ModelFile {
    /// Reads a model file and its includes.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ModelFileError> {
        let path = path.as_ref();
        let files = read::read_tree(path, None)?;
        Self::from_parsed(path, files)
    }

    /// A side file (TOML) applied over the URDF `urdf`, in place of the URDF the side file
    /// names itself (if any): `lash diagnose --model robot.urdf --side robot.toml`.
    pub fn load_over_urdf(urdf: impl AsRef<Path>, side: impl AsRef<Path>) -> Result<Self, ModelFileError> {
        let side = side.as_ref();
        let files = read::read_tree(side, Some(urdf.as_ref()))?;
        Self::from_parsed(side, files)
    }

    /// What the CLI's `--model FILE [--side SIDE]` names: a model file or URDF alone, or a
    /// side TOML over a URDF. A side file with a model that is not a URDF is refused.
    pub fn load_with_side(model: impl AsRef<Path>, side: Option<&Path>) -> Result<Self, ModelFileError> {
        let model = model.as_ref();
        match side {
            None => Self::load(model),
            Some(s) if read::is_urdf(model) => Self::load_over_urdf(model, s),
            Some(s) => Err(ModelFileError::File {
                file: s.display().to_string(),
                problem: Problem::Inconsistent,
                message: format!(
                    "a side file goes over a URDF, but the model '{}' is not a .urdf file",
                    model.display()
                ),
            }),
        }
    }

    /// A model from text (`name` stands for the file in messages; includes and series are
    /// relative to the current directory).
    pub fn from_text(name: &str, text: &str) -> Result<Self, ModelFileError> {
        let path = PathBuf::from(name);
        let src = Source::new(&path, text.to_string());
        let doc = read::parse(&src)?;
        if let Some(inc) = doc.include.first() {
            return Err(src.error(
                inc.span().start,
                error::Problem::Include,
                "includes need a model file on disk (ModelFile::load)",
            ));
        }
        if let Some(u) = &doc.urdf {
            return Err(src.error(
                u.span().start,
                error::Problem::Include,
                "a URDF reference needs a model file on disk (ModelFile::load)",
            ));
        }
        Self::from_parsed(
            &path,
            vec![Parsed {
                src,
                dir: PathBuf::from("."),
                doc,
                urdf: false,
            }],
        )
    }

    fn from_parsed(path: &Path, files: Vec<Parsed>) -> Result<Self, ModelFileError> {
        let parameters = read::parameters(&files)?;
        let candidates = read::candidates(&files, &parameters)?;
        let root = files.last().expect("read_tree returns the root file");
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().to_string())
            .unwrap_or_default();
        let (mut name, mut description) = (stem, String::new());
        for f in &files {
            if let Some(m) = &f.doc.model {
                if let Some(n) = &m.get_ref().name {
                    name = n.get_ref().clone();
                }
                if let Some(d) = &m.get_ref().description {
                    description = d.get_ref().clone();
                }
            }
        }
        let _ = root;
        let (mut fit_recordings, mut holdout_recordings) = (vec![], vec![]);
        for f in &files {
            if let Some(r) = &f.doc.recordings {
                let r = r.get_ref();
                fit_recordings = r.fit.iter().map(|p| f.dir.join(p.get_ref())).collect();
                holdout_recordings = r.holdout.iter().map(|p| f.dir.join(p.get_ref())).collect();
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            name,
            description,
            parameters,
            candidates,
            fit_recordings,
            holdout_recordings,
            files,
        })
    }

    /// The nominal mechanism (parameters at their nominal values, ideal joints).
    pub fn build(&self) -> Result<BuiltModel, ModelFileError> {
        let values: Vec<f64> = self.parameters.iter().map(|p| p.nominal).collect();
        self.build_with(&values, &BuildOptions::default())
    }

    /// The mechanism with parameter `values` (one per [`parameters`](Self::parameters) entry,
    /// SI) and the given options.
    pub fn build_with(&self, values: &[f64], opts: &BuildOptions) -> Result<BuiltModel, ModelFileError> {
        if values.len() != self.parameters.len() {
            return Err(ModelFileError::File {
                file: self.path.display().to_string(),
                problem: Problem::Inconsistent,
                message: format!(
                    "{} parameter values given for {} parameters",
                    values.len(),
                    self.parameters.len()
                ),
            });
        }
        build::build(&self.files, &self.parameters, values, opts)
    }

    /// Builds the nominal mechanism and assembles it at t = 0: what `lash check` prints.
    pub fn check(&self) -> Result<CheckReport, ModelFileError> {
        self.check_with(&BuildOptions::default())
    }

    /// [`check`](Self::check) of the nominal mechanism built with `opts` (`clearance: true`:
    /// joints that declare a clearance as bearings, what `lash check --clearance` prints).
    pub fn check_with(&self, opts: &BuildOptions) -> Result<CheckReport, ModelFileError> {
        let values: Vec<f64> = self.parameters.iter().map(|p| p.nominal).collect();
        let built = self.build_with(&values, opts)?;
        let residual = self.assemble(&built)?;
        let mech = &built.mechanism;
        let name_of = |a: crate::multibody::Attach| match a {
            crate::multibody::Attach::Ground => "ground".to_string(),
            crate::multibody::Attach::Body(h) => mech.body(h).map(|b| b.name.clone()).unwrap_or_default(),
        };
        let columns = built.sensor_columns();
        let mut col = 0;
        let sensors = built
            .sensors
            .iter()
            .map(|s| {
                let n = match s.kind {
                    SensorKind::BodyPosition => 3,
                    SensorKind::BodyOrientation => 4,
                    _ => 1,
                };
                let c = columns[col..col + n]
                    .iter()
                    .map(|(a, b)| [a.clone(), b.to_string()])
                    .collect();
                col += n;
                CheckSensor {
                    name: s.name.clone(),
                    kind: s.kind,
                    columns: c,
                    side: if s.motor_side { "motor" } else { "joint" },
                }
            })
            .collect();
        let driven = built.drivers.len() as isize;
        Ok(CheckReport {
            name: self.name.clone(),
            file: self.path.display().to_string(),
            clearance: opts.clearance,
            dof: mech.degrees_of_freedom(),
            dof_driven: mech.degrees_of_freedom() - driven,
            // The file's bodies, then those the build added (the crosses of universal joints
            // built with clearance).
            bodies: built
                .bodies
                .iter()
                .map(|(n, h)| CheckBody {
                    name: n.clone(),
                    mass_kg: mech.body(*h).map(|b| b.mass).unwrap_or(f64::NAN),
                })
                .chain(
                    mech.bodies()
                        .iter()
                        .filter(|(h, _)| built.bodies.iter().all(|(_, b)| b != h))
                        .map(|(_, b)| CheckBody {
                            name: b.name.clone(),
                            mass_kg: b.mass,
                        }),
                )
                .collect(),
            joints: built
                .joints
                .iter()
                .map(|j| CheckJoint {
                    name: j.name.clone(),
                    kind: format!("{:?}", j.kind).to_lowercase(),
                    i: name_of(j.i),
                    j: name_of(j.j),
                    clearance_m: j.clearance.map(|c| [c.radial_clearance, c.axial_clearance]),
                    limits: j.limits,
                    transmission: j.transmission.as_ref().map(|t| CheckTransmission {
                        compliance: t.compliance,
                        rotor_inertia: t.rotor_inertia,
                        damping: t.damping,
                        compliance_parameter: t.compliance_parameter.map(|k| self.parameters[k].name.clone()),
                    }),
                })
                .collect(),
            drivers: built
                .drivers
                .iter()
                .map(|(n, _, k)| CheckDriver {
                    name: n.clone(),
                    joint: built.joints[*k].name.clone(),
                })
                .collect(),
            // The file's force elements, then the contacts of joints built with clearance.
            forces: built
                .forces
                .iter()
                .map(|(n, k)| CheckForce {
                    name: n.clone(),
                    kind: k.clone(),
                })
                .chain(
                    mech.forces()
                        .filter(|(_, f)| built.forces.iter().all(|(n, _)| n != f.name()))
                        .map(|(_, f)| CheckForce {
                            name: f.name().to_string(),
                            kind: "contact".into(),
                        }),
                )
                .collect(),
            sensors,
            parameters: self.parameters.clone(),
            assembly_residual: residual,
        })
    }

    /// Assembles a built model at t = 0; returns the largest constraint residual. A failure
    /// is located at the joint or driver with the largest residual.
    pub fn assemble(&self, built: &BuiltModel) -> Result<f64, ModelFileError> {
        let mech = &built.mechanism;
        let analysis = Analysis::new(mech).map_err(|e| self.model_error(e))?;
        let mut data = MechanismData::new(mech);
        let s = analysis
            .initial_state(mech, &mut data, 0.0)
            .map_err(|e| self.model_error(e))?;
        analysis
            .constraint_residual(mech, &data, 0.0, &s.q)
            .map_err(|e| self.model_error(e))
    }

    /// A multibody error as a located model-file error: assembly failures at the worst
    /// joint's or driver's table.
    pub fn model_error(&self, e: ModelError) -> ModelFileError {
        let root = self.files.last().expect("read_tree returns the root file");
        if let ModelError::AssemblyFailed { residuals } = &e {
            let places = build::joint_places(&self.files);
            for (constraint, _) in residuals {
                // Constraint names read "joint 'A' point x #0" or "driver 'motor'".
                let quoted = constraint.split('\'').nth(1).unwrap_or("");
                if let Some((_, k, at)) = places.iter().find(|(n, _, _)| n == quoted) {
                    return self.files[*k].src.error(*at, Problem::Assembly, e.to_string());
                }
            }
            return ModelFileError::File {
                file: root.src.file.clone(),
                problem: Problem::Assembly,
                message: e.to_string(),
            };
        }
        ModelFileError::File {
            file: root.src.file.clone(),
            problem: Problem::Model,
            message: e.to_string(),
        }
    }
}
