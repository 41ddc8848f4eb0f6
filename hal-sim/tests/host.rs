//! The host integration tests, one module per file of `tests/`, in one test binary.
//!
//! Each file was its own test crate; linked one by one, the 33 binaries took 3 min 39 s of a
//! cold build on the 2-core CI box (BENCHMARKS.md "CI time"). One binary compiles the shared
//! generic code once and links once. Run one file's tests with a filter on its module:
//! `cargo test -p hal-sim --test host nav_real::` (or `-- --exact nav_real::NAME`).
//! The QEMU tests (`qemu_smoke.rs`, `nav_qemu.rs`) stay binaries of their own: CI runs them in
//! its step 7, after the firmware is built.

#[path = "adaptive.rs"]
mod adaptive;
#[path = "allan_reference.rs"]
mod allan_reference;
#[path = "change.rs"]
mod change;
#[path = "consistency.rs"]
mod consistency;
#[path = "diagnose.rs"]
mod diagnose;
#[path = "diagnose_limits.rs"]
mod diagnose_limits;
#[path = "f32_vs_f64.rs"]
mod f32_vs_f64;
#[path = "formats.rs"]
mod formats;
#[path = "fuzz_parsers.rs"]
mod fuzz_parsers;
#[path = "identifiability.rs"]
mod identifiability;
#[path = "identify_imu.rs"]
mod identify_imu;
#[path = "identify_real.rs"]
mod identify_real;
#[path = "model_toml_golden.rs"]
mod model_toml_golden;
#[path = "module_graph.rs"]
mod module_graph;
#[path = "nav_adapt.rs"]
mod nav_adapt;
#[path = "nav_bank.rs"]
mod nav_bank;
#[path = "nav_blind_spots.rs"]
mod nav_blind_spots;
#[path = "nav_clock.rs"]
mod nav_clock;
#[path = "nav_diagnose.rs"]
mod nav_diagnose;
#[path = "nav_identify_axes.rs"]
mod nav_identify_axes;
#[path = "nav_io_formats.rs"]
mod nav_io_formats;
#[path = "nav_io_real.rs"]
mod nav_io_real;
#[path = "nav_live.rs"]
mod nav_live;
#[path = "nav_present.rs"]
mod nav_present;
#[path = "nav_real.rs"]
mod nav_real;
#[path = "nav_report.rs"]
mod nav_report;
#[path = "nav_seeds.rs"]
mod nav_seeds;
#[path = "nav_sim.rs"]
mod nav_sim;
#[path = "nav_wire.rs"]
mod nav_wire;
#[path = "nav_zupt.rs"]
mod nav_zupt;
#[path = "replay_consistency.rs"]
mod replay_consistency;
#[path = "report_browser.rs"]
mod report_browser;
#[path = "sigma_from_estimates.rs"]
mod sigma_from_estimates;
#[path = "strapdown_f32.rs"]
mod strapdown_f32;
#[path = "strapdown_sim.rs"]
mod strapdown_sim;
#[path = "strapdown_truth.rs"]
mod strapdown_truth;
#[path = "structure.rs"]
mod structure;
