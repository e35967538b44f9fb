//! Colliders: shapes (sphere, capsule, plane, triangle mesh with a bounding-volume
//! hierarchy), their motion over a fixed step, and particle contacts with restitution and
//! Coulomb friction on the velocity relative to the collider (`contact.rs`); the Bevy
//! components in [`plugin`].

pub(crate) mod contact;
pub mod motion;
pub mod plugin;
pub(crate) mod shapes;
pub(crate) mod trimesh;

pub use motion::{FrameStep, FrameTracker, Teleport};
pub use shapes::{ContactMaterial, RigidPose, SolverCollider, SolverShape};
pub use trimesh::TriMesh;
