//! The coordinates of the online identification: what each log10 factor scales (a quantity
//! of one component of a sensor's axes, tied or per axis, or the fixes' position or velocity
//! standard deviations), the starting model tied over the axes, and a point's model and GNSS
//! factors.

use super::{AdaptConfig, TauMode};
use imu_ident::model::{ComponentKind, Quantity};
use imu_ident::nav::online::coords as online;
use imu_ident::nav::ImuErrorModel;
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
    /// A quantity of one component of a sensor's axes: the core's coordinate, which the
    /// model's [`tie`] and [`apply`] go through.
    Imu(online::Coordinate),
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
    /// The coordinate of the core's `c` (an IMU quantity; the bank's, or the window
    /// search's from [`coordinates`]).
    pub fn of_core(c: &online::Coordinate) -> Self {
        Self {
            sensor: c.sensor.name(),
            axes: c.axes().collect(),
            component: usize::from(c.component),
            kind: c.kind.name(),
            quantity: c.quantity.name(),
            target: Target::Imu(*c),
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

    /// The core's coordinate of an IMU quantity (`None` for a GNSS factor).
    pub fn imu(&self) -> Option<online::Coordinate> {
        match self.target {
            Target::Imu(c) => Some(c),
            Target::GnssSd(_) => None,
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
    let gm = |c: &Coordinate, q: Quantity| {
        c.imu()
            .filter(|k| k.quantity == q && k.kind == ComponentKind::GaussMarkov)
            .map(|k| k.sensor)
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

/// The coordinates of `model` under `cfg`: the core's ([`online::each_coordinate`], the bank's
/// order), then the GNSS factors.
pub fn coordinates(model: &ImuErrorModel<f64>, cfg: &AdaptConfig) -> Vec<Coordinate> {
    let mut out = Vec::new();
    let taus = cfg.taus != TauMode::Held;
    let Ok(()) = online::each_coordinate(model, cfg.per_axis, taus, |c| {
        out.push(Coordinate::of_core(&c));
        Ok::<(), std::convert::Infallible>(())
    });
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
/// mean over those axes ([`online::tie`]).
pub fn tie(model: &ImuErrorModel<f64>, coords: &[Coordinate]) -> ImuErrorModel<f64> {
    let imu: Vec<online::Coordinate> = coords.iter().filter_map(Coordinate::imu).collect();
    online::tie(model, &imu)
}

/// `base` with IMU coordinate `i`'s quantity multiplied by `10^x[i]` ([`online::apply`]; the
/// GNSS coordinates: [`gnss_factors`]).
pub fn apply(base: &ImuErrorModel<f64>, coords: &[Coordinate], x: &[f64]) -> ImuErrorModel<f64> {
    let (imu, lx): (Vec<online::Coordinate>, Vec<f64>) = coords
        .iter()
        .zip(x)
        .filter_map(|(c, &lx)| Some((c.imu()?, lx)))
        .unzip();
    online::apply(base, &imu, &lx)
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
