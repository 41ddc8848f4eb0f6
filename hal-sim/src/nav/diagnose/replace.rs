//! "Replace this component's kind" (`nav --diagnose`, [`super`] item 8): next to adding an
//! effect, a component the model has on every axis of a sensor is replaced by its alternative
//! in the core kind table (`ComponentKind::alternative`: Gauss-Markov <-> exponential-cosine).
//! A gyro drift that *is* an exponential-cosine, modelled as a Gauss-Markov, can otherwise only
//! be named as an addition on top of the wrong component (issue 13, item 3; the one-channel
//! `diagnose` has had this since [`crate::candidates::Replacement`]).
//!
//! Parameters. The replaced component may differ per axis (`--identify-axes`), so a
//! replacement keeps the model's per-axis values and scales them: every quantity the old kind
//! also has (sigma, tau) is the old axis's value times `exp(p[i])`, one factor for the three
//! axes; a quantity only the new kind has (the exponential-cosine's period) is one value for
//! the three axes, `exp(p[i])`, as an addition's.
//!
//! The test. Both directions' families lie in the closure of the exponential-cosines with free
//! sigma, tau and `beta >= 0` (a Gauss-Markov is their `beta -> 0` limit), and so does the
//! model. On a right model a replacement's gain is therefore at most that family's, which is
//! asymptotically at most half a chi-square(3) (Wilks; `beta` on its boundary makes it a
//! mixture, which only lowers the tail). So a replacement's `k` is 3 in both directions
//! ([`NavReplacement::k`]): for Gauss-Markov -> exponential-cosine that is also the new kind's
//! own parameters, as the one-channel diagnosis charges
//! ([`crate::candidates::Proposal::free_params`]: the old values were given, not fitted, so
//! refitting them is paid for); for exponential-cosine -> Gauss-Markov, whose own are 2, the
//! chi-square(2) quantile would not bound the false alarms. An exponential-cosine is offered
//! only with half a period in its envelope ([`super::add::offered`]), so the model (the
//! period at infinity) is outside the Gauss-Markov -> exponential-cosine family and on a right
//! model its gain is often negative (-8 nats on the first fresh seeds).

use super::add::{maximise, offered, Layout};
use crate::candidates::{log_param, Candidate, Replacement};
use crate::nav::NavArgs;
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::model::{Component, ComponentKind, ErrorSource};
use imu_ident::nav::{ImuErrorModel, ImuSensor};

/// Replace component `index` of every axis of `sensor` (all of kind `old[0].kind()`) by one
/// of kind `kind`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavReplacement {
    /// The sensor.
    pub sensor: ImuSensor,
    /// Position of the component in each axis's list.
    pub index: usize,
    /// The component as the model has it on x, y, z.
    pub old: [Component<f64>; 3],
    /// The kind that replaces it.
    pub kind: ComponentKind,
    /// How many components of the old kind precede it on an axis (`[1]` in the label for a
    /// second Gauss-Markov; the one-channel list has no white noise in it, an axis's here does).
    pub ordinal: usize,
}

fn source(s: ImuSensor) -> ErrorSource {
    match s {
        ImuSensor::Gyro => ErrorSource::Gyro,
        ImuSensor::Accel => ErrorSource::Accel,
    }
}

impl NavReplacement {
    /// Every replacement of `m`: each position where the three axes of a sensor carry a
    /// component of one kind with an alternative.
    pub fn all(m: &ImuErrorModel<f64>) -> Vec<Self> {
        let mut out = Vec::new();
        for sensor in [ImuSensor::Gyro, ImuSensor::Accel] {
            let [x, y, z] = m.sensor(sensor);
            for (index, cx) in x.iter().enumerate() {
                let (Some(cy), Some(cz)) = (y.get(index), z.get(index)) else {
                    continue;
                };
                let kind = cx.kind();
                let Some(to) = kind.alternative() else {
                    continue;
                };
                if cy.kind() == kind && cz.kind() == kind {
                    let ordinal = x.iter().take(index).filter(|c| c.kind() == kind).count();
                    out.push(Self {
                        sensor,
                        index,
                        old: [*cx, *cy, *cz],
                        kind: to,
                        ordinal,
                    });
                }
            }
        }
        out
    }

    /// The test's degrees of freedom: the parameters of the family that bounds the gain on a
    /// right model, the exponential-cosine's (module docs), i.e. the larger of the two kinds'.
    pub fn k(&self) -> usize {
        let old = Candidate {
            sensor: source(self.sensor),
            kind: self.old[0].kind(),
        };
        self.target().n_params().max(old.n_params())
    }

    /// The new kind's library entry (its parameter layout and count).
    pub fn target(&self) -> Candidate {
        Candidate {
            sensor: source(self.sensor),
            kind: self.kind,
        }
    }

    /// The one-channel replacement with the x axis's component, for the label and the words.
    fn one_channel(&self) -> Replacement {
        Replacement {
            sensor: source(self.sensor),
            index: self.ordinal,
            old: self.old[0],
            kind: self.kind,
        }
    }

    /// `gyro/gauss-markov->exp-cosine` (the one-channel diagnosis's label).
    pub fn label(&self) -> String {
        self.one_channel().label()
    }

    /// What the fitted change means (the x axis's component).
    pub fn explain(&self, c: &Component<f64>) -> String {
        self.one_channel().explain(c)
    }

    /// The indices of `p` that are absolute times (the new kind's own, the period), searched
    /// within the range of times; the others are log-factors on the old values.
    pub fn time_params(&self) -> std::ops::Range<usize> {
        let own = self.own();
        own.clone().next().map_or(0..0, |i| i..own.end)
    }

    /// The `(sigma, tau)` pair of `p` a pattern search also moves along `sigma^2 / tau` =
    /// const when the new kind is a Gauss-Markov ([`Candidate::ridges`]); a factor on an old
    /// value and an absolute log-quantity move alike in log space.
    pub fn ridges(&self) -> &'static [(usize, usize)] {
        self.target().ridges()
    }

    /// The positions of the new kind's quantities the old kind lacks (a contiguous tail:
    /// sigma and tau lead every correlated kind).
    fn own(&self) -> std::ops::Range<usize> {
        let qs = self.kind.quantities();
        let first = qs
            .iter()
            .position(|q| self.old[0].get(*q).is_none())
            .unwrap_or(qs.len());
        first..qs.len()
    }

    /// The components on x, y, z for parameters `p` (module docs); `None` where one is not
    /// offered or `p` is bad.
    pub fn components(&self, p: &[f64]) -> Option<[Component<f64>; 3]> {
        let cand = self.target();
        let one = |old: &Component<f64>| {
            self.per_quantity(old, p, |l, v| l + v)
                .and_then(|lp| offered(&cand, &lp))
        };
        let [x, y, z] = &self.old;
        Some([one(x)?, one(y)?, one(z)?])
    }

    /// `m` with the component replaced on every axis; `None` if the model no longer has it,
    /// `p` is bad or the result is invalid.
    pub fn apply(&self, m: &ImuErrorModel<f64>, p: &[f64]) -> Option<ImuErrorModel<f64>> {
        let new = self.components(p)?;
        let mut out = m.clone();
        for ((axis, c), old) in out
            .sensor_mut(self.sensor)
            .iter_mut()
            .zip(new)
            .zip(self.old)
        {
            let slot = axis.get_mut(self.index)?;
            if *slot != old {
                return None;
            }
            *slot = c;
        }
        out.validate().ok()?;
        Some(out)
    }

    /// The parameters whose x-axis component is the one of absolute log-parameters `a`
    /// ([`Candidate::component`]'s layout for the new kind): the inverse of
    /// [`Self::components`] on the x axis. `None` when `a` is short or the x axis's old value
    /// is not positive.
    pub fn relative(&self, a: &[f64]) -> Option<Vec<f64>> {
        self.per_quantity(&self.old[0], a, |l, v| v - l)
    }

    /// `f(log value of old, p_i)` for each quantity of the new kind that `old` has, `p_i` as
    /// it is for one it lacks (the new kind's own); `None` when `p` is short or an old value
    /// is not positive. The one mapping behind [`Self::components`] and [`Self::relative`].
    fn per_quantity(
        &self,
        old: &Component<f64>,
        p: &[f64],
        f: impl Fn(f64, f64) -> f64,
    ) -> Option<Vec<f64>> {
        let qs = self.kind.quantities();
        if p.len() < qs.len() {
            return None;
        }
        qs.iter()
            .zip(p)
            .map(|(q, v)| match old.get(*q) {
                Some(o) if o > 0.0 && o.is_finite() => Some(f(log_param(*q, o), *v)),
                Some(_) => None,
                None => Some(*v),
            })
            .collect()
    }

    /// Starting points: factors 1 with each of the additions' starting periods (120, 600,
    /// 3000 s), and the same periods with the x axis's tau at the additions' two periods
    /// (their envelope); factors 1 alone when the new kind has no quantity of its own.
    pub fn starts(&self) -> Vec<Vec<f64>> {
        let own = self.own();
        let n = self.kind.quantities().len();
        if own.is_empty() {
            return vec![vec![0.0; n]];
        }
        let tau_x = self.old[0]
            .get(imu_ident::model::Quantity::Tau)
            .filter(|t| *t > 0.0);
        let mut out: Vec<Vec<f64>> = Vec::new();
        for s in self.target().starts_at(1.0) {
            let mut p = vec![0.0; n];
            for i in own.clone() {
                if let (Some(v), Some(w)) = (p.get_mut(i), s.get(i)) {
                    *v = *w;
                }
            }
            out.push(p.clone());
            // The additions' envelope, `s[1]`, as a factor on the x axis's tau.
            if let (Some(t), Some(v), Some(w)) = (tau_x, p.get_mut(1), s.get(1)) {
                *v = w - t.ln();
                out.push(p);
            }
        }
        out
    }
}

/// The maximum-likelihood parameters of replacement `r` (module docs): its parameters, their
/// log-likelihood and the runs spent. The same pattern search as the additions', factors
/// within three decades of 1 and the new kind's own times within the range of times, from
/// the best of [`NavReplacement::starts`] and, when the addition of the new kind was fitted
/// (its log-parameters `added`, [`Candidate::component`]'s layout), that component in place
/// of the old one ([`NavReplacement::relative`]): the addition's answer without the component
/// it was added to.
pub(super) fn fit(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    r: &NavReplacement,
    added: Option<&[f64]>,
) -> Result<(Vec<f64>, f64, usize)> {
    let model_at = |p: &[f64]| r.apply(&args.model, p);
    let mut starts = r.starts();
    starts.extend(added.and_then(|a| r.relative(a)));
    let layout = Layout {
        times: r.time_params(),
        ridges: r.ridges(),
    };
    maximise(args, imu, fixes, &model_at, starts, layout)
}

#[cfg(test)]
mod tests {
    use super::*;
    use imu_ident::model::{ExpCosine, GaussMarkov, WhiteNoise};
    use std::f64::consts::PI;

    /// A gyro Gauss-Markov that differs per axis: one replacement, whose factors scale each
    /// axis's own values, whose period is shared, and which changes nothing else; and back.
    #[test]
    fn a_replacement_scales_each_axis_and_shares_the_period() {
        let mut m = ImuErrorModel::default();
        let white = Component::White(WhiteNoise { density: 1e-4 });
        let gm = |sigma: f64| Component::GaussMarkov(GaussMarkov { sigma, tau: 300.0 });
        for (axis, s) in m.gyro.iter_mut().zip([1e-5, 2e-5, 4e-5]) {
            assert!(axis.push(white).is_ok() && axis.push(gm(s)).is_ok());
        }
        assert!(m.set_all_accel(&[white]).is_ok());
        let all = NavReplacement::all(&m);
        assert_eq!(all.len(), 1);
        let r = all[0];
        assert_eq!(r.label(), "gyro/gauss-markov->exp-cosine");
        assert_eq!(r.time_params(), 2..3);
        // [ln sigma factor, ln tau factor, ln period]: sigma x2, tau x4, period 900 s.
        let p = [2f64.ln(), 4f64.ln(), 900f64.ln()];
        let m2 = r.apply(&m, &p).unwrap();
        for (axis, s) in m2.gyro.iter().zip([1e-5, 2e-5, 4e-5]) {
            assert_eq!(axis[0], white);
            let Component::ExpCosine(e) = axis[1] else {
                panic!("replaced by an exp-cosine")
            };
            assert!((e.sigma / (2.0 * s) - 1.0).abs() < 1e-12);
            assert!((e.tau - 1200.0).abs() < 1e-9);
            assert!((2.0 * PI / e.beta - 900.0).abs() < 1e-9);
        }
        assert_eq!(m2.accel, m.accel);
        // `relative` is the inverse on the x axis: the absolute [ln sigma, ln tau, ln period].
        let abs = [2e-5f64.ln(), 1200f64.ln(), 900f64.ln()];
        let rel = r.relative(&abs).unwrap();
        assert!(
            rel.iter().zip(&p).all(|(a, b)| (a - b).abs() < 1e-12),
            "{rel:?}"
        );
        // Half a period in the envelope on every axis, or not offered.
        assert!(r.apply(&m, &[0.0, 0.0, 601f64.ln()]).is_none());
        assert!(r.apply(&m, &[0.0, 0.0, 599f64.ln()]).is_some());
        // Starts: factors 1 and the envelope of the additions (tau = 2 period), each period.
        let starts = r.starts();
        assert_eq!(starts.len(), 6);
        assert!(starts.iter().all(|s| s[0] == 0.0));
        // The reverse on the replaced model: factors only, one start, sigma and tau kept.
        let back = NavReplacement::all(&m2)[0];
        assert_eq!(back.label(), "gyro/exp-cosine->gauss-markov");
        assert_eq!(back.starts(), [vec![0.0, 0.0]]);
        assert_eq!((r.k(), back.k()), (3, 3));
        assert!(back.time_params().is_empty());
        let m3 = back.apply(&m2, &[0.0, 0.0]).unwrap();
        let Component::GaussMarkov(g) = m3.gyro[2][1] else {
            panic!("back to a Gauss-Markov")
        };
        assert!((g.sigma - 8e-5).abs() < 1e-15 && (g.tau - 1200.0).abs() < 1e-9);
        // A stale replacement applies to nothing.
        assert!(back.apply(&m, &[0.0, 0.0]).is_none());
        // Axes of different kinds at a position: no replacement there.
        let mut mixed = m.clone();
        let ec = Component::ExpCosine(ExpCosine::new(1e-5, 1200.0, 0.01).unwrap());
        mixed.gyro[0][1] = ec;
        assert!(NavReplacement::all(&mixed).is_empty());
        // A second Gauss-Markov is labelled by its place among the Gauss-Markovs.
        let mut two = m.clone();
        for axis in two.gyro.iter_mut() {
            assert!(axis.push(gm(1e-6)).is_ok());
        }
        let labels: Vec<String> = NavReplacement::all(&two)
            .iter()
            .map(|r| r.label())
            .collect();
        assert_eq!(
            labels,
            [
                "gyro/gauss-markov->exp-cosine",
                "gyro/gauss-markov[1]->exp-cosine"
            ]
        );
    }
}
