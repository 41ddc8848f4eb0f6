//! The additions of `nav --diagnose` ([`super`] items 2 and 3): which candidates of the table
//! are offered on a model, and each one's maximum-likelihood fit, added to the three axes of
//! its sensor with one set of parameters.

use crate::candidates::Candidate;
use crate::nav::identify::loglik;
use crate::nav::NavArgs;
use crate::nav_io::{GnssFix, ImuSample};
use anyhow::Result;
use imu_ident::adapt::window::structure::MIN_QUALITY;
use imu_ident::model::{Component, ComponentKind, ErrorSource};
use imu_ident::nav::{
    ImuErrorModel, ImuSensor, NavInit, NavPoint, StrapdownErrorModel, NAV_N, NAV_Z,
};
use nalgebra::Vector3;

/// Pattern-search steps [natural-log units].
const STEPS: [f64; 4] = [2.0, 1.0, 0.5, 0.25];
/// Half-width of a coordinate's interval about its start [natural-log units]: three decades.
const HALF_WIDTH: f64 = 6.907_755_278_982_137;
/// Interval of a correlation time [s].
const TAU_RANGE: (f64, f64) = (10.0, 1e5);

pub(super) fn imu_sensor(s: ErrorSource) -> Option<ImuSensor> {
    match s {
        ErrorSource::Gyro => Some(ImuSensor::Gyro),
        ErrorSource::Accel => Some(ImuSensor::Accel),
        ErrorSource::Observation => None,
    }
}

/// The typical error magnitude of one sensor in `m`: the largest over its axes of the sum of
/// the components' magnitudes (the one-channel table's `sensor_scale`), with the same defaults
/// when it has none.
fn sensor_scale(m: &ImuErrorModel<f64>, s: ImuSensor) -> f64 {
    let v = m
        .sensor(s)
        .iter()
        .map(|a| a.iter().map(|c| c.magnitude()).sum::<f64>())
        .fold(0.0, f64::max);
    match s {
        _ if v > 0.0 && v.is_finite() => v,
        ImuSensor::Accel => 1e-3,
        ImuSensor::Gyro => 0.1f64.to_radians() / 3600.0,
    }
}

/// `m` with component `c[i]` added to axis `i` of sensor `s` (none where `c[i]` is `None`);
/// `None` when an axis is full or the model is invalid.
pub(super) fn with_axes(
    m: &ImuErrorModel<f64>,
    s: ImuSensor,
    c: &[Option<Component<f64>>; 3],
) -> Option<ImuErrorModel<f64>> {
    let mut out = m.clone();
    for (axis, c) in out.sensor_mut(s).iter_mut().zip(c) {
        if let Some(c) = c {
            axis.push(*c).ok()?;
        }
    }
    out.validate().ok()?;
    Some(out)
}

/// `m` with `c` on every axis of sensor `s`; `None` when an axis is full.
pub(super) fn with_component(
    m: &ImuErrorModel<f64>,
    s: ImuSensor,
    c: Component<f64>,
) -> Option<ImuErrorModel<f64>> {
    with_axes(m, s, &[Some(c); 3])
}

/// The filter's states for the noise model `imu` (the core's count: navigation errors, the
/// components, the scale factors of `--scale-factors`).
pub(super) fn filter_states(imu: ImuErrorModel<f64>, scale_factor_sd: Option<[f64; 2]>) -> usize {
    StrapdownErrorModel {
        imu,
        init: NavInit {
            sd_att: Vector3::repeat(1.0),
            sd_vel: 1.0,
            sd_pos: 1.0,
        },
        lever_arm: Vector3::zeros(),
        obs_sd: [1.0; NAV_Z],
        point: NavPoint::at_rest(0.0, 0.0),
        dt: 1.0,
        scale_factor_sd,
    }
    .states()
}

/// Why `cand` is not tested on `m`, if it is not.
pub(super) fn skip_reason(
    m: &ImuErrorModel<f64>,
    scale_factor_sd: Option<[f64; 2]>,
    cand: &Candidate,
) -> Option<&'static str> {
    let Some(s) = imu_sensor(cand.sensor) else {
        return Some("not a sensor of the strapdown model");
    };
    if cand.kind == ComponentKind::White {
        return Some("a magnitude: fitted by --identify");
    }
    let has = m
        .sensor(s)
        .iter()
        .flat_map(|a| a.iter())
        .any(|c| c.kind() == cand.kind);
    if has && cand.kind != ComponentKind::GaussMarkov {
        return Some("the model has one already");
    }
    let probe = cand
        .starts_at(1.0)
        .into_iter()
        .next()
        .and_then(|p| cand.component(&p));
    let fits = probe
        .and_then(|c| with_component(m, s, c))
        .is_some_and(|m2| filter_states(m2, scale_factor_sd) <= NAV_N);
    (!fits).then_some("does not fit the filter's states")
}

/// The component of `cand` at log-parameters `p` ([`Candidate::component`]), `None` where it is
/// not offered: an exponential-cosine whose envelope holds less than half a period,
/// `beta tau <` [`MIN_QUALITY`] `= pi`, the online structure test's rule. Such a one is a
/// Gauss-Markov of another spectral shape, not an oscillation; the one-channel structure test
/// found the null's best alternatives there (BENCHMARKS.md "Structure online, 2026-11-27";
/// `docs/ADAPTATION.md` §7.6).
pub(super) fn offered(cand: &Candidate, p: &[f64]) -> Option<Component<f64>> {
    cand.component(p).filter(|c| match c {
        Component::ExpCosine(e) => e.beta * e.tau >= MIN_QUALITY,
        _ => true,
    })
}

/// The maximum-likelihood parameters of `cand` on sensor `s` (module docs, item 3): the
/// log-parameters, their log-likelihood and the runs spent.
pub(super) fn fit(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    cand: &Candidate,
    s: ImuSensor,
) -> Result<(Vec<f64>, f64, usize)> {
    let model_at = |p: &[f64]| offered(cand, p).and_then(|c| with_component(&args.model, s, c));
    let starts = cand.starts_at(sensor_scale(&args.model, s));
    let layout = Layout {
        times: cand.time_params(),
        ridges: cand.ridges(),
    };
    maximise(args, imu, fixes, &model_at, starts, layout)
}

/// Which log-parameters of a fit are times (searched within [`TAU_RANGE`], not about their
/// start) and which `(sigma, tau)` pairs also move along `sigma^2 / tau` = const.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    /// The times.
    pub times: std::ops::Range<usize>,
    /// The Gauss-Markov pairs ([`Candidate::ridges`]).
    pub ridges: &'static [(usize, usize)],
}

/// The maximum likelihood over the models `model_at(p)` (`None`: not offered): the best of
/// `starts`, then the pattern search ([`search`]) from it; the parameters, their
/// log-likelihood and the runs spent.
pub(super) fn maximise(
    args: &NavArgs,
    imu: &[ImuSample],
    fixes: &[GnssFix],
    model_at: &dyn Fn(&[f64]) -> Option<ImuErrorModel<f64>>,
    starts: Vec<Vec<f64>>,
    layout: Layout,
) -> Result<(Vec<f64>, f64, usize)> {
    let mut a = args.clone();
    let mut n = 0usize;
    let mut eval = |p: &[f64]| -> Result<f64> {
        n += 1;
        match model_at(p) {
            Some(m) => {
                a.model = m;
                loglik(&a, imu, fixes)
            }
            None => Ok(f64::NEG_INFINITY),
        }
    };
    let mut best: Option<(Vec<f64>, f64)> = None;
    for p in starts {
        let ll = eval(&p)?;
        if best.as_ref().is_none_or(|(_, b)| ll > *b) {
            best = Some((p, ll));
        }
    }
    let Some((mut x, mut ll)) = best else {
        return Ok((Vec::new(), f64::NEG_INFINITY, n));
    };
    search(&mut x, &mut ll, layout.times, layout.ridges, &mut eval)?;
    Ok((x, ll, n))
}

/// The pattern search of item 3 from `x` (whose log-likelihood is `ll`): natural-log steps
/// [`STEPS`], every coordinate within three decades of its start except the `times` (a
/// correlation time, a period), within [`TAU_RANGE`]; the `ridges`, a Gauss-Markov's
/// `(sigma, tau)`, also moved along `sigma^2 / tau` = const ([`crate::nav::pattern`]).
/// Updates `x` and `ll`.
pub(super) fn search(
    x: &mut [f64],
    ll: &mut f64,
    times: std::ops::Range<usize>,
    ridges: &[(usize, usize)],
    eval: &mut dyn FnMut(&[f64]) -> Result<f64>,
) -> Result<()> {
    let centre = x.to_vec();
    let bounds = |i: usize| {
        let c = centre.get(i).copied()?;
        Some(if times.contains(&i) {
            (TAU_RANGE.0.ln(), TAU_RANGE.1.ln())
        } else {
            (c - HALF_WIDTH, c + HALF_WIDTH)
        })
    };
    crate::nav::pattern::maximise(x, ll, &STEPS, 4, &bounds, ridges, eval)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exp_cosine_is_offered_with_half_a_period_in_its_envelope() {
        let ec = Candidate {
            sensor: ErrorSource::Gyro,
            kind: ComponentKind::ExpCosine,
        };
        // [ln sigma, ln tau, ln period]: beta tau = 2 pi tau / period >= pi iff period <= 2 tau.
        let p = |tau: f64, period: f64| [1e-5f64.ln(), tau.ln(), period.ln()];
        assert!(offered(&ec, &p(1200.0, 900.0)).is_some());
        assert!(offered(&ec, &p(1200.0, 2399.0)).is_some());
        assert!(offered(&ec, &p(1200.0, 2401.0)).is_none());
        assert_eq!(ec.time_params(), 1..3);
        let walk = Candidate {
            sensor: ErrorSource::Gyro,
            kind: ComponentKind::RandomWalk,
        };
        assert!(walk.time_params().is_empty());
        assert!(skip_reason(&ImuErrorModel::default(), None, &ec).is_none());
    }

    #[test]
    fn candidates_the_model_has_or_cannot_hold_are_skipped() {
        use imu_ident::model::{RandomWalk, WhiteNoise};
        let mut m = ImuErrorModel::default();
        let white = Component::White(WhiteNoise { density: 1e-3 });
        let walk = Component::RandomWalk(RandomWalk {
            q: 1e-10,
            sigma0: 0.0,
        });
        assert!(m.set_all_gyro(&[white, walk]).is_ok());
        assert!(m.set_all_accel(&[white]).is_ok());
        let reason = |m: &ImuErrorModel<f64>, sensor, kind| {
            skip_reason(m, None, &Candidate { sensor, kind })
        };
        assert!(reason(&m, ErrorSource::Gyro, ComponentKind::RandomWalk).is_some());
        assert!(reason(&m, ErrorSource::Gyro, ComponentKind::White).is_some());
        assert!(reason(&m, ErrorSource::Observation, ComponentKind::GaussMarkov).is_some());
        assert_eq!(
            reason(&m, ErrorSource::Accel, ComponentKind::RandomWalk),
            None
        );
        assert_eq!(
            reason(&m, ErrorSource::Gyro, ComponentKind::GaussMarkov),
            None
        );
        // 9 + 3 (gyro walk) + 3 per added component: a 24-state filter holds four more.
        let gm = Component::GaussMarkov(imu_ident::model::GaussMarkov {
            sigma: 1e-3,
            tau: 100.0,
        });
        assert!(m.set_all_accel(&[white, gm, gm, gm]).is_ok());
        assert_eq!(filter_states(m.clone(), None), 21);
        // The six scale-factor states of `--scale-factors` count too.
        assert_eq!(filter_states(m.clone(), Some([0.01, 0.01])), 27);
        assert_eq!(
            skip_reason(
                &m,
                Some([0.01, 0.01]),
                &Candidate {
                    sensor: ErrorSource::Gyro,
                    kind: ComponentKind::RandomConstant
                }
            ),
            Some("does not fit the filter's states")
        );
        assert_eq!(
            reason(&m, ErrorSource::Gyro, ComponentKind::RandomConstant),
            None
        );
        assert!(m.set_all_gyro(&[white, walk, gm]).is_ok());
        assert_eq!(
            reason(&m, ErrorSource::Accel, ComponentKind::RandomWalk),
            Some("does not fit the filter's states")
        );
    }
}
