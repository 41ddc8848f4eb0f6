//! On-target smoke test: the single-precision firmware under QEMU must produce, step for step,
//! the telemetry of the double-precision host filter on the same log.
//!
//! The firmware ELF comes from `IMU_IDENT_FIRMWARE_ELF` (scripts/test.sh sets it after the
//! release build of `imu-ident-qemu`). Without it the test is skipped with a message, except
//! under `CI=true`, where a skipped on-target test would hide a broken pipeline: there it fails.

use std::path::PathBuf;

use hal_sim::qemu::{encode_log, run_firmware, run_firmware_bytes, QemuConfig};
use imu_ident::filter::InsFilter;
use imu_ident::model::InsModel;
use imu_ident::replay::{Replayer, Row};
use imu_ident::telemetry::{Record, MISSING, TIME_JUMP};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

const STEPS: usize = 600;
/// Start time: large enough that an `f32` time would visibly lose the 1 s step.
const T0: f64 = 1.0e7;

/// The firmware ELF, or `None` (after saying why) when the test should be skipped.
fn firmware_elf() -> Option<PathBuf> {
    match std::env::var_os("IMU_IDENT_FIRMWARE_ELF") {
        Some(p) => {
            let p = PathBuf::from(p);
            assert!(
                p.is_file(),
                "IMU_IDENT_FIRMWARE_ELF={} is not a file",
                p.display()
            );
            Some(p)
        }
        None if std::env::var("CI").as_deref() == Ok("true") => {
            panic!("IMU_IDENT_FIRMWARE_ELF is not set under CI=true: run scripts/test.sh")
        }
        None => {
            eprintln!(
                "skipping the QEMU smoke test: IMU_IDENT_FIRMWARE_ELF is not set \
                 (scripts/test.sh builds the firmware and sets it)"
            );
            None
        }
    }
}

/// A short log: a slow velocity-error swing under 0.03 m/s white noise (the paper model's
/// observation noise), with some missing observations and one 3 s gap, starting at 1e7 s.
fn make_log() -> Vec<(f64, f64)> {
    let mut rng = ChaCha8Rng::seed_from_u64(20261122);
    let noise = Normal::new(0.0, 0.03).unwrap_or_else(|e| panic!("{e}"));
    let mut t = T0;
    (0..STEPS)
        .map(|k| {
            t += if k == 400 { 4.0 } else { 1.0 };
            let truth = 0.05 * (2.0 * std::f64::consts::PI * k as f64 / 300.0).sin();
            let z = if k % 97 == 13 {
                f64::NAN
            } else {
                truth + noise.sample(&mut rng)
            };
            (t, z)
        })
        .collect()
}

/// The same replay on the host, in double precision, on the same `f32` observations.
fn host_records(log: &[(f64, f64)]) -> Vec<Record> {
    let filter = InsFilter::new(InsModel::<f64>::paper()).unwrap_or_else(|e| panic!("{e}"));
    let mut replay = Replayer::new(filter);
    log.iter()
        .map(|&(t, z)| replay.step(Row { t, z: z as f32 }))
        .collect()
}

fn same_f32(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn qemu_firmware_matches_the_host_filter() {
    let Some(elf) = firmware_elf() else { return };
    let log = make_log();
    let run = run_firmware(&elf, &log, &QemuConfig::default()).unwrap_or_else(|e| panic!("{e:#}"));
    assert!(
        run.success(),
        "firmware failed: {:?}\nmessages: {:?}\nstderr: {}",
        run.status,
        run.messages,
        run.stderr
    );
    assert!(
        run.messages
            .iter()
            .any(|m| m.contains(&format!("replay done rows={STEPS}"))),
        "no completion message: {:?}",
        run.messages
    );

    let host = host_records(&log);
    assert_eq!(run.records.len(), host.len(), "record count");
    assert!(
        host.iter().any(|r| r.has(MISSING)),
        "the log should exercise MISSING"
    );
    assert!(
        host.iter().any(|r| r.has(TIME_JUMP)),
        "the log should exercise TIME_JUMP"
    );

    let mut worst_delta = 0.0f64;
    let mut worst_nis = 0.0f64;
    for (fw, h) in run.records.iter().zip(&host) {
        let at = format!("step {}: firmware {fw:?}\nhost {h:?}", h.k);
        assert_eq!(fw.k, h.k, "{at}");
        assert_eq!(
            fw.t.to_bits(),
            h.t.to_bits(),
            "time must survive bit-exactly; {at}"
        );
        assert!(same_f32(fw.z, h.z), "observation; {at}");
        assert_eq!(fw.flags, h.flags, "flags; {at}");

        // The tilt estimate: within 5 % of its own standard deviation.
        let err = f64::from((fw.delta - h.delta).abs()) / f64::from(h.sigma_delta);
        assert!(err <= 0.05, "delta differs by {err:.3} sigma; {at}");
        worst_delta = worst_delta.max(err);

        // NIS: close in absolute terms for small values, relatively for large ones.
        if h.has(MISSING) {
            assert!(fw.nis.is_nan(), "missing steps have no NIS; {at}");
        } else {
            let d = f64::from((fw.nis - h.nis).abs()) / f64::from(h.nis).max(1.0);
            assert!(d <= 1e-2, "NIS differs by {d:.2e}; {at}");
            worst_nis = worst_nis.max(d);
            let s = f64::from((fw.variance - h.variance).abs() / h.variance);
            assert!(
                s <= 1e-3,
                "innovation variance differs by {s:.2e} (relative); {at}"
            );
        }
    }
    eprintln!(
        "QEMU smoke: {} steps agree; worst |delta diff| = {worst_delta:.2e} sigma, worst NIS diff = {worst_nis:.2e}",
        host.len()
    );
}

#[test]
fn qemu_firmware_fails_on_a_corrupt_log() {
    let Some(elf) = firmware_elf() else { return };
    let mut bytes = encode_log(&make_log()[..20]).unwrap_or_else(|e| panic!("{e:#}"));
    let last = bytes.len() - 1;
    bytes[last] ^= 0x01; // break the checksum
    let run = run_firmware_bytes(&elf, &bytes, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert!(
        !run.success(),
        "a corrupt log must fail the run; messages: {:?}",
        run.messages
    );
    assert!(
        run.messages.iter().any(|m| m.contains("BadChecksum")),
        "the failure should say why: {:?}",
        run.messages
    );
}
