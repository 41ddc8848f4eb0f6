//! Prototype: a start-independent global stage by maximum likelihood on block means over a
//! buffered window (issue 13). f64, host only.
#![allow(clippy::needless_range_loop)]

use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use hal_sim::adaptive::tilt_window;
use hal_sim::log::LogRow;
use hal_sim::{replay, scenario, sim};
use imu_ident::model::InsModel;

#[path = "bench_args/mod.rs"]
mod bench_args;
use bench_args::ml::{set, simplex, theta};

struct Nll<'a> {
    base: &'a InsModel<f64>,
    log: &'a [LogRow],
}
impl CostFunction for Nll<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, Error> {
        if p.iter().any(|v| !v.is_finite() || v.abs() > 60.0)
            || p[1] < self.base.dt.ln()
            || p[3] < self.base.dt.ln()
            || p[1] > 13.8
            || p[3] > 13.8
        {
            return Ok(f64::INFINITY);
        }
        match replay::log_likelihood(&set(self.base, p), self.log) {
            Ok((ll, _)) if ll.is_finite() => Ok(-ll),
            _ => Ok(f64::INFINITY),
        }
    }
}

fn nm(
    base: &InsModel<f64>,
    log: &[LogRow],
    x0: &[f64],
    step: f64,
    iters: u64,
) -> (Vec<f64>, f64, u64) {
    let res = Executor::new(
        Nll { base, log },
        NelderMead::new(simplex(x0, step))
            .with_sd_tolerance(0.01)
            .unwrap(),
    )
    .configure(|st| st.max_iters(iters))
    .run()
    .unwrap();
    let n = res.state.get_func_counts().values().sum::<u64>();
    (
        res.state.get_best_param().cloned().unwrap(),
        res.state.get_best_cost(),
        n,
    )
}

fn decimate(log: &[LogRow], m: usize) -> Vec<LogRow> {
    log.chunks_exact(m)
        .map(|c| LogRow {
            t: c[m - 1].t,
            z: c.iter().map(|r| r.z).sum::<f64>() / m as f64,
            truth: None,
        })
        .collect()
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let get = |k: &str, d: f64| {
        args.iter()
            .find_map(|a| {
                a.strip_prefix(&format!("{k}="))
                    .and_then(|v| v.parse().ok())
            })
            .unwrap_or(d)
    };
    let seeds = get("seeds", 3.0) as u64;
    let first = get("first", 1000.0) as u64;
    let dec = get("dec", 10.0) as usize;
    let hours = get("hours", 8.0);
    let truth = scenario::load("paper")?.to_core()?;
    let th0 = theta(&truth);
    let starts: Vec<[f64; 4]> = vec![
        [1.0, 1.0, 1.0, 1.0],
        [10.0, 1.0, 10.0, 1.0],
        [0.1, 1.0, 0.1, 1.0],
        [9.3, 0.14, 6.9, 0.19],
        [1.9, 7.4, 3.8, 0.87],
        [0.12, 0.30, 0.14, 0.73],
        [10.0, 10.0, 10.0, 10.0],
        [0.1, 0.1, 0.1, 0.1],
    ];
    let (t0, t1) = (8.0 * 3600.0, 12.0 * 3600.0 + 1.0);
    let nfit = (hours * 3600.0) as usize;
    for seed in first..first + seeds {
        let log = sim::simulate(&truth, 12 * 3600, seed)?;
        let tilt = |m: &InsModel<f64>| {
            let (e, _) = replay::estimates::<f64>(m, &log).unwrap();
            tilt_window(&log, &e, t0, t1).unwrap().0
        };
        let oracle = tilt(&truth);
        // ML reference: full-rate fit over hours 0-8 from the truth.
        let (pref, _, _) = if get("noref", 0.0) > 0.5 {
            (th0.clone(), 0.0, 0)
        } else {
            nm(&truth, &log[..8 * 3600], &th0, 0.5, 200)
        };
        let mlref = tilt(&set(&truth, &pref));
        println!(
            "seed {seed}: ML ref {:.3}x  theta-truth {:?}",
            mlref / oracle,
            pref.iter()
                .zip(&th0)
                .map(|(a, b)| format!("{:.2}", (a - b).exp()))
                .collect::<Vec<_>>()
        );
        let mut dbase = truth.clone();
        dbase.dt = dec as f64;
        dbase.sigma_v = truth.sigma_v / (dec as f64).sqrt();
        let dlog = decimate(&log[..nfit], dec);
        if let Ok(pts) = std::env::var("EVAL") {
            for pt in pts.split(';') {
                let f: Vec<f64> = pt.split(',').map(|v| v.parse().unwrap()).collect();
                let th: Vec<f64> = th0.iter().zip(&f).map(|(a, k)| a + k.ln()).collect();
                let c = Nll {
                    base: &dbase,
                    log: &dlog,
                }
                .cost(&th)
                .unwrap();
                let cf = Nll {
                    base: &truth,
                    log: &log[..nfit],
                }
                .cost(&th)
                .unwrap();
                println!(
                    "  {pt}: decimated -ll {c:.2}, full-rate -ll {cf:.2}, tilt {:.3}x",
                    tilt(&set(&truth, &th)) / oracle
                );
            }
            continue;
        }
        for f in &starts {
            let ts = std::time::Instant::now();
            let s0: Vec<f64> = th0.iter().zip(f.iter()).map(|(a, k)| a + k.ln()).collect();
            let cost = Nll {
                base: &dbase,
                log: &dlog,
            };
            let mut best: (Vec<f64>, f64);
            let mut evals = 0u64;
            if get("compass", 0.0) > 0.5 {
                // compass search: +-step along each axis and along each component's ridge
                // (sigma up by step/2, tau down by step), step 10x -> halved in log when no move
                let mut x = s0.clone();
                let mut fx = cost.cost(&x).unwrap();
                evals += 1;
                let mut step = 10f64.ln();
                let mut dirs: Vec<Vec<f64>> = Vec::new();
                for i in 0..4 {
                    let mut d = vec![0.0; 4];
                    d[i] = 1.0;
                    dirs.push(d.clone());
                    d[i] = -1.0;
                    dirs.push(d);
                }
                for c in 0..2 {
                    for sg in [1.0, -1.0] {
                        let mut d = vec![0.0; 4];
                        d[2 * c] = 0.5 * sg;
                        d[2 * c + 1] = -sg;
                        dirs.push(d);
                    }
                }
                while step > get("minstep", 0.02) {
                    let mut moved = false;
                    let mut bestd: Option<(Vec<f64>, f64)> = None;
                    for d in &dirs {
                        let y: Vec<f64> = x.iter().zip(d).map(|(a, b)| a + step * b).collect();
                        let fy = cost.cost(&y).unwrap();
                        evals += 1;
                        if fy < fx && bestd.as_ref().is_none_or(|b| fy < b.1) {
                            bestd = Some((y, fy));
                        }
                    }
                    if let Some((y, fy)) = bestd {
                        x = y;
                        fx = fy;
                        moved = true;
                    }
                    if !moved {
                        step *= 0.5;
                    }
                }
                best = (x, fx);
            } else {
                // coarse grid: factors 10^{-1,0,1} around the start in each of 4 log-parameters
                let mut pts: Vec<(f64, Vec<f64>)> = Vec::new();
                let l10 = 10f64.ln();
                for a in 0..81 {
                    let mut p = s0.clone();
                    let mut q = a;
                    for i in 0..4 {
                        p[i] += ((q % 3) as f64 - 1.0) * l10;
                        q /= 3;
                    }
                    let c = cost.cost(&p).unwrap();
                    pts.push((c, p));
                }
                pts.sort_by(|a, b| a.0.partial_cmp(&b.0).unwrap());
                best = (s0.clone(), f64::INFINITY);
                evals = 81;
                for (_, p) in pts.iter().take(3) {
                    let (q, c, n) = nm(&dbase, &dlog, p, 1.0, 150);
                    evals += n;
                    if c < best.1 {
                        best = (q, c);
                    }
                }
            }
            let m = set(&truth, &best.0);
            let r = tilt(&m);
            println!(
                "  start {f:?}: {:.3}x oracle, {:.3}x ML ref; est/truth {:?} evals {evals} {:.1}s",
                r / oracle,
                r / mlref,
                best.0
                    .iter()
                    .zip(&th0)
                    .map(|(a, b)| format!("{:.2}", (a - b).exp()))
                    .collect::<Vec<_>>(),
                ts.elapsed().as_secs_f64()
            );
        }
    }
    Ok(())
}
