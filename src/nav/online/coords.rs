//! The coordinates of the online identification: which quantities of the IMU noise model it
//! estimates, each as a base-10 logarithmic factor on a reference model, tied across a
//! sensor's three axes or one per axis (the same choice as `hal-sim nav --adapt`'s window
//! search).
//!
//! ```
//! use imu_ident::model::{Component, GaussMarkov, WhiteNoise};
//! use imu_ident::nav::online::coords::{apply, coordinates};
//! use imu_ident::nav::ImuErrorModel;
//! let mut m = ImuErrorModel::<f64>::default();
//! m.set_all_gyro(&[
//!     Component::White(WhiteNoise { density: 1e-4 }),
//!     Component::GaussMarkov(GaussMarkov { sigma: 1e-5, tau: 600.0 }),
//! ]).unwrap();
//! // Tied: white density, Gauss-Markov sigma and tau of the gyros.
//! let c = coordinates(&m, false, true).unwrap();
//! assert_eq!(c.len(), 3);
//! let m2 = apply(&m, &c, &[1.0, 0.0, 0.0]);
//! assert!((m2.gyro[2][0].white_qc().sqrt() - 1e-3).abs() < 1e-12);
//! ```

use crate::model::{ComponentKind, ModelError, Quantity};
use crate::nav::{ImuErrorModel, ImuSensor};
use crate::Real;
use heapless::Vec;

/// Most coordinates of the IMU model (for example three quantities on each of the six axes,
/// per axis).
pub const MAX_COORDS: usize = 18;

/// Coordinates on the GNSS fixes' standard deviations, when identified: a factor on the
/// position's and one on the velocity's ([`OnlineConfig::gnss_sd`](super::OnlineConfig::gnss_sd)).
pub const GNSS_COORDS: usize = 2;

/// Most coordinates in all: the IMU model's and the GNSS factors.
pub const MAX_PARAMS: usize = MAX_COORDS + GNSS_COORDS;

/// One identified quantity.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Coordinate {
    /// The sensor.
    pub sensor: ImuSensor,
    /// The axis (0, 1, 2: x, y, z), or `None` for the three axes tied.
    pub axis: Option<u8>,
    /// Index of the component on the axis (or on each of the three).
    pub component: u8,
    /// Its kind.
    pub kind: ComponentKind,
    /// The quantity.
    pub quantity: Quantity,
}

impl Coordinate {
    /// The axes it moves.
    pub fn axes(&self) -> core::ops::Range<usize> {
        match self.axis {
            Some(a) => usize::from(a)..usize::from(a) + 1,
            None => 0..3,
        }
    }
}

/// The coordinates of `model`: every identified quantity
/// ([`ComponentKind::identified`], less the exp-cosine's `beta`, held; less the correlation
/// times unless `taus`), tied across a sensor's axes unless `per_axis` or the axes carry
/// different kinds. [`ModelError::TooManyStates`] beyond [`MAX_COORDS`].
pub fn coordinates<T: Real>(
    model: &ImuErrorModel<T>,
    per_axis: bool,
    taus: bool,
) -> Result<Vec<Coordinate, MAX_COORDS>, ModelError> {
    let mut out = Vec::new();
    each_coordinate(model, per_axis, taus, |c| {
        out.push(c).map_err(|_| ModelError::TooManyStates)
    })?;
    Ok(out)
}

/// The coordinates of [`coordinates`], in its order, handed to `f` one by one (the host's
/// window search has no capacity limit); stops at `f`'s first error.
///
/// ```
/// use imu_ident::model::{Component, WhiteNoise};
/// use imu_ident::nav::online::coords::each_coordinate;
/// use imu_ident::nav::ImuErrorModel;
/// let mut m = ImuErrorModel::<f64>::default();
/// m.set_all_gyro(&[Component::White(WhiteNoise { density: 1e-4 })]).unwrap();
/// let mut n = 0;
/// each_coordinate(&m, true, true, |_| Ok::<(), ()>(n += 1)).unwrap();
/// assert_eq!(n, 3); // one white density per gyro axis
/// ```
pub fn each_coordinate<T: Real, E>(
    model: &ImuErrorModel<T>,
    per_axis: bool,
    taus: bool,
    mut f: impl FnMut(Coordinate) -> Result<(), E>,
) -> Result<(), E> {
    for s in [ImuSensor::Gyro, ImuSensor::Accel] {
        let axes = model.sensor(s);
        let same = |a: usize, b: usize| {
            axes.get(a).map(|x| x.len()) == axes.get(b).map(|x| x.len())
                && axes
                    .get(a)
                    .into_iter()
                    .flatten()
                    .zip(axes.get(b).into_iter().flatten())
                    .all(|(p, q)| p.kind() == q.kind())
        };
        let tied = !per_axis && same(0, 1) && same(1, 2);
        for a in 0..3u8 {
            if tied && a > 0 {
                break;
            }
            let Some(comps) = axes.get(usize::from(a)) else {
                continue;
            };
            for (k, c) in comps.iter().enumerate() {
                let kind = c.kind();
                for &q in kind.identified() {
                    let wanted = match q {
                        Quantity::Beta => false,
                        Quantity::Tau => taus,
                        _ => true,
                    };
                    if wanted {
                        f(Coordinate {
                            sensor: s,
                            axis: if tied { None } else { Some(a) },
                            component: k as u8,
                            kind,
                            quantity: q,
                        })?;
                    }
                }
            }
        }
    }
    Ok(())
}

/// `model` with every tied coordinate's quantity set, on each of its axes, to the geometric
/// mean over those axes: tying means one value per sensor, so a start that differs between the
/// axes must not keep its differences under a common factor.
pub fn tie<T: Real>(model: &ImuErrorModel<T>, coords: &[Coordinate]) -> ImuErrorModel<T> {
    let mut m = model.clone();
    for c in coords.iter().filter(|c| c.axis.is_none()) {
        let axes = m.sensor_mut(c.sensor);
        let (mut sum, mut n) = (T::zero(), 0u8);
        for a in c.axes() {
            let v = axes
                .get(a)
                .and_then(|comps| comps.get(usize::from(c.component)))
                .and_then(|comp| comp.get(c.quantity));
            if let Some(v) = v.filter(|v| *v > T::zero()) {
                sum += v.ln();
                n += 1;
            }
        }
        if n == 0 {
            continue;
        }
        let mean = (sum / T::lit(f64::from(n))).exp();
        for a in c.axes() {
            if let Some(comp) = axes
                .get_mut(a)
                .and_then(|comps| comps.get_mut(usize::from(c.component)))
            {
                comp.set(c.quantity, mean);
            }
        }
    }
    m
}

/// `base` with coordinate `i`'s quantity multiplied by `10^x[i]` on each of its axes.
pub fn apply<T: Real>(base: &ImuErrorModel<T>, coords: &[Coordinate], x: &[T]) -> ImuErrorModel<T> {
    let mut m = base.clone();
    for (c, &lx) in coords.iter().zip(x) {
        let f = T::lit(10.0).powf(lx);
        let axes = m.sensor_mut(c.sensor);
        for a in c.axes() {
            if let Some(comp) = axes
                .get_mut(a)
                .and_then(|comps| comps.get_mut(usize::from(c.component)))
            {
                if let Some(v) = comp.get(c.quantity) {
                    comp.set(c.quantity, v * f);
                }
            }
        }
    }
    m
}
