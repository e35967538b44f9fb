//! Keyframed hinge skeletons: keyframe splines at non-uniform times ([`spline`]).

pub mod spline;
