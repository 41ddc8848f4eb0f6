//! The move at a decision ([`super`] module docs): for each coordinate, a parabola through
//! the window's summed log-likelihoods of its shadows at `-d`, `0`, `+d`.
//!
//! The coordinates move together, except the quantities of one component: a Gauss-Markov
//! `sigma` and `tau` both lower `sigma^2 / tau` (what short windows see), so two parabolas
//! that each reach the vertex alone overshoot it twice over together. Such a pair has a
//! shadow at `(+d, +d)` too, which gives the cross curvature
//! `c_ij = -(S(+,+) - S(+,0) - S(0,+) + S(0,0)) / d^2`, and moves by the 2x2 Newton step when
//! that curvature matrix is positive definite; otherwise only its move that promises most is
//! taken.
//!
//! With [`OnlineConfig::flat_waits`] (the default) a coordinate whose parabola is not concave
//! does not move while a coordinate whose parabola is concave steps out of the grid (more
//! than `d`). Each coordinate's slope is measured with the others at the centre, and where
//! several noise sources explain the same excess innovation variance (a model far too quiet:
//! gyro and accelerometer white noise, their random walks and the fixes' variance on the real
//! drive) every one of them rises; the bounded ones step to their vertices, and the flat ones,
//! `2 d` up their slopes besides, overshot the joint maximum to the bound (the drive's
//! accelerometer random walk went +2 decades where the offline fit puts it at -2). They are
//! measured again at the next decision, about the moved centre: coordinate ascent by blocks.
//! Only a move out of the grid holds them: the steps inside it are the settling of a bounded
//! coordinate, and a flat one held by those would never move (tried: a MEMS run from 0.1x
//! kept its white noise 10x too small, 19 % of epochs outside 3 sigma).
//!
//! A flat coordinate steps `2 d` up its slope only on evidence: its shadow on that side must
//! have measured [`FLAT_EVIDENCE`] nats over the centre, `|g| d - c d^2 / 2` (a
//! likelihood-ratio test at 5 %). The parabola's promise at `2 d`, `2 |g| d - 2 c d^2`, grows
//! with the parabola's convexity, which is the window's noise and not a maximum: on a tactical
//! run from 0.1x a flat gyro Gauss-Markov tau stepped 1 decade down on that promise and ended
//! 0.75 decade low, with the attitude at 1.45x the true-model filter where the data's ML
//! reference is at 1.05x (BENCHMARKS.md "A flat coordinate moves on evidence"). On the first
//! window after a bounded coordinate left the grid (the decision's [`Marks::left`]) the test
//! asks [`AFTER_A_LEAVE`], twice as much: that window holds one interval, and every shadow
//! was retuned at its start.
//!
//! With [`OnlineConfig::exit_z`] (2 by default) a bounded coordinate leaves the grid only when
//! its step, the vertex limited to `2 d`, is beyond the edge by `exit_z` Cramér-Rao sds;
//! otherwise it stops at the edge. A vertex past `2 d` counts as `2 d`: on that test alone a
//! coordinate leaves only where `d >= exit_z sd`. Testing the vertex itself (and, separately,
//! a vertex 4 sds past the edge) freed the correlation times held short from a start at 0.1x,
//! and passed no more runs (BENCHMARKS.md "Correlation times wrong at the start"): a single
//! 10-min window's vertex left on noise. So the vertex counts only when it persists: a
//! coordinate stopped at the edge while its vertex is `exit_z` sds past it is *pressed*, and
//! pressed at two decisions in a row (the caller keeps the record) its limited step leaves.
//! With the offset halved by the settled sigmas a correlation time otherwise crept `d` per
//! decision toward a vertex a decade away (BENCHMARKS.md "Pressed on the edge at two
//! decisions").
//! Without it the vertex's noise on a 10-min window (0.1-0.2 decade) was larger than the
//! settled offset, so nearly every decision left the grid and restarted the window, which
//! then never grew to lower that noise ([`settled_off_centre`] is its counterpart inside
//! the grid). A pair's Newton step is optimal only jointly, so when the exit test stops one
//! of its quantities at the edge, the other moves to the quadratic model's maximum given that
//! one, `s_n = (g_n - c_nm s_m) / c_nn`, and takes the exit test in turn, on the sd of that
//! move, `1 / sqrt(c_nn)` (the marginal sd is that of a move along the ridge). Its share of the
//! joint step overshot along the ridge `sigma^2 / tau` = const: on a tactical run from 0.1x
//! the gyro's Gauss-Markov tau stayed at the edge for an hour while its sigma, moving by its
//! share, reached 0.95 decade over the truth with a Cramér-Rao sd of 0.07 (attitude 1.51x the
//! true-model filter; 1.04x with the conditional step).
//!
//! With [`OnlineConfig::hold_flat_taus`] a correlation time the data do not bound is held
//! (issue 13: a flat direction is flagged, not left to wander): in a pair whose tau has a
//! marginal Cramér-Rao sd (from the inverse of the 2x2 curvature matrix) above
//! [`IDENTIFIABLE_SD`], or whose curvature matrix is not positive definite, the tau stays
//! and the sigma takes its own parabola's step. Along the ridge `sigma^2 / tau` = const that
//! short windows leave, tau otherwise drifted to the bound (seed 9701, tactical: +1.96
//! decades, attitude 1.59x the true-model filter).

use super::coords::{Coordinate, MAX_COORDS, MAX_PARAMS};
use super::{OnlineConfig, IDENTIFIABLE_SD};
use crate::model::Quantity;
use heapless::Vec;

/// The likelihood gain [nats] that the shadow up a flat coordinate's slope must have measured
/// over the centre before the coordinate steps `2 d` that way (module docs): half the 95 %
/// point of the chi-square distribution with one degree of freedom (3.84), a likelihood-ratio
/// test at 5 % that the shadow's model beats the centre's. The parabola's extrapolation to
/// `2 d`, which a convex parabola inflates, is not evidence.
pub(super) const FLAT_EVIDENCE: f64 = 1.92;

/// The evidence [nats] a flat coordinate's shadow must have measured at the first decision
/// after a bounded coordinate left the grid (module docs): twice [`FLAT_EVIDENCE`], half the
/// chi-square point at 0.56 % (7.68). That window holds one interval and starts where every
/// shadow was retuned about the moved centre; on MEMS 64902 from sds 10x with taus 0.1x a flat
/// accelerometer white noise stepped a decade up on such a window, under this evidence, and
/// the run ended at 2.74x the true-model filter's horizontal error (1.15x with this test;
/// BENCHMARKS.md "A flat coordinate after a leave").
pub(super) const AFTER_A_LEAVE: f64 = 2.0 * FLAT_EVIDENCE;

/// The pairs of coordinates that are quantities of one component (on the same axes).
pub(super) fn pairs(coords: &[Coordinate]) -> Vec<(usize, usize), MAX_COORDS> {
    let mut out = Vec::new();
    for (i, a) in coords.iter().enumerate() {
        for (j, b) in coords.iter().enumerate().skip(i + 1) {
            if a.sensor == b.sensor && a.axis == b.axis && a.component == b.component {
                // Cannot overflow: with `beta` held a component has at most two identified
                // quantities, so the pairs are disjoint, at most MAX_COORDS / 2 of them.
                let _ = out.push((i, j));
            }
        }
    }
    out
}

/// What a decision marks besides its step: each coordinate's Cramér-Rao sd and whether it is
/// pressed on the grid's edge, and whether a bounded coordinate left the grid (`step`; the
/// record of the previous decision goes in).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Marks {
    pub cr_sd: [f64; MAX_PARAMS],
    pub pressed: [bool; MAX_PARAMS],
    /// A bounded coordinate left the grid: the window restarted, and at the next decision it
    /// holds one interval ([`AFTER_A_LEAVE`]).
    pub left: bool,
}

impl Marks {
    /// Before the first decision: no interval, nothing pressed, nothing left.
    pub const NONE: Self = Self {
        cr_sd: [f64::INFINITY; MAX_PARAMS],
        pressed: [false; MAX_PARAMS],
        left: false,
    };
}

/// A quadratic model of a summed log-likelihood about the current point: gradient `g`
/// [nats/decade], curvatures `c` (positive where concave) [nats/decade^2] and the cross
/// curvature `cx` of each pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Quad {
    pub g: [f64; MAX_PARAMS],
    pub c: [f64; MAX_PARAMS],
    pub cx: [f64; MAX_COORDS],
    /// The shadows' offset [decades] at which it was measured.
    pub d: f64,
}

impl Quad {
    /// No information.
    pub const ZERO: Self = Self {
        g: [0.0; MAX_PARAMS],
        c: [0.0; MAX_PARAMS],
        cx: [0.0; MAX_COORDS],
        d: 0.0,
    };

    /// The model of the shadows' window sums `sums` (shadow `2i` at `+d`, `2i + 1` at `-d` on
    /// coordinate `i`, `2p` the centre, `2p + 1 + q` pair `q` at `(+d, +d)`).
    pub fn from_sums<const M: usize>(
        d: f64,
        p: usize,
        pairs: &[(usize, usize)],
        sums: &[f64; M],
    ) -> Self {
        let sum = |k: usize| sums.get(k).copied().unwrap_or(f64::NAN);
        let centre = sum(2 * p);
        let mut q = Self { d, ..Self::ZERO };
        for (i, (g, c)) in q.g.iter_mut().zip(q.c.iter_mut()).enumerate().take(p) {
            let (plus, minus) = (sum(2 * i), sum(2 * i + 1));
            *g = (plus - minus) / (2.0 * d);
            *c = -(plus + minus - 2.0 * centre) / (d * d);
        }
        for (k, (&(i, j), cx)) in pairs.iter().zip(q.cx.iter_mut()).enumerate() {
            let both = sum(2 * p + 1 + k);
            *cx = -(both - sum(2 * i) - sum(2 * j) + centre) / (d * d);
        }
        q
    }
}

/// The step of the `p` coordinates at `x` from the quadratic model `q` measured at the offset
/// `d = q.d` (`coords` the IMU's,
/// the first ones; the rest, the GNSS factors, are intensities of no pair): each to its
/// parabola's vertex when it is concave, at most `2 d` away (a pattern search's extension), or
/// `2 d` up the slope when it is not and its shadow on that side measured [`FLAT_EVIDENCE`]
/// nats over the centre ([`AFTER_A_LEAVE`] when `marks.left`: a bounded coordinate left the
/// grid at the last decision); only when that promises [`OnlineConfig::min_gain`] nats;
/// within [`OnlineConfig::bound`] of the start; the pairs by their 2x2 Newton step (module
/// docs), with [`OnlineConfig::hold_flat_taus`] a flat pair's tau held; with the exit test,
/// a coordinate pressed on the edge at this decision and the last (`marks.pressed` holds the
/// last's) by its limited step. Writes each coordinate's Cramér-Rao sd into `marks.cr_sd`:
/// `1 / sqrt(c)` (with the option, the marginal sd for a pair with a positive definite
/// curvature matrix), infinite where not concave; whether it is pressed now into
/// `marks.pressed`; and whether a bounded coordinate leaves the grid now into `marks.left`.
pub(super) fn step(
    cfg: &OnlineConfig,
    p: usize,
    coords: &[Coordinate],
    pairs: &[(usize, usize)],
    q: &Quad,
    x: &[f64; MAX_PARAMS],
    marks: &mut Marks,
) -> [f64; MAX_PARAMS] {
    // Whether each coordinate was pressed at the previous decision (the caller's record), and
    // the evidence a flat coordinate needs: more when a bounded one left the grid at it.
    let before = marks.pressed;
    let evidence = if marks.left {
        AFTER_A_LEAVE
    } else {
        FLAT_EVIDENCE
    };
    let Marks {
        cr_sd,
        pressed,
        left,
    } = marks;
    *pressed = [false; MAX_PARAMS];
    let (p, d) = (p.min(MAX_PARAMS), q.d);
    let is_tau = |i: usize| coords.get(i).is_some_and(|c| c.quantity == Quantity::Tau);
    *cr_sd = [f64::INFINITY; MAX_PARAMS];
    let at = |a: &[f64], i: usize| a.get(i).copied().unwrap_or(0.0);
    let mut out = [0.0; MAX_PARAMS];
    // Each step before its `2 d` limit: the vertex. A GNSS factor's (the variance model's
    // maximum) is left at 0, so it is never pressed: its sd (0.01 decade) is far under the
    // smallest offset, and its limited step passes the exit test wherever the vertex would.
    let mut vertex = [0.0; MAX_PARAMS];
    let mut gains = [0.0; MAX_PARAMS];
    // The coordinates the window bounds: a concave parabola, or a variance factor's model
    // ([`OnlineConfig::flat_waits`]).
    let mut bounded = [false; MAX_PARAMS];
    let clamp = |s: f64, i: usize| {
        let xi = at(x, i);
        within(s, -cfg.bound - xi, cfg.bound - xi)
    };
    for i in 0..p {
        let (g, c) = (at(&q.g, i), at(&q.c, i));
        // A factor on the fixes' standard deviations: the variance-scale model's maximum
        // when the shadows fit it (`variance_scale`), else the parabola's as any coordinate.
        if i >= coords.len() {
            if let Some((s, gain, sd)) = variance_scale(g, c, d) {
                if let (Some(v), Some(bd)) = (cr_sd.get_mut(i), bounded.get_mut(i)) {
                    *v = sd;
                    *bd = true;
                }
                if gain >= cfg.min_gain {
                    if let (Some(o), Some(gv)) = (out.get_mut(i), gains.get_mut(i)) {
                        *o = clamp(s, i);
                        *gv = gain;
                    }
                }
                continue;
            }
        }
        if let Some(b) = bounded.get_mut(i) {
            *b = c > 0.0;
        }
        let s = if c > 0.0 {
            g / c
        } else if g >= 0.0 {
            2.0 * d
        } else {
            -2.0 * d
        };
        if let Some(v) = vertex.get_mut(i) {
            *v = s;
        }
        let s = within(s, -2.0 * d, 2.0 * d);
        // A concave coordinate: the parabola's promise at its step. A flat one: what its
        // shadow up the slope measured over the centre (`shadow_gains`, module docs),
        // which must pass the likelihood-ratio test [`FLAT_EVIDENCE`] as well.
        let gain = if c > 0.0 {
            g * s - 0.5 * c * s * s
        } else {
            let (up, down) = shadow_gains(g, c, d);
            let measured = if g >= 0.0 { up } else { down };
            if measured >= evidence {
                measured
            } else {
                f64::NEG_INFINITY
            }
        };
        if let Some(sd) = cr_sd.get_mut(i) {
            *sd = if c > 0.0 {
                1.0 / libm::sqrt(c)
            } else {
                f64::INFINITY
            };
        }
        if s.is_finite() && gain.is_finite() && gain >= cfg.min_gain {
            if let (Some(o), Some(gv)) = (out.get_mut(i), gains.get_mut(i)) {
                *o = clamp(s, i);
                *gv = gain;
            }
        }
    }
    // The sds of the exit test (`exit_z`): each coordinate's own, and a pair's marginal ones
    // where its curvature matrix is positive definite.
    let mut exit_sd = *cr_sd;
    // Whether each pair's curvature matrix is positive definite (its quadratic has a maximum).
    let mut pair_pd = [false; MAX_COORDS];
    // The pairs: the 2x2 Newton step when the curvature matrix is positive definite, else
    // the one move that promises most; with `hold_flat_taus`, a tau the data do not bound
    // held and its partner by its own step.
    for (k, &(i, j)) in pairs.iter().enumerate() {
        let (gi, gj) = (at(&q.g, i), at(&q.g, j));
        let (cii, cjj, cij) = (at(&q.c, i), at(&q.c, j), at(&q.cx, k));
        let det = cii * cjj - cij * cij;
        let pd = cii > 0.0 && det > 0.0 && det.is_finite();
        if let Some(v) = pair_pd.get_mut(k) {
            *v = pd;
        }
        let (sd_i, sd_j) = if pd {
            (libm::sqrt(cjj / det), libm::sqrt(cii / det))
        } else {
            (f64::INFINITY, f64::INFINITY)
        };
        if pd {
            for (m, sd) in [(i, sd_i), (j, sd_j)] {
                if let Some(v) = exit_sd.get_mut(m) {
                    *v = sd;
                }
            }
        }
        // The marginal sds are reported with the option; without it each coordinate keeps its
        // own parabola's (the conservative running model's raise was measured with those).
        if pd && cfg.hold_flat_taus {
            for (m, sd) in [(i, sd_i), (j, sd_j)] {
                if let Some(v) = cr_sd.get_mut(m) {
                    *v = sd;
                }
            }
        }
        // A tau of the pair that the data do not bound: held, the other by its own step.
        let flat = [(i, sd_i), (j, sd_j)].into_iter().find(|&(m, sd)| {
            cfg.hold_flat_taus && is_tau(m) && (sd.is_nan() || sd > IDENTIFIABLE_SD)
        });
        if let Some((tau, _)) = flat {
            if let Some(o) = out.get_mut(tau) {
                *o = 0.0;
            }
        } else if pd {
            let (mut si, mut sj) = ((cjj * gi - cij * gj) / det, (cii * gj - cij * gi) / det);
            for (m, sm) in [(i, si), (j, sj)] {
                if let Some(v) = vertex.get_mut(m) {
                    *v = sm;
                }
            }
            let big = libm::fabs(si).max(libm::fabs(sj));
            if big > 2.0 * d {
                si *= 2.0 * d / big;
                sj *= 2.0 * d / big;
            }
            let gain =
                gi * si + gj * sj - 0.5 * (cii * si * si + 2.0 * cij * si * sj + cjj * sj * sj);
            let ok = gain.is_finite() && gain >= cfg.min_gain;
            for (m, sm) in [(i, si), (j, sj)] {
                let v = if ok && sm.is_finite() {
                    clamp(sm, m)
                } else {
                    0.0
                };
                if let Some(o) = out.get_mut(m) {
                    *o = v;
                }
            }
        } else {
            let drop = if at(&gains, j) > at(&gains, i) { i } else { j };
            if let Some(o) = out.get_mut(drop) {
                *o = 0.0;
            }
        }
    }
    // A bounded coordinate leaves the grid only when its step (the vertex limited to `2 d`)
    // is beyond the edge by `exit_z` Cramér-Rao sds (the pair's marginal sds where its
    // curvature matrix is positive definite); otherwise it stops at the edge.
    if cfg.exit_z > 0.0 {
        let mut stopped = [false; MAX_PARAMS];
        for (i, (((o, b), s), st)) in out
            .iter_mut()
            .zip(bounded.iter())
            .zip(exit_sd.iter())
            .zip(stopped.iter_mut())
            .enumerate()
        {
            let limited = *o;
            (*o, *st) = exit_test(cfg, d, limited, *b, *s);
            // Pressed: stopped at the edge while the vertex itself is `exit_z` sds past it.
            let v = vertex.get(i).copied().unwrap_or(0.0);
            let press = *st && v * limited > 0.0 && libm::fabs(v) - d >= cfg.exit_z * *s;
            if let Some(p) = pressed.get_mut(i) {
                *p = press;
            }
            // Pressed at two decisions in a row: the limited step leaves.
            if press && before.get(i).copied().unwrap_or(false) {
                (*o, *st) = (limited, false);
            }
        }
        // A pair's Newton step is optimal only jointly: with one of its quantities stopped
        // at the edge, the other takes the quadratic model's maximum given that one, not its
        // share of the joint step (module docs; BENCHMARKS.md "A pair's step with one
        // quantity at the edge"). That move is along its own coordinate, so its exit test
        // takes its own curvature's sd, `1 / sqrt(c_nn)`, not the marginal one. It moves even
        // when the bound cut its share to nothing (a sigma at the bound, whose tau stopped at
        // the edge, would otherwise stay there: tactical 63805 from 0.1x, 1.49x). Only a pair
        // whose curvature matrix is positive definite has that maximum; with
        // `hold_flat_taus` a held tau stays held.
        for (k, &(i, j)) in pairs.iter().enumerate() {
            let is_stopped = |m: usize| stopped.get(m).copied().unwrap_or(false);
            let (m, n) = match (is_stopped(i), is_stopped(j)) {
                (true, false) => (i, j),
                (false, true) => (j, i),
                _ => continue,
            };
            // Positive definite: `c_nn > 0` as well.
            let pd = pair_pd.get(k).copied().unwrap_or(false);
            if !pd || (cfg.hold_flat_taus && is_tau(n)) {
                continue;
            }
            let (cnn, cnm) = (at(&q.c, n), at(&q.cx, k));
            let s = within((at(&q.g, n) - cnm * at(&out, m)) / cnn, -2.0 * d, 2.0 * d);
            let bn = bounded.get(n).copied().unwrap_or(false);
            let (s, _) = exit_test(cfg, d, clamp(s, n), bn, 1.0 / libm::sqrt(cnn));
            if let Some(o) = out.get_mut(n) {
                *o = if s.is_finite() { s } else { 0.0 };
            }
        }
    }
    // A bounded coordinate leaving the grid holds the flat ones (module docs).
    let leaves = |(o, b): (&f64, &bool)| *b && libm::fabs(*o) > d;
    *left = out.iter().zip(bounded.iter()).any(leaves);
    if cfg.flat_waits && *left {
        for (o, _) in out.iter_mut().zip(bounded.iter()).filter(|(_, b)| !**b) {
            *o = 0.0;
        }
    }
    out
}

/// With [`OnlineConfig::exit_z`]: whether the estimate `est`, inside the grid about `x`, has
/// settled off its centre, more than `d / 2` on a coordinate whose Cramér-Rao sd (`cr_sd`)
/// times `exit_z` is under `d / 2`, while `d` is above its smallest. The bank then measures
/// again about the estimate with half the offset ([`super::OnlineIdent::decide`]): a parabola
/// through shadows `d` away is biased where the likelihood is not quadratic over them (an
/// intensity's is not over a 10x variance), and with the exit test the estimate would
/// otherwise stay at that biased vertex, the window growing about it.
pub(super) fn settled_off_centre(
    cfg: &OnlineConfig,
    d: f64,
    p: usize,
    est: &[f64; MAX_PARAMS],
    x: &[f64; MAX_PARAMS],
    cr_sd: &[f64; MAX_PARAMS],
) -> bool {
    cfg.exit_z > 0.0
        && d > cfg.min_offset
        && est
            .iter()
            .zip(x.iter())
            .zip(cr_sd.iter())
            .take(p)
            .any(|((e, c), sd)| libm::fabs(e - c) > 0.5 * d && cfg.exit_z * sd < 0.5 * d)
}

/// The move of a factor on the variance of the observations, from its parabola's gradient `g`
/// and curvature `c` at offset `d` (which give back the shadows' differences from the centre,
/// `D+- = +-g d - c d^2 / 2`): `(step, gain, Cramér-Rao sd)`, or `None` when the shadows do not
/// fit the model.
///
/// When the fixes' noise dominates their innovation variance, `n` Gaussian innovations whose
/// variance is scaled by `10^(2u)` have the log-likelihood
/// `l(u) = l0 - n/2 (2 a u + K exp(-2 a u))` about the centre (`a = ln 10`, `K` their sum of
/// squares over the centre's variances, per observation): far from a parabola over the
/// shadows' half-decade offset (a 10x variance), whose vertex fell 0.1-0.4 decade off the
/// maximum (BENCHMARKS.md "The GNSS factors in the bank"). The two differences give `K` and
/// `n`, and the maximum is at `u* = ln K / (2 a)`, where the curvature is `2 n a^2`. The step
/// is at most `2 d`, as any coordinate's.
pub(super) fn variance_scale(g: f64, c: f64, d: f64) -> Option<(f64, f64, f64)> {
    let a = core::f64::consts::LN_10;
    let (dp, dm) = shadow_gains(g, c, d);
    let e = libm::exp(-2.0 * a * d);
    // D+ = -n/2 (2 a d + K (E - 1)),  D- = -n/2 (-2 a d + K (1/E - 1)).
    let den = dp * (1.0 / e - 1.0) - dm * (e - 1.0);
    let k = 2.0 * a * d * (dp + dm) / den;
    let n = -2.0 * dp / (2.0 * a * d + k * (e - 1.0));
    if !(k.is_finite() && k > 0.0 && n.is_finite() && n > 0.0) {
        return None;
    }
    let s = within(libm::log(k) / (2.0 * a), -2.0 * d, 2.0 * d);
    let gain = -0.5 * n * (2.0 * a * s + k * (libm::exp(-2.0 * a * s) - 1.0));
    let sd = 1.0 / (a * libm::sqrt(2.0 * n));
    (s.is_finite() && gain.is_finite()).then_some((s, gain, sd))
}

/// The window sums of a coordinate's shadows at `+d` and `-d` less the centre's, given back by
/// its parabola's gradient `g` and curvature `c`: `D+- = +-g d - c d^2 / 2`.
fn shadow_gains(g: f64, c: f64, d: f64) -> (f64, f64) {
    (g * d - 0.5 * c * d * d, -g * d - 0.5 * c * d * d)
}

/// The exit test ([`OnlineConfig::exit_z`]): the step `o` of a bounded coordinate that
/// leaves the grid (beyond `d`) by fewer than `exit_z` sds `sd` stops at the edge. Returns the
/// step and whether it stopped. A NaN sd is no evidence: the coordinate stops.
fn exit_test(cfg: &OnlineConfig, d: f64, o: f64, bounded: bool, sd: f64) -> (f64, bool) {
    let a = libm::fabs(o);
    let evident = a - d >= cfg.exit_z * sd;
    if bounded && a > d && !evident {
        (if o > 0.0 { d } else { -d }, true)
    } else {
        (o, false)
    }
}

/// `v` limited to `[lo, hi]` (`max` then `min`: unlike `f64::clamp`, no panic path when the
/// bounds are NaN or crossed, for the firmware's link-time no-panic proof).
fn within(v: f64, lo: f64, hi: f64) -> f64 {
    v.max(lo).min(hi)
}
