//! The one Kalman kernel ([`Kalman`]), the one fixed-model filter built on it for any error
//! model ([`ErrorStateFilter`]: vector gate, sequential scalar fusion), its one-channel
//! interface ([`InsFilter`]), and the chi-square quantiles of the gates ([`chi_square`]).

pub mod chi_square;
pub mod error_state;
pub mod ins_filter;
pub mod kalman;

pub use crate::linalg::is_positive_definite;
pub use error_state::{fuse, fuse_ungated, joint, AxisStatus, ErrorStateFilter, Fused, Joint};
pub use ins_filter::{Estimates, InsFilter};
pub use kalman::{Innovation, Kalman, UpdateStatus};
