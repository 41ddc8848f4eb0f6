//! Self-contained HTML reports with embedded SVG plots (plotters).

use crate::compare::ModelRun;
use crate::diagnose::Diagnosis;
use crate::log::LogRow;
use anyhow::{anyhow, Result};
use plotters::prelude::*;

const COLORS: [RGBColor; 4] = [
    RGBColor(200, 40, 40),
    RGBColor(30, 100, 200),
    RGBColor(20, 150, 60),
    RGBColor(150, 60, 170),
];

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("plot: {e:?}")
}

/// A confidence band drawn as a shaded area: `(x, lo, hi)` points.
#[derive(Debug, Clone, Default)]
pub struct Band {
    /// Legend label.
    pub name: String,
    /// `(x, lo, hi)`, in x order.
    pub pts: Vec<(f64, f64, f64)>,
}

impl Band {
    /// A band constant in y (`lo..hi`) over `x0..x1`.
    pub fn flat(name: &str, x0: f64, x1: f64, lo: f64, hi: f64) -> Self {
        Self {
            name: name.to_string(),
            pts: vec![(x0, lo, hi), (x1, lo, hi)],
        }
    }
}

/// Shading of the bands (light grey-blue), under the lines.
const BAND_FILL: RGBColor = RGBColor(120, 150, 220);

/// A line chart of several series `(name, points)` with optional horizontal band lines.
pub fn line_chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    bands: &[f64],
) -> Result<String> {
    chart(title, x_label, y_label, series, &[], bands)
}

/// The x range of the finite points of `series`.
fn x_range(series: &[(String, Vec<(f64, f64)>)]) -> (f64, f64) {
    series
        .iter()
        .flat_map(|s| s.1.iter())
        .filter(|p| p.0.is_finite())
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)))
}

/// A line chart of `series` over shaded confidence `bands`, with horizontal reference lines
/// at `hlines`.
pub fn chart(
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[(String, Vec<(f64, f64)>)],
    bands: &[Band],
    hlines: &[f64],
) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (860, 320)).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        let band_pts = bands
            .iter()
            .flat_map(|b| b.pts.iter().flat_map(|p| [(p.0, p.1), (p.0, p.2)]));
        let pts = series
            .iter()
            .flat_map(|s| s.1.iter().copied())
            .chain(band_pts)
            .filter(|p| p.0.is_finite() && p.1.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in pts {
            (x0, x1, y0, y1) = (x0.min(p.0), x1.max(p.0), y0.min(p.1), y1.max(p.1));
        }
        for b in hlines {
            (y0, y1) = (y0.min(*b), y1.max(*b));
        }
        if x0 >= x1 {
            x1 = x0 + 1.0;
        }
        if y0 >= y1 {
            y1 = y0 + 1.0;
        }
        let pad = 0.05 * (y1 - y0);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| axis_label(*v))
            .draw()
            .map_err(err)?;
        for b in bands {
            let ok: Vec<_> = b
                .pts
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite() && p.2.is_finite())
                .collect();
            let outline: Vec<(f64, f64)> = ok
                .iter()
                .map(|p| (p.0, p.2))
                .chain(ok.iter().rev().map(|p| (p.0, p.1)))
                .collect();
            chart
                .draw_series(std::iter::once(Polygon::new(
                    outline,
                    BAND_FILL.mix(0.3).filled(),
                )))
                .map_err(err)?
                .label(b.name.as_str())
                .legend(|(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 18, y + 5)], BAND_FILL.mix(0.3).filled())
                });
        }
        for b in hlines {
            chart
                .draw_series(LineSeries::new([(x0, *b), (x1, *b)], BLACK.mix(0.5)))
                .map_err(err)?;
        }
        for (i, (name, p)) in series.iter().enumerate() {
            let c = COLORS[i % COLORS.len()];
            chart
                .draw_series(LineSeries::new(
                    p.iter()
                        .copied()
                        .filter(|q| q.0.is_finite() && q.1.is_finite()),
                    c,
                ))
                .map_err(err)?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c));
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        root.present().map_err(err)?;
    }
    Ok(svg)
}

/// `v` with 4 significant digits and its unit (plain notation from 1e-3 to 1e4, else
/// scientific); `-` for a non-finite value.
pub fn sig4(v: f64, unit: &str) -> String {
    let num = if !v.is_finite() {
        return "-".to_string();
    } else if v == 0.0 {
        "0.000".to_string()
    } else {
        let mag = v.abs().log10().floor();
        if (-3.0..4.0).contains(&mag) {
            let decimals = (3.0 - mag).max(0.0) as usize;
            format!("{v:.decimals$}")
        } else {
            format!("{v:.3e}")
        }
    };
    if unit.is_empty() {
        num
    } else {
        format!("{num} {unit}")
    }
}

/// An axis tick label: [`sig4`] without its trailing zeros (`2500`, `0.025`, `4.85e-7`), so
/// that values far from 1 do not all print as `0.0`.
pub fn axis_label(v: f64) -> String {
    let s = sig4(v, "");
    match s.split_once('e') {
        Some((m, e)) if m.contains('.') => {
            format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
        }
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_string(),
        _ => s,
    }
}

/// Normalised-innovation ACF of each run with its 99 % band.
pub fn acf_plot(runs: &[ModelRun]) -> Result<String> {
    let series: Vec<_> = runs
        .iter()
        .map(|r| {
            (
                r.name.clone(),
                r.whiteness
                    .acf
                    .iter()
                    .enumerate()
                    .skip(1)
                    .map(|(k, v)| (k as f64, *v))
                    .collect(),
            )
        })
        .collect();
    let band = runs.first().map_or(0.0, |r| r.whiteness.band);
    let (x0, x1) = x_range(&series);
    chart(
        "Innovation whiteness: ACF of nu/sqrt(S), 99 % band",
        "lag [s]",
        "r_k",
        &series,
        &[Band::flat("99 % band (white)", x0, x1, -band, band)],
        &[0.0],
    )
}

/// Windowed mean NIS of each run with its 99 % band.
pub fn nis_plot(runs: &[ModelRun]) -> Result<String> {
    let series: Vec<_> = runs
        .iter()
        .map(|r| {
            (
                r.name.clone(),
                r.nis_windows
                    .iter()
                    .map(|w| (w.t_end / 3600.0, w.nis_mean))
                    .collect(),
            )
        })
        .collect();
    let band = runs.first().map_or([0.0, 0.0], |r| r.nis_band);
    let (x0, x1) = x_range(&series);
    chart(
        "Windowed NIS (10-min mean), 99 % chi-square band",
        "t [h]",
        "mean NIS",
        &series,
        &[Band::flat("99 % chi-square band", x0, x1, band[0], band[1])],
        &[1.0],
    )
}

/// ACF of each estimated sensor error of one run against its model's 99 % Monte Carlo band.
pub fn estimate_acf_plots(run: &ModelRun) -> Result<String> {
    let mut html = String::new();
    for a in &run.estimate_acf {
        let pts = |v: &[f64]| {
            a.lags
                .iter()
                .copied()
                .zip(v.iter().copied())
                .collect::<Vec<_>>()
        };
        let series = vec![
            ("estimates on the data".to_string(), pts(&a.data)),
            ("model (Monte Carlo mean)".to_string(), pts(&a.model)),
        ];
        let band = Band {
            name: "model 99 % band (Monte Carlo)".to_string(),
            pts: a
                .lags
                .iter()
                .zip(a.lo.iter().zip(&a.hi))
                .map(|(&x, (&lo, &hi))| (x, lo, hi))
                .collect(),
        };
        let title = format!(
            "{}: ACF of the estimated {} error vs the model ({} of {} lags outside)",
            run.name,
            a.sensor,
            a.outside.len(),
            a.lags.len().saturating_sub(1)
        );
        html += &chart(&title, "lag [s]", "r", &series, &[band], &[0.0])?;
    }
    Ok(html)
}

/// Tilt error `true_delta - delta_hat` and `3 sigma_delta` of one run (truth only), every 30 s.
pub fn tilt_plot(run: &ModelRun, log: &[LogRow]) -> Result<Option<String>> {
    let mut err_pts = vec![];
    let mut band = vec![];
    let mut j = 0;
    for (i, e) in run.estimates.iter().enumerate() {
        while j < log.len() && log[j].t < e.t {
            j += 1;
        }
        let Some(tr) = log.get(j).and_then(|r| r.truth) else {
            return Ok(None);
        };
        if i % 30 == 0 {
            let h = e.t / 3600.0;
            err_pts.push((h, (tr.delta - e.delta_hat) * 1e6));
            let s3 = 3.0 * e.sigma_delta * 1e6;
            band.push((h, -s3, s3));
        }
    }
    let series = vec![("tilt error (truth - estimate)".to_string(), err_pts)];
    let band = Band {
        name: "±3 sigma (filter)".to_string(),
        pts: band,
    };
    chart(
        &format!("{}: tilt error against ±3 sigma", run.name),
        "t [h]",
        "µrad",
        &series,
        &[band],
        &[0.0],
    )
    .map(Some)
}

/// How the parameter plots' shaded intervals are obtained (printed under them).
pub const CR_INTERVAL_NOTE: &str = "Shaded: the approximate 95 % Cramér-Rao interval, value x exp(±1.96 sd), where sd is the standard deviation of the logarithm of the value (params.csv's sd_ln_* columns) from the Fisher information of the online identification's window: with the global stage, the last search's window (each marginal deviation, the other parameters free); otherwise the recursion's exponential window as that window weighs it (the sandwich variance of the windowed estimate). An interval appears once that information is positive definite; it is clipped to a third of the smallest and three times the largest plotted value, so that the weak early intervals do not flatten the plot.";

/// One plot per identified parameter of a `run --adapt` (its `params` records) over time, with
/// its Cramér-Rao interval as a shaded band, and the true value when the truth model is known
/// (same sensor, component index and kind).
/// Each value holds until the next re-identification, so the lines and bands are drawn as
/// steps, the last one to `t_end` [s] (the end of the run).
pub fn parameter_plots(
    params: &[crate::records::ParamRow],
    truth: Option<&imu_ident::model::InsModel<f64>>,
    t_end: f64,
) -> Result<String> {
    use crate::records::ParamRow;
    let mut truth_rows = Vec::new();
    if let Some(m) = truth {
        imu_ident::telemetry::model_params(m, 0, 0.0, |p| truth_rows.push(*p));
    }
    let mut keys: Vec<(&str, usize, &str)> = params
        .iter()
        .map(|p| (p.sensor, p.component, p.kind))
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let mut html = String::new();
    for (sensor, comp, kind) in keys {
        let rows: Vec<_> = params
            .iter()
            .filter(|p| (p.sensor, p.component, p.kind) == (sensor, comp, kind))
            .collect();
        let last_t = rows.last().map_or(0.0, |p| p.t);
        let t1 = t_end.max(last_t) / 3600.0;
        // Start of each record's hold and the start of the next (the last holds to `t1`).
        let holds: Vec<(f64, f64)> = rows
            .iter()
            .enumerate()
            .map(|(i, p)| (p.t / 3600.0, rows.get(i + 1).map_or(t1, |q| q.t / 3600.0)))
            .collect();
        let true_row = truth_rows.iter().find(|r| {
            r.sensor.name() == sensor && usize::from(r.component) == comp && r.kind.name() == kind
        });
        type Get = fn(&ParamRow) -> (f64, f64);
        type GetTrue = fn(&imu_ident::step::ParamRecord) -> f32;
        let base = match sensor {
            "accel" => "m/s^2",
            "gyro" => "rad/s",
            _ => "m/s",
        };
        // params.csv's `sigma`: sqrt(q) for a random walk, the density for white noise.
        let per = imu_ident::model::ComponentKind::from_name(kind)
            .map_or("", imu_ident::model::ComponentKind::summary_sigma_per);
        let sigma_unit = format!("{base}{per}");
        let fields: [(&str, &str, Get, GetTrue); 3] = [
            ("tau", "s", |p| (p.tau, p.sd_ln_tau), |r| r.tau),
            (
                "sigma",
                &sigma_unit,
                |p| (p.sigma, p.sd_ln_sigma),
                |r| r.sigma,
            ),
            ("beta", "rad/s", |p| (p.beta, p.sd_ln_beta), |r| r.beta),
        ];
        for (name, unit, get, get_true) in fields {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .zip(&holds)
                .flat_map(|(p, &(a, b))| [(a, get(p).0), (b, get(p).0)])
                .filter(|q| q.1.is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            let truth_v = true_row
                .map(|r| f64::from(get_true(r)))
                .filter(|v| v.is_finite());
            let (vmin, vmax) = pts
                .iter()
                .map(|q| q.1)
                .chain(truth_v)
                .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
            let band_pts: Vec<(f64, f64, f64)> = rows
                .iter()
                .zip(&holds)
                .filter_map(|(p, &(a, b))| {
                    let (v, sd) = get(p);
                    let (lo, hi) = ParamRow::interval95(v, sd)?;
                    let (lo, hi) = (lo.max(vmin / 3.0), hi.min(3.0 * vmax));
                    Some([(a, lo, hi), (b, lo, hi)])
                })
                .flatten()
                .collect();
            let bands: Vec<Band> = if band_pts.is_empty() {
                Vec::new()
            } else {
                vec![Band {
                    name: "95 % Cramér-Rao interval".to_string(),
                    pts: band_pts,
                }]
            };
            let mut series = vec![("identified".to_string(), pts)];
            if let Some(v) = truth_v {
                series.push((format!("truth {}", sig4(v, unit)), vec![(0.0, v), (t1, v)]));
            }
            html += &chart(
                &format!("Online identification: {sensor} {comp} ({kind}) {name}"),
                "t [h]",
                &format!("{name} [{unit}]"),
                &series,
                &bands,
                &[],
            )?;
        }
    }
    html += &format!("<p>{}</p>", esc(CR_INTERVAL_NOTE));
    Ok(html)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// The candidate effects, best score first, each with its fitted parameters explained in one
/// line (scores in nats: log-likelihood gain minus the BIC penalty).
fn candidate_table(cands: &[crate::diagnose::CandidateScore]) -> String {
    let mut sorted: Vec<_> = cands.iter().collect();
    sorted.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut h = "<table><tr><th>candidate</th><th>log-lik gain</th><th>BIC penalty</th><th>score</th><th style=\"text-align:left\">what the fit means</th></tr>".to_string();
    for c in sorted {
        h += &format!(
            "<tr><td style=\"text-align:left\">{}</td><td>{}</td><td>{}</td><td>{}</td><td style=\"text-align:left\">{}</td></tr>",
            esc(&c.label),
            sig4(c.gain, "nats"),
            sig4(c.penalty, "nats"),
            sig4(c.score, "nats"),
            esc(&c.explanation)
        );
    }
    h + "</table>"
}

/// The HTML report: the before/after table, the diagnosis (if any) and the plots.
pub fn html(
    title: &str,
    runs: &[ModelRun],
    log: &[LogRow],
    diagnosis: Option<&Diagnosis>,
    notes: &str,
) -> Result<String> {
    html_with(title, runs, log, diagnosis, notes, "")
}

/// [`html`] with `extra` HTML (e.g. [`parameter_plots`]) at the end.
pub fn html_with(
    title: &str,
    runs: &[ModelRun],
    log: &[LogRow],
    diagnosis: Option<&Diagnosis>,
    notes: &str,
    extra: &str,
) -> Result<String> {
    let mut h = format!(
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{t}</title><style>body{{font-family:sans-serif;max-width:920px;margin:auto}}table{{border-collapse:collapse}}td,th{{border:1px solid #999;padding:3px 8px;text-align:right}}th{{background:#eee}}.ok{{color:#180}}.bad{{color:#b00}}</style></head><body><h1>{t}</h1>",
        t = esc(title)
    );
    if !notes.is_empty() {
        h += &format!("<p>{}</p>", esc(notes));
    }
    if let Some(d) = diagnosis {
        let cls = if d.verdict == "adequate" { "ok" } else { "bad" };
        h += &format!(
            "<h2>Diagnosis: <span class=\"{cls}\">{}</span></h2>",
            d.verdict
        );
        if let (Some(s), Some(e)) = (d.sensor, d.effect) {
            // A replacement names the component it replaces; its explanation starts with
            // "replace ...".
            let what = match &d.replaces {
                Some(r) => format!("{s} / {} → {e}", r.kind),
                None => format!("{s} / {e}"),
            };
            h += &format!("<p><b>{}</b>: {}</p>", esc(&what), esc(&d.explanation));
            h += &format!(
                "<pre>{}</pre>",
                esc(&toml::to_string(&d.params).unwrap_or_default())
            );
        } else {
            h += &format!("<p>{}</p>", esc(&d.explanation));
        }
        if !d.indistinguishable_from.is_empty() {
            h += &format!(
                "<p>Indistinguishable on this data from: {} (chosen by {}: the data cannot tell them apart, so each was simulated as the truth and the named one loses least tilt accuracy on average over them; matrix in diagnosis.json, <code>tie</code>).</p>",
                esc(&d.indistinguishable_from.join(", ")),
                esc(d.chosen_by)
            );
        }
        let ev = &d.evidence;
        h += &format!(
            "<p>Where the model fails: {} of {} innovation-ACF lags outside the 99 % band (Ljung-Box p = {}); {} of {} ten-minute NIS windows outside [{}, {}].</p>",
            ev.failed_lags.len(), ev.whiteness.dof, sig4(ev.whiteness.p_value, ""), ev.failed_windows.len(), ev.nis_windows.len(), sig4(ev.nis_window_band[0], ""), sig4(ev.nis_window_band[1], "")
        );
        h += &candidate_table(&ev.candidates);
        if !d.limits.is_empty() {
            h += "<h3>What these data cannot show</h3><ul>";
            for l in &d.limits {
                h += &format!(
                    "<li><b>{}</b>: {}</li>",
                    esc(&l.candidates.join(" / ")),
                    esc(&l.why)
                );
            }
            h += "</ul>";
        }
    }
    h += "<h2>Before and after</h2><table><tr><th>model</th><th>log-likelihood</th><th>Ljung-Box p</th><th>ACF lags out</th><th>mean NIS</th><th>NIS windows out</th><th>tilt RMS</th><th>outside 3σ</th></tr>";
    for r in runs {
        h += &format!(
            "<tr><td style=\"text-align:left\">{}</td><td>{}</td><td>{}</td><td>{}/{}</td><td>{}</td><td>{}/{}</td><td>{}</td><td>{}</td></tr>",
            esc(&r.name), sig4(r.log_likelihood, "nats"), sig4(r.whiteness.p_value, ""), r.whiteness.failed_lags.len(), r.whiteness.dof, sig4(r.summary.nis_mean, ""), r.nis_failed, r.nis_windows.len(),
            r.summary.tilt_rms.map_or("-".into(), |v| sig4(v * 1e6, "µrad")),
            r.summary.tilt_outside_3sigma.map_or("-".into(), |v| sig4(v * 100.0, "%"))
        );
    }
    h += "</table>";
    h += &acf_plot(runs)?;
    h += &nis_plot(runs)?;
    for r in runs {
        h += &estimate_acf_plots(r)?;
    }
    for r in runs {
        if let Some(svg) = tilt_plot(r, log)? {
            h += &svg;
        }
    }
    h += extra;
    h += "</body></html>";
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sig4_keeps_four_significant_digits_and_the_unit() {
        assert_eq!(sig4(347.891, "µrad"), "347.9 µrad");
        assert_eq!(sig4(0.001_234_56, ""), "0.001235");
        assert_eq!(sig4(85_583.2, "nats"), "8.558e4 nats");
        assert_eq!(sig4(-2.5e-7, "rad"), "-2.500e-7 rad");
        assert_eq!(sig4(f64::NAN, "rad"), "-");
    }

    #[test]
    fn bands_are_filled_polygons() {
        let series = vec![("x".to_string(), vec![(0.0, 0.0), (1.0, 1.0)])];
        let svg = chart(
            "t",
            "x",
            "y",
            &series,
            &[Band::flat("band", 0.0, 1.0, -1.0, 2.0)],
            &[],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(svg.contains("<polygon"), "no filled band in the SVG");
    }
}
