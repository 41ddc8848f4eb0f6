//! Where the named effect sits: the named candidate's tied fit untied over the three axes of
//! its sensor (`nav --diagnose`, after the verdict; [`super`] items 5 and 7).
//!
//! A candidate is added to the x, y and z axes with one set of parameters. A real IMU's axes
//! differ (one gyro nearer a heat source, a forward accelerometer with its own mounting
//! stress), and an effect on one axis, tied, is fitted at a compromise on all three: too
//! small where it is, present where it is not. So, once an effect is named:
//! 1. **Split.** Its magnitude (log-parameter 0 of every kind: a Gauss-Markov's or a random
//!    constant's sigma, a random walk's q) is freed per axis; the other parameters (a
//!    Gauss-Markov's tau) stay shared. Fitted by the same pattern search as the candidates,
//!    from the tied answer (its likelihood known), magnitudes within three decades of it.
//! 2. **Test of the split.** The tied fit is the split with equal magnitudes: two parameters
//!    fewer. The split is significant when it gains more than half the chi-square(2)
//!    `1 - ALPHA` quantile (Wilks); an effect the same on every axis is split in at most
//!    `ALPHA` of logs.
//! 3. **Which axes need it.** When the split is significant, the component is dropped from one
//!    axis at a time (the other two as fitted): the data need it on that axis when the loss
//!    exceeds half the chi-square(1) `1 - ALPHA` quantile. (The magnitude's null value zero
//!    is on its boundary, so the law is a mixture with a point mass at zero and the quantile is
//!    conservative: an axis without the effect is said to need it in at most `ALPHA` of logs.)
//!    The diagnosed model carries the component on the axes that need it, unless dropping the
//!    others together loses more than half the chi-square(number dropped) `1 - ALPHA` quantile,
//!    or no axis needs it on its own (an effect shared by two axes, each replaceable by the
//!    other's): then on all three, split.

use super::add::{offered, search, with_axes, with_component};
use super::{half_chi2_quantile, ComponentJson, ALPHA};
use crate::candidates::Candidate;
use crate::nav::identify::loglik;
use crate::nav::NavArgs;
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::model::Component;
use imu_ident::nav::{ImuErrorModel, ImuSensor};
use serde::Serialize;

/// The named effect split over the axes (module docs).
#[derive(Debug, Clone, Serialize)]
pub struct AxisSplit {
    /// The fitted component on x, y, z (FRD body axes).
    pub axes: [ComponentJson; 3],
    /// Log-likelihood of the split (gate off).
    pub loglik: f64,
    /// Gain over the tied fit [nats].
    pub gain_nats: f64,
    /// Half the chi-square(2) `1 - ALPHA` quantile [nats].
    pub threshold_nats: f64,
    /// The split gains more than its threshold, or (`--diagnose-axes`) the split is what
    /// named the effect.
    pub significant: bool,
    /// With a significant split: the loss of dropping the component from x, y, z alone [nats].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub drop_loss_nats: Option<[f64; 3]>,
    /// Half the chi-square(1) `1 - ALPHA` quantile [nats].
    pub drop_threshold_nats: f64,
    /// The axes of the diagnosed model that carry the component.
    pub on_axes: [bool; 3],
    /// Log-likelihood of the diagnosed model (gate off).
    pub loglik_final: f64,
    /// Filter runs spent here (with `--diagnose-axes`, the split's fit is counted with its
    /// candidate).
    pub evaluations: usize,
}

impl AxisSplit {
    /// `x, z` for the axes that carry the component.
    pub fn axes_label(&self) -> String {
        let names = ["x", "y", "z"];
        let on: Vec<&str> = names
            .iter()
            .zip(self.on_axes)
            .filter_map(|(n, on)| on.then_some(*n))
            .collect();
        on.join(", ")
    }

    /// One paragraph of the report.
    pub fn html(&self) -> String {
        let fitted: Vec<String> = ["x", "y", "z"]
            .iter()
            .zip(&self.axes)
            .map(|(n, j)| {
                let v: Vec<String> = j
                    .quantities()
                    .iter()
                    .filter_map(|(k, v)| v.filter(|v| *v != 0.0).map(|v| format!("{k} {v:.3e}")))
                    .collect();
                format!("{n}: {}", v.join(", "))
            })
            .collect();
        let drops = self.drop_loss_nats.map_or(String::new(), |d| {
            format!(
                " Dropping it from one axis loses x {:.1}, y {:.1}, z {:.1} nats (needed above \
                 {:.1}).",
                d[0], d[1], d[2], self.drop_threshold_nats
            )
        });
        format!(
            "<p>Per axis (magnitude untied): {}. Gain over the tied fit {:.1} nats against \
             {:.1}: {}.{drops} The diagnosed model carries it on {}.</p>",
            fitted.join("; "),
            self.gain_nats,
            self.threshold_nats,
            if self.significant {
                "the axes differ"
            } else {
                "the same on every axis, as far as the data tell"
            },
            self.axes_label()
        )
    }
}

/// The components of the split's log-parameters `x = [m_x, m_y, m_z, shared...]`.
fn components(cand: &Candidate, x: &[f64]) -> Option<[Component<f64>; 3]> {
    let shared = x.get(3..)?;
    let one = |i: usize| {
        let mut p = Vec::with_capacity(1 + shared.len());
        p.push(*x.get(i)?);
        p.extend_from_slice(shared);
        offered(cand, &p)
    };
    Some([one(0)?, one(1)?, one(2)?])
}

/// A candidate's tied fit, which its split starts from.
#[derive(Debug, Clone, Copy)]
pub(super) struct TiedFit<'a> {
    /// The candidate.
    pub cand: &'a Candidate,
    /// Its sensor.
    pub sensor: ImuSensor,
    /// Its fitted log-parameters ([`Candidate::component`]).
    pub p: &'a [f64],
    /// Their log-likelihood.
    pub ll: f64,
}

/// The split of a candidate (module docs, item 1) from its tied fit `t`: the log-parameters
/// `[m_x, m_y, m_z, shared...]`, their log-likelihood and the runs spent.
pub(super) fn fit_split(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    t: TiedFit,
) -> Result<(Vec<f64>, f64, usize)> {
    let (cand, s, tied) = (t.cand, t.sensor, t.p);
    let Some(&m0) = tied.first() else {
        anyhow::bail!("nav --diagnose: {} has no parameters", cand.label());
    };
    let mut a = args.clone();
    let mut n = 0usize;
    let mut x: Vec<f64> = [m0, m0, m0]
        .into_iter()
        .chain(tied.iter().skip(1).copied())
        .collect();
    let mut ll = t.ll;
    // A Gauss-Markov's tau (an exp-cosine's tau and period) follows the three magnitudes: the
    // tied layout's times, two places on.
    let times = cand.time_params();
    // No ridge moves: the correlation time is shared, so `sigma^2 / tau` = const for one
    // axis's magnitude is not that line for the other two.
    search(
        &mut x,
        &mut ll,
        times.start + 2..times.end + 2,
        &[],
        &mut |p: &[f64]| {
            n += 1;
            match model_of(&args.model, cand, s, p, [true; 3]) {
                Some(m) => {
                    a.model = m;
                    loglik(&a, imu, fixes)
                }
                None => Ok(f64::NEG_INFINITY),
            }
        },
    )?;
    Ok((x, ll, n))
}

/// `m` with the split `x` of `cand` on the axes `on` of sensor `s`.
fn model_of(
    m: &ImuErrorModel<f64>,
    cand: &Candidate,
    s: ImuSensor,
    x: &[f64],
    on: [bool; 3],
) -> Option<ImuErrorModel<f64>> {
    let c = components(cand, x)?;
    let pick = |i: usize| on[i].then_some(c[i]);
    with_axes(m, s, &[pick(0), pick(1), pick(2)])
}

/// Splits the named candidate from its tied fit `t` (module docs), or takes the split
/// already fitted (`fitted`,
/// as [`fit_split`] returns it). With `named_split` the split was what named the candidate
/// (`--diagnose-axes`): it is kept whatever its gain over the tied fit, and only the axes are
/// tested. Returns the split and the diagnosed model.
pub(super) fn split(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    t: TiedFit,
    fitted: Option<(Vec<f64>, f64, usize)>,
    named_split: bool,
) -> Result<(AxisSplit, ImuErrorModel<f64>)> {
    let (cand, s, tied, ll_tied) = (t.cand, t.sensor, t.p, t.ll);
    // 1. The split, from the tied answer.
    // A split fitted with the candidates has its runs counted there.
    let (x, ll, n_fit) = match fitted {
        Some((x, ll, _)) => (x, ll, 0),
        None => fit_split(args, imu, fixes, t)?,
    };
    let mut a = args.clone();
    let mut n = n_fit;
    let mut eval_model = |m: Option<ImuErrorModel<f64>>| -> Result<f64> {
        n += 1;
        match m {
            Some(m) => {
                a.model = m;
                loglik(&a, imu, fixes)
            }
            None => Ok(f64::NEG_INFINITY),
        }
    };
    let model_of = |x: &[f64], on: [bool; 3]| model_of(&args.model, cand, s, x, on);
    // 2. The test of the split.
    let threshold = half_chi2_quantile(1.0 - ALPHA, 2)?;
    let drop_threshold = half_chi2_quantile(1.0 - ALPHA, 1)?;
    let significant = named_split || ll - ll_tied > threshold;
    // 3. Which axes need it.
    let (mut on_axes, mut drop_loss) = ([true; 3], None);
    let mut ll_final = if significant { ll } else { ll_tied };
    if significant {
        let mut loss = [0.0; 3];
        for (i, l) in loss.iter_mut().enumerate() {
            let mut on = [true; 3];
            on[i] = false;
            *l = ll - eval_model(model_of(&x, on))?;
        }
        let needed = loss.map(|l| l > drop_threshold);
        let dropped = needed.iter().filter(|n| !**n).count();
        if dropped > 0 && dropped < 3 {
            let ll_needed = eval_model(model_of(&x, needed))?;
            if ll - ll_needed <= half_chi2_quantile(1.0 - ALPHA, dropped)? {
                on_axes = needed;
                ll_final = ll_needed;
            }
        }
        drop_loss = Some(loss);
    }
    let comps = components(cand, &x)
        .ok_or_else(|| anyhow::anyhow!("nav --diagnose: the split of {}", cand.label()))?;
    let model = if significant {
        model_of(&x, on_axes)
    } else {
        let c = cand.component(tied);
        c.and_then(|c| with_component(&args.model, s, c))
    }
    .ok_or_else(|| anyhow::anyhow!("nav --diagnose: {} no longer fits", cand.label()))?;
    Ok((
        AxisSplit {
            axes: comps.map(|c| ComponentJson::of(&c)),
            loglik: ll,
            gain_nats: ll - ll_tied,
            threshold_nats: threshold,
            significant,
            drop_loss_nats: drop_loss,
            drop_threshold_nats: drop_threshold,
            on_axes,
            loglik_final: ll_final,
            evaluations: n,
        },
        model,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::candidates::Candidate;
    use imu_ident::model::{ComponentKind, ErrorSource};

    #[test]
    fn the_split_frees_the_magnitude_and_shares_the_rest() {
        let gm = Candidate {
            sensor: ErrorSource::Accel,
            kind: ComponentKind::GaussMarkov,
        };
        let x = [1e-3f64.ln(), 2e-3f64.ln(), 3e-3f64.ln(), 100f64.ln()];
        let c = components(&gm, &x).unwrap_or_else(|| panic!("no components"));
        for (i, c) in c.iter().enumerate() {
            let j = ComponentJson::of(c);
            let sigma = j.sigma.unwrap_or(f64::NAN);
            assert!((sigma - 1e-3 * (i + 1) as f64).abs() < 1e-12, "{j:?}");
            assert!((j.tau.unwrap_or(f64::NAN) - 100.0).abs() < 1e-9, "{j:?}");
        }
        // A component on x and z only: the y axis keeps what it had.
        let m = ImuErrorModel::default();
        let out = with_axes(&m, ImuSensor::Accel, &[Some(c[0]), None, Some(c[2])])
            .unwrap_or_else(|| panic!("does not fit"));
        let lens: Vec<usize> = out.accel.iter().map(|a| a.len()).collect();
        assert_eq!(lens, [1, 0, 1]);
        let split = AxisSplit {
            axes: c.map(|c| ComponentJson::of(&c)),
            loglik: 0.0,
            gain_nats: 10.0,
            threshold_nats: 4.6,
            significant: true,
            drop_loss_nats: Some([20.0, 0.1, 8.0]),
            drop_threshold_nats: 3.3,
            on_axes: [true, false, true],
            loglik_final: 0.0,
            evaluations: 0,
        };
        assert_eq!(split.axes_label(), "x, z");
    }
}
