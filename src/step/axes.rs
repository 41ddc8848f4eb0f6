//! The step for any error model: one tick with `Z` observation axes
//! ([`tick_axes`](Estimator::tick_axes)), per-axis flags, the vector gate, and the log-row
//! driver with the [`clock`](super::clock)'s time rules ([`push_axes`](Estimator::push_axes)).

use super::clock::Plan;
use super::{Engine, Estimator};
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::has_coordinate;
use crate::telemetry::{
    status_flags, AxesRecord, AxesSink, IdentRecord, BAD_INPUT, BRIDGED, GATED_OUTLIER, MISSING,
    NOT_IDENTIFIABLE, PARAM_CLAMPED, P_REPAIRED, SENSOR_CHANGE, TIME_JUMP,
};
use crate::Real;

/// What one [`tick_axes`](Estimator::tick_axes) did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxesReport<T, const Z: usize> {
    /// The tick's index.
    pub k: u32,
    /// Its time [s].
    pub t: f64,
    /// The (centre) filter's innovation per axis: sequential, after the axes before it (NaN
    /// when missing).
    pub innovation: [T; Z],
    /// Its variance per axis.
    pub variance: [T; Z],
    /// Per axis: [`MISSING`], [`GATED_OUTLIER`], or [`P_REPAIRED`] for a bad innovation
    /// variance.
    pub axis_flags: [u16; Z],
    /// The NIS of the finite axes, `sum_k nu_k^2 / S_k` (the vector NIS of an observation that
    /// was used; of a gated one, the sum of its axes' marginal NIS); NaN when none is finite.
    pub nis: T,
    /// The number of finite axes.
    pub dof: usize,
    /// The tick's flags ([`MISSING`] only when every axis was).
    pub flags: u16,
    /// The parameters changed at this tick (or it is the first tick).
    pub reidentified: bool,
    /// The identification jumped to another basin.
    pub jumped: bool,
}

impl<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize, const W: usize>
    Estimator<T, M, N, Z, W>
{
    /// One tick at time `t` [s] with the observation `z` (per axis; NaN: missing, infinite:
    /// missing and [`BAD_INPUT`]): one prediction, the vector gate on the finite axes
    /// (`q_m s`, module documentation) and their sequential updates, the identification's
    /// share of the tick. Bounded work whatever the input.
    pub fn tick_axes(&mut self, t: f64, z: &[T; Z]) -> AxesReport<T, Z> {
        let nan = T::lit(f64::NAN);
        let mut flags = self.clock.flags(t, self.dt.as_f64());
        // Infinite (not NaN, which means missing): `v == v` is false only for NaN.
        #[allow(clippy::eq_op)]
        if z.iter().any(|v| !v.is_finite() && *v == *v) {
            flags |= BAD_INPUT;
        }
        let (q, s) = (self.quantiles, self.nis_scale);
        let gate = move |m: usize| {
            let qm = m.checked_sub(1).and_then(|i| q.get(i));
            qm.map_or(T::lit(f64::NAN), |qm| *qm * s)
        };
        let mut innovation = [nan; Z];
        let mut variance = [nan; Z];
        let mut axis_flags = [0u16; Z];
        let (reidentified, jumped) = match &mut self.engine {
            Engine::Fixed(f) => {
                f.predict();
                let fused = f.update(z, Some(&gate));
                innovation = fused.innovation;
                variance = fused.variance;
                for (a, st) in axis_flags.iter_mut().zip(fused.axes.iter()) {
                    *a = status_flags(*st);
                }
                // A bad variance means `P` went wrong: here the repair says so, not the axis
                // (the one-channel firmware's flags, unchanged; the adaptive engine has always
                // flagged the bad variance itself).
                flags |= axis_union(&axis_flags) & GATED_OUTLIER;
                if f.repair() {
                    flags |= P_REPAIRED;
                }
                (false, false)
            }
            Engine::Adaptive(a) => {
                let before = a.repairs();
                let st = a.step_axes(z, Some(&gate));
                let axes = innovation.iter_mut().zip(variance.iter_mut());
                for (k, ((v, w), (af, zk))) in axes.zip(axis_flags.iter_mut().zip(z)).enumerate() {
                    let (inn, status) = st.step.bank.axis(k, zk.is_finite());
                    if let Some(i) = inn {
                        (*v, *w) = (i.nu, i.s);
                    }
                    *af = status_flags(status);
                }
                flags |= axis_union(&axis_flags) & (GATED_OUTLIER | P_REPAIRED);
                if a.repairs() != before {
                    flags |= P_REPAIRED;
                }
                if st.clamped {
                    flags |= PARAM_CLAMPED;
                }
                if st.changed {
                    flags |= SENSOR_CHANGE;
                }
                if a.flat() != 0 {
                    flags |= NOT_IDENTIFIABLE;
                }
                (st.step.moved, st.step.jumped)
            }
        };
        if axis_flags.iter().all(|f| f & MISSING != 0) {
            flags |= MISSING;
        }
        // The NIS of the finite axes; the gate's scale follows it per degree of freedom.
        let mut nis = T::zero();
        let mut dof = 0usize;
        let finite = z.iter().zip(innovation.iter().zip(variance.iter()));
        for (_, (nu, s)) in finite.filter(|(v, _)| v.is_finite()) {
            nis += *nu * *nu / *s;
            dof += 1;
        }
        if dof == 0 {
            nis = nan;
        }
        let m = T::lit(dof as f64);
        self.track_scale(nis / m, gate(dof) / m);
        self.clock.ticked(t);
        let k = self.k;
        self.k = self.k.wrapping_add(1);
        if flags & P_REPAIRED != 0 {
            self.repairs = self.repairs.saturating_add(1);
        }
        AxesReport {
            k,
            t,
            innovation,
            variance,
            axis_flags,
            nis,
            dof,
            flags,
            reidentified: reidentified || k == 0,
            jumped,
        }
    }

    /// One log row of `Z` axes: the [`clock`](super::clock)'s time rules, then a tick. Every
    /// tick's [`AxesRecord`] goes to `sink`, followed by an [`IdentRecord`] per identified
    /// parameter when they changed (and at the first tick).
    pub fn push_axes(&mut self, t: f64, z: &[T; Z], sink: &mut impl AxesSink<Z, N>) {
        let dt = self.dt.as_f64();
        let nan = T::lit(f64::NAN);
        match self.clock.plan(t, dt, self.cfg.max_bridge) {
            Plan::Skip(flags) => {
                let r = AxesReport {
                    k: self.k,
                    t,
                    innovation: [nan; Z],
                    variance: [nan; Z],
                    axis_flags: [0; Z],
                    nis: nan,
                    dof: 0,
                    flags,
                    reidentified: false,
                    jumped: false,
                };
                sink.record(&self.axes_record(&r, z));
            }
            Plan::Run {
                start,
                bridged,
                jump,
            } => {
                let missing = [nan; Z];
                for i in 1..=bridged {
                    let mut r = self.tick_axes(start + f64::from(i) * dt, &missing);
                    r.flags |= BRIDGED;
                    self.emit_axes(&r, &missing, sink);
                }
                let mut r = self.tick_axes(t, z);
                if jump {
                    r.flags |= TIME_JUMP;
                }
                self.emit_axes(&r, z, sink);
            }
        }
    }

    /// The telemetry record of a tick with the observation `z`: the report's per-axis figures
    /// and the state estimates now, narrowed to `f32`.
    pub fn axes_record(&self, r: &AxesReport<T, Z>, z: &[T; Z]) -> AxesRecord<Z, N> {
        // Narrowing to f32 is the telemetry's precision, not the filter's.
        let f = |x: &T| x.as_f64() as f32;
        AxesRecord {
            k: r.k,
            t: r.t,
            z: z.each_ref().map(f),
            innovation: r.innovation.each_ref().map(f),
            variance: r.variance.each_ref().map(f),
            axis_flags: r.axis_flags,
            nis: f(&r.nis),
            dof: u8::try_from(r.dof).unwrap_or(u8::MAX),
            x: self.state_si().each_ref().map(f),
            sigma: self.sigma_si().each_ref().map(f),
            flags: r.flags,
        }
    }

    /// Sends a tick's record, then the identified parameters when they changed: those of the
    /// adaptive filter with their Cramér-Rao sd and flags, or the fixed model's (sd NaN).
    pub fn emit_axes(&self, r: &AxesReport<T, Z>, z: &[T; Z], sink: &mut impl AxesSink<Z, N>) {
        sink.record(&self.axes_record(r, z));
        if !r.reidentified {
            return;
        }
        let (specs, theta, sd, flat) = match (&self.engine, self.model()) {
            (Engine::Adaptive(a), _) => (a.specs().clone(), *a.theta(), a.cr_sd(), a.flat()),
            (Engine::Fixed(_), Ok(m)) => {
                let specs = m.identified();
                let theta = m.parameters(&specs);
                (specs, theta, None, 0)
            }
            (Engine::Fixed(_), Err(_)) => return,
        };
        for (i, (spec, th)) in specs.iter().zip(theta.iter()).enumerate() {
            let sd_ln = sd
                .as_ref()
                .and_then(|sd| sd.get(i))
                .map_or(f32::NAN, |s| s.as_f64() as f32);
            sink.ident(&IdentRecord {
                k: r.k,
                t: r.t,
                spec: *spec,
                value: th.exp().as_f64() as f32,
                sd_ln,
                flat: has_coordinate(flat, i),
            });
        }
    }
}

/// Every flag set on some axis.
fn axis_union(flags: &[u16]) -> u16 {
    flags.iter().fold(0, |u, f| u | f)
}
