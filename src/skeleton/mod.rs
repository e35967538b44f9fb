//! Keyframed hinge skeletons: the rig and its forward kinematics ([`rig`]), keyframe splines
//! at non-uniform times ([`spline`]), clips ([`clip`]), the humanoid of the examples
//! ([`humanoid`]) and the Bevy components ([`plugin`]).

pub mod clip;
pub mod humanoid;
pub mod ik;
pub mod plugin;
pub mod rig;
pub mod spline;
