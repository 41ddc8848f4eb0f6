//! The noise model of a six-axis IMU: for each of the three gyros and three accelerometers a sum
//! of the crate's noise components ([`Component`]: white, Gauss-Markov, exp-cosine, random walk,
//! random constant), in sensor units (rad/s for gyros, m/s^2 for accelerometers), body FRD axes.
//!
//! ```
//! use imu_ident::model::{Component, GaussMarkov, WhiteNoise};
//! use imu_ident::nav::ImuErrorModel;
//! let mut m = ImuErrorModel::<f64>::default();
//! m.set_all_gyro(&[
//!     Component::White(WhiteNoise { density: 6.6e-5 }),
//!     Component::GaussMarkov(GaussMarkov { sigma: 5e-4, tau: 300.0 }),
//! ]).unwrap();
//! assert_eq!(m.states(), 3);
//! ```

use crate::model::{Component, ModelError};
use crate::Real;
use heapless::Vec;

/// Most components on one sensor axis.
pub const MAX_AXIS_COMPONENTS: usize = 4;

/// The components of one sensor axis, summed.
pub type AxisModel<T> = Vec<Component<T>, MAX_AXIS_COMPONENTS>;

/// Which sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ImuSensor {
    /// Gyro, rad/s.
    Gyro,
    /// Accelerometer (specific force), m/s^2.
    Accel,
}

impl ImuSensor {
    /// `"gyro"` or `"accel"`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Gyro => "gyro",
            Self::Accel => "accel",
        }
    }
}

/// Per-axis noise components of the gyros and accelerometers.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ImuErrorModel<T: Real> {
    /// Gyro components, axes x, y, z (FRD).
    pub gyro: [AxisModel<T>; 3],
    /// Accelerometer components, axes x, y, z (FRD).
    pub accel: [AxisModel<T>; 3],
}

impl<T: Real> ImuErrorModel<T> {
    /// No component on any axis (usable in `const` items).
    pub const EMPTY: Self = Self {
        gyro: [Vec::new(), Vec::new(), Vec::new()],
        accel: [Vec::new(), Vec::new(), Vec::new()],
    };

    /// The components of one sensor's axes.
    pub fn sensor(&self, s: ImuSensor) -> &[AxisModel<T>; 3] {
        match s {
            ImuSensor::Gyro => &self.gyro,
            ImuSensor::Accel => &self.accel,
        }
    }

    /// Mutable access to one sensor's axes.
    pub fn sensor_mut(&mut self, s: ImuSensor) -> &mut [AxisModel<T>; 3] {
        match s {
            ImuSensor::Gyro => &mut self.gyro,
            ImuSensor::Accel => &mut self.accel,
        }
    }

    /// Sets the same components on the three gyro axes.
    pub fn set_all_gyro(&mut self, comps: &[Component<T>]) -> Result<(), ModelError> {
        set_all(&mut self.gyro, comps)
    }

    /// Sets the same components on the three accelerometer axes.
    pub fn set_all_accel(&mut self, comps: &[Component<T>]) -> Result<(), ModelError> {
        set_all(&mut self.accel, comps)
    }

    /// Number of filter states the components add (white noise adds none).
    pub fn states(&self) -> usize {
        self.gyro
            .iter()
            .chain(self.accel.iter())
            .flat_map(|a| a.iter())
            .map(|c| c.states())
            .sum()
    }

    /// Checks every component.
    pub fn validate(&self) -> Result<(), ModelError> {
        for c in self
            .gyro
            .iter()
            .chain(self.accel.iter())
            .flat_map(|a| a.iter())
        {
            c.validate()?;
        }
        Ok(())
    }

    /// The model in another precision.
    pub fn cast<U: Real>(&self) -> ImuErrorModel<U> {
        let conv = |axes: &[AxisModel<T>; 3]| {
            let mut out: [AxisModel<U>; 3] = Default::default();
            for (o, a) in out.iter_mut().zip(axes.iter()) {
                for c in a.iter() {
                    // Same capacity: cannot fail.
                    let _ = o.push(c.cast());
                }
            }
            out
        };
        ImuErrorModel {
            gyro: conv(&self.gyro),
            accel: conv(&self.accel),
        }
    }
}

fn set_all<T: Real>(
    axes: &mut [AxisModel<T>; 3],
    comps: &[Component<T>],
) -> Result<(), ModelError> {
    if comps.len() > MAX_AXIS_COMPONENTS {
        return Err(ModelError::TooManyStates);
    }
    for a in axes.iter_mut() {
        a.clear();
        for c in comps {
            a.push(*c).map_err(|_| ModelError::TooManyStates)?;
        }
    }
    Ok(())
}
