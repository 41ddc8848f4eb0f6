//! `hal-sim identify`: a noise model of one sensor axis from a static recording.
//!
//! Steps: stream the column ([`crate::series`]), overlapping ADEV with 95 % conservative
//! chi-square intervals on the octave grid ([`crate::allan`]) → `adev.csv`; the ACF of the
//! block-averaged series ([`acf`]) → `acf.csv`, with exponential-cosine detection; a composite
//! model chosen by forward selection on log-ADEV ([`fit`]) → `model.toml`, `summary.json`;
//! plots → `adev.svg`, `acf.svg`. Every file is written atomically. See docs/IDENTIFY.md.

pub mod acf;
pub mod ci;
pub mod fit;
pub mod imu;
pub mod plots;
pub mod select;
pub mod sheet;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use anyhow::{ensure, Context, Result};
use imu_ident::model::{
    Component, ComponentKind, ErrorSource, ExpCosine, GaussMarkov, RandomWalk, WhiteNoise,
};
use serde::Serialize;

use crate::allan::{overlapping_adev, write_adev_csv, AdevConfig, AdevRow};
use crate::candidates::Candidate;
use crate::model_toml::{ComponentToml, ModelToml, ObservationToml};
use crate::output::{write_atomic, write_string};
use crate::series::{read_column, ReadOptions};
use fit::{Kind, Problem, Term};

/// Most ACF lags computed (before decimation they are samples): 512 covers ~100 periods of
/// the ADIS 20 Hz line and ~10 of the PSINS sway at 100 Hz, at O(N · 512) cost.
pub const MAX_LAG: usize = 512;
pub use crate::model_toml::SIGMA_V_PLACEHOLDER;

/// Which sensor the column belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum SensorArg {
    Gyro,
    Accel,
}

impl SensorArg {
    /// From the column name: `gyro`, `dtheta`, `rate` → gyro; `acc`, `dv`, `force` → accel.
    pub fn guess(column: &str) -> Option<Self> {
        let c = column.to_ascii_lowercase();
        if ["gyro", "dtheta", "rate", "omega"]
            .iter()
            .any(|k| c.contains(k))
        {
            Some(Self::Gyro)
        } else if ["acc", "dv", "force"].iter().any(|k| c.contains(k)) {
            Some(Self::Accel)
        } else {
            None
        }
    }
    fn core(self) -> ErrorSource {
        match self {
            Self::Gyro => ErrorSource::Gyro,
            Self::Accel => ErrorSource::Accel,
        }
    }
}

/// Arguments of [`run`].
#[derive(Debug, Clone)]
pub struct IdentifyArgs {
    /// CSV or gzip CSV with a header row.
    pub series: PathBuf,
    /// Column to analyse.
    pub column: String,
    /// Sample rate [Hz].
    pub rate: f64,
    /// Factor applied to every value (to SI for a model `hal-sim run` can use).
    pub scale: f64,
    /// Block-average factor for the ACF (1 = none).
    pub decimate: usize,
    /// Output folder.
    pub out: PathBuf,
    /// No progress bar.
    pub quiet: bool,
    /// Sensor; `None` guesses from the column name.
    pub sensor: Option<SensorArg>,
}

/// One fitted component as reported in `summary.json` (units of the scaled series).
#[derive(Debug, Clone, Serialize)]
pub struct ComponentOut {
    /// Candidate-library label, e.g. `gyro/gauss-markov`.
    pub label: String,
    pub kind: Kind,
    /// White: density N [unit·√s]; random walk: K [unit/√s]; quantisation: Q [unit·s];
    /// Gauss-Markov and exp-cosine: σ [unit].
    pub amplitude: f64,
    /// 95 % interval of `amplitude` (Gauss-Newton, see `ci::intervals`).
    pub amplitude_ci: Option<[f64; 2]>,
    /// Correlation time (exp-cosine: envelope 1/α) [s].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tc: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tc_ci: Option<[f64; 2]>,
    /// Exp-cosine period 2π/β [s] and β [rad/s] (from the ACF).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beta: Option<f64>,
    /// The library's one-line physical reading (assumes SI units).
    pub explanation: String,
}

/// One τ of the fit.
#[derive(Debug, Clone, Serialize)]
pub struct Residual {
    pub tau: f64,
    pub adev: f64,
    pub ci_lo: f64,
    pub ci_hi: f64,
    pub model: f64,
    /// (ln model − ln adev) / s.
    pub z: f64,
    pub inside_ci: bool,
}

/// `summary.json`.
#[derive(Debug, Clone, Serialize)]
pub struct IdentifySummary {
    pub series: String,
    pub column: String,
    pub sensor: SensorArg,
    pub rate: f64,
    pub scale: f64,
    pub samples: usize,
    /// Mean of the scaled series: the turn-on bias (plus Earth rate or gravity), which the
    /// ADEV cannot see. Reported here only; not written to `model.toml`.
    pub mean: f64,
    pub components: Vec<ComponentOut>,
    /// Angle / velocity random walk `[N, lo, hi]`: the long-τ white level of every term
    /// correlated over ≤ 0.1 s, better determined than any one term (`ci::white_density`).
    pub white_density: Option<[f64; 3]>,
    pub chi2: f64,
    pub bic: f64,
    pub taus: usize,
    /// Share of taus where the model lies inside the measured 95 % CI.
    pub inside_ci: f64,
    pub residuals: Vec<Residual>,
    /// Every model tried by the forward selection with its χ² and BIC.
    pub trials: Vec<select::Trial>,
    /// Candidates not tried and why.
    pub not_tried: Vec<String>,
    pub acf: acf::AcfResult,
    /// What went into `model.toml` and what was folded or left out.
    pub model_toml_notes: Vec<String>,
}

impl IdentifySummary {
    /// The exp-cosine component, if one was selected.
    pub fn exp_cosine(&self) -> Option<&ComponentOut> {
        self.components.iter().find(|c| c.kind == Kind::ExpCosine)
    }
}

fn candidate(sensor: SensorArg, kind: ComponentKind) -> Candidate {
    Candidate {
        sensor: sensor.core(),
        kind,
    }
}

/// Runs the whole identification; see the module documentation.
pub fn run(args: &IdentifyArgs) -> Result<IdentifySummary> {
    ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate must be positive and finite, got {}",
        args.rate
    );
    ensure!(
        args.scale.is_finite() && args.scale != 0.0,
        "--scale must be finite and non-zero, got {}",
        args.scale
    );
    ensure!(args.decimate >= 1, "--decimate must be at least 1");
    let sensor = match args.sensor.or_else(|| SensorArg::guess(&args.column)) {
        Some(s) => s,
        None => anyhow::bail!(
            "cannot tell gyro from accel by the column name '{}': give --sensor gyro|accel",
            args.column
        ),
    };
    let opts = ReadOptions {
        scale: args.scale,
        quiet: args.quiet,
    };
    let y = read_column(&args.series, &args.column, &opts)?;
    analyse(args, sensor, &y)
}

/// The identification of one axis already in memory (`y`, scaled): everything [`run`] does
/// after reading the column. `hal-sim identify --columns` reads the file once and calls this
/// for each axis (`imu.rs`), so both forms share every line of the maths.
pub fn analyse(args: &IdentifyArgs, sensor: SensorArg, y: &[f64]) -> Result<IdentifySummary> {
    let file = args.series.display().to_string();
    ensure!(
        y.len() >= 64,
        "{file}, column {}: {} samples, need at least 64",
        args.column,
        y.len()
    );
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let dt = 1.0 / args.rate;

    let rows = overlapping_adev(y, &AdevConfig::octave(args.rate))
        .with_context(|| format!("{file}, column {}: Allan deviation", args.column))?;
    write_adev_csv(args.out.join("adev.csv"), &rows)?;

    let acf = acf::analyse(y, args.rate, args.decimate, MAX_LAG)
        .with_context(|| format!("{file}, column {}", args.column))?;
    write_acf_csv(&args.out.join("acf.csv"), &acf)?;

    let pts = fit::points(&rows);
    ensure!(pts.len() >= 3, "{file}: too few ADEV points to fit a model");
    let record = y.len() as f64 * dt;
    let prob = Problem {
        pts: &pts,
        dt,
        ln_tc: ((0.1 * dt).ln(), (10.0 * record).ln()),
    };
    let ec = acf.exp_cos.map(|f| (1.0 / f.alpha, f.period));
    let sel = select::select(&prob, ec);
    let cis = ci::intervals(&prob, &sel.terms);

    let mut components = Vec::new();
    for (j, t) in sel.terms.iter().enumerate() {
        let ci = cis.as_ref().map(|c| c[j]);
        components.push(describe(sensor, t, ci));
    }
    let residuals: Vec<Residual> = rows
        .iter()
        .filter(|r| r.ci_hi.is_finite())
        .map(|r| residual(r, &sel.terms, dt))
        .collect();
    let inside = residuals.iter().filter(|r| r.inside_ci).count();
    let mean = y.iter().sum::<f64>() / y.len() as f64;
    let mut not_tried = vec![
        "random-constant: zero Allan variance at every tau; the series mean is reported instead"
            .to_string(),
    ];
    if acf.exp_cos.is_none() {
        not_tried.push(format!(
            "exp-cosine: no significant negative ACF lobe (min rho {:.4} at {:.3} s, threshold {:.4})",
            acf.min_rho, acf.min_rho_tau, acf.threshold
        ));
    }

    let (model, notes) = model_toml(sensor, &sel.terms, dt)?;
    write_string(&args.out.join("model.toml"), &model)?;

    let summary = IdentifySummary {
        series: file,
        column: args.column.clone(),
        sensor,
        rate: args.rate,
        scale: args.scale,
        samples: y.len(),
        mean,
        components,
        white_density: ci::white_density(&prob, &sel.terms),
        chi2: sel.chi2,
        bic: sel.bic,
        taus: residuals.len(),
        inside_ci: inside as f64 / residuals.len().max(1) as f64,
        residuals,
        trials: sel.trials,
        not_tried,
        acf,
        model_toml_notes: notes,
    };
    write_atomic(&args.out.join("summary.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &summary)?;
        Ok(writeln!(w)?)
    })?;
    write_plots(&args.out, &summary, &rows, &sel.terms, dt)?;
    Ok(summary)
}

/// Theoretical ADEV of `terms` at cluster `m`.
pub fn model_adev(terms: &[Term], m: usize, dt: f64) -> f64 {
    terms.iter().map(|t| t.avar(m, dt)).sum::<f64>().sqrt()
}

fn residual(r: &AdevRow, terms: &[Term], dt: f64) -> Residual {
    let model = model_adev(terms, r.m, dt);
    let s = (r.ci_hi.ln() - r.ci_lo.ln()) / (2.0 * 1.959_963_984_540_054);
    Residual {
        tau: r.tau,
        adev: r.adev,
        ci_lo: r.ci_lo,
        ci_hi: r.ci_hi,
        model,
        z: (model.ln() - r.adev.ln()) / s,
        inside_ci: model >= r.ci_lo && model <= r.ci_hi,
    }
}

fn describe(sensor: SensorArg, t: &Term, ci: Option<[f64; 4]>) -> ComponentOut {
    let amp = t.var.sqrt();
    let amp_ci = ci.map(|c| [c[0].sqrt(), c[1].sqrt()]);
    let tc_ci = ci.filter(|c| c[2].is_finite()).map(|c| [c[2], c[3]]);
    let core_kind = match t.kind {
        Kind::White | Kind::Quantization | Kind::FilteredWhite => ComponentKind::White,
        Kind::GaussMarkov => ComponentKind::GaussMarkov,
        Kind::ExpCosine => ComponentKind::ExpCosine,
        Kind::RandomWalk => ComponentKind::RandomWalk,
    };
    let cand = candidate(sensor, core_kind);
    // Candidate::component takes log-parameters (see candidates.rs).
    let p: Vec<f64> = match t.kind {
        Kind::White | Kind::Quantization | Kind::FilteredWhite => vec![amp.ln()],
        Kind::GaussMarkov => vec![amp.ln(), t.tc.ln()],
        Kind::ExpCosine => vec![amp.ln(), t.tc.ln(), t.period.ln()],
        Kind::RandomWalk => vec![t.var.ln()],
    };
    let explanation = match (t.kind, cand.component(&p)) {
        (Kind::FilteredWhite, Some(c)) => format!(
            "{} (seen through the sensor's own averaging over {:.2e} s, which correlates neighbouring samples)",
            cand.explain(&c),
            t.tc
        ),
        (Kind::Quantization, _) => format!(
            "quantisation noise Q = {amp:.3e} (unit·s): ADEV 3Q²/τ², e.g. the LSB of an integrated output"
        ),
        (_, Some(c)) => cand.explain(&c),
        (_, None) => "amplitude zero: the data do not support this term".into(),
    };
    let label = match t.kind {
        Kind::Quantization | Kind::FilteredWhite => {
            format!("{}/{}", cand.sensor.name(), t.kind.name())
        }
        _ => cand.label(),
    };
    let shaped = matches!(
        t.kind,
        Kind::GaussMarkov | Kind::ExpCosine | Kind::FilteredWhite
    );
    let ec = t.kind == Kind::ExpCosine;
    ComponentOut {
        label,
        kind: t.kind,
        amplitude: amp,
        amplitude_ci: amp_ci,
        tc: shaped.then_some(t.tc),
        tc_ci: if shaped { tc_ci } else { None },
        period: ec.then_some(t.period),
        beta: ec.then(|| 2.0 * PI / t.period),
        explanation,
    }
}

/// The `model.toml` text and notes on what was folded or dropped.
///
/// The core model holds at most 4 components (6 states) per sensor, and has no quantisation
/// kind, so: quantisation becomes white noise of the same ADEV at τ = Δt (N² = 3Q²/Δt, which
/// overstates it at longer τ, i.e. errs on the safe side); filtered white becomes white of
/// its long-τ density; a Gauss-Markov with T_c < 2Δt is
/// white at the sample rate and is folded in as N² = 2σ²T_c (its long-τ level); then, while
/// the model does not load, the component with the smallest peak ADEV share is dropped.
pub fn model_toml(sensor: SensorArg, terms: &[Term], dt: f64) -> Result<(String, Vec<String>)> {
    let mut notes = Vec::new();
    let mut white2 = 0.0;
    let mut kept: Vec<(f64, ComponentToml)> = Vec::new();
    for t in terms.iter().filter(|t| t.var > 0.0) {
        let share = peak_share(t, terms, dt);
        match t.kind {
            Kind::White => white2 += t.var,
            Kind::FilteredWhite => {
                white2 += t.var;
                notes.push(format!(
                    "filtered-white N = {:.3e} (window {:.2e} s) written as white noise of density N, exact for tau >> window",
                    t.var.sqrt(),
                    t.tc
                ));
            }
            Kind::Quantization => {
                white2 += 3.0 * t.var / dt;
                notes.push(format!(
                    "quantization Q = {:.3e} written as white noise of equal ADEV at tau = dt",
                    t.var.sqrt()
                ));
            }
            Kind::GaussMarkov if t.tc < 2.0 * dt => {
                white2 += 2.0 * t.var * t.tc;
                notes.push(format!(
                    "gauss-markov tc = {:.3e} s < 2 dt folded into white noise (N^2 = 2 sigma^2 tc)",
                    t.tc
                ));
            }
            Kind::GaussMarkov => kept.push((
                share,
                ComponentToml(Component::GaussMarkov(GaussMarkov {
                    sigma: t.var.sqrt(),
                    tau: t.tc,
                })),
            )),
            Kind::ExpCosine => kept.push((
                share,
                ComponentToml(Component::ExpCosine(ExpCosine {
                    sigma: t.var.sqrt(),
                    tau: t.tc,
                    beta: 2.0 * PI / t.period,
                })),
            )),
            Kind::RandomWalk => kept.push((
                share,
                ComponentToml(Component::RandomWalk(RandomWalk {
                    q: t.var,
                    sigma0: 0.0,
                })),
            )),
        }
    }
    if white2 > 0.0 {
        kept.push((
            f64::INFINITY,
            ComponentToml(Component::White(WhiteNoise {
                density: white2.sqrt(),
            })),
        ));
    }
    kept.sort_by(|a, b| b.0.total_cmp(&a.0));
    loop {
        let comps: Vec<ComponentToml> = kept.iter().map(|k| k.1).collect();
        let mut m = ModelToml {
            name: None,
            description: None,
            hours: None,
            dt,
            observation: ObservationToml {
                sigma_v: SIGMA_V_PLACEHOLDER,
                colored: vec![],
            },
            initial: None,
            accel: vec![],
            gyro: vec![],
        };
        match sensor {
            SensorArg::Gyro => m.gyro = comps,
            SensorArg::Accel => m.accel = comps,
        }
        match m.to_core() {
            Ok(_) => {
                let body = toml::to_string_pretty(&m)?;
                let head = format!(
                    "# Written by `hal-sim identify` ({} noise of one axis, units of the scaled series).\n\
                     # observation.sigma_v = {SIGMA_V_PLACEHOLDER} is a placeholder: a static record has no velocity reference.\n",
                    sensor.core().name()
                );
                return Ok((head + &crate::imu_model::readable_toml(&body), notes));
            }
            Err(e) if kept.len() > 1 => {
                if let Some((_, c)) = kept.pop() {
                    notes.push(format!("dropped {c:?} so that the model loads ({e:#})"));
                }
            }
            Err(e) => return Err(e.context("identify: no loadable model")),
        }
    }
}

/// Largest share of the model's Allan variance the term has at any octave τ.
fn peak_share(t: &Term, terms: &[Term], dt: f64) -> f64 {
    (0..24)
        .map(|i| {
            let m = 1usize << i;
            let total: f64 = terms.iter().map(|x| x.avar(m, dt)).sum();
            t.avar(m, dt) / total
        })
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
}

fn write_acf_csv(path: &Path, a: &acf::AcfResult) -> Result<()> {
    write_atomic(path, |w| {
        writeln!(w, "lag,tau,rho,exp_fit,exp_cos_fit")?;
        for (j, r) in a.rho.iter().enumerate() {
            let tau = j as f64 * a.dt;
            let e = a.exp_alpha.map(|al| (-al * tau).exp());
            let ec = a.exp_cos.map(|f| if j == 0 { 1.0 } else { f.eval(tau) });
            let f = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:e}"));
            writeln!(w, "{j},{tau:e},{r:e},{},{}", f(e), f(ec))?;
        }
        Ok(())
    })
}

fn write_plots(
    out: &Path,
    s: &IdentifySummary,
    rows: &[AdevRow],
    terms: &[Term],
    dt: f64,
) -> Result<()> {
    let measured: Vec<(f64, f64, f64, f64)> = rows
        .iter()
        .map(|r| (r.tau, r.adev, r.ci_lo, r.ci_hi))
        .collect();
    // Curves on a finer grid than the octaves: 8 points per octave.
    let max_m = rows.last().map_or(1, |r| r.m) as f64;
    let ms: Vec<usize> = (0..)
        .map(|i| 2f64.powf(i as f64 / 8.0).round() as usize)
        .take_while(|&m| m as f64 <= max_m)
        .collect::<Vec<_>>();
    let mut ms = ms;
    ms.dedup();
    let curves: Vec<plots::Curve> = terms
        .iter()
        .map(|t| {
            let pts = ms
                .iter()
                .map(|&m| (m as f64 * dt, t.avar(m, dt).sqrt()))
                .collect();
            (t.kind.name().to_string(), pts)
        })
        .collect();
    let total: Vec<(f64, f64)> = ms
        .iter()
        .map(|&m| (m as f64 * dt, model_adev(terms, m, dt)))
        .collect();
    let title = format!("{}: Allan deviation and fitted model", s.column);
    let unit = format!("{} x {}", s.column, s.scale);
    let svg = plots::adev_svg(&title, &unit, &measured, &curves, &total)?;
    write_string(&out.join("adev.svg"), &svg)?;

    let a = &s.acf;
    let rho: Vec<(f64, f64)> = a
        .rho
        .iter()
        .enumerate()
        .skip(1)
        .map(|(j, r)| (j as f64 * a.dt, *r))
        .collect();
    let mut fits = Vec::new();
    if let Some(al) = a.exp_alpha {
        fits.push((
            "exp (core ls_slope)".to_string(),
            rho.iter().map(|p| (p.0, (-al * p.0).exp())).collect(),
        ));
    }
    if let Some(f) = a.exp_cos {
        fits.push((
            format!("exp-cos, period {:.4} s", f.period),
            rho.iter().map(|p| (p.0, f.eval(p.0))).collect(),
        ));
    }
    let band = 2.0 / (a.n as f64).sqrt();
    let svg = plots::acf_svg(
        &format!("{}: ACF (decimation {})", s.column, a.decimate),
        &rho,
        &fits,
        band,
    )?;
    write_string(&out.join("acf.svg"), &svg)
}
