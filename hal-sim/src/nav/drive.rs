//! The replay loop of `hal-sim nav` ([`NavLoop`]): each IMU sample through the core's run
//! driver, [`NavReplay::sample`] (the firmware's own step: mechanisation, the non-holonomic
//! constraint and the zero-velocity update after a filter step, the online identification's
//! decision), and the GNSS fixes at their times with the planner's decisions (outages,
//! heading from the course, the interval between fused fixes), fused through
//! [`NavReplay::fuse`]. The whole run ([`super::run_observed`]) and the online
//! identification's window replays ([`super::adapt`]) both advance this loop, so the two apply
//! the same rules; a loop is a value, so a copy taken at a window's start replays that window
//! under another noise model.

use super::records::{self, EpochRecord};
use super::setup::{self, FixPlanner};
use super::shadows::Shadows;
use super::{to_core_fix, NavArgs};
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::{bail, Result};
use imu_ident::filter::AxisStatus;
use imu_ident::nav::run::NavReplay;
use imu_ident::nav::{Navigator, NAV_N};
use imu_ident::Real;
use nalgebra::Vector3;

/// The state of a replay between two IMU samples.
#[derive(Debug, Clone)]
pub struct NavLoop<T: Real> {
    /// The core's run driver (the firmware's), its navigator with the online
    /// identification's shadow filters when it has them.
    run: NavReplay<T, NAV_N, Shadows<T>>,
    /// The per-fix decisions.
    pub planner: FixPlanner,
    /// The constraint's statistics (with `--nhc`).
    pub nhc: Option<records::NhcSummary>,
    /// The zero-velocity updates' statistics (with `--zupt`).
    pub zupt: Option<records::ZuptSummary>,
    /// Index of the last IMU sample mechanised (the next interval is `imu[i]..imu[i + 1]`).
    pub i: usize,
    /// Index of the next fix.
    pub fix_k: usize,
    use_velocity: bool,
    /// Sum of the fused fixes' innovation log-likelihoods so far.
    pub loglik: f64,
    /// Fixes fused so far.
    pub fused: usize,
}

/// The loop's navigator.
pub type NavOf<T> = Navigator<T, NAV_N, Shadows<T>>;

/// What one advance produced for each fix it met.
pub trait EpochSink<T: Real> {
    /// A fix at `f.t`, met after the IMU sample at `t_imu`; `rec` has the fusion filled in.
    fn epoch(&mut self, rec: EpochRecord, nav: &NavOf<T>, t_imu: f64);
}

/// Keeps nothing (window replays).
pub struct Discard;

impl<T: Real> EpochSink<T> for Discard {
    fn epoch(&mut self, _: EpochRecord, _: &NavOf<T>, _: f64) {}
}

impl<T: Real> EpochSink<T> for Vec<EpochRecord> {
    fn epoch(&mut self, mut rec: EpochRecord, nav: &NavOf<T>, t_imu: f64) {
        rec.fill_solution(nav, rec.t, t_imu);
        self.push(rec);
    }
}

impl<T: Real> NavLoop<T> {
    /// The loop at the run's start (levelling, first position: [`setup::start`]) on the
    /// shifted samples `imu`. Also returns the outage schedule.
    pub fn start(
        args: &NavArgs,
        imu: &[ImuSample],
        fixes: &[GnssFix],
    ) -> Result<(Self, Vec<crate::nav_io::outages::Outage>)> {
        let start = setup::start(args, imu, fixes)?;
        let planner = FixPlanner::new(args, &start);
        let setup::Start {
            setup, k, outages, ..
        } = start;
        // The constraint and the zero-velocity update are checked first, with the options
        // named; `NavReplay::new` checks them again, then builds the navigator.
        setup
            .nhc::<T>()
            .map_err(|e| anyhow::anyhow!("nav: constraint (--nhc, --nhc-lever): {e:?}"))?;
        if let Some(z) = args.zupt.as_ref() {
            imu_ident::nav::Zupt::<T>::cast_checked(z)
                .map_err(|e| anyhow::anyhow!("nav: zero-velocity update (--zupt): {e:?}"))?;
        }
        let run = NavReplay::<T, NAV_N>::new(&setup)
            .map_err(|e| anyhow::anyhow!("nav: {e:?} (the model needs more than {NAV_N} states?)"))?
            .with_observer(Shadows::default());
        let nhc = args.nhc.map(|sd| records::NhcSummary {
            sd,
            lever: args.nhc_lever,
            ..Default::default()
        });
        let lp = Self {
            run,
            planner,
            nhc,
            zupt: args.zupt.map(records::ZuptSummary::new),
            i: k,
            fix_k: fixes.partition_point(|f| f.t < setup.t0),
            use_velocity: args.use_velocity,
            loglik: 0.0,
            fused: 0,
        };
        Ok((lp, outages))
    }

    /// The navigator.
    pub fn nav(&self) -> &NavOf<T> {
        self.run.navigator()
    }

    /// The navigator, to change (the bank is started on it; window replays retune it).
    pub fn nav_mut(&mut self) -> &mut NavOf<T> {
        self.run.navigator_mut()
    }

    /// Sets the factors on the fixes' standard deviations (`--gnss-sd-factor`; the online
    /// identification's GNSS coordinates).
    pub fn set_gnss_sd_factor(&mut self, f: [f64; 2]) -> Result<()> {
        self.run
            .set_sd_factor(f.map(T::lit))
            .map_err(|e| anyhow::anyhow!("nav: GNSS sd factors {f:?}: {e:?}"))
    }

    /// The time of the last sample mechanised [s].
    pub fn time(&self, imu: &[ImuSample]) -> f64 {
        imu.get(self.i).map_or(f64::NAN, |s| s.t)
    }

    /// Mechanises the samples of `imu` up to and including time `t_end` (all of them with
    /// `f64::INFINITY`), fusing the fixes met on the way; `progress` is called once per sample.
    /// `imu_name` names the file in errors.
    pub fn advance(
        &mut self,
        imu: &[ImuSample],
        fixes: &[GnssFix],
        t_end: f64,
        sink: &mut impl EpochSink<T>,
        imu_name: &str,
        progress: &dyn Fn(),
    ) -> Result<()> {
        while self.i + 1 < imu.len() && imu[self.i + 1].t <= t_end {
            progress();
            let (a, b) = (&imu[self.i], &imu[self.i + 1]);
            self.i += 1;
            let dt = b.t - a.t;
            if dt.is_nan() || dt <= 0.0 {
                bail!("{imu_name}: IMU time does not increase at t = {}", b.t);
            }
            let gyro = Vector3::from(b.gyro).map(T::lit);
            let accel = Vector3::from(b.accel).map(T::lit);
            // The firmware's step: mechanisation; after a filter step the constraint (once the
            // heading is known and above NHC_MIN_SPEED), the zero-velocity update (when found
            // at rest; never together with the constraint) and the bank's decision.
            let step = self.run.sample(b.t, gyro, accel).map_err(|e| {
                anyhow::anyhow!(
                    "nav: IMU sample at t = {} (mechanisation, constraint, zero-velocity \
                     update or online model): {e:?}",
                    b.t
                )
            })?;
            if let (Some(f), Some(sum)) = (step.nhc, self.nhc.as_mut()) {
                let nu = f.innovation.map(|v| v.as_f64());
                let s = f.variance.map(|v| v.as_f64());
                sum.add(nu, s, f.gated, self.planner.withheld_at(b.t));
            }
            if let (Some(f), Some(sum)) = (step.zupt, self.zupt.as_mut()) {
                let nis: f64 = (0..3)
                    .map(|i| f.innovation[i].as_f64().powi(2) / f.variance[i].as_f64())
                    .sum();
                sum.add(nis, f.gated, self.planner.withheld_at(b.t));
            }
            while self.fix_k < fixes.len() && fixes[self.fix_k].t <= b.t {
                let f = fixes[self.fix_k];
                self.fix_k += 1;
                let rec = self.fix(&f)?;
                sink.epoch(rec, self.run.navigator(), b.t);
            }
        }
        Ok(())
    }

    /// One fix: the planner's decisions, the heading, the fusion.
    fn fix(&mut self, f: &GnssFix) -> Result<EpochRecord> {
        let plan = self.planner.plan(f);
        if let (Some(yaw), Some(v)) = (plan.heading, f.vel_ned) {
            self.run
                .set_heading(T::lit(yaw), Vector3::from(v).map(T::lit))
                .map_err(|e| anyhow::anyhow!("nav: {e:?}"))?;
        }
        let mut rec = EpochRecord::blank(f.t, plan.withheld);
        if plan.fuse {
            let core = to_core_fix::<T>(f, self.use_velocity);
            let fused = self
                .run
                .fuse(&core)
                .map_err(|e| anyhow::anyhow!("nav: GNSS fix at t = {}: {e:?}", f.t))?;
            rec.fused = true;
            rec.gated = fused.gated;
            for i in 0..6 {
                rec.innovation[i] = fused.innovation[i].as_f64();
                rec.nis_axis[i] = fused.innovation[i].as_f64().powi(2) / fused.variance[i].as_f64();
                rec.used[i] = fused.axes[i] == AxisStatus::Used;
            }
            rec.nis = fused.nis.as_f64();
            rec.loglik = fused.loglik.as_f64();
            rec.dof = fused.dof;
            self.loglik += rec.loglik;
            self.fused += 1;
        }
        rec.heading_known = self.planner.heading_known();
        Ok(rec)
    }
}
