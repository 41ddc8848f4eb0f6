//! What the estimator reports each step, and where it sends it.
//!
//! A [`Record`] is one step's worth of telemetry: the observation, the innovation statistics
//! and the tilt estimate, plus a [`u16`] bitset of [flags](MISSING) saying what was unusual about
//! the step. The core hands records to a [`TelemetrySink`]; it never knows the transport. The
//! firmware uses [`DefmtSink`] (feature `defmt`: one defmt frame per step, over semihosting or
//! RTT); the host passes a closure that pushes into a `Vec`:
//!
//! ```
//! use imu_ident::telemetry::{Record, TelemetrySink, MISSING};
//! let mut got = Vec::new();
//! let mut sink = |r: &Record| got.push(*r);
//! sink.record(&Record { flags: MISSING, ..Record::default() });
//! assert!(got[0].has(MISSING));
//! ```
//!
//! Precision: time stays `f64` (an `f32` has a 1 s spacing at 1e7 s); everything else is `f32`,
//! which is what the single-precision firmware computes and halves the bytes on the wire.

pub mod axes;
pub mod params;

pub use axes::{AxesRecord, AxesSink, IdentRecord};

pub use params::{
    model_params, sensor_code, AcfRecord, ParamRecord, ACF_WIRE_TAG, FLAT_BETA, FLAT_SIGMA,
    FLAT_TAU, PARAM_WIRE_FIELDS, PARAM_WIRE_TAG,
};

use crate::filter::{AxisStatus, Estimates};
use crate::Real;

/// The observation was missing (NaN or infinite): the filter only predicted.
pub const MISSING: u16 = 1 << 0;
/// The innovation failed the chi-square gate and was not used.
pub const GATED_OUTLIER: u16 = 1 << 1;
/// The covariance lost positive definiteness and was reset to the initial one.
pub const P_REPAIRED: u16 = 1 << 2;
/// An identified parameter was clamped before it was fed back (set by the adaptation stage).
pub const PARAM_CLAMPED: u16 = 1 << 3;
/// The time since the previous row differs from the filter step by more than half a step.
pub const TIME_JUMP: u16 = 1 << 4;
/// The row itself is unusable in part: non-finite or non-increasing time, infinite observation.
pub const BAD_INPUT: u16 = 1 << 5;
/// The row was skipped (its time does not advance): the filter did not run; the record only
/// reports it.
pub const SKIPPED: u16 = 1 << 6;
/// A tick inserted to bridge a gap in the observation times (no row: prediction only).
pub const BRIDGED: u16 = 1 << 7;
/// The online identification found a change in service at this tick (its innovations left
/// the model's, [`adapt::change`](crate::adapt::change)): its windows start after the change.
pub const SENSOR_CHANGE: u16 = 1 << 8;
/// The model runs with a parameter the online identification's last window search did not
/// identify (Cramér-Rao sd above [`IDENTIFIABLE_SD`](crate::model::IDENTIFIABLE_SD) decades:
/// "not identifiable from these data yet"); the parameter records carry its interval. Set on
/// every tick until a search identifies it.
pub const NOT_IDENTIFIABLE: u16 = 1 << 9;

/// Every flag with its name, in bit order (for reports and decoders).
pub const FLAG_NAMES: [(u16, &str); 10] = [
    (MISSING, "missing"),
    (GATED_OUTLIER, "gated_outlier"),
    (P_REPAIRED, "p_repaired"),
    (PARAM_CLAMPED, "param_clamped"),
    (TIME_JUMP, "time_jump"),
    (BAD_INPUT, "bad_input"),
    (SKIPPED, "skipped"),
    (BRIDGED, "bridged"),
    (SENSOR_CHANGE, "sensor_change"),
    (NOT_IDENTIFIABLE, "not_identifiable"),
];

/// First word of the defmt telemetry frame written by [`Record::log`]; host decoders pick the
/// telemetry frames out of the log stream by it.
pub const WIRE_TAG: &str = "tlm";

/// Field names of the defmt telemetry frame, in order. Each parameter of the frame is
/// preceded by `name=`, so a decoder can check the layout instead of trusting positions.
pub const WIRE_FIELDS: [&str; 15] = [
    "k", "t", "z", "nu", "s", "nis", "dv", "sdv", "delta", "sd", "da", "sda", "dw", "sdw", "flags",
];

/// One filter step, as reported.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Record {
    /// Step index since the start of the run (detects lost frames).
    pub k: u32,
    /// Time of the observation [s].
    pub t: f64,
    /// Observation [m/s] (NaN when missing).
    pub z: f32,
    /// Innovation `z - H x` [m/s] (NaN when missing).
    pub innovation: f32,
    /// Innovation variance `H P H^T + R` [m^2/s^2].
    pub variance: f32,
    /// Normalised innovation squared (NaN when missing).
    pub nis: f32,
    /// Velocity error estimate after the update [m/s].
    pub dv: f32,
    /// Its standard deviation [m/s].
    pub sigma_dv: f32,
    /// Tilt error estimate after the update [rad].
    pub delta: f32,
    /// Its standard deviation [rad].
    pub sigma_delta: f32,
    /// Accelerometer error estimate (sum of its components) [m/s^2].
    pub da: f32,
    /// Its standard deviation [m/s^2].
    pub sigma_da: f32,
    /// Gyro drift estimate (sum of its components) [rad/s].
    pub dw: f32,
    /// Its standard deviation [rad/s].
    pub sigma_dw: f32,
    /// Bitset of [`MISSING`], [`GATED_OUTLIER`], [`P_REPAIRED`], [`PARAM_CLAMPED`],
    /// [`TIME_JUMP`], [`BAD_INPUT`], [`SKIPPED`], [`BRIDGED`].
    pub flags: u16,
}

impl Record {
    /// Builds the record of tick `k` at time `t` with observation `z`, innovation `nu`, its
    /// variance `s` and the estimates after the update.
    pub fn new<T: Real>(k: u32, t: f64, z: T, nu: T, s: T, est: &Estimates<T>, flags: u16) -> Self {
        // Narrowing to f32 is the telemetry's precision, not the filter's.
        let f = |x: T| x.as_f64() as f32;
        Self {
            k,
            t,
            z: f(z),
            innovation: f(nu),
            variance: f(s),
            nis: f(nu * nu / s),
            dv: f(est.dv),
            sigma_dv: f(est.sigma_dv),
            delta: f(est.delta),
            sigma_delta: f(est.sigma_delta),
            da: f(est.da),
            sigma_da: f(est.sigma_da),
            dw: f(est.dw),
            sigma_dw: f(est.sigma_dw),
            flags,
        }
    }

    /// True when every bit of `flag` is set.
    pub const fn has(&self, flag: u16) -> bool {
        self.flags & flag == flag
    }

    /// Writes the record as one defmt frame, flat (one parameter per field, named as in
    /// [`WIRE_FIELDS`]) so that a host decoder gets each value as its own fragment instead of
    /// parsing the text of a nested struct.
    #[cfg(feature = "defmt")]
    pub fn log(&self) {
        defmt::info!(
            "tlm k={=u32} t={=f64} z={=f32} nu={=f32} s={=f32} nis={=f32} dv={=f32} sdv={=f32} delta={=f32} sd={=f32} da={=f32} sda={=f32} dw={=f32} sdw={=f32} flags={=u16}",
            self.k,
            self.t,
            self.z,
            self.innovation,
            self.variance,
            self.nis,
            self.dv,
            self.sigma_dv,
            self.delta,
            self.sigma_delta,
            self.da,
            self.sigma_da,
            self.dw,
            self.sigma_dw,
            self.flags
        );
    }
}

/// The flags of one observation axis, from what the filter did with it (a scalar
/// [`UpdateStatus`](crate::filter::UpdateStatus) or a vector observation's [`AxisStatus`]): [`MISSING`], [`GATED_OUTLIER`],
/// and [`P_REPAIRED`] for a bad innovation variance (`P` went wrong; a tick's own flags take
/// `P_REPAIRED` from the repair that follows, not from this).
pub fn status_flags(status: impl Into<AxisStatus>) -> u16 {
    match status.into() {
        AxisStatus::Used => 0,
        AxisStatus::Missing => MISSING,
        AxisStatus::Gated => GATED_OUTLIER,
        AxisStatus::BadVariance => P_REPAIRED,
    }
}

/// The flags implied by a row's time `t`, given the previous finite time and the filter step.
pub fn time_flags(prev_t: Option<f64>, t: f64, dt: f64) -> u16 {
    if !t.is_finite() {
        return BAD_INPUT;
    }
    let Some(prev) = prev_t else { return 0 };
    let gap = t - prev;
    if gap <= 0.0 {
        // Time went backwards or stood still: the row is suspect and the clock jumped.
        BAD_INPUT | TIME_JUMP
    } else if (gap - dt).abs() > 0.5 * dt {
        TIME_JUMP
    } else {
        0
    }
}

/// Where records go. Implemented by the firmware's transport ([`DefmtSink`]) and, through the
/// blanket implementation for closures, by anything on the host.
pub trait TelemetrySink {
    /// Takes one record. Transports that can lose data count the loss themselves; the step
    /// index [`Record::k`] lets the receiver detect gaps.
    fn record(&mut self, record: &Record);

    /// Takes one component's parameters, sent after a re-identification (default: dropped).
    fn params(&mut self, _params: &ParamRecord) {}

    /// Takes one autocorrelation identification of the estimates (default: dropped).
    fn acf(&mut self, _acf: &AcfRecord) {}
}

impl<F: FnMut(&Record)> TelemetrySink for F {
    fn record(&mut self, record: &Record) {
        self(record)
    }
}

/// Sends each record as one defmt frame (see [`Record::log`]) through whatever global defmt
/// logger the binary defines (semihosting stdout under QEMU, RTT on a board).
#[cfg(feature = "defmt")]
#[derive(Debug, Clone, Copy, Default)]
pub struct DefmtSink;

#[cfg(feature = "defmt")]
impl TelemetrySink for DefmtSink {
    fn record(&mut self, record: &Record) {
        record.log();
    }

    fn params(&mut self, params: &ParamRecord) {
        params.log();
    }

    fn acf(&mut self, acf: &AcfRecord) {
        acf.log();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::UpdateStatus;

    #[test]
    fn flags_are_distinct_bits() {
        let mut all = 0u16;
        for (bit, _) in FLAG_NAMES {
            assert_eq!(bit.count_ones(), 1);
            assert_eq!(all & bit, 0);
            all |= bit;
        }
    }

    #[test]
    fn time_flags_cover_gaps_and_bad_clocks() {
        assert_eq!(time_flags(None, 0.0, 1.0), 0);
        assert_eq!(time_flags(Some(1.0e7), 1.0e7 + 1.0, 1.0), 0);
        assert_eq!(time_flags(Some(1.0), 1.4, 1.0), TIME_JUMP);
        assert_eq!(time_flags(Some(1.0), 4.0, 1.0), TIME_JUMP);
        assert_eq!(time_flags(Some(2.0), 2.0, 1.0), BAD_INPUT | TIME_JUMP);
        assert_eq!(time_flags(Some(2.0), f64::NAN, 1.0), BAD_INPUT);
    }

    #[test]
    fn status_maps_to_flags() {
        assert_eq!(status_flags(UpdateStatus::Updated), 0);
        assert_eq!(status_flags(UpdateStatus::Missing), MISSING);
        assert_eq!(status_flags(UpdateStatus::Gated), GATED_OUTLIER);
        assert_eq!(
            status_flags(UpdateStatus::BadInnovationVariance),
            P_REPAIRED
        );
        assert_eq!(status_flags(AxisStatus::Gated), GATED_OUTLIER);
    }
}
