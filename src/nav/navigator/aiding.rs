//! The navigator's observations ([`Navigator::gnss`], [`Navigator::zupt`],
//! [`Navigator::nhc`]): each propagates the filter to the solution's time, builds its rows,
//! passes the vector chi-square gate with its own count of consecutive rejections, fuses the
//! axes one by one ([`fuse`]) and closes the loop (module docs of [`super`]).

use super::{GnssFix, NavError, NavObserver, Navigator, ObservationKind, CHI2_9999, NHC_Z};
use crate::filter::{fuse, Fused};
use crate::model::ModelError;
use crate::nav::error_model::{nav_idx, NAV_Z};
use crate::strapdown::earth;
use crate::Real;
use nalgebra::Vector3;

impl<T: Real, const N: usize, O: NavObserver<T, N>> Navigator<T, N, O> {
    /// Fuses a GNSS fix (its time must not be after the solution's). Returns the per-axis
    /// fusion result (position N, E, D, velocity N, E, D).
    pub fn gnss(&mut self, fix: &GnssFix<T>) -> Result<Fused<T, NAV_Z>, NavError> {
        let lag = self.t - fix.t;
        if !(lag.is_finite() && lag >= -1e-6) {
            return Err(NavError::BadTime);
        }
        self.propagate()?;
        // The first fix after a step restarts the step clock: fixes at the filter rate then
        // land on the steps and propagate nothing (one propagation per step, not two);
        // faster fixes propagate over the part of the step elapsed, one step in k per fix.
        // The clock starts at the fix's time of validity when the fix falls in the last IMU
        // sample (the usual case): the next step is then the sample that passes the fix a
        // step later, whatever the IMU's jitter. From the sample's time instead, a jittered
        // IMU put the step a sample after that fix, the clock restarted at the fix after,
        // and steps came up to a fix interval late (1.25 s apart with 4-Hz fixes, test
        // `fixes_at_4_hz_on_a_jittered_imu_propagate_once_each`). A late fix (a receiver's
        // latency) restarts it at the sample, so a step never comes more than one IMU sample
        // early.
        if !self.fix_since_step {
            self.t_step = if fix.t > self.t_prev { fix.t } else { self.t };
            self.fix_since_step = true;
        }
        self.linearise();
        // Only H and R: A and Qc were built by the propagation just done.
        let (h, r0) = self.model.observation(&self.scale);
        let c = self.ins.dcm();
        // Antenna position at the fix time, minus the fix, in NED metres (f64: the difference
        // of two latitudes must not be rounded to f32 first). The lever arm is rotated back to
        // the fix's time with the last sample's body rate (`C(t - lag) = C (I - lag [w x])`
        // to first order: 8 cm for a 0.65-m arm, 0.5 rad/s and 0.25 s).
        let p = self.ins.position();
        let arm = self.model.lever_arm;
        let lever_n = c * (arm - self.w_b.cross(&arm) * T::lit(lag.max(0.0)));
        let (rn, re) = (
            earth::radius_north(p.lat) + p.h,
            earth::radius_east(p.lat) + p.h,
        );
        // The solution moved back to the fix's time along the last sample's velocity change
        // (the mechanisation's velocity is linear over a sample): without the velocity's
        // part, a fix was compared with the velocity up to one IMU interval later (3 cm/s at
        // 3 m/s^2 and 100 Hz), and the innovation jumped by that much when the IMU's timing
        // moved a sample across the fix, which made the likelihood rough in the IMU time
        // shift that `--identify` fits (jumps of 1-3 nats per 0.1 ms on the real drive).
        // Before the last sample, along the velocities kept at the sample boundaries (a late
        // fix, `history`): interpolated between them, not extrapolated from one sample's
        // change, which carries vibration.
        let (back, v_fix) = self.back_by(lag);
        let d = [
            (p.lat - fix.pos.lat) * rn + lever_n.x.as_f64() - back[0],
            (p.lon - fix.pos.lon) * re * libm::cos(p.lat) + lever_n.y.as_f64() - back[1],
            -(p.h - fix.pos.h) + lever_n.z.as_f64() - back[2],
        ];
        let v_ant = v_fix + c * self.w_b.cross(&arm);
        let mut z = [T::zero(); NAV_Z];
        let mut r = r0;
        let [fp, fv] = self.gnss_sd_factor;
        for i in 0..3 {
            z[i] = T::lit(d[i]);
            z[3 + i] = v_ant[i] - fix.vel[i];
            let (sp, sv) = (fix.sd_pos[i], fix.sd_vel[i]);
            if sp.is_finite() && sp > T::zero() {
                r[i] = sp * sp;
            }
            if sv.is_finite() && sv > T::zero() {
                r[3 + i] = sv * sv;
            }
            // The observer's factors (ones unless it identifies them), on the stated and the
            // default standard deviations alike, so that the shadows' relative factors hold.
            r[i] *= fp * fp;
            r[3 + i] *= fv * fv;
        }
        let fused = self.fuse_gated(ObservationKind::Gnss, &z, &h, &r);
        self.close_loop()?;
        Ok(fused)
    }

    /// The factors on the GNSS fixes' standard deviations (position, velocity) taken from the
    /// observer ([`NavObserver::gnss_sd_factor`]); ones until it decides any.
    pub fn gnss_sd_factor(&self) -> [T; 2] {
        self.gnss_sd_factor
    }

    /// Zero-velocity update with standard deviation `sd` [m/s] on each axis, with its own count
    /// of consecutive rejections (like [`nhc`](Self::nhc): updates accepted every step at rest
    /// must not reset the count that lets GNSS back in after an outage).
    pub fn zupt(&mut self, sd: T) -> Result<Fused<T, 3>, NavError> {
        self.propagate()?;
        let v = self.ins.velocity();
        let mut h = [[T::zero(); N]; 3];
        for (i, row) in h.iter_mut().enumerate() {
            if let (Some(x), Some(s)) = (
                row.get_mut(nav_idx::VEL + i),
                self.scale.get(nav_idx::VEL + i),
            ) {
                *x = *s;
            }
        }
        let z = [v.x, v.y, v.z];
        let r = [sd * sd; 3];
        let mut rejected = self.rejected_zupt;
        let fused = self.fuse_counted(ObservationKind::Zupt, &z, &h, &r, &mut rejected);
        self.rejected_zupt = rejected;
        self.close_loop()?;
        Ok(fused)
    }

    /// The non-holonomic constraint of a land vehicle: the body-frame lateral (y) and vertical
    /// (z) velocity of the point at `lever` [m, body FRD] from the IMU are zero, each with
    /// standard deviation `sd` [m/s] (how far the vehicle departs from it: side slip, bounce,
    /// mounting misalignment). Fused like a GNSS fix (vector gate, sequential scalar updates,
    /// closed-loop correction), with its own count of consecutive rejections (module docs).
    /// Only meaningful while the vehicle moves and the heading is known; the caller decides
    /// (the host driver and the firmware's replay loop through [`super::run::Nhc::after_step`]).
    pub fn nhc(&mut self, sd: T, lever: &Vector3<T>) -> Result<Fused<T, NHC_Z>, NavError> {
        if !(sd.is_finite() && sd > T::zero() && lever.iter().all(|v| v.is_finite())) {
            return Err(NavError::Model(ModelError::BadSigma));
        }
        self.propagate()?;
        let (z, h) = self.nhc_observation(lever);
        let r = [sd * sd; NHC_Z];
        let mut rejected = self.rejected_nhc;
        let fused = self.fuse_counted(ObservationKind::Nhc, &z, &h, &r, &mut rejected);
        self.rejected_nhc = rejected;
        self.close_loop()?;
        Ok(fused)
    }

    /// The predicted measurement `z` (body y and z velocity of the point at `lever` from the
    /// IMU, computed minus the constraint's zero) and its rows `H` in the scaled states, at the
    /// current solution, with the step's mean body rate [`NavPoint::mean_w_b`].
    ///
    /// Measurement (Groves 2013 eq. 16.60 with the lever arm): `v_b = C^T v + w x l`, `C =
    /// C_b^n`, `v` the NED velocity of the IMU, `w` the body rate, `l = lever`.
    ///
    /// Derivation in this module's phi-angle convention (computed minus true, [`error_model`]
    /// docs): `C^ = (I + [phi x]) C`, so `C^T^ = C^T (I + [phi x])^T = C^T (I - [phi x])`, and
    /// `v^ = v + dv`. To first order
    ///
    /// ```text
    /// v_b^ = C^T (I - [phi x]) (v + dv) + w x l
    ///      = v_b + C^T dv - C^T (phi x v)
    ///      = v_b + C^T dv + C^T [v x] phi          (-(phi x v) = v x phi)
    /// H    = [ C^T [v x] | C^T | 0 ]  rows y, z
    /// ```
    ///
    /// The rate error term `(b_g^ - b_g) x l` is neglected, as in the GNSS velocity rows
    /// ([`error_model`] docs): below a millimetre per second for `|l| < 1 m`. The mean rate of
    /// the step rather than the last sample's: the last sample carries the vibration of a
    /// roof-mounted IMU (0.65 m times a few 0.01 rad/s of noise), the mean only a half-step lag.
    ///
    /// [`error_model`]: super::error_model
    pub fn nhc_observation(&self, lever: &Vector3<T>) -> ([T; NHC_Z], [[T; N]; NHC_Z]) {
        let c = self.ins.dcm();
        let v = self.ins.velocity();
        let ct = c.transpose();
        let v_b = ct * v + self.model.point.mean_w_b.cross(lever);
        let h_att = ct * crate::strapdown::skew(&v);
        let mut h = [[T::zero(); N]; NHC_Z];
        let mut z = [T::zero(); NHC_Z];
        for (k, (row, zk)) in h.iter_mut().zip(z.iter_mut()).enumerate() {
            // Body axis 1 (y, right) then 2 (z, down).
            let b = k + 1;
            *zk = v_b.get(b).copied().unwrap_or_else(T::zero);
            for j in 0..3 {
                let pairs = [
                    (nav_idx::ATT + j, h_att.get((b, j))),
                    (nav_idx::VEL + j, ct.get((b, j))),
                ];
                for (col, val) in pairs {
                    if let (Some(x), Some(v), Some(s)) =
                        (row.get_mut(col), val, self.scale.get(col))
                    {
                        *x = *v * *s;
                    }
                }
            }
        }
        (z, h)
    }

    /// [`fuse`] with the configured gate, skipped after `max_rejections` consecutive
    /// rejections (the GNSS count).
    #[allow(non_snake_case)]
    fn fuse_gated<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; N]; Z],
        r: &[T; Z],
    ) -> Fused<T, Z> {
        let mut rejected = self.rejected;
        let fused = self.fuse_counted(kind, z, H, r, &mut rejected);
        self.rejected = rejected;
        fused
    }

    /// [`fuse`] with the configured gate, skipped after `max_rejections` consecutive
    /// rejections counted in `rejected`.
    #[allow(non_snake_case)]
    fn fuse_counted<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; N]; Z],
        r: &[T; Z],
        rejected: &mut u8,
    ) -> Fused<T, Z> {
        self.obs.observed(kind, z, H, r);
        let gate = if *rejected >= self.cfg.max_rejections {
            None
        } else {
            self.cfg.gate
        };
        let fused = match gate {
            Some(k) => fuse(
                &mut self.kf,
                z,
                H,
                r,
                Some(&move |m: usize| T::lit(CHI2_9999[m.clamp(1, 6) - 1]) * k),
            ),
            None => fuse(&mut self.kf, z, H, r, None),
        };
        *rejected = if fused.gated {
            rejected.saturating_add(1)
        } else {
            0
        };
        fused
    }
}
