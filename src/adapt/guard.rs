//! Safeguards of the Gauss-Newton update: the damped solve, the hysteresis (ignore steps smaller
//! than their standard error), the rate limit, and the physical bounds.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::adapt::params::{Specs, MAXP};
use crate::model::Quantity;
use crate::Real;

/// A `MAXP x MAXP` matrix (only the leading `p x p` block is used).
pub type Mat<T> = crate::linalg::Arr<T, MAXP>;

/// Lower and upper bounds of each `theta_i` (natural logarithms).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Bounds<T> {
    /// Lower bounds.
    pub lo: [T; MAXP],
    /// Upper bounds.
    pub hi: [T; MAXP],
}

impl<T: Real> Bounds<T> {
    /// All zeros (a compile-time placeholder).
    pub const BLANK: Self = Self {
        lo: [T::ZERO; MAXP],
        hi: [T::ZERO; MAXP],
    };

    /// Physical bounds around the starting `theta0`: `tau` within `[dt, tau_max]`, `beta` within
    /// `[2 pi / tau_max, pi / dt]` (periods from the longest correlation time down to the
    /// Nyquist period `2 dt`), every scale (sigma, q, density) within `spread` decades of its
    /// starting value either way. The finite
    /// difference step `h` is kept inside too, so that no bank member leaves the bounds.
    pub fn new(specs: &Specs, theta0: &[T; MAXP], dt: T, tau_max: T, spread: T, h: T) -> Self {
        let mut lo = [T::zero(); MAXP];
        let mut hi = [T::zero(); MAXP];
        let dec = spread * T::ln_10();
        for (i, s) in specs.iter().enumerate().take(MAXP) {
            let (l, u) = match s.kind {
                Quantity::Tau => (dt.ln(), tau_max.ln()),
                Quantity::Beta => (
                    (T::lit(core::f64::consts::TAU) / tau_max).ln(),
                    (T::lit(core::f64::consts::PI) / dt).ln(),
                ),
                _ => (theta0[i] - dec, theta0[i] + dec),
            };
            lo[i] = l + h;
            hi[i] = (u - h).max(l + h);
        }
        Self { lo, hi }
    }

    /// `theta` clamped into the bounds.
    pub fn clamp(&self, theta: &[T; MAXP], p: usize) -> [T; MAXP] {
        let mut out = *theta;
        for i in 0..p.min(MAXP) {
            out[i] = out[i].max(self.lo[i]).min(self.hi[i]);
        }
        out
    }
}

/// Limits a step: components smaller than `threshold` standard errors are dropped (hysteresis),
/// and the rest is scaled down as a whole (keeping its direction, which matters when parameters
/// are strongly correlated, like `sigma` and `tau` of a slow Gauss-Markov process) so that no
/// component exceeds `max_step`.
pub fn limit_step<T: Real>(
    delta: &[T; MAXP],
    std_err: &[T; MAXP],
    threshold: T,
    max_step: T,
    p: usize,
) -> [T; MAXP] {
    let p = p.min(MAXP);
    let mut d = *delta;
    let mut biggest = T::zero();
    for i in 0..p {
        if !(d[i].is_finite()) || d[i].abs() < threshold * std_err[i] {
            d[i] = T::zero();
        }
        biggest = biggest.max(d[i].abs());
    }
    if biggest > max_step {
        let k = max_step / biggest;
        for v in d.iter_mut().take(p) {
            *v *= k;
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_limits() {
        let mut delta = [0.0f64; MAXP];
        delta[..4].copy_from_slice(&[2.0, -0.1, 0.5, 0.0]);
        let mut se = [0.1f64; MAXP];
        se[1] = 0.2;
        let d = limit_step(&delta, &se, 1.0, 1.0, 4);
        assert_eq!(d[1], 0.0);
        assert!((d[0] - 1.0).abs() < 1e-12 && (d[2] - 0.25).abs() < 1e-12);
    }
}
