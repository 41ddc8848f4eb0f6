#![no_std]
#![doc = include_str!("../README.md")]

pub mod real;
pub use real::Real;
