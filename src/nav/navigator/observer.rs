//! What the navigator tells an observer ([`NavObserver`]): each filter operation, with the
//! linearised model, the observation rows and the closed-loop correction, so that a bank of
//! shadow filters under other noise models can follow the running filter step for step
//! ([`crate::nav::online`]). The navigator calls the hooks at the points named; the default
//! observer `()` ignores them (and compiles to nothing).

use crate::linalg::Arr;
use crate::nav::error_model::StrapdownErrorModel;
use crate::nav::ImuErrorModel;
use crate::Real;

/// Which observation a fusion was.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ObservationKind {
    /// A GNSS fix (position and velocity): measured data.
    Gnss,
    /// A zero-velocity update: a pseudo-observation.
    Zupt,
    /// The non-holonomic constraint: a pseudo-observation.
    Nhc,
}

/// Hooks called by [`Navigator`](super::Navigator) around its filter operations. All states
/// are the filter's scaled states (each state divided by the `scale` the hooks receive).
/// Every hook does nothing by default.
#[allow(non_snake_case)]
pub trait NavObserver<T: Real, const N: usize> {
    /// Before the prediction over `model.dt`: `model` is linearised at `model.point`, and `x`
    /// is the running filter's estimate before the prediction (its navigation part is zero:
    /// the mechanisation already removes the sensor errors that `x` carries).
    fn propagated(
        &mut self,
        model: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x: &[T; N],
        p0: &Arr<T, N>,
    ) {
        let _ = (model, scale, x, p0);
    }

    /// Before the running filter fuses `z = H x + v`, `v ~ N(0, diag(R))` (non-finite axes
    /// missing). The running filter may gate it; an observer sees it anyway.
    fn observed<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; N]; Z],
        R: &[T; Z],
    ) {
        let _ = (kind, z, H, R);
    }

    /// Before the loop is closed: the running filter's estimate `x` after the fusion, whose
    /// navigation part is about to be removed from the mechanisation.
    fn corrected(&mut self, x: &[T; N], p0: &Arr<T, N>) {
        let _ = (x, p0);
    }

    /// The heading was restarted with standard deviation `sd` [rad], and with `vel` the
    /// velocity replaced ([`restart_heading`](super::restart_heading)).
    fn heading_restarted(&mut self, scale: &[T; N], sd: T, vel: bool) {
        let _ = (scale, sd, vel);
    }

    /// The running filter's sensor-error estimates were seeded: `x` is its estimate now.
    fn sensors_seeded(&mut self, x: &[T; N]) {
        let _ = x;
    }

    /// Called by the replay loops after every filter step at time `t` [s]: a noise model for
    /// the running filter to take ([`Navigator::retune_imu_model`](super::Navigator::retune_imu_model)),
    /// if the observer has decided one.
    fn decide(&mut self, t: f64) -> Option<ImuErrorModel<T>> {
        let _ = t;
        None
    }

    /// After a decision ([`decide`](Self::decide) returned a model): the factors on the GNSS
    /// fixes' standard deviations (position, velocity) for the running filter to take
    /// ([`Navigator::gnss_sd_factor`](super::Navigator::gnss_sd_factor)), if the observer
    /// identifies them.
    fn gnss_sd_factor(&self) -> Option<[f64; 2]> {
        None
    }
}

/// No observer.
impl<T: Real, const N: usize> NavObserver<T, N> for () {}

/// An observer that may be absent.
#[allow(non_snake_case)]
impl<T: Real, const N: usize, O: NavObserver<T, N>> NavObserver<T, N> for Option<O> {
    fn propagated(
        &mut self,
        model: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x: &[T; N],
        p0: &Arr<T, N>,
    ) {
        if let Some(o) = self {
            o.propagated(model, scale, x, p0);
        }
    }

    fn observed<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; N]; Z],
        R: &[T; Z],
    ) {
        if let Some(o) = self {
            o.observed(kind, z, H, R);
        }
    }

    fn corrected(&mut self, x: &[T; N], p0: &Arr<T, N>) {
        if let Some(o) = self {
            o.corrected(x, p0);
        }
    }

    fn heading_restarted(&mut self, scale: &[T; N], sd: T, vel: bool) {
        if let Some(o) = self {
            o.heading_restarted(scale, sd, vel);
        }
    }

    fn sensors_seeded(&mut self, x: &[T; N]) {
        if let Some(o) = self {
            o.sensors_seeded(x);
        }
    }

    fn decide(&mut self, t: f64) -> Option<ImuErrorModel<T>> {
        self.as_mut().and_then(|o| o.decide(t))
    }

    fn gnss_sd_factor(&self) -> Option<[f64; 2]> {
        self.as_ref().and_then(|o| o.gnss_sd_factor())
    }
}

/// An observer held elsewhere (the firmware keeps a bank in its own static).
#[allow(non_snake_case)]
impl<T: Real, const N: usize, O: NavObserver<T, N>> NavObserver<T, N> for &mut O {
    fn propagated(
        &mut self,
        model: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x: &[T; N],
        p0: &Arr<T, N>,
    ) {
        (**self).propagated(model, scale, x, p0);
    }

    fn observed<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; N]; Z],
        R: &[T; Z],
    ) {
        (**self).observed(kind, z, H, R);
    }

    fn corrected(&mut self, x: &[T; N], p0: &Arr<T, N>) {
        (**self).corrected(x, p0);
    }

    fn heading_restarted(&mut self, scale: &[T; N], sd: T, vel: bool) {
        (**self).heading_restarted(scale, sd, vel);
    }

    fn sensors_seeded(&mut self, x: &[T; N]) {
        (**self).sensors_seeded(x);
    }

    fn decide(&mut self, t: f64) -> Option<ImuErrorModel<T>> {
        (**self).decide(t)
    }

    fn gnss_sd_factor(&self) -> Option<[f64; 2]> {
        (**self).gnss_sd_factor()
    }
}
