//! The coordinate pattern search shared by `nav --identify` ([`super::identify`]) and the
//! online identification ([`super::adapt`]): every coordinate is tried up and down by the
//! current step, a move is kept as soon as it raises the objective, passes repeat while one
//! did (at most `max_passes` per step), then the step shrinks. Hand-written rather than a
//! crate (argmin): a handful of deterministic coordinates, no gradients, and the objective is
//! a whole filter run that may fail with an error worth reporting.

use anyhow::Result;

/// Maximises `eval` from `x` (whose value is `best`) over the steps `steps` in turn;
/// `bounds(i)` gives coordinate `i`'s interval, `None` to leave it out. Updates `x` and `best`.
pub fn maximise(
    x: &mut [f64],
    best: &mut f64,
    steps: &[f64],
    max_passes: usize,
    bounds: &dyn Fn(usize) -> Option<(f64, f64)>,
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<()> {
    let mut y = x.to_vec();
    for &step in steps {
        let mut improved = true;
        let mut passes = 0;
        while improved && passes < max_passes {
            improved = false;
            passes += 1;
            for i in 0..x.len() {
                let Some((lo, hi)) = bounds(i) else { continue };
                for dir in [1.0, -1.0] {
                    y.copy_from_slice(x);
                    y[i] = (y[i] + dir * step).clamp(lo, hi);
                    if y[i] == x[i] {
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
