//! Greedy forward selection of the composite model (see `fit` for the objective).
//!
//! Each step tries one more Gauss-Markov and filtered white (their T_c scanned four per
//! octave, the best two refined), rate random walk, quantisation and, when the ACF found one,
//! the exponential cosine; refits all shapes jointly; keeps the best by BIC `χ² + k ln n`
//! (k free parameters, n taus); stops when no addition lowers the BIC. The taus are treated
//! as independent, which they are only roughly (overlapping clusters), so BIC is a stopping
//! heuristic here, not a likelihood statement.

use super::fit::{Kind, Problem, Term, MAX_TERMS};

/// One tried model in the forward selection.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Trial {
    pub step: usize,
    /// What was added, e.g. `gauss-markov`.
    pub added: String,
    /// Kinds of the whole trial model.
    pub model: Vec<String>,
    pub chi2: f64,
    pub n_params: usize,
    pub bic: f64,
    pub accepted: bool,
}

/// Result of [`select`].
#[derive(Debug, Clone)]
pub struct Selection {
    pub terms: Vec<Term>,
    pub chi2: f64,
    pub bic: f64,
    pub trials: Vec<Trial>,
}

fn n_params(terms: &[Term]) -> usize {
    terms.iter().map(|t| t.kind.n_params()).sum()
}

/// Greedy forward selection (see the module documentation). `exp_cos` is the ACF's
/// exponential cosine `(tc, period)`, when one was detected.
pub fn select(prob: &Problem, exp_cos: Option<(f64, f64)>) -> Selection {
    let ln_n = (prob.pts.len() as f64).ln();
    let bic = |chi2: f64, terms: &[Term]| chi2 + n_params(terms) as f64 * ln_n;
    let mut terms = vec![Term::new(Kind::White, 1.0, 0.0)];
    let mut chi2 = prob.fit(&mut terms);
    let mut best_bic = bic(chi2, &terms);
    let mut trials = vec![Trial {
        step: 0,
        added: "white".into(),
        model: vec!["white".into()],
        chi2,
        n_params: n_params(&terms),
        bic: best_bic,
        accepted: true,
    }];
    // Correlation times scanned for a new Gauss-Markov: a fifth of a sample to the longest
    // cluster, four per octave.
    let max_m = prob.pts.iter().map(|p| p.m).max().unwrap_or(1);
    let gm_starts: Vec<f64> =
        std::iter::successors(Some(0.2 * prob.dt), |t| Some(t * 2f64.sqrt().sqrt()))
            .take_while(|t| *t <= max_m as f64 * prob.dt)
            .collect();
    for step in 1..MAX_TERMS {
        let mut options: Vec<(String, Vec<Term>)> = Vec::new();
        let has = |k: Kind| terms.iter().any(|t| t.kind == k);
        // A new Gauss-Markov: scan its T_c (four per octave) with the other shapes held,
        // then refine all shapes from the best two. A start where NNLS gives the new term
        // zero amplitude is a flat direction that Nelder-Mead cannot leave, hence the scan.
        for kind in [Kind::GaussMarkov, Kind::FilteredWhite] {
            if kind == Kind::FilteredWhite && has(kind) {
                continue;
            }
            let mut scan: Vec<(f64, f64)> = gm_starts
                .iter()
                .filter(|&&tc| kind == Kind::GaussMarkov || tc < 8.0 * prob.dt)
                .map(|&tc| {
                    let mut t = terms.clone();
                    t.push(Term::new(kind, tc, 0.0));
                    (prob.amplitudes(&mut t), tc)
                })
                .collect();
            scan.sort_by(|a, b| a.0.total_cmp(&b.0));
            for &(_, tc) in scan.iter().take(2) {
                let mut t = terms.clone();
                t.push(Term::new(kind, tc, 0.0));
                options.push((kind.name().into(), t));
            }
        }
        for k in [Kind::RandomWalk, Kind::Quantization] {
            if !has(k) {
                let mut t = terms.clone();
                t.push(Term::new(k, 1.0, 0.0));
                options.push((k.name().into(), t));
            }
        }
        if let (Some((tc, period)), false) = (exp_cos, has(Kind::ExpCosine)) {
            let mut t = terms.clone();
            t.push(Term::new(Kind::ExpCosine, tc, period));
            options.push(("exp-cosine".into(), t));
        }
        let mut best: Option<(f64, f64, Vec<Term>, usize)> = None;
        let first = trials.len();
        for (label, mut t) in options {
            let c = prob.fit(&mut t);
            let b = bic(c, &t);
            trials.push(Trial {
                step,
                added: label,
                model: t.iter().map(|x| x.kind.name().to_string()).collect(),
                chi2: c,
                n_params: n_params(&t),
                bic: b,
                accepted: false,
            });
            if best.as_ref().is_none_or(|x| b < x.0) {
                best = Some((b, c, t, trials.len() - 1));
            }
        }
        // Several Gauss-Markov starts are one candidate: keep only its best start in the log.
        dedup_trials(&mut trials, first);
        match best {
            Some((b, c, t, _)) if b < best_bic => {
                if let Some(tr) = trials[first..]
                    .iter_mut()
                    .find(|tr| tr.bic == b && tr.chi2 == c)
                {
                    tr.accepted = true;
                }
                (best_bic, chi2, terms) = (b, c, t);
            }
            _ => break,
        }
    }
    // A term NNLS left at zero carries no information (and has no interval).
    terms.retain(|t| t.var > 0.0);
    Selection {
        terms,
        chi2,
        bic: best_bic,
        trials,
    }
}

fn dedup_trials(trials: &mut Vec<Trial>, first: usize) {
    let mut tail: Vec<Trial> = trials.drain(first..).collect();
    tail.sort_by(|a, b| a.bic.total_cmp(&b.bic));
    let mut seen: Vec<String> = Vec::new();
    for t in tail {
        if !seen.contains(&t.added) {
            seen.push(t.added.clone());
            trials.push(t);
        }
    }
}
