//! The `simulate` and `run` commands (the CLI, defined in `cli.rs` and dispatched by `main.rs`,
//! only parses arguments).

use crate::model_toml;
use crate::output::write_string;
use crate::replay::{self, Telemetry};
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
    let steps = simulation_steps(hours.or(sc.hours), model.dt)?;
    let rows = sim::simulate(&model, steps, seed)?;
    log::write(out, &rows)?;
    Ok(steps)
}

/// The number of steps of `hours` (default 12) at `dt`, as `simulate` draws them.
pub fn simulation_steps(hours: Option<f64>, dt: f64) -> Result<usize> {
    let hours = hours.unwrap_or(12.0);
    if !(hours.is_finite() && hours > 0.0) {
        return Err(anyhow!("--hours must be a positive number, got {hours}"));
    }
    Ok((hours * 3600.0 / dt).round() as usize)
}

/// `run`: replays a log through the firmware's 1 Hz step ([`imu_ident::step`], in double
/// precision); writes `estimates.csv`, `params.csv`, `acf.csv` and `summary.json` into `out`.
/// With `adapt`, the step identifies the noise model online, starting from the given model;
/// `params.csv` logs the parameters (and their Cramér-Rao deviations) at each
/// re-identification, the summary gains `identified_model` (model-TOML structure), and
/// `report.html` shows the parameters over time against their Cramér-Rao intervals (and
/// against `truth` when given), and the start and identified models side by side on the log.
pub fn run(
    log_path: &Path,
    model_path: &Path,
    out: &Path,
    ident: crate::qemu::Ident,
    truth_path: Option<&Path>,
) -> Result<serde_json::Value> {
    let adapt = ident != crate::qemu::Ident::Off;
    let model = model_toml::load(model_path)?;
    let truth = truth_path.map(model_toml::load).transpose()?;
    let rows = log::read(log_path)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let cfg = ident.config();
    let r = replay::run::<f64>(&model, cfg.as_ref(), &rows)?;
    let end = r.end_model()?;
    let json = write_run(out, &rows, &r.telemetry, adapt.then_some(&end))?;
    if adapt {
        write_run_report(
            log_path,
            out,
            &rows,
            &model,
            &end,
            &r.telemetry,
            truth.as_ref(),
        )?;
    }
    Ok(json)
}

/// `report.html` of an adaptive run: the start model and the identified one (each run fixed on
/// the log), the truth when known, and the parameters over time with their intervals.
fn write_run_report(
    log_path: &Path,
    out: &Path,
    rows: &[log::LogRow],
    start: &imu_ident::model::InsModel<f64>,
    end: &imu_ident::model::InsModel<f64>,
    tel: &Telemetry,
    truth: Option<&imu_ident::model::InsModel<f64>>,
) -> Result<()> {
    let mut runs = vec![
        crate::compare::evaluate("start model", start, rows)?,
        crate::compare::evaluate("identified model (end of run)", end, rows)?,
    ];
    if let Some(t) = truth {
        runs.push(crate::compare::evaluate("truth", t, rows)?);
    }
    let flat = tel.not_identifiable();
    let flat = if flat.is_empty() {
        String::new()
    } else {
        format!(
            "<p><b>Not identifiable from these data yet</b> (the last search's window: a Cramér-Rao deviation above half a decade): {}.</p>",
            flat.join("; ")
        )
    };
    let extra = format!(
        "<h2>Online identification over time</h2>{flat}{}",
        crate::report::parameter_plots(&tel.param_rows(), truth, rows.last().map_or(0.0, |r| r.t))?
    );
    let html = crate::report::html_with(
        &format!("Online identification on {}", log_path.display()),
        &runs,
        rows,
        None,
        "The identified model is the one the online identification ended with; both models are replayed fixed on the whole log for the table and plots.",
        &extra,
    )?;
    write_string(&out.join("report.html"), &html)
}

/// `qemu`: runs the firmware ELF under QEMU on the log with the model; writes the files of
/// [`run`] from the decoded telemetry, plus `firmware.json` (instruction counts, stack, exit).
/// Without `elf` (and `$IMU_IDENT_FIRMWARE_ELF`) the firmware is built first when it is missing
/// or older than its sources ([`crate::firmware::prepare`]).
pub fn qemu(
    log_path: &Path,
    model_path: &Path,
    ident: crate::qemu::Ident,
    out: &Path,
    elf: Option<std::path::PathBuf>,
) -> Result<serde_json::Value> {
    let adapt = ident != crate::qemu::Ident::Off;
    let model = model_toml::load(model_path)?;
    let rows = log::read(log_path)?;
    let cfg = crate::qemu::QemuConfig::default();
    let elf = crate::firmware::prepare(elf, &cfg.program)?;
    let pairs: Vec<(f64, f64)> = rows.iter().map(|r| (r.t, r.z)).collect();
    let run = crate::qemu::run_firmware(&elf, &model, ident, &pairs, &cfg)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    let fw = serde_json::json!({
        "elf": elf.display().to_string(),
        "exit_success": run.success(),
        "icount": run.icount,
        "stack": run.stack,
        "messages": run.messages,
    });
    write_string(
        &out.join("firmware.json"),
        &serde_json::to_string_pretty(&fw)?,
    )?;
    if !run.success() {
        return Err(anyhow!(
            "the firmware failed ({}): {}",
            run.status,
            run.messages.join("; ")
        ));
    }
    let end = identified_from_params(&model, &run.telemetry);
    let mut json = write_run(out, &rows, &run.telemetry, adapt.then_some(&end))?;
    json["firmware"] = fw;
    Ok(json)
}

/// The model with the last reported parameters (what the firmware ended with).
fn identified_from_params(
    start: &imu_ident::model::InsModel<f64>,
    tel: &Telemetry,
) -> imu_ident::model::InsModel<f64> {
    let mut m = start.clone();
    if let Some(last_k) = tel.params.last().map(|p| p.k) {
        for p in tel.params.iter().filter(|p| p.k == last_k) {
            p.apply_to(&mut m);
        }
    }
    m
}

/// Writes a run's files (host or firmware telemetry) and returns its summary.
pub fn write_run(
    out: &Path,
    rows: &[log::LogRow],
    tel: &Telemetry,
    identified: Option<&imu_ident::model::InsModel<f64>>,
) -> Result<serde_json::Value> {
    tel.write(out)?;
    let json = run_summary(rows, tel, identified)?;
    write_string(
        &out.join("summary.json"),
        &serde_json::to_string_pretty(&json)?,
    )?;
    Ok(json)
}

/// A run's `summary.json` (see [`write_run`]), without writing anything.
pub fn run_summary(
    rows: &[log::LogRow],
    tel: &crate::replay::Telemetry,
    identified: Option<&imu_ident::model::InsModel<f64>>,
) -> Result<serde_json::Value> {
    let summary: Summary = summarise(rows, &tel.estimate_rows(), tel.counts());
    let mut json = serde_json::to_value(&summary)?;
    if let Some(m) = identified {
        json["identified_model"] = serde_json::to_value(model_toml::ModelToml::from_core(m))?;
        let mut ks: Vec<u32> = tel.params.iter().map(|p| p.k).collect();
        ks.dedup();
        json["parameter_updates"] = ks.len().saturating_sub(1).into();
    }
    Ok(json)
}

/// Writes `diagnosis.json` and `suggested-model.toml` into `out`.
fn write_diagnosis(out: &Path, d: &crate::diagnose::Diagnosis) -> Result<()> {
    write_string(
        &out.join("diagnosis.json"),
        &serde_json::to_string_pretty(d)?,
    )?;
    write_string(
        &out.join("suggested-model.toml"),
        &model_toml::to_string(&d.suggested)?,
    )
}

/// `diagnose`: compares the model with the log, names the missing effect (if any), and writes
/// `diagnosis.json`, `suggested-model.toml` and `report.html` into `out`.
pub fn diagnose(
    log_path: &Path,
    model_path: &Path,
    out: &Path,
) -> Result<crate::diagnose::Diagnosis> {
    let model = model_toml::load(model_path)?;
    let rows = log::read(log_path)?;
    let d = crate::diagnose::diagnose(&model, &rows)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    write_diagnosis(out, &d)?;
    let runs = vec![
        crate::compare::evaluate("model", &model, &rows)?,
        crate::compare::evaluate("suggested model", &d.suggested, &rows)?,
    ];
    let html = crate::report::html(
        &format!("Diagnosis of {}", log_path.display()),
        &runs,
        &rows,
        Some(&d),
        "",
    )?;
    write_string(&out.join("report.html"), &html)?;
    Ok(d)
}

/// `compare`: runs every model on the log; writes `comparison.json` and `report.html`; returns
/// the table.
pub fn compare(log_path: &Path, models: &[std::path::PathBuf], out: &Path) -> Result<String> {
    let rows = log::read(log_path)?;
    let mut runs = Vec::new();
    for m in models {
        let model = model_toml::load(m)?;
        let name = m.file_name().map_or_else(
            || m.display().to_string(),
            |f| f.to_string_lossy().into_owned(),
        );
        runs.push(crate::compare::evaluate(&name, &model, &rows)?);
    }
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    write_string(
        &out.join("comparison.json"),
        &serde_json::to_string_pretty(&runs)?,
    )?;
    let html = crate::report::html(
        &format!("Comparison on {}", log_path.display()),
        &runs,
        &rows,
        None,
        "",
    )?;
    write_string(&out.join("report.html"), &html)?;
    Ok(crate::compare::table(&runs))
}

/// `demo`: hides an effect in `paper` data, diagnoses the nominal model, adds the named effect,
/// reruns, prints the before/after table and writes the report (and the log, models and
/// diagnosis) into `out`.
pub fn demo(effect: Option<&str>, seed: Option<u64>, hours: f64, out: &Path) -> Result<()> {
    use rand::{Rng, SeedableRng};
    let seed = seed.unwrap_or_else(|| rand::thread_rng().gen_range(0..1_000_000));
    println!("demo seed: {seed} (rerun with --seed {seed})");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let candidate = match effect {
        Some(e) => crate::hidden::by_label(e).ok_or_else(|| {
            let names: Vec<String> = crate::candidates::LIBRARY
                .iter()
                .map(|c| c.label())
                .collect();
            anyhow!("--effect {e:?}: not in the library ({})", names.join(", "))
        })?,
        None => crate::candidates::LIBRARY[rng.gen_range(0..crate::candidates::LIBRARY.len())],
    };
    let nominal = scenario::load("paper")?.to_core()?;
    let truth = crate::hidden::truth(&nominal, candidate, &mut rng)
        .ok_or_else(|| anyhow!("hidden effect does not fit"))?;
    let steps = (hours * 3600.0 / nominal.dt).round() as usize;
    let rows = sim::simulate(&truth, steps, seed)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    log::write(&out.join("log.csv"), &rows)?;
    write_string(
        &out.join("nominal-model.toml"),
        &model_toml::to_string(&nominal)?,
    )?;
    write_string(
        &out.join("hidden-truth.toml"),
        &model_toml::to_string(&truth)?,
    )?;
    println!(
        "hidden effect: {} (its parameters are in {}/hidden-truth.toml)",
        candidate.label(),
        out.display()
    );
    println!("diagnosing the nominal model on {hours} h of data (innovations only, no truth)...");
    let d = crate::diagnose::diagnose(&nominal, &rows)?;
    write_diagnosis(out, &d)?;
    match (d.sensor, d.effect) {
        (Some(s), Some(e)) => println!("verdict: {} {s}/{e}: {}", d.verdict, d.explanation),
        _ => println!("verdict: adequate"),
    }
    if !d.indistinguishable_from.is_empty() {
        println!(
            "  (indistinguishable on this data from: {}; chosen by {})",
            d.indistinguishable_from.join(", "),
            d.chosen_by
        );
    }
    for l in &d.limits {
        println!("  limit ({}): {}", l.candidates.join(" / "), l.why);
    }
    let runs = vec![
        crate::compare::evaluate("nominal", &nominal, &rows)?,
        crate::compare::evaluate("nominal + named effect", &d.suggested, &rows)?,
        crate::compare::evaluate("oracle (hidden truth)", &truth, &rows)?,
    ];
    println!("\n{}", crate::compare::table(&runs));
    let note = format!(
        "Hidden effect {} in paper data, seed {seed}, {hours} h.",
        candidate.label()
    );
    // The online identification from the nominal model, on the same data (params over time).
    let cfg = imu_ident::adapt::AdaptConfig::default();
    let tel = crate::replay::run::<f64>(&nominal, Some(&cfg), &rows)?.telemetry;
    let adaptive = format!(
        "<h2>Online identification (run --adapt from the nominal model)</h2>{}",
        crate::report::parameter_plots(
            &tel.param_rows(),
            Some(&truth),
            rows.last().map_or(0.0, |r| r.t)
        )?
    );
    let html = crate::report::html_with(
        "imu-ident demo: find the missing effect",
        &runs,
        &rows,
        Some(&d),
        &note,
        &adaptive,
    )?;
    write_string(&out.join("report.html"), &html)?;
    println!("report: {}", out.join("report.html").display());
    Ok(())
}
