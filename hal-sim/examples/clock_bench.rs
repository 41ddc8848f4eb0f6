//! The GPS clock (`imu_ident::nav::gps_clock`) on simulated board timers
//! (`hal_sim::clock`): per seed, 1 h of an 84-MHz timer whose crystal is N(0, 20 ppm)
//! off with the model's frequency noise (times `walk`), a `TIM-TP` and a pulse each second,
//! a sample stamped every 0.1 s. Prints each seed's mean NIS, the fraction of samples beyond
//! 3 sd and the worst stamp error, then medians, 95th percentiles and worst cases, and the
//! pooled mean NIS against its chi-square band.
//!
//! ```text
//! cargo run --release -p hal-sim --example clock_bench -- [first=65720] [seeds=20] [walk=1] [faults=clean|harsh] [hz=84e6] [identify=1]
//! ```

use hal_sim::clock::{clock_run, Faults};
use imu_ident::nav::gps_clock::ClockConfig;

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::{arg_or, pct};

fn main() {
    let first: u64 = arg_or("first", 65_720);
    let seeds: u64 = arg_or("seeds", 20);
    let walk: f64 = arg_or("walk", 1.0);
    let hz: f64 = arg_or("hz", 84e6);
    let faults = match arg_or("faults", String::from("clean")).as_str() {
        "harsh" => Faults::harsh(),
        _ => Faults::default(),
    };
    let cfg = ClockConfig {
        identify: arg_or("identify", 1u8) == 1,
        ..ClockConfig::crystal(hz)
    };
    let mut late = vec![];
    let mut factors = vec![];
    let (mut nis, mut all) = (vec![], vec![]);
    let (mut beyond, mut worst, mut gap) = (vec![], vec![], vec![]);
    let mut events = [0u32; 4];
    for seed in first..first + seeds {
        let r = clock_run(cfg, 3600, walk, faults, seed);
        let w = r.worst(0.0, 1800.0).max(r.worst(2100.0, 3601.0));
        println!(
            "seed {seed}: mean NIS {:.3} over {} pulses, beyond 3 sd {:.3} %, worst {:.0} ns, \
             in [1800, 2100) s {:.0} ns, unstamped {}, {:?}; q2 factor 10^{:.3} (sd {:?}, {} \
             decisions), mean NIS of the last 1800 pulses {:.3}",
            r.mean_nis(),
            r.nis.len(),
            100.0 * r.beyond_3(false),
            1e9 * w,
            1e9 * r.worst(1800.0, 2100.0),
            r.unstamped,
            r.counts,
            r.noise.0,
            r.noise.1,
            r.noise.2,
            r.late_nis
        );
        late.push(r.late_nis);
        factors.push((r.noise.0 - walk.log10()).abs());
        nis.push(r.mean_nis());
        all.extend(r.nis.iter().copied());
        beyond.push(100.0 * r.beyond_3(false));
        worst.push(1e9 * w);
        gap.push(1e9 * r.worst(1800.0, 2100.0));
        let c = r.counts;
        for (e, n) in events
            .iter_mut()
            .zip([c.rejected, c.reanchored, c.restarts, c.unannounced])
        {
            *e += n;
        }
    }
    let pooled = all.iter().sum::<f64>() / all.len() as f64;
    let band = 3.89 * (2.0 / all.len() as f64).sqrt();
    let line = |name: &str, v: &mut Vec<f64>| {
        let max = v.iter().copied().fold(f64::MIN, f64::max);
        println!(
            "{name}: median {:.3}, p95 {:.3}, worst {:.3}",
            pct(v, 0.5),
            pct(v, 0.95),
            max
        );
    };
    println!("--- {seeds} seeds from {first}, walk {walk}x, hz {hz}, faults {faults:?}");
    line("mean NIS per seed", &mut nis);
    line("beyond 3 sd [%]", &mut beyond);
    line("worst stamp error [ns]", &mut worst);
    line("worst in [1800, 2100) s [ns]", &mut gap);
    line("mean NIS of the last 1800 pulses", &mut late);
    line("|log10 q2 factor - log10 walk| [decade]", &mut factors);
    println!(
        "pooled mean NIS {pooled:.4} over {} pulses (0.9999 band 1 +- {band:.4}); rejected {}, \
         re-anchored {}, restarts {}, unannounced {}",
        all.len(),
        events[0],
        events[1],
        events[2],
        events[3]
    );
}
