//! u-blox UBX logs and the navigator's serial wire on the host, through the core's decoders
//! (`imu_ident::nav::ubx`, `imu_ident::nav::imu_frame`): what the firmware reads is what the
//! host reads.
//!
//! - [`read_ubx`]: the GNSS fixes of a UBX binary log (a receiver's raw output; `NAV-PVT`
//!   with `NAV-TIMEGPS` for the week), as `hal-sim nav --gnss FILE.ubx` takes them.
//! - [`serial_stream`]: a log as the bytes a navigation computer receives (an IMU frame per
//!   sample, `NAV-TIMEGPS` and `NAV-PVT` per fix, each fix on the line when the IMU stream
//!   passes its time plus a delay), and [`wire_inputs`] reads such bytes back;
//!   [`stamped_inputs`] with a hub's counted samples put on GPS time, as the firmware does.
//! - [`read_wire_imu`]: the IMU samples of such a file (GPS-stamped frames, or counted ones
//!   stamped by the clock), as `hal-sim nav --imu FILE.bin` takes them.
//!
//! A fix in `NAV-PVT` is quantised: 1e-7 deg (1.1 cm of latitude), 1 mm, 1 mm/s, and the time
//! of week to 1 ms; one standard deviation for north and east (`hAcc`) and one for the three
//! velocity axes (`sAcc`): [`nav_pvt`] takes the larger of each pair.

use super::{GnssFix, ImuSample};
use anyhow::{bail, Context, Result};
use imu_ident::nav::gps_clock::ClockConfig;
use imu_ident::nav::imu_frame::{encode_imu_frame, ImuSample as WireSample};
use imu_ident::nav::serial::{NavInput, NavWire, TimerStamps, WireCounts};
use imu_ident::nav::ubx::{encode_nav_pvt, encode_nav_timegps, NavPvt, UbxFix, UbxFixes, WEEK_S};
use std::path::Path;

/// The pinned GNSS fix of a UBX solution (the core's conversions: the same numbers as the
/// firmware's `LiveFix`).
pub fn gnss_fix(u: &UbxFix) -> GnssFix {
    let p = &u.pvt;
    GnssFix {
        t: u.t,
        lat_deg: p.lat_deg(),
        lon_deg: p.lon_deg(),
        h: p.height_m(),
        vel_ned: Some(p.vel_ned()),
        sd_pos_ned: p.sd_pos(),
        sd_vel_ned: p.sd_vel(),
    }
}

/// The GNSS fixes in UBX bytes, in their order. Messages other than `NAV-PVT` and
/// `NAV-TIMEGPS` (and IMU frames on the same wire) are stepped over; solutions that are not a
/// good 3D fix, or come before the GPS week is known (`week`, else the first valid
/// `NAV-TIMEGPS`), are left out and counted.
pub fn ubx_fixes(bytes: &[u8], week: Option<u16>) -> (Vec<GnssFix>, WireCounts) {
    let mut fixes = UbxFixes::new(week);
    let out: Vec<GnssFix> = bytes
        .iter()
        .filter_map(|b| fixes.push(*b))
        .map(|u| gnss_fix(&u))
        .collect();
    let drops = fixes.drops();
    let counts = WireCounts {
        imu_rejected: 0,
        ubx_rejected: fixes.decoder().rejected(),
        no_fix: drops.no_fix,
        no_week: drops.no_week,
        time_base: drops.time_base,
    };
    (out, counts)
}

/// The GNSS fixes of a UBX log file ([`ubx_fixes`]). A file with no fix is an error.
pub fn read_ubx(path: &Path, week: Option<u16>) -> Result<(Vec<GnssFix>, WireCounts)> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let (out, counts) = ubx_fixes(&bytes, week);
    if out.is_empty() {
        bail!(
            "{}: no GNSS fix in {} bytes (a UBX log needs NAV-PVT messages with a 3D fix, and \
             NAV-TIMEGPS for the GPS week; {} solutions without a fix, {} before the week was \
             known, {} messages rejected)",
            path.display(),
            bytes.len(),
            counts.no_fix,
            counts.no_week,
            counts.ubx_rejected
        );
    }
    Ok((out, counts))
}

/// A fix as `NAV-PVT` (a good 3D fix) with its GPS week. Errors when the fix has no velocity
/// (the message always carries one) or a value out of the message's range.
pub fn nav_pvt(f: &GnssFix) -> Result<(u16, NavPvt)> {
    let Some(vel) = f.vel_ned else {
        bail!(
            "the fix at t = {} has no velocity: NAV-PVT carries one",
            f.t
        );
    };
    // Whole milliseconds first, then the week and the time of week: a time that rounds to the
    // week's end is the next week's 0.
    const WEEK_MS: f64 = WEEK_S * 1000.0;
    let ms = (f.t * 1000.0).round();
    let week = (ms / WEEK_MS).floor();
    let itow = ms - week * WEEK_MS;
    let int = |x: f64, what: &str| -> Result<i32> {
        let r = x.round();
        if r.is_finite() && r.abs() < f64::from(i32::MAX) {
            Ok(r as i32)
        } else {
            bail!(
                "the fix at t = {}: {what} {x} is out of NAV-PVT's range",
                f.t
            )
        }
    };
    let acc = |x: Option<f64>| -> u32 {
        x.filter(|v| v.is_finite() && *v > 0.0).map_or(0, |v| {
            (v * 1000.0).round().clamp(1.0, f64::from(u32::MAX)) as u32
        })
    };
    let pair = |a: Option<[f64; 3]>, i: usize, j: usize| a.map(|v| v[i].max(v[j]));
    if !(0.0..=f64::from(u16::MAX)).contains(&week) {
        bail!(
            "the fix at t = {} s is not a GPS week NAV-TIMEGPS can carry",
            f.t
        );
    }
    Ok((
        week as u16,
        NavPvt {
            itow_ms: itow as u32,
            fix_type: 3,
            flags: 1,
            num_sv: 0,
            lat_e7: int(f.lat_deg * 1e7, "latitude")?,
            lon_e7: int(f.lon_deg * 1e7, "longitude")?,
            height_mm: int(f.h * 1000.0, "height")?,
            h_acc_mm: acc(pair(f.sd_pos_ned, 0, 1)),
            v_acc_mm: acc(f.sd_pos_ned.map(|v| v[2])),
            vel_ned_mm_s: [
                int(vel[0] * 1000.0, "velocity north")?,
                int(vel[1] * 1000.0, "velocity east")?,
                int(vel[2] * 1000.0, "velocity down")?,
            ],
            s_acc_mm_s: acc(f.sd_vel_ned.map(|v| v[0].max(v[1]).max(v[2]))),
        },
    ))
}

/// The bytes of one fix: `NAV-TIMEGPS` then `NAV-PVT`, as a receiver sends them each epoch.
pub fn ubx_fix_bytes(f: &GnssFix) -> Result<Vec<u8>> {
    let (week, pvt) = nav_pvt(f)?;
    let mut out = encode_nav_timegps(pvt.itow_ms, week).to_vec();
    out.extend_from_slice(&encode_nav_pvt(&pvt));
    Ok(out)
}

/// `imu` and `fixes` as one serial stream: an IMU frame per sample (rates and specific force
/// in `f32`) and each fix's messages before the first sample later than its time plus `delay`
/// [s] (a receiver's latency; negative: ahead of the IMU), the fixes after the last sample at
/// the end.
pub fn serial_stream(imu: &[ImuSample], fixes: &[GnssFix], delay: f64) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(imu.len() * 38 + fixes.len() * 124);
    let mut k = 0;
    for s in imu {
        while let Some(f) = fixes.get(k).filter(|f| f.t + delay < s.t) {
            out.extend_from_slice(&ubx_fix_bytes(f)?);
            k += 1;
        }
        let w = WireSample {
            t: s.t,
            gyro: s.gyro.map(|x| x as f32),
            accel: s.accel.map(|x| x as f32),
        };
        out.extend_from_slice(&encode_imu_frame(&w));
    }
    for f in fixes.get(k..).unwrap_or_default() {
        out.extend_from_slice(&ubx_fix_bytes(f)?);
    }
    Ok(out)
}

/// The samples as the wire carries them: rates and specific force in single precision (the
/// host run that compares with a wire's must read these: the levelling window averages them in
/// `f64`).
pub fn as_sent(imu: &[ImuSample]) -> Vec<ImuSample> {
    imu.iter()
        .map(|s| ImuSample {
            gyro: s.gyro.map(|x| f64::from(x as f32)),
            accel: s.accel.map(|x| f64::from(x as f32)),
            ..*s
        })
        .collect()
}

/// The counter of a hub that counts its samples (`imu_ident::nav::counted`) [Hz]: the
/// navigation firmwares' `HUB_TIMER_HZ`, which `hal-sim wire --hub-ppm` writes and
/// [`read_wire_imu`] reads.
pub const HUB_TIMER_HZ: f64 = 84e6;

/// A wire's inputs, as the core's decoders read them, through a [`TimerStamps`] of `cfg` (what
/// the navigation firmware does): counted samples on GPS time (the unstamped ones dropped),
/// edges taken; with what the decoders refused, and the stamps (their clock and counts).
pub fn stamped_inputs(
    bytes: &[u8],
    cfg: ClockConfig,
) -> Result<(Vec<NavInput>, WireCounts, TimerStamps)> {
    let (inputs, counts) = wire_inputs(bytes, None);
    let mut stamps = TimerStamps::new(cfg)
        .map_err(|e| anyhow::anyhow!("the hub clock's configuration: {e:?}"))?;
    let out = inputs.into_iter().filter_map(|i| stamps.stamp(i)).collect();
    Ok((out, counts, stamps))
}

/// The samples among a wire's inputs, in `f64` of their `f32` values (what a host run on
/// what the wire carried reads).
pub fn samples_of(inputs: &[NavInput]) -> Vec<ImuSample> {
    inputs
        .iter()
        .filter_map(|i| match i {
            NavInput::Imu(s) => Some(ImuSample {
                t: s.t,
                gyro: s.gyro.map(f64::from),
                accel: s.accel.map(f64::from),
            }),
            _ => None,
        })
        .collect()
}

/// The IMU samples of a serial wire file (`hal-sim wire`, or a recording of a board's IMU
/// port): its GPS-stamped frames, and its counted ones put on GPS time by a clock of a
/// [`HUB_TIMER_HZ`] counter as the firmware puts them (those before the clock's lock left
/// out), in `f64` of the frames' `f32`. What the decoders and the clock left out is noted on
/// stderr; a file with no sample is an error naming it.
pub fn read_wire_imu(path: &Path) -> Result<Vec<ImuSample>> {
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let (inputs, counts, stamps) = stamped_inputs(&bytes, ClockConfig::crystal(HUB_TIMER_HZ))?;
    let samples = samples_of(&inputs);
    let c = stamps.counts();
    if samples.is_empty() {
        bail!(
            "{}: no IMU sample in {} bytes (IMU frames A5 5B, or a hub's counted samples A5 5C \
             with its pulse edges A5 5D and the receiver's TIM-TP; {} frames rejected, {} \
             counted samples before the clock locked, {} pulses used)",
            path.display(),
            bytes.len(),
            counts.imu_rejected,
            stamps.unstamped(),
            c.used
        );
    }
    if counts.imu_rejected > 0 || stamps.unstamped() > 0 {
        eprintln!(
            "note: {}: {} IMU samples; {} frames rejected, {} counted samples before the hub's \
             clock locked (pulses used {}, unpaired {}, rejected {})",
            path.display(),
            samples.len(),
            counts.imu_rejected,
            stamps.unstamped(),
            c.used,
            c.unpaired,
            c.rejected
        );
    }
    Ok(samples)
}

/// The samples and fixes a wire carries, in its order (the core's [`NavWire`]), with what it
/// refused.
pub fn wire_inputs(bytes: &[u8], week: Option<u16>) -> (Vec<NavInput>, WireCounts) {
    let mut wire = NavWire::new(week);
    let mut out = Vec::new();
    for &b in bytes {
        wire.push(b, &mut |i| out.push(i));
    }
    (out, wire.counts())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fix_through_the_wire_is_quantised_to_the_message() {
        let f = GnssFix {
            t: 1_436_038_458.499,
            lat_deg: 40.096_626_8,
            lon_deg: -105.147_448_3,
            h: 1601.474,
            vel_ned: Some([0.01, -0.002, -0.009]),
            sd_pos_ned: Some([0.009_899_5, 0.0099, 0.01]),
            sd_vel_ned: Some([0.058_689_9; 3]),
        };
        let (inputs, counts) = wire_inputs(&ubx_fix_bytes(&f).unwrap(), None);
        assert_eq!(counts, WireCounts::default());
        let [NavInput::Fix(got)] = inputs[..] else {
            panic!("{inputs:?}")
        };
        assert_eq!(got.t, f.t);
        assert!((got.pos.lat.to_degrees() - f.lat_deg).abs() < 1e-12);
        assert_eq!(got.pos.h, 1601.474);
        assert_eq!(got.vel, Some([0.01, -0.002, -0.009]));
        assert_eq!(got.sd_pos, Some([0.01, 0.01, 0.01]));
        assert_eq!(got.sd_vel, Some([0.059; 3]));
        let no_vel = GnssFix { vel_ned: None, ..f };
        assert!(nav_pvt(&no_vel).is_err());
    }

    #[test]
    fn a_ubx_file_with_no_fix_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("nmea-only.ubx");
        std::fs::write(&path, b"$GPGGA,142307.00,4812.34567,N*4C\r\n").unwrap();
        let e = format!("{:#}", read_ubx(&path, None).unwrap_err());
        assert!(
            e.contains("nmea-only.ubx") && e.contains("no GNSS fix"),
            "{e}"
        );
    }
}
