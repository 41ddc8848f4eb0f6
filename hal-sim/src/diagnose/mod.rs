//! Diagnosis: compare a model with the measurements, show where it fails, and name the missing
//! physical effect.
//!
//! 1. Replay the log with the model; check innovation whiteness (ACF band and Ljung-Box) and
//!    windowed NIS — checks that need no truth.
//! 2. For every candidate of the library ([`crate::candidates::LIBRARY`]), add it to the model,
//!    fit its parameters by maximum innovation likelihood, and score the gain in log-likelihood
//!    against the BIC penalty `k/2 ln n` (k free parameters, n innovations). Next to the
//!    additions, every component of the model whose kind has an alternative in the core kind
//!    table (`ComponentKind::alternative`) is replaced by it and fitted the same way, with
//!    `k` the new component's parameters, as for an addition (why not the +1 of Gauss-Markov ->
//!    exp-cosine: [`crate::candidates::Proposal::free_params`]).
//! 3. The verdict is "adequate" when no candidate's gain exceeds its penalty, else the best
//!    candidate, with its parameters and a physical explanation: "missing-effect" for an
//!    addition, "wrong-kind" for a replacement.
//!
//! Detection uses what the filter sees (innovations and likelihood), not the ACF of the
//! filter's own sensor-error estimates, which hides an oscillating drift behind a Markov-1
//! model (issue 4's caution).

pub mod estimate_acf;
pub mod fit;
pub mod limits;
pub mod tie;
pub mod whiteness;

use crate::candidates::Proposal;
use crate::log::LogRow;
use crate::model_toml::ComponentToml;
use crate::replay;
use anyhow::Result;
use fit::Fit;
use imu_ident::model::InsModel;
use serde::Serialize;
use whiteness::{nis_windows, whiteness, NisWindow, Whiteness};

/// Lags of the whiteness test: 1..=60 s covers the correlation times the filter's innovations
/// show when a process model is wrong.
pub const WHITENESS_LAGS: usize = 60;
/// Score difference below which two candidates are reported as indistinguishable: a
/// likelihood ratio of e^3 = 20.
pub const TIE: f64 = 3.0;
/// Candidates refined by a second, finer fit before the ranking.
pub const REFINED: usize = 3;
/// NIS window [steps]: 10 minutes at 1 Hz.
pub const NIS_WINDOW: usize = 600;

/// [`Diagnosis::chosen_by`] when one candidate's penalised likelihood is best by [`TIE`] or more.
pub const CHOSEN_BY_LIKELIHOOD: &str = "likelihood";
/// [`Diagnosis::chosen_by`] when candidates are tied: the least tilt-RMS regret wins.
pub const CHOSEN_BY_TIE: &str =
    "tie: least expected tilt regret over the tied candidates, weighted by their likelihood";
/// One candidate's score.
#[derive(Debug, Clone, Serialize)]
pub struct CandidateScore {
    /// `sensor/kind` (an addition) or `sensor/old->new` (a replacement).
    pub label: String,
    /// Fitted component, in model-TOML form.
    pub params: ComponentToml,
    /// Log-likelihood gain over the model.
    pub gain: f64,
    /// BIC penalty.
    pub penalty: f64,
    /// `gain - penalty`.
    pub score: f64,
    /// Likelihood evaluations spent on the fit.
    pub evaluations: u64,
    /// One line on what the fitted change means.
    pub explanation: String,
}

/// The component a "wrong-kind" verdict replaces.
#[derive(Debug, Clone, Serialize)]
pub struct Replaced {
    /// Its position in the sensor's component list of the input model.
    pub index: usize,
    /// Its kind (model-TOML spelling).
    pub kind: &'static str,
    /// Its parameters in the input model.
    pub params: ComponentToml,
}

/// Evidence behind the verdict.
#[derive(Debug, Clone, Serialize)]
pub struct Evidence {
    /// Log-likelihood of the model as given.
    pub log_likelihood: f64,
    /// Innovations used.
    pub n: usize,
    /// Gain of the chosen candidate (best score's gain when adequate).
    pub log_likelihood_gain: f64,
    /// Its penalty.
    pub penalty: f64,
    /// The criterion.
    pub criterion: &'static str,
    /// Lags of the normalised-innovation ACF outside the 99 % band.
    pub failed_lags: Vec<usize>,
    /// Windows whose mean NIS is outside its 99 % band.
    pub failed_windows: Vec<NisWindow>,
    /// Whiteness statistics.
    pub whiteness: Whiteness,
    /// 99 % band of a window's mean NIS.
    pub nis_window_band: [f64; 2],
    /// All windows.
    pub nis_windows: Vec<NisWindow>,
    /// Every candidate, best first.
    pub candidates: Vec<CandidateScore>,
}

/// The outcome written to `diagnosis.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Diagnosis {
    /// "adequate", "missing-effect" (add a component) or "wrong-kind" (replace one).
    pub verdict: &'static str,
    /// "accel", "gyro" or "observation" (not when adequate).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor: Option<&'static str>,
    /// A model-TOML kind: the component to add, or the kind that replaces [`Self::replaces`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<&'static str>,
    /// The fitted parameters of the effect.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub params: Option<ComponentToml>,
    /// The component replaced (wrong-kind only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replaces: Option<Replaced>,
    /// One line on the physics.
    pub explanation: String,
    /// How the verdict was chosen among the candidates: [`CHOSEN_BY_LIKELIHOOD`] or, when
    /// several are tied, [`CHOSEN_BY_TIE`].
    pub chosen_by: &'static str,
    /// Other candidates whose penalised score is within [`TIE`] of the best one: the data
    /// cannot tell them apart (e.g. gyro white noise drives the tilt as a random walk, which the
    /// velocity sees exactly as an accelerometer random walk).
    pub indistinguishable_from: Vec<String>,
    /// How a tie was decided (weights, regret matrix); absent without a tie.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tie: Option<tie::TieBreak>,
    /// Why.
    pub evidence: Evidence,
    /// What this observation cannot show, whatever the verdict (see [`limits`]).
    pub limits: Vec<limits::Limit>,
    /// The input model plus the effect, or with the component replaced (the input model when
    /// adequate).
    #[serde(skip)]
    pub suggested: InsModel<f64>,
}

/// Diagnoses `model` against `log`. Candidates are fitted on two threads.
pub fn diagnose(model: &InsModel<f64>, log: &[LogRow]) -> Result<Diagnosis> {
    // One run of the step gives the estimates and the likelihood; the fits below evaluate
    // the same likelihood through the same step (`replay::log_likelihood`).
    let tel = replay::run::<f64>(model, None, log)?.telemetry;
    let est = tel.estimate_rows();
    let wh = whiteness(&est, WHITENESS_LAGS);
    let (windows, band, failed_windows) = nis_windows(&est, NIS_WINDOW);
    let (ll0, n) = tel.log_likelihood();
    let penalty_per_param = 0.5 * (n.max(2) as f64).ln();

    type Indexed = Vec<(usize, Proposal)>;
    let fits: Vec<Option<Fit>> = std::thread::scope(|s| {
        let (even, odd): (Indexed, Indexed) = Proposal::all(model)
            .into_iter()
            .enumerate()
            .partition(|(i, _)| i % 2 == 0);
        let work = |part: Indexed| {
            part.into_iter()
                .map(|(i, c)| (i, fit::fit(model, c, log)))
                .collect::<Vec<_>>()
        };
        let h = s.spawn(move || work(odd));
        let mut all = work(even);
        all.extend(h.join().unwrap_or_default());
        all.sort_by_key(|(i, _)| *i);
        all.into_iter().map(|(_, f)| f).collect()
    });
    // Refine the three best (on two threads) before ranking: close candidates are decided by
    // a few log-likelihood units.
    let mut fits: Vec<Fit> = fits.into_iter().flatten().collect();
    fits.sort_by(|a, b| {
        let score =
            |f: &Fit| f.log_likelihood - penalty_per_param * f.candidate.free_params() as f64;
        score(b).total_cmp(&score(a))
    });
    let top = fits.len().min(REFINED);
    let refined: Vec<Fit> = std::thread::scope(|s| {
        let handles: Vec<_> = fits[..top]
            .iter()
            .map(|f| s.spawn(move || fit::refine(model, f, log)))
            .collect();
        handles
            .into_iter()
            .zip(&fits[..top])
            .map(|(h, f)| h.join().unwrap_or_else(|_| f.clone()))
            .collect()
    });
    fits.splice(..top, refined);
    let mut scores: Vec<(CandidateScore, Fit)> = fits
        .into_iter()
        .map(|f| {
            let gain = f.log_likelihood - ll0;
            let penalty = penalty_per_param * f.candidate.free_params() as f64;
            let s = CandidateScore {
                label: f.candidate.label(),
                params: ComponentToml::from_core(&f.component),
                gain,
                penalty,
                score: gain - penalty,
                evaluations: f.evaluations,
                explanation: f.candidate.explain(&f.component),
            };
            (s, f)
        })
        .collect();
    scores.sort_by(|a, b| b.0.score.total_cmp(&a.0.score));
    let best = scores.first().cloned();
    let mut evidence = Evidence {
        log_likelihood: ll0,
        n,
        log_likelihood_gain: best.as_ref().map_or(0.0, |b| b.0.gain),
        penalty: best.as_ref().map_or(0.0, |b| b.0.penalty),
        criterion: "BIC: gain in innovation log-likelihood > (k/2) ln n",
        failed_lags: wh.failed_lags.clone(),
        failed_windows,
        whiteness: wh,
        nis_window_band: band,
        nis_windows: windows,
        candidates: scores.iter().map(|s| s.0.clone()).collect(),
    };
    match best {
        Some((top, _)) if top.score > 0.0 => {
            // Every candidate within TIE of the best explains the data as well; among them the
            // verdict is the one with the least expected tilt regret (see `tie`).
            let tied: Vec<usize> = (0..scores.len())
                .filter(|&i| top.score - scores[i].0.score < TIE)
                .collect();
            let (pick, chosen_by, tie) = if tied.len() > 1 {
                let (pick, record) = tie::decide(model, log, &scores, &tied);
                (pick, CHOSEN_BY_TIE, Some(record))
            } else {
                (0, CHOSEN_BY_LIKELIHOOD, None)
            };
            let (score, f) = scores[pick].clone();
            let suggested = f.candidate.apply(model, &f.params).unwrap_or_else(|| model.clone());
            let (verdict, replaces) = match f.candidate {
                Proposal::Add(_) => ("missing-effect", None),
                Proposal::Replace(r) => (
                    "wrong-kind",
                    Some(Replaced {
                        index: r.index,
                        kind: r.old.kind().name(),
                        params: ComponentToml::from_core(&r.old),
                    }),
                ),
            };
            let target = f.candidate.target();
            evidence.log_likelihood_gain = score.gain;
            evidence.penalty = score.penalty;
            let ties = tied
                .iter()
                .filter(|&&i| i != pick)
                .map(|&i| scores[i].0.label.clone())
                .collect();
            Ok(Diagnosis {
                chosen_by,
                indistinguishable_from: ties,
                tie,
                verdict,
                sensor: Some(target.sensor.name()),
                effect: Some(target.kind.name()),
                params: Some(score.params),
                replaces,
                explanation: score.explanation,
                evidence,
                limits: limits::limits(model, log, n),
                suggested,
            })
        }
        _ => Ok(Diagnosis {
            chosen_by: CHOSEN_BY_LIKELIHOOD,
            verdict: "adequate",
            sensor: None,
            effect: None,
            params: None,
            replaces: None,
            indistinguishable_from: Vec::new(),
            tie: None,
            explanation: "no candidate effect raises the innovation likelihood by more than its complexity penalty".into(),
            evidence,
            limits: limits::limits(model, log, n),
            suggested: model.clone(),
        }),
    }
}
