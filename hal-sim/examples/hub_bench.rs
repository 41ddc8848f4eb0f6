//! Samples counted by a hub's timer (`imu_ident::nav::counted`, README "Samples counted by a
//! hub's timer"): per seed, a 10-min simulated drive (`hal_sim::present::simulated_drive`)
//! whose samples a hub stamps with an 84-MHz timer N(0, 20 ppm) off, with the receiver's
//! pulses captured on it, written as its serial wire (`hal_sim::clock::counted_stream`), read
//! by the core's decoders and put on GPS time by a `TimerStamps`; against the GPS-stamped wire
//! of the same samples (those the clock stamped). Prints per seed the samples before the lock,
//! the worst stamp error, the worst position difference of the two live `f32` runs at their
//! epochs (in the GPS run's sigmas, and in metres), then medians, 95th percentiles and worst
//! cases.
//!
//! With `elf=PATH` (`imu-ident-nav-qemu`), each seed's hub wire also runs on the emulated
//! board, against the host's `f32` run on the samples the host's `TimerStamps` stamped: the
//! worst position difference in sigmas, and the decoding's instructions per 256-byte read.
//!
//! ```text
//! cargo run --release -p hal-sim --example hub_bench -- [first=66300] [seeds=20] [elf=PATH]
//! ```

use hal_sim::clock::{oscillator_spec, position_difference};
use hal_sim::nav::setup::{live_config, settings};
use hal_sim::nav_io::ubx::{stamped_inputs, HUB_TIMER_HZ};
use hal_sim::nav_qemu::{compare_firmware, counted_wire_of, run_nav_firmware_wire, wire_of};
use hal_sim::qemu::QemuConfig;
use hal_sim::trajectory::oscillator::Oscillator;
use imu_ident::nav::gps_clock::ClockConfig;
use imu_ident::nav::live::{LiveEvent, LiveNav};
use imu_ident::nav::serial::{feed, NavInput};
use imu_ident::nav::{Epoch, NAV_N};
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Epochs this long [s] after the start are past the start's transient (see the README: a
/// sample on the other side of the levelling window's end moves the start by a sample).
const SETTLED: f64 = 60.0;

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::{arg_or, pct};

/// The epochs of a live `f32` run of `args` on `inputs`, and its start time.
fn epochs(args: &hal_sim::nav::NavArgs, inputs: &[NavInput]) -> (Vec<Epoch<f32>>, f64) {
    let mut nav = LiveNav::<f32, NAV_N>::new(
        settings(args),
        live_config(args),
        LiveNav::<f32, NAV_N>::no_observer,
    );
    let mut out = Vec::new();
    let mut start = f64::NAN;
    let mut take = |e: LiveEvent<'_, f32>| match e {
        LiveEvent::Fix { epoch, .. } => out.push(*epoch),
        LiveEvent::Started(s) => start = s.t0,
        _ => {}
    };
    for i in inputs {
        let _ = feed(&mut nav, i, &mut take);
    }
    let _ = nav.flush(&mut take);
    (out, start)
}

fn main() -> anyhow::Result<()> {
    let first: u64 = arg_or("first", 66_300);
    let seeds: u64 = arg_or("seeds", 20);
    let cfg = ClockConfig::crystal(HUB_TIMER_HZ);
    let (mut lock, mut stamp, mut sigma, mut metres) = (vec![], vec![], vec![], vec![]);
    let mut after = vec![];
    let (mut qemu, mut wire_mean) = (vec![], vec![]);
    let elf: Option<std::path::PathBuf> = bench_args::arg("elf").map(Into::into);
    for seed in first..first + seeds {
        let dir = tempfile::tempdir()?;
        let args = hal_sim::present::simulated_drive(dir.path(), 1.0 / 6.0, seed, true, false)?;
        let imu = hal_sim::nav_io::read_imu_csv(&args.imu)?;
        let fixes = hal_sim::nav_io::read_gnss_csv(&args.gnss)?;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x4b0b);
        let n: f64 = StandardNormal.sample(&mut rng);
        let y0 = 20e-6 * n;
        let mut osc = Oscillator::new(oscillator_spec(&cfg, y0, 1.0), imu[0].t - 2.0, seed);
        let wire = counted_wire_of(&args, &imu, &fixes, 0.0, &mut osc)?;
        let (hub, counts, stamps) = stamped_inputs(&wire, cfg)?;
        let (gps_all, _) =
            hal_sim::nav_io::ubx::wire_inputs(&wire_of(&args, &imu, &fixes, 0.0)?, None);
        let skipped = stamps.unstamped() as usize;
        let mut k = 0;
        let gps: Vec<NavInput> = gps_all
            .into_iter()
            .filter(|i| {
                k += usize::from(matches!(i, NavInput::Imu(_)));
                !matches!(i, NavInput::Imu(_)) || k > skipped
            })
            .collect();
        let times = |v: &[NavInput]| -> Vec<f64> {
            v.iter()
                .filter_map(|i| match i {
                    NavInput::Imu(s) => Some(s.t),
                    _ => None,
                })
                .collect()
        };
        // `shift=S` [s]: the GPS-stamped samples, every one S later, in place of the hub's (how
        // much of the difference a uniform shift of that size makes alone).
        let shift: f64 = arg_or("shift", 0.0);
        let hub: Vec<NavInput> = if shift == 0.0 {
            hub
        } else {
            gps.iter()
                .map(|i| match i {
                    NavInput::Imu(s) => NavInput::Imu(imu_ident::nav::imu_frame::ImuSample {
                        t: s.t + shift,
                        ..*s
                    }),
                    other => *other,
                })
                .collect()
        };
        let (th, tg) = (times(&hub), times(&gps));
        anyhow::ensure!(
            th.len() == tg.len(),
            "seed {seed}: {} stamped samples against {} on GPS time (wire refusals {:?})",
            th.len(),
            tg.len(),
            counts
        );
        let worst = th
            .iter()
            .zip(&tg)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let ((eh, start_hub), (eg, start_gps)) = (epochs(&args, &hub), epochs(&args, &gps));
        let last = th.last().copied().unwrap_or(f64::NAN);
        let missing: Vec<f64> = eg
            .iter()
            .filter(|e| !eh.iter().any(|o| o.t == e.t))
            .map(|e| e.t)
            .collect();
        // Only a fix at the last GPS-stamped sample's time, which the hub's stamp of that
        // sample may put a few tens of ns before it: the fix is after the stream.
        anyhow::ensure!(
            missing.iter().all(|&t| t >= last),
            "seed {seed}: epochs {missing:?} not on the hub's run"
        );
        let missing = missing.len();
        let (sig, m, _) = position_difference(&eg, &eh, f64::NEG_INFINITY);
        let (settled, _, _) = position_difference(&eg, &eh, start_gps + SETTLED);
        if let Some(elf) = &elf {
            let fw = run_nav_firmware_wire(elf, &args, &wire, &QemuConfig::default())?;
            let stamped = hal_sim::nav_io::ubx::samples_of(&hub);
            let carried = hal_sim::nav_io::ubx::ubx_fixes(&wire, None).0;
            let h32 = hal_sim::nav::run_with::<f32>(&args, &stamped, &carried)?;
            let cmp = compare_firmware(elf, &args, &fw, &h32);
            let line = format!("stamps unstamped={skipped} used={}", stamps.counts().used);
            let same = fw.messages.iter().any(|m| m.contains(&line));
            let cost = cmp.icount.iter().find(|c| c.class == "wire");
            println!(
                "seed {seed}: firmware {} epochs of {}, worst {:.2e} sigma from the host's f32; \
                 the host's stamp counts: {same}; wire icount mean {:?} worst {:?}",
                cmp.epochs[0],
                cmp.epochs[1],
                cmp.worst_position_diff_sigma,
                cost.map(|c| c.mean),
                cost.map(|c| c.worst)
            );
            anyhow::ensure!(fw.success() && same, "seed {seed}: {:?}", fw.messages);
            qemu.push(cmp.worst_position_diff_sigma);
            if let Some(c) = cost {
                wire_mean.push(c.mean as f64);
            }
        }
        let c = stamps.counts();
        println!(
            "seed {seed}: {:+.1} ppm; {skipped} samples before the lock; worst stamp error \
             {:.0} ns; starts at {start_hub:.8} / {start_gps:.8} s; worst position difference \
             {sig:.2e} sigma ({m:.2e} m) over {} epochs ({missing} after the hub's stream), \
             {settled:.2e} sigma from {SETTLED} s after the start; \
             wire refusals {}; pulses used {} (unpaired {}, rejected {}, restarts {})",
            1e6 * y0,
            1e9 * worst,
            eg.len(),
            counts.imu_rejected + counts.ubx_rejected,
            c.used,
            c.unpaired,
            c.rejected,
            c.restarts
        );
        lock.push(skipped as f64);
        stamp.push(1e9 * worst);
        sigma.push(sig);
        after.push(settled);
        metres.push(m);
    }
    for (label, v) in [
        ("samples before the lock", &mut lock),
        ("worst stamp error [ns]", &mut stamp),
        ("worst position difference [sigma]", &mut sigma),
        ("worst position difference [m]", &mut metres),
        (
            "worst position difference after the start's minute [sigma]",
            &mut after,
        ),
        ("firmware against the host's f32 [sigma]", &mut qemu),
        (
            "firmware decoding and stamping per 256 B, mean",
            &mut wire_mean,
        ),
    ] {
        if v.is_empty() {
            continue;
        }
        v.sort_by(f64::total_cmp);
        println!(
            "{label}: median {:.3e} / p95 {:.3e} / worst {:.3e}",
            pct(v, 0.5),
            pct(v, 0.95),
            v[v.len() - 1]
        );
    }
    Ok(())
}
