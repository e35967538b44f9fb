//! The cloth core: model, state, constraints and the XPBD step, free of ECS types, and the
//! Bevy plugin that drives it ([`plugin`]).

pub(crate) mod air;
// The kernels `internals` exposes are reached from outside only with that feature.
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod batch;
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod constraints;
pub(crate) mod crossings;
pub(crate) mod damping;
pub(crate) mod debug_colors;
pub(crate) mod embedding;
pub(crate) mod fast_projection;
pub(crate) mod flat_layout;
pub(crate) mod garment;
pub(crate) mod grid;
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod isometric_bending;
pub(crate) mod lod;
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod mass_spring;
pub mod mesh;
pub(crate) mod model;
pub(crate) mod ordering;
pub mod plugin;
pub mod render_mesh;
pub(crate) mod rest_paths;
pub(crate) mod rims;
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod self_collision;
pub(crate) mod settings;
pub(crate) mod sim;
pub(crate) mod state;
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod stretch_limits;
#[cfg_attr(not(feature = "internals"), allow(unreachable_pub, dead_code))]
pub(crate) mod triangle_collision;
pub(crate) mod volume;
pub mod wind_plugin;

pub use crate::weld::{Welded, weld};
pub use air::{AirSettings, Falloff, Gusts, WindField, WindShape, WindSourceDesc};
pub use crossings::{CROSSING_REACH, TwoPoses, count_crossings_between, count_self_crossings};
pub use damping::RigidMotion;
pub use debug_colors::{ClothPaint, DebugColorMode, PaintSource, PaintTarget};
pub use embedding::{EmbeddedVertex, Embedding};
pub use garment::{PonchoDesc, to_obj};
pub use lod::{LOD_MARGIN, LodBudget, LodLevel};
pub use mass_spring::{SpringConstants, SpringSettings};
pub use model::{ClothModel, Edge, EdgeKind, GridDesc, GridMesh};
pub use settings::{
    AdaptiveSubsteps, DampingMode, DivergenceBounds, ExactEdges, SelfCollisionMethod, SolverMethod,
    SolverSettings,
};
pub(crate) use sim::SubstepCoupling;
pub use sim::diagnostics::{Divergence, StrainStats};
pub use sim::{
    ClothSolver, Join, LayerSolver, MAX_SPEED_CHANGE, MAX_STEP, ORIGIN_GRID, OneThread, Pin,
    SleepSettings, StepTimings, with_helper,
};
pub use state::ClothState;
pub use volume::VolumeSettings;

/// The solver's kernels, for the crate's own benches and measuring harness (feature
/// `internals`); not part of the API a game uses, and free to change.
#[cfg(feature = "internals")]
pub mod internals {
    pub use super::batch::PairBatches;
    pub use super::constraints::{Projection, project_distance};
    pub use super::isometric_bending::IsometricPair;
    pub use super::mass_spring::SpringSet;
    pub use super::self_collision::SelfCollision;
    pub use super::stretch_limits::straight_line_limits;
    pub use super::triangle_collision::{TriangleSelfCollision, VertexTriangle};
}
