//! Deciding between candidates the data cannot tell apart.
//!
//! Candidates whose penalised log-likelihood is within [`super::TIE`] nats of the best explain
//! the innovations almost equally well. Some are exactly equivalent: gyro white noise `w` and
//! the driving noise `n` of an accelerometer random walk enter the velocity only as `-g w + n`
//! (`dV'' + (g/R) dV = -g w + n`), so for `q = g^2 N^2` every innovation sequence has the same
//! likelihood under both. They place the error differently, though, as tilt or as accelerometer
//! bias, and naming the wrong one costs asymmetrically (measured on hidden gyro white noise
//! named as an accelerometer random walk: 8.8x to 74x the oracle's tilt RMS; the reverse: 0.87x
//! to 1.41x).
//!
//! So the choice is a decision under uncertainty, made on simulated data (the log's own truth
//! columns are never read):
//! - each tied model `M_j` (base model changed by candidate `j` with its fitted parameters) is
//!   simulated as the truth over the log's length, every tied model `M_i` is run on it, and
//!   `regret[i][j] = tilt RMS(M_i) / tilt RMS(M_j)` on that simulation (1 on the diagonal);
//! - the posterior weight of `j` is `exp(score_j)` normalised over the tied set (the BIC score
//!   is the log of the marginal likelihood to first order, with equal prior odds);
//! - the verdict minimises the posterior expected regret `sum_j w_j regret[i][j]` (Bayes risk).
//!
//! For an exact tie the weights are equal and the rule is the safe one: naming the gyro costs
//! `(1 + 1.35)/2`, naming the accelerometer `(1 + 8.8)/2` or worse. When one tied candidate is
//! clearly more likely (a slow accelerometer Gauss-Markov that fits 2 nats better than gyro
//! white noise), its weight lets it win unless the others' regret outweighs the odds, which the
//! earlier minimax rule (worst case over `j`, weights ignored) never allowed.

use super::fit::Fit;
use super::CandidateScore;
use crate::log::LogRow;
use crate::replay;
use imu_ident::model::InsModel;
use serde::Serialize;

/// Seed of the simulations that break a tie (the decision depends on the models only).
const TIE_SEED: u64 = 0x7115;

/// How a tie was decided, written into `diagnosis.json`.
#[derive(Debug, Clone, Serialize)]
pub struct TieBreak {
    /// The tied candidates (`sensor/kind`), best score first.
    pub labels: Vec<String>,
    /// Posterior weight of each, `exp(score)` normalised over the tied set.
    pub weights: Vec<f64>,
    /// `regret[i][j]`: tilt RMS of candidate `i`'s model over candidate `j`'s own, on data
    /// simulated with `j` as the truth (infinite when a run failed).
    pub regret: Vec<Vec<f64>>,
    /// Posterior expected regret of naming each candidate; the least wins.
    pub expected_regret: Vec<f64>,
}

/// Decides among `tied` (indices into `scores`, best score first); returns the index into
/// `scores` of the verdict and the record of how it was reached.
pub fn decide(
    model: &InsModel<f64>,
    log: &[LogRow],
    scores: &[(CandidateScore, Fit)],
    tied: &[usize],
) -> (usize, TieBreak) {
    let models: Vec<Option<InsModel<f64>>> = tied
        .iter()
        .map(|&i| scores[i].1.candidate.apply(model, &scores[i].1.params))
        .collect();
    let tilt = |m: &InsModel<f64>, data: &[LogRow]| -> f64 {
        replay::estimates::<f64>(m, data)
            .ok()
            .and_then(|(est, _)| crate::summary::tilt_stats(data, &est))
            .map(|t| t.0)
            .filter(|t| t.is_finite())
            .unwrap_or(f64::INFINITY)
    };
    let k = tied.len();
    let mut regret = vec![vec![f64::INFINITY; k]; k];
    for (j, truth) in models.iter().enumerate() {
        let Some(truth) = truth else { continue };
        let Ok(data) = crate::sim::simulate(truth, log.len(), TIE_SEED) else {
            // No simulation, no information on this column: neutral.
            regret.iter_mut().for_each(|row| row[j] = 1.0);
            continue;
        };
        let oracle = tilt(truth, &data);
        for (i, m) in models.iter().enumerate() {
            let r = m
                .as_ref()
                .map_or(f64::INFINITY, |m| tilt(m, &data) / oracle);
            regret[i][j] = if i == j {
                1.0
            } else if r.is_nan() {
                f64::INFINITY
            } else {
                r
            };
        }
    }
    let weights = posterior(&tied.iter().map(|&i| scores[i].0.score).collect::<Vec<_>>());
    let expected_regret = expected_regret(&regret, &weights);
    let pick = least(&expected_regret);
    let record = TieBreak {
        labels: tied.iter().map(|&i| scores[i].0.label.clone()).collect(),
        weights,
        regret,
        expected_regret,
    };
    (tied.get(pick).copied().unwrap_or(0), record)
}

/// Posterior weights `exp(score_j)` normalised (equal prior odds; BIC score as log evidence).
fn posterior(scores: &[f64]) -> Vec<f64> {
    let top = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let raw: Vec<f64> = scores.iter().map(|s| (s - top).exp()).collect();
    let total: f64 = raw.iter().sum();
    raw.iter().map(|w| w / total).collect()
}

/// `sum_j w_j regret[i][j]` for each `i`; a candidate of zero weight adds nothing (even an
/// infinite regret against it).
fn expected_regret(regret: &[Vec<f64>], weights: &[f64]) -> Vec<f64> {
    regret
        .iter()
        .map(|row| {
            row.iter()
                .zip(weights)
                .map(|(r, w)| if *w == 0.0 { 0.0 } else { r * w })
                .sum()
        })
        .collect()
}

/// Index of the least value (the first on equality; NaN sorts last).
fn least(v: &[f64]) -> usize {
    (0..v.len())
        .min_by(|&a, &b| v[a].total_cmp(&v[b]).then(a.cmp(&b)))
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Measured regrets of the gyro-white / accelerometer-random-walk pair: with equal odds the
    /// safe candidate (gyro, index 0) wins; odds of 40:1 for the accelerometer overturn it
    /// (break-even at (8.8 - 1)/(1.35 - 1) = 22:1).
    #[test]
    fn expected_regret_weighs_the_odds_against_the_cost() {
        let regret = vec![vec![1.0, 1.35], vec![8.8, 1.0]];
        assert_eq!(least(&expected_regret(&regret, &posterior(&[5.0, 5.0]))), 0);
        assert_eq!(
            least(&expected_regret(
                &regret,
                &posterior(&[5.0, 5.0 + 40f64.ln()])
            )),
            1
        );
        assert_eq!(
            least(&expected_regret(
                &regret,
                &posterior(&[5.0, 5.0 + 20f64.ln()])
            )),
            0
        );
    }

    /// An infinite regret (a run that failed) against a candidate of no weight does not poison
    /// the others; the weights sum to one.
    #[test]
    fn posterior_is_normalised_and_an_impossible_candidate_is_ignored() {
        let w = posterior(&[0.0, -1.0, f64::NEG_INFINITY]);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(w[2], 0.0);
        let regret = vec![
            vec![1.0, 2.0, f64::INFINITY],
            vec![3.0, 1.0, 1.0],
            vec![9.0; 3],
        ];
        let e = expected_regret(&regret, &w);
        assert!(e[0].is_finite() && e[0] < e[1], "{e:?}");
    }
}
