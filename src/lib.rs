#![no_std]
#![doc = include_str!("../README.md")]

pub mod adapt;
pub mod autocorr;
pub mod crc;
#[cfg(all(target_arch = "arm", target_os = "none", feature = "defmt"))]
pub mod defmt_frame;
pub mod edge;
pub mod filter;
pub mod ident;
pub mod linalg;
pub mod model;
pub mod nav;
#[cfg(all(target_arch = "arm", target_os = "none", feature = "prove-no-panic"))]
mod panic_proof;
pub mod port;
pub mod real;
pub mod replay;
pub mod step;
pub mod strapdown;
pub mod telemetry;
pub use real::Real;
