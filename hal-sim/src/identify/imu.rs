//! `hal-sim identify --columns gx,gy,gz,ax,ay,az` (or `--imu`): the whole IMU in one pass
//! over the file. The six columns are read together ([`read_columns_counted`]: one
//! decompression, one parse), converted to SI, and each axis goes through the same
//! [`super::analyse`] as the one-column form (writing `DIR/<axis>/...`). Then the per-axis
//! models are gathered into `DIR/imu-model.toml`, the Kalibr figures into
//! `DIR/kalibr-imu.yaml`, and the datasheet figures into `DIR/datasheet.{md,json}`.

use std::path::PathBuf;

use anyhow::{anyhow, bail, ensure, Context, Result};
use serde::Serialize;

use super::fit::Kind;
use super::sheet::{axis_figures, markdown, AxisFigures};
use super::{analyse, ci::ARW_TC_MAX, IdentifyArgs, IdentifySummary, SensorArg};
use crate::datasheet::{reference, Reference, G0};
use crate::imu_model::{AxesToml, ImuModelToml};
use crate::kalibr::KalibrImu;
use crate::output::{write_atomic, write_string};
use crate::series::{read_columns_counted, read_header, ReadOptions, ReadStats};

/// Unit of a column in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Unit {
    /// deg/s
    Dps,
    /// rad/s
    Rads,
    /// standard gravity, 9.80665 m/s^2
    G,
    /// m/s^2
    Mps2,
}

impl Unit {
    /// Factor to SI (rad/s, m/s^2).
    pub fn scale(self) -> f64 {
        match self {
            Unit::Dps => std::f64::consts::PI / 180.0,
            Unit::Rads | Unit::Mps2 => 1.0,
            Unit::G => G0,
        }
    }
    /// The sensor this unit belongs to.
    pub fn sensor(self) -> SensorArg {
        match self {
            Unit::Dps | Unit::Rads => SensorArg::Gyro,
            Unit::G | Unit::Mps2 => SensorArg::Accel,
        }
    }
    /// From the name's last `_` token: `dps`/`degps`/`deg_s` → deg/s, `rads`/`rad_s`/`rps` →
    /// rad/s, `g` → g, `mps2`/`ms2`/`m_s2` → m/s^2.
    pub fn from_suffix(column: &str) -> Option<Self> {
        let c = column.to_ascii_lowercase();
        let ends = |s: &[&str]| s.iter().any(|x| c.ends_with(&format!("_{x}")));
        if ends(&["dps", "degps", "deg_s"]) {
            Some(Unit::Dps)
        } else if ends(&["rads", "rad_s", "rps"]) {
            Some(Unit::Rads)
        } else if ends(&["mps2", "ms2", "m_s2"]) {
            Some(Unit::Mps2)
        } else if ends(&["g"]) {
            Some(Unit::G)
        } else {
            None
        }
    }
}

/// Arguments of [`run`].
#[derive(Debug, Clone)]
pub struct ImuArgs {
    pub series: PathBuf,
    /// Six columns in the order gx, gy, gz, ax, ay, az; `None` finds them by name (`--imu`).
    pub columns: Option<Vec<String>>,
    pub rate: f64,
    /// Units of the gyro / accel columns; `None` reads them from the column-name suffix.
    pub gyro_unit: Option<Unit>,
    pub accel_unit: Option<Unit>,
    pub decimate: usize,
    pub out: PathBuf,
    pub quiet: bool,
    /// A datasheet of [`crate::datasheet::REFERENCES`] to set the figures against.
    pub reference: Option<String>,
}

/// One axis: where it came from and how it was scaled.
#[derive(Debug, Clone, Serialize)]
pub struct AxisSpec {
    /// `gyro_x` ... `accel_z`: also the output sub-folder.
    pub axis: String,
    pub column: String,
    pub unit: Unit,
    pub scale: f64,
}

/// `DIR/datasheet.json` and what [`run`] returns.
#[derive(Debug, Clone, Serialize)]
pub struct ImuSummary {
    pub series: String,
    pub rate: f64,
    /// What the one pass read: `bytes` equals the file size, `rows` the samples per axis.
    pub read: ReadStats,
    pub axes: Vec<AxisSpec>,
    pub figures: Vec<AxisFigures>,
    pub kalibr: KalibrImu,
    /// How each Kalibr random walk was obtained, per sensor.
    pub kalibr_notes: Vec<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reference: Option<Reference>,
    /// The per-axis identification (also in `DIR/<axis>/summary.json`); not in the JSON.
    #[serde(skip)]
    pub summaries: Vec<IdentifySummary>,
}

const AXIS_LABELS: [&str; 6] = [
    "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z",
];

/// The six axes' columns and units.
fn resolve(args: &ImuArgs) -> Result<Vec<AxisSpec>> {
    let file = args.series.display().to_string();
    let names: Vec<String> = match &args.columns {
        Some(c) => {
            ensure!(
                c.len() == 6,
                "--columns: expected six names gx,gy,gz,ax,ay,az, found {}",
                c.len()
            );
            c.clone()
        }
        None => {
            let header = read_header(&args.series)?;
            find_axes(&header).with_context(|| format!("{file}: --imu"))?
        }
    };
    names
        .iter()
        .zip(AXIS_LABELS)
        .map(|(col, axis)| {
            let gyro = axis.starts_with("gyro");
            let given = if gyro { args.gyro_unit } else { args.accel_unit };
            let unit = given.or_else(|| Unit::from_suffix(col)).ok_or_else(|| {
                anyhow!(
                    "{file}, column {col}: unit not recognised from the name (suffix _dps, _rads, _g or _mps2); give --{}-unit",
                    if gyro { "gyro" } else { "accel" }
                )
            })?;
            ensure!(
                (unit.sensor() == SensorArg::Gyro) == gyro,
                "{file}, column {col} ({axis}): unit {unit:?} is not a {} unit",
                if gyro { "gyro" } else { "accelerometer" }
            );
            Ok(AxisSpec {
                axis: axis.to_string(),
                column: col.clone(),
                unit,
                scale: unit.scale(),
            })
        })
        .collect()
}

/// The six columns of a header by name: sensor from [`SensorArg::guess`], axis from an `x`,
/// `y` or `z` token between `_` (e.g. `gyro_x_dps`, `acc_z_g`). Exactly one per axis.
pub fn find_axes(header: &[String]) -> Result<Vec<String>> {
    let mut out = Vec::with_capacity(6);
    for label in AXIS_LABELS {
        let (sensor, axis) = label.split_once('_').unwrap_or((label, ""));
        let want = if sensor == "gyro" {
            SensorArg::Gyro
        } else {
            SensorArg::Accel
        };
        let hits: Vec<&String> = header
            .iter()
            .filter(|h| SensorArg::guess(h) == Some(want))
            .filter(|h| h.to_ascii_lowercase().split('_').any(|t| t == axis))
            .collect();
        match hits.as_slice() {
            [one] => out.push((*one).clone()),
            [] => bail!(
                "no column for {label} (a {sensor} name with an _{axis}_ token); columns: {}; give --columns",
                header.join(", ")
            ),
            many => bail!(
                "several columns for {label}: {}; give --columns",
                many.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
            ),
        }
    }
    Ok(out)
}

/// Runs the whole-IMU identification; see the module documentation.
pub fn run(args: &ImuArgs) -> Result<ImuSummary> {
    ensure!(
        args.rate.is_finite() && args.rate > 0.0,
        "--rate must be positive and finite, got {}",
        args.rate
    );
    ensure!(args.decimate >= 1, "--decimate must be at least 1");
    let specs = resolve(args)?;
    let cols: Vec<&str> = specs.iter().map(|s| s.column.as_str()).collect();
    let opts = ReadOptions {
        scale: 1.0,
        quiet: args.quiet,
    };
    let (mut data, read) = read_columns_counted(&args.series, &cols, &opts)?;
    // The same product `v * scale` the one-column reader forms, so each axis is bit-identical
    // to `identify --column NAME --scale S`.
    for (col, spec) in data.iter_mut().zip(&specs) {
        col.iter_mut().for_each(|v| *v *= spec.scale);
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    // The six analyses are independent: one thread each (they only read their own column).
    let results: Vec<Result<IdentifySummary>> = std::thread::scope(|s| {
        let handles: Vec<_> = specs
            .iter()
            .zip(&data)
            .map(|(spec, y)| {
                let a = IdentifyArgs {
                    series: args.series.clone(),
                    column: spec.column.clone(),
                    rate: args.rate,
                    scale: spec.scale,
                    decimate: args.decimate,
                    out: args.out.join(&spec.axis),
                    quiet: true,
                    sensor: Some(spec.unit.sensor()),
                };
                s.spawn(move || {
                    analyse(&a, a.sensor.unwrap_or(SensorArg::Gyro), y)
                        .with_context(|| format!("axis {}", spec.axis))
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err(anyhow!("identification thread panicked")))
            })
            .collect()
    });
    let summaries = results.into_iter().collect::<Result<Vec<_>>>()?;

    let model = imu_model(args, &specs)?;
    let header = format!(
        "# Written by `hal-sim identify --columns` from {} ({} Hz): one noise model per axis, SI units.\n\
         # Each [[<sensor>.<axis>]] list has the component syntax of the one-channel model TOML.\n",
        args.series.display(),
        args.rate
    );
    write_string(&args.out.join("imu-model.toml"), &model.to_text(&header)?)?;

    let figures: Vec<AxisFigures> = specs
        .iter()
        .zip(&summaries)
        .map(|(spec, s)| axis_figures(&spec.axis, s))
        .collect();
    let (kalibr, kalibr_notes) = kalibr_of(&summaries, args.rate);
    kalibr.write(
        &args.out.join("kalibr-imu.yaml"),
        &format!("hal-sim identify from {}", args.series.display()),
    )?;
    let reference = match &args.reference {
        Some(name) => Some(*reference(name).ok_or_else(|| {
            anyhow!(
                "--reference: unknown datasheet '{name}'; known: {}",
                crate::datasheet::REFERENCES
                    .iter()
                    .map(|r| r.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        })?),
        None => None,
    };
    let series = args.series.display().to_string();
    let md = markdown(&series, &figures, &kalibr, reference.as_ref());
    write_string(&args.out.join("datasheet.md"), &md)?;
    let summary = ImuSummary {
        series,
        rate: args.rate,
        read,
        axes: specs,
        figures,
        kalibr,
        kalibr_notes,
        reference,
        summaries,
    };
    write_atomic(&args.out.join("datasheet.json"), |w| {
        serde_json::to_writer_pretty(&mut *w, &summary)?;
        Ok(writeln!(w)?)
    })?;
    Ok(summary)
}

/// The six `DIR/<axis>/model.toml` gathered into one IMU model.
fn imu_model(args: &ImuArgs, specs: &[AxisSpec]) -> Result<ImuModelToml> {
    let mut m = ImuModelToml {
        dt: 1.0 / args.rate,
        gyro: AxesToml::default(),
        accel: AxesToml::default(),
    };
    for spec in specs {
        let path = args.out.join(&spec.axis).join("model.toml");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let one = crate::model_toml::parse_file(&text, &path.display().to_string())?;
        let (sensor, axis) = spec.axis.split_once('_').unwrap_or(("", ""));
        let (comps, axes) = if sensor == "gyro" {
            (one.gyro, &mut m.gyro)
        } else {
            (one.accel, &mut m.accel)
        };
        let a = axis.chars().next().unwrap_or('?');
        *axes
            .axis_mut(a)
            .ok_or_else(|| anyhow!("axis label {}", spec.axis))? = comps;
    }
    m.validate("imu-model.toml")?;
    Ok(m)
}

/// Kalibr's figures from the six identifications. Kalibr has one density per sensor for the
/// three axes, so the largest axis is taken (the filter then stays honest on every axis).
/// Noise density: the fitted white level N (`white_density`). Random walk: the fitted
/// random-walk K if there is one, else the largest driving density sqrt(2 σ²/T_c) of a
/// Gauss-Markov term with T_c > 0.1 s (for τ ≪ T_c a Gauss-Markov is a random walk of that
/// density), else the random walk that would reach the measured ADEV minimum at its τ,
/// K = ADEV_min · sqrt(3/τ_min) (an upper bound on any random walk hidden under the floor).
pub fn kalibr_of(summaries: &[IdentifySummary], rate: f64) -> (KalibrImu, Vec<String>) {
    let mut notes = Vec::new();
    let mut figs = [(0.0, 0.0); 2];
    for (i, sensor) in [SensorArg::Gyro, SensorArg::Accel].into_iter().enumerate() {
        let axes: Vec<&IdentifySummary> = summaries.iter().filter(|s| s.sensor == sensor).collect();
        let n = axes
            .iter()
            .filter_map(|s| s.white_density.map(|w| w[0]))
            .fold(0.0, f64::max);
        let mut how = Vec::new();
        let k = axes
            .iter()
            .map(|s| {
                let (k, why) = random_walk_density(s);
                how.push(format!("{}: {why}", s.column));
                k
            })
            .fold(0.0, f64::max);
        notes.push(format!(
            "{sensor:?} random walk (largest axis): {}",
            how.join("; ")
        ));
        figs[i] = (n, k);
    }
    (
        KalibrImu {
            gyroscope_noise_density: figs[0].0,
            gyroscope_random_walk: figs[0].1,
            accelerometer_noise_density: figs[1].0,
            accelerometer_random_walk: figs[1].1,
            update_rate: rate,
        },
        notes,
    )
}

/// The Kalibr random-walk density of one axis and where it came from (see [`kalibr_of`]).
fn random_walk_density(s: &IdentifySummary) -> (f64, String) {
    if let Some(c) = s.components.iter().find(|c| c.kind == Kind::RandomWalk) {
        return (c.amplitude, "fitted random walk".into());
    }
    let gm = s
        .components
        .iter()
        .filter(|c| c.kind == Kind::GaussMarkov && c.tc.is_some_and(|t| t > ARW_TC_MAX))
        .map(|c| c.amplitude * (2.0 / c.tc.unwrap_or(f64::INFINITY)).sqrt())
        .fold(0.0, f64::max);
    if gm > 0.0 {
        return (gm, "Gauss-Markov driving density sqrt(2 sigma^2/tc)".into());
    }
    let min = super::sheet::flat_bottom(&s.residuals);
    match min {
        Some(r) => (
            r.adev * (3.0 / r.tau).sqrt(),
            format!(
                "no random walk or slow Gauss-Markov found: bound ADEV_min sqrt(3/tau) at tau {:.4} s",
                r.tau
            ),
        ),
        None => (0.0, "no ADEV".into()),
    }
}

/// The lines `identify --columns` prints: per axis the random walk and bias instability with
/// their intervals and units, then the Kalibr figures.
pub fn report(s: &ImuSummary) -> String {
    let mut out = String::new();
    for f in &s.figures {
        let rw = if f.axis.starts_with("gyro") {
            "ARW"
        } else {
            "VRW"
        };
        out += &format!(
            "{:<8} {rw} {}  bias instability {}\n",
            f.axis,
            f.random_walk.text(),
            f.bias_instability.text()
        );
    }
    out += &format!(
        "kalibr: gyroscope_noise_density {} rad/s/sqrt(Hz), gyroscope_random_walk {} rad/s^2/sqrt(Hz), accelerometer_noise_density {} m/s^2/sqrt(Hz), accelerometer_random_walk {} m/s^3/sqrt(Hz)\n",
        crate::imu_model::sig4(s.kalibr.gyroscope_noise_density),
        crate::imu_model::sig4(s.kalibr.gyroscope_random_walk),
        crate::imu_model::sig4(s.kalibr.accelerometer_noise_density),
        crate::imu_model::sig4(s.kalibr.accelerometer_random_walk),
    );
    out
}
