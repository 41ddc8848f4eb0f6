//! The coordinate pattern search shared by `nav --identify` ([`super::identify`]), the
//! online identification ([`super::adapt`]) and the diagnosis's candidate fits
//! ([`super::diagnose`]): every coordinate is tried up and down by the
//! current step, a move is kept as soon as it raises the objective, passes repeat while one
//! did (at most `max_passes` per step), then the step shrinks. Given `ridges`, pairs of
//! coordinates `(sigma, tau)` of one Gauss-Markov component, each pass also tries their
//! move along `sigma^2 / tau` = const (`sigma` by the step, `tau` by twice it, both up or both
//! down): short windows bound that ratio far better than either quantity, and steps along one
//! axis at a time stop on that ridge (from a start with every standard deviation 3x, the
//! online search ended with sigma 3x and tau 10x, 12-17 nats below the true model: BENCHMARKS.md
//! "The window search along the Gauss-Markov ridge"). Hand-written rather than a
//! crate (argmin): a handful of deterministic coordinates, no gradients, and the objective is
//! a whole filter run that may fail with an error worth reporting.

use anyhow::Result;

/// Maximises `eval` from `x` (whose value is `best`) over the steps `steps` in turn;
/// `bounds(i)` gives coordinate `i`'s interval, `None` to leave it out; `ridges` the
/// `(sigma, tau)` pairs also moved together (module docs; a pair with a coordinate left out is
/// not). Updates `x` and `best`.
pub fn maximise(
    x: &mut [f64],
    best: &mut f64,
    steps: &[f64],
    max_passes: usize,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    ridges: &[(usize, usize)],
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<()> {
    // Each move: the coordinates it changes, with their bounds and multiples of the step.
    type Move = Vec<(usize, (f64, f64), f64)>;
    let mut moves: Vec<Move> = (0..x.len())
        .filter_map(|i| bounds(i).map(|b| vec![(i, b, 1.0)]))
        .collect();
    for &(s, t) in ridges {
        if let (Some(bs), Some(bt), true) = (bounds(s), bounds(t), s.max(t) < x.len()) {
            moves.push(vec![(s, bs, 1.0), (t, bt, 2.0)]);
        }
    }
    let mut y = x.to_vec();
    for &step in steps {
        let mut improved = true;
        let mut passes = 0;
        while improved && passes < max_passes {
            improved = false;
            passes += 1;
            for m in &moves {
                for dir in [1.0, -1.0] {
                    y.copy_from_slice(x);
                    for &(i, (lo, hi), k) in m {
                        y[i] = (y[i] + dir * k * step).clamp(lo, hi);
                    }
                    // A move that a bound stops on any of its coordinates is not tried.
                    if m.iter().any(|&(i, ..)| y[i] == x[i]) {
                        continue;
                    }
                    let ll = eval(&y)?;
                    if ll > *best {
                        *best = ll;
                        x.copy_from_slice(&y);
                        improved = true;
                        break;
                    }
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A narrow ridge along `t = 2 s` (the Gauss-Markov `sigma^2 / tau` in log10), highest at
    /// the origin: one coordinate at a time, every step off the ridge costs more than it
    /// gains, so the search stays at its start; the ridge move walks along it to the maximum.
    #[test]
    fn a_ridge_move_walks_along_sigma_squared_over_tau() {
        let f = |x: &[f64]| -100.0 * (2.0 * x[0] - x[1]).powi(2) - x[0] * x[0];
        let all = |_: usize| Some((-2.0, 2.0));
        let run = |ridges: &[(usize, usize)]| {
            let mut x = vec![0.5, 1.0];
            let mut best = f(&x);
            maximise(
                &mut x,
                &mut best,
                &[1.0, 0.5, 0.25, 0.125],
                6,
                &all,
                ridges,
                &mut |y| Ok(f(y)),
            )
            .unwrap();
            (x, best)
        };
        let (x, best) = run(&[]);
        assert_eq!(
            x,
            vec![0.5, 1.0],
            "one coordinate at a time stops on the ridge"
        );
        assert_eq!(best, -0.25);
        let (x, best) = run(&[(0, 1)]);
        assert_eq!(x, vec![0.0, 0.0], "along the ridge to its maximum");
        assert_eq!(best, 0.0);
        // A pair with a coordinate left out does not move.
        let held = |i: usize| (i == 0).then_some((-2.0, 2.0));
        let mut x = vec![0.5, 1.0];
        let mut best = f(&x);
        maximise(&mut x, &mut best, &[0.5], 6, &held, &[(0, 1)], &mut |y| {
            Ok(f(y))
        })
        .unwrap();
        assert_eq!(x, vec![0.5, 1.0]);
    }
}
