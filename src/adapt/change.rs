//! A sensor that changes in service: Page's two-sided CUSUM on normalised innovations, which
//! tells the global stage ([`window`](super::window)) where the data of the sensor it now has
//! begin. Its input is the innovations of the filter's model on the block means
//! ([`window`](super::window)'s change monitor).
//!
//! # Why
//! The global stage fits one model to a window of up to 8 h. When the sensor changes inside the
//! window, the fit describes neither the sensor before nor the one after, and a change 6 h ago
//! still weighs on the answer (measured, `docs/ADAPTATION.md` §7.7). Knowing when the change
//! happened, the search can use only the hours since.
//!
//! # What
//! With the model right, its normalised innovations `e_k = nu_k / sqrt(S_k)` are independent
//! `N(0, 1)`. Against innovations of variance `K` the log-likelihood ratio of one innovation is
//!
//! ```text
//! l_K(e) = -ln(K) / 2 + e^2 (1 - 1 / K) / 2
//! ```
//!
//! and Page's CUSUM `g_k = max(0, g_{k-1} + l_K(e_k))` alarms when `g_k >= h`; the last `k` at
//! which `g` was zero is the maximum-likelihood estimate of the change time (Basseville &
//! Nikiforov, *Detection of Abrupt Changes*, 1993, §2.2). Two sums run: `K = 2` (the innovations
//! grew, a noisier sensor) and `K = 1/2` (they shrank, a quieter one). Lorden's bound gives the
//! mean time to a false alarm: at least `e^h` innovations for each sum when the model is right
//! (`h = 16` nats: 8.9 million). The global stage watches an estimated model and uses a higher
//! threshold ([`CHANGE_THRESHOLD`](super::window::CHANGE_THRESHOLD)).
//!
//! An outlier counts as `e^2 = CAP` and no `e^2` counts more: one moves `g` by at most
//! `(CAP / 2 - ln 2) / 2 = 3.65` nats, so an alarm needs at least five. The owner arms the
//! detector only while the model is an answer of the search: before the first search the start
//! model may be wrong in any direction, and its innovations say nothing about a change.
//!
//! ```
//! use imu_ident::adapt::change::ChangeDetector;
//! let mut d = ChangeDetector::<f64>::new(16.0);
//! d.arm();
//! // Innovations of variance 1 for 1000 ticks (e^2 at its mean), then of variance 9.
//! assert!((0..1000).all(|_| d.push(Some(1.0)).is_none()));
//! let age = (0..100).find_map(|_| d.push(Some(9.0)));
//! // Found within a few ticks, dated to the first tick of the change.
//! assert_eq!(age, Some(9));
//! ```

use crate::Real;

/// The largest `e^2` a tick contributes (a 4-sigma innovation), and what a gated one counts as.
pub const CAP: f64 = 16.0;
/// The variance ratios `K` of the two alternatives (a rise and a fall).
const K_UP: f64 = 2.0;
const K_DOWN: f64 = 0.5;

/// Page's two-sided CUSUM on `e^2` (module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ChangeDetector<T> {
    /// Alarm threshold `h` [nats] (zero: off).
    threshold: T,
    /// The sums for `K = 2` and `K = 1/2`.
    up: T,
    down: T,
    /// Innovations since each sum was last zero (the change's age if it alarms).
    up_age: u32,
    down_age: u32,
    armed: bool,
}

impl<T: Real> ChangeDetector<T> {
    /// Off (a compile-time value).
    pub const BLANK: Self = Self {
        threshold: T::ZERO,
        up: T::ZERO,
        down: T::ZERO,
        up_age: 0,
        down_age: 0,
        armed: false,
    };

    /// A detector that alarms at `threshold` nats (not positive or not finite: never), unarmed.
    pub fn new(threshold: T) -> Self {
        Self {
            threshold,
            ..Self::BLANK
        }
    }

    /// Whether it can alarm at all.
    pub fn enabled(&self) -> bool {
        self.threshold.is_finite() && self.threshold > T::zero()
    }

    /// Starts watching from now (the filter's model was just chosen): both sums at zero.
    pub fn arm(&mut self) {
        *self = Self {
            armed: self.enabled(),
            ..Self::new(self.threshold)
        };
    }

    /// Whether it is watching.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// The larger of the two sums [nats].
    pub fn statistic(&self) -> T {
        self.up.max(self.down)
    }

    /// One innovation: `Some(e^2)` for a used observation, `Some(CAP)` or more for an outlier,
    /// `None` for a missing one (the sums wait). On an alarm, returns the number of innovations
    /// since the estimated change (at least 1) and disarms.
    pub fn push(&mut self, e2: Option<T>) -> Option<u32> {
        if !self.armed {
            return None;
        }
        // A NaN `e^2` (a broken variance) fails both comparisons and is missing; an infinite
        // one is capped.
        let e2 = match e2? {
            v if v >= T::zero() => v.min(T::lit(CAP)),
            v if v < T::zero() => T::zero(),
            _ => return None,
        };
        let l = |k: f64| T::lit(-libm::log(k) / 2.0) + e2 * T::lit((1.0 - 1.0 / k) / 2.0);
        let up = self.up + l(K_UP);
        let down = self.down + l(K_DOWN);
        (self.up, self.up_age) = restart_at_zero(up, self.up_age);
        (self.down, self.down_age) = restart_at_zero(down, self.down_age);
        let age = if self.up >= self.threshold {
            self.up_age
        } else if self.down >= self.threshold {
            self.down_age
        } else {
            return None;
        };
        self.armed = false;
        Some(age.max(1))
    }
}

/// `max(0, g)` and the ticks since it was last zero.
fn restart_at_zero<T: Real>(g: T, age: u32) -> (T, u32) {
    if g > T::zero() {
        (g, age.saturating_add(1))
    } else {
        (T::zero(), 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    fn normal(rng: &mut rand_chacha::ChaCha8Rng, sd: f64) -> f64 {
        sd * rng.sample::<f64, _>(StandardNormal)
    }

    #[test]
    fn no_alarm_on_a_right_model_in_a_day() {
        // Lorden: mean time to a false alarm >= e^16 = 8.9e6 ticks per sum, so the chance of
        // an alarm within 86 400 ticks is at most about 2 x 86 400 / 8.9e6 = 2 % per day; a
        // fixed seed. (Measured: the largest sum over the day stays below 10 nats.)
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut d = ChangeDetector::<f64>::new(16.0);
        d.arm();
        let mut top = 0.0f64;
        for _ in 0..86_400 {
            let e = normal(&mut rng, 1.0);
            assert_eq!(d.push(Some(e * e)), None);
            top = top.max(d.statistic());
        }
        assert!(top < 16.0 && top > 1.0, "largest sum {top}");
    }

    #[test]
    fn a_rise_and_a_fall_are_found_and_dated() {
        // Variance x3 and x1/3 after 5000 ticks: expected drifts 0.40 and 0.18 nats per tick,
        // so the alarm comes after about 40 and 90 ticks; the date is within a few tens.
        for (sd, most) in [(3f64.sqrt(), 200u32), (1.0 / 3f64.sqrt(), 400)] {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
            let mut d = ChangeDetector::<f64>::new(16.0);
            d.arm();
            for _ in 0..5000 {
                let e = normal(&mut rng, 1.0);
                assert_eq!(d.push(Some(e * e)), None);
            }
            let mut found = None;
            for k in 1..=most {
                let e = normal(&mut rng, sd);
                if let Some(age) = d.push(Some(e * e)) {
                    found = Some((k, age));
                    break;
                }
            }
            let (k, age) = found.expect("no alarm");
            // The change began `k` ticks ago; the estimate is within 60 ticks of it.
            assert!(
                age.abs_diff(k) <= 60,
                "sd {sd}: after {k} ticks, dated {age} ago"
            );
            assert!(!d.armed());
            assert_eq!(d.push(Some(100.0)), None, "disarmed after an alarm");
        }
    }

    #[test]
    fn outliers_missing_and_non_finite_inputs_are_bounded() {
        let mut d = ChangeDetector::<f32>::new(16.0);
        d.arm();
        // Four outliers in a row (each capped at 3.65 nats) do not alarm.
        for _ in 0..4 {
            assert_eq!(d.push(Some(f32::INFINITY)), None);
        }
        // NaN and missing leave the sums alone.
        let s = d.statistic();
        assert_eq!(d.push(Some(f32::NAN)), None);
        assert_eq!(d.push(None), None);
        assert_eq!(d.statistic(), s);
        // A fifth does.
        assert_eq!(d.push(Some(1e30)), Some(5));
        // Off: never.
        let mut off = ChangeDetector::<f32>::new(0.0);
        off.arm();
        assert!(!off.armed());
        assert_eq!(off.push(Some(f32::INFINITY)), None);
    }
}
