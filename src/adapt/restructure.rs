//! Carrying the filter's state across a structure switch (one component's kind replaced, see
//! [`window::structure`](super::window::structure)).
//!
//! The navigation errors and every component that did not change keep their estimates and
//! their covariances (cross-covariances included), converted between the two models' state
//! scalings. The replaced component's states start from the new component's stationary
//! covariance, uncorrelated with the rest, and zero mean: its old estimate is of another
//! process (an exponential-cosine's output is a combination of two states, not the first one),
//! and the filter re-estimates it within about one correlation time.

// Small fixed-size matrix code reads best with explicit indices.
#![allow(clippy::needless_range_loop)]

use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::information::Information;
use crate::adapt::{AdaptError, Switch};
use crate::linalg::Arr;
use crate::Real;

/// The state and covariance of `new` (scaled by `s_new`, `n` active states, initial covariance
/// `p0_new`) that carry `x, P` of the old model (scaled by `s_old`) through `map`.
pub fn carry<T: Real, const N: usize>(
    map: &[Option<usize>; N],
    x: &[T; N],
    p: &Arr<T, N>,
    s_old: &[T; N],
    s_new: &[T; N],
    p0_new: &Arr<T, N>,
    n: usize,
) -> ([T; N], Arr<T, N>) {
    let n = n.min(N);
    let mut xn = [T::zero(); N];
    let mut pn = *p0_new;
    // Physical value = scale x scaled value, so a carried entry is multiplied by the old scale
    // and divided by the new one (twice for a covariance).
    let ratio = |i: usize, j: usize| s_old[j] / s_new[i];
    for i in 0..n {
        let Some(oi) = map[i].filter(|&o| o < N) else {
            // A new state: its prior row and column (the new block's own entries stay).
            for j in 0..n {
                if map[j].is_some() {
                    pn[i][j] = T::zero();
                    pn[j][i] = T::zero();
                }
            }
            continue;
        };
        xn[i] = x[oi] * ratio(i, oi);
        for j in 0..n {
            if let Some(oj) = map[j].filter(|&o| o < N) {
                pn[i][j] = p[oi][oj] * ratio(i, oi) * ratio(j, oj);
            }
        }
    }
    (xn, pn)
}

/// The switch itself (this module is a child of [`super`], so it reads the filter's fields).
impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    super::AdaptiveFilter<T, M, N, Z, W>
{
    /// Replaces the model's structure by the search's alternative `sw` (found on a window of
    /// `blocks` block means): a new bank at `sw.theta`
    /// that carries the centre's state ([`restructure`]), new specs and bounds, and fresh
    /// information (its layout changed). On error nothing is changed.
    pub(super) fn switch_structure(
        &mut self,
        sw: &Switch<T>,
        blocks: u32,
    ) -> Result<(), AdaptError> {
        // The same alternative the search built: its block length and window.
        let block_s = self.global.block_seconds();
        let window_s = T::lit(f64::from(blocks)) * block_s;
        let alt = super::window::structure::alternative(
            &self.id.base,
            &self.id.specs,
            &self.id.theta,
            &self.id.theta,
            &self.id.bounds,
            sw.site,
            block_s,
            window_s,
        )
        .ok_or(AdaptError::BadParameter)?;
        let model = (alt.base)
            .with_parameters(&alt.specs, &sw.theta)
            .ok_or(AdaptError::BadParameter)?;
        let map = self
            .id
            .base
            .state_map(&model)
            .ok_or(AdaptError::BadParameter)?;
        let scale = model.scaling().map_err(AdaptError::Model)?;
        let outputs = model.outputs(&scale).map_err(AdaptError::Model)?;
        let old_scale = *self.id.bank.scale_array();
        let (x, p) = (self.id.bank.centre().kf.x, self.id.bank.centre().kf.P);
        // In place (a second bank would not fit on the firmware's stack); `init` changes nothing
        // on error, and a failed `set_theta` is rolled back to the bank `init` built (from
        // `base`, whose scaling it keeps) at the old point and state.
        self.id.bank.init(&model, &alt.specs, self.id.cfg.h)?;
        if let Err(e) = self.id.bank.set_theta(&sw.theta) {
            let _ = self
                .id
                .bank
                .init(&self.id.base, &self.id.specs, self.id.cfg.h);
            let _ = self.id.bank.set_theta(&self.id.theta);
            self.id.bank.reset_states(&x, &p);
            return Err(e);
        }
        let (xn, pn) = carry(
            &map,
            &x,
            &p,
            &old_scale,
            self.id.bank.scale_array(),
            self.id.bank.p0(),
            self.id.bank.active(),
        );
        self.id.bank.reset_states(&xn, &pn);
        self.global
            .restructure(&self.id.specs, &alt.specs, &sw.theta);
        // The bank's scaling comes from this model: it is the new base.
        self.id.base = model;
        self.id.specs = alt.specs;
        self.id.theta = sw.theta;
        self.id.bounds = alt.bounds;
        self.outputs = outputs;
        self.id.forget_window(true);
        self.id.total = Information::default();
        if self.id.cfg.probe_factor > T::one() {
            self.id
                .probes
                .init(&self.id.specs, self.id.cfg.probe_factor, self.id.bank.p0());
            self.id
                .probes
                .anchor(&self.id.theta, &self.id.bounds, self.id.specs.len());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{ErrorModel, InsModel, NX};

    /// Paper -> gyro exp-cosine: the navigation errors and the accelerometer's state are
    /// carried (with the scalings' ratio), the gyro's two new states start at their prior.
    #[test]
    fn switching_the_gyro_keeps_the_rest_of_the_state() {
        let old = InsModel::<f64>::paper();
        let new = old.swapped(&old.site(1).unwrap(), 0.01).unwrap();
        let map = old.state_map(&new).unwrap();
        assert_eq!(&map[..5], &[Some(0), Some(1), Some(2), None, None]);
        let (so, sn) = (
            ErrorModel::scaling(&old).unwrap(),
            ErrorModel::scaling(&new).unwrap(),
        );
        let sys = new.system(&sn).unwrap();
        let p0: Arr<f64, NX> = sys.P0;
        let mut x = [0.0; NX];
        let mut p = [[0.0; NX]; NX];
        for i in 0..4 {
            x[i] = 1.0 + i as f64;
            for j in 0..4 {
                p[i][j] = if i == j { 2.0 } else { 0.5 };
            }
        }
        let (xn, pn) = carry(&map, &x, &p, &so, &sn, &p0, sys.n);
        for i in 0..3 {
            assert!((xn[i] * sn[i] - x[i] * so[i]).abs() < 1e-12);
            assert!((pn[i][i] * sn[i] * sn[i] - 2.0 * so[i] * so[i]).abs() < 1e-9);
        }
        assert_eq!(xn[3], 0.0);
        assert_eq!(pn[0][3], 0.0);
        assert_eq!(pn[3][3], p0[3][3]);
        assert_eq!(pn[4][3], p0[4][3]);
    }
}
