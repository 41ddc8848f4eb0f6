//! `DIR/report.html` of `hal-sim nav`: a self-contained page with SVG plots (plotters, the
//! shaded bands of [`crate::report::chart`]) and tables:
//! - the summary (and the truth statistics with the NEES bands, `--truth`);
//! - the track ([`super::track`]), east against north from the first GNSS fix: the GNSS fixes
//!   (used and withheld), the solution, and the solution during the outages highlighted;
//! - the position errors N, E, D against the filter's +-3 sigma (with `--truth`), else the
//!   pre-fit GNSS position innovations against +-3 sqrt(S);
//! - with `--truth`, the velocity and roll/pitch/yaw errors against +-3 sigma;
//! - the velocity and attitude sigmas;
//! - the estimated gyro and accelerometer errors per axis with +-3 sigma (and the truth);
//! - the outage table (`outages.json`), the identified factors (`--identify`) and the online
//!   identification's factors over time (`--adapt`).

use super::identify::{Identified, FACTORS, IDENTIFIABLE_SD, SHIFT_PER_DECADE};
use super::plot::{break_gaps, chart};
use super::records::EpochRecord;
use super::truth::{ErrorRow, TruthComparison};
use super::NavRun;
use crate::report::sig4;
use anyhow::Result;
use std::path::Path;

type Series = Vec<(String, Vec<(f64, f64)>)>;

/// `(t, value, sigma)` points with breaks where `t` jumps by more than `max_dx`.
fn broken(pts: &[(f64, f64, f64)], max_dx: f64) -> Vec<(f64, f64, f64)> {
    let nan = f64::NAN;
    break_gaps(pts, |p| p.0, max_dx, (nan, nan, nan))
}

/// Three times the median spacing of the epochs [s] (a longer step is a gap in the plots).
fn gap_limit(epochs: &[EpochRecord]) -> f64 {
    let mut dt: Vec<f64> = epochs.windows(2).map(|w| w[1].t - w[0].t).collect();
    dt.sort_by(f64::total_cmp);
    3.0 * dt.get(dt.len() / 2).copied().unwrap_or(1.0)
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// One quantity against `+-3 sigma`: `(t, value, sigma)` points.
fn against_band(
    title: &str,
    unit: &str,
    pts: &[(f64, f64, f64)],
    what: &str,
    max_dx: f64,
) -> Result<String> {
    let pts = broken(pts, max_dx);
    let series: Series = vec![(what.to_string(), pts.iter().map(|p| (p.0, p.1)).collect())];
    let band = pts.iter().map(|p| (p.0, -3.0 * p.2, 3.0 * p.2)).collect();
    let bands = [("±3 sigma (filter)".to_string(), band)];
    chart(title, "t - t0 [s]", unit, &series, &bands, true)
}

/// One estimate with a `+-3 sigma` band around it and, optionally, the truth.
fn estimate_with_band(
    title: &str,
    unit: &str,
    pts: &[(f64, f64, f64)],
    truth: Option<Vec<(f64, f64)>>,
    max_dx: f64,
) -> Result<String> {
    let pts = broken(pts, max_dx);
    let mut series: Series = vec![(
        "estimate".to_string(),
        pts.iter().map(|p| (p.0, p.1)).collect(),
    )];
    if let Some(t) = truth {
        let nan = f64::NAN;
        series.push((
            "truth".to_string(),
            break_gaps(&t, |p| p.0, max_dx, (nan, nan)),
        ));
    }
    let band = pts
        .iter()
        .map(|p| (p.0, p.1 - 3.0 * p.2, p.1 + 3.0 * p.2))
        .collect();
    let bands = [("estimate ±3 sigma".to_string(), band)];
    chart(title, "t - t0 [s]", unit, &series, &bands, true)
}

/// The three components of `get` over time.
fn sigma_chart(
    title: &str,
    unit: &str,
    epochs: &[EpochRecord],
    get: fn(&EpochRecord) -> [f64; 3],
    names: [&str; 3],
) -> Result<String> {
    let t0 = epochs.first().map_or(0.0, |e| e.t);
    let max_dx = gap_limit(epochs);
    let nan = f64::NAN;
    let series: Series = (0..3)
        .map(|i| {
            let pts: Vec<(f64, f64)> = epochs.iter().map(|e| (e.t - t0, get(e)[i])).collect();
            (
                names[i].to_string(),
                break_gaps(&pts, |p| p.0, max_dx, (nan, nan)),
            )
        })
        .collect();
    chart(title, "t - t0 [s]", unit, &series, &[], false)
}

const NED: [&str; 3] = ["north", "east", "down"];
const RPY: [&str; 3] = ["roll", "pitch", "yaw"];

/// The plots of the errors against the truth (position, velocity, attitude).
fn truth_plots(cmp: &TruthComparison, t0: f64, max_dx: f64) -> Result<String> {
    let mut h = String::new();
    let groups: [(&str, &str, usize, [&str; 3]); 3] = [
        ("Position error", "m", 0, NED),
        ("Velocity error", "m/s", 3, NED),
        ("Attitude error", "deg", 6, RPY),
    ];
    for (what, unit, k, names) in groups {
        for (i, name) in names.iter().enumerate() {
            let pts: Vec<(f64, f64, f64)> = cmp
                .rows
                .iter()
                .map(|r: &ErrorRow| (r.t - t0, r.errors()[k + i], r.sigmas()[k + i]))
                .collect();
            h += &against_band(
                &format!("{what} {name} (solution - truth) against ±3 sigma"),
                unit,
                &pts,
                "error",
                max_dx,
            )?;
        }
    }
    Ok(h)
}

/// Pre-fit GNSS position innovations against `+-3 sqrt(S)` (no truth).
fn innovation_plots(epochs: &[EpochRecord], t0: f64, max_dx: f64) -> Result<String> {
    let mut h = String::new();
    for (i, name) in NED.iter().enumerate() {
        let pts: Vec<(f64, f64, f64)> = epochs
            .iter()
            .filter(|e| e.fused && e.innovation[i].is_finite())
            .map(|e| (e.t - t0, e.innovation[i], e.inn_sd[i]))
            .collect();
        h += &against_band(
            &format!("GNSS position innovation {name} (pre-fit) against ±3 sqrt(S)"),
            "m",
            &pts,
            "innovation",
            max_dx,
        )?;
    }
    Ok(h)
}

/// The estimated sensor errors with their `+-3 sigma` (and the truth when known).
fn sensor_plots(
    run: &NavRun,
    cmp: Option<&TruthComparison>,
    t0: f64,
    max_dx: f64,
) -> Result<String> {
    // Gyro in deg/h (rad/s times this), accelerometer in m/s^2.
    let deg_h = 180.0 / std::f64::consts::PI * 3600.0;
    let mut h = String::new();
    for (sensor, unit, k) in [("gyro", "deg/h", deg_h), ("accelerometer", "m/s^2", 1.0)] {
        for (i, axis) in ["x", "y", "z"].iter().enumerate() {
            let gyro = sensor == "gyro";
            let pts: Vec<(f64, f64, f64)> = run
                .epochs
                .iter()
                .map(|e| {
                    let (b, s) = if gyro {
                        (e.bg, e.sd_bg)
                    } else {
                        (e.ba, e.sd_ba)
                    };
                    (e.t - t0, b[i] * k, s[i] * k)
                })
                .collect();
            // truth = estimate - (estimate - truth).
            let truth = cmp.map(|c| {
                c.rows
                    .iter()
                    .filter_map(|r| {
                        let e = run.epochs.get(run.epochs.partition_point(|e| e.t < r.t))?;
                        let (est, d) = if gyro {
                            (e.bg[i], [r.err_bg_x, r.err_bg_y, r.err_bg_z][i])
                        } else {
                            (e.ba[i], [r.err_ba_x, r.err_ba_y, r.err_ba_z][i])
                        };
                        d.is_finite().then_some((r.t - t0, (est - d) * k))
                    })
                    .collect::<Vec<_>>()
            });
            let truth = truth.filter(|t| !t.is_empty());
            h += &estimate_with_band(
                &format!("Estimated {sensor} error, body {axis}"),
                unit,
                &pts,
                truth,
                max_dx,
            )?;
        }
    }
    Ok(h)
}

fn row(cells: &[String]) -> String {
    let mut s = "<tr>".to_string();
    for (i, c) in cells.iter().enumerate() {
        if i == 0 {
            s += &format!("<td style=\"text-align:left\">{c}</td>");
        } else {
            s += &format!("<td>{c}</td>");
        }
    }
    s + "</tr>"
}

fn header(cells: &[&str]) -> String {
    let mut s = "<tr>".to_string();
    for c in cells {
        s += &format!("<th>{}</th>", esc(c));
    }
    s + "</tr>"
}

fn three(v: &[f64; 3], unit: &str) -> String {
    v.iter()
        .map(|x| sig4(*x, unit))
        .collect::<Vec<_>>()
        .join(" / ")
}

fn summary_table(run: &NavRun) -> String {
    let s = &run.summary;
    let mut h = "<table>".to_string();
    let kv = |k: &str, v: String| row(&[esc(k), esc(&v)]);
    h += &kv("model", s.model.clone());
    h += &kv("IMU / GNSS", format!("{} / {}", s.imu, s.gnss));
    h += &kv("core precision", s.precision.to_string());
    h += &kv(
        "GNSS epochs (fused / gated / withheld)",
        format!("{} ({} / {} / {})", s.epochs, s.fused, s.gated, s.withheld),
    );
    h += &kv(
        "mean NIS per axis pos N, E, D, vel N, E, D (1 if consistent)",
        s.mean_nis_axis
            .iter()
            .map(|x| sig4(*x, ""))
            .collect::<Vec<_>>()
            .join(" / "),
    );
    h += &kv("innovation log-likelihood", sig4(s.loglik, "nats"));
    if let Some(c) = &s.nhc {
        h += &kv(
            "non-holonomic constraint (--nhc): sd, lever F/R/D",
            format!("{}, {}", sig4(c.sd, "m/s"), three(&c.lever, "m")),
        );
        h += &kv(
            "constraint updates (gated / in outages)",
            format!("{} ({} / {})", c.updates, c.gated, c.in_outages),
        );
        h += &kv(
            "constraint mean NIS body y, z (1 if consistent); RMS pre-fit innovation",
            format!(
                "{} / {}; {} / {}",
                sig4(c.mean_nis_axis[0], ""),
                sig4(c.mean_nis_axis[1], ""),
                sig4(c.rms_innovation[0], "m/s"),
                sig4(c.rms_innovation[1], "m/s")
            ),
        );
    }
    if let Some(z) = &s.zupt {
        h += &kv(
            "zero-velocity updates (--zupt): sd; rest below rate, specific force, speed",
            format!(
                "{}; {}, {}, {}",
                sig4(z.sd, "m/s"),
                sig4(z.detector[0], "rad/s"),
                sig4(z.detector[1], "m/s²"),
                sig4(z.detector[2], "m/s")
            ),
        );
        h += &kv(
            "zero-velocity updates (gated / in outages); mean NIS per axis",
            format!(
                "{} ({} / {}); {}",
                z.updates,
                z.gated,
                z.in_outages,
                sig4(z.mean_nis_axis, "")
            ),
        );
    }
    h += &kv("heading aligned", s.heading_known.to_string());
    h += &kv("IMU gaps > 0.1 s", s.imu_gaps.to_string());
    h += &kv("run time", sig4(s.run_seconds, "s"));
    h + "</table>"
}

fn truth_table(cmp: &TruthComparison) -> String {
    let s = &cmp.summary;
    let pct = |v: &[f64; 3]| three(&v.map(|x| 100.0 * x), "%");
    let mut h = format!(
        "<p>Against the truth over {} epochs ({} before the heading was known and {} outside the truth's span left out). A consistent filter has 0.27 % of the epochs outside 3 sigma on each axis, a mean NEES of 9 and 1 % of the epochs outside the per-epoch band.</p><table>",
        s.epochs, s.epochs_before_heading, s.epochs_without_truth
    );
    h += &header(&["", "RMS", "outside 3 sigma"]);
    h += &row(&[
        "position N / E / D".into(),
        three(&s.rms_pos_m, "m"),
        pct(&s.outside_3sigma_pos),
    ]);
    h += &row(&[
        "velocity N / E / D".into(),
        three(&s.rms_vel_m_s, "m/s"),
        pct(&s.outside_3sigma_vel),
    ]);
    h += &row(&[
        "roll / pitch / yaw".into(),
        three(&s.rms_att_deg, "deg"),
        pct(&s.outside_3sigma_att),
    ]);
    h += "</table><table>";
    h += &header(&["NEES (9 dof)", "value", "99 % band"]);
    h += &row(&[
        format!(
            "mean over {} epochs (<span class=\"{}\">{}</span>)",
            s.nees_epochs,
            if s.nees_inside_band99_mean {
                "ok"
            } else {
                "bad"
            },
            if s.nees_inside_band99_mean {
                "inside"
            } else {
                "outside"
            }
        ),
        sig4(s.nees_mean, ""),
        format!(
            "[{}, {}] (chi2(9n)/n, independent epochs)",
            sig4(s.nees_band99_mean[0], ""),
            sig4(s.nees_band99_mean[1], "")
        ),
    ]);
    h += &row(&[
        format!(
            "mean over {} effective independent epochs (<span class=\"{}\">{}</span>)",
            sig4(s.nees_n_effective, ""),
            if s.nees_consistent { "ok" } else { "bad" },
            if s.nees_consistent {
                "inside: consistent"
            } else {
                "outside: inconsistent"
            }
        ),
        sig4(s.nees_mean, ""),
        format!(
            "[{}, {}] (chi2(9 n_eff)/n_eff, n_eff from the NEES autocorrelation)",
            sig4(s.nees_band99_effective[0], ""),
            sig4(s.nees_band99_effective[1], "")
        ),
    ]);
    h += &row(&[
        "epochs outside the per-epoch band".into(),
        sig4(100.0 * s.nees_outside_epoch_band, "%"),
        format!(
            "[{}, {}] (chi2(9))",
            sig4(s.nees_band99_epoch[0], ""),
            sig4(s.nees_band99_epoch[1], "")
        ),
    ]);
    h + "</table>"
}

fn outage_table(run: &NavRun, t0: f64) -> String {
    let Some(o) = &run.outages else {
        return "<p>No outage schedule (<code>--outages</code>).</p>".to_string();
    };
    let mut h = format!(
        "<p>Horizontal error at the end of each outage against the GNSS reference: RMS {}, median {}, max {} over {} outages ({} unscored).</p><table>",
        sig4(o.rms, "m"),
        sig4(o.median, "m"),
        sig4(o.max, "m"),
        o.outages.len(),
        o.unscored
    );
    h += &header(&[
        "outage",
        "start - t0 [s]",
        "end - t0 [s]",
        "scored at - t0 [s]",
        "error N",
        "error E",
        "horizontal",
    ]);
    for (i, s) in o.outages.iter().enumerate() {
        h += &row(&[
            (i + 1).to_string(),
            sig4(s.outage.start - t0, ""),
            sig4(s.outage.end - t0, ""),
            sig4(s.t - t0, ""),
            sig4(s.err_ne[0], "m"),
            sig4(s.err_ne[1], "m"),
            sig4(s.err_h, "m"),
        ]);
    }
    h + "</table>"
}

/// `[lo, hi]`, an end at the search's bound marked `(bound)`; `held` when the others stayed.
fn likelihood_interval_cell(v: &crate::nav::interval::LikelihoodInterval) -> String {
    let end = |x: f64, open: bool| sig4(x, "") + if open { " (bound)" } else { "" };
    format!(
        "[{}, {}]{}{}",
        end(v.lo, v.lo_open),
        end(v.hi, v.hi_open),
        if v.along_ridge { "" } else { ", others held" },
        if v.above_nats > crate::nav::identify::ABOVE_NOTED {
            format!(", a run {} above the answer", sig4(v.above_nats, "nats"))
        } else {
            String::new()
        }
    )
}

fn identified_table(id: &Identified) -> String {
    let mut h = format!(
        "<p>Maximum-likelihood factors on the standard deviations (<code>identified.json</code>, <code>identified-model.toml</code>): log-likelihood {} at the start, {} identified, {} runs; the Newton step off the search's grid: {}.</p><table>",
        sig4(id.loglik_start, "nats"),
        sig4(id.loglik, "nats"),
        id.evaluations,
        id.newton_nats.map_or("none (no concave direction)".to_string(), |v| format!(
            "{} ({})",
            sig4(v, "nats"),
            if v > 0.0 { "kept" } else { "not kept" }
        ))
    );
    h += &header(&["factor", "value"]);
    for (name, f) in FACTORS.iter().zip(id.factors) {
        h += &row(&[esc(name), sig4(f, "")]);
    }
    h += "</table>";
    h += &format!(
        "<p>Cramér-Rao standard deviations of the coordinates searched, at the answer kept (from the curvature of the log-likelihood); a coordinate whose sd exceeds {IDENTIFIABLE_SD} decade (for the shift, {} s) is not identifiable from this log, and its value is where the search stopped, not a measurement. The 95 % likelihood interval is where the log-likelihood has fallen by 1.92 nats, measured by runs (the others at their conditional maximum where the curvature gives it, else held): skewed where the likelihood is not quadratic, and one-sided (an end at the search's bound, marked) where the data bound the coordinate only on one side.</p><table>",
        IDENTIFIABLE_SD * SHIFT_PER_DECADE
    );
    h += &header(&[
        "coordinate",
        "value (log10 factor; shift [s])",
        "Cramér-Rao sd",
        "identifiable",
        "95 % likelihood interval",
    ]);
    for u in &id.uncertainty {
        h += &row(&[
            esc(&u.name),
            sig4(u.value, ""),
            u.cr_sd.map_or("unbounded".to_string(), |v| sig4(v, "")),
            (if u.identifiable { "yes" } else { "no" }).to_string(),
            likelihood_interval_cell(&u.interval_95),
        ]);
    }
    h += "</table>";
    if let Some(a) = &id.axes {
        h += &format!(
            "<p>Per axis (<code>--identify-axes</code>): the four IMU factors untied over x, y, z gain {} over the tied fit, against a threshold of {} (half the chi-square({}) 0.99 quantile): the {} answer is kept{}.</p><table>",
            sig4(a.gain_nats, "nats"),
            sig4(a.threshold_nats, "nats"),
            a.df,
            if a.significant { "per-axis" } else { "tied" },
            if a.significant {
                " (the factors above are its geometric means over the axes, after the Newton step; the table gives the test's answer, on the search's grid)"
            } else {
                ""
            }
        );
        h += &header(&["factor", "x", "y", "z"]);
        for (name, f) in FACTORS.iter().zip(a.factors) {
            h += &row(&[esc(name), sig4(f[0], ""), sig4(f[1], ""), sig4(f[2], "")]);
        }
        h += "</table>";
    }
    h
}

/// The whole page.
/// `sections`: further `(title, HTML)` sections after the identification's (the diagnosis of
/// `nav --diagnose`).
pub fn html(
    run: &NavRun,
    cmp: Option<&TruthComparison>,
    id: Option<&Identified>,
    sections: &[(String, String)],
) -> Result<String> {
    let title = "hal-sim nav: strapdown INS/GNSS";
    let t0 = run.epochs.first().map_or(0.0, |e| e.t);
    let max_dx = gap_limit(&run.epochs);
    let mut h = format!(
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>{title}</title><style>body{{font-family:sans-serif;max-width:920px;margin:auto}}table{{border-collapse:collapse;margin:6px 0}}td,th{{border:1px solid #999;padding:3px 8px;text-align:right}}th{{background:#eee}}.ok{{color:#180}}.bad{{color:#b00}}</style></head><body><h1>{title}</h1>"
    );
    // Real logs are in GPS seconds (README "time scale"): show the date too.
    let date = if t0 > 1e8 {
        crate::nav_io::gpst::to_calendar(t0).map_or(String::new(), |d| format!(" ({d} GPST)"))
    } else {
        String::new()
    };
    h += &format!("<p>Times from the first GNSS epoch after the start, t0 = {t0} s{date}.</p>");
    h += "<h2>Summary</h2>";
    h += &summary_table(run);
    if let Some(c) = cmp {
        h += "<h2>Errors against the truth</h2>";
        h += &truth_table(c);
    }
    h += "<h2>Track</h2>";
    h += &super::track::track_svg(run)?;
    h += "<h2>GNSS outages</h2>";
    h += &outage_table(run, t0);
    if let Some(id) = id {
        h += "<h2>Identified noise model</h2>";
        h += &identified_table(id);
    }
    for (title, body) in sections {
        h += &format!("<h2>{title}</h2>");
        h += body;
    }
    if let Some(a) = &run.adapt {
        h += "<h2>Online identification</h2>";
        h += &a.html_section(t0)?;
    }
    match cmp {
        Some(c) => {
            h += "<h2>Navigation errors against ±3 sigma</h2>";
            h += &truth_plots(c, t0, max_dx)?;
        }
        None => {
            h += "<h2>GNSS position innovations against ±3 sqrt(S)</h2><p>No truth: the pre-fit innovations of the fused fixes (solution at the antenna minus the fix) against the filter's predicted innovation standard deviation.</p>";
            h += &innovation_plots(&run.epochs, t0, max_dx)?;
        }
    }
    h += "<h2>Velocity and attitude sigmas</h2>";
    h += &sigma_chart(
        "Velocity error 1-sigma",
        "m/s",
        &run.epochs,
        |e| e.sd_vel,
        NED,
    )?;
    h += &sigma_chart(
        "Attitude error (phi) 1-sigma",
        "deg",
        &run.epochs,
        |e| e.sd_att_deg,
        NED,
    )?;
    h += "<h2>Estimated sensor errors</h2>";
    h += &sensor_plots(run, cmp, t0, max_dx)?;
    h += "</body></html>";
    Ok(h)
}

/// Writes `report.html` into `out` ([`html`]).
pub fn write(
    out: &Path,
    run: &NavRun,
    cmp: Option<&TruthComparison>,
    id: Option<&Identified>,
    sections: &[(String, String)],
) -> Result<()> {
    crate::output::write_string(&out.join("report.html"), &html(run, cmp, id, sections)?)
}
