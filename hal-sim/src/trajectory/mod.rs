//! Trajectory and IMU simulator with truth (f64, seeded) for the strapdown INS/GNSS: a smooth
//! segment profile ([`profile`]), the truth and exact error-free IMU increments along it
//! ([`truth`]), per-axis sensor errors from the core's noise components ([`errors`]), GNSS
//! fixes with noise and outages ([`gnss`]), a board timer's oscillator ([`oscillator`]), and
//! the CSV writers of the pinned formats ([`write`], README "Strapdown formats").

pub mod errors;
pub mod gnss;
pub mod oscillator;
pub mod profile;
pub mod truth;
pub mod write;

pub use profile::{Kinematics, Piece, Profile};
pub use truth::{TruthGen, TruthSample};
