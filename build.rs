//! Selects the linker memory map of the board being built for.
//!
//! cortex-m-rt's `link.x` includes `memory.x`; in a workspace the linker runs from the workspace
//! root, and a file found there wins over the -L search path (see the comment in `memory.x`).
//! So this script copies the board's map from `memory/` into OUT_DIR under two names:
//! `memory.x` (found through -L when nothing shadows it) and `imu-ident-board.x` (what the
//! top-level `memory.x` forwards to). Either way the linker reads the selected board's map.
//!
//! Host builds (tests, hal-sim) link no linker script, so the script does nothing for them.

use std::env;
use std::error::Error;
use std::fs;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=memory");

    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    if arch != "arm" || os != "none" {
        return Ok(());
    }

    // `board` is the real STM32F405; everything else (the `qemu` firmware, a plain library
    // build) gets the emulated mps2-an386 map.
    let board = if env::var_os("CARGO_FEATURE_BOARD").is_some() {
        "stm32f405"
    } else {
        "mps2-an386"
    };
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR")?);
    let map = fs::read(manifest.join("memory").join(format!("{board}.x")))?;

    let out = PathBuf::from(env::var("OUT_DIR")?);
    fs::write(out.join("memory.x"), &map)?;
    fs::write(out.join("imu-ident-board.x"), &map)?;
    // Both maps include the shared `.ccmram` section.
    fs::copy(
        manifest.join("memory").join("ccmram.x"),
        out.join("ccmram.x"),
    )?;
    println!("cargo:rustc-link-search={}", out.display());
    Ok(())
}
