//! The cloth core: model, state, constraints and the XPBD step, free of ECS types, and the
//! Bevy plugin that drives it ([`plugin`]).

pub mod batch;
pub mod constraints;
pub mod damping;
pub mod debug_colors;
pub mod garment;
pub mod isometric_bending;
pub mod mass_spring;
pub mod mesh;
pub mod model;
pub mod ordering;
pub mod plugin;
pub mod self_collision;
pub mod settings;
pub mod sim;
pub mod state;
pub mod stretch_limits;
pub mod volume;
pub mod weld;

pub use constraints::Tether;
pub use garment::{PonchoDesc, to_obj};
pub use mass_spring::{SpringConstants, SpringSet, SpringSettings};
pub use model::{BendingPair, ClothModel, Edge, EdgeKind, GridDesc, GridMesh};
pub use self_collision::{SelfCollision, SelfContactPair};
pub use settings::{AdaptiveSubsteps, DampingMode, DivergenceBounds, SolverMethod, SolverSettings};
pub use sim::{ClothSim, Divergence, Pin, StrainStats};
pub use state::ClothState;
pub use volume::{VolumeConstraint, VolumeSettings};
pub use weld::{Welded, weld};
