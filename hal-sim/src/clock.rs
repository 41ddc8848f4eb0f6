//! The GPS clock (`imu_ident::nav::gps_clock`) on a simulated board timer
//! ([`crate::trajectory::oscillator`]): the scenario the tests and `examples/clock_bench.rs`
//! share. Each second the receiver's `TIM-TP` (0.6 s before its pulse, through the core's UBX
//! reader), the pulse's capture, and a sample stamped every 0.1 s; faults on request. And
//! [`counted_stream`]: a log as the serial wire of a hub that stamps its samples with such a
//! timer (`imu_ident::nav::counted`).

use crate::nav_io::ubx::ubx_fix_bytes;
use crate::nav_io::{GnssFix, ImuSample};
use crate::trajectory::oscillator::{Oscillator, OscillatorSpec};
use anyhow::Result;
use imu_ident::nav::counted::{encode_counted_sample, encode_edge, CountedSample};
use imu_ident::nav::gps_clock::{ClockConfig, ClockCounts, GpsClock, PulseUse};
use imu_ident::nav::ubx::{encode_tim_tp, tim_tp_at, UbxEvent, UbxFixes};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// What goes wrong on the way.
#[derive(Debug, Clone, Copy, Default)]
pub struct Faults {
    /// Probability that a `TIM-TP` is lost.
    pub lost_message: f64,
    /// Probability that a pulse is lost.
    pub lost_pulse: f64,
    /// Probability, each second, of a glitch edge 0.7 s after the pulse.
    pub glitch: f64,
    /// No pulse and no message over `[start, end)` [s].
    pub gap: Option<(f64, f64)>,
    /// A frequency step: when [s], by how much.
    pub step: Option<(f64, f64)>,
}

impl Faults {
    /// 5 % of the messages and 2 % of the pulses lost, a glitch in 1 % of the seconds, and
    /// no pulse over `[1800, 2100)` s (a 5-min tunnel).
    pub fn harsh() -> Self {
        Self {
            lost_message: 0.05,
            lost_pulse: 0.02,
            glitch: 0.01,
            gap: Some((1800.0, 2100.0)),
            step: None,
        }
    }
}

/// An oscillator of the crystal `cfg` describes: `y0` off, its random walk `walk` times the
/// model's, pulses with 20 ns of jitter.
pub fn oscillator_spec(cfg: &ClockConfig, y0: f64, walk: f64) -> OscillatorSpec {
    OscillatorSpec {
        hz: cfg.hz,
        y0,
        q_white: cfg.q_white,
        q_walk: cfg.q_walk * walk,
        offset: 37.123_456_789,
        pulse_jitter: 20e-9,
    }
}

/// One run's statistics.
#[derive(Debug, Default)]
pub struct ClockRun {
    /// Normalised squared innovation of each pulse fused after the lock (its prediction
    /// error over the prediction's and the capture's variance): chi-square(1) when the clock
    /// is consistent with the oscillator.
    pub nis: Vec<f64>,
    /// Each sample's time, stamp error [s] and error over its sd (the sample's own capture
    /// quantisation included), and whether it was in the gap.
    pub samples: Vec<(f64, f64, f64, bool)>,
    /// What the clock counted.
    pub counts: ClockCounts,
    /// Samples before the lock (not stamped).
    pub unstamped: usize,
    /// Glitch edges sent.
    pub glitches: u32,
    /// Of those, the ones that paired with nothing.
    pub glitches_unpaired: u32,
    /// Messages lost.
    pub lost_messages: u32,
    /// The identified `log10` factor on `q2` at the end, its sd and the decisions taken.
    pub noise: (f64, Option<f64>, u32),
    /// The mean NIS of the last 1 800 pulses fused (the second half hour of a 1-h run).
    pub late_nis: f64,
}

impl ClockRun {
    /// The fraction of samples (in the gap or not) beyond 3 sd.
    pub fn beyond_3(&self, in_gap: bool) -> f64 {
        let z: Vec<f64> = self
            .samples
            .iter()
            .filter(|s| s.3 == in_gap)
            .map(|s| s.2)
            .collect();
        z.iter().filter(|z| z.abs() > 3.0).count() as f64 / z.len().max(1) as f64
    }

    /// The largest stamp error [s] over samples in `[from, to)`.
    pub fn worst(&self, from: f64, to: f64) -> f64 {
        self.samples
            .iter()
            .filter(|s| s.0 >= from && s.0 < to)
            .map(|s| s.1.abs())
            .fold(0.0, f64::max)
    }

    /// The mean NIS.
    pub fn mean_nis(&self) -> f64 {
        self.nis.iter().sum::<f64>() / self.nis.len().max(1) as f64
    }
}

/// `secs` of GPS time of seed `seed`: the oscillator's initial frequency error drawn
/// N(0, 20 ppm) (the filter's prior is 50 ppm), its random walk `walk` times the model's.
pub fn clock_run(cfg: ClockConfig, secs: u32, walk: f64, faults: Faults, seed: u64) -> ClockRun {
    let n: f64 = StandardNormal.sample(&mut ChaCha8Rng::seed_from_u64(seed));
    let y0 = 20e-6 * n;
    let osc = Oscillator::new(oscillator_spec(&cfg, y0, walk), 0.0, seed);
    run_on(osc, cfg, secs, faults, seed)
}

/// [`clock_run`] on a given oscillator.
pub fn run_on(
    mut osc: Oscillator,
    cfg: ClockConfig,
    secs: u32,
    faults: Faults,
    seed: u64,
) -> ClockRun {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x000c_10c4);
    let mut run = ClockRun::default();
    let Ok(mut clock) = GpsClock::new(cfg) else {
        return run;
    };
    let mut ubx = UbxFixes::new(None);
    let quantisation = 1.0 / (cfg.hz * 12f64.sqrt());
    for i in 1..=secs * 10 {
        let t = f64::from(i) * 0.1;
        osc.advance(t);
        if let Some((at, dy)) = faults.step {
            if (t - at).abs() < 0.05 {
                osc.shift_frequency(dy);
            }
        }
        let in_gap = faults.gap.is_some_and(|(a, b)| t >= a && t < b);
        let tenth = i % 10;
        let lost = rng.gen_bool(faults.lost_message);
        if tenth == 4 && !in_gap {
            run.lost_messages += u32::from(lost);
            let next = f64::from(i / 10 + 1);
            for b in encode_tim_tp(&tim_tp_at(next))
                .into_iter()
                .filter(|_| !lost)
            {
                if let Some(UbxEvent::Pulse(p)) = ubx.push_any(b) {
                    clock.announce(p.t, osc.count());
                }
            }
        }
        if tenth == 0 && !in_gap && !rng.gen_bool(faults.lost_pulse) {
            let c = osc.pulse_count();
            let locked = clock.locked();
            let pred = clock.stamp(c);
            let used = clock.pulse(c);
            if let (true, PulseUse::Used, Some(p)) = (locked, used, pred) {
                run.nis
                    .push((p.t - t).powi(2) / (p.sd.powi(2) + cfg.sd_capture.powi(2)));
            }
        }
        if tenth == 7 && rng.gen_bool(faults.glitch) {
            run.glitches += 1;
            run.glitches_unpaired += u32::from(clock.pulse(osc.count()) == PulseUse::Unpaired);
        }
        match clock.stamp(osc.count()) {
            Some(s) => {
                let e = s.t - t;
                let z = e / (s.sd.powi(2) + quantisation.powi(2)).sqrt();
                run.samples.push((t, e, z, in_gap));
            }
            None => run.unstamped += 1,
        }
    }
    run.counts = clock.counts();
    let n = clock.noise();
    run.noise = (n.log10_factor(), n.sd(), n.decisions());
    let late = &run.nis[run.nis.len().saturating_sub(1800)..];
    run.late_nis = late.iter().sum::<f64>() / late.len().max(1) as f64;
    run
}

/// `imu` and `fixes` as the serial wire of a hub whose samples carry the counts of `osc`'s timer
/// instead of their GPS times ([`imu_ident::nav::counted`]): a counted-sample frame per
/// sample (rates and specific force in `f32`), the receiver's `TIM-TP` 0.6 s before each whole
/// GPS second and that pulse's edge captured on the timer, each fix's messages `delay` s after
/// its time (as [`crate::nav_io::ubx::serial_stream`]); in the order of their times (at the
/// same time: message, edge, sample, fix). Pulses run from the second before the first sample
/// to the last sample. `osc` must stand at or before the first sample and is advanced.
pub fn counted_stream(
    imu: &[ImuSample],
    fixes: &[GnssFix],
    delay: f64,
    osc: &mut Oscillator,
) -> Result<Vec<u8>> {
    enum Item<'a> {
        TimTp(f64),
        Edge,
        Sample(&'a ImuSample),
        Fix(&'a GnssFix),
    }
    let (Some(first), Some(last)) = (imu.first(), imu.last()) else {
        return Ok(Vec::new());
    };
    let mut items: Vec<(f64, u8, Item)> = Vec::with_capacity(imu.len() + 3 * fixes.len());
    let mut second = first.t.floor();
    while second <= last.t {
        items.push((second - 0.6, 0, Item::TimTp(second)));
        items.push((second, 1, Item::Edge));
        second += 1.0;
    }
    items.extend(imu.iter().map(|s| (s.t, 2, Item::Sample(s))));
    items.extend(fixes.iter().map(|f| (f.t + delay, 3, Item::Fix(f))));
    items.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut out = Vec::with_capacity(imu.len() * 34 + fixes.len() * 124 + 34 * items.len() / 100);
    for (t, _, item) in items {
        osc.advance(t.max(osc.time()));
        match item {
            Item::TimTp(at) => out.extend_from_slice(&encode_tim_tp(&tim_tp_at(at))),
            Item::Edge => out.extend_from_slice(&encode_edge(osc.pulse_count())),
            Item::Sample(s) => {
                let c = CountedSample {
                    count: osc.count(),
                    gyro: s.gyro.map(|x| x as f32),
                    accel: s.accel.map(|x| x as f32),
                };
                out.extend_from_slice(&encode_counted_sample(&c));
            }
            Item::Fix(f) => out.extend_from_slice(&ubx_fix_bytes(f)?),
        }
    }
    Ok(out)
}

/// How far two runs' positions are apart at the epochs of the first (`a`) from `from` [s] on
/// that the second also has: the largest north, east or down difference in `a`'s sigmas and
/// in metres, and the epochs compared.
pub fn position_difference(
    a: &[imu_ident::nav::Epoch<f32>],
    b: &[imu_ident::nav::Epoch<f32>],
    from: f64,
) -> (f64, f64, usize) {
    let (mut sig, mut m, mut n) = (0f64, 0f64, 0);
    for e in a.iter().filter(|e| e.t >= from) {
        let Some(o) = b.iter().find(|o| o.t == e.t) else {
            continue;
        };
        let [dn, de] = crate::nav_io::outages::north_east(
            e.pos.lat.to_degrees(),
            e.pos.lon.to_degrees(),
            e.pos.h,
            o.pos.lat.to_degrees(),
            o.pos.lon.to_degrees(),
        );
        for (d, sd) in [dn, de, o.pos.h - e.pos.h].iter().zip(e.sd_pos) {
            sig = sig.max(d.abs() / f64::from(sd));
            m = m.max(d.abs());
        }
        n += 1;
    }
    (sig, m, n)
}
