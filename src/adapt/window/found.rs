//! What a finished search answers: the best point and its gain over the anchor ([`Found`]), and
//! the best alternative structure the structure test tried ([`Switch`]). The caller (the
//! adaptive filter) decides from them whether to jump or switch; kept apart from the search's
//! state machine that fills them.

use super::structure::Site;
use crate::adapt::guard::Mat;
use crate::adapt::params::{flat_coordinates, has_coordinate, MAXP};
use crate::linalg::{chol_solve, cholesky, inverse_diagonal};
use crate::Real;

/// The result of a finished search.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Found<T> {
    /// The best point (`ln` parameters).
    pub theta: [T; MAXP],
    /// Its log-likelihood minus the anchor's, over the same window [nats].
    pub gain: T,
    /// Blocks in the window.
    pub blocks: u32,
    /// Likelihood evaluations spent.
    pub evaluations: u32,
    /// The window's Fisher information at `theta` (`ln` parameters), from the polish that
    /// reached it; zero when no polish ran.
    pub fisher: Mat<T>,
    /// With [`WindowConfig::hold_flat`](super::WindowConfig::hold_flat): the window's
    /// maximum with the [`flat`](Self::flat) coordinates held at the anchor's values (the
    /// profile likelihood's); the anchor when none is flat.
    pub held: [T; MAXP],
    /// The log-likelihood `held` gives up against `theta` [nats]: the likelihood-ratio
    /// statistic of the hold, halved. NaN when no hold was evaluated.
    pub hold_cost: T,
    /// The best alternative structure tried (`valid` false when the structure test is off or
    /// nothing is switchable; not an `Option`: its `None` would not be all-zero bits, and the
    /// firmware's estimator would move from `.bss` to `.data`, 56 KB of flash).
    pub switch: Switch<T>,
}

impl<T: Real> Found<T> {
    /// No search yet.
    pub const BLANK: Self = Self {
        theta: [T::ZERO; MAXP],
        gain: T::ZERO,
        blocks: 0,
        evaluations: 0,
        fisher: [[T::ZERO; MAXP]; MAXP],
        held: [T::ZERO; MAXP],
        hold_cost: T::ZERO,
        switch: Switch::NONE,
    };

    /// The Cramér-Rao standard deviations of the first `p` coordinates of `theta` (`ln`) on
    /// the window: `sqrt((I^-1)_ii)`, each marginal (the other parameters free, so a ridge
    /// counts as flat). `None` when the information is not positive definite: some direction
    /// is not bounded by the window at all.
    pub fn sd(&self, p: usize) -> Option<[T; MAXP]> {
        let p = p.min(MAXP);
        let l = cholesky(&self.fisher, p)?;
        let mut v = inverse_diagonal(&l, p);
        for x in v.iter_mut().take(p) {
            *x = x.max(T::zero()).sqrt();
        }
        Some(v)
    }

    /// The coordinates (bit `i`: `theta[i]`) of the first `p` that the window does not
    /// identify ([`flat_coordinates`] of its Cramér-Rao standard deviations; issue 13, item 2).
    pub fn flat(&self, p: usize) -> u8 {
        flat_coordinates(self.sd(p).as_ref(), p)
    }

    /// `theta` with the coordinates in `mask` (bit `i`: `theta[i]`) held at `current`'s values
    /// and the others at the maximum of the window's quadratic log-likelihood model given
    /// them: `theta_F = theta_F - I_FF^-1 I_FH (current_H - theta_H)` (the conditional mean
    /// of a Gaussian with precision `I`), so that a free coordinate correlated with a held one
    /// follows the ridge instead of staying where the held one's estimate put it. The free
    /// coordinates stay at `theta` when `I_FF` is not positive definite.
    pub fn held(&self, current: &[T; MAXP], mask: u8, p: usize) -> [T; MAXP] {
        let p = p.min(MAXP);
        let held = |i: usize| has_coordinate(mask, i);
        let mut out = self.theta;
        // Free coordinates packed first: `free[k]` is the k-th free index.
        let mut free = [0usize; MAXP];
        let mut nf = 0;
        for i in 0..p {
            if !held(i) {
                if let Some(f) = free.get_mut(nf) {
                    *f = i;
                    nf += 1;
                }
            }
        }
        // `get`: the indices come from `free`, which the optimiser cannot bound.
        let info = |i: usize, j: usize| {
            self.fisher
                .get(i)
                .and_then(|r| r.get(j))
                .copied()
                .unwrap_or(T::zero())
        };
        let mut a: Mat<T> = [[T::zero(); MAXP]; MAXP];
        let mut b = [T::zero(); MAXP];
        for ((row, bk), &i) in a.iter_mut().zip(b.iter_mut()).zip(free.iter()).take(nf) {
            for (v, &j) in row.iter_mut().zip(free.iter()).take(nf) {
                *v = info(i, j);
            }
            // b = I_FH (current_H - theta_H)
            for (j, (c, t)) in current.iter().zip(self.theta.iter()).enumerate().take(p) {
                if held(j) {
                    *bk += info(i, j) * (*c - *t);
                }
            }
        }
        let shift = cholesky(&a, nf).map(|l| chol_solve(&l, &b, nf));
        for (k, &i) in free.iter().enumerate().take(nf) {
            let d = shift.as_ref().and_then(|d| d.get(k)).copied();
            if let (Some(d), Some(o)) = (d.filter(|d| d.is_finite()), out.get_mut(i)) {
                *o -= d;
            }
        }
        for (i, (o, c)) in out.iter_mut().zip(current.iter()).enumerate().take(p) {
            if held(i) {
                *o = *c;
            }
        }
        out
    }
}

/// The best alternative structure of a search: one component's kind replaced.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Switch<T> {
    /// Which component, and its new kind.
    pub site: Site,
    /// Its best point (`ln` parameters in the alternative's own `specs` order).
    pub theta: [T; MAXP],
    /// Its log-likelihood minus that of the search's best point of the filter's model [nats].
    pub gain: T,
    /// Its identified parameters minus the filter model's.
    pub extra: i8,
    /// Whether an alternative was searched (the other fields are meaningful).
    pub valid: bool,
}

impl<T: Real> Switch<T> {
    /// No alternative (all zeros).
    pub const NONE: Self = Self {
        site: Site::BLANK,
        theta: [T::ZERO; MAXP],
        gain: T::ZERO,
        extra: 0,
        valid: false,
    };

    /// `Some` when an alternative was searched.
    pub fn get(&self) -> Option<&Self> {
        self.valid.then_some(self)
    }

    /// The switch rule with `pen` nats per parameter (`docs/ADAPTATION.md` §7.6): the
    /// alternative replaces the model when `gain - pen * extra > pen / 2`. Hysteresis: with
    /// `c` nats per parameter, Gauss-Markov -> exponential-cosine needs `1.5 c` (4.5 nats at
    /// 3), and the way back is taken once the exponential-cosine's advantage falls below
    /// `0.5 c`, so that a borderline component does not switch at every search. Never with
    /// the test off (`pen <= 0`), nor for a non-finite gain.
    pub fn wins(&self, pen: T) -> bool {
        self.valid
            && pen > T::zero()
            && self.gain.is_finite()
            && self.gain - pen * T::lit(f64::from(self.extra)) > pen * T::lit(0.5)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::IDENTIFIABLE_SD;

    /// A window's information for two coordinates with sds `s0`, `s1` (`ln`) and correlation
    /// `rho` (the inverse of their covariance).
    fn found(theta: [f64; 2], s0: f64, s1: f64, rho: f64) -> Found<f64> {
        let det = s0 * s0 * s1 * s1 * (1.0 - rho * rho);
        let mut f = Found::BLANK;
        f.theta[..2].copy_from_slice(&theta);
        f.fisher[0][0] = s1 * s1 / det;
        f.fisher[1][1] = s0 * s0 / det;
        f.fisher[0][1] = -rho * s0 * s1 / det;
        f.fisher[1][0] = f.fisher[0][1];
        f
    }

    #[test]
    fn marginal_deviations_invert_the_information() {
        let f = found([0.0, 0.0], 0.1, 3.0, 0.9);
        let sd = f.sd(2).unwrap();
        assert!(
            (sd[0] - 0.1).abs() < 1e-12 && (sd[1] - 3.0).abs() < 1e-12,
            "{sd:?}"
        );
    }

    #[test]
    fn a_coordinate_above_half_a_decade_is_flat() {
        let limit = IDENTIFIABLE_SD * core::f64::consts::LN_10;
        assert_eq!(found([0.0; 2], 0.1, 0.99 * limit, 0.0).flat(2), 0);
        assert_eq!(found([0.0; 2], 0.1, 1.01 * limit, 0.0).flat(2), 0b10);
        // Along a ridge both marginal deviations are large although each conditional one is
        // small: both are flagged.
        assert_eq!(found([0.0; 2], 2.0, 2.0, 0.999).flat(2), 0b11);
        // No information at all: every coordinate is flat.
        assert_eq!(Found::<f64>::BLANK.flat(2), 0b11);
        // A NaN in the information: flat, not identified.
        let mut f = found([0.0; 2], 0.1, 0.1, 0.0);
        f.fisher[1][1] = f64::NAN;
        assert_eq!(f.flat(2), 0b11);
    }

    #[test]
    fn holding_a_coordinate_moves_the_other_along_the_ridge() {
        // theta = (1, 2), correlation 0.8: holding coordinate 1 at 2 + 3 s1 moves coordinate
        // 0 by rho s0 / s1 times that, the conditional mean of a Gaussian.
        let (s0, s1, rho) = (0.5, 2.0, 0.8);
        let f = found([1.0, 2.0], s0, s1, rho);
        let current = [f64::NAN, 2.0 + 3.0 * s1, 0.0, 0.0, 0.0];
        let held = f.held(&current, 0b10, 2);
        assert_eq!(held[1], current[1]);
        let want = 1.0 + rho * s0 / s1 * 3.0 * s1;
        assert!((held[0] - want).abs() < 1e-12, "{held:?} vs {want}");
        // Nothing held: the best point; everything held: the current point.
        assert_eq!(f.held(&current, 0, 2)[..2], [1.0, 2.0]);
        let all = f.held(&[0.5, 0.25, 0.0, 0.0, 0.0], 0b11, 2);
        assert_eq!(all[..2], [0.5, 0.25]);
    }
}
