//! Keyframed hinge skeletons: the rig and its forward kinematics ([`rig`]) and keyframe
//! splines at non-uniform times ([`spline`]).

pub mod clip;
pub mod rig;
pub mod spline;
