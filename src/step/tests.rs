//! Unit tests of the step: bookkeeping, flags, gate and bridging. Statistical behaviour (the
//! identification itself) is tested through `hal-sim` on simulated logs.

extern crate std;
use super::*;
use crate::model::ErrorSource;
use crate::telemetry::{
    TelemetrySink, BAD_INPUT, BRIDGED, FLAG_NAMES, GATED_OUTLIER, MISSING, SKIPPED, TIME_JUMP,
};
use std::vec::Vec;

#[derive(Default)]
struct Collect {
    records: Vec<Record>,
    params: Vec<ParamRecord>,
    acf: Vec<AcfRecord>,
}

impl TelemetrySink for Collect {
    fn record(&mut self, r: &Record) {
        self.records.push(*r);
    }
    fn params(&mut self, p: &ParamRecord) {
        self.params.push(*p);
    }
    fn acf(&mut self, a: &AcfRecord) {
        self.acf.push(*a);
    }
}

fn noise(k: u32) -> f32 {
    // A deterministic, roughly white sequence of about the paper's observation noise (0.03 m/s).
    let x = (k.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32;
    0.05 * (x - 0.5)
}

#[test]
fn bad_config_is_an_error() {
    let bad = [
        (f32::NAN, 1.0e6),
        (0.5, 1.0e6),
        (f32::INFINITY, 1.0e6),
        (30.0, 0.5),
        (30.0, 1.0e38),
    ];
    for (gate, max_gate_scale) in bad {
        let cfg = StepConfig {
            gate,
            max_gate_scale,
            ..StepConfig::default()
        };
        assert_eq!(
            Estimator::new(InsModel::paper(), cfg).err(),
            Some(StepError::BadConfig)
        );
    }
}

#[test]
fn an_isolated_jump_is_gated_and_a_persistent_one_accepted() {
    for cfg in [StepConfig::<f32>::default(), StepConfig::adaptive()] {
        let mut nav = Estimator::new(InsModel::paper(), cfg).unwrap();
        let mut sink = Collect::default();
        for k in 1..=2000u32 {
            nav.push(f64::from(k), noise(k), &mut sink);
        }
        // One GNSS jump of 5 m/s.
        nav.push(2001.0, 5.0, &mut sink);
        let r = sink.records.last().unwrap();
        assert!(r.has(GATED_OUTLIER), "flags {:#x}", r.flags);
        // A persistent 0.5 m/s offset: the gate scale grows and lets it in within a minute.
        let mut accepted_at = None;
        for k in 2002..=2100u32 {
            nav.push(f64::from(k), 0.5 + noise(k), &mut sink);
            let r = sink.records.last().unwrap();
            if accepted_at.is_none() && !r.has(GATED_OUTLIER) {
                accepted_at = Some(k);
            }
        }
        let at = accepted_at.expect("a persistent change must be accepted");
        assert!(at < 2062, "accepted only at {at}");
    }
}

#[test]
fn gaps_are_bridged_and_non_advancing_rows_skipped() {
    let mut nav = Estimator::<f32>::new(InsModel::paper(), StepConfig::default()).unwrap();
    let mut sink = Collect::default();
    nav.push(10.0, 0.01, &mut sink);
    nav.push(14.0, 0.01, &mut sink);
    nav.push(13.0, 0.01, &mut sink);
    nav.push(f64::NAN, 0.01, &mut sink);
    let flags: Vec<u16> = sink.records.iter().map(|r| r.flags).collect();
    assert_eq!(flags.len(), 7);
    assert_eq!(flags[0], 0);
    for f in &flags[1..4] {
        assert_eq!(
            *f,
            BRIDGED | MISSING,
            "bridged ticks are missing observations"
        );
    }
    assert_eq!(flags[4], 0, "the row after a bridged gap is on time");
    // t = 13 went backwards, t = NaN is unusable: both skipped, the filter untouched.
    for f in &flags[5..] {
        assert_eq!(*f & (SKIPPED | BAD_INPUT), SKIPPED | BAD_INPUT);
    }
    assert_eq!(nav.ticks(), 5);
    // t of the bridged ticks.
    let ts: Vec<f64> = sink.records.iter().take(5).map(|r| r.t).collect();
    assert_eq!(ts, [10.0, 11.0, 12.0, 13.0, 14.0]);
}

#[test]
fn a_gap_longer_than_the_bridge_is_flagged() {
    let cfg = StepConfig::<f32> {
        max_bridge: 100,
        ..StepConfig::default()
    };
    let mut nav = Estimator::new(InsModel::paper(), cfg).unwrap();
    let mut sink = Collect::default();
    nav.push(0.0, 0.0, &mut sink);
    // A real outage of 1e6 s: the first row after it is suspect (skipped), the next confirms.
    nav.push(1.0e6, 0.0, &mut sink);
    assert_eq!(sink.records.len(), 2);
    assert_eq!(sink.records[1].flags, SKIPPED | TIME_JUMP);
    nav.push(1.0e6 + 1.0, 0.0, &mut sink);
    assert_eq!(sink.records.len(), 103);
    assert!(sink.records[2..102]
        .iter()
        .all(|r| r.has(BRIDGED | MISSING)));
    assert_eq!(sink.records[102].flags, TIME_JUMP);
    assert_eq!(sink.records[102].t, 1.0e6 + 1.0);
    nav.push(1.0e6 + 2.0, 0.0, &mut sink);
    assert_eq!(sink.records[103].flags, 0, "the new time base holds");
    assert!(nav.estimates().sigma_delta.is_finite());
    // A clock reset backwards: the same, without bridging.
    nav.push(5.0, 0.0, &mut sink);
    assert_eq!(sink.records[104].flags, SKIPPED | TIME_JUMP | BAD_INPUT);
    nav.push(6.0, 0.0, &mut sink);
    assert_eq!(sink.records.len(), 106);
    assert_eq!(sink.records[105].flags, TIME_JUMP | BAD_INPUT);
    nav.push(7.0, 0.0, &mut sink);
    assert_eq!(sink.records[106].flags, 0);
}

#[test]
fn parameters_are_reported_at_start_and_acf_on_schedule() {
    let cfg = StepConfig::<f32> {
        acf_every: 500,
        ..StepConfig::default()
    };
    let mut nav = Estimator::new(InsModel::paper(), cfg).unwrap();
    let mut sink = Collect::default();
    for k in 1..=2500u32 {
        nav.push(f64::from(k), noise(k), &mut sink);
    }
    // paper: one accelerometer and one gyro Gauss-Markov component.
    assert_eq!(sink.params.len(), 2);
    assert_eq!(sink.params[0].sensor, ErrorSource::Accel);
    assert_eq!(sink.params[1].sensor, ErrorSource::Gyro);
    assert!(sink.params.iter().all(|p| p.tau > 0.0 && p.sigma > 0.0));
    // 5 schedules x 2 sensors; the window (1024) is full from the third on.
    assert_eq!(sink.acf.len(), 10);
    assert!(sink.acf[..4].iter().all(|a| a.tau.is_nan()));
    assert!(sink.acf[4..]
        .iter()
        .all(|a| a.sigma.is_finite() && a.sigma > 0.0));
}

#[test]
fn flag_names_cover_the_new_bits() {
    let all = FLAG_NAMES.iter().fold(0u16, |a, (b, _)| a | b);
    assert_eq!(all & (SKIPPED | BRIDGED), SKIPPED | BRIDGED);
}

#[test]
fn row_flags_for_missing_infinite_and_unusable_rows() {
    let mut nav = Estimator::<f64>::new(InsModel::paper(), StepConfig::default()).unwrap();
    let mut sink = Collect::default();
    let rows = [
        (1.0, 0.01),
        (2.0, f64::NAN),
        (3.0, 0.02),
        (4.0, f64::INFINITY),
        (f64::NAN, 0.0),
    ];
    for (t, z) in rows {
        nav.push(t, z, &mut sink);
    }
    let flags: Vec<u16> = sink.records.iter().map(|r| r.flags).collect();
    assert_eq!(
        flags,
        [0, MISSING, 0, MISSING | BAD_INPUT, BAD_INPUT | SKIPPED]
    );
    let ks: Vec<u32> = sink.records.iter().map(|r| r.k).collect();
    assert_eq!(ks, [0, 1, 2, 3, 4]);
    assert!(sink.records[0].nis.is_finite() && sink.records[1].nis.is_nan());
}

#[test]
fn one_corrupted_time_stamp_does_not_stop_the_navigator() {
    // A row with an absurd time (a corrupted GNSS time, a clock far in the future or past)
    // used to become the time base: every later row was skipped as going backwards (or, ahead,
    // a day of blind prediction was bridged). Now it is skipped and the old base kept.
    for bad in [1.0e300, f64::MAX, 1.0e17 + 10.0, -1.0e300, 0.0, 9.0e5] {
        let cfg = StepConfig::<f32> {
            max_bridge: 100,
            ..StepConfig::default()
        };
        let mut nav = Estimator::new(InsModel::paper(), cfg).unwrap();
        let mut sink = Collect::default();
        // Ten rows on a clock that starts at 1000 s, one bad time, ten more rows.
        let t0 = 1000.0;
        for k in 1..=10u32 {
            nav.push(t0 + f64::from(k), noise(k), &mut sink);
        }
        nav.push(bad, 0.0, &mut sink);
        let glitch = sink.records.last().unwrap();
        assert!(glitch.has(SKIPPED | TIME_JUMP), "flags {:#x}", glitch.flags);
        assert_eq!(nav.ticks(), 10, "nothing bridged for one bad time ({bad})");
        for k in 11..=20u32 {
            nav.push(t0 + f64::from(k), noise(k), &mut sink);
        }
        assert_eq!(nav.ticks(), 20, "later rows are ticked ({bad})");
        assert!(sink.records[sink.records.len() - 10..]
            .iter()
            .all(|r| r.flags == 0));
    }
}

#[test]
fn an_infinite_time_is_skipped_like_nan() {
    let mut nav = Estimator::<f32>::new(InsModel::paper(), StepConfig::default()).unwrap();
    let mut sink = Collect::default();
    nav.push(1.0, 0.0, &mut sink);
    nav.push(f64::INFINITY, 0.0, &mut sink);
    nav.push(2.0, 0.0, &mut sink);
    let flags: Vec<u16> = sink.records.iter().map(|r| r.flags).collect();
    assert_eq!(flags, [0, BAD_INPUT | SKIPPED, 0]);
}

#[test]
fn the_gate_threshold_stays_finite_under_a_stuck_source() {
    // 3000 s of a source stuck at 1e18 m/s used to grow the gate scale until `g s` overflowed
    // f32 and every observation, even an infinite NIS, passed the gate.
    let mut nav = Estimator::<f32>::new(InsModel::paper(), StepConfig::default()).unwrap();
    let mut sink = Collect::default();
    for k in 1..=6000u32 {
        nav.push(f64::from(k), 1.0e18, &mut sink);
        assert!(nav.gate_threshold().is_finite());
    }
    assert!(nav.gate_threshold() <= 30.0 * 1.0e6);
    nav.push(6001.0, 1.0e30, &mut sink);
    assert!(sink.records.last().unwrap().has(GATED_OUTLIER));
    assert!(
        nav.estimates().dv.abs() < 1.0e3,
        "the stuck value never got in"
    );
}

/// A model with every component kind, its parameters multiplied by `f` (same structure).
fn every_kind(f: f64) -> InsModel<f64> {
    use crate::model::{Component, ExpCosine, GaussMarkov, RandomConstant, RandomWalk, WhiteNoise};
    let mut m = InsModel::<f64>::paper();
    let (a, g) = (&mut m.accel, &mut m.gyro);
    a.push(Component::White(WhiteNoise::new(0.05 * f).unwrap()))
        .unwrap();
    a.push(Component::RandomWalk(
        RandomWalk::new(4e-9 * f, 0.0).unwrap(),
    ))
    .unwrap();
    g.push(Component::ExpCosine(
        ExpCosine::new(3e-6 * f, 3600.0 * f, 0.01 / f).unwrap(),
    ))
    .unwrap();
    g.push(Component::RandomConstant(
        RandomConstant::new(3e-6 * f).unwrap(),
    ))
    .unwrap();
    m.colored
        .push(GaussMarkov::new(0.2 * f, 60.0 * f).unwrap())
        .unwrap();
    m
}

/// `ParamRecord::apply_to` inverts `model_params` for every kind (the host rebuilds the
/// firmware's final model from its telemetry this way), and refuses a record whose component
/// is missing or of another kind.
#[test]
fn param_records_rebuild_the_model_they_describe() {
    let records = |m: &InsModel<f64>| {
        let mut v = Vec::new();
        model_params(m, 7, 7.0, |p| v.push(*p));
        v
    };
    // Bitwise, so that the NaN of a kind without that parameter compares equal.
    let bits = |v: &[ParamRecord]| -> Vec<_> {
        v.iter()
            .map(|p| {
                (
                    p.sensor,
                    p.component,
                    p.kind,
                    p.tau.to_bits(),
                    p.sigma.to_bits(),
                    p.beta.to_bits(),
                )
            })
            .collect()
    };
    let want = records(&every_kind(1.0));
    let mut m = every_kind(2.5);
    assert_ne!(bits(&records(&m)), bits(&want));
    assert!(want.iter().all(|p| p.apply_to(&mut m)));
    assert_eq!(bits(&records(&m)), bits(&want));

    let mut paper = InsModel::<f64>::paper();
    let before = paper.clone();
    // Component 1 of the accelerometer does not exist in `paper`; component 0 is Gauss-Markov.
    let missing = want
        .iter()
        .find(|p| p.sensor == ErrorSource::Accel && p.component == 1);
    let wrong_kind = ParamRecord {
        kind: crate::model::ComponentKind::White,
        ..want[0]
    };
    assert!(!missing.unwrap().apply_to(&mut paper));
    assert!(!wrong_kind.apply_to(&mut paper));
    assert_eq!(paper, before);
}
