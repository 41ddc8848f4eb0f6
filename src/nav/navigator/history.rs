//! The solution's recent velocities, with which a late GNSS fix is compared with the solution
//! at its own time of validity ([`super::Navigator::gnss`]).
//!
//! A receiver delivers each fix some time after its time of validity (0.05-0.5 s). A fix
//! inside the last IMU sample is compared with the solution interpolated along that sample's
//! velocity change (over which the mechanised velocity is linear). Until 2026-12-01 a fix
//! older than that was compared with the position moved back along a *constant* velocity, and
//! with the velocity of the newest sample: in a turn at 38 m/s (about 3 m/s^2 across the
//! track) a fix 0.25 s late then met a velocity 0.75 m/s off, the gate refused it or the filter
//! took the turn's acceleration for an attitude error, and a 20-min simulated drive ended at
//! 6.4 m horizontal RMS against 0.52 m with the fixes on time (BENCHMARKS.md "Late fixes
//! without a budget"). So the navigator keeps the velocity at sample boundaries 20 ms apart
//! over the last second, and a late fix is compared with the solution there: the velocity
//! interpolated linearly between kept points (and along the last sample's own velocity
//! change), the position moved back by the integral of that polyline.
//!
//! Each closed-loop correction adds its velocity correction to every kept point: the
//! navigation error is taken as constant over the history (the filter's own approximation for
//! a fix, whose rows are those of the error now). A velocity replaced outright (a heading
//! restart with a measured velocity) clears it. Older than the oldest point, the velocity is
//! held at the oldest point's (the behaviour before, which keeps a fix valid however late).
//!
//! Cost: [`POINTS`] times a time (`f64`) and a velocity, 960 B in `f32`; a push per kept
//! sample, a walk of at most [`POINTS`] points per late fix, an addition per point per
//! correction.

use super::{NavObserver, Navigator};
use crate::strapdown::{move_by, Geodetic};
use crate::Real;
use nalgebra::Vector3;

/// Points kept: with [`SPACING`], 0.94 s of history at 100 Hz and faster.
pub const POINTS: usize = 48;

/// Least time between kept points [s]: every second sample at 100 Hz (with up to 0.5 ms of
/// jitter), every fourth at 200 Hz, every eighth at 400 Hz. Measured against a point at every
/// sample (`SPACING` 9.5 ms, half the history): the same accuracy with fixes 0.25 s late, to
/// 4e-4 of the RMS (BENCHMARKS.md "Late fixes without a budget").
pub const SPACING: f64 = 0.0195;

/// The velocity at the last [`POINTS`] sample boundaries at least [`SPACING`] apart (a ring).
#[derive(Debug, Clone)]
pub struct VelocityHistory<T: Real> {
    t: [f64; POINTS],
    v: [Vector3<T>; POINTS],
    /// Index of the newest point (meaningful when `len > 0`).
    head: usize,
    len: usize,
}

impl<T: Real> Default for VelocityHistory<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> VelocityHistory<T> {
    /// Empty.
    pub fn new() -> Self {
        Self {
            t: [0.0; POINTS],
            v: [Vector3::zeros(); POINTS],
            head: 0,
            len: 0,
        }
    }

    /// Forgets every point (a velocity replaced outright).
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Points kept.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No point kept.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Keeps the solution's velocity `v` at the sample boundary `t`, unless the newest point
    /// is less than [`SPACING`] before it (or not before it: a time going back is not kept).
    pub fn push(&mut self, t: f64, v: Vector3<T>) {
        if !(t.is_finite() && v.iter().all(|x| x.is_finite())) {
            return;
        }
        if let Some((newest, _)) = self.point(0) {
            // Both finite (checked above and when kept): a plain comparison.
            if t - newest < SPACING {
                return;
            }
        }
        let head = if self.len == 0 {
            0
        } else {
            (self.head + 1) % POINTS
        };
        if let (Some(tk), Some(vk)) = (self.t.get_mut(head), self.v.get_mut(head)) {
            *tk = t;
            *vk = v;
            self.head = head;
            self.len = (self.len + 1).min(POINTS);
        }
    }

    /// Adds a closed-loop velocity correction `dv` (the solution's new velocity less its old)
    /// to every point.
    pub fn shift(&mut self, dv: &Vector3<T>) {
        if !dv.iter().all(|x| x.is_finite()) {
            self.clear();
            return;
        }
        for v in self.v.iter_mut() {
            *v += dv;
        }
    }

    /// The `i`-th newest point (0: the newest).
    fn point(&self, i: usize) -> Option<(f64, Vector3<T>)> {
        if i >= self.len {
            return None;
        }
        let k = (self.head + POINTS - i % POINTS) % POINTS;
        Some((*self.t.get(k)?, *self.v.get(k)?))
    }

    /// The solution `lag` seconds before `now`: the displacement since then [m, NED, `f64`]
    /// and the velocity then. `now` is the solution's time and velocity, `prev` those at the
    /// start of its last sample (the mechanised velocity is linear between them); the kept
    /// points before `prev` follow, then the oldest one's velocity is held.
    pub fn back(
        &self,
        now: (f64, Vector3<T>),
        prev: (f64, Vector3<T>),
        lag: f64,
    ) -> ([f64; 3], Vector3<T>) {
        let (t_now, v_now) = now;
        let mut d = [0.0f64; 3];
        if lag.is_nan() || lag <= 0.0 {
            // At (or, within the caller's tolerance, after) the solution's time.
            for (di, vi) in d.iter_mut().zip(v_now.iter()) {
                *di = vi.as_f64() * lag;
            }
            return (d, v_now);
        }
        let target = t_now - lag;
        let (mut t_cur, mut v_cur) = (t_now, v_now);
        let older = (0..self.len).filter_map(|i| self.point(i));
        for (t1, v1) in core::iter::once(prev).chain(older) {
            if t1.is_nan() || t1 >= t_cur {
                // Not before the current point (the start, where `prev` is `now`; a kept point
                // at the start of the last sample, which `prev` already is).
                continue;
            }
            let span = t_cur - t1;
            if target >= t1 {
                let f = (t_cur - target) / span;
                let v_at = v_cur + (v1 - v_cur) * T::lit(f);
                add_trapezoid(&mut d, &v_cur, &v_at, t_cur - target);
                return (d, v_at);
            }
            add_trapezoid(&mut d, &v_cur, &v1, span);
            t_cur = t1;
            v_cur = v1;
        }
        // Older than every point: the oldest velocity held.
        add_trapezoid(&mut d, &v_cur, &v_cur, t_cur - target);
        (d, v_cur)
    }
}

impl<T: Real, const N: usize, O: NavObserver<T, N>> Navigator<T, N, O> {
    /// The solution `lag` seconds before its time: the displacement since then [m, NED,
    /// `f64`] and the velocity then (module docs; `lag <= 0`: the velocity now).
    pub(super) fn back_by(&self, lag: f64) -> ([f64; 3], Vector3<T>) {
        let v = self.ins.velocity();
        let dt_last = (self.t - self.t_prev).max(0.0);
        let prev = (self.t_prev, v - self.a_sample * T::lit(dt_last));
        self.history.back((self.t, v), prev, lag)
    }

    /// The IMU's position and NED velocity [m/s] at time `t` (at most the solution's time):
    /// the solution moved back along the velocities kept (module docs). The epochs of a run
    /// are reported so, at the fix's time (`run::Run::epoch`, and the host's records).
    pub fn solution_at(&self, t: f64) -> (Geodetic, Vector3<T>) {
        let (d, v) = self.back_by(self.t - t);
        let p = move_by(&self.ins.position(), &-Vector3::from(d));
        (p, v)
    }
}

/// `d += (a + b) / 2 * dt`, in `f64`.
fn add_trapezoid<T: Real>(d: &mut [f64; 3], a: &Vector3<T>, b: &Vector3<T>, dt: f64) {
    for ((di, ai), bi) in d.iter_mut().zip(a.iter()).zip(b.iter()) {
        *di += 0.5 * (ai.as_f64() + bi.as_f64()) * dt;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64) -> Vector3<f64> {
        Vector3::new(x, -2.0 * x, 0.5)
    }

    /// A velocity linear in time is recovered exactly at any lag within the history, and its
    /// integral too; beyond it the oldest velocity is held.
    #[test]
    fn a_linear_velocity_is_recovered_at_any_lag() {
        let mut h = VelocityHistory::<f64>::new();
        let vel = |t: f64| v(3.0 + 2.0 * t);
        let mut t = 0.0;
        while t < 2.0 - 1e-9 {
            h.push(t, vel(t));
            t += 0.01;
        }
        let (t_now, t_prev) = (2.0, 1.99);
        assert_eq!(h.len(), POINTS);
        for lag in [0.0, 0.004, 0.01, 0.013, 0.25, 0.3333, 0.47, 0.93] {
            let (d, v_at) = h.back((t_now, vel(t_now)), (t_prev, vel(t_prev)), lag);
            assert!((v_at - vel(t_now - lag)).norm() < 1e-12, "lag {lag}");
            // The integral of 3 + 2 t over [2 - lag, 2], per axis.
            let int = 3.0 * lag + (4.0 - (2.0 - lag) * (2.0 - lag));
            let want = [int, -2.0 * int, 0.5 * lag];
            for (a, b) in d.iter().zip(want.iter()) {
                assert!((a - b).abs() < 1e-12, "lag {lag}: {d:?} against {want:?}");
            }
        }
        // Beyond the oldest point (every second push kept, the newest at 1.98): held there.
        let oldest = 1.98 - 0.02 * (POINTS as f64 - 1.0);
        let (_, v_at) = h.back((t_now, vel(t_now)), (t_prev, vel(t_prev)), 1.5);
        assert!((v_at - vel(oldest)).norm() < 1e-9);
    }

    /// A closed-loop correction moves every kept velocity; a non-finite one clears them.
    #[test]
    fn a_correction_shifts_the_history() {
        let mut h = VelocityHistory::<f32>::new();
        for k in 0..5 {
            h.push(0.02 * f64::from(k), Vector3::zeros());
        }
        h.shift(&Vector3::new(1.0, 0.0, 0.0));
        let (_, v_at) = h.back(
            (0.1, Vector3::new(1.0, 0.0, 0.0)),
            (0.09, Vector3::x()),
            0.05,
        );
        assert_eq!(v_at, Vector3::x());
        h.shift(&Vector3::new(f32::NAN, 0.0, 0.0));
        assert!(h.is_empty());
    }

    /// Points closer than the spacing, out of order or not finite are not kept.
    #[test]
    fn close_or_bad_points_are_not_kept() {
        let mut h = VelocityHistory::<f64>::new();
        h.push(0.0, v(1.0));
        h.push(0.005, v(1.0));
        h.push(-1.0, v(1.0));
        h.push(f64::NAN, v(1.0));
        h.push(0.02, Vector3::new(f64::INFINITY, 0.0, 0.0));
        assert_eq!(h.len(), 1);
        h.push(0.01, v(1.0));
        assert_eq!(h.len(), 1);
        h.push(0.02, v(1.0));
        assert_eq!(h.len(), 2);
    }
}
