//! `imu_ident._native`: the Python extension module of imu-ident. Every function is a thin
//! adapter between numpy arrays / Python dicts and the hal-sim library, so Python and the
//! `hal-sim` CLI run the same Rust code (no second copy of the maths). The public, documented
//! API is the pure-Python package `imu_ident` (python/imu_ident/__init__.py), which calls these.
//!
//! Results that hal-sim already serialises for its JSON files (identify's summary, the
//! diagnosis, a run's summary) cross into Python as the same JSON, decoded by Python's `json`
//! module, so a dict from Python has exactly the fields of the file the CLI writes.

use std::path::Path;

use anyhow::{anyhow, Context};
use hal_sim::allan::{overlapping_adev, AdevConfig};
use hal_sim::identify::{IdentifyArgs, SensorArg};
use hal_sim::log::{LogRow, Truth};
use hal_sim::records::EstimateRow;
use imu_ident::model::InsModel;
use numpy::{IntoPyArray, PyReadonlyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// An `anyhow` error as a Python `ValueError` carrying the whole context chain (file, line,
/// field), as the CLI prints it.
fn value_error(e: anyhow::Error) -> PyErr {
    PyValueError::new_err(format!("{e:#}"))
}

/// A 1-D numpy array (any stride) as a vector.
fn to_vec(a: &PyReadonlyArray1<'_, f64>) -> Vec<f64> {
    a.as_array().iter().copied().collect()
}

/// Decodes JSON text with Python's `json` module (NaN stays NaN, as hal-sim writes it).
fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| value_error(e.into()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// A model from a TOML file path or from TOML text (`source` says which, for errors).
fn load_model(model: &str, is_path: bool) -> anyhow::Result<InsModel<f64>> {
    if is_path {
        hal_sim::model_toml::load(Path::new(model))
    } else {
        hal_sim::model_toml::parse(model, "<model TOML text>")
    }
}

/// Log rows from arrays, as `hal-sim` reads them from a log CSV.
fn log_rows(
    t: &PyReadonlyArray1<'_, f64>,
    z: &PyReadonlyArray1<'_, f64>,
    truth: Option<[PyReadonlyArray1<'_, f64>; 4]>,
) -> anyhow::Result<Vec<LogRow>> {
    let (t, z) = (to_vec(t), to_vec(z));
    if t.len() != z.len() {
        return Err(anyhow!(
            "t has {} values but z has {}: they must have the same length",
            t.len(),
            z.len()
        ));
    }
    let truth: Option<Vec<Vec<f64>>> = truth.map(|arrs| arrs.iter().map(to_vec).collect());
    if let Some(cols) = &truth {
        for (name, c) in ["dv", "delta", "da", "dw"].iter().zip(cols) {
            if c.len() != t.len() {
                return Err(anyhow!(
                    "truth['{name}'] has {} values but t has {}",
                    c.len(),
                    t.len()
                ));
            }
        }
    }
    Ok(t.iter()
        .zip(&z)
        .enumerate()
        .map(|(i, (&t, &z))| LogRow {
            t,
            z,
            truth: truth.as_ref().map(|c| Truth {
                dv: c[0][i],
                delta: c[1][i],
                da: c[2][i],
                dw: c[3][i],
            }),
        })
        .collect())
}

/// Overlapping Allan deviation on the octave grid with its chi-square confidence interval
/// (`hal_sim::allan::overlapping_adev`, the code behind `identify`'s adev.csv).
#[pyfunction]
fn adev<'py>(
    py: Python<'py>,
    y: PyReadonlyArray1<'py, f64>,
    rate: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let y = to_vec(&y);
    let rows = py
        .detach(|| overlapping_adev(&y, &AdevConfig::octave(rate)))
        .map_err(|e| value_error(e.into()))?;
    let d = PyDict::new(py);
    let col = |f: fn(&hal_sim::allan::AdevRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    d.set_item("tau", col(|r| r.tau).into_pyarray(py))?;
    d.set_item(
        "m",
        rows.iter()
            .map(|r| r.m as u64)
            .collect::<Vec<u64>>()
            .into_pyarray(py),
    )?;
    d.set_item("adev", col(|r| r.adev).into_pyarray(py))?;
    d.set_item("ci_lo", col(|r| r.ci_lo).into_pyarray(py))?;
    d.set_item("ci_hi", col(|r| r.ci_hi).into_pyarray(py))?;
    d.set_item("edf", col(|r| r.edf).into_pyarray(py))?;
    Ok(d)
}

/// `hal-sim identify` on one array: the series goes through the same code as a CSV column
/// (written to a temporary CSV with round-trip exact numbers), and the result is identify's
/// summary.json as a dict, plus `model_toml` (the text of model.toml).
#[pyfunction]
#[pyo3(signature = (y, rate, sensor, decimate=1, column="series"))]
fn identify<'py>(
    py: Python<'py>,
    y: PyReadonlyArray1<'py, f64>,
    rate: f64,
    sensor: &str,
    decimate: usize,
    column: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let sensor = match sensor {
        "gyro" => SensorArg::Gyro,
        "accel" => SensorArg::Accel,
        o => {
            return Err(PyValueError::new_err(format!(
                "sensor: expected 'gyro' or 'accel', found '{o}'"
            )))
        }
    };
    let y = to_vec(&y);
    let column = column.to_string();
    let (summary, model_toml) = py
        .detach(|| -> anyhow::Result<(serde_json::Value, String)> {
            let dir = tempfile::tempdir().context("creating a temporary folder")?;
            let series = dir.path().join("series.csv");
            let mut text = String::with_capacity(24 * y.len() + 16);
            text.push_str(&column);
            text.push('\n');
            for v in &y {
                // `{:e}` prints the shortest representation that round-trips exactly.
                text.push_str(&format!("{v:e}\n"));
            }
            std::fs::write(&series, text)
                .with_context(|| format!("writing {}", series.display()))?;
            let args = IdentifyArgs {
                series,
                column,
                rate,
                scale: 1.0,
                decimate,
                out: dir.path().join("out"),
                quiet: true,
                sensor: Some(sensor),
            };
            let s = hal_sim::identify::run(&args)?;
            let toml = std::fs::read_to_string(args.out.join("model.toml"))?;
            Ok((serde_json::to_value(&s)?, toml))
        })
        .map_err(value_error)?;
    let d = json_to_py(py, &summary)?;
    d.set_item("model_toml", model_toml)?;
    Ok(d)
}

/// Columns of `estimates.csv` as numpy arrays.
fn estimates_dict<'py>(py: Python<'py>, rows: &[EstimateRow]) -> PyResult<Bound<'py, PyDict>> {
    type Field = (&'static str, fn(&EstimateRow) -> f64);
    const FIELDS: [Field; 12] = [
        ("t", |r| r.t),
        ("dv_hat", |r| r.dv_hat),
        ("delta_hat", |r| r.delta_hat),
        ("da_hat", |r| r.da_hat),
        ("dw_hat", |r| r.dw_hat),
        ("sigma_dv", |r| r.sigma_dv),
        ("sigma_delta", |r| r.sigma_delta),
        ("sigma_da", |r| r.sigma_da),
        ("sigma_dw", |r| r.sigma_dw),
        ("innovation", |r| r.innovation),
        ("innovation_var", |r| r.innovation_var),
        ("nis", |r| r.nis),
    ];
    let d = PyDict::new(py);
    for (name, f) in FIELDS {
        d.set_item(
            name,
            rows.iter().map(f).collect::<Vec<f64>>().into_pyarray(py),
        )?;
    }
    // The step's telemetry flags (`imu_ident::telemetry::FLAG_NAMES`), as integers.
    d.set_item(
        "flags",
        rows.iter()
            .map(|r| r.flags)
            .collect::<Vec<u16>>()
            .into_pyarray(py),
    )?;
    Ok(d)
}

/// Columns of `params.csv`: numbers as numpy arrays, names as lists of str.
fn params_dict<'py>(
    py: Python<'py>,
    rows: &[hal_sim::records::ParamRow],
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    let num = |f: fn(&hal_sim::records::ParamRow) -> f64| {
        rows.iter().map(f).collect::<Vec<f64>>().into_pyarray(py)
    };
    d.set_item("t", num(|r| r.t))?;
    d.set_item("sensor", PyList::new(py, rows.iter().map(|r| r.sensor))?)?;
    d.set_item(
        "component",
        rows.iter()
            .map(|r| r.component as u64)
            .collect::<Vec<u64>>()
            .into_pyarray(py),
    )?;
    d.set_item("kind", PyList::new(py, rows.iter().map(|r| r.kind))?)?;
    d.set_item("tau", num(|r| r.tau))?;
    d.set_item("sigma", num(|r| r.sigma))?;
    d.set_item("beta", num(|r| r.beta))?;
    d.set_item("sd_ln_tau", num(|r| r.sd_ln_tau))?;
    d.set_item("sd_ln_sigma", num(|r| r.sd_ln_sigma))?;
    d.set_item("sd_ln_beta", num(|r| r.sd_ln_beta))?;
    d.set_item(
        "not_identifiable",
        PyList::new(py, rows.iter().map(|r| r.not_identifiable.as_str()))?,
    )?;
    Ok(d)
}

/// `hal-sim run [--adapt]` on arrays: the firmware's 1 Hz step (in f64) over the log `t`, `z`
/// (optional truth `[dv, delta, da, dw]`) with the model (TOML text, or a path when
/// `model_is_path`). Returns `estimates` (the columns of estimates.csv), `params` (params.csv),
/// `acf` (acf.csv) and `summary` (summary.json).
#[pyfunction]
#[pyo3(signature = (t, z, model, model_is_path, adapt=false, truth=None))]
fn replay<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    model: &str,
    model_is_path: bool,
    adapt: bool,
    truth: Option<[PyReadonlyArray1<'py, f64>; 4]>,
) -> PyResult<Bound<'py, PyDict>> {
    let rows = log_rows(&t, &z, truth).map_err(value_error)?;
    let model = model.to_string();
    let (tel, summary) = py
        .detach(|| -> anyhow::Result<_> {
            let m = load_model(&model, model_is_path)?;
            let cfg = imu_ident::adapt::AdaptConfig::default();
            let run = hal_sim::replay::run::<f64>(&m, adapt.then_some(&cfg), &rows)?;
            let end = run.end_model()?;
            let tel = run.telemetry;
            let summary = hal_sim::commands::run_summary(&rows, &tel, adapt.then_some(&end))?;
            Ok((tel, summary))
        })
        .map_err(value_error)?;
    let d = PyDict::new(py);
    d.set_item("estimates", estimates_dict(py, &tel.estimate_rows())?)?;
    d.set_item("params", params_dict(py, &tel.param_rows())?)?;
    let acf = PyDict::new(py);
    let acf_rows = tel.acf_rows();
    acf.set_item(
        "t",
        acf_rows
            .iter()
            .map(|a| a.t)
            .collect::<Vec<f64>>()
            .into_pyarray(py),
    )?;
    acf.set_item(
        "sensor",
        PyList::new(py, acf_rows.iter().map(|a| a.sensor))?,
    )?;
    acf.set_item(
        "tau",
        acf_rows
            .iter()
            .map(|a| a.tau)
            .collect::<Vec<f64>>()
            .into_pyarray(py),
    )?;
    acf.set_item(
        "sigma",
        acf_rows
            .iter()
            .map(|a| a.sigma)
            .collect::<Vec<f64>>()
            .into_pyarray(py),
    )?;
    d.set_item("acf", acf)?;
    d.set_item("summary", json_to_py(py, &summary)?)?;
    Ok(d)
}

/// `hal-sim diagnose` on arrays: the verdict dict of diagnosis.json, plus
/// `suggested_model_toml` (the text of suggested-model.toml).
#[pyfunction]
#[pyo3(signature = (t, z, model, model_is_path, truth=None))]
fn diagnose<'py>(
    py: Python<'py>,
    t: PyReadonlyArray1<'py, f64>,
    z: PyReadonlyArray1<'py, f64>,
    model: &str,
    model_is_path: bool,
    truth: Option<[PyReadonlyArray1<'py, f64>; 4]>,
) -> PyResult<Bound<'py, PyAny>> {
    let rows = log_rows(&t, &z, truth).map_err(value_error)?;
    let model = model.to_string();
    let (json, suggested) = py
        .detach(|| -> anyhow::Result<_> {
            let m = load_model(&model, model_is_path)?;
            let d = hal_sim::diagnose::diagnose(&m, &rows)?;
            Ok((
                serde_json::to_value(&d)?,
                hal_sim::model_toml::to_string(&d.suggested)?,
            ))
        })
        .map_err(value_error)?;
    let d = json_to_py(py, &json)?;
    d.set_item("suggested_model_toml", suggested)?;
    Ok(d)
}

/// Checks a model (TOML text, or a path when `model_is_path`) and returns it re-serialised in
/// the canonical model-TOML form; errors name the file, line and field.
#[pyfunction]
fn model_toml(model: &str, model_is_path: bool) -> PyResult<String> {
    let m = load_model(model, model_is_path).map_err(value_error)?;
    hal_sim::model_toml::to_string(&m).map_err(value_error)
}

/// The model of a scenario (a built-in name such as `paper`, or a scenario file), as model-TOML
/// text.
#[pyfunction]
fn scenario_toml(name: &str) -> PyResult<String> {
    let sc = hal_sim::scenario::load(name).map_err(value_error)?;
    let m = sc.to_core().map_err(value_error)?;
    hal_sim::model_toml::to_string(&m).map_err(value_error)
}

/// `hal-sim simulate` without the file: `hours` of a scenario's truth model (built-in name or
/// file) drawn with `seed`. Returns `t`, `z` and `truth` (`dv`, `delta`, `da`, `dw`) as arrays.
#[pyfunction]
#[pyo3(signature = (scenario="paper", hours=None, seed=1))]
fn simulate<'py>(
    py: Python<'py>,
    scenario: &str,
    hours: Option<f64>,
    seed: u64,
) -> PyResult<Bound<'py, PyDict>> {
    let scenario = scenario.to_string();
    let rows = py
        .detach(|| -> anyhow::Result<Vec<LogRow>> {
            let sc = hal_sim::scenario::load(&scenario)?;
            let model = sc
                .to_core()
                .with_context(|| format!("scenario {scenario}"))?;
            let steps = hal_sim::commands::simulation_steps(hours.or(sc.hours), model.dt)?;
            hal_sim::sim::simulate(&model, steps, seed)
        })
        .map_err(value_error)?;
    let col = |f: fn(&LogRow) -> f64| rows.iter().map(f).collect::<Vec<f64>>().into_pyarray(py);
    let tr = |f: fn(&Truth) -> f64| {
        rows.iter()
            .map(|r| r.truth.as_ref().map_or(f64::NAN, f))
            .collect::<Vec<f64>>()
            .into_pyarray(py)
    };
    let d = PyDict::new(py);
    d.set_item("t", col(|r| r.t))?;
    d.set_item("z", col(|r| r.z))?;
    let truth = PyDict::new(py);
    truth.set_item("dv", tr(|t| t.dv))?;
    truth.set_item("delta", tr(|t| t.delta))?;
    truth.set_item("da", tr(|t| t.da))?;
    truth.set_item("dw", tr(|t| t.dw))?;
    d.set_item("truth", truth)?;
    Ok(d)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(adev, m)?)?;
    m.add_function(wrap_pyfunction!(identify, m)?)?;
    m.add_function(wrap_pyfunction!(replay, m)?)?;
    m.add_function(wrap_pyfunction!(diagnose, m)?)?;
    m.add_function(wrap_pyfunction!(model_toml, m)?)?;
    m.add_function(wrap_pyfunction!(scenario_toml, m)?)?;
    m.add_function(wrap_pyfunction!(simulate, m)?)?;
    Ok(())
}
