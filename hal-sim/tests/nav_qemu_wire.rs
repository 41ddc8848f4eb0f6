//! The emulated board fed by its serial wire: a log written as IMU frames and a u-blox
//! receiver's `NAV-TIMEGPS` / `NAV-PVT` messages (`hal_sim::nav_qemu::wire_of`) goes through
//! the core's decoders (`imu_ident::nav::serial`) into the firmware's live loop, as a board's
//! ports would feed it; against the host run on what the wire carried (the samples in `f32`,
//! the fixes as decoded: `nav_wire.rs` shows that host run is the wire's on the host, bit for
//! bit). Bars as for the live replay (`live_under_qemu`): the platform's maths only. With every
//! fix late and no budget, against the host's live runs on the same inputs (the late path,
//! `imu_ident::nav::navigator::history`). With the board's budget, the solution at the newest
//! sample the firmware sends (`now`) against the host's output predictor.

use super::{at_parity, drive_nhc, drive_online, firmware_elf, real_drive, streamed};
use hal_sim::nav::{run_with, NavArgs, NavRun};
use hal_sim::nav_io::ubx::{as_sent, ubx_fixes};
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv};
use hal_sim::nav_qemu::{run_nav_firmware_wire, wire_of, NavEpoch, NavFirmwareRun};
use hal_sim::qemu::QemuConfig;
use imu_ident::nav::live::{LiveEvent, LiveNav};
use imu_ident::nav::serial::{feed, NavInput};
use imu_ident::nav::{Epoch, NAV_N};

/// Runs `args`' log over the wire under QEMU; checks it fits the F405, that the wire lost
/// nothing, and the positions and sigmas against the host's `f32` run (within `bar32` sigma)
/// and `f64` run (0.05 sigma).
fn wire_under_qemu(elf: &std::path::Path, args: &NavArgs, bar32: f64) -> (NavFirmwareRun, NavRun) {
    let args = &streamed(args);
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    let wire = wire_of(args, &imu, &fixes, 0.0).unwrap_or_else(|e| panic!("{e:#}"));
    let fw = run_nav_firmware_wire(elf, args, &wire, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let as_sent = as_sent(&imu);
    let (carried, _) = ubx_fixes(&wire, None);
    assert_eq!(carried.len(), fixes.len());
    let h32 = run_with::<f32>(args, &as_sent, &carried).unwrap_or_else(|e| panic!("{e:#}"));
    let h64 = run_with::<f64>(args, &as_sent, &carried).unwrap_or_else(|e| panic!("{e:#}"));
    at_parity("serial wire QEMU", &fw, &h32, &h64, bar32);
    // The firmware's decoders refuse what the host's do: on a line the IMU and the receiver
    // share, a sync pattern inside a UBX message starts an IMU candidate the CRC refuses (3 on
    // the real drive: 3 of its 2104 fixes' 124 bytes hold one; random bytes would hold about
    // 12, 3 patterns in 65 536 byte pairs); nothing else.
    let (_, c) = hal_sim::nav_io::ubx::wire_inputs(&wire, None);
    let counts = format!(
        "wire imu_rejected={} ubx_rejected=0 no_fix=0 no_week=0",
        c.imu_rejected
    );
    assert!(
        fw.messages.iter().any(|m| m.contains(&counts)),
        "{counts}: {:?}",
        fw.messages
    );
    let ubx_bytes = wire.len() - 38 * imu.len();
    assert!(
        f64::from(c.imu_rejected) <= 3.0 * ubx_bytes as f64 / 65_536.0,
        "{c:?}"
    );
    (fw, h32)
}

/// A simulated drive, heading from the course and the constraint on: the board levels, places
/// the run and decides every fix from what its ports deliver.
#[test]
fn qemu_firmware_on_the_serial_wire_matches_the_host() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive_nhc(dir.path());
    let (fw, _) = wire_under_qemu(&elf, &args, 1e-3);
    assert!(fw.epochs.len() > 300, "{} epochs", fw.epochs.len());
}

/// With the online identification's bank, started by the live loop inside the wire's read
/// loop: the deepest stack of the firmware, which must still fit the F405.
#[test]
fn qemu_firmware_on_the_serial_wire_with_the_bank_fits_and_matches_the_host() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive_online(dir.path());
    let (fw, _) = wire_under_qemu(&elf, &args, 1e-3);
    assert!(!fw.online.is_empty(), "the bank made no decision");
}

/// The real drive (`../shared/data/real/rtklib-drive-0708`; skipped with a message when the
/// data are missing, failed under `CI=true`) over the wire: 100-Hz frames and 4-Hz `NAV-PVT`.
/// The bar against f32 is the live replay's there (1e-2).
#[test]
fn qemu_firmware_on_the_serial_wire_of_the_real_drive_matches_the_host() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let Some(args) = real_drive(dir.path()) else {
        return;
    };
    let (fw, _) = wire_under_qemu(&elf, &args, 1e-2);
    assert!(fw.epochs.len() > 2000, "{} epochs", fw.epochs.len());
}

/// The drive of the first test from a hub that stamps its samples with its own 84-MHz timer,
/// 30 ppm fast, and captures the receiver's pulses on it (`imu_ident::nav::counted`): the
/// board puts them on GPS time with its `TimerStamps` (the GPS clock in `f64`, in software).
/// Against the host runs on the samples the host's `TimerStamps` stamped from the same wire:
/// the same samples dropped before the lock, the same pulses used, and the positions at the
/// live runs' bars. (That those stamps are within 1 us of GPS time, and the run the
/// GPS-stamped wire's within 0.01 sigma: `nav_clock::a_counting_hubs_wire_...`.)
#[test]
fn qemu_firmware_on_a_counting_hubs_wire_matches_the_host() {
    use hal_sim::clock::oscillator_spec;
    use hal_sim::nav_io::ubx::{stamped_inputs, HUB_TIMER_HZ};
    use hal_sim::nav_qemu::counted_wire_of;
    use hal_sim::trajectory::oscillator::Oscillator;
    use imu_ident::nav::gps_clock::ClockConfig;
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = &streamed(&drive_nhc(dir.path()));
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    // The firmware's hub timer (`nav_support::HUB_TIMER_HZ`, the host's the same).
    let cfg = ClockConfig::crystal(HUB_TIMER_HZ);
    let mut osc = Oscillator::new(oscillator_spec(&cfg, 30e-6, 1.0), imu[0].t - 2.0, 65_712);
    let wire =
        counted_wire_of(args, &imu, &fixes, 0.0, &mut osc).unwrap_or_else(|e| panic!("{e:#}"));
    let fw = run_nav_firmware_wire(&elf, args, &wire, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    let (inputs, _, stamps) = stamped_inputs(&wire, cfg).unwrap_or_else(|e| panic!("{e:#}"));
    let stamped = hal_sim::nav_io::ubx::samples_of(&inputs);
    let (carried, _) = ubx_fixes(&wire, None);
    assert_eq!(carried.len(), fixes.len());
    let h32 = run_with::<f32>(args, &stamped, &carried).unwrap_or_else(|e| panic!("{e:#}"));
    let h64 = run_with::<f64>(args, &stamped, &carried).unwrap_or_else(|e| panic!("{e:#}"));
    at_parity("counting hub's wire QEMU", &fw, &h32, &h64, 1e-3);
    let c = stamps.counts();
    let host = format!(
        "stamps unstamped={} used={} unpaired={} rejected={} restarts={}",
        stamps.unstamped(),
        c.used,
        c.unpaired,
        c.rejected,
        c.restarts
    );
    println!(
        "host {host}; firmware {:?}",
        fw.messages.iter().find(|m| m.contains("stamps"))
    );
    assert!(
        fw.messages.iter().any(|m| m.contains(&host)),
        "{host}: {:?}",
        fw.messages
    );
    assert!(stamps.unstamped() < 400 && fw.epochs.len() > 300);
}

/// A host live run in `T` on the wire's inputs: its epochs, and after every sample the
/// solution at the newest sample ([`LiveNav::present`]) with the run's position and attitude
/// sigmas (the present has none of its own).
struct HostLive<T: imu_ident::Real> {
    epochs: Vec<Epoch<T>>,
    present: Vec<HostPresent>,
}

/// The host's solution at the newest sample.
struct HostPresent {
    /// The samples given to the live loop so far, this one included.
    k: usize,
    t: f64,
    pos: imu_ident::strapdown::Geodetic,
    /// Roll, pitch, yaw [rad].
    euler: [f64; 3],
    /// The run's sigmas of position N, E, D [m] and attitude [rad].
    sd_pos: [f64; 3],
    sd_att: [f64; 3],
    /// The present's standard deviations (`LiveNav::present_sd`): attitude, velocity and
    /// position, N, E, D each.
    present_sd: [f64; 9],
}

/// [`HostLive`] of `args` (its latency budget) on `inputs`.
fn host_live<T: imu_ident::Real>(args: &NavArgs, inputs: &[NavInput]) -> HostLive<T> {
    use imu_ident::nav::nav_idx::{ATT, POS};
    let mut nav = LiveNav::<T, NAV_N>::new(
        hal_sim::nav::setup::settings(args),
        hal_sim::nav::setup::live_config(args),
        LiveNav::<T, NAV_N>::no_observer,
    );
    let mut epochs = Vec::new();
    let mut present = Vec::new();
    let mut k = 0;
    let mut take = |e: LiveEvent<'_, T>| {
        if let LiveEvent::Fix { epoch, .. } = e {
            epochs.push(*epoch);
        }
    };
    for i in inputs {
        let _ = feed(&mut nav, i, &mut take);
        k += usize::from(matches!(i, NavInput::Imu(_)));
        if let (NavInput::Imu(_), Some(now), Some(run)) = (i, nav.present(), nav.run()) {
            let sd = run.navigator().sigma_si().map(|v| v.as_f64());
            let s = nav
                .present_sd()
                .unwrap_or_else(|| panic!("no sd at {}", now.time()));
            let mut present_sd = [0.0; 9];
            for (o, v) in present_sd
                .iter_mut()
                .zip(s.att.iter().chain(&s.vel).chain(&s.pos))
            {
                *o = v.as_f64();
            }
            let (roll, pitch, yaw) = now.ins().attitude_f64().euler();
            present.push(HostPresent {
                k,
                t: now.time(),
                pos: now.ins().position(),
                euler: [roll, pitch, yaw],
                sd_pos: [sd[POS], sd[POS + 1], sd[POS + 2]],
                sd_att: [sd[ATT], sd[ATT + 1], sd[ATT + 2]],
                present_sd,
            });
        }
    }
    nav.flush(&mut take)
        .unwrap_or_else(|e| panic!("flush: {e:?}"));
    HostLive { epochs, present }
}

/// Worst position difference of the firmware's epochs `fw` from the host's `host` (the same
/// times, bit for bit), in units of the host's position sigma.
fn epochs_apart<T: imu_ident::Real>(fw: &[NavEpoch], host: &[Epoch<T>]) -> f64 {
    assert_eq!(fw.len(), host.len());
    let mut worst = 0.0f64;
    for (f, h) in fw.iter().zip(host) {
        assert_eq!(f.t.to_bits(), h.t.to_bits());
        let sd = h.sd_pos.map(|v| v.as_f64());
        worst = worst.max(apart(&h.pos, [f.lat, f.lon, f.h], &sd));
    }
    worst
}

/// Largest of the N, E and D distances of the position `(lat, lon, h)` [rad, rad, m] from
/// `at`, each over its sigma `sd`.
fn apart(at: &imu_ident::strapdown::Geodetic, [lat, lon, h]: [f64; 3], sd: &[f64; 3]) -> f64 {
    let ne = hal_sim::nav_io::outages::north_east(
        at.lat.to_degrees(),
        at.lon.to_degrees(),
        at.h,
        lat.to_degrees(),
        lon.to_degrees(),
    );
    [ne[0], ne[1], h - at.h]
        .iter()
        .zip(sd)
        .fold(0.0f64, |w, (d, s)| w.max(d.abs() / s))
}

/// The emulated board on the wire of `args`' log with every fix `delay` s late, and the
/// inputs the wire carried (for the host's live runs).
fn late_wire(elf: &std::path::Path, args: &NavArgs, delay: f64) -> (NavFirmwareRun, Vec<NavInput>) {
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    let wire = wire_of(args, &imu, &fixes, delay).unwrap_or_else(|e| panic!("{e:#}"));
    let fw = run_nav_firmware_wire(elf, args, &wire, &QemuConfig::default())
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert!(fw.success(), "{:?} {:?}", fw.status, fw.messages);
    let (inputs, _) = hal_sim::nav_io::ubx::wire_inputs(&wire, None);
    (fw, inputs)
}

/// A receiver 0.25 s late and no latency budget (the board's other choice): every fix reaches
/// the live loop 25 samples after its time and is compared with the solution moved back
/// along the velocities the navigator keeps (`imu_ident::nav::navigator::history`). The
/// emulated M4 against the host's live runs on what the wire carried, epoch by epoch: within
/// 1e-3 sigma of position of the `f32` run and 0.05 sigma of the `f64` one (the bars of
/// `qemu_firmware_on_the_serial_wire_matches_the_host`).
#[test]
fn qemu_firmware_takes_late_fixes_as_the_host_live_loop() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = streamed(&drive_nhc(dir.path()));
    let (fw, inputs) = late_wire(&elf, &args, 0.25);
    let (h32, h64) = (
        host_live::<f32>(&args, &inputs),
        host_live::<f64>(&args, &inputs),
    );
    assert!(fw.epochs.len() > 300, "{} epochs", fw.epochs.len());
    let worst = [
        epochs_apart(&fw.epochs, &h32.epochs),
        epochs_apart(&fw.epochs, &h64.epochs),
    ];
    eprintln!(
        "late fixes (0.25 s, no budget) on the M4: worst position {:.2e} sigma from the host's \
         f32 live run, {:.2e} from f64",
        worst[0], worst[1]
    );
    assert!(worst[0] < 1e-3 && worst[1] < 0.05, "{worst:?}");
}

/// The worst differences of the firmware run `fw` from the host's `h`: its `now` frames'
/// positions and attitudes, and its epochs' positions, in units of the host run's sigmas; and
/// the frames' standard deviations relative to the host's.
fn present_apart<T: imu_ident::Real>(fw: &NavFirmwareRun, h: &HostLive<T>) -> [f64; 4] {
    // The firmware sends a frame after every tenth sample when there is a present
    // (`PRESENT_EVERY` in `src/bin/nav_support`): as many as the host has, at the same times.
    let host: Vec<&HostPresent> = h.present.iter().filter(|p| p.k % 10 == 0).collect();
    assert_eq!(fw.present.len(), host.len());
    let mut w = [0.0f64; 4];
    for (f, p) in fw.present.iter().zip(host) {
        assert_eq!(f.t.to_bits(), p.t.to_bits());
        let sent = f.sd_att.iter().chain(&f.sd_vel).chain(&f.sd_pos);
        for (a, b) in sent.zip(p.present_sd) {
            w[3] = w[3].max((f64::from(*a) - b).abs() / b);
        }
        w[0] = w[0].max(apart(&p.pos, [f.lat, f.lon, f.h], &p.sd_pos));
        // Roll and pitch over the smaller level tilt sigma, yaw over the heading's.
        let level = p.sd_att[0].min(p.sd_att[1]);
        for ((a, b), sd) in f.euler.iter().zip(p.euler).zip([level, level, p.sd_att[2]]) {
            // The frame carries the angles in `f32`: the host's are rounded alike.
            let d = (f64::from(*a) - f64::from(b as f32) + std::f64::consts::PI)
                .rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            w[2] = w[2].max(d.abs() / sd);
        }
    }
    w[1] = epochs_apart(&fw.epochs, &h.epochs);
    w
}

/// The board's setting: the receiver 0.1 s late, a 0.15-s latency budget, the output predictor
/// carrying the run to the newest sample. The emulated board sends the solution at the newest
/// sample every tenth sample (`now`, the navigation board's frame, the same code:
/// `src/bin/nav_support`); each against the host's live runs' present at the same sample
/// (the same time, bit for bit), in units of the host run's sigmas: within 1e-3 of the `f32`
/// run, 0.05 of the `f64` run (the bars of the epochs, which are checked too). Attitude as
/// roll and pitch over the smaller level tilt sigma, yaw over the heading's (the frame carries
/// them in `f32`; the host's are rounded alike).
#[test]
fn qemu_firmware_sends_the_present_solution_as_the_host_predictor() {
    let Some(elf) = firmware_elf() else { return };
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = NavArgs {
        latency: 0.15,
        ..streamed(&drive_nhc(dir.path()))
    };
    let (fw, inputs) = late_wire(&elf, &args, 0.1);
    assert!(fw.present.len() > 3000, "{} frames", fw.present.len());
    let worst = [
        present_apart(&fw, &host_live::<f32>(&args, &inputs)),
        present_apart(&fw, &host_live::<f64>(&args, &inputs)),
    ];
    eprintln!(
        "the present on the M4 ({} frames; fixes 0.1 s late, 0.15-s budget): worst position \
         {:.2e} sigma, attitude {:.2e} sigma from the host's f32 live run ({:.2e} sigma at the \
         epochs); {:.2e}, {:.2e} ({:.2e}) from f64; standard deviations {:.2e} ({:.2e} from \
         f64) relative",
        fw.present.len(),
        worst[0][0],
        worst[0][2],
        worst[0][1],
        worst[1][0],
        worst[1][2],
        worst[1][1],
        worst[0][3],
        worst[1][3]
    );
    assert!(worst[0].iter().all(|w| *w < 1e-3), "{worst:?}");
    assert!(worst[1].iter().all(|w| *w < 0.05), "{worst:?}");
    let cost = fw.icount.iter().find(|c| c.class == "present");
    let cost = cost.unwrap_or_else(|| panic!("no icount present: {:?}", fw.icount));
    assert!(cost.n as usize >= fw.present.len(), "{} counted", cost.n);
    eprintln!(
        "a now frame's solution and standard deviations: {} instructions mean, {} worst",
        cost.mean, cost.worst
    );
}
