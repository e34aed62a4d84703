//! Rigid multibody systems in absolute coordinates on the `dae` layer.
//!
//! | file | concern |
//! |---|---|
//! | `rotation.rs` | Euler parameters, rotation matrices and their derivatives |
//! | `body.rs` | rigid bodies, the body set and handles |
//! | `error.rs` | model errors naming bodies and joints |
//! | `constraints.rs` | constraint primitives (point, dot-1, dot-2, angle) with derivatives |
//! | `joints/` | one joint kind per file, built from primitives |
//! | `drivers.rs` | motion laws for driven joint coordinates |
//! | `forces.rs` | gravity, point forces, torques, spring-dampers, the force-element trait |
//! | `model.rs` | the mechanism (constant model): builder, accessors, replace/remove with stable handles |
//! | `data.rs` | the mechanism's data (state t, q, w, ẇ, λ and scratch); typed access by handle, driver-effort sign |
//! | `layout.rs` | the state layout (`Layout`): the one place for every address |
//! | `evaluator.rs` | scratch of one evaluation of kinematics, constraints and loads |
//! | `formulation.rs` | GGL index-2 equations of motion as a `dae::DaeSystem` |
//! | `analysis.rs` | assembly, velocity/acceleration analysis, reactions, singularity measure on `(&Mechanism, &mut MechanismData)` |
//! | `explicit.rs` | the same equations as an ODE (index-1, Baumgarte) for explicit integrators |
//! | `simulation.rs` | the pipeline: initial state → BDF → samples, singularity watch; `SimulationOptions` and every default |
//! | `statics.rs` | quasi-static equilibrium (drivers held, loads balanced) by pseudo-transient continuation |
//! | `output.rs` | CSV per body and per joint |

pub mod analysis;
pub mod body;
pub(crate) mod constraints;
pub mod data;
pub mod drivers;
pub mod error;
pub(crate) mod evaluator;
pub mod explicit;
pub mod forces;
pub mod formulation;
pub mod joints;
pub mod layout;
pub mod model;
pub mod output;
pub mod rotation;
pub mod simulation;
pub mod statics;

pub use analysis::{Analysis, AssemblyOptions, Reaction, Snapshot};
pub use body::{Attach, BodyHandle, BodySet, RigidBody};
pub use data::MechanismData;
pub use drivers::{MotionLaw, Profile};
pub use error::ModelError;
pub use explicit::{BaumgarteGains, MultibodyOde};
pub use forces::{BodyLoad, BodyState, ForceElement, LoadDerivative, PointForce, SpringDamper, Torque};
pub use formulation::{FormulationOptions, Layout, MultibodyDae};
pub use joints::{Joint, JointFrame, JointHandle, JointKind};
pub use model::{Driver, DriverHandle, ForceHandle, Marker, MarkerHandle, Mechanism, STANDARD_GRAVITY};
pub use simulation::{
    output_count, output_times, RunEnd, Sample, Simulation, SimulationOptions, SingularityEvent, Trajectory,
    MAX_OUTPUT_TIMES,
};
pub use statics::{static_equilibrium, Equilibrium, Statics, StaticsOptions, STATICS_REJECT_FACTOR};
