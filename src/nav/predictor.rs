//! The solution at the newest IMU sample while the filter runs behind it: the output predictor
//! of a delayed-fusion navigator (PX4's EKF2 keeps one for the same reason).
//!
//! A live run with a latency budget ([`LiveConfig::latency`](super::live::LiveConfig::latency))
//! mechanises each sample that long after it arrives, so that a receiver's late fixes are
//! still fused in time order. Its solution is then the budget behind the newest sample: at
//! 15 m/s, 0.15 s is 2.25 m of position a consumer would read as the present. The predictor
//! holds a copy of the run's mechanisation, carried through the samples still waiting in the
//! delay line with the run's current estimate of the sensor errors.
//!
//! **Exact, not blended.** PX4 blends its predictor towards the delayed filter with a
//! complementary filter, in O(1) per correction. Here, whenever the delayed run changes its
//! solution other than by mechanising a sample (a filter step, a fused fix, a heading, a
//! pseudo-observation, a retuned model), the copy is taken again and the waiting samples are
//! mechanised on it once more ([`LiveNav`](super::live::LiveNav) counts these). Between such
//! changes the predictor mechanises each new sample once, through the very functions the
//! navigator uses ([`compensate`], [`record_rates`], [`Strapdown::step`]). So the predicted
//! solution at a sample's time is, bit for bit, the solution the delayed run will have at that
//! time unless a fix or a step comes between (`hal-sim/tests/nav_present.rs`). The price is a
//! re-mechanisation of the delay line per change: at 100 Hz, 0.15 s and 4-Hz fixes, 15 samples
//! five times a second (BENCHMARKS.md "The present solution").
//!
//! ```
//! use imu_ident::nav::live::{LiveConfig, LiveEvent, LiveFix, LiveNav};
//! use imu_ident::nav::{ImuErrorModel, NavInit, NavSetup};
//! use imu_ident::strapdown::Geodetic;
//! use nalgebra::Vector3;
//! let init = NavInit { sd_att: Vector3::repeat(0.01), sd_vel: 0.1, sd_pos: 3.0 };
//! let setup = NavSetup::new(ImuErrorModel::default(), init);
//! let cfg = LiveConfig { latency: 0.2, ..LiveConfig::new(2.0) };
//! let mut nav = LiveNav::<f64, 24>::new(setup, cfg, LiveNav::<f64, 24>::no_observer);
//! let ant = Geodetic { lat: 0.8, lon: 0.1, h: 50.0 };
//! for k in 0..400u32 {
//!     let t = 0.01 * f64::from(k);
//!     nav.imu(t, [0.0; 3], [0.0, 0.0, -9.806], &mut |_: LiveEvent<'_, f64>| {}).unwrap();
//!     if k % 100 == 50 {
//!         let fix = LiveFix { t, pos: ant, vel: Some([0.0; 3]), sd_pos: None, sd_vel: None };
//!         nav.gnss(&fix, &mut |_| {}).unwrap();
//!     }
//! }
//! let run = nav.run().unwrap();
//! let now = nav.present().unwrap();
//! // The run is 0.2 s behind the newest sample; the prediction is at it.
//! assert!((run.time() - 3.79).abs() < 1e-9 && (now.time() - 3.99).abs() < 1e-9);
//! // Off, it costs nothing and there is none; on again, it is carried to the newest sample.
//! nav.set_present(false);
//! assert!(nav.present().is_none());
//! nav.set_present(true);
//! assert_eq!(nav.present().map(|p| p.time()), Some(0.01 * 399.0));
//! ```

use super::navigator::{compensate, NavError, NavObserver, Navigator};
use super::replay::ImuRecord;
use super::run::record_rates;
use crate::strapdown::{Increment, Strapdown};
use crate::Real;
use nalgebra::Vector3;

/// The solution at the newest sample ([`LiveNav::present`](super::live::LiveNav::present)):
/// the predictor's, or the run's own when no sample waits for the budget.
#[derive(Debug, Clone, Copy)]
pub struct Present<'a, T: Real> {
    t: f64,
    ins: &'a Strapdown<T>,
}

impl<'a, T: Real> Present<'a, T> {
    /// The solution `ins` at time `t` [s].
    pub fn new(t: f64, ins: &'a Strapdown<T>) -> Self {
        Self { t, ins }
    }

    /// Position, velocity and attitude at [`time`](Self::time).
    pub fn ins(&self) -> &'a Strapdown<T> {
        self.ins
    }

    /// Time of the solution [s]: the newest sample's.
    pub fn time(&self) -> f64 {
        self.t
    }
}

/// The run's mechanisation carried ahead to the newest sample (module docs).
#[derive(Debug, Clone)]
pub struct OutputPredictor<T: Real> {
    ins: Strapdown<T>,
    /// Time of the solution [s].
    t: f64,
    /// The sensor errors removed, `(b_g, b_a)`, and the scale factors, `(s_g, s_a)`, as the
    /// run had them when the copy was taken.
    bias: (Vector3<T>, Vector3<T>),
    scale: (Vector3<T>, Vector3<T>),
    max_gap: T,
}

impl<T: Real> OutputPredictor<T> {
    /// A copy of the solution of `nav`, at its time.
    pub fn new<const N: usize, O: NavObserver<T, N>>(nav: &Navigator<T, N, O>) -> Self {
        Self {
            ins: nav.ins().clone(),
            t: nav.time(),
            bias: nav.sensor_errors(),
            scale: nav.scale_factors(),
            max_gap: nav.max_imu_gap(),
        }
    }

    /// Carries `present` to the newest of the samples `waiting` (in time order): a new copy
    /// of the solution of `nav` when it `moved` other than by a sample, or has passed the
    /// copy (a sample run without waiting), then the waiting samples the copy has not
    /// mechanised yet. Returns the samples mechanised, and false when one was refused: the
    /// prediction then ends (`present` is none) until the next copy.
    pub fn carry<'a, const N: usize, O: NavObserver<T, N>>(
        present: &mut Option<Self>,
        nav: &Navigator<T, N, O>,
        moved: bool,
        waiting: impl Iterator<Item = &'a ImuRecord>,
    ) -> (u64, bool) {
        if moved || present.as_ref().map_or(true, |p| p.t < nav.time()) {
            *present = Some(Self::new(nav));
        }
        let Some(p) = present else {
            return (0, false);
        };
        let mut n = 0u64;
        for r in waiting {
            if r.t <= p.t {
                continue;
            }
            if p.sample(r).is_err() {
                *present = None;
                return (n, false);
            }
            n += 1;
        }
        (n, true)
    }

    /// Mechanises the sample `r`, as [`Navigator::imu`] would with the sensor errors of the
    /// copy. A sample at or before the solution's time is refused ([`NavError::BadTime`]).
    /// After any other error the copy is not the run's any more ([`Strapdown::step`]): it is
    /// dropped ([`carry`](Self::carry)).
    pub fn sample(&mut self, r: &ImuRecord) -> Result<(), NavError> {
        let dt64 = r.t - self.t;
        if !(dt64.is_finite() && dt64 > 0.0) {
            return Err(NavError::BadTime);
        }
        // The arithmetic of `NavReplay::sample` and `Navigator::imu`, step by step.
        let (gyro, accel) = record_rates::<T>(r);
        let inc = Increment::from_rates(&gyro, &accel, T::lit(dt64));
        let dt = T::lit(dt64);
        if dt > self.max_gap {
            self.ins.restart_increments();
        }
        self.ins
            .step(&compensate(&inc, dt, &self.bias, &self.scale), dt)?;
        self.t = r.t;
        Ok(())
    }

    /// The predicted solution.
    pub fn present(&self) -> Present<'_, T> {
        Present::new(self.t, &self.ins)
    }
}
