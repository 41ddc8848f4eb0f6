//! RTKLIB solution files (`.pos`), read and written, in the format of RTKLIB's `solution.c`
//! (`outsolheads`, `outpos`, `decode_solllh`) that rtkplot and rtkpost use.
//!
//! Reading: lines starting with `%` are the header; it gives the time system (only `GPST` is
//! accepted: UTC would need a leap-second table) and the position format (only
//! `latitude(deg)`, i.e. lat/lon/height in decimal degrees; ECEF `x-ecef(m)`, dms and ENU
//! baselines are refused with an error saying how to write llh) and the field separator (the
//! character after `latitude(deg)`; a space means any run of blanks). Each data line is a time,
//! either `YYYY/MM/DD HH:MM:SS.sss` or `WWWW SSSSSS.SSS` (GPS week and seconds of week; told
//! apart per line, as RTKLIB does), then, positionally: `lat lon h Q ns sdn sde sdu sdne sdeu
//! sdun age ratio` and optionally `vn ve vu sdvn sdve sdvu sdvne sdveu sdvun`. The up velocity
//! is turned into down. The cross terms `sdne, sdeu, sdun` are signed square roots of the
//! covariances (RTKLIB's `sqvar`). Times become seconds since 1980-01-06 GPST ([`super::gpst`]).

use super::gnss_csv::GnssFix;
use super::gpst;
use anyhow::{anyhow, bail, Context, Result};
use std::path::Path;

/// Solution quality `Q` codes of RTKLIB.
pub mod q {
    /// Fixed integer ambiguities (RTK fix).
    pub const FIX: u8 = 1;
    /// Float ambiguities.
    pub const FLOAT: u8 = 2;
    /// SBAS.
    pub const SBAS: u8 = 3;
    /// DGPS.
    pub const DGPS: u8 = 4;
    /// Single point.
    pub const SINGLE: u8 = 5;
    /// PPP.
    pub const PPP: u8 = 6;
    /// Dead reckoning (RTKLIB 2.4.3 `SOLQ_DR`): use it for INS-only epochs.
    pub const DR: u8 = 7;
}

/// One epoch of a `.pos` file.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PosEpoch {
    /// Time, position, NED velocity and standard deviations.
    pub fix: GnssFix,
    /// Quality (see [`q`]).
    pub q: u8,
    /// Number of satellites.
    pub ns: u16,
    /// `sdne, sdeu, sdun` [m]: signed square roots of the covariances.
    pub sd_cross: [f64; 3],
    /// Age of differential [s].
    pub age: f64,
    /// Ambiguity ratio.
    pub ratio: f64,
    /// `sdvne, sdveu, sdvun` [m/s], when the velocity is there.
    pub sd_vel_cross: [f64; 3],
}

/// How the times of a file were written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeFormat {
    /// `YYYY/MM/DD HH:MM:SS.sss`.
    Calendar,
    /// `WWWW SSSSSS.SSS`.
    WeekSeconds,
}

/// A `.pos` file.
#[derive(Debug, Clone, PartialEq)]
pub struct PosFile {
    /// Every epoch, in file order.
    pub epochs: Vec<PosEpoch>,
    /// Time format of the first data line.
    pub time_format: Option<TimeFormat>,
}

impl PosFile {
    /// The fixes of quality `1 <= Q <= max_q` (`max_q = 1`: RTK fixes only; 2: fix and float).
    pub fn fixes(&self, max_q: u8) -> Vec<GnssFix> {
        self.epochs
            .iter()
            .filter(|e| (1..=max_q).contains(&e.q))
            .map(|e| e.fix)
            .collect()
    }

    /// Number of epochs of quality `q`.
    pub fn count_q(&self, q: u8) -> usize {
        self.epochs.iter().filter(|e| e.q == q).count()
    }
}

/// Reads an RTKLIB `.pos` file (see the module documentation). Errors name the file, the line
/// and the field.
pub fn read_pos(path: &Path) -> Result<PosFile> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {file}"))?;
    parse_pos(&text, &file)
}

const FIELDS: [&str; 22] = [
    "lat", "lon", "h", "Q", "ns", "sdn", "sde", "sdu", "sdne", "sdeu", "sdun", "age", "ratio",
    "vn", "ve", "vu", "sdvn", "sdve", "sdvu", "sdvne", "sdveu", "sdvun",
];

/// Parses the text of a `.pos` file; `file` names it in errors.
pub fn parse_pos(text: &str, file: &str) -> Result<PosFile> {
    let mut sep: Option<char> = None;
    let mut epochs: Vec<PosEpoch> = Vec::new();
    let mut time_format = None;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let s = raw.trim_end_matches('\r');
        if let Some(head) = s.strip_prefix('%') {
            check_header(head, file, line, &mut sep)?;
            continue;
        }
        if s.trim().is_empty() {
            continue;
        }
        let tokens: Vec<&str> = match sep {
            Some(c) if c != ' ' && c != '\t' => s.split(c).map(str::trim).collect(),
            _ => s.split_whitespace().collect(),
        };
        // With a non-blank separator the date and clock are still one field "date time".
        let tokens: Vec<&str> = tokens.iter().flat_map(|t| t.split_whitespace()).collect();
        let (t, fmt, rest) = parse_time(&tokens, file, line)?;
        time_format.get_or_insert(fmt);
        let e = parse_fields(rest, t, file, line)?;
        if let Some(p) = epochs.last() {
            if e.fix.t <= p.fix.t {
                bail!(
                    "{file} line {line}: time {} does not increase (previous {})",
                    gpst::to_calendar(e.fix.t).unwrap_or_default(),
                    gpst::to_calendar(p.fix.t).unwrap_or_default()
                );
            }
        }
        epochs.push(e);
    }
    Ok(PosFile {
        epochs,
        time_format,
    })
}

fn check_header(head: &str, file: &str, line: usize, sep: &mut Option<char>) -> Result<()> {
    if head.contains("x-ecef(m)") {
        bail!("{file} line {line}: ECEF x/y/z solutions are not supported: write the solution as lat/lon/height in degrees (RTKLIB out-solformat=llh, out-degfmt=deg)");
    }
    if head.contains("latitude(d'\")") {
        bail!("{file} line {line}: latitude in deg-min-sec is not supported: write it in decimal degrees (RTKLIB out-degfmt=deg)");
    }
    if head.contains("e-baseline(m)") {
        bail!("{file} line {line}: ENU baselines are not supported: write lat/lon/height (RTKLIB out-solformat=llh)");
    }
    if let Some(p) = head.find("latitude(deg)") {
        if head.contains("UTC") || head.contains("JST") {
            bail!("{file} line {line}: times in UTC/JST are not supported (no leap-second table): write them in GPST (RTKLIB out-timesys=gpst)");
        }
        *sep = head[p + "latitude(deg)".len()..].chars().next();
    }
    Ok(())
}

fn parse_time<'a>(
    tokens: &'a [&'a str],
    file: &str,
    line: usize,
) -> Result<(f64, TimeFormat, &'a [&'a str])> {
    let (Some(a), Some(b)) = (tokens.first(), tokens.get(1)) else {
        bail!("{file} line {line}: expected a time (YYYY/MM/DD HH:MM:SS.sss or WWWW SSSSSS.SSS)");
    };
    if a.contains('/') {
        let t = gpst::parse_calendar(a, b).ok_or_else(|| {
            anyhow!("{file} line {line}, field time: expected YYYY/MM/DD HH:MM:SS.sss, found {a:?} {b:?}")
        })?;
        return Ok((t, TimeFormat::Calendar, &tokens[2..]));
    }
    let week = a.parse::<u32>().ok().filter(|w| *w <= 9999);
    let sow = b
        .parse::<f64>()
        .ok()
        .filter(|s| (0.0..gpst::WEEK).contains(s));
    match (week, sow) {
        (Some(w), Some(s)) => Ok((
            gpst::from_week_seconds(w, s),
            TimeFormat::WeekSeconds,
            &tokens[2..],
        )),
        _ => bail!("{file} line {line}, field time: expected YYYY/MM/DD HH:MM:SS.sss or GPS week and seconds of week, found {a:?} {b:?}"),
    }
}

fn parse_fields(rest: &[&str], t: f64, file: &str, line: usize) -> Result<PosEpoch> {
    let n = rest.len();
    if n < 5 {
        bail!(
            "{file} line {line}: expected at least lat lon h Q ns after the time, found {n} fields"
        );
    }
    if n > FIELDS.len() {
        bail!(
            "{file} line {line}: {n} fields after the time, at most {} expected",
            FIELDS.len()
        );
    }
    let mut v = [0.0; 22];
    for (k, tok) in rest.iter().enumerate() {
        let x: f64 = tok.parse().map_err(|_| {
            anyhow!(
                "{file} line {line}, field {}: expected a number, found {tok:?}",
                FIELDS[k]
            )
        })?;
        if !x.is_finite() {
            bail!(
                "{file} line {line}, field {}: expected a finite number, found {tok}",
                FIELDS[k]
            );
        }
        v[k] = x;
    }
    if v[0].abs() > 90.0 {
        bail!(
            "{file} line {line}, field lat: {} is not a latitude in degrees",
            v[0]
        );
    }
    // Q and ns are integers; some writers print them as floats ("1.0000000").
    let int = |k: usize, max: f64| -> Result<f64> {
        let x = v[k];
        if x.fract() != 0.0 || !(0.0..=max).contains(&x) {
            bail!(
                "{file} line {line}, field {}: expected an integer 0..{max}, found {x}",
                FIELDS[k]
            );
        }
        Ok(x)
    };
    let q = int(3, f64::from(q::DR))? as u8;
    let ns = int(4, f64::from(u16::MAX))? as u16;
    let group = |from: usize| (n >= from + 3).then(|| [v[from], v[from + 1], v[from + 2]]);
    let sd_pos = group(5);
    let vel = group(13).map(|[vn, ve, vu]| [vn, ve, -vu]);
    let sd_vel = group(16);
    for (g, from) in [(sd_pos, 5), (sd_vel, 16)] {
        if let Some(k) = g.and_then(|s| (0..3).find(|&k| s[k] < 0.0)) {
            bail!(
                "{file} line {line}, field {}: a standard deviation cannot be negative",
                FIELDS[from + k]
            );
        }
    }
    Ok(PosEpoch {
        fix: GnssFix {
            t,
            lat_deg: v[0],
            lon_deg: v[1],
            h: v[2],
            vel_ned: vel,
            sd_pos_ned: sd_pos,
            sd_vel_ned: sd_vel,
        },
        q,
        ns,
        sd_cross: [v[8], v[9], v[10]],
        age: v[11],
        ratio: v[12],
        sd_vel_cross: [v[19], v[20], v[21]],
    })
}

/// Writes `epochs` as an RTKLIB llh solution file in GPST (`YYYY/MM/DD HH:MM:SS.sss`), with
/// RTKLIB's own header lines and field widths (`outsolheads`/`outpos`: lat/lon `%14.9f`, h
/// `%10.4f`, Q and ns `%3d`, sd `%8.4f`, age `%6.2f`, ratio `%6.1f`, velocity `%10.5f`), so
/// rtkplot reads it. The velocity columns are written when every epoch has a velocity. A
/// missing sd is written as 0 (RTKLIB's "unknown"). `program` goes into a `% program` line.
pub fn write_solution_pos(path: &Path, epochs: &[PosEpoch], program: &str) -> Result<()> {
    let with_vel = !epochs.is_empty() && epochs.iter().all(|e| e.fix.vel_ned.is_some());
    crate::output::write_atomic(path, |w| {
        writeln!(w, "% program   : {program}")?;
        writeln!(w, "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of satellites)")?;
        // "%  %-20s " with the time system: 16 + 3 decimals + 1, as outsolheads pads it.
        write!(
            w,
            "%  {:<20} {:>14} {:>14} {:>10} {:>3} {:>3} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>6}",
            "GPST", "latitude(deg)", "longitude(deg)", "height(m)", "Q", "ns", "sdn(m)",
            "sde(m)", "sdu(m)", "sdne(m)", "sdeu(m)", "sdun(m)", "age(s)", "ratio"
        )?;
        if with_vel {
            write!(
                w,
                " {:>10} {:>10} {:>10} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8}",
                "vn(m/s)", "ve(m/s)", "vu(m/s)", "sdvn", "sdve", "sdvu", "sdvne", "sdveu", "sdvun"
            )?;
        }
        writeln!(w)?;
        for e in epochs {
            let f = &e.fix;
            let time = gpst::to_calendar(f.t)
                .ok_or_else(|| anyhow!("time {} cannot be written as a GPST date", f.t))?;
            let sd = f.sd_pos_ned.unwrap_or([0.0; 3]);
            write!(
                w,
                "{time} {:14.9} {:14.9} {:10.4} {:3} {:3} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4} {:6.2} {:6.1}",
                f.lat_deg, f.lon_deg, f.h, e.q, e.ns, sd[0], sd[1], sd[2], e.sd_cross[0],
                e.sd_cross[1], e.sd_cross[2], e.age, e.ratio
            )?;
            if let (true, Some(v)) = (with_vel, f.vel_ned) {
                let s = f.sd_vel_ned.unwrap_or([0.0; 3]);
                let c = e.sd_vel_cross;
                write!(
                    w,
                    " {:10.5} {:10.5} {:10.5} {:9.5} {:8.5} {:8.5} {:8.5} {:8.5} {:8.5}",
                    v[0], v[1], -v[2], s[0], s[1], s[2], c[0], c[1], c[2]
                )?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
}
