//! Strapdown INS/GNSS navigation with the seed's noise models on every sensor axis (issue 16):
//! the per-axis IMU noise model ([`imu_model`]), the multi-axis error-state model
//! ([`error_model`], phi-angle form, an [`ErrorModel`](crate::model::ErrorModel) with six
//! observation axes) and the closed-loop navigator ([`navigator`]) that runs the
//! [`Strapdown`](crate::strapdown::Strapdown) mechanisation at the IMU rate and the one
//! Kalman kernel at the filter rate.
//!
//! `no_std`, heap-free; the capacity `N` of the filter is a const generic ([`NAV_N`] by
//! default).

pub mod counted;
pub mod error_model;
pub mod gps_clock;
pub mod imu_frame;
pub mod imu_model;
pub mod live;
pub mod navigator;
pub mod online;
pub mod predictor;
pub mod replay;
pub mod rest;
pub mod run;
pub mod serial;
pub mod start;
pub mod ubx;

pub use error_model::{nav_idx, NavInit, NavPoint, StrapdownErrorModel, NAV_Z};
pub use imu_model::{AxisModel, ImuErrorModel, ImuSensor, MAX_AXIS_COMPONENTS};
pub use navigator::{
    GnssFix, NavConfig, NavError, NavObserver, NavSd, Navigator, ObservationKind, CHI2_9999, NHC_Z,
};
pub use online::{OnlineConfig, OnlineIdent};
pub use replay::NavSetup;
pub use rest::{RestDetector, Zupt};
pub use run::{Epoch, ImuStep, NavReplay, Nhc, NHC_MIN_SPEED};

/// Default filter capacity: 9 navigation errors plus up to 15 sensor-component states (for
/// example a Gauss-Markov and a random constant on each of the six axes, plus three more).
pub const NAV_N: usize = 24;
