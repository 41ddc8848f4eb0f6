//! Likelihood intervals of an identified coordinate: where the log-likelihood has fallen by
//! `level` nats from its maximum, on each side, measured by runs of the filter rather than
//! read off the quadratic that the Cramér-Rao sd assumes ([`super::information`]).
//!
//! Why: the Cramér-Rao (Wald) interval `x ± 1.96 sd` is exact for a quadratic log-likelihood.
//! A variance factor's is not (it is steeper towards less noise), a slow Gauss-Markov's is
//! skewed (the blind-spot bench, BENCHMARKS.md, where only the likelihood interval covered),
//! and a coordinate at a bound, or flat, has no sd at all: there the data still bound it on
//! one side ("the accelerometer walk is at most x times the datasheet's"), which is what the
//! user of `--identify` needs to know.
//!
//! The path: when the inverse observed information `C` over the coordinates that the
//! differences bounded is known ([`Refined`]), coordinate `i` moves by `t` and each other
//! coordinate `j` of `C` by `t C_ji / C_ii`, their conditional maximum under the quadratic (the
//! profile's path, exact for a quadratic, so that the interval is then the Wald one exactly);
//! otherwise (a coordinate at a bound or not concave, or `-H` not positive definite) the others
//! stay at the answer, and the interval is the conditional one (narrower than the profile's
//! when the coordinate is correlated with others). On a side where the ridge's end comes
//! inside [`RIDGE_SHORT`] of the conditional interval's (which the quadratic puts inside the
//! ridge's: the ridge moved a weakly determined coordinate far, beyond where its quadratic
//! holds), the held path is measured too, and the further end kept: the profile lies above
//! both paths, so its interval holds both. [`LikelihoodInterval::along_ridge`] says which.
//!
//! The end on each side is the root of `r(t) = sqrt(2 (f_max - f(t)))` (the likelihood root,
//! linear in `t` for a quadratic) at `sqrt(2 level)`: a first run at the Wald end (or half a
//! decade out when there is no sd), then linear interpolation in `r` between the bracketing
//! runs, or extrapolation from the origin (at most 4x per run) until the level is crossed or the
//! bound reached: then the end is open. A run whose fall is within [`FALL_TOLERANCE`] of the
//! level ends the search, at the secant's root through it and the run before (through the
//! answer, for the first: exact for a quadratic). Near a quadratic that is the first run or
//! the second: about four runs per coordinate.
//!
//! ```
//! use hal_sim::nav::interval::{likelihood_interval, LEVEL_95};
//! // A 1-D quadratic with sd 0.2 about 0.5: the 95 % interval is 0.5 -+ 1.96 x 0.2.
//! let ll = |x: &[f64]| -> anyhow::Result<f64> { Ok(-0.5 * ((x[0] - 0.5) / 0.2).powi(2)) };
//! let v = likelihood_interval(&[0.5], 0.0, 0, None, Some(0.2), LEVEL_95,
//!     &|_| Some((-2.0, 3.0)), &mut |x| ll(x)).unwrap();
//! assert!((v.lo - (0.5 - 1.959964 * 0.2)).abs() < 1e-5 && !v.lo_open);
//! assert!((v.hi - (0.5 + 1.959964 * 0.2)).abs() < 1e-5 && !v.hi_open);
//! ```
//!
//! [`Refined`]: super::information::Refined

pub use super::information::Covariance;
use anyhow::Result;
use serde::Serialize;

/// Half the chi-square(1) 0.95 quantile, `1.959964^2 / 2`: the fall in log-likelihood at the
/// ends of a 95 % interval.
pub const LEVEL_95: f64 = 1.920_729_410_347_062;

/// Most runs per side.
const MAX_RUNS: usize = 8;

/// The end is taken when the fall is within this of the level [nats] (module docs). Why
/// this wide: the real drive's likelihood has a jitter of a third of a nat between runs 0.1 ms
/// apart in the IMU time shift (what still follows the samples: BENCHMARKS.md "The fix at its
/// own time"), so a tighter target costs runs without a better end; 0.2 nat is at most 5 % of
/// the root, 0.1 sd at the 95 % end.
const FALL_TOLERANCE: f64 = 0.2;

/// A ridge end closer than this fraction of the conditional interval's end is checked
/// against the held path ([`likelihood_interval`]).
const RIDGE_SHORT: f64 = 0.8;

/// The first distance tried from a coordinate without a Cramér-Rao sd [decades].
const NO_SD_START: f64 = 0.5;

/// Most growth of the distance in one extrapolating run.
const MAX_GROWTH: f64 = 4.0;

/// One coordinate's likelihood interval, in the coordinate's own unit.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct LikelihoodInterval {
    /// The lower end; at `lo_open` the bound of the search, where the likelihood had not
    /// yet fallen by the level.
    pub lo: f64,
    pub hi: f64,
    /// The data do not bound the coordinate on this side within the search's bounds.
    pub lo_open: bool,
    pub hi_open: bool,
    /// The others followed their conditional maximum (the profile's path under the
    /// quadratic) on both sides; `false`: on at least one side they stayed at the answer (no
    /// curvature for the ridge, or the ridge's end came well inside the held path's, which
    /// was then further).
    pub along_ridge: bool,
    /// Runs of the filter made for both ends.
    pub runs: usize,
    /// The most a run on the path rose above the answer's log-likelihood [nats]: 0 when the
    /// answer is the path's maximum; above about a nat, the likelihood is rough or the
    /// answer not at its maximum, and the interval is about a point that is not the best.
    pub above_nats: f64,
}

/// The `level`-nat likelihood interval of coordinate `i` about the maximum `x` (value
/// `f_max`), with the covariance `cov` of the answer's Cramér-Rao sds (the path, module docs)
/// and coordinate `i`'s sd `sd` (the first run's distance), within `bounds` (`None`: not
/// searched; every coordinate the path moves must have bounds).
#[allow(clippy::too_many_arguments)]
pub fn likelihood_interval(
    x: &[f64],
    f_max: f64,
    i: usize,
    cov: Option<&Covariance>,
    sd: Option<f64>,
    level: f64,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<LikelihoodInterval> {
    // The path's direction, per unit of coordinate i, and the conditional sd `1 / sqrt(I_ii)`
    // (the others held) under the same quadratic.
    let mut held = vec![0.0; x.len()];
    held[i] = 1.0;
    let ridge = cov
        .and_then(|c| c.ok.iter().position(|&j| j == i).map(|a| (c, a)))
        .filter(|(c, a)| c.cov[(*a, *a)] > 0.0)
        .map(|(c, a)| {
            let mut v = vec![0.0; x.len()];
            for (b, &j) in c.ok.iter().enumerate() {
                v[j] = c.cov[(b, a)] / c.cov[(a, a)];
            }
            v[i] = 1.0;
            (v, c.conditional_sd.get(a).copied().unwrap_or(f64::NAN))
        });
    let first = sd
        .filter(|s| s.is_finite() && *s > 0.0)
        .map_or(NO_SD_START, |s| s * (2.0 * level).sqrt());
    let mut runs = 0;
    let mut ends = [(0.0, false); 2];
    let mut along_ridge = ridge.is_some();
    let mut best = f_max;
    let mut eval = |y: &[f64]| -> Result<f64> {
        let f = eval(y)?;
        if f > best {
            best = f;
        }
        Ok(f)
    };
    for (k, side) in [-1.0, 1.0].into_iter().enumerate() {
        let (mut t, mut open, n) = match &ridge {
            Some((v, _)) => end(x, f_max, v, side, first, level, bounds, &mut eval)?,
            None => end(x, f_max, &held, side, first, level, bounds, &mut eval)?,
        };
        runs += n;
        // The profile lies above both paths, so its interval holds both intervals. Under the
        // quadratic the ridge's end is the further (the marginal sd is at least the
        // conditional one); where it came out well inside the conditional interval, the
        // ridge moved other coordinates into a region where the quadratic does not hold,
        // and the held path's end is measured too: the further one is kept.
        if let Some((_, sd_held)) = &ridge {
            let held_end = (2.0 * level).sqrt() * sd_held;
            if !open && t < RIDGE_SHORT * held_end {
                let (th, oh, nh) = end(x, f_max, &held, side, held_end, level, bounds, &mut eval)?;
                runs += nh;
                if th > t {
                    (t, open) = (th, oh);
                    along_ridge = false;
                }
            }
        }
        ends[k] = (x[i] + side * t, open);
    }
    Ok(LikelihoodInterval {
        lo: ends[0].0,
        hi: ends[1].0,
        lo_open: ends[0].1,
        hi_open: ends[1].1,
        along_ridge,
        runs,
        above_nats: best - f_max,
    })
}

/// The distance `t` along `side * v` from `x` at which the log-likelihood has fallen by
/// `level`, whether it is open (the bound reached first), and the runs made.
#[allow(clippy::too_many_arguments)]
fn end(
    x: &[f64],
    f_max: f64,
    v: &[f64],
    side: f64,
    first: f64,
    level: f64,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<(f64, bool, usize)> {
    // The longest distance within every moved coordinate's bounds.
    let mut room = f64::INFINITY;
    for (j, &vj) in v.iter().enumerate() {
        if vj == 0.0 {
            continue;
        }
        let Some((lo, hi)) = bounds(j) else {
            return Ok((0.0, true, 0));
        };
        let d = side * vj;
        let r = if d > 0.0 { hi - x[j] } else { lo - x[j] } / d;
        room = room.min(r.max(0.0));
    }
    if room <= 1e-12 {
        return Ok((0.0, true, 0));
    }
    let target = (2.0 * level).sqrt();
    let root = |t: f64, eval: &mut dyn FnMut(&[f64]) -> Result<f64>| -> Result<f64> {
        let y: Vec<f64> = x.iter().zip(v).map(|(a, b)| a + side * t * b).collect();
        // A run above the maximum (the answer is not quite the maximum) counts as no fall.
        Ok((2.0 * (f_max - eval(&y)?)).max(0.0).sqrt())
    };
    // Bracket on the root: `below` the farthest run under the target (the answer itself at
    // first), `above` the nearest over it. Between them: linear interpolation in `r`, or in
    // `ln r` where `r` grows more than 4x across the bracket (a walk's fall grows as its
    // variance, exponentially in decades, and false position would crawl); kept 5 % inside.
    let mut below = (0.0, 0.0);
    let mut above: Option<(f64, f64)> = None;
    let mut last = below;
    let mut t = first.min(room);
    for n in 1..=MAX_RUNS {
        // A run that failed (NaN likelihood) counts as beyond the end.
        let r = Some(root(t, eval)?)
            .filter(|r| r.is_finite())
            .unwrap_or(f64::INFINITY);
        if r.is_finite() && (0.5 * r * r - level).abs() <= FALL_TOLERANCE {
            // The secant through this run and the one before (the answer, for the first)
            // puts the end at the level, kept within one step of this run.
            let (tl, rl) = last;
            let step = (t - tl).abs();
            let end = if r != rl && rl.is_finite() {
                t + (target - r) * (t - tl) / (r - rl)
            } else {
                t
            };
            return Ok((end.clamp(t - step, t + step).clamp(0.0, room), false, n));
        }
        last = (t, r);
        if r > target {
            above = Some((t, r));
        } else {
            below = (t, r);
        }
        t = match above {
            Some((ta, ra)) => {
                let (tb, rb) = below;
                let w = if !ra.is_finite() {
                    0.5
                } else if rb > 0.0 && ra > 4.0 * rb {
                    (target / rb).ln() / (ra / rb).ln()
                } else {
                    (target - rb) / (ra - rb)
                };
                tb + w.clamp(0.05, 0.95) * (ta - tb)
            }
            None if below.0 >= room => return Ok((room, true, n)),
            None => {
                let grow = if below.1 > 0.0 {
                    (target / below.1).min(MAX_GROWTH)
                } else {
                    MAX_GROWTH
                };
                (below.0 * grow).min(room)
            }
        };
    }
    // Out of runs: the interpolated end (inside the bracket, or the last extrapolation).
    Ok((t, above.is_none() && t >= room, MAX_RUNS))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quadratic_cov() -> Covariance {
        // Information [[4, 1], [1, 2]]: covariance [[2, -1], [-1, 4]] / 7.
        Covariance {
            conditional_sd: vec![0.5, 1.0 / 2f64.sqrt()],
            ok: vec![0, 1],
            cov: nalgebra::DMatrix::from_row_slice(
                2,
                2,
                &[2.0 / 7.0, -1.0 / 7.0, -1.0 / 7.0, 4.0 / 7.0],
            ),
        }
    }

    /// On a quadratic log-likelihood with correlated coordinates, the path of the
    /// conditional maximum gives the profile interval, which is the Wald one: `x -+ 1.96 sd`
    /// with the marginal sd, found by the first run on each side. Holding the other
    /// coordinate instead gives the narrower conditional interval, `1.96 / sqrt(I_ii)`.
    #[test]
    fn a_quadratics_interval_is_the_wald_interval() {
        let m = [0.3, -0.2];
        let ll = |x: &[f64]| -> Result<f64> {
            let (a, b) = (x[0] - m[0], x[1] - m[1]);
            Ok(-0.5 * (4.0 * a * a + 2.0 * a * b + 2.0 * b * b))
        };
        let bounds = |_: usize| Some((-2.0, 2.0));
        let cov = quadratic_cov();
        let z = 1.959_963_984_540_054;
        for (i, var, info) in [(0, 2.0 / 7.0, 4.0), (1, 4.0 / 7.0, 2.0)] {
            let sd = f64::sqrt(var);
            let v = likelihood_interval(
                &m,
                0.0,
                i,
                Some(&cov),
                Some(sd),
                LEVEL_95,
                &bounds,
                &mut |x| ll(x),
            )
            .unwrap();
            assert!((v.lo - (m[i] - z * sd)).abs() < 1e-9, "{v:?}");
            assert!((v.hi - (m[i] + z * sd)).abs() < 1e-9, "{v:?}");
            assert!(
                v.along_ridge && !v.lo_open && !v.hi_open && v.runs == 2,
                "{v:?}"
            );
            let c = likelihood_interval(&m, 0.0, i, None, Some(sd), LEVEL_95, &bounds, &mut |x| {
                ll(x)
            })
            .unwrap();
            let half = z / f64::sqrt(info);
            assert!((c.hi - c.lo - 2.0 * half).abs() < 1e-3 * half, "{c:?}");
            assert!(!c.along_ridge, "{c:?}");
        }
    }

    /// A variance factor's log-likelihood, `-n/2 (2 a u + K exp(-2 a u))` (`a = ln 10`, `u` the
    /// log10 factor on a standard deviation; information.rs), is steeper towards less noise:
    /// its interval is skewed, and the ends found match the roots of the exact fall, solved by
    /// bisection, within 5 % of the sd (the secant at the last run), where the Wald
    /// ends miss by more than 10 % (here 18 % and 22 %).
    #[test]
    fn a_variance_factors_interval_is_skewed() {
        let (n, a) = (20.0, std::f64::consts::LN_10);
        let u0 = 0.1f64;
        let k = (2.0 * a * u0).exp();
        let f = |u: f64| -0.5 * n * (2.0 * a * u + k * (-2.0 * a * u).exp());
        let fmax = f(u0);
        let sd = 1.0 / (a * (2.0 * n).sqrt());
        let exact = |lo: f64, hi: f64| {
            let (mut lo, mut hi) = (lo, hi);
            let g = |u: f64| fmax - f(u) - LEVEL_95;
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if (g(mid) > 0.0) == (g(lo) > 0.0) {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            0.5 * (lo + hi)
        };
        let (lo, hi) = (exact(u0 - 10.0 * sd, u0), exact(u0, u0 + 10.0 * sd));
        let v = likelihood_interval(
            &[u0],
            fmax,
            0,
            None,
            Some(sd),
            LEVEL_95,
            &|_| Some((-2.0, 3.0)),
            &mut |x| Ok(f(x[0])),
        )
        .unwrap();
        assert!(
            (v.lo - lo).abs() < 0.05 * sd && (v.hi - hi).abs() < 0.05 * sd,
            "{v:?} against {lo} {hi}"
        );
        let z = 1.959_963_984_540_054;
        assert!(
            (u0 - z * sd - lo).abs() > 0.05 * sd,
            "not skewed: {lo} {hi}"
        );
        assert!(u0 - lo < hi - u0, "steeper towards less noise: {lo} {hi}");
        assert!(v.runs <= 2 * MAX_RUNS, "{v:?}");
    }

    /// A ridge that moves a weakly determined coordinate far: coordinate 1 (sd 10, correlation
    /// 0.9 with coordinate 0) is quadratic only within `|x1| <= 1` and falls steeply beyond,
    /// so the ridge of coordinate 0 (9 units of x1 per unit of x0) ends at 0.12, well inside
    /// the conditional interval's 0.85. The held path is measured then, and its end kept:
    /// within the true profile interval, found here by brute force over x1.
    #[test]
    fn a_ridge_beyond_its_quadratic_falls_back_to_the_held_path() {
        let (rho, s1) = (0.9f64, 10.0f64);
        // Information = covariance [[1, rho s1], [rho s1, s1^2]] inverted.
        let det = s1 * s1 * (1.0 - rho * rho);
        let info = [s1 * s1 / det, -rho * s1 / det, 1.0 / det];
        let ll = |x: &[f64]| -> Result<f64> {
            let q = info[0] * x[0] * x[0] + 2.0 * info[1] * x[0] * x[1] + info[2] * x[1] * x[1];
            let out = (x[1].abs() - 1.0).max(0.0);
            Ok(-0.5 * q - 100.0 * out * out)
        };
        let cov = Covariance {
            ok: vec![0, 1],
            cov: nalgebra::DMatrix::from_row_slice(2, 2, &[1.0, rho * s1, rho * s1, s1 * s1]),
            conditional_sd: vec![1.0 / info[0].sqrt(), 1.0 / info[2].sqrt()],
        };
        let bounds = |_: usize| Some((-50.0, 50.0));
        let v = likelihood_interval(
            &[0.0, 0.0],
            0.0,
            0,
            Some(&cov),
            Some(1.0),
            LEVEL_95,
            &bounds,
            &mut |x| ll(x),
        )
        .unwrap();
        let held = 1.959_963_984_540_054 / info[0].sqrt();
        // The profile's end: where max over x1 of ll(x0, x1) falls by the level.
        let profile = |x0: f64| {
            (-4000..=4000)
                .map(|k| ll(&[x0, k as f64 * 0.005]).unwrap())
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut end = held;
        while profile(end) > -LEVEL_95 {
            end += 1e-3;
        }
        assert!(!v.along_ridge, "{v:?}");
        for t in [-v.lo, v.hi] {
            assert!(
                t >= 0.95 * held && t <= end + 0.01,
                "{v:?}: held {held}, profile {end}"
            );
        }
    }

    /// A coordinate at its lower bound, whose likelihood falls only upwards (a random walk the
    /// data do not see below some size): the lower end is open at the bound with no run, the
    /// upper end is found. A flat coordinate is open on both sides.
    #[test]
    fn a_coordinate_at_its_bound_is_bounded_on_one_side() {
        let ll = |x: &[f64]| -> Result<f64> { Ok(-(10f64.powf(2.0 * x[0]))) };
        let bounds = |_: usize| Some((-2.0, 3.0));
        let v = likelihood_interval(
            &[-2.0],
            ll(&[-2.0]).unwrap(),
            0,
            None,
            None,
            LEVEL_95,
            &bounds,
            &mut |x| ll(x),
        )
        .unwrap();
        assert!(v.lo_open && v.lo == -2.0, "{v:?}");
        // The fall 10^(2u) - 1e-4 = 1.92 at u = log10(1.9208) / 2.
        let hi = (LEVEL_95 + 1e-4).log10() / 2.0;
        assert!(!v.hi_open && (v.hi - hi).abs() < 0.01, "{v:?} against {hi}");
        let flat = likelihood_interval(&[0.0], 0.0, 0, None, None, LEVEL_95, &bounds, &mut |_| {
            Ok(0.0)
        })
        .unwrap();
        assert!(
            flat.lo_open && flat.hi_open && flat.lo == -2.0 && flat.hi == 3.0,
            "{flat:?}"
        );
    }
}
