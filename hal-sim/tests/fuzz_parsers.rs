//! Every parser on arbitrary input (issue 7): the host's log and model parsers (never a panic;
//! rows/models, or an error that names the file) and the firmware's decoders, the replay log
//! [`Decoder`], the navigation replay's decoder (`imu_ident::nav::replay`, its version-2 setup
//! fields above all) and the serial [`FrameDecoder`] (never a panic; a valid log decodes exactly
//! and any damage to it is an error; a valid frame is always recovered after arbitrary noise).
//!
//! Case count per test: `FUZZ_CASES` (default [`DEFAULT_CASES`], the CI budget); each test
//! prints its number of inputs and the time. The long run of issue 7 is the same tests with a
//! large `FUZZ_CASES` (RELIABILITY.md).

use imu_ident::edge::{encode_frame, FrameDecoder, FRAME_LEN};
use imu_ident::replay::{encode, encoded_len, Decoder, ReplayError, Row};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use std::time::Instant;

/// Cases per test when `FUZZ_CASES` is not set.
const DEFAULT_CASES: u32 = 2000;

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(DEFAULT_CASES)
}

/// Runs `test` on `FUZZ_CASES` inputs from `strategy` and prints the count and the time.
fn fuzz<S: Strategy>(name: &str, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>)
where
    S::Value: std::fmt::Debug,
{
    let n = cases();
    let mut runner = TestRunner::new(Config {
        cases: n,
        failure_persistence: None,
        ..Config::default()
    });
    let start = Instant::now();
    let result = runner.run(&strategy, test);
    eprintln!(
        "fuzz_parsers {name}: {n} inputs in {:.1} s",
        start.elapsed().as_secs_f64()
    );
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
}

#[test]
fn log_parser_never_panics() {
    fuzz(
        "log_text",
        "(t,z(,true_dv,true_delta,true_da,true_dw)?\n)?([-0-9.eEnaNif, x\"]{0,40}\n){0,8}",
        |body: String| {
            match hal_sim::log::read_from(body.as_bytes(), "fuzz.csv") {
                Ok(rows) => prop_assert!(rows.iter().all(|r| r.t.is_finite())),
                Err(e) => {
                    let msg = format!("{e:#}");
                    prop_assert!(msg.contains("fuzz.csv"), "{}", msg);
                }
            }
            Ok(())
        },
    );
}

#[test]
fn log_parser_on_raw_bytes() {
    fuzz(
        "log_bytes",
        proptest::collection::vec(any::<u8>(), 0..200),
        |bytes: Vec<u8>| {
            if let Err(e) = hal_sim::log::read_from(&bytes[..], "fuzz.csv") {
                let msg = format!("{e:#}");
                prop_assert!(msg.contains("fuzz.csv"), "{}", msg);
            }
            Ok(())
        },
    );
}

#[test]
fn model_parser_never_panics() {
    let strategy = (
        "(-?[0-9.e]{1,6}|nan|inf)",
        "(-?[0-9.e]{1,6}|nan)",
        "(gauss-markov|exp-cosine|random-walk|random-constant|white|pink)",
        "(-?[0-9.e]{1,6}|inf)",
        "(-?[0-9.e]{1,6})",
    );
    fuzz(
        "model_toml",
        strategy,
        |(dt, sigma_v, kind, a, b): (String, String, String, String, String)| {
            let text = format!(
                "dt = {dt}\n[observation]\nsigma_v = {sigma_v}\n[[gyro]]\nkind = \"{kind}\"\nsigma = {a}\ntau = {b}\nbeta = {b}\nq = {a}\ndensity = {a}\n"
            );
            match hal_sim::model_toml::parse(&text, "fuzz.toml") {
                Ok(m) => prop_assert!(m.layout().is_ok()),
                Err(e) => {
                    let msg = format!("{e:#}");
                    prop_assert!(msg.contains("fuzz.toml"), "{}", msg);
                }
            }
            Ok(())
        },
    );
}

/// Rows with arbitrary bit patterns (NaN payloads, infinities, subnormals included).
fn any_rows(max: usize) -> impl Strategy<Value = Vec<Row>> {
    proptest::collection::vec(
        (any::<u64>(), any::<u32>()).prop_map(|(t, z)| Row {
            t: f64::from_bits(t),
            z: f32::from_bits(z),
        }),
        0..max,
    )
}

fn encoded(rows: &[Row]) -> Vec<u8> {
    let mut buf = vec![0u8; encoded_len(rows.len()).expect("small log")];
    let n = encode(rows, &mut buf).expect("buffer sized by encoded_len");
    assert_eq!(n, buf.len());
    buf
}

/// Feeds `bytes` to a fresh [`Decoder`] one at a time, checking that errors are sticky; returns
/// the rows handed out and the result of `finish`.
fn decode_all(bytes: &[u8]) -> Result<(Vec<Row>, Result<u32, ReplayError>), TestCaseError> {
    let mut dec = Decoder::new();
    let mut rows = Vec::new();
    let mut failed: Option<ReplayError> = None;
    for &b in bytes {
        match dec.push(b) {
            Ok(Some(r)) => {
                prop_assert!(failed.is_none(), "a row after an error");
                rows.push(r);
            }
            Ok(None) => prop_assert!(failed.is_none(), "no error after an error"),
            Err(e) => {
                if let Some(first) = failed {
                    prop_assert_eq!(e, first, "errors are sticky");
                }
                failed = Some(e);
            }
        }
    }
    let fin = dec.finish();
    if let Some(e) = failed {
        prop_assert_eq!(fin, Err(e));
    }
    prop_assert_eq!(dec.rows_seen() as usize, rows.len());
    Ok((rows, fin))
}

fn same_rows(a: &[Row], b: &[Row]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.t.to_bits() == y.t.to_bits() && x.z.to_bits() == y.z.to_bits())
}

#[test]
fn replay_decoder_on_raw_bytes() {
    // Random bytes, and random bytes behind a valid magic and version (so that the header, row
    // and trailer stages all see garbage).
    let strategy = (
        any::<bool>(),
        proptest::collection::vec(any::<u8>(), 0..300),
    );
    fuzz(
        "replay_bytes",
        strategy,
        |(header, mut bytes): (bool, Vec<u8>)| {
            if header {
                let mut head = b"IMUR\x01\x00\x0c\x00".to_vec();
                let count = bytes.first().map_or(0, |c| u32::from(*c % 8));
                head.extend_from_slice(&count.to_le_bytes());
                head.extend_from_slice(&bytes);
                bytes = head;
            }
            let (rows, fin) = decode_all(&bytes)?;
            if let Ok(n) = fin {
                prop_assert_eq!(n as usize, rows.len());
                prop_assert_eq!(Some(bytes.len()), encoded_len(rows.len()));
            }
            Ok(())
        },
    );
}

/// What is done to a valid log.
#[derive(Debug, Clone)]
enum Damage {
    /// One byte replaced by a different value.
    Byte { at: usize, xor: u8 },
    /// Cut to `len % (length + 1)` bytes.
    Truncate { len: usize },
    /// Bytes appended after the checksum.
    Append(Vec<u8>),
    /// Several arbitrary changes (result: anything but a panic).
    Many(Vec<(usize, u8)>),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(at, xor)| Damage::Byte { at, xor }),
        any::<usize>().prop_map(|len| Damage::Truncate { len }),
        proptest::collection::vec(any::<u8>(), 1..20).prop_map(Damage::Append),
        proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8).prop_map(Damage::Many),
    ]
}

#[test]
fn replay_decoder_on_mutated_logs() {
    fuzz(
        "replay_mutated",
        (any_rows(12), damage()),
        |(rows, damage): (Vec<Row>, Damage)| {
            let good = encoded(&rows);
            let (back, fin) = decode_all(&good)?;
            prop_assert_eq!(fin, Ok(rows.len() as u32));
            prop_assert!(same_rows(&back, &rows), "round trip changed the rows");
            let mut bad = good.clone();
            match damage {
                Damage::Byte { at, xor } => {
                    let i = at % bad.len();
                    bad[i] ^= xor;
                    // CRC-32 detects every error burst of up to 32 bits; a changed header field
                    // is caught by its own check or by the structure it announces.
                    let (_, fin) = decode_all(&bad)?;
                    prop_assert!(fin.is_err(), "byte {} ^ {:#x} undetected", i, xor);
                }
                Damage::Truncate { len } => {
                    let n = len % (bad.len() + 1);
                    bad.truncate(n);
                    let (_, fin) = decode_all(&bad)?;
                    if n < good.len() {
                        prop_assert_eq!(fin, Err(ReplayError::Truncated), "cut at {}", n);
                    }
                }
                Damage::Append(extra) => {
                    bad.extend_from_slice(&extra);
                    let (back, fin) = decode_all(&bad)?;
                    prop_assert_eq!(fin, Err(ReplayError::TrailingData));
                    prop_assert!(same_rows(&back, &rows));
                }
                Damage::Many(changes) => {
                    for (at, v) in changes {
                        let i = at % bad.len();
                        bad[i] = v;
                    }
                    let (back, fin) = decode_all(&bad)?;
                    if fin.is_ok() && bad != good {
                        // Possible only by a CRC collision (2^-32): report it as a failure.
                        prop_assert!(false, "damaged log accepted with {} rows", back.len());
                    }
                }
            }
            Ok(())
        },
    );
}

/// Feeds `bytes` to `dec`; returns every row with the index of the byte that completed it, and
/// checks that each returned row is exactly the frame formed by the last `FRAME_LEN` bytes.
fn frames(dec: &mut FrameDecoder, bytes: &[u8]) -> Result<Vec<(usize, Row)>, TestCaseError> {
    let mut out = Vec::new();
    for (i, &b) in bytes.iter().enumerate() {
        if let Some(row) = dec.push(b) {
            prop_assert!(i + 1 >= FRAME_LEN, "a frame from {} bytes", i + 1);
            let window = &bytes[i + 1 - FRAME_LEN..=i];
            prop_assert_eq!(&encode_frame(row)[..], window, "row is not the last frame");
            out.push((i, row));
        }
    }
    Ok(out)
}

fn any_row() -> impl Strategy<Value = Row> {
    (any::<u64>(), any::<u32>()).prop_map(|(t, z)| Row {
        t: f64::from_bits(t),
        z: f32::from_bits(z),
    })
}

/// Noise with plenty of sync bytes in it (arbitrary bytes rarely contain `A5 5A`).
fn noise() -> impl Strategy<Value = Vec<u8>> {
    proptest::collection::vec(
        prop_oneof![4 => any::<u8>(), 1 => Just(0xA5u8), 1 => Just(0x5Au8)],
        0..120,
    )
}

#[test]
fn frame_decoder_on_raw_bytes() {
    fuzz("frame_bytes", noise(), |bytes: Vec<u8>| {
        let mut dec = FrameDecoder::new();
        let got = frames(&mut dec, &bytes)?;
        // A random 18-byte window passes the CRC with probability 2^-32.
        prop_assert!(got.is_empty(), "a frame out of noise: {:?}", got);
        Ok(())
    });
}

#[test]
fn frame_decoder_recovers_a_frame_after_noise() {
    // Noise, a damaged copy of a frame (a few bytes changed, or cut short), noise, then the
    // frame itself: it must come out, at its last byte, whatever came before.
    let strategy = (
        noise(),
        any_row(),
        proptest::collection::vec((0..FRAME_LEN, any::<u8>()), 0..4),
        0..=FRAME_LEN,
        noise(),
        any_row(),
    );
    fuzz(
        "frame_recovery",
        strategy,
        |(pre, bad_row, changes, keep, mid, row)| {
            let mut bytes = pre;
            let mut damaged = encode_frame(bad_row);
            for (i, v) in changes {
                damaged[i] = v;
            }
            bytes.extend_from_slice(&damaged[..keep]);
            bytes.extend_from_slice(&mid);
            let frame = encode_frame(row);
            bytes.extend_from_slice(&frame);
            let mut dec = FrameDecoder::new();
            let got = frames(&mut dec, &bytes)?;
            let last = bytes.len() - 1;
            let found = got
                .iter()
                .any(|(i, r)| *i == last && encode_frame(*r) == frame);
            // The one exception: a cut copy completed by the frame's own first bytes (its
            // missing tail equal to them: 1 in 256 when one byte is cut and the last one happens
            // to be the sync byte) is a valid frame that ends inside this one, whose leading
            // bytes it has consumed. Two overlapping frames never occur on a real line.
            let copy = encode_frame(bad_row);
            let start = bytes.len() - FRAME_LEN;
            let overlapped = got
                .iter()
                .any(|(i, r)| *i >= start && *i < last && encode_frame(*r) == copy);
            prop_assert!(found || overlapped, "frame not recovered; got {:?}", got);
            // Nothing else, except the damaged copy when it is intact after all (no byte changed
            // or the following bytes complete it).
            let spurious = got
                .iter()
                .filter(|(i, r)| *i != last && encode_frame(*r) != copy)
                .count();
            prop_assert_eq!(spurious, 0, "spurious frames {:?}", got);
            Ok(())
        },
    );
}

/// The exception of [`frame_decoder_recovers_a_frame_after_noise`], found by it in CI
/// (2026-12-01): a copy cut one byte short whose last byte is the sync byte that starts the next
/// frame. The decoder sees the copy whole at that byte and the next frame's header is gone with
/// it; the frame after that comes out again.
#[test]
fn a_cut_copy_completed_by_the_next_frame_takes_its_first_byte() {
    let bad = Row {
        t: -8.872294705309457e-290,
        z: 199096.78,
    };
    let row = Row { t: 0.0, z: 0.0 };
    let copy = encode_frame(bad);
    let frame = encode_frame(row);
    assert_eq!(
        copy[FRAME_LEN - 1],
        frame[0],
        "the case needs the copy's last byte = sync"
    );
    let mut bytes = copy[..FRAME_LEN - 1].to_vec();
    bytes.extend_from_slice(&frame);
    bytes.extend_from_slice(&frame);
    let got = frames(&mut FrameDecoder::new(), &bytes).unwrap();
    assert_eq!(got.first().map(|(i, _)| *i), Some(FRAME_LEN - 1));
    assert_eq!(got.last().map(|(i, _)| *i), Some(bytes.len() - 1));
    assert_eq!(got.len(), 2, "{got:?}");
}

/// The navigation replay's setup with arbitrary version-2 fields (the non-holonomic
/// constraint's sd and lever arm, any bit pattern, NaN = off; the heading flag) and a few
/// records. The encoding is the comparison: a NaN field has no `==`.
fn nav_replay(nhc: (u64, [u64; 3], bool), n: usize) -> Vec<u8> {
    use imu_ident::nav::replay::{GnssRecord, ImuRecord, Record};
    use imu_ident::nav::{ImuErrorModel, NavInit, NavSetup};
    use imu_ident::strapdown::{Geodetic, Quat};
    let (sd, lever, heading_known) = nhc;
    let pos = Geodetic {
        lat: 0.8,
        lon: 0.1,
        h: 300.0,
    };
    let setup = NavSetup {
        t0: 100.0,
        pos,
        att: Quat::from_euler(0.0, 0.0, 0.4),
        vel: [0.0; 3],
        gyro_bias: None,
        imu: ImuErrorModel::default(),
        init: NavInit {
            sd_att: nalgebra::Vector3::repeat(0.02),
            sd_vel: 0.1,
            sd_pos: 1.0,
        },
        lever_arm: [0.3, 0.0, -0.8],
        obs_sd: [0.5, 0.5, 1.0, 0.1, 0.1, 0.2],
        step: 1.0,
        gate: Some(1.0),
        max_imu_gap: 0.1,
        max_rejections: 3,
        sd_factor: [1.0; 2],
        heading_sd: 0.035,
        scale_factor_sd: None,
        nhc_sd: Some(f64::from_bits(sd)).filter(|v| !v.is_nan()),
        nhc_lever: lever.map(f64::from_bits),
        zupt: None,
        online: None,
        heading_known,
        live: None,
    };
    let records: Vec<Record> = (0..n)
        .map(|k| {
            let t = 100.0 + 0.01 * (k + 1) as f64;
            if k % 4 == 3 {
                Record::Gnss(GnssRecord {
                    t,
                    pos,
                    vel: [1.0, 0.0, 0.0],
                    sd_pos: [f32::NAN; 3],
                    sd_vel: [f32::NAN; 3],
                    flags: 4,
                    yaw: 0.0,
                })
            } else {
                Record::Imu(ImuRecord {
                    t,
                    gyro: [0.0; 3],
                    accel: [0.0, 0.0, -9.8],
                })
            }
        })
        .collect();
    let mut out = Vec::new();
    imu_ident::nav::replay::encode(&setup, &records, |b| out.extend_from_slice(b))
        .unwrap_or_else(|e| panic!("{e}"));
    out
}

/// The setup decoded from `bytes` encoded again (with no records), and the decoder's verdict.
fn nav_decode(
    bytes: &[u8],
) -> (
    Option<Vec<u8>>,
    Result<u32, imu_ident::nav::replay::NavReplayError>,
) {
    use imu_ident::nav::replay::{encode, Decoder, Event};
    let mut dec = Decoder::new();
    let mut setup = None;
    for &b in bytes {
        match dec.push(b) {
            Ok(Some(Event::Setup)) => {
                let mut out = Vec::new();
                if let Some(s) = dec.setup() {
                    let _ = encode(s, &[], |b| out.extend_from_slice(b));
                }
                setup = Some(out);
            }
            Ok(_) => {}
            Err(e) => return (setup, Err(e)),
        }
    }
    (setup, dec.finish())
}

#[test]
fn nav_replay_decoder_on_mutated_setups() {
    let fields = (any::<u64>(), any::<[u64; 3]>(), any::<bool>());
    fuzz(
        "nav_replay_mutated",
        (fields, 0usize..6, damage()),
        |(nhc, n, damage)| {
            let good = nav_replay(nhc, n);
            let (setup, fin) = nav_decode(&good);
            prop_assert_eq!(fin, Ok(n as u32));
            // The setup round-trips bit for bit (NaN sd: off; any lever, any flag).
            prop_assert_eq!(setup, Some(nav_replay(nhc, 0)));
            let mut bad = good.clone();
            match damage {
                Damage::Byte { at, xor } => {
                    let i = at % bad.len();
                    bad[i] ^= xor;
                    prop_assert!(nav_decode(&bad).1.is_err(), "byte {} ^ {:#x}", i, xor);
                }
                Damage::Truncate { len } => {
                    bad.truncate(len % good.len());
                    prop_assert!(nav_decode(&bad).1.is_err());
                }
                Damage::Append(extra) => {
                    bad.extend_from_slice(&extra);
                    let (_, fin) = nav_decode(&bad);
                    prop_assert_eq!(
                        fin,
                        Err(imu_ident::nav::replay::NavReplayError::TrailingData)
                    );
                }
                Damage::Many(changes) => {
                    for (at, v) in changes {
                        let i = at % bad.len();
                        bad[i] = v;
                    }
                    // Anything but a panic; accepted only if unchanged (or a CRC collision).
                    let (_, fin) = nav_decode(&bad);
                    prop_assert!(fin.is_err() || bad == good, "damaged replay accepted");
                }
            }
            Ok(())
        },
    );
}
