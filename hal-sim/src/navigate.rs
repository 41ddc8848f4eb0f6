//! The firmware's 1 Hz step ([`Navigator`]) driven on the host: `hal-sim run` and the
//! reference side of the firmware-vs-host parity checks both go through here, so the host and
//! the QEMU firmware run the same code and differ only in precision (`f64` here, `f32` there).
//!
//! The firmware's telemetry and a host run have the same shape, [`Telemetry`], and are written
//! with the same functions, so `hal-sim qemu` and `hal-sim run` produce comparable files.

use std::path::Path;

use anyhow::{anyhow, Result};
use imu_ident::model::InsModel;
use imu_ident::navigator::{AcfRecord, NavConfig, Navigator, ParamRecord};
use imu_ident::telemetry::{
    Record, TelemetrySink, BRIDGED, GATED_OUTLIER, MISSING, P_REPAIRED, SKIPPED,
};
use imu_ident::Real;
use serde::Serialize;

use crate::adaptive::{write_params_csv, ParamRow};
use crate::commands::write_estimates;
use crate::log::LogRow;
use crate::output::write_atomic;
use crate::runner::{EstimateRow, RunCounts};

/// Everything a run of the step reports: per-tick records, parameters at each
/// re-identification, and the autocorrelation identifications.
#[derive(Debug, Clone, Default)]
pub struct Telemetry {
    /// One per tick (bridged ticks included) and one per skipped row.
    pub records: Vec<Record>,
    /// One per model component at each re-identification.
    pub params: Vec<ParamRecord>,
    /// Two per schedule (accelerometer, gyro).
    pub acf: Vec<AcfRecord>,
}

impl TelemetrySink for Telemetry {
    fn record(&mut self, r: &Record) {
        self.records.push(*r);
    }
    fn params(&mut self, p: &ParamRecord) {
        self.params.push(*p);
    }
    fn acf(&mut self, a: &AcfRecord) {
        self.acf.push(*a);
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

/// The step's settings for a run: the defaults, with the online identification when `adapt`.
pub fn config<T: Real>(adapt: bool) -> NavConfig<T> {
    if adapt {
        NavConfig::adaptive()
    } else {
        NavConfig::default()
    }
}

/// Runs the step in precision `T` over `log`, starting from `model`; returns the telemetry and
/// the model in use at the end.
pub fn run<T: Real>(
    model: &InsModel<f64>,
    adapt: bool,
    log: &[LogRow],
) -> Result<(Telemetry, InsModel<f64>)> {
    let mut nav = Navigator::<T>::new(model.cast(), config(adapt))
        .map_err(|e| anyhow!("the model was rejected: {e:?}"))?;
    let mut tel = Telemetry::default();
    for row in log {
        nav.push(row.t, T::lit(row.z), &mut tel);
    }
    let end = nav
        .model()
        .map_err(|e| anyhow!("the identified model is invalid: {e:?}"))?;
    Ok((tel, end.cast()))
}

impl Telemetry {
    /// Records of log rows that the filter used (not bridged ticks, not skipped rows).
    pub fn row_records(&self) -> impl Iterator<Item = &Record> {
        self.records
            .iter()
            .filter(|r| r.flags & (BRIDGED | SKIPPED) == 0)
    }

    /// One `estimates.csv` row per processed log row, as `hal-sim run` writes them.
    pub fn estimate_rows(&self) -> Vec<EstimateRow> {
        self.row_records().map(EstimateRow::from_record).collect()
    }

    /// What the run did with the rows.
    pub fn counts(&self) -> RunCounts {
        let mut c = RunCounts::default();
        let mut after_bridge = false;
        for r in &self.records {
            if r.has(SKIPPED) {
                c.skipped_time += 1;
                continue;
            }
            if r.has(P_REPAIRED) {
                c.repairs += 1;
            }
            if r.has(BRIDGED) {
                after_bridge = true;
                continue;
            }
            c.steps += 1;
            c.gaps += usize::from(after_bridge);
            after_bridge = false;
            if r.has(MISSING) {
                c.missing += 1;
            } else if r.has(GATED_OUTLIER) {
                c.gated += 1;
            } else if r.nis.is_finite() {
                c.updated += 1;
            }
        }
        c
    }

    /// The parameter records as `params.csv` rows.
    pub fn param_rows(&self) -> Vec<ParamRow> {
        self.params
            .iter()
            .map(|p| ParamRow {
                t: p.t,
                sensor: p.sensor.name(),
                component: usize::from(p.component),
                kind: p.kind.name(),
                tau: f64::from(p.tau),
                sigma: f64::from(p.sigma),
                beta: f64::from(p.beta),
            })
            .collect()
    }

    /// The autocorrelation records as `acf.csv` rows.
    pub fn acf_rows(&self) -> Vec<AcfRow> {
        self.acf
            .iter()
            .map(|a| AcfRow {
                t: a.t,
                sensor: a.sensor.name(),
                tau: f64::from(a.tau),
                sigma: f64::from(a.sigma),
            })
            .collect()
    }

    /// Writes `estimates.csv`, `params.csv` and `acf.csv` into `out` (each atomically).
    pub fn write(&self, out: &Path) -> Result<()> {
        write_estimates(&out.join("estimates.csv"), &self.estimate_rows())?;
        write_params_csv(&out.join("params.csv"), &self.param_rows())?;
        let rows = self.acf_rows();
        write_atomic(&out.join("acf.csv"), |w| {
            let mut csv = csv::Writer::from_writer(w);
            for r in &rows {
                csv.serialize(r)?;
            }
            csv.flush()?;
            Ok(())
        })
    }
}
