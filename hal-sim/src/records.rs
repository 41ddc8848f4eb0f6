//! The host's output records of a replay and their files: one `estimates.csv` row per tick
//! ([`EstimateRow`]), the counts of `summary.json` ([`RunCounts`]), the parameters over time
//! (`params.csv`, [`ParamRow`]) and the autocorrelation identifications (`acf.csv`,
//! [`AcfRow`]). Both the host replay ([`crate::replay`]) and the firmware run under QEMU
//! ([`crate::qemu`]) produce these from the step's telemetry, so the files are comparable.
//!
//! This module depends on no other module of the crate but [`crate::output`].

use crate::output::write_csv;
use anyhow::Result;
use imu_ident::telemetry::{
    Record, BRIDGED, GATED_OUTLIER, MISSING, NOT_IDENTIFIABLE, P_REPAIRED, SENSOR_CHANGE, SKIPPED,
    TIME_JUMP,
};
use serde::Serialize;
use std::path::Path;

/// One row of `estimates.csv`: one tick of the step (a bridged tick included).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EstimateRow {
    pub t: f64,
    pub dv_hat: f64,
    pub delta_hat: f64,
    pub da_hat: f64,
    pub dw_hat: f64,
    pub sigma_dv: f64,
    pub sigma_delta: f64,
    pub sigma_da: f64,
    pub sigma_dw: f64,
    pub innovation: f64,
    pub innovation_var: f64,
    pub nis: f64,
    /// The step's telemetry flags ([`imu_ident::telemetry::FLAG_NAMES`]): `missing` (1),
    /// `gated_outlier` (2), `p_repaired` (4), `param_clamped` (8), `time_jump` (16),
    /// `bad_input` (32), `bridged` (128), `sensor_change` (256), `not_identifiable` (512).
    pub flags: u16,
}

impl EstimateRow {
    /// A row from a telemetry record of the firmware's step (host or QEMU).
    pub fn from_record(r: &Record) -> Self {
        let f = f64::from;
        EstimateRow {
            t: r.t,
            dv_hat: f(r.dv),
            delta_hat: f(r.delta),
            da_hat: f(r.da),
            dw_hat: f(r.dw),
            sigma_dv: f(r.sigma_dv),
            sigma_delta: f(r.sigma_delta),
            sigma_da: f(r.sigma_da),
            sigma_dw: f(r.sigma_dw),
            innovation: f(r.innovation),
            innovation_var: f(r.variance),
            nis: f(r.nis),
            flags: r.flags,
        }
    }

    /// True for a tick that bridged a gap in the log's times (no row, prediction only).
    pub fn is_bridged(&self) -> bool {
        self.flags & BRIDGED != 0
    }

    /// This tick's term of the Gaussian innovation log-likelihood,
    /// `-0.5 (ln(2 pi S) + nu^2 / S)`, or `None` when it had no innovation (missing or
    /// bridged). A gated innovation counts: it is still the model's prediction of the
    /// observation, and leaving it out would reward a model for rejecting data.
    pub fn log_likelihood_term(&self) -> Option<f64> {
        let ok = self.innovation.is_finite()
            && self.nis.is_finite()
            && self.innovation_var.is_finite()
            && self.innovation_var > 0.0;
        ok.then(|| -0.5 * ((2.0 * std::f64::consts::PI * self.innovation_var).ln() + self.nis))
    }
}

/// The innovation log-likelihood of a run and its number of terms, summed over rows in order
/// with [`EstimateRow::log_likelihood_term`]: the one definition used by `run`, `compare` and
/// `diagnose`.
pub fn log_likelihood<'a>(rows: impl IntoIterator<Item = &'a EstimateRow>) -> (f64, usize) {
    let mut acc = LogLikelihood::default();
    for r in rows {
        acc.add(r);
    }
    (acc.value, acc.terms)
}

/// A running innovation log-likelihood ([`log_likelihood`] without storing the rows).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LogLikelihood {
    /// Sum of the terms so far.
    pub value: f64,
    /// Number of terms.
    pub terms: usize,
}

impl LogLikelihood {
    /// Adds one tick's term, if it has one.
    pub fn add(&mut self, r: &EstimateRow) {
        if let Some(v) = r.log_likelihood_term() {
            self.value += v;
            self.terms += 1;
        }
    }
}

/// Counts of what a replay did, from its telemetry records ([`RunCounts::of`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct RunCounts {
    /// Ticks of the step: log rows used plus bridged ticks (= rows of `estimates.csv`).
    pub steps: usize,
    /// Log rows used (ticked with their observation).
    pub rows: usize,
    /// Observations used by the update.
    pub updated: usize,
    /// Ticks without an observation: missing (NaN) observations and bridged ticks.
    pub missing: usize,
    /// Ticks inserted to bridge gaps in the log's times (included in `missing`).
    pub bridged: usize,
    /// Observations rejected by the outlier gate.
    pub gated: usize,
    /// Rows after a gap in time (bridged ticks before them, or flagged `time_jump`).
    pub gaps: usize,
    /// Rows ticked with the `time_jump` flag: a clock jump beyond the longest bridge (ahead
    /// or back, once confirmed by the next row) or a time off the step grid.
    pub time_jumps: usize,
    /// Rows skipped (time not advancing, not finite, or a suspect jump).
    pub skipped_time: usize,
    /// Covariance repairs.
    pub repairs: usize,
    /// Changes in service the global stage's monitor found (ticks flagged `sensor_change`).
    pub sensor_changes: usize,
    /// Ticks run with a parameter the last window search did not identify (flagged
    /// `not_identifiable`).
    pub not_identifiable: usize,
}

impl RunCounts {
    /// The counts of a run's per-tick records (skipped rows included, as the step reports
    /// them).
    pub fn of<'a>(records: impl IntoIterator<Item = &'a Record>) -> Self {
        let mut c = RunCounts::default();
        let mut after_bridge = false;
        for r in records {
            if r.has(SKIPPED) {
                c.skipped_time += 1;
                continue;
            }
            c.steps += 1;
            c.repairs += usize::from(r.has(P_REPAIRED));
            c.sensor_changes += usize::from(r.has(SENSOR_CHANGE));
            c.not_identifiable += usize::from(r.has(NOT_IDENTIFIABLE));
            if r.has(MISSING) {
                c.missing += 1;
            } else if r.has(GATED_OUTLIER) {
                c.gated += 1;
            } else if r.nis.is_finite() {
                c.updated += 1;
            }
            if r.has(BRIDGED) {
                c.bridged += 1;
                after_bridge = true;
                continue;
            }
            c.rows += 1;
            c.gaps += usize::from(after_bridge || r.has(TIME_JUMP));
            c.time_jumps += usize::from(r.has(TIME_JUMP));
            after_bridge = false;
        }
        c
    }
}

/// One row of the parameters-over-time log (`params.csv`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamRow {
    /// Time [s].
    pub t: f64,
    /// `accel`, `gyro` or `observation`.
    pub sensor: &'static str,
    /// Component index within the sensor.
    pub component: usize,
    /// Its kind (model-TOML spelling): with the rows of one time, the selected structure.
    pub kind: &'static str,
    /// Correlation time [s] (NaN when the kind has none).
    pub tau: f64,
    /// Standard deviation (NaN when the kind has none).
    pub sigma: f64,
    /// Oscillation frequency [rad/s] (NaN unless exponential-cosine).
    pub beta: f64,
    /// Cramér-Rao standard deviation of `ln tau` from the online identification's windowed
    /// Fisher information (NaN when `tau` is not identified online).
    pub sd_ln_tau: f64,
    /// The same for `ln sigma`.
    pub sd_ln_sigma: f64,
    /// The same for `ln beta`.
    pub sd_ln_beta: f64,
    /// The quantities of this component the last window search did not identify, space
    /// separated (`tau`, `sigma`, `beta`; empty: all identified or not identified online):
    /// "not identifiable from these data yet", their interval being the row's Cramér-Rao one.
    pub not_identifiable: String,
}

impl ParamRow {
    /// The approximate 95 % Cramér-Rao interval `value * exp(±1.96 sd)` of a value and the
    /// standard deviation of its logarithm; `None` when either is not finite.
    pub fn interval95(value: f64, sd_ln: f64) -> Option<(f64, f64)> {
        let k = (1.96 * sd_ln).exp();
        (value.is_finite() && k.is_finite() && sd_ln >= 0.0).then(|| (value / k, value * k))
    }
}

/// One row of `acf.csv`.
#[derive(Debug, Clone, Serialize)]
pub struct AcfRow {
    pub t: f64,
    pub sensor: &'static str,
    pub tau: f64,
    pub sigma: f64,
}

/// Writes `estimates.csv` atomically.
pub fn write_estimates(path: &Path, rows: &[EstimateRow]) -> Result<()> {
    write_csv(path, rows)
}

/// Writes the parameters-over-time log as CSV
/// (`t,sensor,component,kind,tau,sigma,beta,sd_ln_tau,sd_ln_sigma,sd_ln_beta,not_identifiable`).
pub fn write_params_csv(path: &Path, rows: &[ParamRow]) -> Result<()> {
    write_csv(path, rows)
}
