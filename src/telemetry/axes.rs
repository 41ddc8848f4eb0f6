//! Telemetry of an estimator over any error model: one [`AxesRecord`] per tick with `Z`
//! observation axes and `N` states, and one [`IdentRecord`] per identified parameter after a
//! re-identification. Sent to an [`AxesSink`]; the one-channel [`Record`](super::Record) and
//! its wire frame are the `Z = 1` Schuler model's own, unchanged.
//!
//! ```
//! use imu_ident::telemetry::{AxesRecord, AxesSink, GATED_OUTLIER};
//! let mut got = Vec::new();
//! let mut sink = |r: &AxesRecord<2, 4>| got.push(*r);
//! let mut r = AxesRecord::<2, 4>::default();
//! r.axis_flags[1] = GATED_OUTLIER;
//! sink.record(&r);
//! assert!(got[0].axis_has(1, GATED_OUTLIER) && !got[0].axis_has(0, GATED_OUTLIER));
//! ```

use crate::adapt::params::ParamSpec;
use crate::model::Quantity;

/// One tick of an estimator with `Z` observation axes and `N` states. Per axis: the
/// observation, the innovation, its variance and the axis's flags ([`MISSING`](super::MISSING),
/// [`GATED_OUTLIER`](super::GATED_OUTLIER), [`P_REPAIRED`](super::P_REPAIRED) for a bad
/// innovation variance). For the tick: the NIS of the finite axes (the sum of the sequential
/// `nu_k^2 / S_k`, which is the vector NIS `nu^T S^-1 nu` of an observation that was used) and
/// its degrees of freedom, the estimate of every state in physical units with its standard
/// deviation (the model's named blocks say which state is which), and the tick's flags (the
/// one-channel bits; [`MISSING`](super::MISSING) when every axis was missing).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxesRecord<const Z: usize, const N: usize> {
    /// Step index since the start of the run.
    pub k: u32,
    /// Time of the observation [s].
    pub t: f64,
    /// Observation per axis (NaN when missing).
    pub z: [f32; Z],
    /// Innovation per axis (NaN when missing).
    pub innovation: [f32; Z],
    /// Innovation variance per axis.
    pub variance: [f32; Z],
    /// Flags per axis.
    pub axis_flags: [u16; Z],
    /// NIS of the finite axes (NaN when none).
    pub nis: f32,
    /// Number of finite axes.
    pub dof: u8,
    /// State estimates in physical units (inactive states 0).
    pub x: [f32; N],
    /// Their standard deviations.
    pub sigma: [f32; N],
    /// The tick's flags.
    pub flags: u16,
}

impl<const Z: usize, const N: usize> Default for AxesRecord<Z, N> {
    fn default() -> Self {
        Self {
            k: 0,
            t: 0.0,
            z: [0.0; Z],
            innovation: [0.0; Z],
            variance: [0.0; Z],
            axis_flags: [0; Z],
            nis: 0.0,
            dof: 0,
            x: [0.0; N],
            sigma: [0.0; N],
            flags: 0,
        }
    }
}

impl<const Z: usize, const N: usize> AxesRecord<Z, N> {
    /// True when every bit of `flag` is set in the tick's flags.
    pub const fn has(&self, flag: u16) -> bool {
        self.flags & flag == flag
    }

    /// True when every bit of `flag` is set on axis `axis` (false for an axis out of range).
    pub fn axis_has(&self, axis: usize, flag: u16) -> bool {
        self.axis_flags.get(axis).is_some_and(|f| f & flag == flag)
    }

    /// Writes the record as one defmt frame (arrays as slices).
    #[cfg(feature = "defmt")]
    pub fn log(&self) {
        defmt::info!(
            "tlmz k={=u32} t={=f64} z={=[?]} nu={=[?]} s={=[?]} af={=[?]} nis={=f32} dof={=u8} x={=[?]} sx={=[?]} flags={=u16}",
            self.k,
            self.t,
            &self.z[..],
            &self.innovation[..],
            &self.variance[..],
            &self.axis_flags[..],
            self.nis,
            self.dof,
            &self.x[..],
            &self.sigma[..],
            self.flags
        );
    }
}

/// One identified parameter of any model, sent after a re-identification: which quantity of
/// which component, its value and the Cramér-Rao standard deviation of its logarithm.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IdentRecord {
    /// Tick index.
    pub k: u32,
    /// Time [s].
    pub t: f64,
    /// The parameter: sensor, component index, quantity.
    pub spec: ParamSpec,
    /// Its value, `exp(theta_i)`, in the quantity's unit.
    pub value: f32,
    /// Cramér-Rao standard deviation of `theta_i = ln value` (NaN: not available).
    pub sd_ln: f32,
    /// The last window search did not identify it (sd above the identifiable bound).
    pub flat: bool,
}

impl IdentRecord {
    /// Wire code of a quantity: its position in [`Quantity::ALL`].
    pub fn quantity_code(q: Quantity) -> u8 {
        Quantity::ALL
            .iter()
            .position(|a| *a == q)
            .unwrap_or(u8::MAX as usize) as u8
    }

    /// Writes the record as one defmt frame.
    #[cfg(feature = "defmt")]
    pub fn log(&self) {
        defmt::info!(
            "idp k={=u32} t={=f64} sensor={=u8} comp={=u8} kind={=u8} value={=f32} sd_ln={=f32} flat={=bool}",
            self.k,
            self.t,
            super::sensor_code(self.spec.sensor),
            self.spec.index,
            Self::quantity_code(self.spec.kind),
            self.value,
            self.sd_ln,
            self.flat
        );
    }
}

/// Where an estimator over any error model sends its telemetry: implemented by
/// [`DefmtSink`](super::DefmtSink) and, for the records alone, by closures.
pub trait AxesSink<const Z: usize, const N: usize> {
    /// Takes one tick's record.
    fn record(&mut self, record: &AxesRecord<Z, N>);

    /// Takes one identified parameter (default: dropped).
    fn ident(&mut self, _p: &IdentRecord) {}
}

impl<F: FnMut(&AxesRecord<Z, N>), const Z: usize, const N: usize> AxesSink<Z, N> for F {
    fn record(&mut self, record: &AxesRecord<Z, N>) {
        self(record)
    }
}

#[cfg(feature = "defmt")]
impl<const Z: usize, const N: usize> AxesSink<Z, N> for super::DefmtSink {
    fn record(&mut self, record: &AxesRecord<Z, N>) {
        record.log();
    }

    fn ident(&mut self, p: &IdentRecord) {
        p.log();
    }
}
