//! One shadow filter of the online identification: the running filter's error-state filter
//! under another noise model, following its predictions, observations and corrections
//! ([`super`] module docs).

use crate::filter::{fuse_ungated, Kalman};
use crate::linalg::Arr;
use crate::model::ModelError;
use crate::nav::error_model::{nav_idx, StrapdownErrorModel, NAV_Z};
use crate::nav::ImuErrorModel;
use crate::Real;

/// A shadow filter.
#[derive(Debug, Clone)]
pub(super) struct Shadow<T: Real, const N: usize> {
    model: StrapdownErrorModel<T>,
    pub(super) kf: Kalman<T, N>,
    /// Log-likelihood of the last observation fused [nats].
    pub(super) loglik: f64,
    /// Factors on the variances of the GNSS fixes the running filter fuses, its position rows
    /// and its velocity rows: this shadow's GNSS noise relative to the running filter's
    /// ([`OnlineConfig::gnss_sd`](super::OnlineConfig::gnss_sd); ones without).
    pub(super) r_gain: [T; 2],
}

impl<T: Real, const N: usize> Shadow<T, N> {
    pub(super) fn new(model: StrapdownErrorModel<T>, kf: Kalman<T, N>) -> Self {
        Self {
            model,
            kf,
            loglik: 0.0,
            r_gain: [T::one(); 2],
        }
    }

    /// Predicts over `run.dt` at `run.point` under this shadow's noise model, less the drive
    /// of the sensor errors `x_run` that the mechanisation already removes (module docs).
    #[allow(non_snake_case)]
    pub(super) fn propagate(
        &mut self,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x_run: &[T; N],
        p0: &Arr<T, N>,
    ) -> Result<(), ModelError> {
        self.follow(run);
        let mut Phi = [[T::zero(); N]; N];
        let mut Qd = [[T::zero(); N]; N];
        self.model.discrete_into(scale, &mut Phi, &mut Qd)?;
        self.predict(&Phi, &Qd, x_run, p0);
        Ok(())
    }

    /// This shadow's continuous `A'`, `Qc'` at the running filter's point and step, into `a`,
    /// `qc`; returns the number of active states.
    pub(super) fn dynamics_into(
        &mut self,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
        a: &mut Arr<T, N>,
        qc: &mut Arr<T, N>,
    ) -> Result<usize, ModelError> {
        self.follow(run);
        self.model.dynamics_into(scale, a, qc)
    }

    /// Takes the running filter's linearisation point and step.
    fn follow(&mut self, run: &StrapdownErrorModel<T>) {
        self.model.point = run.point;
        self.model.dt = run.dt;
    }

    /// The prediction with this shadow's discrete `(Phi, Qd)`, less the drive of `x_run`.
    #[allow(non_snake_case)]
    pub(super) fn predict(
        &mut self,
        Phi: &Arr<T, N>,
        Qd: &Arr<T, N>,
        x_run: &[T; N],
        p0: &Arr<T, N>,
    ) {
        // The navigation rows of Phi x_run: the part of the prediction the running filter's
        // compensation has already taken out of the mechanisation.
        let mut u = [T::zero(); nav_idx::SENSOR];
        for (ui, row) in u.iter_mut().zip(Phi.iter()) {
            for (a, b) in row.iter().zip(x_run.iter()) {
                *ui += *a * *b;
            }
        }
        self.kf.predict(Phi, Qd);
        for (x, ui) in self.kf.x.iter_mut().zip(u.iter()) {
            *x -= *ui;
        }
        if !self.kf.diagonal_healthy() {
            self.kf.repair(p0);
        }
    }

    /// Fuses `z = H x + v` ungated; keeps its log-likelihood. A GNSS fix (`gnss`: its rows
    /// the position's three, then the velocity's, [`NAV_Z`]) under this shadow's factors on
    /// the variances ([`r_gain`](Self::r_gain)).
    #[allow(non_snake_case)]
    pub(super) fn fuse<const Z: usize>(
        &mut self,
        z: &[T; Z],
        H: &[[T; N]; Z],
        R: &[T; Z],
        gnss: bool,
    ) {
        let mut r = *R;
        if gnss && Z == NAV_Z {
            let [gp, gv] = self.r_gain;
            for (i, v) in r.iter_mut().enumerate() {
                *v *= if i < 3 { gp } else { gv };
            }
        }
        self.loglik = fuse_ungated(&mut self.kf, z, H, &r).as_f64();
    }

    /// The running filter closed its loop with its estimate `x_run`: the navigation errors of
    /// the corrected solution are this shadow's less the correction.
    pub(super) fn correct(&mut self, x_run: &[T; N], p0: &Arr<T, N>) {
        for (x, c) in self.kf.x.iter_mut().zip(x_run.iter()).take(nav_idx::SENSOR) {
            *x -= *c;
        }
        if !self.kf.diagonal_healthy() {
            self.kf.repair(p0);
        }
    }

    /// Takes the running filter's sensor-error estimates.
    pub(super) fn seed_sensors(&mut self, x_run: &[T; N]) {
        for (x, c) in self.kf.x.iter_mut().zip(x_run.iter()).skip(nav_idx::SENSOR) {
            *x = *c;
        }
    }

    /// Takes the noise model `imu` (same layout), its covariance retuned
    /// ([`StrapdownErrorModel::retune_covariance`]).
    pub(super) fn retune(&mut self, imu: ImuErrorModel<T>) {
        let mut new = self.model.clone();
        new.imu = imu;
        self.model.retune_covariance(&new, &mut self.kf.P);
        self.model = new;
    }
}
