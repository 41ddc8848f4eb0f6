//! The fixed-size Kalman filter ([`Ekf`]) and the INS error filter built on it ([`InsFilter`]).

pub mod ekf;
pub mod ins_filter;

pub use ekf::{is_positive_definite, Ekf, Innovation, UpdateStatus};
pub use ins_filter::{Estimates, InsFilter};
