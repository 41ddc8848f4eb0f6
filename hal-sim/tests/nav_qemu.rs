//! On-target parity of the 3D INS/GNSS navigator (issue 16): a simulated 10-min drive (MEMS IMU
//! at 100 Hz, 1 Hz GNSS, one 40-s gap in the GNSS file and a 30-s outage withheld by the
//! schedule) through the `f32` navigation firmware under QEMU and
//! through the host driver `hal_sim::nav::run_with` (f32 and f64) on the same inputs.
//!
//! The firmware ELF comes from `IMU_IDENT_NAV_FIRMWARE_ELF` (scripts/test.sh sets it after the
//! release build of `imu-ident-nav-qemu`). Without it the test is skipped with a message,
//! except under `CI=true`, where it fails.
//!
//! Bounds (measured values in BENCHMARKS.md, "Navigation firmware"):
//! - firmware against host f32: the same arithmetic on the same `f32` inputs (the replay holds
//!   the values the host rounds to, and the start and every fix decision are shared code), so
//!   the only differences are the transcendental functions: the firmware's `libm` against the
//!   host's `std` (glibc) `sinf`/`cosf`/`expf`..., which may differ in the last bit. The bar is
//!   1e-3 of the position sigma (measured 1.1e-4: see the printout). That the platform's maths
//!   is the only source is checked without QEMU: the replay through the same loop on the host
//!   reproduces the host run bit for bit (`nav_replay_on_the_host_is_the_host_run_bit_for_bit`).
//! - firmware against host f64: within 0.05 sigma, the bar of the f32 core (nav_sim.rs).
//!
//! The same bars hold with the non-holonomic constraint on (`--nhc`, applied by the core's
//! `Nhc::after_step` in both runs), on a second drive whose heading comes from the GNSS course
//! (so the constraint starts with the first heading fix, a decision the replay carries), and
//! with zero-velocity updates (`--zupt`, the core's `Zupt::after_step`) on a stop-and-go drive
//! whose 120-s stop falls inside a 180-s outage.
//!
//! Memory: the QEMU map is the STM32F405's (128 KiB of SRAM, the bank in a 64 KiB region
//! standing for the CCM), so a static too large does not link, and `fits_the_f405` asserts
//! that the stack marks the firmware reports stay clear of the statics.

use std::path::PathBuf;

#[path = "nav_qemu_wire.rs"]
mod wire;

use hal_sim::nav::{run_with, NavArgs, NavRun};
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv};
use hal_sim::nav_qemu::{
    compare_online, encode_live_replay, encode_replay, run_nav_firmware, run_nav_firmware_bytes,
    NavEpoch, NavFirmwareRun, NAV_ELF_ENV,
};
use hal_sim::qemu::QemuConfig;
use imu_ident::nav::online::FIRMWARE_BANK;
use imu_ident::nav::replay::{gnss_flags, Decoder, Event, Record};
use imu_ident::nav::{ImuErrorModel, NavReplay, OnlineIdent, NAV_N};

/// The firmware ELF, or `None` (after saying why) when the test should be skipped.
fn firmware_elf() -> Option<PathBuf> {
    match std::env::var_os(NAV_ELF_ENV) {
        Some(p) => {
            let p = PathBuf::from(p);
            assert!(p.is_file(), "{NAV_ELF_ENV}={} is not a file", p.display());
            Some(p)
        }
        None if std::env::var("CI").as_deref() == Ok("true") => {
            panic!("{NAV_ELF_ENV} is not set under CI=true: run scripts/test.sh")
        }
        None => {
            eprintln!(
                "skipping the navigation QEMU test: {NAV_ELF_ENV} is not set \
                 (scripts/test.sh builds the firmware and sets it)"
            );
            None
        }
    }
}

fn mems() -> ImuErrorModel<f64> {
    hal_sim::trajectory::errors::ImuErrorModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"))
}

/// The simulated drive and the run's options (those of nav_sim.rs, with the gyro bias seeded
/// from the static window so that the replay carries it too).
fn drive(dir: &std::path::Path) -> NavArgs {
    drive_of(dir, 1.0 / 6.0, 16, vec![(400.0, 440.0)])
}

/// [`drive`] with the non-holonomic constraint: the same course (one figure-eight, climbs and
/// a speed dip; a shorter `hours` would drop them, leaving a straight run), seed 17, no gap in
/// the GNSS file, the scheduled 30-s outage at 250 s; heading from the GNSS course (no yaw
/// given); constraint sd 0.05 m/s at a point 0.65 m below the IMU.
fn drive_nhc(dir: &std::path::Path) -> NavArgs {
    NavArgs {
        yaw_deg: None,
        nhc: Some(0.05),
        nhc_lever: [0.0, 0.0, 0.65],
        ..drive_of(dir, 1.0 / 6.0, 17, vec![])
    }
}

/// The stop-and-go drive (`Profile::stop_and_go`, a 120-s stop from 260 s), seed 19, GNSS
/// withheld over [240 s, 420 s) from the simulation's start, the options of [`drive_of`] and
/// zero-velocity updates at 0.02 m/s with the default detector.
fn drive_zupt(dir: &std::path::Path) -> NavArgs {
    use hal_sim::trajectory::{gnss::GnssConfig, profile::Profile, write};
    let profile = Profile::stop_and_go(120.0).unwrap_or_else(|e| panic!("{e:#}"));
    let start = hal_sim::trajectory::write::course_start();
    let sim = hal_sim::trajectory::errors::ImuErrorModel::mems();
    let d = write::simulate_drive(&profile, start, 0.01, &sim, GnssConfig::default(), 19)
        .unwrap_or_else(|e| panic!("{e:#}"));
    write::write_drive(dir, &d).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&dir.join("gnss.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    let t_first = fixes.first().map_or(0.0, |f| f.t);
    let truth =
        hal_sim::nav_io::read_truth_csv(&dir.join("truth.csv")).unwrap_or_else(|e| panic!("{e:#}"));
    NavArgs {
        outages: Some(hal_sim::nav_io::OutageSpec {
            start: 240.0 - t_first,
            len: 180.0,
            period: 1e6,
            margin: 10.0,
        }),
        yaw_deg: Some(truth[0].rpy_deg[2]),
        zupt: Some(imu_ident::nav::Zupt {
            sd: 0.02,
            gyro_max: 0.15,
            accel_max: 0.6,
            speed_max: 0.5,
        }),
        ..drive_of_files(dir)
    }
}

/// A simulated drive of `hours` (seed, GNSS gaps, the antenna at `hal_sim::present`'s lever
/// arm) written into `dir`, and the run's options.
fn drive_of(dir: &std::path::Path, hours: f64, seed: u64, gaps: Vec<(f64, f64)>) -> NavArgs {
    let arm = hal_sim::present::LEVER_ARM;
    hal_sim::trajectory::write::simulate_drive_files(hours, 100.0, seed, (gaps, arm), dir)
        .unwrap_or_else(|e| panic!("{e:#}"));
    drive_of_files(dir)
}

/// The run's options for the drive already written into `dir` (`hal_sim::present`'s, the
/// heading given) with a 30-s outage at 250 s.
fn drive_of_files(dir: &std::path::Path) -> NavArgs {
    NavArgs {
        outages: Some(hal_sim::nav_io::OutageSpec {
            start: 250.0,
            len: 30.0,
            period: 1000.0,
            margin: 60.0,
        }),
        ..hal_sim::present::drive_options(dir, true, false).unwrap_or_else(|e| panic!("{e:#}"))
    }
}

/// Worst position difference (N, E, D, each over the host's sigma on that axis) and worst
/// relative sigma difference between the firmware and a host run.
fn compare(fw: &[NavEpoch], host: &NavRun) -> (f64, f64) {
    assert_eq!(fw.len(), host.epochs.len(), "epoch count");
    let (mut worst_pos, mut worst_sd) = (0.0f64, 0.0f64);
    for (f, h) in fw.iter().zip(&host.epochs) {
        assert_eq!(f.t.to_bits(), h.t.to_bits(), "epoch time");
        assert_eq!(
            f.flags & gnss_flags::WITHHELD != 0,
            h.withheld,
            "t = {}",
            h.t
        );
        assert_eq!(f.flags & gnss_flags::FUSE != 0, h.fused, "t = {}", h.t);
        let ne = hal_sim::nav_io::outages::north_east(
            h.lat_deg,
            h.lon_deg,
            h.h,
            f.lat.to_degrees(),
            f.lon.to_degrees(),
        );
        let d = [ne[0], ne[1], f.h - h.h];
        for ((d, fs), hs) in d.iter().zip(f.sd_pos).zip(h.sd_pos) {
            worst_pos = worst_pos.max(d.abs() / hs);
            worst_sd = worst_sd.max((f64::from(fs) - hs).abs() / hs);
        }
    }
    (worst_pos, worst_sd)
}

#[test]
fn qemu_firmware_nav_matches_the_host_navigator() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path());
    let (fw, h32) = parity_under_qemu(&elf, &args);
    let fused = h32.epochs.iter().filter(|e| e.fused).count();
    let withheld = h32.epochs.iter().filter(|e| e.withheld).count();
    assert!(
        withheld > 0 && fused > 300,
        "the drive should fuse most fixes and withhold some"
    );
    let classes: Vec<&str> = fw.icount.iter().map(|c| c.class.as_str()).collect();
    assert_eq!(
        classes,
        ["clock_stamp", "clock_pulse", "imu", "step", "nhc", "gnss"]
    );
    assert_eq!(fw.icount[4].n, 0, "no constraint without --nhc");
    fits_the_f405(&fw);
    clock_on_the_m4(&fw);
}

/// The GPS clock's start-up bench (`imu-ident-nav-qemu`'s `clock_bench`: 60 s of an 84-MHz
/// timer, a stamp every 10 ms, a pulse every second): a working clock (its worst stamp error
/// after the lock within a microsecond), and its cost in `f64` software arithmetic bounded
/// well below the navigator's: a stamp per sample against a sample's 38 000 instructions of
/// mechanisation, a pulse (the clock filter and the three shadows of its noise
/// identification) once a second against the 1-Hz filter step's 630 000.
fn clock_on_the_m4(fw: &NavFirmwareRun) {
    let get = |class: &str| {
        fw.icount
            .iter()
            .find(|c| c.class == class)
            .unwrap_or_else(|| panic!("no icount {class}"))
    };
    let (stamp, pulse) = (get("clock_stamp"), get("clock_pulse"));
    assert_eq!((stamp.n, pulse.n), (6000, 60));
    assert!(
        stamp.mean < 5_000 && pulse.mean < 60_000,
        "{stamp:?} {pulse:?}"
    );
    let worst = fw
        .messages
        .iter()
        .find_map(|m| m.strip_prefix("INFO clock worst_ns="))
        .and_then(|v| v.trim().parse::<f64>().ok())
        .unwrap_or_else(|| panic!("no clock line in {:?}", fw.messages));
    assert!(worst < 1000.0, "worst stamp error {worst} ns");
}

/// The firmware fits the STM32F405's RAM. The QEMU map is the F405's (memory/mps2-an386.x):
/// 128 KiB of SRAM from 0x2000_0000 for the statics and the stack, and the 64 KiB CCM region
/// for `.ccmram` (the bank), whose overflow would not link. The stack must stay clear of the
/// statics: the paint left below its deepest use is the margin (an overflow into the statics
/// reads as the whole gap used).
fn fits_the_f405(fw: &NavFirmwareRun) {
    const SRAM: u32 = 0x2000_0000;
    assert!(!fw.stack.is_empty(), "the firmware reported no stack marks");
    for s in &fw.stack {
        assert_eq!(s.ram_top, SRAM + 128 * 1024, "not the F405's RAM map");
        let free = s.ram_top - s.statics_end;
        assert!(
            s.high_water < free,
            "stack {}: {} B used of the {free} B between the statics and the top",
            s.phase,
            s.high_water
        );
    }
}

/// The parity check with the non-holonomic constraint on (`--nhc`): the firmware applies it
/// through the replay (sd, lever arm, heading-known flag) exactly where the host does, once
/// per filter step after the heading is known and above 1 m/s, GNSS or not.
#[test]
fn qemu_firmware_nav_with_the_constraint_matches_the_host_navigator() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive_nhc(dir.path());
    let (fw, h32) = parity_under_qemu(&elf, &args);
    let c = h32
        .summary
        .nhc
        .as_ref()
        .unwrap_or_else(|| panic!("no constraint summary"));
    eprintln!(
        "constraint: {} updates, {} gated, {} in outages",
        c.updates, c.gated, c.in_outages
    );
    assert!(
        c.updates > 200 && c.in_outages > 20,
        "the constraint should act most steps, outages included"
    );
    let nhc = fw.icount.iter().find(|k| k.class == "nhc");
    assert_eq!(
        nhc.map(|k| k.n),
        Some(c.updates as u32),
        "firmware constraint updates"
    );
    // The heading came from the course: no update before the first heading fix.
    assert!(h32.epochs.first().is_some_and(|e| !e.heading_known));
}

/// The parity check with zero-velocity updates (`--zupt`) on the stop-and-go drive: the
/// firmware detects rest and updates through the replay (sd and the detector's bounds) exactly
/// where the host does. Its updates are counted in the `step` class.
#[test]
fn qemu_firmware_nav_with_zero_velocity_updates_matches_the_host_navigator() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive_zupt(dir.path());
    let (_, h32) = parity_under_qemu(&elf, &args);
    let z = h32
        .summary
        .zupt
        .as_ref()
        .unwrap_or_else(|| panic!("no zero-velocity summary"));
    eprintln!(
        "zero-velocity updates: {} ({} gated, {} in the outage)",
        z.updates, z.gated, z.in_outages
    );
    assert!(z.in_outages >= 118, "{z:?}");
}

/// The parity check with the online identification by the bank (`--adapt-method bank`, from a
/// model 10x too large): the firmware starts the bank in its static from the replay's setup,
/// and decides and retunes where the host does. Its bank costs are in the `step` class (a step
/// predicts every shadow) and the `gnss` class (a fix is fused into every shadow).
#[test]
fn qemu_firmware_nav_with_the_online_identification_matches_the_host_navigator() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive_online(dir.path());
    let (fw, h32) = parity_under_qemu(&elf, &args);
    // With the bank (in the CCM) the SRAM still holds the statics and the stack.
    fits_the_f405(&fw);
    let log = h32.adapt.as_ref().unwrap_or_else(|| panic!("no adapt log"));
    eprintln!(
        "online identification: {} decisions, final log10 factors {:?}",
        log.searches.len(),
        log.searches.last().map(|s| &s.log10_factors)
    );
    // The firmware's telemetry of every decision: the same decisions at the same times, the
    // same factors and the same "identifiable" flags as the host's f32 run. The platforms
    // differ only in `libm`'s last bits: each fix's f32 log-likelihood by ~1e-7 relative, a
    // window's sums of ~300 of them by ~1e-4 nat, a Newton step (gradient over a curvature of
    // tens of nats per decade^2) by ~1e-5 decade. Bound 1e-4 decade, 600x below the smallest
    // offset (1/16 decade); the sds likewise within 1e-3 relative.
    let p = log.coordinates.len();
    assert_eq!(fw.online.len(), p * log.searches.len(), "{:?}", fw.online);
    for (k, s) in log.searches.iter().enumerate() {
        for i in 0..p {
            let r = &fw.online[k * p + i];
            assert_eq!((r.t, usize::from(r.i)), (s.t, i), "{r:?}");
            assert!(
                (r.x - s.log10_factors[i]).abs() <= 1e-4,
                "{r:?} against {}",
                s.log10_factors[i]
            );
            assert_eq!(r.identifiable, s.identifiable[i], "{r:?}");
            let (a, b) = (r.sd, s.cr_sd_log10[i]);
            assert!(
                a == b || (a - b).abs() <= 1e-3 * b.abs(),
                "{r:?} against {b}"
            );
        }
    }
    // The same comparison as `hal-sim nav --adapt --adapt-method bank --qemu-elf` writes to
    // `firmware.json`: every decision matched, within the bound above.
    let online = compare_online(&fw.online, log);
    eprintln!("online decisions, firmware against host: {online:?}");
    assert_eq!(online.decisions, [log.searches.len(); 2]);
    assert!(online.worst_factor_diff_decades <= 1e-4, "{online:?}");
    assert_eq!(online.flags_differ, 0);
}

/// Runs `args` through the firmware under QEMU and the host (f32 and f64), prints the parity
/// and instruction counts, asserts the bars (module docs); returns the firmware run and the
/// host f32 run.
fn parity_under_qemu(elf: &std::path::Path, args: &NavArgs) -> (NavFirmwareRun, NavRun) {
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));

    let started = std::time::Instant::now();
    let fw = run_nav_firmware(elf, args, &imu, &fixes, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let qemu_s = started.elapsed().as_secs_f64();
    assert!(
        fw.success(),
        "firmware failed: {:?}\nmessages: {:?}\nstderr: {}",
        fw.status,
        fw.messages,
        fw.stderr
    );
    let h32 = run_with::<f32>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let h64 = run_with::<f64>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let fused = h32.epochs.iter().filter(|e| e.fused).count();
    let withheld = h32.epochs.iter().filter(|e| e.withheld).count();
    eprintln!(
        "{} epochs, {fused} fused, {withheld} withheld",
        h32.epochs.len()
    );

    let (pos32, sd32, pos64, _) =
        report(&format!("nav QEMU ({qemu_s:.1} s wall)"), &fw, &h32, &h64);
    assert!(pos32 <= 1e-3, "firmware vs host f32: {pos32} sigma");
    assert!(
        sd32 <= 1e-3,
        "firmware vs host f32 sigma: {sd32} (relative)"
    );
    assert!(pos64 <= 0.05, "firmware vs host f64: {pos64} sigma");
    (fw, h32)
}

/// The firmware's loop on the host: the replay decoded and run through the library's
/// `NavReplay<f32>` must reproduce the host driver's `f32` run bit for bit (same start, same
/// decisions, same arithmetic), so that a firmware difference can only come from the platform
/// (its `libm` against the host's `std` maths). No QEMU needed: runs with the host tests.
#[test]
fn nav_replay_on_the_host_is_the_host_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (updates, host) = replay_matches_host_bit_for_bit(&drive(dir.path()));
    assert_eq!((updates, host.summary.nhc.is_none()), ([0, 0], true));
}

/// [`nav_replay_on_the_host_is_the_host_run_bit_for_bit`] with the non-holonomic constraint:
/// the replay loop (`NavReplay::imu`) applies it at the same steps as the host driver, with
/// the same result, because both call the core's `Nhc::after_step`.
#[test]
fn nav_replay_with_the_constraint_is_the_host_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (updates, host) = replay_matches_host_bit_for_bit(&drive_nhc(dir.path()));
    let c = host
        .summary
        .nhc
        .unwrap_or_else(|| panic!("no constraint summary"));
    assert!(c.updates > 200, "{} updates", c.updates);
    assert_eq!(updates, [c.updates, 0]);
}

/// [`nav_replay_on_the_host_is_the_host_run_bit_for_bit`] with zero-velocity updates, on the
/// stop-and-go drive: the replay loop detects rest and updates at the same steps as the host
/// driver, with the same result, because both call the core's `RestDetector` and
/// `Zupt::after_step`.
#[test]
fn nav_replay_with_zero_velocity_updates_is_the_host_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (updates, host) = replay_matches_host_bit_for_bit(&drive_zupt(dir.path()));
    let z = host
        .summary
        .zupt
        .unwrap_or_else(|| panic!("no zero-velocity summary"));
    // The 120-s stop inside the outage, and the rest after the alignment.
    assert!(z.in_outages >= 118, "{z:?}");
    assert_eq!(updates, [0, z.updates]);
}

/// [`drive`] started with every standard deviation 10x too large, identified online by the
/// core's bank of shadow filters (`--adapt --adapt-method bank`), decisions every 2 min from
/// 2 min, with the factors on the fixes' standard deviations (`--adapt-gnss-sd true`, the
/// default).
fn drive_online(dir: &std::path::Path) -> NavArgs {
    use hal_sim::nav::adapt::{AdaptConfig, AdaptMethod};
    let args = drive(dir);
    NavArgs {
        model: hal_sim::nav::model::scaled_sd(&args.model, 10.0),
        adapt: Some(AdaptConfig {
            method: AdaptMethod::Bank,
            bank: imu_ident::nav::OnlineConfig {
                first: 120.0,
                every: 120.0,
                // A finite memory: the replay carries it (version 5), as it carries the GNSS
                // factors' flag (version 6), and the firmware's window forgets as the host's
                // does.
                memory: 900.0,
                ..imu_ident::nav::OnlineConfig::DEFAULT
            },
            gnss_sd: true,
            ..AdaptConfig::DEFAULT
        }),
        ..args
    }
}

/// [`nav_replay_on_the_host_is_the_host_run_bit_for_bit`] with the online identification by
/// the bank: the replay loop (`NavReplay::imu`) starts the same bank from the replay's setup,
/// takes its decisions after the same steps and retunes the running filter the same way as
/// the host driver, because both run the core's `OnlineIdent`.
#[test]
fn nav_replay_with_the_online_identification_is_the_host_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive_online(dir.path());
    let (_, host) = replay_matches_host_bit_for_bit(&args);
    let log = host
        .adapt
        .as_ref()
        .unwrap_or_else(|| panic!("no adapt log"));
    let moved = log
        .searches
        .iter()
        .filter(|s| s.log10_factors.iter().any(|x| *x != 0.0))
        .count();
    assert!(log.searches.len() >= 3 && moved >= 1, "{:?}", log.searches);
    // The GNSS factors are the last two coordinates, so the replay covers their shadows too.
    let gnss = log.coordinates.iter().filter(|c| c.gnss_sd().is_some());
    assert_eq!(gnss.count(), 2, "{:?}", log.coordinates);
}

/// The replay of `args` through `NavReplay<f32>` on the host against `run_with::<f32>`:
/// asserts bit-for-bit equality at every epoch; returns the replay's constraint and
/// zero-velocity updates and the host run.
fn replay_matches_host_bit_for_bit(args: &NavArgs) -> ([usize; 2], NavRun) {
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    let bytes = encode_replay(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let mut dec = Decoder::new();
    // The bank (with `--adapt-method bank`) as the firmware keeps it: started in place.
    let mut bank = Box::new(OnlineIdent::<f32, NAV_N, FIRMWARE_BANK>::BLANK);
    let mut bank_slot = Some(&mut *bank);
    let mut run: Option<
        NavReplay<f32, NAV_N, Option<&mut OnlineIdent<f32, NAV_N, FIRMWARE_BANK>>>,
    > = None;
    let mut epochs = Vec::new();
    let mut updates = [0, 0];
    for &b in &bytes {
        match dec.push(b).unwrap_or_else(|e| panic!("{e}")) {
            None => {}
            Some(Event::Setup) => {
                let setup = dec.setup().unwrap_or_else(|| panic!("no setup"));
                let plain = NavReplay::<f32, NAV_N>::new(setup).unwrap_or_else(|e| panic!("{e:?}"));
                let obs = match (setup.online, bank_slot.take()) {
                    (Some(cfg), Some(b)) => {
                        b.start(cfg, plain.navigator(), setup.t0)
                            .unwrap_or_else(|e| panic!("{e:?}"));
                        Some(b)
                    }
                    _ => None,
                };
                run = Some(plain.with_observer(obs));
            }
            Some(Event::Record(r)) => {
                let run = run
                    .as_mut()
                    .unwrap_or_else(|| panic!("record before setup"));
                match r {
                    Record::Imu(r) => {
                        let done = run.imu(&r).unwrap_or_else(|e| panic!("{e:?}"));
                        updates[0] += usize::from(done.nhc.is_some());
                        updates[1] += usize::from(done.zupt.is_some());
                    }
                    Record::Gnss(r) => {
                        let fused = run.gnss(&r).unwrap_or_else(|e| panic!("{e:?}"));
                        let e = run.epoch(&r, fused.as_ref());
                        epochs.push(NavEpoch {
                            t: e.t,
                            lat: e.pos.lat,
                            lon: e.pos.lon,
                            h: e.pos.h,
                            vel: e.vel,
                            sd_pos: e.sd_pos,
                            flags: e.flags,
                        });
                    }
                }
            }
        }
    }
    dec.finish().unwrap_or_else(|e| panic!("{e}"));
    let host = run_with::<f32>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(epochs.len(), host.epochs.len());
    for (e, h) in epochs.iter().zip(&host.epochs) {
        assert_eq!(e.flags & 0x80 != 0, h.gated, "t = {}", h.t);
        assert_eq!(
            [e.lat.to_degrees(), e.lon.to_degrees(), e.h],
            [h.lat_deg, h.lon_deg, h.h],
            "t = {}",
            h.t
        );
        assert_eq!(e.vel.map(f64::from), h.vel, "t = {}", h.t);
        assert_eq!(e.sd_pos.map(f64::from), h.sd_pos, "t = {}", h.t);
    }
    let (pos, sd) = compare(&epochs, &host);
    assert_eq!((pos, sd), (0.0, 0.0));
    (updates, host)
}

#[test]
fn qemu_firmware_nav_rejects_a_corrupt_replay() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    // A short log: the simulator's first minute (the static window and a little driving).
    hal_sim::trajectory::write::simulate_drive_files(
        1.0 / 60.0,
        100.0,
        3,
        (vec![], [0.0; 3]),
        dir.path(),
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let mut args = drive_args_static(dir.path());
    args.align = 20.0;
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    let mut bytes = encode_replay(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let good = run_nav_firmware_bytes(&elf, &bytes, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert!(good.success(), "messages: {:?}", good.messages);
    let last = bytes.len() - 1;
    bytes[last] ^= 0x01;
    let bad = run_nav_firmware_bytes(&elf, &bytes, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert!(!bad.success(), "messages: {:?}", bad.messages);
    assert!(
        bad.messages.iter().any(|m| m.contains("BadChecksum")),
        "the failure should say why: {:?}",
        bad.messages
    );
}

/// The options of [`drive`] for a log already written in `dir`.
fn drive_args_static(dir: &std::path::Path) -> NavArgs {
    NavArgs {
        single: true,
        ..NavArgs::simulated(
            dir.join("imu.csv"),
            dir.join("gnss.csv"),
            mems(),
            "mems",
            0.0,
        )
    }
}

/// The live loop on the firmware (`imu_ident::nav::live`): the raw stream of the constraint's
/// drive in a live replay (every sample from the first, every fix unflagged, no outage
/// schedule), from which the firmware levels, places the run at its fix, takes the heading
/// from the course and decides every fix itself. Against the host's run of the same log,
/// which levels on the `f64` samples and decides on `f64` velocities where the live replay
/// holds them rounded to `f32`: the replay firmware's bars, 1e-3 sigma against host `f32`
/// and 0.05 sigma against host `f64`.
#[test]
fn qemu_firmware_live_start_matches_the_host_navigator() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (fw, _) = live_under_qemu(&elf, &drive_nhc(dir.path()), 1e-3);
    let heading = fw.epochs.iter().any(|e| e.flags & gnss_flags::HEADING != 0);
    assert!(heading, "no fix set the heading");
}

/// [`qemu_firmware_live_start_matches_the_host_navigator`] with the online identification's
/// bank, which the live loop starts when it places the run (inside the record loop, so the
/// stack of that call holds the navigator's construction and the bank's start): it fits the
/// F405, and takes the host's decisions (the host's comparison of `firmware.json`).
#[test]
fn qemu_firmware_live_start_with_the_online_identification_matches_the_host() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let (fw, h32) = live_under_qemu(&elf, &drive_online(dir.path()), 1e-3);
    let log = h32.adapt.as_ref().unwrap_or_else(|| panic!("no adapt log"));
    let online = compare_online(&fw.online, log);
    eprintln!("live online identification against the host: {online:?}");
    assert!(
        !log.searches.is_empty() && fw.online.len() == log.coordinates.len() * log.searches.len()
    );
    // The bound of the replay's comparison (1e-4 decade); the live start's inputs are the
    // replay's plus the window's samples and the heading's velocity rounded to f32.
    assert!(
        online.worst_factor_diff_decades <= 1e-4 && online.flags_differ == 0,
        "{online:?}"
    );
}

/// Runs the live replay of `args` under QEMU; checks it fits the F405 and its positions and
/// sigmas against the host's `f32` (`bar32` sigma) and `f64` (0.05 sigma) runs ([`streamed`]:
/// without the outage schedule).
fn live_under_qemu(elf: &std::path::Path, args: &NavArgs, bar32: f64) -> (NavFirmwareRun, NavRun) {
    let args = &streamed(args);
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    let bytes = encode_live_replay(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let fw = run_nav_firmware_bytes(elf, &bytes, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let h32 = run_with::<f32>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let h64 = run_with::<f64>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    at_parity("live QEMU", &fw, &h32, &h64, bar32);
    (fw, h32)
}

/// The firmware run `fw` succeeded, fits the F405, and is within `bar32` sigma of the host's
/// `f32` run and 0.05 sigma of its `f64` run (positions and sigmas; printed by [`report`]).
fn at_parity(label: &str, fw: &NavFirmwareRun, h32: &NavRun, h64: &NavRun, bar32: f64) {
    assert!(
        fw.success(),
        "firmware failed: {:?}\nmessages: {:?}\nstderr: {}",
        fw.status,
        fw.messages,
        fw.stderr
    );
    let (pos32, sd32, pos64, sd64) = report(label, fw, h32, h64);
    fits_the_f405(fw);
    assert!(pos32 < bar32 && sd32 < bar32, "{pos32} {sd32}");
    assert!(pos64 < 0.05 && sd64 < 0.05, "{pos64} {sd64}");
}

/// The real drive (`../shared/data/real/rtklib-drive-0708`; skipped with a message when the
/// data are missing, failed under `CI=true`) as a live replay: 9 min of a roof-mounted MEMS
/// IMU at 100 Hz and 4-Hz RTK fixes, the run levelled, placed and decided by the firmware
/// itself. Against the host's run of the same log (datasheet model, no outage schedule): 0.05
/// sigma against `f64`, the f32 core's bar; against `f32`, 1e-2 sigma: on this drive the
/// platforms' last-bit `libm` differences grow over four fusions a second, and the replay
/// firmware itself is 6.5e-3 sigma from the host's `f32` run (BENCHMARKS.md "Every fix fused";
/// the live firmware 2.1e-3, "Live input"). Without a latency budget and with the board's
/// kind of budget (0.25 s: the run a quarter of a second behind the newest sample, the output
/// predictor carrying it to the newest one, `imu_ident::nav::predictor`): the run is the same.
#[test]
fn qemu_firmware_live_on_the_real_drive_matches_the_host() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some(args) = real_drive(dir.path()) else {
        return;
    };
    for latency in [0.0, 0.25] {
        eprintln!("latency budget {latency} s:");
        let (fw, _) = live_under_qemu(
            &elf,
            &NavArgs {
                latency,
                ..args.clone()
            },
            1e-2,
        );
        assert!(fw.epochs.len() > 2000, "{} epochs", fw.epochs.len());
    }
}

/// The real drive's run options, or `None` when the data are missing outside CI
/// (`drive_0708` says why).
fn real_drive(dir: &std::path::Path) -> Option<NavArgs> {
    let (args, _, _) = hal_sim::nav::real::drive_0708(dir).unwrap_or_else(|e| panic!("{e:#}"))?;
    Some(args)
}

/// `args` as a stream runs them: without the outage schedule (a live run withholds nothing),
/// so that the host runs compared are the stream's.
fn streamed(args: &NavArgs) -> NavArgs {
    NavArgs {
        outages: None,
        ..args.clone()
    }
}

/// Prints the firmware run `fw` against the host's `f32` and `f64` runs (worst position and
/// relative sigma differences, as [`compare`]), its instruction counts and stack marks, and
/// returns the four differences.
fn report(label: &str, fw: &NavFirmwareRun, h32: &NavRun, h64: &NavRun) -> (f64, f64, f64, f64) {
    let (pos32, sd32) = compare(&fw.epochs, h32);
    let (pos64, sd64) = compare(&fw.epochs, h64);
    eprintln!(
        "{label} ({} epochs): firmware vs host f32: worst position {pos32:.2e} sigma, worst \
         sigma {sd32:.2e} (relative); vs host f64: {pos64:.2e} sigma, sigma {sd64:.2e}",
        fw.epochs.len()
    );
    for c in &fw.icount {
        eprintln!(
            "icount {}: n {} mean {} worst {} (at {})",
            c.class, c.n, c.mean, c.worst, c.worst_k
        );
    }
    for s in &fw.stack {
        eprintln!(
            "stack {}: high water {} B, statics {} B",
            s.phase,
            s.high_water,
            s.statics_end - 0x2000_0000
        );
    }
    (pos32, sd32, pos64, sd64)
}
