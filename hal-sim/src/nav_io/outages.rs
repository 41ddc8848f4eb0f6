//! Simulated GNSS outages (`--outages START,LEN,PERIOD,MARGIN`) and their score: the horizontal
//! position error at the end of each outage against the RTK reference (the scoring of the real
//! drive's README, the same as its source's).

use super::gnss_csv::GnssFix;
use anyhow::{anyhow, bail, Result};
use serde::Serialize;
use std::str::FromStr;

/// `START,LEN,PERIOD,MARGIN` [s]: outage `k` withholds GNSS over
/// `[t0 + START + k PERIOD, t0 + START + k PERIOD + LEN)`, `t0` the first GNSS epoch, for every
/// `k` whose start is before the last GNSS epoch minus `MARGIN`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OutageSpec {
    /// Start of the first outage after the first GNSS epoch [s].
    pub start: f64,
    /// Length of each outage [s].
    pub len: f64,
    /// Start-to-start spacing [s].
    pub period: f64,
    /// No outage starts later than this before the last GNSS epoch [s].
    pub margin: f64,
}

impl OutageSpec {
    /// The simulation benches' schedule (issue 16): 60-s outages every 20 min from 10 min
    /// after `t_sim0`, the simulation's time zero, for a log whose first GNSS epoch is at
    /// `t_first_fix`; none starts in the last 3 min.
    pub fn every_20_min(t_sim0: f64, t_first_fix: f64) -> Self {
        Self {
            start: t_sim0 + 600.0 - t_first_fix,
            len: 60.0,
            period: 1200.0,
            margin: 180.0,
        }
    }
}

impl FromStr for OutageSpec {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        let v: Vec<f64> = s
            .split(',')
            .map(|x| {
                x.trim()
                    .parse::<f64>()
                    .map_err(|_| anyhow!("--outages: {x:?} is not a number"))
            })
            .collect::<Result<_>>()?;
        let [start, len, period, margin] = v[..] else {
            bail!("--outages: expected START,LEN,PERIOD,MARGIN (4 numbers, seconds), found {s:?}");
        };
        if !v.iter().all(|x| x.is_finite() && *x >= 0.0) {
            bail!("--outages: every value must be a finite number >= 0, found {s:?}");
        }
        if len <= 0.0 || period < len {
            bail!(
                "--outages: need LEN > 0 and PERIOD >= LEN (outages must not overlap), found {s:?}"
            );
        }
        Ok(Self {
            start,
            len,
            period,
            margin,
        })
    }
}

/// One outage `[start, end)` [s].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Outage {
    /// First withheld time.
    pub start: f64,
    /// End (exclusive).
    pub end: f64,
}

impl OutageSpec {
    /// The outages for GNSS epochs from `t_first` to `t_last`.
    pub fn schedule(&self, t_first: f64, t_last: f64) -> Vec<Outage> {
        let stop = t_last - self.margin;
        // A spec built by hand with a zero or non-finite period has one outage, not endless ones.
        let count = if self.period > 0.0 && self.period.is_finite() {
            u32::MAX
        } else {
            1
        };
        (0u32..count)
            .map(|k| t_first + self.start + f64::from(k) * self.period)
            .take_while(|&s| s < stop && s.is_finite())
            .map(|start| Outage {
                start,
                end: start + self.len,
            })
            .collect()
    }
}

/// True when `t` falls in one of `outages` (sorted): that GNSS epoch is withheld.
pub fn withheld(outages: &[Outage], t: f64) -> bool {
    let k = outages.partition_point(|o| o.start <= t);
    k > 0 && t < outages[k - 1].end
}

/// The horizontal error at the end of one outage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OutageScore {
    /// The outage.
    pub outage: Outage,
    /// Time of the last reference epoch inside the outage, where the error is taken [s].
    pub t: f64,
    /// Solution minus reference, north and east [m].
    pub err_ne: [f64; 2],
    /// Horizontal error [m].
    pub err_h: f64,
}

/// Statistics of the horizontal errors over the scored outages [m].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OutageSummary {
    /// Every scored outage.
    pub outages: Vec<OutageScore>,
    /// Outages without a reference epoch inside, or outside the solution's time span.
    pub unscored: usize,
    /// Root mean square.
    pub rms: f64,
    /// Median.
    pub median: f64,
    /// Maximum.
    pub max: f64,
}

/// North and east offsets [m] of `(lat, lon)` from `(lat0, lon0)` [deg] at height `h`, through
/// the core's meridian and transverse radii of curvature (`imu_ident::strapdown::earth`, Groves
/// eq. 2.105-2.106); exact to first order in the offset, i.e. to ~1e-6 relative for the tens of
/// metres scored here.
pub fn north_east(lat0: f64, lon0: f64, h: f64, lat: f64, lon: f64) -> [f64; 2] {
    use imu_ident::strapdown::earth::{radius_east, radius_north};
    let phi = lat0.to_radians();
    let mut dlon = lon - lon0;
    if dlon > 180.0 {
        dlon -= 360.0;
    } else if dlon < -180.0 {
        dlon += 360.0;
    }
    [
        (lat - lat0).to_radians() * (radius_north(phi) + h),
        dlon.to_radians() * (radius_east(phi) + h) * phi.cos(),
    ]
}

/// One solution point: time [s], latitude and longitude [deg].
pub type TrackPoint = (f64, f64, f64);

/// Linear interpolation of the track (sorted by time) at `t`; `None` outside it.
fn interpolate(track: &[TrackPoint], t: f64) -> Option<(f64, f64)> {
    let k = track.partition_point(|p| p.0 <= t);
    if k == 0 {
        return None;
    }
    let a = track[k - 1];
    if a.0 == t {
        return Some((a.1, a.2));
    }
    let b = *track.get(k)?;
    let u = (t - a.0) / (b.0 - a.0);
    Some((a.1 + u * (b.1 - a.1), a.2 + u * (b.2 - a.2)))
}

/// Scores a solution track against the reference (e.g. the RTK fixes, `Q = 1`) at the end of
/// each outage: the last reference epoch before the outage ends (and not before it starts),
/// the solution linearly interpolated to that time, the horizontal distance between the two.
/// RMS, median and maximum over the scored outages (NaN when none is).
pub fn score_outages(
    track: &[TrackPoint],
    reference: &[GnssFix],
    outages: &[Outage],
) -> OutageSummary {
    let mut scores = Vec::new();
    for o in outages {
        let k = reference.partition_point(|f| f.t < o.end);
        let Some(r) = k.checked_sub(1).map(|i| reference[i]) else {
            continue;
        };
        if r.t < o.start {
            continue;
        }
        let Some((lat, lon)) = interpolate(track, r.t) else {
            continue;
        };
        let err_ne = north_east(r.lat_deg, r.lon_deg, r.h, lat, lon);
        scores.push(OutageScore {
            outage: *o,
            t: r.t,
            err_ne,
            err_h: err_ne[0].hypot(err_ne[1]),
        });
    }
    let errs: Vec<f64> = scores.iter().map(|s| s.err_h).collect();
    let n = errs.len() as f64;
    let rms = (errs.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    OutageSummary {
        unscored: outages.len() - scores.len(),
        rms,
        median: crate::shared_data::median(&errs),
        max: errs.iter().copied().fold(f64::NAN, f64::max),
        outages: scores,
    }
}
