//! The time scale of every file in [`crate::nav_io`]: GPS time as seconds since the GPS epoch,
//! 1980-01-06 00:00:00 GPST. GPST has no leap seconds, so a GPST calendar label converts to it
//! exactly (the calendar arithmetic is chrono's, on labels without a time zone), and it runs on
//! across GPS week roll-overs, unlike seconds of week. Around 2025 the values are ~1.44e9 s; an
//! f64 resolves them to 2.4e-7 s.

use chrono::{NaiveDate, NaiveDateTime, TimeDelta};

/// The GPS epoch as a calendar label.
fn epoch() -> NaiveDateTime {
    NaiveDate::from_ymd_opt(1980, 1, 6)
        .and_then(|d| d.and_hms_opt(0, 0, 0))
        .unwrap_or_default()
}

/// Seconds of one GPS week.
pub const WEEK: f64 = 604_800.0;

/// Seconds from 1970-01-01 to 1980-01-06 on a clock without leap seconds (a GPST label read as
/// a Unix timestamp, as RTKLIB's time tags store it).
pub const GPS_EPOCH_UNIX: i64 = 315_964_800;

/// GPST calendar label -> seconds since the GPS epoch.
pub fn from_calendar(label: NaiveDateTime) -> f64 {
    let d = label - epoch();
    d.num_seconds() as f64 + f64::from(d.subsec_nanos()) * 1e-9
}

/// Parses `YYYY/MM/DD HH:MM:SS[.sss]` (RTKLIB's time format; a two-digit year is 19xx from 80,
/// else 20xx, as RTKLIB reads it).
pub fn parse_calendar(date: &str, time: &str) -> Option<f64> {
    let mut label =
        NaiveDateTime::parse_from_str(&format!("{date} {time}"), "%Y/%m/%d %H:%M:%S%.f").ok()?;
    let year = chrono::Datelike::year(&label);
    if (0..100).contains(&year) {
        let add = if year < 80 { 2000 } else { 1900 };
        label = chrono::Datelike::with_year(&label, year + add)?;
    }
    Some(from_calendar(label))
}

/// GPS week and seconds of week -> seconds since the GPS epoch.
pub fn from_week_seconds(week: u32, sow: f64) -> f64 {
    f64::from(week) * WEEK + sow
}

/// A time tag's start: whole seconds of a GPST label read as a Unix timestamp plus a fraction.
pub fn from_unix_label(secs: u32, frac: f64) -> f64 {
    (i64::from(secs) - GPS_EPOCH_UNIX) as f64 + frac
}

/// Seconds since the GPS epoch -> `YYYY/MM/DD HH:MM:SS.sss` (rounded to the millisecond, the
/// carry included, as RTKLIB's `time2str` prints it); `None` for a non-finite or absurd time.
pub fn to_calendar(t: f64) -> Option<String> {
    let ms = (t * 1000.0).round();
    if !(ms.is_finite() && ms.abs() < 1e15) {
        return None;
    }
    let label = epoch().checked_add_signed(TimeDelta::try_milliseconds(ms as i64)?)?;
    Some(label.format("%Y/%m/%d %H:%M:%S%.3f").to_string())
}
