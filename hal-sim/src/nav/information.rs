//! The Cramér-Rao intervals of a search's answer: the observed information of the
//! log-likelihood at its maximum, by finite differences on the search's own grid. Shared by
//! the online window search ([`super::adapt`]) and `nav --identify` ([`super::identify`]), as
//! the search itself ([`super::pattern`]). For `--identify`, [`refine`] also moves the grid
//! answer to the maximum by Newton steps, with the gradient and the curvature's diagonal
//! measured within the quadratic region (a step of one sd where the likelihood is sharper
//! than the grid).

use anyhow::Result;

/// Step of the curvature's finite differences [decades]: the search's finest step, so that
/// the points the search's last pass tried are reused.
const CURVATURE_STEP: f64 = 0.125;

/// The smallest step of [`refine`]'s differences at one sd [decades].
const MIN_LOCAL_STEP: f64 = 1e-3;

/// The curvature of the log-likelihood at a search's answer, by finite differences: the
/// Cramér-Rao standard deviations, and the gradient and Hessian over the coordinates
/// differenced, from which [`refine`] takes its Newton steps.
struct Curvature {
    /// The Cramér-Rao standard deviations ([`cramer_rao_sd`]).
    sd: Vec<f64>,
    /// The coordinates whose central differences stay within their bounds.
    ok: Vec<usize>,
    /// The gradient and the Hessian over `ok`.
    grad: nalgebra::DVector<f64>,
    hess: nalgebra::DMatrix<f64>,
}

/// The Cramér-Rao standard deviations of the coordinates at the maximum `x` (value `f0`):
/// the square roots of the diagonal of the inverse observed information, `-H^-1`, with `H`
/// the Hessian of the window log-likelihood by finite differences of step
/// [`CURVATURE_STEP`] (central on the diagonal, forward across; `n (n - 1) / 2` replays
/// beyond the search's own points). `bounds(i)` is coordinate `i`'s interval, `None` for one
/// left out of the search (its sd is NaN). A coordinate whose step would leave its bounds, or
/// whose curvature is not negative, gets an infinite sd; if the information of the others is not
/// positive definite, each gets its own `1 / sqrt(-H_ii)` (conditional on the others, so
/// optimistic).
pub fn cramer_rao_sd(
    x: &[f64],
    f0: f64,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<Vec<f64>> {
    Ok(curvature(x, f0, &vec![CURVATURE_STEP; x.len()], bounds, eval)?.sd)
}

/// The curvature at `x` (value `f0`) by finite differences of step `steps[i]` in coordinate
/// `i` ([`cramer_rao_sd`] with one step for all): `n (n + 3) / 2` runs.
fn curvature(
    x: &[f64],
    f0: f64,
    steps: &[f64],
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<Curvature> {
    let n = x.len();
    let inside =
        |i: usize, v: f64| bounds(i).is_some_and(|(lo, hi)| v >= lo - 1e-12 && v <= hi + 1e-12);
    let at = |moves: &[(usize, f64)]| {
        let mut y = x.to_vec();
        for &(i, d) in moves {
            y[i] += d;
        }
        y
    };
    let ok: Vec<usize> = (0..n)
        .filter(|&i| inside(i, x[i] + steps[i]) && inside(i, x[i] - steps[i]))
        .collect();
    let d = central(x, f0, &ok, steps, eval)?;
    let mut hess = nalgebra::DMatrix::<f64>::from_diagonal(&d.diag);
    for (a, &i) in ok.iter().enumerate() {
        for (b, &j) in ok.iter().enumerate().skip(a + 1) {
            let both = eval(&at(&[(i, steps[i]), (j, steps[j])]))?;
            let v = (both - d.up[a] - d.up[b] + f0) / (steps[i] * steps[j]);
            hess[(a, b)] = v;
            hess[(b, a)] = v;
        }
    }
    Ok(Curvature {
        sd: sds(n, &ok, &hess, bounds),
        ok,
        grad: d.grad,
        hess,
    })
}

/// Most runs of [`refine`]'s Newton steps, halvings included.
const MAX_NEWTON: usize = 8;

/// Most halvings of one Newton step that does not raise the likelihood.
const MAX_HALVINGS: usize = 2;

/// A search's grid answer moved to the maximum by Newton iterations ([`refine`]).
#[derive(Debug, Clone)]
pub struct Refined {
    /// The point kept (the grid answer when no step raised the likelihood).
    pub x: Vec<f64>,
    /// Its log-likelihood.
    pub f: f64,
    /// The Cramér-Rao sds at the point kept ([`refine`]).
    pub sd: Vec<f64>,
    /// The log-likelihood gained by the steps kept, or, when none was, the change at the
    /// last step tried (negative); `None` when the curvature gave no step.
    pub newton_nats: Option<f64>,
    /// The covariance `(-H)^-1` over the coordinates the differences bounded, when `-H` is
    /// positive definite: the direction in which the others follow one coordinate at their
    /// conditional maximum ([`super::interval`]).
    pub covariance: Option<Covariance>,
}

/// The inverse observed information over some coordinates.
#[derive(Debug, Clone)]
pub struct Covariance {
    /// The coordinates, in the order of `cov`'s rows.
    pub ok: Vec<usize>,
    /// The covariance over `ok`.
    pub cov: nalgebra::DMatrix<f64>,
    /// Each coordinate's sd with the others held, `1 / sqrt(-H_ii)`, over `ok`.
    pub conditional_sd: Vec<f64>,
}

impl Covariance {
    /// `(-hess)^-1` over `ok`, `None` unless `-hess` is finite and positive definite.
    fn of(ok: &[usize], hess: &nalgebra::DMatrix<f64>) -> Option<Self> {
        if ok.is_empty() || !hess.iter().all(|v| v.is_finite()) {
            return None;
        }
        (-hess.clone()).cholesky().map(|c| Self {
            ok: ok.to_vec(),
            cov: c.inverse(),
            conditional_sd: (0..ok.len())
                .map(|a| (-1.0 / hess[(a, a)]).sqrt())
                .collect(),
        })
    }
}

/// From a search's answer `x` (value `f0`) on its grid: the curvature at the grid's step
/// ([`cramer_rao_sd`]), then Newton steps, each kept when its run raises the likelihood.
///
/// The gradient and the Hessian's diagonal are measured by central differences at each
/// coordinate's own step, its sd within [[`MIN_LOCAL_STEP`], [`CURVATURE_STEP`]] (`2 k` runs
/// for `k` coordinates differenced), at the grid answer when some sd is below the grid's step
/// and at every point kept; the Hessian is rescaled to that diagonal, its correlations the
/// grid step's ([`rescale`]). Why: a log-likelihood that is sharp in a coordinate (the GNSS
/// factors on the real drive: sd 0.005 decade) is not quadratic over the 0.125-decade step.
/// Central differences there bias the gradient by `h^2 f3 / 6` (`f3` the third derivative;
/// for a variance factor `f3 / f2 = -2 ln 10` per decade: 0.012 decade, two sds) and the
/// Newton step loses likelihood; over one sd the cubic term is 1-2 % of the quadratic. And
/// a variance factor's curvature changes by `exp(-2 ln 10 du)` over `du` decade, so the
/// diagonal is measured again where the step lands.
///
/// A step that does not raise the likelihood is halved, at most [`MAX_HALVINGS`] times. It
/// stops at a step that still does not, at one below a tenth of an sd in every coordinate,
/// or after [`MAX_NEWTON`] runs. The sds are those of the Hessian last rescaled.
pub fn refine(
    x: &[f64],
    f0: f64,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<Refined> {
    let c = curvature(x, f0, &vec![CURVATURE_STEP; x.len()], bounds, eval)?;
    let steps: Vec<f64> =
        c.sd.iter()
            .map(|&sd| {
                if sd.is_finite() {
                    sd.clamp(MIN_LOCAL_STEP, CURVATURE_STEP)
                } else {
                    CURVATURE_STEP
                }
            })
            .collect();
    let mut hess = c.hess.clone();
    let mut rescaled = false;
    // The differences at one sd, and the Newton step from them.
    let local = |at: &[f64],
                 f: f64,
                 hess: &mut nalgebra::DMatrix<f64>,
                 rescaled: &mut bool,
                 eval: &mut dyn FnMut(&[f64]) -> Result<f64>|
     -> Result<Option<Vec<f64>>> {
        let d = central(at, f, &c.ok, &steps, eval)?;
        if !d.grad.iter().chain(d.diag.iter()).all(|v| v.is_finite()) {
            return Ok(None);
        }
        *rescaled |= rescale(hess, &d.diag);
        Ok(newton_step(at, &c.ok, hess, &d.grad, bounds))
    };
    let mut proposal = if steps.iter().any(|&h| h < CURVATURE_STEP) {
        local(x, f0, &mut hess, &mut rescaled, eval)?
    } else {
        grid_newton(x, &c, bounds)
    };
    let mut best = (x.to_vec(), f0);
    let mut newton_nats = None;
    let mut runs = 0;
    let mut halvings = 0;
    while let Some(y) = proposal.take() {
        if runs == MAX_NEWTON {
            break;
        }
        runs += 1;
        let fy = eval(&y)?;
        if fy <= best.1 {
            // Backtracking: the quadratic overshot; half the step, at most MAX_HALVINGS times.
            if halvings < MAX_HALVINGS {
                halvings += 1;
                let half = y.iter().zip(&best.0).map(|(a, b)| 0.5 * (a + b)).collect();
                proposal = Some(half);
                continue;
            }
            newton_nats.get_or_insert(fy - f0);
            break;
        }
        halvings = 0;
        let small =
            c.ok.iter()
                .all(|&i| (y[i] - best.0[i]).abs() < 0.1 * steps[i]);
        best = (y, fy);
        newton_nats = Some(fy - f0);
        if small {
            break;
        }
        proposal = local(&best.0, best.1, &mut hess, &mut rescaled, eval)?;
    }
    // The sds of the Hessian last rescaled; a coordinate the grid's differences could not
    // bound (at a bound, not concave) keeps that verdict.
    let covariance = Covariance::of(&c.ok, if rescaled { &hess } else { &c.hess });
    let sd = if rescaled {
        let moved = sds(x.len(), &c.ok, &hess, bounds);
        c.sd.iter()
            .zip(moved)
            .map(|(&grid, m)| if grid.is_finite() { m } else { grid })
            .collect()
    } else {
        c.sd
    };
    Ok(Refined {
        x: best.0,
        f: best.1,
        sd,
        newton_nats,
        covariance,
    })
}

/// Central differences over the coordinates `ok` at `x` (value `f`), steps `steps`: `2 k`
/// runs.
struct Central {
    /// The gradient and the Hessian's diagonal over `ok`.
    grad: nalgebra::DVector<f64>,
    diag: nalgebra::DVector<f64>,
    /// The values at `x + steps[i] e_i` (for the cross differences of [`curvature`]).
    up: Vec<f64>,
}

fn central(
    x: &[f64],
    f: f64,
    ok: &[usize],
    steps: &[f64],
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<Central> {
    let mut grad = nalgebra::DVector::<f64>::zeros(ok.len());
    let mut diag = nalgebra::DVector::<f64>::zeros(ok.len());
    let mut up = vec![f64::NAN; ok.len()];
    let mut y = x.to_vec();
    for (a, &i) in ok.iter().enumerate() {
        let h = steps[i];
        y[i] = x[i] + h;
        up[a] = eval(&y)?;
        y[i] = x[i] - h;
        let down = eval(&y)?;
        y[i] = x[i];
        grad[a] = (up[a] - down) / (2.0 * h);
        diag[a] = (up[a] - 2.0 * f + down) / (h * h);
    }
    Ok(Central { grad, diag, up })
}

/// The Newton point from the grid step's differences alone ([`newton_step`]), when they are
/// finite.
fn grid_newton(
    x: &[f64],
    c: &Curvature,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
) -> Option<Vec<f64>> {
    let finite = c.hess.iter().chain(c.grad.iter()).all(|v| v.is_finite());
    (finite && !c.ok.is_empty())
        .then(|| newton_step(x, &c.ok, &c.hess, &c.grad, bounds))
        .flatten()
}

/// `hess` given the diagonal `diag` measured at another step or point, its correlations
/// kept: each entry scaled by `sqrt(diag_i diag_j / (H_ii H_jj))`. Returns whether it did: a
/// diagonal entry whose sign differs (not concave there) leaves `hess` as it is.
fn rescale(hess: &mut nalgebra::DMatrix<f64>, diag: &nalgebra::DVector<f64>) -> bool {
    let k = diag.len();
    let r: Vec<f64> = (0..k).map(|a| diag[a] / hess[(a, a)]).collect();
    if r.iter().any(|&v| !(v > 0.0 && v.is_finite())) {
        return false;
    }
    for a in 0..k {
        for b in 0..k {
            hess[(a, b)] *= (r[a] * r[b]).sqrt();
        }
    }
    true
}

/// The Cramér-Rao sds of the `n` coordinates from the Hessian `hess` over `ok`
/// ([`cramer_rao_sd`]'s rules for the others and for an information not positive definite).
fn sds(
    n: usize,
    ok: &[usize],
    hess: &nalgebra::DMatrix<f64>,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
) -> Vec<f64> {
    let mut sd: Vec<f64> = (0..n)
        .map(|i| {
            if bounds(i).is_some() {
                f64::INFINITY
            } else {
                f64::NAN
            }
        })
        .collect();
    let finite = hess.iter().all(|v| v.is_finite());
    match (-hess.clone()).cholesky().filter(|_| finite) {
        Some(c) => {
            let cov = c.inverse();
            for (a, &i) in ok.iter().enumerate() {
                sd[i] = cov[(a, a)].sqrt();
            }
        }
        None => {
            for (a, &i) in ok.iter().enumerate() {
                if hess[(a, a)] < 0.0 {
                    sd[i] = (-1.0 / hess[(a, a)]).sqrt();
                }
            }
        }
    }
    sd
}

/// The Newton point `x - H^-1 g` over the coordinates `ok` (the others fixed) and over the eigen-directions of `H` along which
/// the log-likelihood is concave (a direction flat or convex to the finite differences gets
/// no step: on it the quadratic has no maximum), shortened along its direction to one
/// [`CURVATURE_STEP`] in any coordinate and to the bounds.
fn newton_step(
    x: &[f64],
    ok: &[usize],
    hess: &nalgebra::DMatrix<f64>,
    grad: &nalgebra::DVector<f64>,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
) -> Option<Vec<f64>> {
    let h = CURVATURE_STEP;
    let eig = (-hess.clone()).symmetric_eigen();
    let top = eig.eigenvalues.max();
    if top <= 0.0 {
        return None;
    }
    let mut step = nalgebra::DVector::<f64>::zeros(ok.len());
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        // Relative floor: a curvature below 1e-6 of the largest is rounding, not information.
        if l > 1e-6 * top {
            let v = eig.eigenvectors.column(k);
            step += v * (v.dot(grad) / l);
        }
    }
    let longest = step.amax();
    if longest == 0.0 || !longest.is_finite() {
        return None;
    }
    let mut scale = (h / longest).min(1.0);
    for (a, &i) in ok.iter().enumerate() {
        let (lo, hi) = bounds(i)?;
        let room = if step[a] > 0.0 { hi - x[i] } else { lo - x[i] };
        if step[a] != 0.0 {
            scale = scale.min((room / step[a]).max(0.0));
        }
    }
    if scale <= 0.0 {
        return None;
    }
    let mut y = x.to_vec();
    for (a, &i) in ok.iter().enumerate() {
        y[i] += scale * step[a];
    }
    Some(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a quadratic log-likelihood the finite differences are exact: the sds are the roots
    /// of the diagonal of the covariance whose inverse is the quadratic's matrix. A coordinate
    /// left out gets NaN, one at its bound an infinite sd.
    #[test]
    fn a_quadratic_gives_its_covariance() {
        // Information [[4, 1], [1, 2]]: covariance [[2, -1], [-1, 4]] / 7.
        let m = [0.3, -0.2, 0.0, 1.0];
        let ll = |x: &[f64]| -> Result<f64> {
            let (a, b) = (x[0] - m[0], x[1] - m[1]);
            Ok(-0.5 * (4.0 * a * a + 2.0 * a * b + 2.0 * b * b) - x[2].powi(2) - x[3].powi(2))
        };
        let bounds = |i: usize| match i {
            2 => None,
            3 => Some((-1.0, 1.0)),
            _ => Some((-2.0, 2.0)),
        };
        let f0 = ll(&m).unwrap();
        let sd = cramer_rao_sd(&m, f0, &bounds, &mut |x| ll(x)).unwrap();
        assert!((sd[0] - (2.0f64 / 7.0).sqrt()).abs() < 1e-9, "{sd:?}");
        assert!((sd[1] - (4.0f64 / 7.0).sqrt()).abs() < 1e-9, "{sd:?}");
        assert!(sd[2].is_nan(), "{sd:?}");
        assert!(sd[3].is_infinite(), "{sd:?}");
    }

    /// From a point off the maximum, the Newton step lands on the quadratic's maximum when it
    /// is within one step, and is shortened along its direction to one step when not.
    #[test]
    fn the_newton_step_reaches_a_quadratics_maximum() {
        let m = [0.3, -0.2];
        let ll = |x: &[f64]| -> Result<f64> {
            let (a, b) = (x[0] - m[0], x[1] - m[1]);
            Ok(-0.5 * (4.0 * a * a + 2.0 * a * b + 2.0 * b * b))
        };
        let bounds = |_: usize| Some((-2.0, 2.0));
        let near = [0.25, -0.125];
        let h = [CURVATURE_STEP; 2];
        let c = curvature(&near, ll(&near).unwrap(), &h, &bounds, &mut |x| ll(x)).unwrap();
        let y = grid_newton(&near, &c, &bounds).expect("a concave quadratic has a Newton step");
        assert!(
            (y[0] - m[0]).abs() < 1e-9 && (y[1] - m[1]).abs() < 1e-9,
            "{y:?}"
        );
        let far = [1.0, -0.2];
        let c = curvature(&far, ll(&far).unwrap(), &h, &bounds, &mut |x| ll(x)).unwrap();
        let y = grid_newton(&far, &c, &bounds).expect("a concave quadratic has a Newton step");
        // The full step is (-0.7, 0): shortened to one CURVATURE_STEP.
        assert!((y[0] - (1.0 - CURVATURE_STEP)).abs() < 1e-9, "{y:?}");
        assert!((y[1] + 0.2).abs() < 1e-9, "{y:?}");
    }

    /// A variance factor's log-likelihood, `-n/2 (2 a u + K exp(-2 a u))` with `a = ln 10`
    /// (`u` the log10 factor on a standard deviation, `K` the innovations' mean square in
    /// stated units), is sharp for large `n` and far from a parabola over 0.125 decade: from a
    /// grid point 0.05 decade off (23 sds), the one-pass Newton step misses the maximum by
    /// more than its sd; the local pass and its iterations land within a tenth of it, with
    /// the exact sd `1 / (a sqrt(2 n))`.
    #[test]
    fn the_refinement_finds_a_sharp_maximum() {
        let (n, a) = (20_000.0, std::f64::consts::LN_10);
        let truth = -0.25f64;
        let k = (2.0 * a * truth).exp();
        let ll = |x: &[f64]| -> Result<f64> {
            Ok(-0.5 * n * (2.0 * a * x[0] + k * (-2.0 * a * x[0]).exp()))
        };
        let bounds = |_: usize| Some((-2.0, 3.0));
        let x = [truth + 0.05];
        let f0 = ll(&x).unwrap();
        let sd_exact = 1.0 / (a * (2.0 * n).sqrt());
        let coarse = curvature(&x, f0, &[CURVATURE_STEP], &bounds, &mut |y| ll(y)).unwrap();
        let miss = (grid_newton(&x, &coarse, &bounds).unwrap()[0] - truth).abs();
        assert!(miss > sd_exact, "coarse miss {miss} against sd {sd_exact}");
        let r = refine(&x, f0, &bounds, &mut |y| ll(y)).unwrap();
        let miss = (r.x[0] - truth).abs();
        assert!(
            miss < 0.1 * sd_exact,
            "refined miss {miss} against sd {sd_exact}: {r:?}"
        );
        assert!(r.newton_nats.unwrap() > 0.0, "{r:?}");
        assert!((r.sd[0] / sd_exact - 1.0).abs() < 0.05, "{:?}", r.sd);
    }
}
