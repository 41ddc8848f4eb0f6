//! Finding, and when needed building, the QEMU firmware that `hal-sim qemu` runs, and saying how
//! to get every external tool that takes.
//!
//! With an ELF given (`--elf` or `$IMU_IDENT_FIRMWARE_ELF`) that file is used as it is. Otherwise
//! the ELF is `<target dir>/thumbv7em-none-eabihf/release/imu-ident-qemu` of the imu-ident
//! sources this hal-sim was built from (`$CARGO_TARGET_DIR`, else `target/` in the workspace),
//! and it is built with [`BUILD_COMMAND`] when it is missing or older than any of its sources,
//! so that `hal-sim qemu` never runs a firmware that differs from the code beside it. A missing
//! tool (cargo, the Cortex-M4F target, QEMU) is an error that prints the command installing it.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

use anyhow::{bail, Context, Result};

/// The Cortex-M4F target of the firmware.
pub const TARGET: &str = "thumbv7em-none-eabihf";
/// The firmware binary run under QEMU.
pub const BIN: &str = "imu-ident-qemu";
/// How the firmware is built (from the workspace root).
pub const BUILD_COMMAND: &str = "cargo build --release -p imu-ident --target thumbv7em-none-eabihf --features qemu --bin imu-ident-qemu";
/// How to get the Cortex-M4F target.
pub const TARGET_HINT: &str = "rustup target add thumbv7em-none-eabihf";
/// How to get QEMU (Debian; `sudo` when not root).
pub const QEMU_HINT: &str = "apt-get update && apt-get install -y qemu-system-arm";
/// How to get cargo.
pub const CARGO_HINT: &str = "install Rust with rustup: https://rustup.rs (curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh)";
/// The variable naming a prebuilt ELF.
pub const ELF_ENV: &str = "IMU_IDENT_FIRMWARE_ELF";

/// Files and folders (relative to the workspace root) the firmware is built from: an ELF older
/// than any file in them is rebuilt.
const SOURCES: &[&str] = &[
    "src",
    "Cargo.toml",
    "Cargo.lock",
    "build.rs",
    "memory.x",
    "memory",
    ".cargo/config.toml",
];

/// The imu-ident workspace this hal-sim was compiled from (the parent of hal-sim's manifest
/// folder), if it is still there.
pub fn workspace_root() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()?
        .to_path_buf();
    root.join("src")
        .join("bin")
        .join("qemu.rs")
        .is_file()
        .then_some(root)
}

/// The default ELF path under `root`, honouring `$CARGO_TARGET_DIR` (relative to `root` when
/// relative, as cargo resolves it from the root).
pub fn default_elf(root: &Path) -> PathBuf {
    let target_dir = std::env::var_os("CARGO_TARGET_DIR")
        .filter(|v| !v.is_empty())
        .map_or_else(|| root.join("target"), |d| root.join(d));
    target_dir.join(TARGET).join("release").join(BIN)
}

/// The newest modification time of the files under `paths` (folders walked recursively).
fn newest_mtime(paths: impl IntoIterator<Item = PathBuf>) -> Result<Option<SystemTime>> {
    let mut newest = None;
    let mut stack: Vec<PathBuf> = paths.into_iter().collect();
    while let Some(p) = stack.pop() {
        let Ok(meta) = std::fs::metadata(&p) else {
            continue; // an optional source (e.g. no .cargo/config.toml)
        };
        if meta.is_dir() {
            for entry in
                std::fs::read_dir(&p).with_context(|| format!("listing {}", p.display()))?
            {
                stack.push(entry?.path());
            }
        } else {
            let m = meta.modified()?;
            newest = Some(newest.map_or(m, |n: SystemTime| n.max(m)));
        }
    }
    Ok(newest)
}

/// True when `elf` is missing or older than a source of the firmware under `root`.
pub fn is_stale(elf: &Path, root: &Path) -> Result<bool> {
    let Ok(built) = std::fs::metadata(elf).and_then(|m| m.modified()) else {
        return Ok(true);
    };
    let newest = newest_mtime(SOURCES.iter().map(|s| root.join(s)))?;
    Ok(newest.is_some_and(|n| n > built))
}

/// The program `name` answers `--version` (it exists and runs).
fn runs(program: &Path) -> bool {
    Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// cargo: `$CARGO` (set when hal-sim itself runs under cargo), else `cargo` on PATH.
fn cargo() -> PathBuf {
    std::env::var_os("CARGO").map_or_else(|| PathBuf::from("cargo"), PathBuf::from)
}

/// The rustc sysroot has the library of [`TARGET`] (works with and without rustup).
fn target_installed(root: &Path) -> bool {
    let rustc = std::env::var_os("RUSTC").map_or_else(|| PathBuf::from("rustc"), PathBuf::from);
    Command::new(rustc)
        .args(["--print", "sysroot"])
        .current_dir(root)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .is_some_and(|o| {
            let sysroot = String::from_utf8_lossy(&o.stdout).trim().to_string();
            Path::new(&sysroot)
                .join("lib/rustlib")
                .join(TARGET)
                .join("lib")
                .is_dir()
        })
}

/// An error listing what is missing to run the firmware and the commands that get it.
pub fn missing_tools_error(missing: &[(&str, &str)], why: &str) -> anyhow::Error {
    let mut msg = format!("{why}; missing:");
    for (what, how) in missing {
        msg.push_str(&format!("\n  - {what}: {how}"));
    }
    anyhow::anyhow!(msg)
}

/// What `hal-sim qemu` needs and lacks: QEMU, and when the firmware must be built, cargo and
/// the target; each with the command that gets it.
fn missing_tools(qemu: &Path, root: Option<&Path>) -> Vec<(String, &'static str)> {
    let mut missing = Vec::new();
    if !runs(qemu) {
        missing.push((
            format!(
                "{} (QEMU for the emulated Cortex-M4F board)",
                qemu.display()
            ),
            QEMU_HINT,
        ));
    }
    if let Some(root) = root {
        if !runs(&cargo()) {
            missing.push(("cargo (to build the firmware)".to_string(), CARGO_HINT));
        } else if !target_installed(root) {
            missing.push((
                format!("the Rust target {TARGET} (to build the firmware)"),
                TARGET_HINT,
            ));
        }
    }
    missing
}

/// The ELF `hal-sim qemu` runs under `qemu`: `elf`, else `$IMU_IDENT_FIRMWARE_ELF`, else the
/// default path, built first with [`BUILD_COMMAND`] when it is missing or older than its
/// sources (cargo's output goes to this process's stderr). A missing tool is an error listing
/// every missing tool with the command that installs it.
pub fn prepare(elf: Option<PathBuf>, qemu: &Path) -> Result<PathBuf> {
    let given = elf.or_else(|| std::env::var_os(ELF_ENV).map(PathBuf::from));
    let (elf, build_in) = match given {
        Some(p) => {
            if !p.is_file() {
                bail!(
                    "firmware ELF {}: no such file (build it with `{BUILD_COMMAND}`, or leave \
                     out --elf and {ELF_ENV} to have hal-sim build it)",
                    p.display()
                );
            }
            (p, None)
        }
        None => {
            let Some(root) = workspace_root() else {
                bail!(
                    "no firmware ELF given and the imu-ident sources this hal-sim was built \
                     from ({}) are gone: give --elf or set {ELF_ENV} (build it with \
                     `{BUILD_COMMAND}`)",
                    env!("CARGO_MANIFEST_DIR")
                );
            };
            let elf = default_elf(&root);
            let stale = is_stale(&elf, &root)?;
            (elf, stale.then_some(root))
        }
    };
    let missing = missing_tools(qemu, build_in.as_deref());
    if !missing.is_empty() {
        let mut msg = "cannot run the firmware under QEMU".to_string();
        if let Some(root) = &build_in {
            msg.push_str(&format!(
                " ({} is missing or older than its sources; it is built with `{BUILD_COMMAND}` \
                 in {})",
                elf.display(),
                root.display()
            ));
        }
        let list: Vec<(&str, &str)> = missing.iter().map(|(w, h)| (w.as_str(), *h)).collect();
        return Err(missing_tools_error(&list, &msg));
    }
    if let Some(root) = build_in {
        build_firmware(&root, &elf)?;
    }
    Ok(elf)
}

/// Builds the firmware in `root` with [`BUILD_COMMAND`]; `elf` is where it must appear.
pub fn build_firmware(root: &Path, elf: &Path) -> Result<()> {
    let cargo = cargo();
    eprintln!(
        "hal-sim: building the firmware (missing or older than its sources): {BUILD_COMMAND}"
    );
    let args: Vec<&str> = BUILD_COMMAND.split_whitespace().skip(1).collect();
    let status = Command::new(&cargo)
        .args(&args)
        // The workspace root: cargo reads .cargo/config.toml (linker scripts) from there.
        .current_dir(root)
        .status()
        .with_context(|| format!("running {}", cargo.display()))?;
    if !status.success() {
        bail!(
            "building the firmware failed ({status}): `{BUILD_COMMAND}` in {}",
            root.display()
        );
    }
    if !elf.is_file() {
        bail!(
            "`{BUILD_COMMAND}` succeeded but {} is not there (CARGO_TARGET_DIR?)",
            elf.display()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_build_command_builds_the_default_binary() {
        assert!(BUILD_COMMAND.contains(TARGET) && BUILD_COMMAND.ends_with(BIN));
        assert!(TARGET_HINT.ends_with(TARGET));
    }

    #[test]
    fn a_missing_elf_is_stale_and_a_fresh_one_is_not() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let root = dir.path();
        std::fs::create_dir_all(root.join("src")).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(root.join("src/lib.rs"), "").unwrap_or_else(|e| panic!("{e}"));
        let elf = root.join("fw.elf");
        assert!(is_stale(&elf, root).unwrap_or_else(|e| panic!("{e}")));
        std::thread::sleep(std::time::Duration::from_millis(20));
        std::fs::write(&elf, "").unwrap_or_else(|e| panic!("{e}"));
        assert!(!is_stale(&elf, root).unwrap_or_else(|e| panic!("{e}")));
        std::thread::sleep(std::time::Duration::from_millis(20));
        std::fs::write(root.join("src/lib.rs"), "// edited").unwrap_or_else(|e| panic!("{e}"));
        assert!(is_stale(&elf, root).unwrap_or_else(|e| panic!("{e}")));
    }

    #[test]
    fn missing_tools_are_listed_with_their_commands() {
        let e = missing_tools_error(&[("qemu", QEMU_HINT), ("target", TARGET_HINT)], "cannot");
        let msg = format!("{e}");
        assert!(msg.contains("apt-get install -y qemu-system-arm"), "{msg}");
        assert!(
            msg.contains("rustup target add thumbv7em-none-eabihf"),
            "{msg}"
        );
    }
}
