//! Tests of the GPS clock: wraps, lost messages and pulses, glitches, a wrong first pairing,
//! holdover and hostile input. The statistics (the filter's consistency on a simulated
//! oscillator) are in `hal-sim/tests/nav_clock.rs`.

extern crate std;

use super::*;
use std::vec::Vec;

const T0: f64 = 1.4e9;

/// A counter at `hz` whose local time runs `(1 + y)` times GPS time, from count 0 at `T0 - 10`.
fn counter(hz: f64, y: f64) -> impl Fn(f64) -> u32 {
    move |t: f64| ((t - T0 + 10.0) * (1.0 + y) * hz) as u64 as u32
}

/// Runs pulses at `T0 + k` for `k` in `ks`, each announced 0.6 s before (unless in `silent`).
fn run(clock: &mut GpsClock, c: &impl Fn(f64) -> u32, ks: &[u32], silent: &[u32]) -> Vec<PulseUse> {
    ks.iter()
        .map(|&k| {
            let t = T0 + f64::from(k);
            if !silent.contains(&k) {
                clock.announce(t, c(t - 0.6));
            }
            let _ = clock.stamp(c(t - 0.3)); // samples keep the clock called
            clock.pulse(c(t))
        })
        .collect()
}

#[test]
fn a_wrapping_84_mhz_counter_is_followed() {
    let hz = 84e6;
    let c = counter(hz, -37e-6);
    let mut clock = GpsClock::new(ClockConfig::crystal(hz)).unwrap();
    let ks: Vec<u32> = (0..200).collect(); // about four wraps
    let used = run(&mut clock, &c, &ks, &[]);
    assert_eq!(used[0], PulseUse::First);
    assert!(used[1..].iter().all(|u| *u == PulseUse::Used));
    let (y, sd) = clock.frequency_error().unwrap();
    assert!((y + 37e-6).abs() < 5.0 * sd && sd < 1e-7, "{y} {sd}");
    for k in 0..100 {
        let t = T0 + 199.0 + 0.01 * f64::from(k);
        let s = clock.stamp(c(t)).unwrap();
        // A tick is 12 ns; the stamp is within it and the f64 resolution at 1.4e9 s.
        assert!((s.t - t).abs() < 3e-7, "{}", s.t - t);
    }
    assert_eq!(clock.counts().used, 200);
}

#[test]
fn lost_messages_and_glitches_cost_nothing_once_locked() {
    let hz = 1e6;
    let c = counter(hz, 20e-6);
    let mut clock = GpsClock::new(ClockConfig::crystal(hz)).unwrap();
    // Before any announcement nothing pairs; a silent pulse after the lock pairs with its second.
    let ks: Vec<u32> = (0..30).collect();
    let used = run(&mut clock, &c, &ks, &[0, 10, 11, 20]);
    assert_eq!(used[0], PulseUse::Unpaired);
    assert_eq!(used[1], PulseUse::First);
    assert!(used[2..].iter().all(|u| *u == PulseUse::Used), "{used:?}");
    assert_eq!(clock.counts().unannounced, 3);
    // A glitch 0.3 s after a pulse pairs with nothing; one 10 us off a whole second is gated.
    assert_eq!(clock.pulse(c(T0 + 29.3)), PulseUse::Unpaired);
    assert_eq!(clock.pulse(c(T0 + 30.0 + 1e-5)), PulseUse::Rejected);
    assert_eq!(run(&mut clock, &c, &[30], &[]), [PulseUse::Used]);
    // Glitches just after a pulse pair with its second, already fused: refused, however many,
    // and the clock neither re-anchors nor restarts.
    for k in 1..=5 {
        let glitch = T0 + 30.0 + 2e-4 * f64::from(k);
        assert_eq!(clock.pulse(c(glitch)), PulseUse::Rejected);
    }
    assert_eq!(run(&mut clock, &c, &[31], &[]), [PulseUse::Used]);
    assert_eq!((clock.counts().reanchored, clock.counts().restarts), (0, 0));
    let s = clock.stamp(c(T0 + 30.5)).unwrap();
    assert!((s.t - (T0 + 30.5)).abs() < 2e-6);
}

#[test]
fn a_wrong_first_pairing_is_dropped_and_the_clock_acquires_again() {
    let hz = 1e6;
    let c = counter(hz, 0.0);
    let mut clock = GpsClock::new(ClockConfig::crystal(hz)).unwrap();
    // A glitch 0.3 s before the first pulse takes its announcement: the pulse itself pairs
    // with nothing, and every pulse after the glitch disagrees with it by 0.3 s.
    clock.announce(T0, c(T0 - 0.6));
    assert_eq!(clock.pulse(c(T0 - 0.3)), PulseUse::First);
    assert_eq!(clock.pulse(c(T0)), PulseUse::Unpaired);
    // An announcement read after its pulse (a late reader) does not pair with it either.
    clock.announce(T0 + 1.0, c(T0 + 1.1));
    assert_eq!(clock.pulse(c(T0 + 1.0)), PulseUse::Unpaired);
    let used = run(&mut clock, &c, &(2..10).collect::<Vec<_>>(), &[]);
    assert_eq!(&used[..3], [PulseUse::Rejected; 3]);
    assert_eq!(used[3], PulseUse::First);
    assert!(used[4..].iter().all(|u| *u == PulseUse::Used));
    assert_eq!(clock.counts().restarts, 1);
    let s = clock.stamp(c(T0 + 9.5)).unwrap();
    assert!((s.t - (T0 + 9.5)).abs() < 2e-6);
}

#[test]
fn without_pulses_stamps_go_on_until_their_sd_reaches_the_limit() {
    let hz = 1e6;
    let c = counter(hz, 5e-6);
    let cfg = ClockConfig {
        max_sd: 50e-6,
        ..ClockConfig::crystal(hz)
    };
    let mut clock = GpsClock::new(cfg).unwrap();
    run(&mut clock, &c, &(0..60).collect::<Vec<_>>(), &[]);
    // Stamp every second into the gap: the sd grows as sqrt(q2 tau^3 / 3) (the random walk).
    let mut last = None;
    for k in 1..400u32 {
        let t = T0 + 59.0 + f64::from(k);
        match clock.stamp(c(t)) {
            Some(s) => {
                assert!((s.t - t).abs() < 5.0 * s.sd + 1e-6, "{k}");
                last = Some((k, s.sd));
            }
            None => break,
        }
    }
    let (k, sd) = last.unwrap();
    let tau = f64::from(k);
    // The random walk's own term alone at the last stamp given, and at the next.
    let walk = |tau: f64| (cfg.q_walk * tau * tau * tau / 3.0).sqrt();
    assert!(
        sd <= 50e-6 && walk(tau) < 50e-6 && walk(tau + 2.0) > 45e-6,
        "{k} {sd}"
    );
    // The pulses come back: the clock is still locked and pairs them.
    let back = T0 + 59.0 + tau + 3.0;
    assert_eq!(
        run(&mut clock, &c, &[(back - T0) as u32], &[]),
        [PulseUse::Used]
    );
}

#[test]
fn bad_configs_and_non_finite_times_are_refused() {
    let good = ClockConfig::crystal(1e6);
    for bad in [
        ClockConfig { hz: 0.0, ..good },
        ClockConfig {
            sd_capture: f64::NAN,
            ..good
        },
        ClockConfig {
            q_walk: -1.0,
            ..good
        },
        ClockConfig {
            period: f64::INFINITY,
            ..good
        },
    ] {
        assert_eq!(GpsClock::new(bad).err(), Some(ClockError::BadConfig));
    }
    let mut clock = GpsClock::new(good).unwrap();
    clock.announce(f64::NAN, 10);
    assert_eq!(clock.pulse(20), PulseUse::Unpaired);
    assert_eq!(clock.stamp(30), None);
    assert_eq!(clock.counts().refused, 1);
}

proptest::proptest! {
    /// Any sequence of calls with any counts and times: no panic, and every stamp given is
    /// finite with its sd within the limit.
    #[test]
    fn hostile_calls_never_panic(
        calls in proptest::collection::vec(
            (0u8..3, proptest::prelude::any::<u32>(), proptest::prelude::any::<f64>()), 0..200),
    ) {
        let mut clock = GpsClock::new(ClockConfig::crystal(84e6)).unwrap();
        for (kind, count, t) in calls {
            match kind {
                0 => clock.announce(t, count),
                1 => { clock.pulse(count); }
                _ => {
                    if let Some(s) = clock.stamp(count) {
                        proptest::prop_assert!(s.t.is_finite() && s.sd <= 1e-3);
                    }
                }
            }
        }
    }
}

#[test]
fn an_announcement_at_the_newest_count_pairs_once_a_count_was_seen() {
    // A hub's wire: the counts come only with samples and edges. An announcement before any
    // count (a wire that opens with the `TIM-TP`) is read a tick before the first count, a
    // sample's or its own pulse's edge, and that pulse is the first one used (one second
    // sooner to the lock than when it paired with nothing); after a count it is read at the
    // newest count. `announce` with those counts reproduces both bit for bit.
    let hz = 1e6;
    let count = |t: f64| ((t + 5.0) * hz) as u64 as u32;
    for first_sample in [None, Some(0.3)] {
        let mut newest = GpsClock::new(ClockConfig::crystal(hz)).unwrap();
        let mut given = newest.clone();
        newest.announce_at_newest(1.0);
        let first = first_sample.map_or(count(1.0), count);
        given.announce(1.0, first - 1);
        if let Some(t) = first_sample {
            assert!(newest.stamp(count(t)).is_none() && given.stamp(count(t)).is_none());
        }
        assert_eq!(newest.pulse(count(1.0)), PulseUse::First);
        assert_eq!(given.pulse(count(1.0)), PulseUse::First);
        for k in 2..6 {
            let t = f64::from(k);
            let sample = count(t - 0.7);
            assert_eq!(newest.stamp(sample), given.stamp(sample), "sample {k}");
            newest.announce_at_newest(t);
            given.announce(t, sample);
            assert_eq!(newest.pulse(count(t)), given.pulse(count(t)), "pulse {k}");
            assert_eq!(newest.stamp(count(t + 0.2)), given.stamp(count(t + 0.2)));
        }
        assert!(newest.locked() && newest.counts() == given.counts());
    }
}
