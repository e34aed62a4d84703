//! Clearance design: which clearances keep a mechanism within a required positioning
//! accuracy (the purpose the reference paper states and stops short of).
//!
//! | file | concern |
//! |---|---|
//! | `allowable.rs` | the largest uniform clearance that meets an accuracy at given poses: first-order estimate ([`crate::contact::play_bound`]) and verification by the nonlinear static equilibria ([`crate::multibody::static_equilibrium`]) |
//! | `allocation.rs` | clearances per joint and per direction over a region under a cost model (∝ 1/h), first-order optimum verified by the equilibria |
//! | `calibration.rs` | the bearing dimensions the paper does not give, fitted to its Table 3 on the static envelopes |
//! | `region.rs` | the region a design holds over: named poses, a path, a box |
//! | `map.rs` | worst-case error maps over a slice of the work zone, both methods, where they part |

pub mod allocation;
pub mod allowable;
pub mod calibration;
pub mod map;
pub mod region;

pub use allocation::{allocate, Allocation, CostModel, Grouping, RegionDesign};
pub use allowable::{allowable_along, allowable_uniform, Accuracy, AllowablePoint, CurvePoint, DesignError};
pub use map::{error_map, error_map_part, merge_parts, CellKind, ErrorMap, MapCell, MapGrid, MapPart, Shard};
pub use region::{Region, RegionPoses};
