//! Tests of the UBX reader: a receiver's own message, corruption, the week's turn.

extern crate std;

use super::*;
use std::vec;
use std::vec::Vec;

/// A `NAV-PVT` as a receiver sent it (a public capture used as a parser's test vector): 3D fix,
/// `gnssFixOK`, 32 satellites, iTOW 486 677 000 ms, at 13.73 N 100.64 E, 25.5 m below the
/// ellipsoid (hMSL +1.97 m: the geoid there is 27 m below it), hAcc 730 mm, vAcc 1 012 mm, velocity
/// (-1, -5, 1) mm/s, sAcc 80 mm/s; its checksum `7E 4B` is the receiver's.
const CAPTURE: &str = "b56201075c00081a021dea07071f0f0a3b3717000000866a01000301ea20212bfd3bb450\
2f08809cffffb6070000da020000f4030000fffffffffbffffff01000000060000000000000050000000\
80a81201590000002c2e4c3300000000000000007e4b";

fn hex(s: &str) -> Vec<u8> {
    (0..s.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap())
        .collect()
}

fn decode(bytes: &[u8]) -> Vec<UbxMessage> {
    let mut d = UbxDecoder::new();
    bytes.iter().filter_map(|b| d.push(*b)).collect()
}

#[test]
fn a_receivers_nav_pvt_is_read_field_by_field() {
    let got = decode(&hex(CAPTURE));
    let want = NavPvt {
        itow_ms: 486_677_000,
        fix_type: 3,
        flags: 1,
        num_sv: 32,
        lon_e7: 1_006_447_393,
        lat_e7: 137_318_580,
        height_mm: -25_472,
        h_acc_mm: 730,
        v_acc_mm: 1012,
        vel_ned_mm_s: [-1, -5, 1],
        s_acc_mm_s: 80,
    };
    assert_eq!(got, [UbxMessage::NavPvt(want)]);
    // The encoder gives the same fields back (its other fields are zero, so not the capture).
    assert_eq!(decode(&encode_nav_pvt(&want)), [UbxMessage::NavPvt(want)]);
}

#[test]
fn every_single_bit_flip_is_rejected_and_the_next_message_read() {
    let msg = hex(CAPTURE);
    // From the class on: a flipped sync byte is simply not a message.
    for bit in 16..msg.len() * 8 {
        let mut bad = msg.clone();
        bad[bit / 8] ^= 1 << (bit % 8);
        let mut d = UbxDecoder::new();
        let got: Vec<_> = bad
            .iter()
            .chain(msg.iter())
            .filter_map(|b| d.push(*b))
            .collect();
        // The next message is found, however the first was hit (a corrupted length swallows
        // nothing).
        assert_eq!(got, decode(&msg), "bit {bit}");
        // The Fletcher sum catches every single-bit error in the length and payload, and a
        // flipped checksum byte is a mismatch: each is counted. A hit class or id is another
        // message, not one of ours refused.
        assert_eq!(d.rejected(), u32::from(bit / 8 >= 4), "bit {bit}");
    }
}

#[test]
fn other_messages_and_noise_are_passed_over() {
    let mon = [0xB5, 0x62, 0x0A, 0x04, 3, 0, 1, 2, 3];
    let mut ck = (0u8, 0u8);
    for b in &mon[2..] {
        ck.0 = ck.0.wrapping_add(*b);
        ck.1 = ck.1.wrapping_add(ck.0);
    }
    let mut stream = vec![0xB5, 0xB5, 0x00, 0x62];
    stream.extend_from_slice(&mon);
    stream.extend_from_slice(&[ck.0, ck.1]);
    stream.extend_from_slice(b"$GPGGA,142307.00,4812.34567,N*4C\r\n");
    // A NAV-PVT of the wrong length is refused, and the search starts again at once.
    stream.extend_from_slice(&[0xB5, 0x62, 0x01, 0x07, 0xFF, 0xFF]);
    stream.extend_from_slice(&hex(CAPTURE));
    let mut d = UbxDecoder::new();
    let got: Vec<_> = stream.iter().filter_map(|b| d.push(*b)).collect();
    assert_eq!(got.len(), 1);
    assert_eq!(d.rejected(), 1);
}

/// The fixes `f` reads in `bytes`.
fn fixes_of(f: &mut UbxFixes, bytes: &[u8]) -> Vec<LiveFix> {
    bytes
        .iter()
        .filter_map(|b| f.push(*b))
        .map(|x| x.live())
        .collect()
}

fn pvt(itow_ms: u32) -> NavPvt {
    NavPvt {
        itow_ms,
        fix_type: 3,
        flags: 1,
        num_sv: 9,
        lat_e7: 400_000_000,
        lon_e7: -1_050_000_000,
        height_mm: 1_600_000,
        h_acc_mm: 20,
        v_acc_mm: 30,
        vel_ned_mm_s: [1000, -2000, 30],
        s_acc_mm_s: 50,
    }
}

#[test]
fn fixes_need_a_week_and_a_3d_solution() {
    let mut f = UbxFixes::new(None);
    let mut feed = |bytes: &[u8]| fixes_of(&mut f, bytes);
    assert!(feed(&encode_nav_pvt(&pvt(1000))).is_empty());
    assert!(feed(&encode_nav_timegps(1250, 2374)).is_empty());
    let two_d = NavPvt {
        fix_type: 2,
        ..pvt(1250)
    };
    assert!(feed(&encode_nav_pvt(&two_d)).is_empty());
    let not_ok = NavPvt {
        flags: 0,
        ..pvt(1250)
    };
    assert!(feed(&encode_nav_pvt(&not_ok)).is_empty());
    let got = feed(&encode_nav_pvt(&pvt(1250)));
    assert_eq!(got.len(), 1);
    let fix = got[0];
    assert_eq!(fix.t, 2374.0 * WEEK_S + 1.25);
    assert_eq!(fix.pos.lat, 40f64.to_radians());
    assert_eq!(fix.pos.lon, (-105f64).to_radians());
    assert_eq!(fix.pos.h, 1600.0);
    assert_eq!(fix.vel, Some([1.0, -2.0, 0.03]));
    assert_eq!(fix.sd_pos, Some([0.02, 0.02, 0.03]));
    assert_eq!(fix.sd_vel, Some([0.05; 3]));
    // No accuracy estimate: the setup's defaults.
    let no_acc = NavPvt {
        h_acc_mm: 0,
        s_acc_mm_s: 0,
        ..pvt(1500)
    };
    let got = feed(&encode_nav_pvt(&no_acc));
    assert_eq!((got[0].sd_pos, got[0].sd_vel), (None, None));
    assert_eq!(
        f.drops(),
        UbxDrops {
            no_fix: 2,
            no_week: 1,
            time_base: 0
        }
    );
}

#[test]
fn the_weeks_turn_between_the_two_messages_is_followed() {
    let end = 604_799_750;
    let mut f = UbxFixes::new(None);
    let mut feed = |bytes: &[u8]| fixes_of(&mut f, bytes);
    assert!(feed(&encode_nav_timegps(end, 2000)).is_empty());
    // The next epoch's solution comes before its own NAV-TIMEGPS: time of week 0 of week 2001.
    assert_eq!(feed(&encode_nav_pvt(&pvt(0)))[0].t, 2001.0 * WEEK_S);
    // A week given up front holds for the first solution; the turn after it is followed.
    let mut g = UbxFixes::new(Some(2000));
    let mut feed = |bytes: &[u8]| fixes_of(&mut g, bytes);
    assert_eq!(
        feed(&encode_nav_pvt(&pvt(end)))[0].t,
        2000.0 * WEEK_S + 604_799.75
    );
    assert_eq!(
        feed(&encode_nav_pvt(&pvt(250)))[0].t,
        2001.0 * WEEK_S + 0.25
    );
}

/// The pulse times `f` reads in `bytes`.
fn pulses_of(f: &mut UbxFixes, bytes: &[u8]) -> Vec<f64> {
    let pulse = |e| match e {
        UbxEvent::Pulse(p) => Some(p.t),
        UbxEvent::Fix(_) => None,
    };
    bytes
        .iter()
        .filter_map(|b| f.push_any(*b))
        .filter_map(pulse)
        .collect()
}

#[test]
fn a_time_pulse_is_read_on_gps_time_or_on_utc_with_the_leap_seconds() {
    let t = 2374.0 * WEEK_S + 243_259.0;
    let tp = tim_tp_at(t);
    assert_eq!((tp.week, tp.tow_ms, tp.tow_sub_ms), (2374, 243_259_000, 0));
    let half = tim_tp_at(t + 0.5e-3 + 0.25e-6);
    assert_eq!(half.tow_ms, 243_259_000);
    assert_eq!(
        decode(&encode_tim_tp(&half)),
        [UbxMessage::TimTp(half)],
        "the encoder's fields are read back"
    );
    let mut f = UbxFixes::new(None);
    // GPS time base: needs nothing else (the week is in the message).
    assert_eq!(pulses_of(&mut f, &encode_tim_tp(&tp)), [t]);
    let got = pulses_of(&mut f, &encode_tim_tp(&half))[0];
    assert!((got - (t + 0.50025e-3)).abs() < 1e-9, "{}", got - t);
    // UTC: 18 s behind GPS; refused until NAV-TIMEGPS gives the leap seconds.
    let utc = TimTp {
        flags: 0b11,
        ..tim_tp_at(t - 18.0)
    };
    assert!(pulses_of(&mut f, &encode_tim_tp(&utc)).is_empty());
    assert!(pulses_of(&mut f, &encode_nav_timegps(243_258_500, 2374)).is_empty());
    assert_eq!(pulses_of(&mut f, &encode_tim_tp(&utc)), [t]);
    // Another GNSS's time (Galileo), or UTC not available: refused.
    let gal = TimTp { ref_info: 3, ..tp };
    let no_utc = TimTp { flags: 0b01, ..utc };
    assert!(pulses_of(&mut f, &encode_tim_tp(&gal)).is_empty());
    assert!(pulses_of(&mut f, &encode_tim_tp(&no_utc)).is_empty());
    assert_eq!(f.drops().time_base, 3);
}

proptest::proptest! {
    /// Whatever bytes come first (false syncs of both kinds, a candidate cut short, a wrong
    /// length), a complete message after them is read; so is an IMU frame after that.
    #[test]
    fn a_message_after_any_bytes_is_read(
        noise in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400),
        sync_at in proptest::collection::vec(0usize..400, 0..6),
    ) {
        let mut noise = noise;
        // Plant false starts of both kinds in the noise.
        for (k, at) in sync_at.iter().enumerate() {
            let head: &[u8] = if k % 2 == 0 { &[0xB5, 0x62, 0x01, 0x07, 0x5C, 0x00] } else { &[0xA5, 0x5B] };
            if *at + head.len() <= noise.len() {
                noise[*at..*at + head.len()].copy_from_slice(head);
            }
        }
        let msg = hex(CAPTURE);
        let sample = crate::nav::imu_frame::ImuSample { t: 7.0, ..Default::default() };
        let frame = crate::nav::imu_frame::encode_imu_frame(&sample);
        let mut d = UbxDecoder::new();
        let mut f = crate::nav::imu_frame::ImuFrameDecoder::new();
        let bytes: Vec<u8> = noise.iter().chain(msg.iter()).chain(frame.iter()).copied().collect();
        let got: Vec<_> = bytes.iter().filter_map(|b| d.push(*b)).collect();
        let samples: Vec<_> = bytes.iter().filter_map(|b| f.push(*b)).collect();
        let want = decode(&msg);
        proptest::prop_assert_eq!(got.last(), want.last());
        proptest::prop_assert_eq!(samples.last(), Some(&sample));
    }
}
