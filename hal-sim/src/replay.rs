//! The one replay driver of the host: every log replay of `hal-sim` (`run`, `diagnose`,
//! `compare`, `demo`, `figures`, the benchmarks) goes through [`drive`], which hands each row
//! to the firmware's own step, [`Estimator::push`] (in `f64` or `f32`), with a sink. So the
//! host and the QEMU firmware apply one set of rules, the step's:
//!
//! - time: a gap of `k = round((t - t_prev) / dt) > 1` steps is bridged by `k - 1` ticks
//!   without an observation (flagged `bridged`, written to `estimates.csv` and counted as
//!   `missing`), at most [`StepConfig::max_bridge`]; a row whose time does not advance, is not
//!   finite, or jumps further than that until the next row confirms the jump, is skipped;
//! - outliers: the NIS gate with its running scale ([`imu_ident::step`]);
//! - the adaptive model, when asked, is the step's own online identification.
//!
//! What the step does not expose (one state's posterior for the diagnosis limits, or the
//! paper's ACF loop that feeds a model back) is computed by [`follow`]ing the ticks of a
//! driven run: the step still decides every tick, and nothing here re-decides time.

use std::path::Path;

use anyhow::{anyhow, Result};
use imu_ident::adapt::AdaptConfig;
use imu_ident::model::InsModel;
use imu_ident::step::{AcfRecord, Estimator, ParamRecord, StepConfig};
use imu_ident::telemetry::{
    Record, TelemetrySink, BRIDGED, FLAT_BETA, FLAT_SIGMA, FLAT_TAU, SKIPPED,
};
use imu_ident::Real;

use crate::log::LogRow;
use crate::output::write_csv;
use crate::records::{
    write_estimates, write_params_csv, AcfRow, EstimateRow, LogLikelihood, ParamRow, RunCounts,
};

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

impl Telemetry {
    /// Records of the ticks (rows used and bridged ticks; not the skipped rows).
    pub fn tick_records(&self) -> impl Iterator<Item = &Record> {
        self.records.iter().filter(|r| !r.has(SKIPPED))
    }

    /// One `estimates.csv` row per tick, bridged ticks included (flagged).
    pub fn estimate_rows(&self) -> Vec<EstimateRow> {
        self.tick_records().map(EstimateRow::from_record).collect()
    }

    /// What the run did with the rows.
    pub fn counts(&self) -> RunCounts {
        RunCounts::of(&self.records)
    }

    /// The innovation log-likelihood and its number of terms
    /// ([`crate::records::log_likelihood`]).
    pub fn log_likelihood(&self) -> (f64, usize) {
        let mut ll = LogLikelihood::default();
        for r in self.tick_records() {
            ll.add(&EstimateRow::from_record(r));
        }
        (ll.value, ll.terms)
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
                sd_ln_tau: f64::from(p.sd_tau),
                sd_ln_sigma: f64::from(p.sd_sigma),
                sd_ln_beta: f64::from(p.sd_beta),
                not_identifiable: flat_names(p.flat),
            })
            .collect()
    }

    /// The quantities the last parameter records of each component flag "not identifiable
    /// from these data yet", as `sensor component quantity` with the value and its 95 %
    /// Cramér-Rao interval (for `summary.json` and the report).
    pub fn not_identifiable(&self) -> Vec<String> {
        let Some(last) = self.params.last().map(|p| p.k) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for p in self.params.iter().filter(|p| p.k == last) {
            for (bit, name, value, sd) in [
                (FLAT_TAU, "tau", p.tau, p.sd_tau),
                (FLAT_SIGMA, "sigma", p.sigma, p.sd_sigma),
                (FLAT_BETA, "beta", p.beta, p.sd_beta),
            ] {
                if p.flat & bit == 0 {
                    continue;
                }
                let (v, sd) = (f64::from(value), f64::from(sd));
                let interval = ParamRow::interval95(v, sd).map_or(
                    "no interval: the information is singular".to_string(),
                    |(a, b)| format!("95 % Cramér-Rao interval {a:.3e} to {b:.3e}"),
                );
                out.push(format!(
                    "{} {} {name} = {v:.3e} ({interval})",
                    p.sensor.name(),
                    p.component
                ));
            }
        }
        out
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
        write_csv(&out.join("acf.csv"), &self.acf_rows())
    }
}

/// The online-identification settings in precision `T`.
pub fn adapt_config<T: Real>(c: &AdaptConfig<f64>) -> AdaptConfig<T> {
    AdaptConfig::<T> {
        block: c.block,
        h: T::lit(c.h),
        window: T::lit(c.window),
        damping: T::lit(c.damping),
        hysteresis: T::lit(c.hysteresis),
        max_step: T::lit(c.max_step),
        tau_max: T::lit(c.tau_max),
        spread: T::lit(c.spread),
        move_discount: T::lit(c.move_discount),
        probe_factor: T::lit(c.probe_factor),
        epoch: c.epoch,
        warmup: c.warmup,
        margin: T::lit(c.margin),
        first_margin: T::lit(c.first_margin),
        hold_first_epoch: c.hold_first_epoch,
        search_until_settled: c.search_until_settled,
        adapt: c.adapt,
        global: imu_ident::adapt::WindowConfig {
            block: c.global.block,
            window: c.global.window,
            first: c.global.first,
            every: c.global.every,
            filling_every: c.global.filling_every,
            budget: c.global.budget,
            spacing: T::lit(c.global.spacing),
            min_step: T::lit(c.global.min_step),
            margin: T::lit(c.global.margin),
            hold_recursion: c.global.hold_recursion,
            structure: T::lit(c.global.structure),
            change: T::lit(c.global.change),
            after_change: c.global.after_change,
            hold_flat: c.global.hold_flat,
            flat_every: c.global.flat_every,
            keep_start: c.global.keep_start,
            keep_identified: c.global.keep_identified,
            conservative: T::lit(c.global.conservative),
            prior: T::lit(c.global.prior),
        },
    }
}

/// The step's settings: the defaults, with the online identification `adapt` when given.
pub fn nav_config<T: Real>(adapt: Option<&AdaptConfig<f64>>) -> StepConfig<T> {
    StepConfig {
        adapt: adapt.map(adapt_config),
        ..StepConfig::default()
    }
}

/// A step in precision `T` starting from `model` (boxed: the adaptive engine is tens of KB).
pub fn estimator<T: Real>(
    model: &InsModel<f64>,
    adapt: Option<&AdaptConfig<f64>>,
) -> Result<Box<Estimator<T>>> {
    let mut nav = Box::new(Estimator::<T>::BLANK);
    nav.init(model.cast(), nav_config(adapt))
        .map_err(|e| anyhow!("the model was rejected: {e:?}"))?;
    Ok(nav)
}

/// THE replay loop: hands every row of `log` to the step, which decides the ticks (bridges,
/// skips, gates) and sends what it did to `sink`.
pub fn drive<T: Real>(nav: &mut Estimator<T>, log: &[LogRow], sink: &mut impl TelemetrySink) {
    for row in log {
        nav.push(row.t, T::lit(row.z), sink);
    }
}

/// A finished replay: the telemetry and the step at the end (its model, its adaptive state).
#[derive(Debug, Clone)]
pub struct Replay<T: Real> {
    /// What the step reported.
    pub telemetry: Telemetry,
    /// The step after the last row.
    pub estimator: Box<Estimator<T>>,
}

impl<T: Real> Replay<T> {
    /// The model in use at the end (the identified one when adapting).
    pub fn end_model(&self) -> Result<InsModel<f64>> {
        let m = self
            .estimator
            .model()
            .map_err(|e| anyhow!("the identified model is invalid: {e:?}"))?;
        Ok(m.cast())
    }
}

/// Replays `log` through the step in precision `T` from `model` (fixed, or identified online
/// with `adapt`), keeping all telemetry.
pub fn run<T: Real>(
    model: &InsModel<f64>,
    adapt: Option<&AdaptConfig<f64>>,
    log: &[LogRow],
) -> Result<Replay<T>> {
    let mut estimator = estimator::<T>(model, adapt)?;
    let mut telemetry = Telemetry::default();
    drive(&mut estimator, log, &mut telemetry);
    Ok(Replay {
        telemetry,
        estimator,
    })
}

/// The estimates (one row per tick) and counts of the fixed `model` on `log`, in precision `T`.
pub fn estimates<T: Real>(
    model: &InsModel<f64>,
    log: &[LogRow],
) -> Result<(Vec<EstimateRow>, RunCounts)> {
    let r = run::<T>(model, None, log)?;
    Ok((r.telemetry.estimate_rows(), r.telemetry.counts()))
}

/// A sink that only sums the innovation log-likelihood (for the many evaluations of a fit).
#[derive(Debug, Default)]
struct LikelihoodSink(LogLikelihood);

impl TelemetrySink for LikelihoodSink {
    fn record(&mut self, r: &Record) {
        if !r.has(SKIPPED) {
            self.0.add(&EstimateRow::from_record(r));
        }
    }
}

/// The innovation log-likelihood of the fixed `model` on `log` (`f64`) and its number of
/// terms: the same value as [`Telemetry::log_likelihood`] of [`run`], without storing.
pub fn log_likelihood(model: &InsModel<f64>, log: &[LogRow]) -> Result<(f64, usize)> {
    let mut nav = estimator::<f64>(model, None)?;
    let mut sink = LikelihoodSink::default();
    drive(&mut nav, log, &mut sink);
    Ok((sink.0.value, sink.0.terms))
}

/// One tick of a driven run, for a computation that follows it.
#[derive(Debug, Clone, Copy)]
pub struct Tick<'a> {
    /// The step's record of the tick.
    pub record: &'a Record,
    /// The log row it used (`None`: a bridged tick).
    pub row: Option<&'a LogRow>,
}

impl Tick<'_> {
    /// The observation the step used: the row's, or NaN (missing) for a bridged tick or an
    /// observation the gate withheld.
    pub fn used_z(&self) -> f64 {
        match self.row {
            Some(r) if !self.record.has(imu_ident::telemetry::GATED_OUTLIER) => r.z,
            _ => f64::NAN,
        }
    }
}

/// The ticks of a run of `log` whose per-tick records are `records` (from [`drive`]), in
/// order, each paired with its row: every row gives exactly one record (ticked or skipped),
/// and bridged ticks come before the row that ends the gap.
pub fn follow<'a>(log: &'a [LogRow], records: &'a [Record]) -> impl Iterator<Item = Tick<'a>> {
    let mut rows = log.iter();
    records.iter().filter_map(move |record| {
        if record.has(BRIDGED) {
            return Some(Tick { record, row: None });
        }
        let row = rows.next();
        (!record.has(SKIPPED)).then_some(Tick { record, row })
    })
}

/// The names of the quantities a parameter record flags not identifiable, space separated.
fn flat_names(flat: u8) -> String {
    [
        (FLAT_TAU, "tau"),
        (FLAT_SIGMA, "sigma"),
        (FLAT_BETA, "beta"),
    ]
    .iter()
    .filter(|(bit, _)| flat & bit != 0)
    .map(|(_, n)| *n)
    .collect::<Vec<_>>()
    .join(" ")
}
