//! Interaction: picking cloth particles with a ray ([`pick`]); dragging them is
//! [`crate::cloth::ClothSim::grab`], [`crate::cloth::ClothSim::drag_to`] and
//! [`crate::cloth::ClothSim::release`].

pub mod pick;
