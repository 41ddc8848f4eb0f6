//! `nav --adapt --adapt-method bank --adapt-per-axis --adapt-tied-first`: the bank runs tied
//! until it settles, then a per-axis bank takes over from its point (host only: 47 filters).
//!
//! Neither bank alone serves both kinds of sensor (BENCHMARKS.md "The bank per axis, and
//! sensors whose axes differ"). The tied bank fails where the axes differ: the best tied model
//! is itself short there (its ML reference). The per-axis bank from a far start fails where
//! they are alike: from a model too quiet the axes explain the fixes' excess jointly, and its
//! single-axis parabolas do not add up to the tied one. Started where the tied bank settled
//! (its first decision that keeps its window, [`Shadows::settled`]), about its estimate and
//! with its offset, the per-axis bank's parabolas are local
//! (BENCHMARKS.md "Tied first, then per axis").
//!
//! The record shows one history: the tied bank's decisions are written in the per-axis
//! coordinates, as log10 factors on the per-axis bank's reference (the tied estimate at the
//! switch), each axis taking its sensor's tied value. The GNSS factors stay on the run's
//! start; the per-axis bank's start from the navigator's at the switch (the tied bank's
//! running factors, raised by their Cramér-Rao sd, about 0.01 decade).

use super::value;
use crate::nav::drive::NavOf;
use crate::nav::shadows::{Decision, Ident, Shadows, TiedBank};
use anyhow::Result;
use imu_ident::nav::OnlineConfig;
use imu_ident::Real;

/// With `--adapt-tied-first`, once the tied bank has settled: starts the per-axis bank at time
/// `t` about the tied estimate, with the tied bank's offset, and keeps the tied bank's record.
pub fn switch_if_settled<T: Real>(nav: &mut NavOf<T>, t: f64) -> Result<()> {
    let gnss_sd_factor = nav.gnss_sd_factor().map(|f| f.as_f64());
    let obs = nav.observer();
    let (Some(next), true, Some(tied)) = (obs.per_axis_next, obs.settled, obs.ident.as_deref())
    else {
        return Ok(());
    };
    let offset = tied.offset();
    let cfg = OnlineConfig {
        offset,
        min_offset: next.min_offset.min(offset),
        ..next
    };
    // About the tied estimate: the running model is raised (`OnlineConfig::conservative`),
    // and the per-axis bank raises its own estimate again.
    let estimate = tied.estimate_model();
    let bank = Ident::<T>::new_about(cfg, nav, t, &estimate)
        .map_err(|e| anyhow::anyhow!("nav --adapt-tied-first: the per-axis bank: {e}"))?;
    let obs = nav.observer_mut();
    let Some(tied) = obs.ident.replace(Box::new(bank)) else {
        return Ok(());
    };
    obs.per_axis_next = None;
    obs.tied = Some(TiedBank {
        coords: tied.coordinates().to_vec(),
        base: tied.base().clone(),
        log: std::mem::take(&mut obs.log),
        gnss_sd_factor,
        t,
    });
    Ok(())
}

/// The tied bank's decisions in the per-axis bank `id`'s coordinates (module docs).
pub fn tied_decisions<T: Real>(shadows: &Shadows<T>, id: &Ident<T>) -> Vec<Decision> {
    let Some(tied) = shadows.tied.as_ref() else {
        return Vec::new();
    };
    let coords = id.coordinates();
    let (base, tied_base) = (id.base().cast::<f64>(), tied.base.cast::<f64>());
    // For each per-axis coordinate: its tied coordinate, and its reference's log10 ratio to
    // the tied one's on that axis.
    let map: Vec<Option<(usize, f64)>> = coords
        .iter()
        .map(|c| {
            let j = tied.coords.iter().position(|u| {
                u.axis.is_none()
                    && u.sensor == c.sensor
                    && u.component == c.component
                    && u.quantity == c.quantity
            })?;
            let c = super::Coordinate::of_core(c);
            let ratio = value(&base, [1.0; 2], &c) / value(&tied_base, [1.0; 2], &c);
            (ratio > 0.0 && ratio.is_finite()).then(|| (j, ratio.log10()))
        })
        .collect();
    let (n_tied, gnss) = (tied.coords.len(), id.gnss_coordinates());
    let nan = f64::NAN;
    tied.log
        .iter()
        .map(|d: &Decision| {
            let at = |v: &[f64], j: usize| v.get(j).copied().unwrap_or(nan);
            let imu = |v: &[f64], shift: bool| -> Vec<f64> {
                map.iter()
                    .map(|m| match m {
                        Some((j, r)) => at(v, *j) - if shift { *r } else { 0.0 },
                        None => nan,
                    })
                    .collect()
            };
            // The GNSS factors stay on the run's start ([`gnss_on_start`]).
            let factors: Vec<f64> = imu(&d.log10_factors, true)
                .into_iter()
                .chain((0..gnss).map(|k| at(&d.log10_factors, n_tied + k)))
                .collect();
            let cr_sd: Vec<f64> = imu(&d.cr_sd, false)
                .into_iter()
                .chain((0..gnss).map(|k| at(&d.cr_sd, n_tied + k)))
                .collect();
            let identifiable = map
                .iter()
                .map(|m| m.is_some_and(|(j, _)| d.identifiable.get(j).copied().unwrap_or(false)))
                .chain((0..gnss).map(|k| d.identifiable.get(n_tied + k).copied().unwrap_or(false)))
                .collect();
            Decision {
                t: d.t,
                window_start: d.window_start,
                fixes: d.fixes,
                log10_factors: factors,
                cr_sd,
                identifiable,
            }
        })
        .collect()
}

/// The per-axis bank's decision `d` (IMU coordinates `imu`, then the GNSS ones) with its GNSS
/// factors moved onto the run's start: the per-axis bank's are on the navigator's at the
/// switch, which the tied bank had set (its own on the start, where the navigator's are ones).
pub fn gnss_on_start<T: Real>(shadows: &Shadows<T>, imu: usize, d: &Decision) -> Decision {
    let mut out = d.clone();
    if let Some(tied) = shadows.tied.as_ref() {
        for (x, f) in out
            .log10_factors
            .iter_mut()
            .skip(imu)
            .zip(tied.gnss_sd_factor)
        {
            *x += f.log10();
        }
    }
    out
}
