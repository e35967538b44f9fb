//! The standard scenes every figure of the crate comes from (see `docs/benchmarks.md`), built on
//! the pure cores so they run without an App: the `scenes` example, the benches and the
//! accuracy tests all use these.
//!
//! One file per scene: S1 the hanging cloth (`hanging.rs`), S2 the drape (`drape.rs`), the
//! sheet drop (`sheet_drop.rs`), two sheets dropped on a sphere (`layered_drop.rs`), the collision scene (`collisions.rs`), the wind scene (`flag.rs`);
//! what they share in `common.rs`.

mod collisions;
mod common;
mod drape;
mod flag;
mod hanging;
mod layered_drop;
mod mesh_drop;
mod sheet_drop;

pub use collisions::{Collisions, CollisionsRun};
pub use common::{DENSITY, FRAME_RATE, GRAVITY, lowest_height, median};
pub use drape::{Drape, DrapeRun};
pub use flag::{Flag, FlagRun};
pub use hanging::{HangingCloth, SceneRun, Trajectory};
pub use layered_drop::{LayeredDrop, LayeredDropRun};
pub use mesh_drop::{MeshDrop, MeshDropRun, read_obj};
pub use sheet_drop::{SheetDrop, SheetDropRun, closest_non_adjacent};
