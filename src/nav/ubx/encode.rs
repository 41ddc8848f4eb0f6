//! UBX messages written (for tests and the host's encoders; the firmware only reads): the
//! inverse of [`super`]'s reading, field for field.

use super::{NavPvt, TimTp, NAV_PVT, NAV_TIMEGPS, TIM_TP, UBX_SYNC, WEEK_S};

/// A whole UBX message: sync, class, id, length, `payload`, checksum (for tests and the host's
/// encoders; the firmware only reads).
fn encode<const P: usize, const M: usize>(class: u8, id: u8, payload: &[u8; P]) -> [u8; M] {
    let mut m = [0u8; M];
    let len = u16::try_from(P).unwrap_or(u16::MAX).to_le_bytes();
    let head = [UBX_SYNC[0], UBX_SYNC[1], class, id, len[0], len[1]];
    for (d, s) in m.iter_mut().zip(head.iter().chain(payload.iter())) {
        *d = *s;
    }
    let (mut a, mut b) = (0u8, 0u8);
    for x in m.iter().take(6 + P).skip(2) {
        a = a.wrapping_add(*x);
        b = b.wrapping_add(a);
    }
    if let Some(ck) = m.get_mut(6 + P..8 + P) {
        ck.copy_from_slice(&[a, b]);
    }
    m
}

/// A `NAV-PVT` message with these fields (the others zero).
pub fn encode_nav_pvt(p: &NavPvt) -> [u8; 100] {
    let mut q = [0u8; 92];
    let mut put = |o: usize, bytes: &[u8]| {
        if let Some(d) = q.get_mut(o..o + bytes.len()) {
            d.copy_from_slice(bytes);
        }
    };
    put(0, &p.itow_ms.to_le_bytes());
    put(20, &[p.fix_type, p.flags, 0, p.num_sv]);
    put(24, &p.lon_e7.to_le_bytes());
    put(28, &p.lat_e7.to_le_bytes());
    put(32, &p.height_mm.to_le_bytes());
    put(40, &p.h_acc_mm.to_le_bytes());
    put(44, &p.v_acc_mm.to_le_bytes());
    for (k, v) in p.vel_ned_mm_s.iter().enumerate() {
        put(48 + 4 * k, &v.to_le_bytes());
    }
    put(68, &p.s_acc_mm_s.to_le_bytes());
    encode(NAV_PVT.0, NAV_PVT.1, &q)
}

/// A `NAV-TIMEGPS` message with a valid time of week and week (and 18 leap seconds, valid).
pub fn encode_nav_timegps(itow_ms: u32, week: u16) -> [u8; 24] {
    let mut q = [0u8; 16];
    if let Some(t) = q.get_mut(..4) {
        t.copy_from_slice(&itow_ms.to_le_bytes());
    }
    if let Some(w) = q.get_mut(8..10) {
        w.copy_from_slice(&week.to_le_bytes());
    }
    if let Some(v) = q.get_mut(10..12) {
        // leapS 18 (GPS - UTC since 2017); valid: towValid, weekValid, leapSValid.
        v.copy_from_slice(&[18, 0b111]);
    }
    encode(NAV_TIMEGPS.0, NAV_TIMEGPS.1, &q)
}

/// A `TIM-TP` message with these fields.
pub fn encode_tim_tp(tp: &TimTp) -> [u8; 24] {
    let mut q = [0u8; 16];
    let fields = [
        &tp.tow_ms.to_le_bytes()[..],
        &tp.tow_sub_ms.to_le_bytes(),
        &tp.q_err_ps.to_le_bytes(),
        &tp.week.to_le_bytes(),
        &[tp.flags, tp.ref_info],
    ];
    for (d, s) in q.iter_mut().zip(fields.into_iter().flatten()) {
        *d = *s;
    }
    encode(TIM_TP.0, TIM_TP.1, &q)
}

/// The `TIM-TP` of a pulse at GPS time `t` [s] (GPS time base; the inverse of the reading).
pub fn tim_tp_at(t: f64) -> TimTp {
    let week = libm::floor(t / WEEK_S);
    let tow = t - week * WEEK_S;
    let ms = libm::floor(tow * 1000.0);
    let sub = libm::round((tow * 1000.0 - ms) * 4_294_967_296.0);
    TimTp {
        tow_ms: ms as u32,
        tow_sub_ms: sub.min(4_294_967_295.0) as u32,
        week: week as u16,
        ..TimTp::default()
    }
}
