//! `bevy_drape` with `bevy-inspector-egui`: every component and setting of the crate is
//! reflected, so the inspector shows and edits them in a running App.
//!
//! This package holds the inspector example (`cargo run -p drape_inspector --features egui
//! --example inspector`) and its headless test (`cargo test -p drape_inspector`), apart from
//! the crate so that a plain `cargo test` of `bevy_drape` builds no egui.
