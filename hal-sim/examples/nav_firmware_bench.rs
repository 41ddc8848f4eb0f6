//! The navigation firmware's budget (issue 16, BENCHMARKS.md "Navigation firmware"): a simulated
//! drive (figure-eight course, MEMS IMU `ImuErrorModel::mems` at 100 Hz, 1 Hz GNSS, seed 7, one
//! 60-s GNSS gap) through `imu-ident-nav-qemu` under QEMU (`-icount shift=0`) and through the
//! host navigator in f32 and f64; prints one JSON object: instruction counts per class, stack
//! marks, statics, and the parity of the firmware's positions with both host runs (in units
//! of the host's position sigma).
//!
//!   cargo run --release -p hal-sim --example nav_firmware_bench -- ELF [MINUTES]
//!
//! (scripts/bench_firmware.sh runs it with the ELF it builds; MINUTES defaults to 20.)

use anyhow::{bail, Context, Result};
use hal_sim::nav::{run_with, NavArgs, NavRun};
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv, read_truth_csv};
use hal_sim::nav_qemu::{run_nav_firmware, NavEpoch};
use hal_sim::qemu::QemuConfig;

/// Worst position difference over the host's sigma (N, E, D), and its RMS.
fn parity(fw: &[NavEpoch], host: &NavRun) -> Result<(f64, f64)> {
    if fw.len() != host.epochs.len() {
        bail!("{} firmware epochs, {} host", fw.len(), host.epochs.len());
    }
    let (mut worst, mut ss, mut n) = (0.0f64, 0.0, 0.0);
    for (f, h) in fw.iter().zip(&host.epochs) {
        let ne = hal_sim::nav_io::outages::north_east(
            h.lat_deg,
            h.lon_deg,
            h.h,
            f.lat.to_degrees(),
            f.lon.to_degrees(),
        );
        for (d, s) in [ne[0], ne[1], f.h - h.h].iter().zip(h.sd_pos) {
            worst = worst.max(d.abs() / s);
            ss += (d / s).powi(2);
            n += 1.0;
        }
    }
    Ok((worst, (ss / n).sqrt()))
}

fn main() -> Result<()> {
    let mut argv = std::env::args().skip(1);
    let elf = argv
        .next()
        .context("usage: nav_firmware_bench ELF [MINUTES]")?;
    let minutes: f64 = argv.next().map_or(Ok(20.0), |m| m.parse())?;
    let dir = tempfile::tempdir()?;
    hal_sim::trajectory::write::simulate_drive_files(
        minutes / 60.0,
        100.0,
        7,
        (vec![(600.0, 660.0)], [0.0; 3]),
        dir.path(),
    )?;
    let truth = read_truth_csv(&dir.path().join("truth.csv"))?;
    let args = NavArgs {
        single: true,
        ..NavArgs::simulated(
            dir.path().join("imu.csv"),
            dir.path().join("gnss.csv"),
            hal_sim::trajectory::errors::ImuErrorModel::mems().to_core()?,
            "mems (true)",
            truth[0].rpy_deg[2],
        )
    };
    let imu = read_imu_csv(&args.imu)?;
    let fixes = read_gnss_csv(&args.gnss)?;
    let t = std::time::Instant::now();
    let fw = run_nav_firmware(elf.as_ref(), &args, &imu, &fixes, &QemuConfig::default())?;
    let wall = t.elapsed().as_secs_f64();
    if !fw.success() {
        bail!("firmware failed: {:?} {:?}", fw.status, fw.messages);
    }
    let h32 = run_with::<f32>(&args, &imu, &fixes)?;
    let h64 = run_with::<f64>(&args, &imu, &fixes)?;
    let (w32, r32) = parity(&fw.epochs, &h32)?;
    let (w64, r64) = parity(&fw.epochs, &h64)?;
    let out = serde_json::json!({
        "minutes": minutes,
        "imu_samples": imu.len(),
        "epochs": fw.epochs.len(),
        "fused": h32.epochs.iter().filter(|e| e.fused).count(),
        "qemu_wall_s": wall,
        "icount": fw.icount,
        "stack": fw.stack,
        "statics_bytes": fw.stack.first().map(|s| s.statics_end - 0x2000_0000),
        "parity_vs_host_f32": {"worst_sigma": w32, "rms_sigma": r32},
        "parity_vs_host_f64": {"worst_sigma": w64, "rms_sigma": r64},
    });
    println!("{}", serde_json::to_string_pretty(&out)?);
    Ok(())
}
