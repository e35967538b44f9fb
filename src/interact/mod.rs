//! Interaction: picking cloth particles with a ray ([`pick`]); dragging them is
//! [`crate::cloth::ClothSolver::grab`], [`crate::cloth::ClothSolver::drag_to`] and
//! [`crate::cloth::ClothSolver::release`]; with the `render` feature, `drag::ClothDragPlugin`
//! does it with the mouse (debug colours are `crate::cloth::debug_colors`); with `render`, collider
//! gizmos (`gizmos::ColliderGizmoPlugin`); with `egui`, the settings panel
//! (`panel::DrapePanelPlugin`); with `render`, whether the renderer can start at all
//! (`adapter::find_graphics_adapter`).

#[cfg(feature = "render")]
pub mod adapter;
#[cfg(feature = "render")]
pub mod drag;
#[cfg(feature = "render")]
pub mod gizmos;
#[cfg(feature = "egui")]
pub mod panel;
pub mod pick;
