//! Fitting a candidate change's parameters by maximum innovation likelihood.
//!
//! The base model stays fixed (apart from the replaced component, for a replacement); the
//! candidate's log-parameters are fitted with Nelder-Mead
//! (argmin) from each of the candidate's starting points, and the best is kept. The likelihood
//! is the core filter's own (`replay::log_likelihood`, through the firmware's step): no second copy of the filter.

use crate::candidates::Proposal;
use crate::log::LogRow;
use crate::replay::log_likelihood;
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use imu_ident::model::{Component, InsModel};

/// Iterations per Nelder-Mead run: enough for 1-3 log-parameters to settle to ~0.01 in log
/// space (about 1 % relative), far below their statistical spread.
const MAX_ITERS: u64 = 60;

/// The result of fitting one candidate.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The candidate: an addition or a replacement.
    pub candidate: Proposal,
    /// Fitted log-parameters.
    pub params: Vec<f64>,
    /// The fitted component.
    pub component: Component<f64>,
    /// Log-likelihood of the model with the candidate applied.
    pub log_likelihood: f64,
    /// Likelihood evaluations spent.
    pub evaluations: u64,
}

struct NegLogLik<'a> {
    base: &'a InsModel<f64>,
    candidate: Proposal,
    log: &'a [LogRow],
}

impl CostFunction for NegLogLik<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        // Parameters outside the physical range (or a model that does not fit) cost +inf, so
        // the simplex walks back; a bounded log range keeps it away from overflow.
        if p.iter().any(|v| !v.is_finite() || v.abs() > 80.0) {
            return Ok(f64::INFINITY);
        }
        let Some(m) = self.candidate.apply(self.base, p) else {
            return Ok(f64::INFINITY);
        };
        match log_likelihood(&m, self.log) {
            Ok((ll, _)) if ll.is_finite() => Ok(-ll),
            _ => Ok(f64::INFINITY),
        }
    }
}

/// Initial simplex around `x0`: one vertex per parameter, a factor e^0.7 (about 2x) away.
fn simplex(x0: &[f64]) -> Vec<Vec<f64>> {
    let mut s = vec![x0.to_vec()];
    for i in 0..x0.len() {
        let mut v = x0.to_vec();
        v[i] += 0.7;
        s.push(v);
    }
    s
}

/// Refines a fit with a second Nelder-Mead run from its optimum with a smaller simplex: the
/// first run stops at `MAX_ITERS`, which can leave a 3-parameter fit a few log-likelihood units
/// short — enough to swap two close candidates.
pub fn refine(base: &InsModel<f64>, f: &Fit, log: &[LogRow]) -> Fit {
    let cost = NegLogLik {
        base,
        candidate: f.candidate,
        log,
    };
    let mut s = vec![f.params.clone()];
    for i in 0..f.params.len() {
        let mut v = f.params.clone();
        v[i] += 0.2;
        s.push(v);
    }
    let run = NelderMead::new(s)
        .with_sd_tolerance(0.01)
        .ok()
        .and_then(|solver| {
            Executor::new(cost, solver)
                .configure(|st| st.max_iters(2 * MAX_ITERS))
                .run()
                .ok()
        });
    let Some(res) = run else { return f.clone() };
    let ll = -res.state.get_best_cost();
    let evaluations = f.evaluations + res.state.get_func_counts().values().sum::<u64>();
    match res.state.get_best_param().cloned() {
        Some(p) if ll > f.log_likelihood => match f.candidate.component(&p) {
            Some(component) => Fit {
                candidate: f.candidate,
                params: p,
                component,
                log_likelihood: ll,
                evaluations,
            },
            None => f.clone(),
        },
        _ => Fit {
            evaluations,
            ..f.clone()
        },
    }
}

/// Fits `candidate` (a library candidate to add, or any [`Proposal`]) applied to `base` on
/// `log`; `None` if no start gave a finite likelihood.
///
/// Every starting point is evaluated once and Nelder-Mead runs from the best of them: the starts
/// span decades of time scale, and the likelihood separates them clearly, so one local search
/// suffices and the fit costs about a third of searching from every start.
pub fn fit(base: &InsModel<f64>, candidate: impl Into<Proposal>, log: &[LogRow]) -> Option<Fit> {
    let candidate = candidate.into();
    let cost = NegLogLik {
        base,
        candidate,
        log,
    };
    let mut evaluations = 0;
    let mut x0: Option<(Vec<f64>, f64)> = None;
    for s in candidate.starts(base) {
        evaluations += 1;
        let c = cost.cost(&s).unwrap_or(f64::INFINITY);
        if c.is_finite() && x0.as_ref().is_none_or(|(_, b)| c < *b) {
            x0 = Some((s, c));
        }
    }
    let (x0, _) = x0?;
    let solver = NelderMead::new(simplex(&x0)).with_sd_tolerance(0.05).ok()?;
    let res = Executor::new(cost, solver)
        .configure(|s| s.max_iters(MAX_ITERS))
        .run()
        .ok()?;
    evaluations += res.state.get_func_counts().values().sum::<u64>();
    let p = res.state.get_best_param().cloned()?;
    let ll = -res.state.get_best_cost();
    let component = candidate.component(&p)?;
    ll.is_finite().then_some(Fit {
        candidate,
        params: p,
        component,
        log_likelihood: ll,
        evaluations,
    })
}
