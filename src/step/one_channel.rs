//! The one-channel Schuler model's step: [`tick_axes`](Estimator::tick_axes) with one axis,
//! reported in the firmware's wire [`Record`], with the parameter records of its components and
//! the paper's autocorrelation identification of the estimates (METHOD.md §3).

use super::{acf, AcfRecord, Estimator, Report, StepConfig, StepError, ACF_WINDOW};
use super::{clock::Plan, Engine};
use crate::adapt::params::{has_coordinate, Specs, MAXP};
use crate::filter::Estimates;
use crate::linalg::to_vec;
use crate::model::{ErrorSource, InsModel, Quantity};
use crate::telemetry::{
    model_params, ParamRecord, Record, TelemetrySink, BRIDGED, FLAT_BETA, FLAT_SIGMA, FLAT_TAU,
    TIME_JUMP,
};
use crate::Real;

impl<T: Real> Estimator<T> {
    /// An estimator starting from `model`.
    pub fn new(model: InsModel<T>, cfg: StepConfig<T>) -> Result<Self, StepError> {
        Self::from_model(model, cfg)
    }

    /// Estimates in SI units.
    pub fn estimates(&self) -> Estimates<T> {
        match &self.engine {
            Engine::Fixed(f) => {
                let (accel, gyro) = &self.outputs;
                Estimates::from_kalman(f.kalman(), &to_vec(f.scale()), accel, gyro)
            }
            Engine::Adaptive(a) => a.estimates(),
        }
    }

    /// One tick at time `t` [s] with observation `z` [m/s] (non-finite: missing): exactly one
    /// prediction and at most one update, so its cost is bounded whatever the input.
    pub fn tick(&mut self, t: f64, z: T) -> Report {
        let r = self.tick_axes(t, &[z]);
        let est = self.estimates();
        self.feed_acf(&est);
        let [nu] = r.innovation;
        let [s] = r.variance;
        Report {
            record: Record::new(r.k, t, z, nu, s, &est, r.flags),
            reidentified: r.reidentified,
            jumped: r.jumped,
            // `checked_rem`: a BLANK estimator (acf_every = 0) ticked without `init` must not panic.
            acf: self.k.checked_rem(self.cfg.acf_every) == Some(0),
        }
    }

    fn feed_acf(&mut self, est: &Estimates<T>) {
        let w = T::lit(1.0 / ACF_WINDOW as f64);
        let pairs = [(est.da, est.sigma_da), (est.dw, est.sigma_dw)];
        for ((acf, pm), (x, sd)) in self.acf.iter_mut().zip(self.p_mean.iter_mut()).zip(pairs) {
            // A rejected sample (non-finite after a repair) leaves the window as it was.
            if acf.push(x).is_ok() {
                let first = acf.len() == 1;
                *pm = if first {
                    sd * sd
                } else {
                    *pm + w * (sd * sd - *pm)
                };
            }
        }
    }

    /// One log row: the [`clock`](super::clock)'s time rules (a gap bridged by at most
    /// [`StepConfig::max_bridge`] missing-observation ticks, a row whose time does not advance,
    /// is not finite or is suspect skipped), then a tick with the row. Every tick's record goes
    /// to `sink`, followed by the parameters when they changed and the autocorrelation
    /// identification when it ran.
    pub fn push(&mut self, t: f64, z: T, sink: &mut impl TelemetrySink) {
        let dt = self.dt.as_f64();
        match self.clock.plan(t, dt, self.cfg.max_bridge) {
            Plan::Skip(flags) => {
                let nan = T::lit(f64::NAN);
                let est = self.estimates();
                sink.record(&Record::new(self.k, t, z, nan, nan, &est, flags));
            }
            Plan::Run {
                start,
                bridged,
                jump,
            } => {
                for i in 1..=bridged {
                    let mut r = self.tick(start + f64::from(i) * dt, T::lit(f64::NAN));
                    r.record.flags |= BRIDGED;
                    self.emit(&r, sink);
                }
                let mut r = self.tick(t, z);
                if jump {
                    r.record.flags |= TIME_JUMP;
                }
                self.emit(&r, sink);
            }
        }
    }

    /// Sends a tick's record and what came with it.
    pub fn emit(&self, r: &Report, sink: &mut impl TelemetrySink) {
        sink.record(&r.record);
        if r.reidentified {
            if let Ok(m) = self.model() {
                // One factorisation per re-identification, shared by the records.
                let ident = self.adaptive().map(|a| (a.specs(), a.cr_sd(), a.flat()));
                model_params(&m, r.record.k, r.record.t, |p| {
                    let mut p = *p;
                    if let Some((specs, sd, flat)) = &ident {
                        add_crb(&mut p, specs, sd.as_ref(), *flat);
                    }
                    sink.params(&p);
                });
            }
        }
        if r.acf {
            for sensor in [ErrorSource::Accel, ErrorSource::Gyro] {
                sink.acf(&self.acf_identify(sensor, r.record.k, r.record.t));
            }
        }
    }

    /// The paper's identification from the estimates' autocorrelation (lag-1 bias-corrected
    /// `alpha`, `sigma^2 = R_0 + mean(P)`); NaN fields when the window cannot support it.
    pub fn acf_identify(&self, sensor: ErrorSource, k: u32, t: f64) -> AcfRecord {
        let i = usize::from(sensor == ErrorSource::Gyro);
        let (acf, pm) = (&self.acf[i], self.p_mean[i]);
        acf::acf_record(acf, pm, self.dt, sensor, k, t)
    }
}

/// Fills a parameter record's Cramér-Rao standard deviations (of `ln` of each value) from the
/// adaptive filter's [`AdaptiveFilter::cr_sd`] `sd` of its identified `specs`, and its flags
/// from [`AdaptiveFilter::flat`] (bit `i`: `specs[i]` not identifiable). A random walk's record
/// carries `sqrt(q)`, so its `ln` standard deviation is half that of the identified `ln q`.
fn add_crb<T: Real>(p: &mut ParamRecord, specs: &Specs, sd: Option<&[T; MAXP]>, flat: u8) {
    for (i, spec) in specs.iter().enumerate().take(MAXP) {
        if spec.sensor != p.sensor || spec.index != p.component {
            continue;
        }
        let s = sd
            .and_then(|sd| sd.get(i))
            .map_or(f32::NAN, |s| s.as_f64() as f32);
        let bit = if has_coordinate(flat, i) {
            match spec.kind {
                Quantity::Tau => FLAT_TAU,
                Quantity::Beta => FLAT_BETA,
                Quantity::Sigma0 => 0,
                _ => FLAT_SIGMA,
            }
        } else {
            0
        };
        p.flat |= bit;
        match spec.kind {
            Quantity::Tau => p.sd_tau = s,
            Quantity::Sigma | Quantity::Density => p.sd_sigma = s,
            Quantity::Q => p.sd_sigma = 0.5 * s,
            Quantity::Beta => p.sd_beta = s,
            Quantity::Sigma0 => {}
        }
    }
}
