//! The likelihood derivatives a bank measures: the finite-difference score and Fisher
//! information of the innovation log-likelihood (the equations are in [`bank`](super::bank)'s
//! module documentation), accumulated one scalar innovation at a time.
//!
//! A vector observation with independent axes (diagonal `R`) fused as sequential scalar updates
//! contributes one term per axis: its log-likelihood is the sum of the sequential scalar
//! innovations' (the chain rule `p(z_1, z_2) = p(z_1) p(z_2 | z_1)`), and so are its score and,
//! the innovations being independent under the model, its Fisher information.

// Small fixed-size matrix code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::adapt::params::MAXP;
use crate::Real;

/// Number of bank members: the centre and two per parameter.
pub const MEMBERS: usize = 2 * MAXP + 1;

/// The innovation of one member at one step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MemberInnovation<T> {
    /// `nu = z - H x` (before the update).
    pub nu: T,
    /// `S = H P H^T + R`.
    pub s: T,
}

impl<T: Real> MemberInnovation<T> {
    /// Log-likelihood of the innovation, `-1/2 (ln S + nu^2 / S)`.
    pub fn loglik(&self) -> T {
        -T::lit(0.5) * (self.s.ln() + self.nu * self.nu / self.s)
    }
}

/// Score and Fisher information accumulated over a number of scalar innovations.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Information<T> {
    /// `g_i = sum_k d l_k / d theta_i`.
    pub score: [T; MAXP],
    /// `I_ij = sum_k (dS_i dS_j / 2S^2 + dnu_i dnu_j / S)`.
    pub fisher: [[T; MAXP]; MAXP],
    /// Number of scalar innovations summed (the steps, for a one-axis observation).
    pub steps: u32,
}

impl<T: Real> Information<T> {
    /// Nothing accumulated.
    pub const BLANK: Self = Self {
        score: [T::ZERO; MAXP],
        fisher: [[T::ZERO; MAXP]; MAXP],
        steps: 0,
    };
}

impl<T: Real> Default for Information<T> {
    fn default() -> Self {
        Self::BLANK
    }
}

/// Central differences of `l`, `nu`, `S` of the members `[centre, theta + h e_0, theta - h e_0,
/// ...]` (`np` parameters, step `h`) into `info` (module documentation); false (nothing added) if
/// any term, or any sum it would make, is not finite. Used by the bank and by the global stage's
/// polish.
pub fn accumulate<T: Real>(
    inn: &[MemberInnovation<T>; MEMBERS],
    np: usize,
    h: T,
    info: &mut Information<T>,
) -> bool {
    let half = T::lit(0.5);
    let inv2h = half / h;
    let c = inn[0];
    let mut dl = [T::zero(); MAXP];
    let mut dnu = [T::zero(); MAXP];
    let mut ds = [T::zero(); MAXP];
    // `np <= MAXP` always; the `min` lets the optimiser drop the bounds checks (and their
    // panics) below.
    let np = np.min(MAXP);
    for i in 0..np {
        let (pl, mi) = (inn[2 * i + 1], inn[2 * i + 2]);
        // l+ - l- = -1/2 (ln(S+/S-) + nu+^2/S+ - nu-^2/S-): one logarithm per parameter.
        let d = -half * ((pl.s / mi.s).ln() + pl.nu * pl.nu / pl.s - mi.nu * mi.nu / mi.s);
        dl[i] = d * inv2h;
        dnu[i] = (pl.nu - mi.nu) * inv2h;
        ds[i] = (pl.s - mi.s) * inv2h;
    }
    if !(dl.iter().chain(dnu.iter()).chain(ds.iter())).all(|v| v.is_finite()) {
        return false;
    }
    let inv_s = T::one() / c.s;
    let w = half * inv_s * inv_s;
    // The sums must stay finite too (an absurd parameter point, a huge observation): checked on
    // the score and the diagonal. The information and each step's term are positive
    // semi-definite, so `|I_ij| <= max(I_ii, I_jj)` and a finite diagonal bounds the rest.
    for i in 0..np {
        let d = info.fisher[i][i] + (w * ds[i] * ds[i] + inv_s * dnu[i] * dnu[i]);
        if !((info.score[i] + dl[i]).is_finite() && d.is_finite()) {
            return false;
        }
    }
    for i in 0..np {
        info.score[i] += dl[i];
        for j in 0..np {
            info.fisher[i][j] += w * ds[i] * ds[j] + inv_s * dnu[i] * dnu[j];
        }
    }
    info.steps = info.steps.saturating_add(1);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Terms that are finite but whose products overflow (an innovation of 4e18 in `f32`: its
    /// square, in the log-likelihood, is finite, but the squared difference over `2h` is 4e38)
    /// add nothing, so that one absurd step cannot leave an infinite
    /// information behind for every later Gauss-Newton solve; ordinary terms still add.
    #[test]
    fn an_overflowing_term_adds_nothing() {
        let mut inn = [MemberInnovation::<f32> { nu: 0.1, s: 1.0 }; MEMBERS];
        inn[1].nu = 0.2;
        let mut info = Information::default();
        assert!(accumulate(&inn, 2, 0.1, &mut info));
        let before = info;
        assert!(before.fisher[0][0] > 0.0 && before.score[0] != 0.0);
        inn[1].nu = 4e18;
        assert!(!accumulate(&inn, 2, 0.1, &mut info));
        assert_eq!(info, before);
        // A finite term that would take a finite sum past f32::MAX adds nothing either.
        inn[1].nu = 2e18;
        info.fisher[0][0] = 3.0e38;
        let near = info;
        assert!(!accumulate(&inn, 2, 0.1, &mut info));
        assert_eq!(info, near);
    }
}
