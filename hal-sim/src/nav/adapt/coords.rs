//! The coordinates of the online identification: what each log10 factor scales (a quantity
//! of one component of a sensor's axes, tied or per axis, or the fixes' position or velocity
//! standard deviations), the starting model tied over the axes, and a point's model and GNSS
//! factors.

use super::{AdaptConfig, TauMode};
use imu_ident::model::{ComponentKind, Quantity};
use imu_ident::nav::{ImuErrorModel, ImuSensor};
use serde::Serialize;

/// Whether the window search identifies the GNSS standard deviations by default
/// (`--adapt-gnss-sd`; chosen by measurement, BENCHMARKS.md "The GNSS noise online").
pub const GNSS_SD_DEFAULT: bool = true;

/// The quantities of the GNSS coordinates ([`AdaptConfig::gnss_sd`]): factors on the fixes'
/// position and velocity standard deviations.
pub const GNSS_SD: [&str; 2] = ["position_sd", "velocity_sd"];

/// What a coordinate scales.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Target {
    /// A quantity of one component of a sensor's axes.
    Imu(ImuSensor, Quantity),
    /// The GNSS position (0) or velocity (1) standard deviations.
    GnssSd(usize),
}

/// One identified coordinate: a quantity of a component on a set of axes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Coordinate {
    /// `gyro` or `accel`.
    pub sensor: &'static str,
    /// Axes it applies to (0 = x, 1 = y, 2 = z).
    pub axes: Vec<usize>,
    /// Index of the component on each of those axes.
    pub component: usize,
    /// The component's kind.
    pub kind: &'static str,
    /// The quantity.
    pub quantity: &'static str,
    #[serde(skip)]
    pub(super) target: Target,
}

impl Coordinate {
    /// The coordinate of the bank's `c` (an IMU quantity).
    pub fn of_bank(c: &imu_ident::nav::online::coords::Coordinate) -> Self {
        Self {
            sensor: c.sensor.name(),
            axes: c.axes().collect(),
            component: usize::from(c.component),
            kind: c.kind.name(),
            quantity: c.quantity.name(),
            target: Target::Imu(c.sensor, c.quantity),
        }
    }

    /// The factor on the GNSS fixes' position (`i = 0`) or velocity (1) standard deviations.
    pub fn gnss(i: usize) -> Self {
        Self {
            sensor: "gnss",
            axes: vec![0, 1, 2],
            component: 0,
            kind: "fix",
            quantity: GNSS_SD.get(i).copied().unwrap_or("sd"),
            target: Target::GnssSd(i),
        }
    }

    /// The GNSS standard deviation it scales (0 position, 1 velocity), if any.
    pub fn gnss_sd(&self) -> Option<usize> {
        match self.target {
            Target::GnssSd(i) => Some(i),
            Target::Imu(..) => None,
        }
    }

    /// Its axes as letters: `xyz`, `x`, ...
    pub fn axes_name(&self) -> String {
        self.axes
            .iter()
            .filter_map(|&a| crate::imu_model::AXES.get(a))
            .collect()
    }

    /// Its `adapt.csv` column: `sensor_axes_component_quantity` (`gyro_xyz_1_sigma`).
    pub fn column(&self) -> String {
        format!(
            "{}_{}_{}_{}",
            self.sensor,
            self.axes_name(),
            self.component,
            self.quantity
        )
    }

    /// Its name in the report: `gyro xyz gauss_markov sigma`.
    pub fn label(&self) -> String {
        format!(
            "{} {} {} {}",
            self.sensor,
            self.axes_name(),
            self.kind,
            self.quantity
        )
    }
}

/// The `(sigma, tau)` pairs of `coords` that are one Gauss-Markov component's (the same
/// sensor, axes and component): the pattern search's ridge moves (`nav::pattern`).
pub(super) fn ridges(coords: &[Coordinate]) -> Vec<(usize, usize)> {
    // The sensor of a Gauss-Markov component's quantity `q`.
    let gm = |c: &Coordinate, q: Quantity| match c.target {
        Target::Imu(s, cq) if cq == q && c.kind == ComponentKind::GaussMarkov.name() => Some(s),
        _ => None,
    };
    coords
        .iter()
        .enumerate()
        .filter_map(|(i, a)| {
            let sensor = gm(a, Quantity::Sigma)?;
            let j = coords.iter().position(|b| {
                gm(b, Quantity::Tau) == Some(sensor)
                    && b.axes == a.axes
                    && b.component == a.component
            })?;
            Some((i, j))
        })
        .collect()
}

/// The coordinates of `model` under `cfg`.
pub fn coordinates(model: &ImuErrorModel<f64>, cfg: &AdaptConfig) -> Vec<Coordinate> {
    let mut out = Vec::new();
    for s in [ImuSensor::Gyro, ImuSensor::Accel] {
        let axes = model.sensor(s);
        // Tied only when the three axes carry the same kinds in the same order.
        let kinds = |a: usize| axes[a].iter().map(|c| c.kind()).collect::<Vec<_>>();
        let tied = !cfg.per_axis && kinds(0) == kinds(1) && kinds(1) == kinds(2);
        let groups: Vec<Vec<usize>> = if tied {
            vec![vec![0, 1, 2]]
        } else {
            (0..3).map(|a| vec![a]).collect()
        };
        for g in groups {
            for (k, c) in axes[g[0]].iter().enumerate() {
                let kind: ComponentKind = c.kind();
                for &q in kind.identified() {
                    let wanted = match q {
                        Quantity::Beta => false,
                        Quantity::Tau => cfg.taus != TauMode::Held,
                        _ => true,
                    };
                    if wanted {
                        out.push(Coordinate {
                            sensor: s.name(),
                            axes: g.clone(),
                            component: k,
                            kind: kind.name(),
                            quantity: q.name(),
                            target: Target::Imu(s, q),
                        });
                    }
                }
            }
        }
    }
    if cfg.gnss_sd {
        out.extend((0..GNSS_SD.len()).map(Coordinate::gnss));
    }
    out
}

/// The factors on the GNSS standard deviations at `x`: `base` times the GNSS coordinates'
/// factors (`base` where there are none).
pub fn gnss_factors(base: [f64; 2], coords: &[Coordinate], x: &[f64]) -> [f64; 2] {
    let mut f = base;
    for (c, &lx) in coords.iter().zip(x) {
        if let Some(slot) = c.gnss_sd().and_then(|i| f.get_mut(i)) {
            *slot *= 10f64.powf(lx);
        }
    }
    f
}

/// `model` with every tied coordinate's quantity set, on each of its axes, to the geometric
/// mean over those axes: tying means one value per sensor, so a start that differs between
/// the axes must not keep its differences under a common factor.
pub fn tie(model: &ImuErrorModel<f64>, coords: &[Coordinate]) -> ImuErrorModel<f64> {
    let mut m = model.clone();
    for c in coords.iter().filter(|c| c.axes.len() > 1) {
        let Target::Imu(s, q) = c.target else {
            continue;
        };
        let axes = m.sensor_mut(s);
        let logs: Vec<f64> = c
            .axes
            .iter()
            .filter_map(|&a| axes[a].get(c.component).and_then(|comp| comp.get(q)))
            .map(f64::ln)
            .collect();
        let mean = (logs.iter().sum::<f64>() / logs.len() as f64).exp();
        for &a in &c.axes {
            if let Some(comp) = axes[a].get_mut(c.component) {
                comp.set(q, mean);
            }
        }
    }
    m
}

/// `base` with IMU coordinate `i`'s quantity multiplied by `10^x[i]` (the GNSS coordinates:
/// [`gnss_factors`]).
pub fn apply(base: &ImuErrorModel<f64>, coords: &[Coordinate], x: &[f64]) -> ImuErrorModel<f64> {
    let mut m = base.clone();
    for (c, &lx) in coords.iter().zip(x) {
        let Target::Imu(s, q) = c.target else {
            continue;
        };
        let axes = m.sensor_mut(s);
        for &a in &c.axes {
            if let Some(comp) = axes[a].get_mut(c.component) {
                if let Some(v) = comp.get(q) {
                    comp.set(q, v * 10f64.powf(lx));
                }
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White noise plus a Gauss-Markov on every axis of both sensors: the ridge pairs are each
    /// sensor's Gauss-Markov `(sigma, tau)`, tied or per axis, and none with the taus held.
    #[test]
    fn the_ridges_are_each_gauss_markov_sigma_and_tau() {
        use imu_ident::model::{Component, GaussMarkov, WhiteNoise};
        let mut model = ImuErrorModel::<f64>::default();
        let axis = [
            Component::White(WhiteNoise { density: 1e-4 }),
            Component::GaussMarkov(GaussMarkov {
                sigma: 1e-5,
                tau: 300.0,
            }),
        ];
        model.set_all_gyro(&axis).unwrap();
        model.set_all_accel(&axis).unwrap();
        let cfg = AdaptConfig::default();
        let c = coordinates(&model, &cfg);
        assert_eq!(ridges(&c), vec![(1, 2), (4, 5)]);
        let per_axis = coordinates(
            &model,
            &AdaptConfig {
                per_axis: true,
                ..cfg
            },
        );
        let r = ridges(&per_axis);
        assert_eq!(r.len(), 6);
        for (i, j) in r {
            assert_eq!(per_axis[i].quantity, Quantity::Sigma.name());
            assert_eq!(per_axis[j].quantity, Quantity::Tau.name());
            assert_eq!(per_axis[i].axes, per_axis[j].axes);
        }
        let held = AdaptConfig {
            taus: TauMode::Held,
            ..cfg
        };
        assert!(ridges(&coordinates(&model, &held)).is_empty());
    }
}
