//! The crate's integration tests, one binary (a binary per file would link Bevy 35 times).
//! Each module is one subject; `common` is what they share. `no_allocation` (its own global
//! allocator) and `avian` (the `avian` feature) are binaries of their own.

mod common;

mod air;
mod app_characters;
mod app_cloth;
mod app_colliders;
mod app_divergence;
mod app_drawing;
mod app_threads;
mod balloon;
mod budget;
mod cloth_dynamics;
mod cloth_model;
mod cloth_statics;
mod colliders_analytic;
mod colliders_scenes;
mod colliders_sheets;
mod contact_strain;
mod files;
mod fluid;
mod fluid_cloth;
mod gltf_character;
mod gltf_ik;
mod ik;
mod interaction;
mod layers;
mod mass_spring;
mod mesh_colliders;
mod moving_character_cloth;
mod moving_character_velocities;
mod parallel;
mod plugin_subsets;
mod poncho;
mod self_collision;
mod study;
mod water;
mod wind_default;
