//! The one Kalman kernel ([`Kalman`]) and the one-channel INS error filter built on it
//! ([`InsFilter`]).

pub mod error_state;
pub mod ins_filter;
pub mod kalman;

pub use crate::linalg::is_positive_definite;
pub use error_state::{fuse, joint, AxisStatus, ErrorStateFilter, Fused, Joint};
pub use ins_filter::{Estimates, InsFilter};
pub use kalman::{Innovation, Kalman, UpdateStatus};
