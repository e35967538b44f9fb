//! Interaction: picking cloth particles with a ray ([`pick`]); dragging them is
//! [`crate::cloth::ClothSim::grab`], [`crate::cloth::ClothSim::drag_to`] and
//! [`crate::cloth::ClothSim::release`]; with the `render` feature, `drag::ClothDragPlugin`
//! does it with the mouse; per-vertex debug colours ([`colors`]).

pub mod colors;
#[cfg(feature = "render")]
pub mod drag;
pub mod pick;
