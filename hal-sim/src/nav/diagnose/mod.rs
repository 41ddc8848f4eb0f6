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
//!    ([`add::offered`]); below that it is a Gauss-Markov of another shape.
//! 3. Each candidate's parameters maximise the likelihood: every start of the table
//!    ([`crate::candidates::Candidate::starts_at`], scaled to the sensor's magnitude in the
//!    model) is evaluated, and a pattern search ([`super::pattern`]) runs from the best, in
//!    natural-log steps 2, 1, 0.5, 0.25, within three decades of its start (correlation times
//!    and periods within [10 s, 1e5 s]); a Gauss-Markov's `(sigma, tau)` also moves along
//!    `sigma^2 / tau` = const ([`crate::candidates::Candidate::ridges`]: one axis at a time,
//!    the search stopped short of the maximum on that ridge, by up to 2.7 nats on the
//!    simulated logs of BENCHMARKS.md "Naming a missing effect on the strapdown navigator").
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
//! 8. Replacements ([`replace`]): a component the three axes of a sensor carry is replaced by
//!    its alternative kind (Gauss-Markov <-> exponential-cosine), its values scaled alike on
//!    every axis and fitted the same way (one more start: the addition of the new kind, if
//!    fitted, in place of the old component), `k` = 3 in both directions (the exponential-cosine's
//!    parameters: the family that bounds its gain on a right model), counted in `m`.
//!    Named like an addition, by the largest excess ("wrong-kind"); the nesting rule is among
//!    additions. A gyro drift that is an oscillation, modelled as a Gauss-Markov, is named as
//!    the replacement, not as an exponential-cosine added on top of the wrong component. When
//!    the addition of the same kind on the same sensor is within 3.3 nats (half the
//!    chi-square(1) 0.99 quantile) of the replacement, the data do not tell whether the old
//!    component stays: `tied_with` names the other, and the report says so. Measured: with
//!    the oscillation well above the old component (BENCHMARKS.md "The wrong kind on the
//!    navigator") the two are within 2.2 nats.
//!
//! Diagnose a model whose magnitudes are fitted: `--identify --diagnose` identifies them first
//! (or `--model identified-model.toml $(cat identified-options.txt) --diagnose` after an
//! identification). Otherwise a candidate can win by standing in for a white density that is
//! only too small: on the real drive the datasheet model "lacks" an accelerometer
//! Gauss-Markov of 17 mg over 16 s (a gain of 1.2e5 nats), and with it the error at the
//! outage ends rises from 7.0 to 25 m; the identified model is adequate (BENCHMARKS.md
//! "Naming a missing effect on the strapdown navigator").

mod add;
mod axes;
mod record;
mod replace;

pub use axes::AxisSplit;
pub use record::{ComponentJson, Form, NavCandidate, NavDiagnosis, RunScores};
pub use replace::NavReplacement;

use super::identify::loglik;
use super::{run_with, NavArgs, NavRun};
use crate::candidates::{Candidate, LIBRARY};
use crate::nav_io::truth_csv::TruthRow;
use crate::nav_io::{self, GnssFix, ImuSample};
use add::{filter_states, fit, imu_sensor, skip_reason};
use anyhow::Result;
use imu_ident::nav::{ImuSensor, NAV_N};
use std::path::Path;

/// Family-wise probability of calling a right model inadequate (item 4 of the module docs).
pub const ALPHA: f64 = 0.01;
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

/// A candidate as fitted, for the naming rule.
enum Fitted<'a> {
    /// An addition on sensor `sensor`: its tied log-parameters `p` and log-likelihood `ll`,
    /// and with `--diagnose-axes` its split fit.
    Add {
        sensor: ImuSensor,
        cand: &'a Candidate,
        p: Vec<f64>,
        ll: f64,
        split: Option<(Vec<f64>, f64, usize)>,
    },
    /// A replacement ([`replace`]) with its parameters `p` and log-likelihood `ll`.
    Replace {
        r: NavReplacement,
        p: Vec<f64>,
        ll: f64,
    },
}

impl Fitted<'_> {
    /// The component kind and sensor the fit puts in the model.
    fn target(&self) -> Candidate {
        match self {
            Self::Add { cand, .. } => **cand,
            Self::Replace { r, .. } => r.target(),
        }
    }

    /// The sensor of an addition (the nesting rule of item 4 is among additions).
    fn added_on(&self) -> Option<ImuSensor> {
        match self {
            Self::Add { sensor, .. } => Some(*sensor),
            Self::Replace { .. } => None,
        }
    }
}

/// Why replacement `r` is not tested on `args.model`, if it is not: it would not fit the
/// filter's states (a Gauss-Markov -> exponential-cosine adds one state per axis).
fn swap_skip_reason(args: &NavArgs, r: &NavReplacement) -> Option<&'static str> {
    let fits = r
        .starts()
        .iter()
        .find_map(|p| r.apply(&args.model, p))
        .is_some_and(|m| filter_states(m, args.scale_factor_sd) <= NAV_N);
    (!fits).then_some("does not fit the filter's states")
}

/// An untested candidate's record.
fn untested(label: String, n_params: usize, skipped: Option<&'static str>) -> NavCandidate {
    NavCandidate {
        label,
        n_params,
        component: None,
        loglik: None,
        gain_nats: None,
        threshold_nats: None,
        significant: false,
        split_gain_nats: None,
        split_threshold_nats: None,
        evaluations: 0,
        explanation: None,
        skipped,
    }
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
    let swaps = NavReplacement::all(&args.model);
    let swaps_fitted = swaps
        .iter()
        .filter(|r| swap_skip_reason(args, r).is_none())
        .count();
    // Every test counts in the Bonferroni correction: the tied and, with `per_axis`, the
    // split additions, and the replacements.
    let tested = if per_axis { 2 * fitted } else { fitted } + swaps_fitted;
    let mut evaluations = 1usize;
    let mut candidates: Vec<(NavCandidate, Option<Fitted>)> =
        Vec::with_capacity(LIBRARY.len() + swaps.len());
    let bar = indicatif::ProgressBar::new((fitted + swaps_fitted) as u64);
    for cand in LIBRARY.iter() {
        let mut out = untested(
            cand.label(),
            cand.n_params(),
            skip_reason(&args.model, args.scale_factor_sd, cand),
        );
        let sensor = imu_sensor(cand.sensor);
        if let (None, Some(s)) = (out.skipped, sensor) {
            bar.set_message(out.label.clone());
            let (p, ll, n) = fit(args, imu, fixes, cand, s)?;
            bar.inc(1);
            evaluations += n;
            let th = threshold(cand.n_params(), tested)?;
            let comp = cand.component(&p);
            out.record_fit(comp.as_ref().map(|c| (c, cand.explain(c))), ll - l0, th, n);
            out.loglik = Some(ll);
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
            if comp.is_some() {
                let f = Fitted::Add {
                    sensor: s,
                    cand,
                    p,
                    ll,
                    split,
                };
                candidates.push((out, Some(f)));
                continue;
            }
        }
        candidates.push((out, None));
    }
    for r in swaps {
        let k = r.k();
        let mut out = untested(r.label(), k, swap_skip_reason(args, &r));
        if out.skipped.is_none() {
            bar.set_message(out.label.clone());
            // The addition of the new kind on the same sensor, if fitted, is one start.
            let added = candidates.iter().find_map(|(_, f)| match f {
                Some(Fitted::Add { cand, p, .. }) if **cand == r.target() => Some(p.as_slice()),
                _ => None,
            });
            let (p, ll, n) = replace::fit(args, imu, fixes, &r, added)?;
            bar.inc(1);
            evaluations += n;
            let th = threshold(k, tested)?;
            // The x axis's component stands for the three (the others scaled alike).
            let comp = r.components(&p).map(|[x, _, _]| x);
            out.record_fit(comp.as_ref().map(|c| (c, r.explain(c))), ll - l0, th, n);
            out.loglik = Some(ll);
            if comp.is_some() {
                candidates.push((out, Some(Fitted::Replace { r, p, ll })));
                continue;
            }
        }
        candidates.push((out, None));
    }
    // The named change: the largest gain above its own threshold, then, for an addition, the
    // simplest of its sensor's significant additions that it does not beat significantly
    // (item 4); each addition in the form (tied or split) with the larger excess.
    let order =
        |a: Option<f64>, b: Option<f64>| a.partial_cmp(&b).unwrap_or(std::cmp::Ordering::Equal);
    let significant = || {
        candidates
            .iter()
            .filter(|(c, p)| c.significant && p.is_some())
    };
    let excess = |c: &NavCandidate| c.best_form().map(|f| f.gain - f.threshold);
    let mut best = significant().max_by(|a, b| order(excess(&a.0), excess(&b.0)));
    if let Some((b, Some(fb))) = best {
        let sb = fb.added_on();
        let simpler = significant()
            .filter(|(c, p)| {
                sb.is_some()
                    && p.as_ref().and_then(Fitted::added_on) == sb
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
    // An addition and a replacement of the same new kind on the same sensor differ only in
    // whether the old component stays; within the nesting rule's 3.3 nats of each other the
    // data do not tell, and the report says so (item 8).
    let tied_with = best.and_then(|(b, fb)| {
        let target = fb.as_ref()?.target();
        let tie = threshold_nested(1).ok()?;
        significant()
            .filter(|(c, f)| {
                c.label != b.label
                    && f.as_ref().map(Fitted::target) == Some(target)
                    && c.gain_nats
                        .zip(b.gain_nats)
                        .is_some_and(|(g, gb)| (gb - g).abs() <= tie)
            })
            .map(|(c, _)| c.label.clone())
            .next()
    });
    let (verdict, named, model, split, loglik_diagnosed) = match best {
        Some((
            c,
            Some(Fitted::Add {
                sensor,
                cand,
                p,
                ll,
                split,
            }),
        )) => {
            bar.set_message(format!("{}: per axis", c.label));
            let named_split = c.best_form().is_some_and(|f| f.split);
            let t = tied(cand, *sensor, p, *ll);
            let (split, model) = axes::split(args, imu, fixes, t, split.clone(), named_split)?;
            evaluations += split.evaluations;
            let ll = split.loglik_final;
            (
                "missing-effect",
                Some(c.label.clone()),
                model,
                Some(split),
                ll,
            )
        }
        Some((c, Some(Fitted::Replace { r, p, ll }))) => {
            let Some(model) = r.apply(&args.model, p) else {
                anyhow::bail!("nav --diagnose: {} no longer applies", c.label);
            };
            ("wrong-kind", Some(c.label.clone()), model, None, *ll)
        }
        _ => ("adequate", None, args.model.clone(), None, l0),
    };
    bar.finish_and_clear();
    Ok(NavDiagnosis {
        verdict,
        named,
        alpha: ALPHA,
        loglik_model: l0,
        loglik_diagnosed,
        tied_with,
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
    let imu = nav_io::read_imu_any(&args.imu)?;
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
            d.change().map(|n| format!(", {n}")).unwrap_or_default()
        ))?,
    )?;
    let (before, cmp_before) = run_scored(args, &imu, &fixes, truth)?;
    d.before = Some(RunScores::of(&before, d.loglik_model));
    let (run, cmp) = match d.named_on_axes() {
        Some(name) => {
            let mut a = args.clone();
            a.model = d.model.clone();
            a.model_name = format!("{} + {name} (nav --diagnose)", args.model_name);
            let (r, c) = run_scored(&a, &imu, &fixes, truth)?;
            d.after = Some(RunScores::of(&r, d.loglik_diagnosed));
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
}
