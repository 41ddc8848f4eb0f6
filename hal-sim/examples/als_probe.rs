//! Prototype: autocovariance least squares (ALS) on the innovations of a fixed reference filter
//! as a start-independent global stage (issue 13). f64, host only.
//!
//! cargo run --release -p hal-sim --example als_probe -- [seeds=3] [tg=7200]
#![allow(non_snake_case, clippy::needless_range_loop)]

use hal_sim::{replay, scenario, sim};
use imu_ident::model::{Component, ErrorSource, InsModel};
use nalgebra::DMatrix;

fn set_gm(m: &mut InsModel<f64>, accel: bool, tau: Option<f64>, sigma: Option<f64>) {
    let comps = if accel { &mut m.accel } else { &mut m.gyro };
    if let Some(Component::GaussMarkov(g)) = comps.first_mut() {
        if let Some(t) = tau {
            g.tau = t;
        }
        if let Some(s) = sigma {
            g.sigma = s;
        }
    }
}

fn gm(m: &InsModel<f64>, accel: bool) -> (f64, f64) {
    let sensor = if accel {
        ErrorSource::Accel
    } else {
        ErrorSource::Gyro
    };
    hal_sim::adaptive::gm_params(m, sensor).unwrap_or((f64::NAN, f64::NAN))
}

struct Sys {
    phi: DMatrix<f64>,
    qd: DMatrix<f64>,
    h: DMatrix<f64>,
    n: usize,
}

fn sys(m: &InsModel<f64>, scale: &imu_ident::model::Scaling<f64>) -> Sys {
    let (c, d) = m.discretise(scale).unwrap();
    let n = c.n;
    let phi = DMatrix::from_fn(n, n, |i, j| d.Phi[(i, j)]);
    let qd = DMatrix::from_fn(n, n, |i, j| d.Qd[(i, j)]);
    let h = DMatrix::from_fn(1, n, |_, j| c.H[j]);
    Sys { phi, qd, h, n }
}

/// Steady-state prior covariance and gain of the reference filter (Riccati iteration).
fn steady_gain(s: &Sys, r: f64) -> DMatrix<f64> {
    let mut p = DMatrix::<f64>::identity(s.n, s.n);
    for _ in 0..200_000 {
        let sv = (&s.h * &p * s.h.transpose())[(0, 0)] + r;
        let k = &p * s.h.transpose() / sv;
        let pu = &p - &k * &s.h * &p;
        let pn = &s.phi * pu * s.phi.transpose() + &s.qd;
        let d = (&pn - &p).abs().max();
        p = pn;
        if d < 1e-14 * p.abs().max() {
            break;
        }
    }
    let sv = (&s.h * &p * s.h.transpose())[(0, 0)] + r;
    &p * s.h.transpose() / sv
}

fn lyap(a: &DMatrix<f64>, w: &DMatrix<f64>) -> DMatrix<f64> {
    let mut s = w.clone();
    let mut ak = a.clone();
    for _ in 0..40 {
        let add = &ak * &s * ak.transpose();
        s += &add;
        ak = &ak * &ak;
        if ak.abs().max() < 1e-18 {
            break;
        }
    }
    s
}

/// Innovation autocovariance C(k), k = 0..kmax, of the reference filter (phi0, k0) on a truth
/// (phi, qd, r) with the same state layout (Schuler columns identical).
fn basis(ref0: &Sys, k0: &DMatrix<f64>, truth: &Sys, r: f64, kmax: usize) -> Vec<f64> {
    let n = ref0.n;
    let nc = n - 2;
    let m = nc + n;
    let mut A = DMatrix::<f64>::zeros(m, m);
    // c_{k+1} = Phi_cc c_k
    for i in 0..nc {
        for j in 0..nc {
            A[(i, j)] = truth.phi[(2 + i, 2 + j)];
        }
    }
    // x~_{k+1} = (Phi - Phi0)[:, c] c + Phi0 (I - K0 H) x~
    let cl = &ref0.phi * (DMatrix::<f64>::identity(n, n) - k0 * &ref0.h);
    for i in 0..n {
        for j in 0..nc {
            A[(nc + i, j)] = truth.phi[(i, 2 + j)] - ref0.phi[(i, 2 + j)];
        }
        for j in 0..n {
            A[(nc + i, nc + j)] = cl[(i, j)];
        }
    }
    // Noise: [S_c w; w - Phi0 K0 v]
    let mut W = DMatrix::<f64>::zeros(m, m);
    let idx = |a: usize| if a < nc { 2 + a } else { a - nc };
    for a in 0..m {
        for b in 0..m {
            W[(a, b)] = truth.qd[(idx(a), idx(b))];
        }
    }
    let g = &ref0.phi * k0; // n x 1
    for a in 0..n {
        for b in 0..n {
            W[(nc + a, nc + b)] += g[a] * g[b] * r;
        }
    }
    let S = lyap(&A, &W);
    let mut hx = DMatrix::<f64>::zeros(1, m);
    for j in 0..n {
        hx[(0, nc + j)] = ref0.h[(0, j)];
    }
    let mut gx = DMatrix::<f64>::zeros(m, 1);
    for a in 0..n {
        gx[nc + a] = -g[a];
    }
    let mut out = Vec::with_capacity(kmax + 1);
    // C(0) = h S h' + r; C(k) = h A^k S h' + h A^{k-1} g r
    let mut ak_s = S.clone() * hx.transpose(); // A^k S h'
    let mut ak1_g = gx.clone(); // A^{k-1} g
    out.push((&hx * &ak_s)[(0, 0)] + r);
    for _k in 1..=kmax {
        ak_s = &A * ak_s;
        out.push((&hx * &ak_s)[(0, 0)] + (&hx * &ak1_g)[(0, 0)] * r);
        ak1_g = &A * ak1_g;
    }
    out
}

/// Biased sample autocovariance of block means of length `b`, lags 0..=l.
fn acov_blocks(e: &[f64], b: usize, l: usize) -> (Vec<f64>, usize) {
    let x: Vec<f64> = e
        .chunks_exact(b)
        .map(|c| c.iter().sum::<f64>() / b as f64)
        .collect();
    let n = x.len();
    let m = x.iter().sum::<f64>() / n as f64;
    let out = (0..=l)
        .map(|k| (k..n).map(|i| (x[i] - m) * (x[i - k] - m)).sum::<f64>() / n as f64)
        .collect();
    (out, n)
}

/// Theoretical autocovariance of block means from the fine-lag one.
fn blocks_of(c: &[f64], b: usize, l: usize) -> Vec<f64> {
    (0..=l)
        .map(|k| {
            let mut s = 0.0;
            for i in 0..b {
                for j in 0..b {
                    let d = (k * b + i) as i64 - j as i64;
                    s += c[d.unsigned_abs() as usize];
                }
            }
            s / (b * b) as f64
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
    let tg = get("tg", 7200.0) as usize;
    let warm = get("warm", 900.0) as usize;
    let blocks: Vec<usize> = vec![1, 10, 60];
    let lags = get("lags", 40.0) as usize;
    let truth = scenario::load("paper")?.to_core()?;
    let (ta0, sa0) = gm(&truth, true);
    let (tg0, sg0) = gm(&truth, false);
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
    let grid: Vec<f64> = (0..33)
        .map(|i| 10f64.powf(0.5 + i as f64 * 0.125))
        .collect(); // 3 s .. 31623 s
    for seed in 0..seeds {
        let log = sim::simulate(&truth, 12 * 3600, 1000 + seed)?;
        for f in &starts {
            let mut start = truth.clone();
            set_gm(&mut start, true, Some(ta0 * f[1]), Some(sa0 * f[0]));
            set_gm(&mut start, false, Some(tg0 * f[3]), Some(sg0 * f[2]));
            let (est, _) = replay::estimates::<f64>(&start, &log)?;
            let e: Vec<f64> = est[warm..tg].iter().map(|r| r.innovation).collect();
            let scale = start.scaling()?;
            let ref0 = sys(&start, &scale);
            let r = start.sigma_v * start.sigma_v;
            let k0 = steady_gain(&ref0, r);
            let kmax = blocks.iter().map(|b| (lags + 1) * b).max().unwrap();
            // observed
            let mut obs: Vec<(Vec<f64>, usize)> = Vec::new();
            for &b in &blocks {
                obs.push(acov_blocks(&e, b, lags));
            }
            // R-only basis (components silenced)
            let mut quiet = start.clone();
            set_gm(&mut quiet, true, None, Some(sa0 * f[0] * 1e-9));
            set_gm(&mut quiet, false, None, Some(sg0 * f[2] * 1e-9));
            let br = basis(&ref0, &k0, &sys(&quiet, &scale), r, kmax);
            let comp_basis = |accel: bool, tau: f64| -> Vec<f64> {
                let mut m = quiet.clone();
                let s = if accel { sa0 * f[0] } else { sg0 * f[2] };
                set_gm(&mut m, accel, Some(tau), Some(s));
                let c = basis(&ref0, &k0, &sys(&m, &scale), r, kmax);
                c.iter().zip(&br).map(|(a, b)| a - b).collect()
            };
            let ba: Vec<Vec<f64>> = grid.iter().map(|&t| comp_basis(true, t)).collect();
            let bg: Vec<Vec<f64>> = grid.iter().map(|&t| comp_basis(false, t)).collect();
            // stack: y = obs - R basis; columns a, g; weights 1/(c0^2/n)
            let stack = |c: &[f64]| -> Vec<f64> {
                let mut v = Vec::new();
                for (bi, &b) in blocks.iter().enumerate() {
                    let cb = blocks_of(c, b, lags);
                    let w = (obs[bi].1 as f64).sqrt() / obs[bi].0[0];
                    v.extend(cb.iter().map(|x| x * w));
                }
                v
            };
            let mut y = Vec::new();
            for (bi, _) in blocks.iter().enumerate() {
                let w = (obs[bi].1 as f64).sqrt() / obs[bi].0[0];
                y.extend(obs[bi].0.iter().map(|x| x * w));
            }
            let yr = stack(&br);
            let y: Vec<f64> = y.iter().zip(&yr).map(|(a, b)| a - b).collect();
            let sa: Vec<Vec<f64>> = ba.iter().map(|c| stack(c)).collect();
            let sg: Vec<Vec<f64>> = bg.iter().map(|c| stack(c)).collect();
            let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
            let mut best = (f64::INFINITY, 0, 0, 0.0, 0.0);
            for i in 0..grid.len() {
                for j in 0..grid.len() {
                    let (a, g) = (&sa[i], &sg[j]);
                    let (aa, gg, ag) = (dot(a, a), dot(g, g), dot(a, g));
                    let (ay, gy) = (dot(a, &y), dot(g, &y));
                    let det = aa * gg - ag * ag;
                    let mut cands = vec![(0.0, 0.0)];
                    if det > 0.0 {
                        cands.push(((gg * ay - ag * gy) / det, (aa * gy - ag * ay) / det));
                    }
                    cands.push(((ay / aa).max(0.0), 0.0));
                    cands.push((0.0, (gy / gg).max(0.0)));
                    for (xa, xg) in cands {
                        if xa < 0.0 || xg < 0.0 {
                            continue;
                        }
                        let res: f64 = y
                            .iter()
                            .zip(a.iter().zip(g))
                            .map(|(yy, (p, q))| (yy - xa * p - xg * q).powi(2))
                            .sum();
                        if res < best.0 {
                            best = (res, i, j, xa, xg);
                        }
                    }
                }
            }
            let (res, i, j, xa, xg) = best;
            println!(
                "seed {seed} start {f:?}: tau_a {:.2}x sig_a {:.2}x tau_g {:.2}x sig_g {:.2}x  res {:.1} (n {})",
                grid[i] / ta0,
                xa.sqrt() * f[0],
                grid[j] / tg0,
                xg.sqrt() * f[2],
                res,
                y.len()
            );
        }
    }
    Ok(())
}
