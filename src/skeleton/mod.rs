//! Keyframed hinge skeletons: the rig and its forward kinematics ([`rig`]), keyframe splines
//! at non-uniform times ([`spline`]), clips ([`clip`]), the humanoid of the examples
//! ([`humanoid`]) and the Bevy components ([`plugin`]); with the `animation` feature, Bevy's
//! `AnimationPlayer` stepped with the cloth (`fixed_step_animation`).

pub mod clip;
#[cfg(feature = "animation")]
pub mod fixed_step_animation;
pub mod humanoid;
pub mod ik;
pub mod plugin;
pub mod rig;
pub mod spline;
