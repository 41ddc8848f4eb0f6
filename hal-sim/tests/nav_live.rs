//! The live loop (`imu_ident::nav::live::LiveNav`): a log streamed through it sample by sample
//! and fix by fix, with no host to prepare the start, gives the host's replay (the same setup
//! and records, byte for byte) and so the host's run, bit for bit, whether the fixes arrive
//! before the IMU samples that pass them or after; late fixes (receiver latency) are fused at
//! their own time and stay within a small fraction of a sigma of the on-time run; and the start
//! recovers from a window that was not at rest and from a receiver that is silent, without a
//! panic on any input.

use hal_sim::nav::setup::{live_config, settings};
use hal_sim::nav::{live_fix, run_with, NavArgs};
use hal_sim::nav_io::{read_gnss_csv, read_imu_csv, GnssFix, ImuSample};
use hal_sim::nav_qemu::replay_records;
use imu_ident::nav::live::{DropReason, LiveConfig, LiveEvent, LiveNav};
use imu_ident::nav::replay::{encode, Record};
use imu_ident::nav::{Epoch, ImuErrorModel, NavSetup, NAV_N};

fn mems() -> ImuErrorModel<f64> {
    hal_sim::trajectory::errors::ImuErrorModel::mems()
        .to_core()
        .unwrap_or_else(|e| panic!("{e:#}"))
}

/// A simulated 10-min drive (`hal_sim::present::simulated_drive`).
pub(crate) fn drive(dir: &std::path::Path, seed: u64, yaw: bool, nhc: bool) -> NavArgs {
    hal_sim::present::simulated_drive(dir, 1.0 / 6.0, seed, yaw, nhc)
        .unwrap_or_else(|e| panic!("{e:#}"))
}

/// What a live run produced.
#[derive(Default)]
pub(crate) struct Live {
    setup: Option<NavSetup>,
    records: Vec<Record>,
    /// Epoch time and position (lat, lon, h) bits, velocity and position sigmas.
    pub(crate) epochs: Vec<Epoch<f32>>,
    gated: usize,
    starts: usize,
    realigned: usize,
    no_fix: usize,
    dropped: Vec<(f64, DropReason)>,
}

impl Live {
    /// Starts and dropped fixes.
    pub(crate) fn starts_and_drops(&self) -> (usize, usize) {
        (self.starts, self.dropped.len())
    }

    pub(crate) fn take(&mut self, e: LiveEvent<'_, f32>) {
        match e {
            LiveEvent::Started(s) => {
                self.starts += 1;
                self.setup = Some(s.clone());
            }
            LiveEvent::Realigning(_) => self.realigned += 1,
            LiveEvent::NoFix => self.no_fix += 1,
            LiveEvent::FixDropped(t, why) => self.dropped.push((t, why)),
            LiveEvent::Imu(r, _) => self.records.push(Record::Imu(*r)),
            LiveEvent::Fix { record, epoch, .. } => {
                self.gated += usize::from(epoch.flags & imu_ident::nav::run::EPOCH_GATED != 0);
                self.records.push(Record::Gnss(*record));
                self.epochs.push(*epoch);
            }
        }
    }
}

/// Streams `imu` and `fixes` through a live run of `args`, each fix delivered when the IMU
/// stream reaches its time plus `delay` [s] (negative: before), IMU first on a tie, with the
/// latency budget `latency` [s].
fn stream(args: &NavArgs, imu: &[ImuSample], fixes: &[GnssFix], delay: f64, latency: f64) -> Live {
    let cfg = LiveConfig {
        latency,
        ..live_config(args)
    };
    let mut nav =
        LiveNav::<f32, NAV_N>::new(settings(args), cfg, LiveNav::<f32, NAV_N>::no_observer);
    let mut live = Live::default();
    let mut k = 0;
    for s in imu {
        while k < fixes.len() && fixes[k].t + delay < s.t {
            nav.gnss(&live_fix(&fixes[k]), &mut |e| live.take(e))
                .unwrap_or_else(|e| panic!("fix at {}: {e:?}", fixes[k].t));
            k += 1;
        }
        nav.imu(s.t, s.gyro, s.accel, &mut |e| live.take(e))
            .unwrap_or_else(|e| panic!("sample at {}: {e:?}", s.t));
    }
    // The fixes after the last sample: only one at its time is the run's.
    for f in &fixes[k..] {
        nav.gnss(&live_fix(f), &mut |e| live.take(e))
            .unwrap_or_else(|e| panic!("fix at {}: {e:?}", f.t));
    }
    nav.flush(&mut |e| live.take(e))
        .unwrap_or_else(|e| panic!("flush: {e:?}"));
    live
}

fn encoded(setup: &NavSetup, records: &[Record]) -> Vec<u8> {
    let mut out = Vec::new();
    encode(setup, records, |b| out.extend_from_slice(b)).unwrap_or_else(|e| panic!("{e}"));
    out
}

pub(crate) fn load(args: &NavArgs) -> (Vec<ImuSample>, Vec<GnssFix>) {
    let imu = read_imu_csv(&args.imu).unwrap_or_else(|e| panic!("{e:#}"));
    let fixes = read_gnss_csv(&args.gnss).unwrap_or_else(|e| panic!("{e:#}"));
    (imu, fixes)
}

/// The replay's bytes and the host run's epochs against the live run's, bit for bit. The
/// fixes come early (up to 0.7 s before the IMU reaches them: they wait in the queue) or just
/// in time, or late within the latency budget: the records and the run are the same.
pub(crate) fn live_is_the_replay(args: &NavArgs, delay: f64, latency: f64) -> Live {
    let (imu, fixes) = load(args);
    let (setup, records) = replay_records(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let live = stream(args, &imu, &fixes, delay, latency);
    assert_eq!((live.starts, live.realigned, live.no_fix), (1, 0, 0));
    assert!(live.dropped.is_empty(), "{:?}", live.dropped);
    let mut live_setup = live.setup.clone().unwrap_or_else(|| panic!("no start"));
    // The live run's setup carries its rules; the replay's start is the host's.
    assert_eq!(
        live_setup.live,
        Some(LiveConfig {
            latency,
            ..live_config(args)
        })
    );
    live_setup.live = None;
    if live.records.len() != records.len() {
        let first = live
            .records
            .iter()
            .zip(&records)
            .position(|(a, b)| encoded(&live_setup, &[*a]) != encoded(&live_setup, &[*b]));
        panic!(
            "delay {delay}: {} live records against {}; first difference at {first:?}: \
             {:?} against {:?}",
            live.records.len(),
            records.len(),
            first.map(|i| live.records[i]),
            first.map(|i| records[i])
        );
    }
    assert!(
        encoded(&live_setup, &live.records) == encoded(&setup, &records),
        "the live run's replay differs from the host's"
    );
    let host = run_with::<f32>(args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    assert_same_epochs(&live.epochs, &host);
    live
}

/// A live run's epochs are the host run's, bit for bit.
pub(crate) fn assert_same_epochs(live: &[Epoch<f32>], host: &hal_sim::nav::NavRun) {
    assert_eq!(live.len(), host.epochs.len());
    for (e, h) in live.iter().zip(&host.epochs) {
        let (t, p, v, sd) = (e.t, [e.pos.lat, e.pos.lon, e.pos.h], e.vel, e.sd_pos);
        assert_eq!(t.to_bits(), h.t.to_bits());
        assert_eq!(
            [p[0].to_degrees(), p[1].to_degrees(), p[2]],
            [h.lat_deg, h.lon_deg, h.h],
            "t = {t}"
        );
        assert_eq!(v.map(f64::from), h.vel, "t = {t}");
        assert_eq!(sd.map(f64::from), h.sd_pos, "t = {t}");
    }
}

#[test]
fn a_log_streamed_live_is_the_host_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path(), 16, true, false);
    let live = live_is_the_replay(&args, 0.0, 0.0);
    assert!(live.epochs.len() > 300, "{} epochs", live.epochs.len());
    // The size a firmware would hold in a static (BENCHMARKS.md "Live input"; printed, a
    // memory figure is not a test).
    eprintln!(
        "size of LiveNav<f32, {NAV_N}>: {} B with the default 256-sample buffer, {} B with 128",
        std::mem::size_of::<LiveNav<f32, NAV_N>>(),
        std::mem::size_of::<LiveNav<f32, NAV_N, (), 128>>()
    );
    // Early fixes wait for the samples that pass them.
    live_is_the_replay(&args, -0.7, 0.0);
}

/// The heading from the GNSS course (the planner's decision in the live loop) and the
/// non-holonomic constraint (which waits for it).
#[test]
fn heading_from_the_course_and_the_constraint_live_as_on_the_host() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path(), 17, false, true);
    let live = live_is_the_replay(&args, -0.3, 0.0);
    let heading = live.records.iter().any(|r| {
        matches!(r, Record::Gnss(g) if g.flags & imu_ident::nav::replay::gnss_flags::HEADING != 0)
    });
    assert!(heading, "no fix set the heading");
}

/// Fixes that arrive late (a receiver's latency: 0.25 s, 25 IMU samples after their time):
/// with a latency budget of 0.3 s the samples wait for them, and the run is the host's, bit
/// for bit. Without one, each is taken after the samples it missed, compared with the solution
/// moved back to its time along the velocities the navigator keeps
/// (`imu_ident::nav::navigator::history`). The run then differs from the host's only by
/// taking each correction 0.25 s later (the error held over the lag), so it stays inside the
/// host's 3-sigma band at every epoch (0.22 sigma worst on 2026-12-02; 1.21 while the simulated
/// fixes were at the IMU and the run put the antenna 0.85 m from it; 44 sigma before the
/// history, when a late fix met the newest sample's velocity and turns gated it), and the gate
/// refuses no more fixes than on time, give or take 1 % of them (none either way; 4 against 5
/// with the antenna misplaced; 139 before the history).
#[test]
fn a_latency_budget_takes_late_fixes_in_the_host_order() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path(), 16, true, false);
    let live = live_is_the_replay(&args, 0.25, 0.3);
    assert!(live.epochs.len() > 300, "{} epochs", live.epochs.len());
    let (imu, fixes) = load(&args);
    let host = run_with::<f32>(&args, &imu, &fixes).unwrap_or_else(|e| panic!("{e:#}"));
    let late = stream(&args, &imu, &fixes, 0.25, 0.0);
    assert_eq!((late.starts, late.dropped.len()), (1, 0));
    let mut worst = 0.0f64;
    for (e, h) in late.epochs.iter().zip(&host.epochs) {
        let (t, p) = (e.t, [e.pos.lat, e.pos.lon, e.pos.h]);
        assert_eq!(t.to_bits(), h.t.to_bits());
        let ne = hal_sim::nav_io::outages::north_east(
            h.lat_deg,
            h.lon_deg,
            h.h,
            p[0].to_degrees(),
            p[1].to_degrees(),
        );
        for (d, sd) in [ne[0], ne[1], p[2] - h.h].iter().zip(h.sd_pos) {
            worst = worst.max(d.abs() / sd);
        }
    }
    let host_gated = host.epochs.iter().filter(|e| e.gated).count();
    eprintln!(
        "fixes 0.25 s late, no latency budget: worst position difference {worst:.3} sigma, \
         {} of {} fixes gated (on time: {host_gated})",
        late.gated,
        late.epochs.len()
    );
    assert!(
        worst < 3.0,
        "{worst} sigma from the run with the fixes on time"
    );
    assert!(
        late.gated <= host_gated + late.epochs.len() / 100,
        "{} fixes gated late, {host_gated} on time",
        late.gated
    );
}

/// The epochs of a live run in `T` on `imu` and `fixes`, each fix delivered `delay` s after
/// its time, without a latency budget.
fn late_epochs<T: imu_ident::Real>(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    delay: f64,
) -> Vec<Epoch<T>> {
    let mut nav = LiveNav::<T, NAV_N>::new(
        settings(args),
        live_config(args),
        LiveNav::<T, NAV_N>::no_observer,
    );
    let mut epochs = Vec::new();
    let mut take = |e: LiveEvent<'_, T>| {
        if let LiveEvent::Fix { epoch, .. } = e {
            epochs.push(*epoch);
        }
    };
    let mut k = 0;
    for s in imu {
        while k < fixes.len() && fixes[k].t + delay < s.t {
            nav.gnss(&live_fix(&fixes[k]), &mut take)
                .unwrap_or_else(|e| panic!("fix at {}: {e:?}", fixes[k].t));
            k += 1;
        }
        nav.imu(s.t, s.gyro, s.accel, &mut take)
            .unwrap_or_else(|e| panic!("sample at {}: {e:?}", s.t));
    }
    nav.flush(&mut take)
        .unwrap_or_else(|e| panic!("flush: {e:?}"));
    epochs
}

/// Single precision on the late-fix path (`imu_ident::nav::navigator::history`: velocities in
/// `T`, their integral in `f64`): fixes 0.25 s late without a budget, the `f32` live run
/// against the `f64` one at every epoch within 0.05 sigma of position, the core's `f32` bar
/// (8.8e-4 sigma on 2026-12-02).
#[test]
fn late_fixes_in_single_precision_follow_double() {
    let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
    let args = drive(dir.path(), 18, true, true);
    let (imu, fixes) = load(&args);
    let e32 = late_epochs::<f32>(&args, &imu, &fixes, 0.25);
    let e64 = late_epochs::<f64>(&args, &imu, &fixes, 0.25);
    assert!(e32.len() > 300, "{} epochs", e32.len());
    assert_eq!(e32.len(), e64.len());
    let mut worst = 0.0f64;
    for (a, b) in e32.iter().zip(&e64) {
        assert_eq!(a.t.to_bits(), b.t.to_bits());
        let ne = hal_sim::nav_io::outages::north_east(
            b.pos.lat.to_degrees(),
            b.pos.lon.to_degrees(),
            b.pos.h,
            a.pos.lat.to_degrees(),
            a.pos.lon.to_degrees(),
        );
        for (d, sd) in [ne[0], ne[1], a.pos.h - b.pos.h].iter().zip(b.sd_pos) {
            worst = worst.max(d.abs() / sd);
        }
    }
    eprintln!("fixes 0.25 s late, no budget: f32 against f64, worst position {worst:.2e} sigma");
    assert!(worst < 0.05, "{worst} sigma");
}

/// A level IMU at rest at 100 Hz from `t0` for `secs` seconds (the specific force `f`).
fn at_rest(t0: f64, secs: f64, f: [f64; 3]) -> Vec<ImuSample> {
    let n = (secs * 100.0).round() as usize;
    (0..n)
        .map(|k| ImuSample {
            t: t0 + 0.01 * k as f64,
            gyro: [0.0; 3],
            accel: f,
        })
        .collect()
}

fn fix_at(t: f64) -> GnssFix {
    GnssFix {
        t,
        lat_deg: 45.0,
        lon_deg: 7.0,
        h: 300.0,
        vel_ned: Some([0.0; 3]),
        sd_pos_ned: None,
        sd_vel_ned: None,
    }
}

/// A short at-rest configuration: a 2-s window, the heading given.
fn rest_args() -> NavArgs {
    NavArgs {
        align: 2.0,
        yaw_deg: Some(30.0),
        ..NavArgs::new("imu.csv".into(), "gnss.csv".into(), mems(), "mems")
    }
}

const G: [f64; 3] = [0.0, 0.0, -9.806];

/// A window that was not at rest (2 g for the first 3 s) is levelled again from the next
/// sample, and the run starts after the next window; a receiver silent for longer than the
/// start's buffer (256 samples) restarts the levelling, and the run starts once fixes come;
/// with a fix before the window's end and none after, the full buffer places the run there and
/// its samples run in their order.
#[test]
fn the_start_recovers_from_motion_and_from_a_silent_receiver() {
    let args = rest_args();
    let mut imu = at_rest(0.0, 3.0, [0.0, 0.0, -19.6]);
    imu.extend(at_rest(3.0, 12.0, G));
    let fixes: Vec<GnssFix> = (0..15).map(|k| fix_at(0.5 + f64::from(k))).collect();
    let live = stream(&args, &imu, &fixes, 0.0, 0.0);
    assert_eq!((live.realigned, live.no_fix, live.starts), (1, 0, 1));
    let t0 = live.setup.as_ref().map_or(f64::NAN, |s| s.t0);
    // The first window [0, 2] failed at its fix (2.5 s); the next starts at the next sample.
    assert!(t0 > 4.5 && t0 < 5.0, "t0 = {t0}");

    // Fixes from 9.5 s only: the window ends at 2.01 s, the buffer fills at 4.57 s.
    let imu = at_rest(0.0, 15.0, G);
    let fixes: Vec<GnssFix> = (9..15).map(|k| fix_at(0.5 + f64::from(k))).collect();
    let live = stream(&args, &imu, &fixes, 0.0, 0.0);
    assert!(
        live.no_fix >= 1 && live.starts == 1,
        "{} {}",
        live.no_fix,
        live.starts
    );
    let s = live.setup.unwrap_or_else(|| panic!("no start"));
    assert!(s.t0 > 9.0 && (s.pos.h - 300.0).abs() < 1e-6, "{}", s.t0);
    // At rest and level: every epoch after the start stays within its 3 sigma of the fix.
    assert!(live
        .epochs
        .iter()
        .all(|e| (e.pos.h - 300.0).abs() < 3.0 * f64::from(e.sd_pos[2])));

    // Fixes until 1.5 s, then none until 9.5 s: the buffer fills (4.57 s) and the last fix
    // before the window's end (1.5 s) places the run; the samples run in their order.
    let imu = at_rest(0.0, 15.0, G);
    let fixes: Vec<GnssFix> = [0.5, 1.5]
        .into_iter()
        .chain((9..15).map(|k| 0.5 + f64::from(k)))
        .map(fix_at)
        .collect();
    let live = stream(&args, &imu, &fixes, 0.0, 0.0);
    assert_eq!((live.no_fix, live.starts), (0, 1));
    let t0 = live.setup.as_ref().map_or(f64::NAN, |s| s.t0);
    assert!((t0 - 2.01).abs() < 1e-9, "t0 = {t0}");
    let times: Vec<f64> = live
        .records
        .iter()
        .filter_map(|r| match r {
            Record::Imu(r) => Some(r.t),
            Record::Gnss(_) => None,
        })
        .collect();
    assert_eq!(times.len(), 1500 - 202);
    assert!(
        times.windows(2).all(|w| w[0] < w[1]),
        "samples out of order"
    );
    assert!(live
        .epochs
        .iter()
        .all(|e| (e.pos.h - 300.0).abs() < 3.0 * f64::from(e.sd_pos[2])));
}

/// One corrupted time stamp costs one sample or one fix, not the run: a sample at +Inf, one at
/// 1e30 and one 5 s ahead in the middle of a run are refused, and so are fixes at 1e30, NaN
/// and 30 s ahead; the epochs go on to the end. A first sample at 1e30 restarts the
/// levelling when the next one goes back.
#[test]
fn a_corrupted_time_stamp_does_not_stop_the_live_run() {
    let args = rest_args();
    let mut imu = at_rest(0.0, 20.0, G);
    imu[1000].t = f64::INFINITY;
    imu[1200].t = 1e30;
    imu[1400].t += 5.0;
    let mut fixes: Vec<GnssFix> = (0..20).map(|k| fix_at(0.5 + f64::from(k))).collect();
    fixes[10].t = 1e30;
    fixes[12].t = f64::NAN;
    fixes[14].t += 30.0;
    let mut nav = LiveNav::<f32, NAV_N>::new(
        settings(&args),
        live_config(&args),
        LiveNav::<f32, NAV_N>::no_observer,
    );
    let mut live = Live::default();
    let mut refused = 0;
    let mut k = 0;
    for (i, s) in imu.iter().enumerate() {
        // The fixes in the order of their true times (the corrupted ones among them).
        while k < fixes.len() && 0.5 + k as f64 <= 0.01 * i as f64 {
            nav.gnss(&live_fix(&fixes[k]), &mut |e| live.take(e))
                .unwrap_or_else(|e| panic!("{e:?}"));
            k += 1;
        }
        if nav
            .imu(s.t, s.gyro, s.accel, &mut |e| live.take(e))
            .is_err()
        {
            refused += 1;
        }
    }
    assert_eq!(refused, 3);
    let ahead = live
        .dropped
        .iter()
        .filter(|(_, why)| *why == DropReason::Ahead)
        .count();
    assert_eq!(ahead, 3, "{:?}", live.dropped);
    // Fixes at 2.5 ... 19.5 s after the start at 2.01 s, less the three corrupted ones; the
    // last, at 19.5 s, is passed by the sample at 19.5 s.
    assert_eq!(live.epochs.len(), 18 - 3);
    assert!(live.epochs.last().is_some_and(|e| e.t == 19.5));

    let mut nav = LiveNav::<f32, NAV_N>::new(
        settings(&args),
        live_config(&args),
        LiveNav::<f32, NAV_N>::no_observer,
    );
    let mut live = Live::default();
    nav.imu(1e30, [0.0; 3], G, &mut |e| live.take(e))
        .unwrap_or_else(|e| panic!("{e:?}"));
    for s in &at_rest(0.0, 5.0, G) {
        nav.imu(s.t, s.gyro, s.accel, &mut |e| live.take(e))
            .unwrap_or_else(|e| panic!("{e:?}"));
        if (s.t * 100.0).round() as i64 % 100 == 50 {
            nav.gnss(&live_fix(&fix_at(s.t)), &mut |e| live.take(e))
                .unwrap_or_else(|e| panic!("{e:?}"));
        }
    }
    assert_eq!((live.realigned, live.starts), (1, 1));
    assert!(live.setup.is_some_and(|s| (s.t0 - 2.01).abs() < 1e-9));
}

/// Seeded hostile streams (non-finite and huge values, times that stand still or go back,
/// fixes before the start and bursts that fill the queue) through the live loop: never a
/// panic; refused samples are `BadTime` and change nothing; every fix is either taken, queued
/// or reported dropped. Half the seeds run with a latency budget: the present solution is
/// never behind the run's.
#[test]
fn hostile_live_streams_never_panic() {
    use rand::{Rng, SeedableRng};
    let args = rest_args();
    let (setup, cfg) = (settings(&args), live_config(&args));
    let hostile = [f64::NAN, f64::INFINITY, -f64::INFINITY, 1e30, -1e30, 0.0];
    for seed in 0..40u64 {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let cfg = LiveConfig {
            latency: if seed % 2 == 1 { 0.2 } else { 0.0 },
            ..cfg
        };
        let mut nav =
            LiveNav::<f32, NAV_N>::new(setup.clone(), cfg, LiveNav::<f32, NAV_N>::no_observer);
        let mut live = Live::default();
        let (mut t, mut tf) = (0.0, 0.0);
        let (mut fixes_sent, mut refused) = (0usize, 0usize);
        for _ in 0..3000 {
            fn pick(rng: &mut impl Rng, hostile: &[f64], v: f64) -> f64 {
                if rng.gen_bool(0.02) {
                    hostile[rng.gen_range(0..hostile.len())]
                } else {
                    v
                }
            }
            let r = &mut rng;
            t += pick(r, &hostile, 0.01);
            let s = [0.0, 0.0, 0.0].map(|v| pick(r, &hostile, v));
            let a = [0.0, 0.0, -9.806].map(|v| pick(r, &hostile, v));
            let before = live.records.len();
            match nav.imu(t, s, a, &mut |e| live.take(e)) {
                Ok(()) => {}
                Err(imu_ident::nav::NavError::BadTime) => {
                    refused += 1;
                    assert_eq!(live.records.len(), before);
                    t = 0.01 * (1.0 + t.abs().min(1e6).floor());
                }
                Err(_) => {}
            }
            if rng.gen_bool(0.15) {
                let step = rng.gen_range(-0.5..1.5);
                tf += pick(&mut rng, &hostile, step);
                let mut f = live_fix(&fix_at(tf));
                f.pos.h = pick(&mut rng, &hostile, 300.0);
                fixes_sent += 1;
                let _ = nav.gnss(&f, &mut |e| live.take(e));
                if !tf.is_finite() {
                    tf = 0.0;
                }
            }
            if let (Some(run), Some(now)) = (nav.run(), nav.present()) {
                assert!(
                    now.time() >= run.time(),
                    "seed {seed}: present behind the run"
                );
            }
        }
        let taken = live.epochs.len() + live.dropped.len();
        assert!(taken <= fixes_sent, "seed {seed}: {taken} of {fixes_sent}");
        assert!(refused > 0 || seed > 0, "seed {seed}: no hostile time");
    }
}
