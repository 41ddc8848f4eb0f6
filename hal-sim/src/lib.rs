//! hal-sim: the host test bed of imu-ident. It drives the same no_std core on x86: a truth
//! simulator, scenarios, log replay, and the file formats of the README.

pub mod adaptive;
pub mod allan;
pub mod candidates;
pub mod cli;
pub mod clock;
pub mod commands;
pub mod compare;
pub mod datasheet;
pub mod datasheet_model;
pub mod diagnose;
pub mod figures;
pub mod firmware;
pub mod hidden;
pub mod identify;
pub mod imu_model;
pub mod imu_sim;
pub mod kalibr;
pub mod log;
pub mod mismatch;
pub mod model_toml;
pub mod nav;
pub mod nav_io;
pub mod nav_qemu;
pub mod output;
pub mod present;
pub mod qemu;
pub mod records;
pub mod replay;
pub mod report;
pub mod scenario;
pub mod series;
pub mod shared_data;
pub mod sim;
pub mod summary;
pub mod trajectory;
