//! The benches' maximum-likelihood reference (issue 13): an offline Nelder-Mead fit of a
//! model's identified parameters to a log, run afterwards as a fixed filter, "the best that the
//! data allow" (`anystart_bench`, `change_bench`).

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use hal_sim::log::LogRow;
use hal_sim::replay;
use imu_ident::adapt::params::{apply, specs, theta_of, MAXP};
use imu_ident::model::InsModel;

/// `m` at the `ln` parameters `th` (the core's mapping, `imu_ident::adapt::params`).
pub fn set(m: &InsModel<f64>, th: &[f64]) -> InsModel<f64> {
    let sp = specs(m);
    let mut t = [0.0; MAXP];
    for (o, v) in t.iter_mut().zip(th) {
        *o = *v;
    }
    apply(m, &sp, &t).unwrap_or_else(|| m.clone())
}

/// The `ln` parameters of `m` (accelerometer sigma, tau, gyro sigma, tau for `paper`).
pub fn theta(m: &InsModel<f64>) -> Vec<f64> {
    let sp = specs(m);
    theta_of(m, &sp)[..sp.len()].to_vec()
}

/// The negative log-likelihood of `log` under `base` at `ln` parameters, summed over the ticks
/// at or after `from` [s] (the earlier ones are filtered, not counted; `-inf`: every tick).
struct Nll<'a> {
    base: &'a InsModel<f64>,
    log: &'a [LogRow],
    from: f64,
    /// Lower bounds of the `ln` parameters, by coordinate (missing: none).
    floor: &'a [f64],
}
impl CostFunction for Nll<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        if p.iter().any(|v| !v.is_finite() || v.abs() > 60.0)
            || p[1] < 0.0
            || p[3] < 0.0
            || p.iter().zip(self.floor).any(|(v, f)| v < f)
        {
            return Ok(f64::INFINITY);
        }
        let ll = if self.from.is_finite() {
            replay::estimates::<f64>(&set(self.base, p), self.log).map(|(rows, _)| {
                rows.iter()
                    .filter(|r| r.t >= self.from)
                    .filter_map(|r| r.log_likelihood_term())
                    .sum::<f64>()
            })
        } else {
            replay::log_likelihood(&set(self.base, p), self.log).map(|(ll, _)| ll)
        };
        match ll {
            Ok(ll) if ll.is_finite() => Ok(-ll),
            _ => Ok(f64::INFINITY),
        }
    }
}

/// Offline maximum-likelihood fit: Nelder-Mead (restarted once from its optimum) from the truth
/// and from the best point of a grid of factors 10^{-1, 0, 1} around it (81 points, on 10-s
/// block means, `docs/ADAPTATION.md` §7); the one with the higher full-rate likelihood. The
/// likelihood is multi-modal: on some seeds the maximum is not the local one near the truth.
/// `from`: the likelihood counts the ticks at or after this time [s] (`f64::NEG_INFINITY`: all).
pub fn ml_fit(base: &InsModel<f64>, log: &[LogRow], from: f64) -> (Vec<f64>, Vec<f64>, f64, f64) {
    let local = nm_fit(base, log, theta(base), from);
    let mut dbase = base.clone();
    dbase.dt *= 10.0;
    dbase.sigma_v /= 10f64.sqrt();
    let dlog: Vec<LogRow> = log
        .chunks_exact(10)
        .map(|c| LogRow {
            t: c[9].t,
            z: c.iter().map(|r| r.z).sum::<f64>() / 10.0,
            truth: None,
        })
        .collect();
    let dcost = Nll {
        base: &dbase,
        log: &dlog,
        from,
        floor: &[],
    };
    let th0 = theta(base);
    let mut best = (f64::INFINITY, th0.clone());
    for a in 0..81 {
        let mut p = th0.clone();
        let mut q = a;
        for v in p.iter_mut() {
            *v += ((q % 3) as f64 - 1.0) * 10f64.ln();
            q /= 3;
        }
        let c = dcost.cost(&p).unwrap();
        if c < best.0 {
            best = (c, p);
        }
    }
    let global = nm_fit(base, log, best.1, from);
    let cost = Nll {
        base,
        log,
        from,
        floor: &[],
    };
    let (cl, cg) = (cost.cost(&local).unwrap(), cost.cost(&global).unwrap());
    (local, global, -cl, -cg)
}

/// The log-likelihood of `log` under `base` at the `ln` parameters `th`, every tick counted
/// (`-inf` where the model is invalid).
pub fn loglik(base: &InsModel<f64>, log: &[LogRow], th: &[f64]) -> f64 {
    let nll = Nll {
        base,
        log,
        from: f64::NEG_INFINITY,
        floor: &[],
    };
    -nll.cost(&th.to_vec()).unwrap_or(f64::INFINITY)
}

/// Nelder-Mead from `x0` (simplex steps 0.5 then 0.15 in `ln`), the ticks at or after `from`.
pub fn nm_fit(base: &InsModel<f64>, log: &[LogRow], x0: Vec<f64>, from: f64) -> Vec<f64> {
    nm_fit_above(base, log, x0, from, &[])
}

/// [`nm_fit`] with lower bounds `floor` on the `ln` parameters (by coordinate).
pub fn nm_fit_above(
    base: &InsModel<f64>,
    log: &[LogRow],
    x0: Vec<f64>,
    from: f64,
    floor: &[f64],
) -> Vec<f64> {
    let mut x = x0;
    for step in [0.5, 0.15] {
        let res = Executor::new(
            Nll {
                base,
                log,
                from,
                floor,
            },
            NelderMead::new(simplex(&x, step))
                .with_sd_tolerance(0.002)
                .unwrap(),
        )
        .configure(|st| st.max_iters(300))
        .run()
        .unwrap();
        x = res.state.get_best_param().cloned().unwrap();
    }
    x
}

/// The starting simplex of a Nelder-Mead search: `x` and `x + step e_i` for every `i`.
pub fn simplex(x: &[f64], step: f64) -> Vec<Vec<f64>> {
    let mut s = vec![x.to_vec()];
    for i in 0..x.len() {
        let mut v = x.to_vec();
        v[i] += step;
        s.push(v);
    }
    s
}
