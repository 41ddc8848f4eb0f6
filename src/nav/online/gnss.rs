//! The factors on the GNSS fixes' standard deviations in the bank
//! ([`OnlineConfig::gnss_sd`]): each shadow's factors relative to the running filter's, and
//! what the running filter takes. Their step is in `newton.rs` (`variance_scale`).

use super::coords::GNSS_COORDS;
#[cfg(doc)]
use super::OnlineConfig;
use super::OnlineIdent;
#[cfg(doc)]
use crate::nav::navigator::NavObserver;
use crate::Real;

impl<T: Real, const N: usize, const M: usize> OnlineIdent<T, N, M> {
    /// The number of coordinates on the GNSS fixes' standard deviations (0, or
    /// [`GNSS_COORDS`]: position, then velocity), after the IMU's.
    pub fn gnss_coordinates(&self) -> usize {
        self.gnss
    }

    /// Each shadow's factors on the variances of the GNSS fixes it is given, which are the
    /// running filter's (position rows, velocity rows): `10^(2 (x_k - x_run))` for shadow
    /// `k`'s GNSS coordinates `x_k` and the running filter's `x_run`. Called whenever either
    /// moves, so that every shadow scores the fixes under its own factors.
    /// Without the GNSS factors every shadow keeps the ones it was built with.
    pub(super) fn sync_gnss(&mut self) {
        if self.gnss != GNSS_COORDS {
            return;
        }
        let imu = self.coords.len();
        for k in 0..self.shadows.len() {
            let f = self.factors(k);
            let mut gain = [T::one(); GNSS_COORDS];
            for (i, g) in gain.iter_mut().enumerate() {
                let xk = f.get(imu + i).map_or(0.0, |v| v.as_f64());
                let xr = self.run_gnss.get(i).copied().unwrap_or(0.0);
                *g = T::lit(libm::pow(10.0, 2.0 * (xk - xr)));
            }
            if let Some(sh) = self.shadows.get_mut(k) {
                sh.r_gain = gain;
            }
        }
    }

    /// The running filter's GNSS factors (log10), with [`OnlineConfig::conservative`] raised
    /// as the intensities are ([`running_model`](Self::running_model)).
    pub(super) fn running_gnss(&self) -> [f64; GNSS_COORDS] {
        let imu = self.coords.len();
        let mut out = [0.0; GNSS_COORDS];
        if self.gnss == GNSS_COORDS {
            for (i, o) in out.iter_mut().enumerate() {
                *o = self.est.get(imu + i).copied().unwrap_or(0.0) + self.raise(imu + i);
            }
        }
        out
    }

    /// The factors (not log10) the running filter applies to the fixes' standard deviations,
    /// stated or the model's default, position and velocity ([`NavObserver::gnss_sd_factor`]):
    /// the navigator's when the bank started, times the bank's; the navigator's without
    /// [`OnlineConfig::gnss_sd`].
    pub fn running_gnss_sd(&self) -> [f64; GNSS_COORDS] {
        let mut out = [1.0; GNSS_COORDS];
        for ((o, r), x) in out.iter_mut().zip(self.gnss_ref).zip(self.run_gnss) {
            *o = libm::pow(10.0, r + x);
        }
        out
    }
}
