//! The `simulate` and `run` commands (the CLI in `main.rs` only parses arguments).

use crate::model_toml;
use crate::output::{write_atomic, write_string};
use crate::runner::{self, EstimateRow};
use crate::summary::{summarise, Summary};
use crate::{log, scenario, sim};
use anyhow::{anyhow, Context, Result};
use std::path::Path;

/// `simulate`: draws a log of `hours` from a scenario's truth model.
pub fn simulate(scenario_spec: &str, hours: Option<f64>, seed: u64, out: &Path) -> Result<usize> {
    let sc = scenario::load(scenario_spec)?;
    let model = sc
        .to_core()
        .with_context(|| format!("scenario {scenario_spec}"))?;
    let hours = hours.or(sc.hours).unwrap_or(12.0);
    if !(hours.is_finite() && hours > 0.0) {
        return Err(anyhow!("--hours must be a positive number, got {hours}"));
    }
    let steps = (hours * 3600.0 / model.dt).round() as usize;
    let rows = sim::simulate(&model, steps, seed)?;
    log::write(out, &rows)?;
    Ok(steps)
}

/// Writes `estimates.csv` atomically.
pub fn write_estimates(path: &Path, rows: &[EstimateRow]) -> Result<()> {
    write_atomic(path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        for r in rows {
            csv.serialize(r)?;
        }
        csv.flush()?;
        Ok(())
    })
}

/// `run`: replays a log through the filter with a fixed model; writes `estimates.csv` and
/// `summary.json` into `out`.
pub fn run(log_path: &Path, model_path: &Path, out: &Path) -> Result<Summary> {
    let model = model_toml::load(model_path)?;
    let rows = log::read(log_path)?;
    let (est, counts) = runner::run::<f64>(&model, &rows)?;
    let summary = summarise(&rows, &est, counts);
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    write_estimates(&out.join("estimates.csv"), &est)?;
    let json = serde_json::to_string_pretty(&summary)?;
    write_string(&out.join("summary.json"), &json)?;
    Ok(summary)
}
