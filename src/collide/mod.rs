//! Colliders: shapes (sphere, capsule, plane, triangle mesh with a bounding-volume
//! hierarchy), their motion over a fixed step, and particle contacts with restitution and
//! Coulomb friction on the velocity relative to the collider ([`contact`]); the Bevy
//! components in [`plugin`].

pub mod contact;
pub mod motion;
pub mod plugin;
pub mod shapes;
pub mod trimesh;

pub use contact::{Contact, ContactScratch};
pub use motion::{FrameStep, FrameTracker, RigidMap, Teleport};
pub use shapes::{Collider, ContactMaterial, RigidPose, Shape};
pub use trimesh::{Aabb, TriMesh};
