//! Composite noise-model fit to an overlapping Allan deviation, with greedy model selection.
//!
//! # Objective
//! Weighted least squares of log-ADEV: with `s_k = (ln ci_hi − ln ci_lo) / (2 · 1.96)` the
//! standard deviation of `ln adev_k` implied by its 95 % chi-square interval,
//!
//! ```text
//! χ²(θ) = Σ_k ( ½ ln Σ_j v_j u_j(m_k; θ_j) − ln adev_k )² / s_k² ,
//! ```
//!
//! where every term's Allan variance is linear in its variance-like amplitude `v_j` (N², σ²,
//! K², Q²) and `u_j` is the unit-amplitude curve, which depends only on the term's shape
//! parameters (`ln T_c`; the exp-cosine period is fixed from the ACF). So the fit is separable
//! (variable projection, Golub & Pereyra 1973): for given shapes the amplitudes solve a
//! non-negative linear least-squares problem in AVAR space, weighted with the linearisation
//! `δ ln adev = δavar / (2 avar)`; Nelder-Mead (argmin) moves only the shapes.
//!
//! `u_j` is the exact expectation of the overlapping estimator for the point-sampled process
//! ([`NoiseComponent::avar_sampled`]) up to [`SAMPLED_MAX`] samples per cluster, then the
//! continuous-time curve, whose O(Δt/τ) difference is below 0.1 % there.
//!
//! Model selection over these terms is in `select.rs`.

use std::f64::consts::PI;

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use nalgebra::{Complex, DMatrix, DVector};

use crate::allan::theory::NoiseComponent;
use crate::allan::AdevRow;

/// Clusters up to this size use the theory module's O(m) semivariogram sum directly.
pub const SAMPLED_MAX: usize = 64;
/// z of a two-sided 95 % interval.
pub const Z95: f64 = 1.959_963_984_540_054;
/// Most terms a composite may have (the model TOML holds at most 4 per sensor; the rest is
/// folded or dropped when writing it, see `mod.rs`).
pub const MAX_TERMS: usize = 6;

/// The kinds of term the ADEV fit knows. `RandomConstant` is absent on purpose: its Allan
/// variance is zero at every τ, so the ADEV cannot see it (reported from the mean instead).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Kind {
    White,
    GaussMarkov,
    ExpCosine,
    RandomWalk,
    Quantization,
    /// White noise seen through the sensor's own averaging filter (a box-car of width T_w):
    /// see [`avar_filtered_white`]. Not in the candidate library; added here because the
    /// ADIS16405 gyros show a pure lag-1 correlation (ρ₁ = 0.17, ρ₂ = 0.003) that no
    /// Gauss-Markov reproduces (it would need ρ₂ ≥ ρ₁²/share).
    FilteredWhite,
}

impl Kind {
    /// Label in the candidate-library style (`white`, `gauss-markov`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Kind::White => "white",
            Kind::GaussMarkov => "gauss-markov",
            Kind::ExpCosine => "exp-cosine",
            Kind::RandomWalk => "random-walk",
            Kind::Quantization => "quantization",
            Kind::FilteredWhite => "filtered-white",
        }
    }
    /// Free parameters counted by BIC (the exp-cosine's period comes from the ACF but is a
    /// parameter of the model all the same).
    pub fn n_params(self) -> usize {
        match self {
            Kind::White | Kind::RandomWalk | Kind::Quantization => 1,
            Kind::GaussMarkov | Kind::FilteredWhite => 2,
            Kind::ExpCosine => 3,
        }
    }
}

/// One term of a composite: amplitude `var` (N², σ², K² or Q²), correlation time `tc` [s]
/// (Gauss-Markov, exp-cosine envelope) and period [s] (exp-cosine).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Term {
    pub kind: Kind,
    pub var: f64,
    pub tc: f64,
    pub period: f64,
}

impl Term {
    pub fn new(kind: Kind, tc: f64, period: f64) -> Self {
        Self {
            kind,
            var: 0.0,
            tc,
            period,
        }
    }

    /// The theory module's component with amplitude `var`.
    pub fn component_with(&self, var: f64) -> NoiseComponent {
        let a = var.max(0.0).sqrt();
        match self.kind {
            // The theory module has no filtered white: its long-τ equivalent.
            Kind::White | Kind::FilteredWhite => NoiseComponent::White { n: a },
            Kind::GaussMarkov => NoiseComponent::GaussMarkov {
                sigma: a,
                tc: self.tc,
            },
            Kind::ExpCosine => NoiseComponent::ExpCosine {
                sigma: a,
                alpha: 1.0 / self.tc,
                beta: 2.0 * PI / self.period,
            },
            Kind::RandomWalk => NoiseComponent::RandomWalk { k: a },
            Kind::Quantization => NoiseComponent::Quantization { q: a },
        }
    }

    pub fn component(&self) -> NoiseComponent {
        self.component_with(self.var)
    }

    /// Expected overlapping AVAR of the sampled term at cluster `m`.
    pub fn avar(&self, m: usize, dt: f64) -> f64 {
        self.avar_with(self.var, m, dt)
    }

    fn avar_with(&self, var: f64, m: usize, dt: f64) -> f64 {
        match self.kind {
            Kind::FilteredWhite => avar_filtered_white(var, self.tc, m, dt),
            _ => avar_at(&self.component_with(var), m, dt),
        }
    }

    /// Does the term have a shape parameter (`ln tc`) the outer search moves?
    pub(crate) fn has_shape(&self) -> bool {
        matches!(
            self.kind,
            Kind::GaussMarkov | Kind::ExpCosine | Kind::FilteredWhite
        )
    }
}

/// Theoretical Allan variance of one component at cluster `m`: the exact expectation of the
/// overlapping estimator for the point-sampled process.
///
/// White, random walk and quantisation have O(1) closed forms in the theory module. For
/// Gauss-Markov and exp-cosine, γ(h) = σ²(1 − Re zʰ) with `z = e^{(−α + iβ)Δt}`, and the
/// semivariogram sum of `theory` (weights w(h), Σw = −m) becomes
/// `E σ̂²(m) = σ² (m + Re S) / m²` with
/// `S = Σ_{h<2m} w(h) zʰ = 4m A(m) − 4 B(m) − 2m A(2m−1) + B(2m−1)` and the geometric sums `A(n) = Σ_{h≤n} zʰ = z(1 − zⁿ)/(1 − z)` and
/// `B(n) = Σ_{h≤n} h zʰ = z(1 − (n+1)zⁿ + n zⁿ⁺¹)/(1 − z)²`. That is O(1) per τ where the
/// O(m) sum would dominate the fit. It cancels when `1 − z` is small, so it is used only for
/// `m >` [`SAMPLED_MAX`] and `|1 − z| ≥ 0.01`; below that the direct sum, and for
/// `|1 − z| < 0.01` (correlation time > 100 samples) at large m the continuous curve,
/// which differs from the sampled one by O((Δt/τ)²).
pub fn avar_at(c: &NoiseComponent, m: usize, dt: f64) -> f64 {
    let (sigma, lnz) = match *c {
        NoiseComponent::GaussMarkov { sigma, tc } => (sigma, Complex::new(-dt / tc, 0.0)),
        NoiseComponent::ExpCosine { sigma, alpha, beta } => {
            (sigma, Complex::new(-alpha * dt, beta * dt))
        }
        _ => return c.avar_sampled(m, dt),
    };
    if m <= SAMPLED_MAX {
        return c.avar_sampled(m, dt);
    }
    let z = lnz.exp();
    // 1 − z without cancellation: e^{a+ib} − 1 = expm1(a) cos b − 2 sin²(b/2) + i e^a sin b.
    let (ea, hb) = (lnz.re.exp_m1(), (0.5 * lnz.im).sin());
    let omz = -Complex::new(ea * lnz.im.cos() - 2.0 * hb * hb, (ea + 1.0) * lnz.im.sin());
    if omz.norm() < 0.01 {
        return c.avar(m as f64 * dt);
    }
    let a = |n: usize| z * (Complex::new(1.0, 0.0) - (lnz * n as f64).exp()) / omz;
    let b = |n: usize| {
        let nf = n as f64;
        let zn = (lnz * nf).exp();
        z * (Complex::new(1.0, 0.0) - (nf + 1.0) * zn + nf * zn * z) / (omz * omz)
    };
    let mf = m as f64;
    let s = 4.0 * mf * a(m) - 4.0 * b(m) - 2.0 * mf * a(2 * m - 1) + b(2 * m - 1);
    sigma * sigma * (mf + s.re) / (mf * mf)
}

/// Filtered white noise: the ACF of white noise averaged over a window T_w, a triangle
/// `K(t) ∝ (1 − |t|/T_w)₊`, sampled every Δt and scaled so that `Δt Σ_h K(hΔt) = N²`: for
/// τ ≫ T_w it is exactly white noise of density N (`var` = N²), which is how it is written
/// to the model TOML. With the semivariogram sum of the theory module (Σw = −m),
/// `E σ̂²(m) = (m K₀ + Σ_{1≤h<2m} w(h) K_h) / m²`; only `h < T_w/Δt` contribute. T_w is held
/// in [Δt/2, 64Δt] (a longer window is a Gauss-Markov's job).
pub fn avar_filtered_white(var: f64, tw: f64, m: usize, dt: f64) -> f64 {
    if m == 0 || dt.is_nan() || dt <= 0.0 {
        return f64::NAN;
    }
    let tw = tw.clamp(0.5 * dt, 64.0 * dt);
    let k = |h: usize| (1.0 - h as f64 * dt / tw).max(0.0);
    let hw = (tw / dt).ceil() as usize;
    let norm = dt * (1.0 + 2.0 * (1..=hw).map(k).sum::<f64>());
    let mf = m as f64;
    let mut acc = mf;
    for h in 1..(2 * m).min(hw + 1) {
        let w = if h <= m {
            2.0 * mf - 3.0 * h as f64
        } else {
            -(2.0 * mf - h as f64)
        };
        acc += w * k(h);
    }
    var / norm * acc / (mf * mf)
}

/// One ADEV point as the fit sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub m: usize,
    pub ln_adev: f64,
    /// Standard deviation of `ln adev`.
    pub s: f64,
}

/// The fit points of an ADEV table: rows with a finite, positive interval.
pub fn points(rows: &[AdevRow]) -> Vec<Point> {
    rows.iter()
        .filter(|r| r.adev > 0.0 && r.ci_lo > 0.0 && r.ci_hi.is_finite() && r.ci_hi > r.ci_lo)
        .map(|r| Point {
            m: r.m,
            ln_adev: r.adev.ln(),
            s: (r.ci_hi.ln() - r.ci_lo.ln()) / (2.0 * Z95),
        })
        .collect()
}

/// The problem: points, sample period and the admissible range of correlation times.
pub struct Problem<'a> {
    pub pts: &'a [Point],
    pub dt: f64,
    /// `[ln tc_min, ln tc_max]`: a tenth of a sample to ten record lengths.
    pub ln_tc: (f64, f64),
}

impl Problem<'_> {
    /// Unit-amplitude curves of each term at each point.
    fn unit_matrix(&self, terms: &[Term]) -> DMatrix<f64> {
        DMatrix::from_fn(self.pts.len(), terms.len(), |k, j| {
            terms[j].avar_with(1.0, self.pts[k].m, self.dt)
        })
    }

    /// χ² of log-ADEV for the given terms (amplitudes included). `inf` if the model is 0.
    pub fn chi2(&self, terms: &[Term]) -> f64 {
        self.pts
            .iter()
            .map(|p| {
                let a: f64 = terms.iter().map(|t| t.avar(p.m, self.dt)).sum();
                if a > 0.0 && a.is_finite() {
                    ((0.5 * a.ln() - p.ln_adev) / p.s).powi(2)
                } else {
                    f64::INFINITY
                }
            })
            .sum()
    }

    /// Non-negative amplitudes for fixed shapes, weighted in AVAR space (row weight
    /// `1/(2 avar_k s_k)`, the linearised log-ADEV residual), by Lawson-Hanson NNLS on
    /// unit-norm columns. Returns the exact log-ADEV χ² of the result.
    pub fn amplitudes(&self, terms: &mut [Term]) -> f64 {
        let u = self.unit_matrix(terms);
        let n = terms.len();
        let rows = self.pts.len();
        let mut a = DMatrix::from_fn(rows, n, |k, j| {
            u[(k, j)] / (2.0 * (2.0 * self.pts[k].ln_adev).exp() * self.pts[k].s)
        });
        let b = DVector::from_iterator(rows, self.pts.iter().map(|p| 0.5 / p.s));
        let norms: Vec<f64> = (0..n).map(|j| a.column(j).norm()).collect();
        for (j, &nj) in norms.iter().enumerate() {
            if nj > 0.0 && nj.is_finite() {
                a.column_mut(j).unscale_mut(nj);
            }
        }
        let x = nnls(&a, &b);
        for (j, t) in terms.iter_mut().enumerate() {
            let nj = norms[j];
            t.var = if nj > 0.0 && nj.is_finite() {
                x[j] / nj
            } else {
                0.0
            };
        }
        self.pts
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let m: f64 = (0..n).map(|j| u[(k, j)] * terms[j].var).sum();
                if m > 0.0 && m.is_finite() {
                    ((0.5 * m.ln() - p.ln_adev) / p.s).powi(2)
                } else {
                    f64::INFINITY
                }
            })
            .sum()
    }

    /// Moves the shapes of `terms` by Nelder-Mead from their current values; amplitudes by
    /// [`Self::amplitudes`] at every step. Returns χ².
    pub fn fit(&self, terms: &mut [Term]) -> f64 {
        let x0: Vec<f64> = terms
            .iter()
            .filter(|t| t.has_shape())
            .map(|t| t.tc.ln())
            .collect();
        if x0.is_empty() {
            return self.amplitudes(terms);
        }
        let cost = ShapeCost {
            prob: self,
            base: terms.to_vec(),
        };
        let mut simplex = vec![x0.clone()];
        for i in 0..x0.len() {
            let mut v = x0.clone();
            v[i] += 0.7;
            simplex.push(v);
        }
        let iters = 80 * x0.len() as u64;
        let best = NelderMead::new(simplex)
            .with_sd_tolerance(1e-4)
            .ok()
            .and_then(|s| {
                Executor::new(cost, s)
                    .configure(|st| st.max_iters(iters))
                    .run()
                    .ok()
            })
            .and_then(|r| r.state.get_best_param().cloned())
            .unwrap_or(x0);
        set_shapes(terms, &best);
        self.amplitudes(terms)
    }
}

/// Lawson & Hanson (1974) NNLS, `min |A x − b|` subject to `x ≥ 0`; the sub-problems are
/// solved by SVD so that nearly collinear columns (a very short Gauss-Markov next to white
/// noise) do not break it.
fn nnls(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let n = a.ncols();
    let mut x = DVector::zeros(n);
    let mut passive = vec![false; n];
    let solve = |passive: &[bool]| -> DVector<f64> {
        let cols: Vec<usize> = (0..n).filter(|&j| passive[j]).collect();
        let sub = DMatrix::from_fn(a.nrows(), cols.len(), |k, c| a[(k, cols[c])]);
        let mut z = DVector::zeros(n);
        if let Ok(s) = sub.svd(true, true).solve(b, 1e-12) {
            for (c, &j) in cols.iter().enumerate() {
                z[j] = s[c];
            }
        }
        z
    };
    for _ in 0..3 * n + 3 {
        let w = a.transpose() * (b - a * &x);
        let tol = 1e-10 * w.amax().max(1e-300);
        let Some(j) = (0..n)
            .filter(|&j| !passive[j] && w[j] > tol)
            .max_by(|&p, &q| w[p].total_cmp(&w[q]))
        else {
            break;
        };
        passive[j] = true;
        for _ in 0..3 * n + 3 {
            let z = solve(&passive);
            if (0..n).all(|j| !passive[j] || z[j] > 0.0) {
                x = z;
                break;
            }
            // Step towards z as far as feasibility allows, then free the zeroed variables.
            let mut step = 1.0_f64;
            for j in (0..n).filter(|&j| passive[j] && z[j] <= 0.0) {
                let d = x[j] - z[j];
                if d > 0.0 {
                    step = step.min(x[j] / d);
                }
            }
            x += (z - &x) * step;
            for j in 0..n {
                if passive[j] && x[j] <= 1e-15 * x.amax().max(1e-300) {
                    passive[j] = false;
                    x[j] = 0.0;
                }
            }
        }
    }
    x
}

fn set_shapes(terms: &mut [Term], x: &[f64]) {
    let mut it = x.iter();
    for t in terms.iter_mut().filter(|t| t.has_shape()) {
        if let Some(v) = it.next() {
            t.tc = v.exp();
        }
    }
}

struct ShapeCost<'a> {
    prob: &'a Problem<'a>,
    base: Vec<Term>,
}

impl CostFunction for ShapeCost<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, x: &Vec<f64>) -> Result<f64, Error> {
        let (lo, hi) = self.prob.ln_tc;
        if x.iter().any(|v| !(*v >= lo && *v <= hi)) {
            return Ok(f64::INFINITY);
        }
        let mut t = self.base.clone();
        set_shapes(&mut t, x);
        Ok(self.prob.amplitudes(&mut t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form_matches_the_semivariogram_sum() {
        use crate::allan::theory::avar_from_semivariogram;
        let dt = 0.01;
        let comps = [
            NoiseComponent::GaussMarkov {
                sigma: 0.3,
                tc: 0.004,
            },
            NoiseComponent::GaussMarkov {
                sigma: 0.3,
                tc: 0.5,
            },
            NoiseComponent::ExpCosine {
                sigma: 0.2,
                alpha: 3.0,
                beta: 125.0,
            },
            NoiseComponent::ExpCosine {
                sigma: 0.2,
                alpha: 0.1,
                beta: 14.0,
            },
        ];
        for c in comps {
            for m in [65, 100, 777, 4096] {
                let fast = avar_at(&c, m, dt);
                let slow = avar_from_semivariogram(m, |h| c.semivariogram_sampled(h, dt));
                assert!(
                    ((fast - slow) / slow).abs() < 1e-9,
                    "{c:?} m={m}: {fast} {slow}"
                );
            }
        }
    }

    #[test]
    fn filtered_white_is_white_at_long_tau_and_matches_its_semivariogram() {
        use crate::allan::theory::avar_from_semivariogram;
        let (dt, tw, n2) = (0.01, 0.012, 4e-4);
        // K_h from the definition, then the theory module's O(m) sum.
        let k = |h: usize| (1.0 - h as f64 * dt / tw).max(0.0);
        let norm = dt * (1.0 + 2.0 * k(1));
        let kh = |h: usize| n2 / norm * k(h);
        for m in [1, 2, 3, 10, 1000] {
            let ours = avar_filtered_white(n2, tw, m, dt);
            let sum = avar_from_semivariogram(m, |h| kh(0) - kh(h));
            assert!(((ours - sum) / sum).abs() < 1e-12, "m={m}");
        }
        let m = 100_000;
        let white = n2 / (m as f64 * dt);
        assert!((avar_filtered_white(n2, tw, m, dt) / white - 1.0).abs() < 1e-4);
    }

    /// Points of an exact theoretical curve with 1 % log-sd: the fit must recover it.
    #[test]
    fn recovers_white_plus_gauss_markov() {
        let dt = 0.01;
        let truth = [
            NoiseComponent::White { n: 0.02 },
            NoiseComponent::GaussMarkov {
                sigma: 0.01,
                tc: 30.0,
            },
        ];
        let pts: Vec<Point> = (0..18)
            .map(|i| {
                let m = 1usize << i;
                let a: f64 = truth.iter().map(|c| avar_at(c, m, dt)).sum();
                Point {
                    m,
                    ln_adev: 0.5 * a.ln(),
                    s: 0.01,
                }
            })
            .collect();
        let prob = Problem {
            pts: &pts,
            dt,
            ln_tc: ((0.1 * dt).ln(), 1e5_f64.ln()),
        };
        let sel = crate::identify::select::select(&prob, None);
        assert!(sel.chi2 < 1e-3, "chi2 {}", sel.chi2);
        let gm = sel
            .terms
            .iter()
            .find(|t| t.kind == Kind::GaussMarkov)
            .expect("a Gauss-Markov term");
        assert!((gm.tc / 30.0 - 1.0).abs() < 0.02, "tc {}", gm.tc);
        assert!((gm.var.sqrt() / 0.01 - 1.0).abs() < 0.02);
    }
}
