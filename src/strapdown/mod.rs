//! Multi-axis strapdown inertial navigation in the local-level NED frame: the WGS-84 Earth
//! model ([`earth`]), attitude quaternions ([`attitude`]), the IMU-rate mechanisation with
//! coning and sculling corrections and the closed-loop correction hooks of an error-state
//! filter ([`mechanise`]), and the initial alignment ([`align`]).
//!
//! Frames: body FRD (x forward, y right, z down), navigation NED; attitude `q_b^n`. Errors are
//! *computed minus true* (see [`mechanise`]). Everything is `no_std`, heap-free, generic over
//! [`Real`](crate::Real), and returns an error rather than panicking on non-finite input.
//!
//! The exact-truth simulator that checks this module lives in hal-sim (`hal_sim::trajectory`).

pub mod align;
pub mod attitude;
pub mod earth;
pub mod mechanise;
#[cfg(test)]
mod tests;

pub use align::{heading_from_course, level_from_specific_force, AlignError, Leveller};
pub use attitude::{skew, Quat};
pub use mechanise::{
    body_increments, coning, move_by, sculling, Corrections, Geodetic, Increment, Strapdown,
    StrapdownError, MAX_LAT, REBASE_M,
};
