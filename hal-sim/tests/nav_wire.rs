//! The navigator's serial wire on the host (`imu_ident::nav::serial`): a log written as IMU
//! frames and a u-blox receiver's `NAV-TIMEGPS` / `NAV-PVT` messages
//! (`hal_sim::nav_io::ubx::serial_stream`), read back through the core's decoders into a live
//! run, is the host run on what the wire carried, bit for bit; a `.ubx` file gives `nav` the
//! same fixes; a noisy line costs the frames it corrupts and nothing else.
//!
//! The wire quantises a fix to `NAV-PVT`'s units (1e-7 deg, 1 mm, 1 mm/s, 1 ms): the host run
//! compared is the one on the fixes as decoded, so the comparison is exact; the quantisation
//! itself is bounded here to half a unit.

use crate::nav_live::{assert_same_epochs, drive, load, Live};
use hal_sim::nav::run_with;
use hal_sim::nav::setup::{live_config, settings};
use hal_sim::nav_io::read_gnss_any;
use hal_sim::nav_io::ubx::{as_sent, ubx_fixes, wire_inputs};
use hal_sim::nav_qemu::wire_of;
use imu_ident::nav::live::LiveNav;
use imu_ident::nav::serial::{feed, NavInput, WireCounts};
use imu_ident::nav::NAV_N;

/// A live `f32` run of `args`' setup on `inputs`.
fn live_run(args: &hal_sim::nav::NavArgs, inputs: &[NavInput]) -> Live {
    let mut nav = LiveNav::<f32, NAV_N>::new(
        settings(args),
        live_config(args),
        LiveNav::<f32, NAV_N>::no_observer,
    );
    let mut live = Live::default();
    for i in inputs {
        // A refused input (a corrupted time) is the live loop's to report; it goes on.
        let _ = feed(&mut nav, i, &mut |e| live.take(e));
    }
    nav.flush(&mut |e| live.take(e))
        .unwrap_or_else(|e| panic!("flush: {e:?}"));
    live
}

#[test]
fn a_log_over_the_serial_wire_is_the_host_run_on_what_the_wire_carried() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    // Heading from the course and the constraint: the live run decides everything itself.
    let args = drive(dir.path(), 16, false, true);
    let (imu, fixes) = load(&args);
    let as_sent = as_sent(&imu);
    // On time, and half a second ahead of the IMU (the fixes wait in the live queue).
    for delay in [0.0, -0.5] {
        let wire = wire_of(&args, &imu, &fixes, delay).unwrap_or_else(|e| panic!("{e:#}"));
        let (inputs, counts) = wire_inputs(&wire, None);
        assert_eq!(counts, WireCounts::default());
        let (carried, _) = ubx_fixes(&wire, None);
        assert_eq!(carried.len(), fixes.len());
        assert_eq!(inputs.len(), imu.len() + fixes.len());
        for (c, f) in carried.iter().zip(&fixes) {
            // Half a unit of NAV-PVT (and the f64 rounding of the sums).
            assert!((c.t - f.t).abs() <= 0.5e-3 + 1e-6, "t {} {}", c.t, f.t);
            assert!(
                (c.lat_deg - f.lat_deg).abs() <= 0.5e-7 + 1e-12,
                "t = {}",
                f.t
            );
            assert!(
                (c.lon_deg - f.lon_deg).abs() <= 0.5e-7 + 1e-12,
                "t = {}",
                f.t
            );
            assert!((c.h - f.h).abs() <= 0.5e-3 + 1e-9, "t = {}", f.t);
            let (cv, fv) = (c.vel_ned.unwrap_or_default(), f.vel_ned.unwrap_or_default());
            assert!(cv
                .iter()
                .zip(fv)
                .all(|(a, b)| (a - b).abs() <= 0.5e-3 + 1e-9));
        }
        let live = live_run(&args, &inputs);
        assert_eq!(live.starts_and_drops(), (1, 0));
        let host = run_with::<f32>(&args, &as_sent, &carried).unwrap_or_else(|e| panic!("{e:#}"));
        assert_same_epochs(&live.epochs, &host);
        assert!(live.epochs.len() > 300, "{} epochs", live.epochs.len());
    }
    // The same fixes from a `.ubx` file (a receiver's log: the wire without the IMU frames),
    // written by `hal-sim wire`.
    let wire = wire_of(&args, &[], &fixes, 0.0).unwrap_or_else(|e| panic!("{e:#}"));
    let path = dir.path().join("gnss.ubx");
    let cli = |extra: &[&std::ffi::OsStr]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_hal-sim"))
            .arg("wire")
            .args(extra)
            .output()
            .unwrap_or_else(|e| panic!("{e}"))
    };
    let o = cli(&[
        "--gnss".as_ref(),
        args.gnss.as_os_str(),
        "--out".as_ref(),
        path.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read(&path).unwrap_or_default(), wire);
    let from_file = read_gnss_any(&path, 1).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(from_file, ubx_fixes(&wire, None).0);
    // A fix without velocity cannot be a NAV-PVT: the command says which file and which fix.
    let bad = dir.path().join("no-velocity.csv");
    std::fs::write(&bad, "t,lat,lon,h\n1.5,40.0,-105.0,1600.0\n").unwrap_or_else(|e| panic!("{e}"));
    let o = cli(&[
        "--gnss".as_ref(),
        bad.as_os_str(),
        "--out".as_ref(),
        path.as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("no-velocity.csv") && err.contains("t = 1.5"),
        "{err}"
    );
}

/// A wire file (`hal-sim wire`, GPS-stamped or a counting hub's) is a log for `hal-sim nav`:
/// `--imu W.bin --gnss W.bin` runs on the samples and fixes the core's decoders read from it
/// (the hub's put on GPS time as the firmware puts them), the live loop's run on the same
/// inputs bit for bit. The same log, the same answer, through either path.
#[test]
fn a_wire_file_is_a_log_for_nav() {
    use hal_sim::nav_io::ubx::{stamped_inputs, HUB_TIMER_HZ};
    use imu_ident::nav::gps_clock::ClockConfig;
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path(), 16, false, true);
    let (imu, fixes) = load(&args);
    for (name, hub) in [("gps.bin", None), ("hub.bin", Some(("-25", 7u64)))] {
        let path = dir.path().join(name);
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_hal-sim"));
        cmd.arg("wire")
            .arg("--imu")
            .arg(&args.imu)
            .arg("--gnss")
            .arg(&args.gnss)
            .arg("--out")
            .arg(&path);
        if let Some((ppm, seed)) = hub {
            cmd.args(["--hub-ppm", ppm, "--hub-seed", &seed.to_string()]);
        }
        let o = cmd.output().unwrap_or_else(|e| panic!("{e}"));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let wire = std::fs::read(&path).unwrap_or_else(|e| panic!("{e}"));
        // The hub's wire is the library's on the same oscillator.
        if let Some((ppm, seed)) = hub {
            let cfg = ClockConfig::crystal(HUB_TIMER_HZ);
            let y0 = ppm.parse::<f64>().unwrap_or_default() * 1e-6;
            let spec = hal_sim::clock::oscillator_spec(&cfg, y0, 1.0);
            let mut osc =
                hal_sim::trajectory::oscillator::Oscillator::new(spec, imu[0].t - 2.0, seed);
            let lib = hal_sim::clock::counted_stream(&imu, &fixes, 0.0, &mut osc)
                .unwrap_or_else(|e| panic!("{e:#}"));
            assert!(lib == wire, "{name}: the CLI's wire is not the library's");
        }
        let (inputs, _, stamps) = stamped_inputs(&wire, ClockConfig::crystal(HUB_TIMER_HZ))
            .unwrap_or_else(|e| panic!("{e:#}"));
        let live = live_run(&args, &inputs);
        let on_file = hal_sim::nav::NavArgs {
            imu: path.clone(),
            gnss: path.clone(),
            single: true,
            ..args.clone()
        };
        let host = hal_sim::nav::run(&on_file).unwrap_or_else(|e| panic!("{e:#}"));
        println!(
            "{name}: {} epochs, {} samples before the hub's clock locked",
            host.epochs.len(),
            stamps.unstamped()
        );
        assert_same_epochs(&live.epochs, &host);
        assert!(
            live.epochs.len() > 300,
            "{name}: {} epochs",
            live.epochs.len()
        );
        assert_eq!(stamps.unstamped() > 0, hub.is_some(), "{name}");
    }
    // A file with no IMU frame is an error naming it.
    let empty = dir.path().join("none.bin");
    std::fs::write(&empty, b"\xb5\x62 no frames here").unwrap_or_else(|e| panic!("{e}"));
    let e = format!("{:#}", hal_sim::nav_io::read_imu_any(&empty).unwrap_err());
    assert!(e.contains("none.bin") && e.contains("no IMU sample"), "{e}");
}

/// Where each input ends on a wire, and how long its frame or message is.
fn item_spans(wire: &[u8]) -> Vec<(usize, usize, NavInput)> {
    let mut w = imu_ident::nav::serial::NavWire::new(None);
    let mut ubx = imu_ident::nav::ubx::UbxDecoder::new();
    let mut out = Vec::new();
    for (i, &b) in wire.iter().enumerate() {
        w.push(b, &mut |input| {
            let len = match input {
                NavInput::Imu(_) => 38,
                NavInput::Fix(_) => 100,
                NavInput::Pulse(_) => 24,
                NavInput::Counted(_) => imu_ident::nav::counted::COUNTED_FRAME_LEN,
                NavInput::Edge(_) => imu_ident::nav::counted::EDGE_FRAME_LEN,
            };
            out.push((i + 1 - len, i + 1, input));
        });
        // The week messages, as spans with no input (a fix needs one intact before it).
        if let Some(imu_ident::nav::ubx::UbxMessage::NavTimeGps { .. }) = ubx.push(b) {
            out.push((i + 1 - 24, i + 1, NavInput::Imu(Default::default())));
        }
    }
    out
}

/// A noisy line: seeded bursts of random bytes overwrite parts of the wire. Every sample and
/// fix whose bytes were not hit is read (a fix also needs an intact week message before it);
/// every other is refused and counted; the run goes on with what arrived. The same on the
/// wire of a hub that counts its samples (`imu_ident::nav::counted`: counted samples, pulse
/// edges and the receiver's `TIM-TP`), put on GPS time by a `TimerStamps`.
#[test]
fn a_noisy_line_costs_the_frames_it_hits() {
    use hal_sim::trajectory::oscillator::Oscillator;
    use imu_ident::nav::gps_clock::ClockConfig;
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path(), 16, true, false);
    let (imu, fixes) = load(&args);
    let gps = wire_of(&args, &imu, &fixes, 0.0).unwrap_or_else(|e| panic!("{e:#}"));
    noisy_line(&args, &gps, None, imu.len(), fixes.len());
    let cfg = ClockConfig::crystal(84e6);
    let spec = hal_sim::clock::oscillator_spec(&cfg, -20e-6, 1.0);
    let mut osc = Oscillator::new(spec, imu[0].t - 2.0, 65_601);
    let counted = hal_sim::nav_qemu::counted_wire_of(&args, &imu, &fixes, 0.0, &mut osc)
        .unwrap_or_else(|e| panic!("{e:#}"));
    noisy_line(&args, &counted, Some(cfg), imu.len(), fixes.len());
}

/// [`a_noisy_line_costs_the_frames_it_hits`] on the wire `clean` (counted samples stamped by a
/// clock of `hub`, when given).
fn noisy_line(
    args: &hal_sim::nav::NavArgs,
    clean: &[u8],
    hub: Option<imu_ident::nav::gps_clock::ClockConfig>,
    n_imu: usize,
    n_fixes: usize,
) {
    use rand::{Rng, SeedableRng};
    let spans = item_spans(clean);
    for seed in 0..4u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(65_600 + seed);
        let mut wire = clean.to_vec();
        let mut hit = vec![false; wire.len()];
        // 200 bursts of 1-40 bytes: about 0.05 % of the bytes.
        for _ in 0..200 {
            let at = rng.gen_range(0..wire.len() - 40);
            let len = rng.gen_range(1..=40);
            for k in at..at + len {
                wire[k] = rng.gen();
                hit[k] = true;
            }
        }
        let intact = |sp: &(usize, usize, NavInput)| !hit[sp.0..sp.1].contains(&true);
        let mut week = false;
        let mut expected = Vec::new();
        for sp in &spans {
            match sp.2 {
                NavInput::Imu(s) if s.t == 0.0 => week |= intact(sp),
                NavInput::Fix(_) if !week => {}
                _ if intact(sp) => expected.push(sp.2),
                _ => {}
            }
        }
        let (inputs, counts) = wire_inputs(&wire, None);
        assert_eq!(inputs, expected, "seed {}", 65_600 + seed);
        assert!(counts.imu_rejected + counts.ubx_rejected > 0, "{counts:?}");
        let inputs = match hub {
            Some(cfg) => {
                let (stamped, _, stamps) = hal_sim::nav_io::ubx::stamped_inputs(&wire, cfg)
                    .unwrap_or_else(|e| panic!("{e}"));
                // Lost pulses and messages are bridged: every sample after the lock is stamped
                // and no pulse is refused.
                let c = stamps.counts();
                eprintln!("seed {}: the clock's counts {c:?}", 65_600 + seed);
                assert!(stamps.unstamped() < 400 && c.rejected == 0 && c.restarts == 0);
                stamped
            }
            None => inputs,
        };
        let live = live_run(args, &inputs);
        assert_eq!(live.starts_and_drops().0, 1);
        let n_fix = inputs
            .iter()
            .filter(|i| matches!(i, NavInput::Fix(_)))
            .count();
        eprintln!(
            "seed {}: {} of {} samples, {n_fix} of {} fixes, {counts:?}, {} epochs",
            65_600 + seed,
            inputs
                .iter()
                .filter(|i| matches!(i, NavInput::Imu(_)))
                .count(),
            n_imu,
            n_fixes,
            live.epochs.len()
        );
    }
}
