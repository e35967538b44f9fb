//! Errors and warnings for user-supplied data.
//!
//! The library never panics on user data: anything that can be wrong in a mesh, a setting or a
//! pin list is reported as a [`ClothError`] (the cloth is not built) or a [`ClothWarning`]
//! (the cloth is built, with the offending part left out). The Bevy side logs both with the
//! entity named.

use thiserror::Error;

/// Why a cloth could not be built or changed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ClothError {
    /// The cloth's mesh file could not be loaded.
    #[error("cannot load the mesh {path}: {reason}")]
    MeshLoadFailed {
        /// The asset path.
        path: String,
        /// What went wrong.
        reason: String,
    },
    /// A volume constraint was asked of a surface that does not close.
    #[error(
        "a volume constraint needs a closed surface; this one has {boundary_edges} boundary or non-manifold edges"
    )]
    OpenSurface {
        /// Edges not shared by exactly two triangles in opposite directions.
        boundary_edges: usize,
    },
    /// A garment pattern's dimensions make no garment.
    #[error("invalid pattern: {0}")]
    InvalidPattern(String),
    /// The mesh has no (non-degenerate) triangles.
    #[error("the mesh has no usable triangles")]
    NoTriangles,
    /// The index list is not a whole number of triangles.
    #[error("the index count {0} is not a multiple of 3")]
    IndexCountNotTriangles(usize),
    /// A triangle refers to a vertex that does not exist.
    #[error("index {index} is out of range for {vertex_count} vertices")]
    IndexOutOfRange {
        /// The offending index.
        index: u32,
        /// The number of vertices.
        vertex_count: usize,
    },
    /// A vertex position is NaN or infinite.
    #[error("vertex {vertex} has a non-finite position")]
    NonFinitePosition {
        /// The offending vertex.
        vertex: usize,
    },
    /// The areal density is not a finite positive number.
    #[error("density {0} kg/m^2 is not a finite positive number")]
    InvalidDensity(f32),
    /// A particle mass is negative or not finite.
    #[error("particle {particle} has an invalid mass {mass} kg")]
    InvalidMass {
        /// The offending particle.
        particle: usize,
        /// Its mass.
        mass: f32,
    },
    /// A distance constraint joins a particle to itself or has zero rest length.
    #[error("constraint {constraint} between particles {a} and {b} has zero rest length")]
    DegenerateConstraint {
        /// The index of the constraint in the input.
        constraint: usize,
        /// First particle.
        a: u32,
        /// Second particle.
        b: u32,
    },
    /// A pinned or attached vertex does not exist.
    #[error("vertex {vertex} is out of range for {vertex_count} vertices")]
    VertexOutOfRange {
        /// The offending vertex.
        vertex: u32,
        /// The number of vertices.
        vertex_count: usize,
    },
    /// The mesh cannot be read as triangles.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A setting is out of its valid range.
    #[error("setting `{name}` = {value} is invalid: {reason}")]
    InvalidSetting {
        /// The setting's name.
        name: &'static str,
        /// Its value.
        value: f32,
        /// What the valid range is.
        reason: &'static str,
    },
    /// Cloths to be stepped as layers of one solve: none were given.
    #[error("no cloths to step as layers")]
    NoLayers,
    /// A layer of a solve is missing or is not the cloth it was built from (another particle
    /// count): the solve must be built again.
    #[error("layer {layer} is not the cloth the layered solve was built with")]
    LayerChanged {
        /// The layer's place, innermost first.
        layer: usize,
    },
}

impl ClothError {
    /// The first of the named `settings` that is not finite and at least 0, as an
    /// [`ClothError::InvalidSetting`].
    pub(crate) fn require_non_negative(settings: &[(&'static str, f32)]) -> Result<(), Self> {
        match settings
            .iter()
            .find(|(_, value)| !(value.is_finite() && *value >= 0.0))
        {
            Some(&(name, value)) => Err(Self::InvalidSetting {
                name,
                value,
                reason: "finite and >= 0",
            }),
            None => Ok(()),
        }
    }
}

/// Something in the input that was left out or adjusted; the cloth is still built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ClothWarning {
    /// A triangle with (near) zero area was dropped.
    #[error("triangle {triangle} has zero area and was ignored")]
    DegenerateTriangle {
        /// The triangle's index in the input.
        triangle: usize,
    },
    /// An edge is shared by more than two triangles; it gets no bending constraint.
    #[error(
        "edge ({a}, {b}) is shared by {triangles} triangles (non-manifold); it has no bending constraint"
    )]
    NonManifoldEdge {
        /// First vertex.
        a: u32,
        /// Second vertex.
        b: u32,
        /// How many triangles share it.
        triangles: usize,
    },
    /// Vertices that belong to no triangle have no mass; they are held in place.
    #[error("{count} vertices belong to no triangle; they have no mass and are held in place")]
    IsolatedVertices {
        /// How many.
        count: usize,
    },
}

/// Why a collider is ignored.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ColliderError {
    /// A radius, length, margin, friction or restitution is out of range.
    #[error("collider `{name}` = {value} is out of range")]
    InvalidDimension {
        /// Which dimension.
        name: &'static str,
        /// Its value.
        value: f32,
    },
    /// The collider's pose or velocity is NaN or infinite.
    #[error("the collider's transform or velocity is not finite")]
    NonFinitePose,
    /// The collider's position or velocity is finite but beyond
    /// [`MAX_COORDINATE`](crate::collide::MAX_COORDINATE).
    #[error("the collider's position or velocity is beyond 1e6 (m, m/s or rad/s)")]
    PoseOutOfRange,
    /// A triangle-mesh collider has no (non-degenerate) triangles.
    #[error("the collider mesh has no usable triangles")]
    EmptyMesh,
    /// A triangle-mesh collider refers to a vertex that does not exist.
    #[error("collider mesh index {index} is out of range for {vertex_count} vertices")]
    IndexOutOfRange {
        /// The offending index.
        index: u32,
        /// The number of vertices.
        vertex_count: usize,
    },
    /// A triangle-mesh collider has a NaN or infinite vertex.
    #[error("collider mesh vertex {vertex} is not finite")]
    NonFiniteVertex {
        /// The offending vertex.
        vertex: usize,
    },
    /// The collider mesh could not be read.
    #[error("the collider mesh cannot be read: {0}")]
    Mesh(#[from] MeshError),
}

/// Why a [`bevy::mesh::Mesh`] cannot be read as triangles ([`crate::mesh::mesh_triangles`]).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum MeshError {
    /// The mesh is not a triangle list.
    #[error("the mesh is not a triangle list")]
    NotTriangleList,
    /// The mesh has no `Float32x3` position attribute.
    #[error("the mesh has no Float32x3 position attribute")]
    MissingPositions,
    /// The mesh data lives only in the render world (its asset usage lacks `MAIN_WORLD`).
    #[error("the mesh data is not in the main world; create it with RenderAssetUsages::MAIN_WORLD")]
    MeshDataUnavailable,
}

/// Why a fluid could not be built or changed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FluidError {
    /// A fluid setting is out of range.
    #[error("fluid setting {name} = {value} is invalid: {reason}")]
    InvalidSetting {
        /// The setting's name.
        name: &'static str,
        /// Its value.
        value: f32,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A particle's position or velocity is NaN or infinite.
    #[error("fluid particle {particle} has a non-finite position or velocity")]
    NonFiniteParticle {
        /// The offending particle, counted in the list given.
        particle: usize,
    },
    /// A box of particles has a corner that is not finite, or no room for one particle.
    #[error("the fluid box from {min:?} to {max:?} holds no particle")]
    EmptyBox {
        /// The box's smallest corner.
        min: [f32; 3],
        /// Its largest corner.
        max: [f32; 3],
    },
    /// A collider's shape, material, margin or pose is invalid.
    #[error("fluid collider {index}: {source}")]
    InvalidCollider {
        /// The collider's place in the list given.
        index: usize,
        /// What is wrong with it.
        source: ColliderError,
    },
}
