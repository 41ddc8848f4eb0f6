//! Tests of the navigation replay format (`super`).

extern crate std;
use super::*;
use crate::model::{Component, GaussMarkov, RandomWalk, WhiteNoise};
use nalgebra::Vector3;
use std::vec;
use std::vec::Vec;

fn setup() -> NavSetup {
    let mut imu = ImuErrorModel::default();
    let _ = imu.set_all_gyro(&[
        Component::White(WhiteNoise { density: 6.6e-5 }),
        Component::GaussMarkov(GaussMarkov {
            sigma: 5e-4,
            tau: 300.0,
        }),
    ]);
    let _ = imu.set_all_accel(&[Component::RandomWalk(RandomWalk {
        q: 1e-8,
        sigma0: 1e-3,
    })]);
    let _ = imu.accel[2].push(Component::White(WhiteNoise { density: 1e-3 }));
    NavSetup {
        t0: 1.0e6 + 0.01,
        pos: Geodetic {
            lat: 0.9,
            lon: -0.2,
            h: 120.5,
        },
        att: Quat::from_euler(0.01, -0.02, 1.5),
        vel: [0.0, 0.1, -0.2],
        gyro_bias: Some([1e-4, -2e-4, 3e-5]),
        imu,
        init: NavInit {
            sd_att: Vector3::new(0.01, 0.01, 0.05),
            sd_vel: 0.1,
            sd_pos: 1.0,
        },
        lever_arm: [0.5, 0.0, -1.0],
        obs_sd: [0.5, 0.5, 1.0, 0.1, 0.1, 0.2],
        step: 1.0,
        gate: Some(1.0),
        max_imu_gap: 0.1,
        max_rejections: 3,
        sd_factor: [1.0, 2.0],
        heading_sd: 0.035,
        scale_factor_sd: Some([0.01, 0.002]),
        nhc_sd: Some(0.05),
        nhc_lever: [0.1, -0.2, 0.65],
        zupt: Some(Zupt {
            sd: 0.02,
            gyro_max: 0.15,
            accel_max: 0.6,
            speed_max: 0.5,
        }),
        online: Some(crate::nav::OnlineConfig {
            first: 300.0,
            every: 900.0,
            offset: 0.25,
            min_offset: 0.03125,
            bound: 1.5,
            min_gain: 2.0,
            min_fixes: 30,
            memory: 1800.0,
            conservative: false,
            per_axis: true,
            taus: true,
            hold_flat_taus: true,
            gnss_sd: true,
            flat_waits: false,
            exit_z: 1.5,
        }),
        heading_known: true,
        live: Some(crate::nav::live::LiveConfig {
            align: 50.0,
            yaw: Some(0.4),
            static_gyro_bias: false,
            yaw_speed: 3.0,
            fix_interval: 0.5,
            use_velocity: true,
            latency: 0.25,
        }),
    }
}

fn records(n: usize) -> Vec<Record> {
    (0..n)
        .map(|k| {
            let t = 1.0e6 + 0.01 * (k + 2) as f64;
            if k % 5 == 4 {
                Record::Gnss(GnssRecord {
                    t,
                    pos: Geodetic {
                        lat: 0.9 + k as f64 * 1e-9,
                        lon: -0.2,
                        h: 121.0,
                    },
                    vel: [1.0, f32::NAN, 0.0],
                    sd_pos: [0.5, 0.5, 1.0],
                    sd_vel: [f32::NAN; 3],
                    flags: gnss_flags::FUSE | gnss_flags::HEADING,
                    yaw: 0.3,
                })
            } else {
                Record::Imu(ImuRecord {
                    t,
                    gyro: [1e-3, -2e-3, k as f32 * 1e-4],
                    accel: [0.1, 0.2, -9.8],
                })
            }
        })
        .collect()
}

fn encoded(s: &NavSetup, r: &[Record]) -> Vec<u8> {
    let mut out = Vec::new();
    encode(s, r, |b| out.extend_from_slice(b)).unwrap_or_else(|e| panic!("{e}"));
    out
}

fn decoded(bytes: &[u8]) -> Result<(Option<NavSetup>, Vec<Record>), NavReplayError> {
    let mut dec = Decoder::new();
    let mut setup = None;
    let mut recs = Vec::new();
    for &b in bytes {
        match dec.push(b)? {
            Some(Event::Setup) => setup = dec.setup().cloned(),
            Some(Event::Record(r)) => recs.push(r),
            None => {}
        }
    }
    dec.finish()?;
    Ok((setup, recs))
}

fn same_bits(a: &Record, b: &Record) -> bool {
    // NaN fields: compare the encodings.
    encoded(&setup(), &[*a]) == encoded(&setup(), &[*b])
}

#[test]
fn round_trip_is_bit_exact() {
    let s = setup();
    let r = records(23);
    let bytes = encoded(&s, &r);
    let imu_n = r.iter().filter(|x| matches!(x, Record::Imu(_))).count();
    let comps = 3 * 2 + 3 + 1;
    assert_eq!(
        bytes.len(),
        HEADER_LEN
            + SETUP_LEN
            + comps * COMPONENT_LEN
            + imu_n * (1 + IMU_LEN)
            + (r.len() - imu_n) * (1 + GNSS_LEN)
            + TRAILER_LEN
    );
    let (back_s, back_r) = decoded(&bytes).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back_s.as_ref(), Some(&s));
    let back_s = back_s.unwrap_or_else(|| panic!("no setup"));
    // The version-2 fields, bit for bit.
    assert_eq!(back_s.nhc_sd.map(f64::to_bits), Some(0.05f64.to_bits()));
    assert_eq!(
        back_s.nhc_lever.map(f64::to_bits),
        s.nhc_lever.map(f64::to_bits)
    );
    assert!(back_s.heading_known);
    assert_eq!(back_r.len(), r.len());
    for (a, b) in r.iter().zip(&back_r) {
        assert!(same_bits(a, b), "{a:?} != {b:?}");
    }
}

#[test]
fn no_gate_no_bias_no_constraint_and_no_records_round_trip() {
    let mut s = setup();
    s.gate = None;
    s.gyro_bias = None;
    s.imu = ImuErrorModel::default();
    // Without the constraint its lever arm is kept, and the heading flag is off.
    s.nhc_sd = None;
    s.zupt = None;
    s.online = None;
    s.heading_known = false;
    let (back, recs) = decoded(&encoded(&s, &[])).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back, Some(s));
    assert!(recs.is_empty());
}

#[test]
fn every_truncation_and_bit_flip_is_detected() {
    let bytes = encoded(&setup(), &records(6));
    for n in 0..bytes.len() {
        assert!(decoded(&bytes[..n]).is_err(), "length {n}");
    }
    for i in 0..bytes.len() * 8 {
        let mut bad = bytes.clone();
        bad[i / 8] ^= 1 << (i % 8);
        assert!(decoded(&bad).is_err(), "bit {i} flipped undetected");
    }
    let mut long = bytes;
    long.push(0);
    assert_eq!(decoded(&long), Err(NavReplayError::TrailingData));
}

#[test]
fn header_errors_are_specific() {
    let good = encoded(&setup(), &records(2));
    let mut bad = good.clone();
    bad[0] = b'X';
    assert_eq!(decoded(&bad), Err(NavReplayError::BadMagic));
    let mut bad = good.clone();
    bad[4] = 10;
    assert_eq!(decoded(&bad), Err(NavReplayError::BadVersion(10)));
    let mut bad = good.clone();
    bad[HEADER_LEN + SETUP_LEN - 8] = 9; // gyro x: 9 components
    assert_eq!(decoded(&bad), Err(NavReplayError::BadField));
    let mut bad = good.clone();
    bad[HEADER_LEN + SETUP_LEN - 2] = 128; // an undefined setup flag
    assert_eq!(decoded(&bad), Err(NavReplayError::BadField));
    let mut bad = good;
    bad[HEADER_LEN + SETUP_LEN - 1] = 4; // an undefined live flag
    assert_eq!(decoded(&bad), Err(NavReplayError::BadField));
}

/// Version-1 to version-8 replays (shorter setups: no constraint, zero-velocity update or
/// online identification; the online identification without its memory or GNSS factors;
/// version 6 without the flat coordinates' flag, version 7 without the test for leaving the
/// grid, version 8 without the live start)
/// are refused at their header with the version they have, before their setup could be
/// misread; the message says which one is read.
#[test]
fn older_versions_are_refused_with_their_number() {
    for v in [1u16, 2, 3, 4, 5, 6, 7, 8] {
        let mut old = encoded(&setup(), &records(2));
        old[4..6].copy_from_slice(&v.to_le_bytes());
        let e = decoded(&old).err();
        assert_eq!(e, Some(NavReplayError::BadVersion(v)));
        let msg = std::format!("{}", NavReplayError::BadVersion(v));
        assert!(
            msg.contains(&std::format!("version {v}")) && msg.contains("version 9"),
            "{msg}"
        );
        let mut dec = Decoder::new();
        let errs: Vec<_> = old[..HEADER_LEN].iter().map(|&b| dec.push(b)).collect();
        assert_eq!(errs.last(), Some(&Err(NavReplayError::BadVersion(v))));
    }
}

/// Every setup field lands at its documented offset: the constraint's sd and lever arm, the
/// zero-velocity update's sd and bounds, the online identification's nine values, then the
/// live start's five values are the last twenty-two `f64` of the block; the setup flags and
/// the live flags its last two bytes.
#[test]
fn version_9_fields_are_at_their_documented_offsets() {
    let s = setup();
    let bytes = encoded(&s, &[]);
    let f64_at = |k: usize| {
        let o = HEADER_LEN + 8 * k;
        f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap_or([0; 8]))
    };
    assert_eq!(SETUP_LEN, 58 * 8 + 9);
    assert_eq!(f64_at(36), 0.05);
    assert_eq!([f64_at(37), f64_at(38), f64_at(39)], s.nhc_lever);
    assert_eq!(
        [f64_at(40), f64_at(41), f64_at(42), f64_at(43)],
        [0.02, 0.15, 0.6, 0.5]
    );
    assert_eq!(
        (44..53).map(f64_at).collect::<Vec<_>>(),
        [300.0, 900.0, 0.25, 0.03125, 1.5, 2.0, 30.0, 1800.0, 1.5]
    );
    assert_eq!(
        (53..58).map(f64_at).collect::<Vec<_>>(),
        [50.0, 0.4, 3.0, 0.5, 0.25]
    );
    assert_eq!(bytes[HEADER_LEN + SETUP_LEN - 1], live_flags::USE_VELOCITY);
    assert_eq!(
        bytes[HEADER_LEN + SETUP_LEN - 2],
        setup_flags::HEADING_KNOWN
            | setup_flags::ONLINE_PER_AXIS
            | setup_flags::ONLINE_TAUS
            | setup_flags::ONLINE_HOLD_FLAT_TAUS
            | setup_flags::ONLINE_GNSS_SD
    );
    let mut off = s.clone();
    off.nhc_sd = None;
    off.zupt = None;
    off.online = None;
    off.live = None;
    let bytes = encoded(&off, &[]);
    for k in [36, 40, 44, 53] {
        let o = HEADER_LEN + 8 * k;
        assert!(f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap_or([0; 8])).is_nan());
    }
}

#[test]
fn arbitrary_bytes_never_panic() {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        s
    };
    let good = encoded(&setup(), &records(8));
    for _ in 0..3000 {
        let mut bytes: Vec<u8> = if next() % 2 == 0 {
            let len = (next() % 600) as usize;
            (0..len).map(|_| next() as u8).collect()
        } else {
            let mut b = good.clone();
            for _ in 0..1 + next() % 3 {
                let i = (next() as usize) % b.len();
                b[i] = next() as u8;
            }
            b.truncate((next() as usize) % (good.len() + 1));
            b
        };
        if next() % 4 == 0 {
            bytes = vec![0u8; (next() % 400) as usize];
        }
        let _ = decoded(&bytes);
    }
}
