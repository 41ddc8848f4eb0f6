//! `nav --adapt --adapt-method bank`: the core's shadow-filter bank started in the loop, and
//! its decisions written as the window search's records ([`AdaptLog`]), so that `adapt.json`,
//! `adapt.csv` and the report show either method the same way.

use super::{AdaptLog, Coordinate, Search};
use crate::nav::drive::NavOf;
use crate::nav::shadows::{Ident, Shadows};
use anyhow::Result;
use imu_ident::nav::OnlineConfig;
use imu_ident::Real;

/// Starts the bank `online` ([`crate::nav::NavArgs::online`]) on the loop's navigator `nav`
/// at time `t`; with `per_axis_next` (`--adapt-tied-first`), the per-axis bank that takes
/// over once it settles ([`super::tied_first`]).
pub fn start_bank<T: Real>(
    online: OnlineConfig,
    per_axis_next: Option<OnlineConfig>,
    nav: &mut NavOf<T>,
    t: f64,
) -> Result<()> {
    let id = new_bank(online, nav, t)?;
    let obs = nav.observer_mut();
    obs.ident = Some(Box::new(id));
    obs.per_axis_next = per_axis_next;
    Ok(())
}

/// The core's bank `online` on `nav` from time `t`.
fn new_bank<T: Real>(online: OnlineConfig, nav: &NavOf<T>, t: f64) -> Result<Ident<T>> {
    Ident::<T>::new(online, nav, t).map_err(|e| {
        anyhow::anyhow!(
            "nav --adapt-method bank: {e} (the bank needs more than {} shadow filters?)",
            crate::nav::shadows::BANK_M
        )
    })
}

/// The record of a run identified by the bank, which started with the GNSS sd factors
/// `gnss_sd_factor` (`--gnss-sd-factor`; with `--adapt-gnss-sd` the bank's own factors
/// multiply them, as in the window search's record).
pub fn bank_log<T: Real>(shadows: &Shadows<T>, gnss_sd_factor: [f64; 2]) -> Option<AdaptLog> {
    let id = shadows.ident.as_ref()?;
    let coordinates = id
        .coordinates()
        .iter()
        .map(Coordinate::of_core)
        .chain((0..id.gnss_coordinates()).map(Coordinate::gnss))
        .collect();
    let nan = f64::NAN;
    // With `--adapt-tied-first`, the tied bank's decisions first, in this bank's coordinates.
    let imu = id.coordinates().len();
    let searches = super::tied_first::tied_decisions(shadows, id)
        .into_iter()
        .chain(
            shadows
                .log
                .iter()
                .map(|d| super::tied_first::gnss_on_start(shadows, imu, d)),
        )
        .map(|d| Search {
            t: d.t,
            window_start: d.window_start,
            fixes: d.fixes as usize,
            loglik_before: nan,
            loglik: nan,
            loglik_max: nan,
            evaluations: 0,
            tau_test: None,
            ml_log10_factors: d.log10_factors.clone(),
            identifiable: d.identifiable,
            cr_sd_log10: d.cr_sd,
            log10_factors: d.log10_factors,
        })
        .collect();
    Some(AdaptLog {
        coordinates,
        searches,
        model: id.running_model().cast(),
        base: id.base().cast(),
        gnss_sd_factor_start: gnss_sd_factor,
        tied_until: shadows.tied.as_ref().map(|t| t.t),
    })
}
