//! Colliders: shapes (sphere, capsule, plane, triangle mesh with a bounding-volume
//! hierarchy and pseudo-normals), their motion over a fixed step, particle contacts with
//! restitution and Coulomb friction on the velocity relative to the collider (`contact.rs`),
//! the cloth's triangles against a mesh's vertices (`vertex_contacts.rs`), its structural edges
//! against spheres and capsules thin enough to pass between two particles
//! (`edge_contacts.rs`); the Bevy components in
//! [`plugin`]; with the `avian` feature, Avian's colliders as cloth colliders (`avian`).

#[cfg(feature = "avian")]
pub mod avian;
pub(crate) mod components;
pub(crate) mod contact;
pub(crate) mod edge_contacts;
pub mod motion;
pub mod plugin;
pub(crate) mod pose;
pub(crate) mod shapes;
pub(crate) mod skin;
pub(crate) mod trimesh;
pub(crate) mod vertex_contacts;

pub use motion::{FrameStep, FrameTracker, Teleport};
pub use pose::RigidPose;
pub use shapes::{ContactMaterial, MAX_COORDINATE, SolverCollider, SolverShape};
pub use trimesh::TriMesh;
