//! Water: Position Based Fluids (Macklin and Müller 2013) as plain data, free of ECS types.
//! [`FluidSolver`] steps one body of particles (`solver.rs`) with the SPH kernels of
//! `kernels.rs` and neighbour lists from a uniform grid (`neighbours.rs`), stepped with a
//! cloth in its substeps, both ways ([`FluidSolver::step_with_cloth`], `cloth_coupling.rs`).

pub mod cloth_coupling;
pub mod jet;
pub(crate) mod kernels;
pub(crate) mod neighbours;
pub mod plugin;
pub mod settings;
pub mod solver;

pub use cloth_coupling::ClothContacts;
pub use jet::{FluidJet, JetEmitter};
pub use settings::FluidSettings;
pub use solver::{DensityError, FluidSolver};
