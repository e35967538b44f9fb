//! The measuring harness of `bevy_drape`, kept out of the published library: the standard
//! scenes every figure comes from (`docs/benchmarks.md`), the speed-against-accuracy study and
//! the main scene (S3) with its headless runner. The library's tests, benches and the `scenes`
//! and `speed_accuracy` examples use it; a game does not need it.
//!
//! - [`scenes`]: S1 (the hanging cloth), S2 (the drape over a sphere) and the sheet drop, on
//!   the pure cores, without an App.
//! - [`study`]: the measurements behind the `speed_accuracy` charts.
//! - [`scan`]: random scan-like meshes (thin ears, open bottoms, dented rocks) for the mesh
//!   collider tests and benches.
//! - [`gltf_character`]: the poncho on that character loaded as a glTF scene and animated by
//!   Bevy's `AnimationPlayer`.
//! - [`gltf_export`]: the humanoid, a body skinned to it and its clips as a `.glb` file.
//! - [`poncho`]: S3, the poncho on the walking character, as a plugin ([`poncho::PonchoScenePlugin`])
//!   and as a headless run with its figures ([`poncho::run_headless`]).
//! - [`water`]: measures of water in cloth.

pub mod gltf_character;
pub mod gltf_export;
pub mod poncho;
pub mod scan;
pub mod scenes;
pub mod study;
pub mod water;
