//! `hal-sim nav --diagnose`: which physical effect the navigator's noise model lacks, named by
//! the innovation likelihood of the GNSS fixes, added, and the run repeated with it.
//!
//! The one-channel `diagnose` (issue 4) cannot separate an accelerometer random constant, an
//! accelerometer random walk and a slow accelerometer Gauss-Markov from tilt; under the
//! manoeuvres of a strapdown INS/GNSS log they are separable (BENCHMARKS.md "The one-channel
//! blind spots under manoeuvres"), so here they are candidates like the others.
//!
//! Method (nested likelihood-ratio tests, one per candidate):
//! 1. `L0`: the total innovation log-likelihood of the fused fixes under the model as given
//!    ([`super::identify::loglik`]: the gate off, so that the likelihood is continuous in the
//!    parameters; withheld fixes are not in it).
//! 2. Candidates: the table of component kinds' sensor candidates ([`crate::candidates::LIBRARY`])
//!    on the gyros and the accelerometers, each added to the three axes of its sensor with
//!    one set of parameters (tied): a Gauss-Markov (sigma, tau), an exponential-cosine
//!    (sigma, tau, period: an oscillating error, a heater cycling), a random walk (q), a
//!    random constant (sigma). A kind the sensor already carries is left out, except a second
//!    Gauss-Markov (another time scale); so is a candidate that does not fit the filter's
//!    [`imu_ident::nav::NAV_N`] states (counted by the core, scale factors included). White
//!    noise is a magnitude, not a missing effect (`--identify` fits it). An exponential-cosine
//!    is offered only with at least half a period in its envelope, `beta tau >= pi`
//!    ([`offered`]); below that it is a Gauss-Markov of another shape.
//! 3. Each candidate's parameters maximise the likelihood: every start of the table
//!    ([`crate::candidates::Candidate::starts_at`], scaled to the sensor's magnitude in the
//!    model) is evaluated, and a pattern search ([`super::pattern`]) runs from the best, in
//!    natural-log steps 2, 1, 0.5, 0.25, within three decades of its start (correlation times
//!    and periods within [10 s, 1e5 s]).
//! 4. The test: with the model right, twice a candidate's gain `L1 - L0` is asymptotically at
//!    most chi-square(k) (Wilks; `k` its free parameters; the component's magnitude on its
//!    boundary at zero makes it a mixture with a point mass at zero, which only lowers the
//!    tail). With `m` candidates tested, a candidate is significant when its gain exceeds
//!    half the chi-square(k) `1 - ALPHA / m` quantile (Bonferroni): a right model is called
//!    inadequate in at most `ALPHA` of logs. The named effect is the significant candidate with
//!    the largest gain over its own threshold (so that a 2-parameter candidate must explain
//!    more than a 1-parameter one); but a simpler significant candidate of the same sensor
//!    that the winner contains as a limit is named instead unless the winner gains more than
//!    half the chi-square(dk) `1 - ALPHA` quantile over it (a Gauss-Markov whose correlation
//!    time runs past the log is a random walk: on 1 of 8 seeds with a hidden walk the
//!    Gauss-Markov led the walk by 1.8 nats, within the 3.3 nats of that test; an
//!    exponential-cosine of `beta -> 0` is a Gauss-Markov).
//! 5. Where the named effect sits ([`axes`]): its magnitude is untied over the three axes,
//!    the split tested against the tied fit (half the chi-square(2) `1 - ALPHA` quantile)
//!    and, when the axes differ, each axis tested for the effect; the diagnosed model carries
//!    it, split, on the axes that need it.
//! 6. The model with the named effect is run again (gated, as any run) and its outputs are the
//!    command's; `diagnosis.json` keeps the scores before and after.
//! 7. `--diagnose-axes`: every candidate is also fitted split ([`axes::fit_split`]: its
//!    magnitude per axis, two more parameters) and tested against the model at half the
//!    chi-square(k + 2) `1 - ALPHA / m` quantile, `m` now counting both forms of every
//!    candidate. A candidate counts in the form with the larger excess; a split form contains
//!    the tied one, and the nesting rule of item 4 applies between forms ([`Form::contains`]).
//!    A tied candidate that also lands on an axis without the effect can lose its gain there:
//!    a walk on one horizontal accelerometer, tied, is put on the vertical one too, where the
//!    heights reject it (BENCHMARKS.md "Which axis: the split of the named effect"). About
//!    three times the runs (the real drive, before the exponential-cosine candidates: 285
//!    against 88).
//!
//! Diagnose a model whose magnitudes are fitted: `--identify --diagnose` identifies them first
//! (or `--model identified-model.toml $(cat identified-options.txt) --diagnose` after an
//! identification). Otherwise a candidate can win by standing in for a white density that is
//! only too small: on the real drive the datasheet model "lacks" an accelerometer
//! Gauss-Markov of 17 mg over 16 s (a gain of 1.2e5 nats), and with it the error at the
//! outage ends rises from 7.0 to 25 m; the identified model is adequate (BENCHMARKS.md
//! "Naming a missing effect on the strapdown navigator").

mod axes;
mod record;

pub use axes::AxisSplit;
pub use record::{ComponentJson, Form, NavCandidate, NavDiagnosis, RunScores};

use super::identify::loglik;
use super::{run_with, NavArgs, NavRun};
use crate::candidates::{Candidate, LIBRARY};
use crate::nav_io::truth_csv::TruthRow;
use crate::nav_io::{self, GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::adapt::window::structure::MIN_QUALITY;
use imu_ident::model::{Component, ComponentKind, ErrorSource};
use imu_ident::nav::{
    ImuErrorModel, ImuSensor, NavInit, NavPoint, StrapdownErrorModel, NAV_N, NAV_Z,
};
use nalgebra::Vector3;
use std::path::Path;

/// Family-wise probability of calling a right model inadequate (item 4 of the module docs).
pub const ALPHA: f64 = 0.01;
/// Pattern-search steps [natural-log units].
const STEPS: [f64; 4] = [2.0, 1.0, 0.5, 0.25];
/// Half-width of a coordinate's interval about its start [natural-log units]: three decades.
const HALF_WIDTH: f64 = 6.907_755_278_982_137;
/// Interval of a correlation time [s].
const TAU_RANGE: (f64, f64) = (10.0, 1e5);

fn imu_sensor(s: ErrorSource) -> Option<ImuSensor> {
    match s {
        ErrorSource::Gyro => Some(ImuSensor::Gyro),
        ErrorSource::Accel => Some(ImuSensor::Accel),
        ErrorSource::Observation => None,
    }
}

/// The typical error magnitude of one sensor in `m`: the largest over its axes of the sum of
/// the components' magnitudes (the one-channel table's `sensor_scale`), with the same defaults
/// when it has none.
fn sensor_scale(m: &ImuErrorModel<f64>, s: ImuSensor) -> f64 {
    let v = m
        .sensor(s)
        .iter()
        .map(|a| a.iter().map(|c| c.magnitude()).sum::<f64>())
        .fold(0.0, f64::max);
    match s {
        _ if v > 0.0 && v.is_finite() => v,
        ImuSensor::Accel => 1e-3,
        ImuSensor::Gyro => 0.1f64.to_radians() / 3600.0,
    }
}

/// `m` with `c` on every axis of sensor `s`; `None` when an axis is full.
fn with_component(
    m: &ImuErrorModel<f64>,
    s: ImuSensor,
    c: Component<f64>,
) -> Option<ImuErrorModel<f64>> {
    axes::with_axes(m, s, &[Some(c); 3])
}

/// The filter's states for the noise model `imu` (the core's count: navigation errors, the
/// components, the scale factors of `--scale-factors`).
fn filter_states(imu: ImuErrorModel<f64>, scale_factor_sd: Option<[f64; 2]>) -> usize {
    StrapdownErrorModel {
        imu,
        init: NavInit {
            sd_att: Vector3::repeat(1.0),
            sd_vel: 1.0,
            sd_pos: 1.0,
        },
        lever_arm: Vector3::zeros(),
        obs_sd: [1.0; NAV_Z],
        point: NavPoint::at_rest(0.0, 0.0),
        dt: 1.0,
        scale_factor_sd,
    }
    .states()
}

/// Why `cand` is not tested on `m`, if it is not.
fn skip_reason(
    m: &ImuErrorModel<f64>,
    scale_factor_sd: Option<[f64; 2]>,
    cand: &Candidate,
) -> Option<&'static str> {
    let Some(s) = imu_sensor(cand.sensor) else {
        return Some("not a sensor of the strapdown model");
    };
    if cand.kind == ComponentKind::White {
        return Some("a magnitude: fitted by --identify");
    }
    let has = m
        .sensor(s)
        .iter()
        .flat_map(|a| a.iter())
        .any(|c| c.kind() == cand.kind);
    if has && cand.kind != ComponentKind::GaussMarkov {
        return Some("the model has one already");
    }
    let probe = cand
        .starts_at(1.0)
        .into_iter()
        .next()
        .and_then(|p| cand.component(&p));
    let fits = probe
        .and_then(|c| with_component(m, s, c))
        .is_some_and(|m2| filter_states(m2, scale_factor_sd) <= NAV_N);
    (!fits).then_some("does not fit the filter's states")
}

/// The component of `cand` at log-parameters `p` ([`Candidate::component`]), `None` where it is
/// not offered: an exponential-cosine whose envelope holds less than half a period,
/// `beta tau <` [`MIN_QUALITY`] `= pi`, the online structure test's rule. Such a one is a
/// Gauss-Markov of another spectral shape, not an oscillation; the one-channel structure test
/// found the null's best alternatives there (BENCHMARKS.md "Structure online, 2026-11-27";
/// `docs/ADAPTATION.md` §7.6).
fn offered(cand: &Candidate, p: &[f64]) -> Option<Component<f64>> {
    cand.component(p).filter(|c| match c {
        Component::ExpCosine(e) => e.beta * e.tau >= MIN_QUALITY,
        _ => true,
    })
}

/// Half the chi-square(`dk`) `1 - ALPHA` quantile: how much a candidate must gain over a
/// simpler one it contains as a limit (a Gauss-Markov holds a random walk as `tau -> inf` with
/// `2 sigma^2 / tau = q`, and a random constant as `tau -> inf` with `sigma` fixed) to be named
/// instead of it.
fn threshold_nested(dk: usize) -> Result<f64> {
    half_chi2_quantile(1.0 - ALPHA, dk)
}

/// Half the chi-square(`k`) quantile at `p` ([`crate::allan::chi2_quantile`]: accurate to
/// ~1e-14, where statrs's inverse is a coarse numerical one).
fn half_chi2_quantile(p: f64, k: usize) -> Result<f64> {
    crate::allan::chi2_quantile(p, k as f64)
        .map(|x| 0.5 * x)
        .ok_or_else(|| anyhow::anyhow!("chi-square quantile at {p} with {k} degrees of freedom"))
}

/// Half the chi-square(`k`) `1 - alpha / m` quantile.
fn threshold(k: usize, m: usize) -> Result<f64> {
    half_chi2_quantile(1.0 - ALPHA / m.max(1) as f64, k)
}

/// Tests every candidate on `args.model` (module docs). Does not run the model after.
/// With `per_axis` (`--diagnose-axes`) every candidate is also tested split over the axes
/// (item 7).
pub fn diagnose(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    per_axis: bool,
) -> Result<NavDiagnosis> {
    let l0 = loglik(args, imu, fixes)?;
    let fitted = LIBRARY
        .iter()
        .filter(|c| skip_reason(&args.model, args.scale_factor_sd, c).is_none())
        .count();
    // Every test counts in the Bonferroni correction: the tied and, with `per_axis`, the split.
    let tested = if per_axis { 2 * fitted } else { fitted };
    let mut evaluations = 1usize;
    let mut candidates = Vec::with_capacity(LIBRARY.len());
    let bar = indicatif::ProgressBar::new(fitted as u64);
    for cand in LIBRARY.iter() {
        let mut out = NavCandidate {
            label: cand.label(),
            n_params: cand.n_params(),
            component: None,
            loglik: None,
            gain_nats: None,
            threshold_nats: None,
            significant: false,
            split_gain_nats: None,
            split_threshold_nats: None,
            evaluations: 0,
            explanation: None,
            skipped: skip_reason(&args.model, args.scale_factor_sd, cand),
        };
        let sensor = imu_sensor(cand.sensor);
        if let (None, Some(s)) = (out.skipped, sensor) {
            bar.set_message(out.label.clone());
            let (p, ll, n) = fit(args, imu, fixes, cand, s)?;
            bar.inc(1);
            evaluations += n;
            let th = threshold(cand.n_params(), tested)?;
            let comp = cand.component(&p);
            out.component = comp.as_ref().map(ComponentJson::of);
            out.explanation = comp.as_ref().map(|c| cand.explain(c));
            out.loglik = Some(ll);
            out.gain_nats = Some(ll - l0);
            out.threshold_nats = Some(th);
            out.significant = ll - l0 > th;
            out.evaluations = n;
            let split = if per_axis && comp.is_some() {
                let (x, ls, ns) = axes::fit_split(args, imu, fixes, tied(cand, s, &p, ll))?;
                evaluations += ns;
                let ts = threshold(cand.n_params() + 2, tested)?;
                out.split_gain_nats = Some(ls - l0);
                out.split_threshold_nats = Some(ts);
                out.significant |= ls - l0 > ts;
                out.evaluations += ns;
                Some((x, ls, ns))
            } else {
                None
            };
            if let Some(c) = comp {
                candidates.push((out, Some((s, c, *cand, p, ll, split))));
                continue;
            }
        }
        candidates.push((out, None));
    }
    // The named effect: the largest gain above its own threshold, then the simplest of its
    // sensor's significant candidates that it does not beat significantly (item 4); each
    // candidate in the form (tied or split) with the larger excess.
    let order =
        |a: Option<f64>, b: Option<f64>| a.partial_cmp(&b).unwrap_or(std::cmp::Ordering::Equal);
    let significant = || {
        candidates
            .iter()
            .filter(|(c, p)| c.significant && p.is_some())
    };
    let excess = |c: &NavCandidate| c.best_form().map(|f| f.gain - f.threshold);
    let mut best = significant().max_by(|a, b| order(excess(&a.0), excess(&b.0)));
    if let Some((b, Some((sb, ..)))) = best {
        let simpler = significant()
            .filter(|(c, p)| {
                p.as_ref().is_some_and(|(s, ..)| s == sb)
                    && c.best_form().zip(b.best_form()).is_some_and(|(fc, fb)| {
                        fb.contains(&fc)
                            && fb
                                .nested_threshold(&fc)
                                .is_some_and(|t| fb.gain - fc.gain <= t)
                    })
            })
            .max_by(|a, b| {
                order(
                    a.0.best_form().map(|f| f.gain),
                    b.0.best_form().map(|f| f.gain),
                )
            });
        if simpler.is_some() {
            best = simpler;
        }
    }
    let (verdict, named, model, split) = match best {
        Some((c, Some((s, _, cand, p, ll, fitted)))) => {
            bar.set_message(format!("{}: per axis", c.label));
            let named_split = c.best_form().is_some_and(|f| f.split);
            let t = tied(cand, *s, p, *ll);
            let (split, model) = axes::split(args, imu, fixes, t, fitted.clone(), named_split)?;
            evaluations += split.evaluations;
            ("missing-effect", Some(c.label.clone()), model, Some(split))
        }
        _ => ("adequate", None, args.model.clone(), None),
    };
    bar.finish_and_clear();
    Ok(NavDiagnosis {
        verdict,
        named,
        alpha: ALPHA,
        loglik_model: l0,
        candidates: candidates.into_iter().map(|(c, _)| c).collect(),
        evaluations,
        axes: split,
        before: None,
        after: None,
        model,
    })
}

/// The tied fit of `cand` on sensor `s`: log-parameters `p`, log-likelihood `ll`.
fn tied<'a>(cand: &'a Candidate, s: ImuSensor, p: &'a [f64], ll: f64) -> axes::TiedFit<'a> {
    axes::TiedFit {
        cand,
        sensor: s,
        p,
        ll,
    }
}

/// The maximum-likelihood parameters of `cand` on sensor `s` (module docs, item 3): the
/// log-parameters, their log-likelihood and the runs spent.
fn fit(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    cand: &Candidate,
    s: ImuSensor,
) -> Result<(Vec<f64>, f64, usize)> {
    let mut a = args.clone();
    let mut n = 0usize;
    let mut eval = |p: &[f64]| -> Result<f64> {
        n += 1;
        match offered(cand, p).and_then(|c| with_component(&args.model, s, c)) {
            Some(m) => {
                a.model = m;
                loglik(&a, imu, fixes)
            }
            None => Ok(f64::NEG_INFINITY),
        }
    };
    let starts = cand.starts_at(sensor_scale(&args.model, s));
    let mut best: Option<(Vec<f64>, f64)> = None;
    for p in starts {
        let ll = eval(&p)?;
        if best.as_ref().is_none_or(|(_, b)| ll > *b) {
            best = Some((p, ll));
        }
    }
    let Some((mut x, mut ll)) = best else {
        return Ok((Vec::new(), f64::NEG_INFINITY, n));
    };
    search(&mut x, &mut ll, cand.time_params(), &mut eval)?;
    Ok((x, ll, n))
}

/// The pattern search of item 3 from `x` (whose log-likelihood is `ll`): natural-log steps
/// [`STEPS`], every coordinate within three decades of its start except the `times` (a
/// correlation time, a period), within [`TAU_RANGE`]. Updates `x` and `ll`.
fn search(
    x: &mut [f64],
    ll: &mut f64,
    times: std::ops::Range<usize>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<()> {
    let centre = x.to_vec();
    let bounds = |i: usize| {
        let c = centre.get(i).copied()?;
        Some(if times.contains(&i) {
            (TAU_RANGE.0.ln(), TAU_RANGE.1.ln())
        } else {
            (c - HALF_WIDTH, c + HALF_WIDTH)
        })
    };
    super::pattern::maximise(x, ll, &STEPS, 4, &bounds, eval)
}

/// One run of `args` (f32 or f64 core) with the truth attached when given.
fn run_scored(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    truth: Option<(&[TruthRow], &Path)>,
) -> Result<(NavRun, Option<super::truth::TruthComparison>)> {
    let mut run = if args.single {
        run_with::<f32>(args, imu, fixes)?
    } else {
        run_with::<f64>(args, imu, fixes)?
    };
    let cmp = truth
        .map(|(rows, p)| super::truth::attach(&mut run, rows, p))
        .transpose()?;
    Ok((run, cmp))
}

/// `hal-sim nav --diagnose [--identify [--identify-axes]]`: reads the inputs; with `identify`,
/// first identifies the model's magnitudes ([`super::identify_and_write`], its files written); diagnoses the
/// model, runs it and, when an effect is named, the model with it; writes the last run's
/// outputs (as `nav`), `diagnosis.json` (the candidates, the verdict, the scores before and
/// after) and `diagnosed-model.toml` into `out`.
pub fn run_diagnosed(
    args: &NavArgs,
    identify: Option<super::identify::Axes>,
    per_axis: bool,
    truth: Option<&[TruthRow]>,
    truth_path: Option<&Path>,
    out: &Path,
) -> Result<NavDiagnosis> {
    let imu = nav_io::read_imu_csv(&args.imu)?;
    let fixes = nav_io::read_gnss_any(&args.gnss, args.max_q)?;
    let truth = truth.zip(truth_path);
    let (identified, id) = if let Some(axes) = identify {
        let (a, id) = super::identify_and_write(args, &imu, &fixes, axes, out)?;
        eprintln!("{}", id.summary_line());
        (a, Some(id))
    } else {
        (args.clone(), None)
    };
    let args = &identified;
    let mut d = diagnose(args, &imu, &fixes, per_axis)?;
    // Written at once, so that a failure in the runs below loses none of the search; rewritten
    // with their scores.
    std::fs::create_dir_all(out)?;
    let write_json = |d: &NavDiagnosis| {
        crate::output::write_string(
            &out.join("diagnosis.json"),
            &serde_json::to_string_pretty(d)?,
        )
    };
    write_json(&d)?;
    let toml = super::model::to_toml(&d.model)?;
    crate::output::write_string(
        &out.join("diagnosed-model.toml"),
        &toml.to_text(&format!(
            "# hal-sim nav --diagnose of {} on {}: {}{}\n",
            args.model_name,
            args.imu.display(),
            d.verdict,
            d.named_on_axes()
                .map(|n| format!(", {n} added"))
                .unwrap_or_default()
        ))?,
    )?;
    let (before, cmp_before) = run_scored(args, &imu, &fixes, truth)?;
    d.before = Some(RunScores::of(&before, d.loglik_model));
    let (run, cmp) = match d.named_on_axes() {
        Some(name) => {
            let mut a = args.clone();
            a.model = d.model.clone();
            a.model_name = format!("{} + {name} (nav --diagnose)", args.model_name);
            let ll = d.axes.as_ref().map_or(f64::NAN, |a| a.loglik_final);
            let (r, c) = run_scored(&a, &imu, &fixes, truth)?;
            d.after = Some(RunScores::of(&r, ll));
            (r, c)
        }
        None => (before, cmp_before),
    };
    let section = ("Diagnosis: a missing effect?".to_string(), d.html());
    super::records::write_outputs(out, &run, cmp.as_ref(), id.as_ref(), &[section])?;
    write_json(&d)?;
    println!("{}", serde_json::to_string_pretty(&run.summary)?);
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_are_half_the_chi_square_quantiles() {
        // chi-square(2): P(X > x) = exp(-x / 2), so half its 1 - a quantile is -ln a.
        let t = threshold(2, 5).unwrap_or(f64::NAN);
        assert!((t - (-(ALPHA / 5.0).ln())).abs() < 1e-9, "{t}");
        // chi-square(1) 0.99 quantile 6.634897 (tables).
        let n = threshold_nested(1).unwrap_or(f64::NAN);
        assert!((n - 0.5 * 6.634_897).abs() < 1e-6, "{n}");
    }

    #[test]
    fn an_exp_cosine_is_offered_with_half_a_period_in_its_envelope() {
        let ec = Candidate {
            sensor: ErrorSource::Gyro,
            kind: ComponentKind::ExpCosine,
        };
        // [ln sigma, ln tau, ln period]: beta tau = 2 pi tau / period >= pi iff period <= 2 tau.
        let p = |tau: f64, period: f64| [1e-5f64.ln(), tau.ln(), period.ln()];
        assert!(offered(&ec, &p(1200.0, 900.0)).is_some());
        assert!(offered(&ec, &p(1200.0, 2399.0)).is_some());
        assert!(offered(&ec, &p(1200.0, 2401.0)).is_none());
        assert_eq!(ec.time_params(), 1..3);
        let walk = Candidate {
            sensor: ErrorSource::Gyro,
            kind: ComponentKind::RandomWalk,
        };
        assert!(walk.time_params().is_empty());
        assert!(skip_reason(&ImuErrorModel::default(), None, &ec).is_none());
    }

    #[test]
    fn candidates_the_model_has_or_cannot_hold_are_skipped() {
        use imu_ident::model::{RandomWalk, WhiteNoise};
        let mut m = ImuErrorModel::default();
        let white = Component::White(WhiteNoise { density: 1e-3 });
        let walk = Component::RandomWalk(RandomWalk {
            q: 1e-10,
            sigma0: 0.0,
        });
        assert!(m.set_all_gyro(&[white, walk]).is_ok());
        assert!(m.set_all_accel(&[white]).is_ok());
        let reason = |m: &ImuErrorModel<f64>, sensor, kind| {
            skip_reason(m, None, &Candidate { sensor, kind })
        };
        assert!(reason(&m, ErrorSource::Gyro, ComponentKind::RandomWalk).is_some());
        assert!(reason(&m, ErrorSource::Gyro, ComponentKind::White).is_some());
        assert!(reason(&m, ErrorSource::Observation, ComponentKind::GaussMarkov).is_some());
        assert_eq!(
            reason(&m, ErrorSource::Accel, ComponentKind::RandomWalk),
            None
        );
        assert_eq!(
            reason(&m, ErrorSource::Gyro, ComponentKind::GaussMarkov),
            None
        );
        // 9 + 3 (gyro walk) + 3 per added component: a 24-state filter holds four more.
        let gm = Component::GaussMarkov(imu_ident::model::GaussMarkov {
            sigma: 1e-3,
            tau: 100.0,
        });
        assert!(m.set_all_accel(&[white, gm, gm, gm]).is_ok());
        assert_eq!(filter_states(m.clone(), None), 21);
        // The six scale-factor states of `--scale-factors` count too.
        assert_eq!(filter_states(m.clone(), Some([0.01, 0.01])), 27);
        assert_eq!(
            skip_reason(
                &m,
                Some([0.01, 0.01]),
                &Candidate {
                    sensor: ErrorSource::Gyro,
                    kind: ComponentKind::RandomConstant
                }
            ),
            Some("does not fit the filter's states")
        );
        assert_eq!(
            reason(&m, ErrorSource::Gyro, ComponentKind::RandomConstant),
            None
        );
        assert!(m.set_all_gyro(&[white, walk, gm]).is_ok());
        assert_eq!(
            reason(&m, ErrorSource::Accel, ComponentKind::RandomWalk),
            Some("does not fit the filter's states")
        );
    }
}
