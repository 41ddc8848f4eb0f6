//! `hal-sim model from-datasheet`: an IMU model TOML from the usual datasheet figures or a
//! Kalibr IMU YAML (docs/IDENTIFY.md "From a datasheet"). Every axis of a sensor gets the same
//! components: white noise from the ARW / VRW (or Kalibr noise density), a Gauss-Markov from the
//! bias instability ([`bias_gauss_markov`]), and a random walk from the rate random walk (or
//! Kalibr random walk). Figures outside the claimed grade's range give warnings.

use std::path::PathBuf;

use anyhow::{bail, ensure, Result};
use imu_ident::model::{Component, GaussMarkov, RandomWalk, WhiteNoise};
use serde::Serialize;

use crate::datasheet::{
    accel_density_from_vrw, bias_gauss_markov, grade_warnings, gyro_density_from_arw,
    m_s2_from_micro_g, rad_s_from_deg_h, BiasGm, Grade,
};
use crate::imu_model::{AxesToml, ImuModelToml};
use crate::model_toml::ComponentToml;

/// Averaging time of the ADEV minimum assumed when `--bias-tau` is not given [s]: the order
/// of the minima of MEMS datasheet Allan plots (tens to hundreds of seconds).
pub const DEFAULT_BIAS_TAU: f64 = 100.0;
/// Sample rate assumed when neither `--rate` nor a Kalibr file gives one [Hz].
pub const DEFAULT_RATE: f64 = 100.0;

/// The figures, in datasheet units (`None` = not given); also the options of
/// `hal-sim model from-datasheet`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct DatasheetArgs {
    /// Angle random walk [deg/sqrt(h)].
    #[arg(long)]
    pub arw: Option<f64>,
    /// Velocity random walk [m/s/sqrt(h)].
    #[arg(long)]
    pub vrw: Option<f64>,
    /// Gyro bias instability [deg/h] (IEEE 952 B: ADEV minimum = 0.664 B).
    #[arg(long)]
    pub gyro_bias_instability: Option<f64>,
    /// Accelerometer bias instability [ug].
    #[arg(long)]
    pub accel_bias_instability: Option<f64>,
    /// Gyro rate random walk [deg/h/sqrt(h)].
    #[arg(long)]
    pub gyro_rrw: Option<f64>,
    /// Accelerometer rate random walk [m/s/h/sqrt(h)].
    #[arg(long)]
    pub accel_rrw: Option<f64>,
    /// Averaging time of the ADEV minimum [s] (default 100).
    #[arg(long)]
    pub bias_tau: Option<f64>,
    /// Grade the figures claim: warns on figures outside its range.
    #[arg(long, value_enum)]
    pub grade: Option<Grade>,
    /// Kalibr IMU YAML: noise densities, random walks and update_rate (figures given as
    /// options take precedence).
    #[arg(long)]
    pub kalibr: Option<PathBuf>,
    /// Sample rate [Hz] (default: the Kalibr update_rate, else 100).
    #[arg(long)]
    pub rate: Option<f64>,
}

/// What [`build`] made.
#[derive(Debug, Clone, Serialize)]
pub struct FromDatasheet {
    #[serde(skip)]
    pub model: ImuModelToml,
    /// Grade-range warnings.
    pub warnings: Vec<String>,
    /// Assumptions made (defaults used, the bias-instability mapping).
    pub notes: Vec<String>,
    /// The Gauss-Markov made from each bias instability (gyro, accel).
    pub bias_gm: [Option<BiasGm>; 2],
}

/// Builds the IMU model; see the module documentation.
pub fn build(a: &DatasheetArgs) -> Result<FromDatasheet> {
    let k = a
        .kalibr
        .as_ref()
        .map(|p| crate::kalibr::load(p))
        .transpose()?;
    let mut notes = Vec::new();
    let rate = match (a.rate, &k) {
        (Some(r), _) => r,
        (None, Some(k)) => k.update_rate,
        (None, None) => {
            notes.push(format!("--rate not given: dt = 1/{DEFAULT_RATE} s"));
            DEFAULT_RATE
        }
    };
    ensure!(
        rate.is_finite() && rate > 0.0,
        "rate must be positive, got {rate}"
    );
    let tau_b = a.bias_tau.unwrap_or(DEFAULT_BIAS_TAU);
    ensure!(
        tau_b.is_finite() && tau_b > 0.0,
        "--bias-tau must be positive, got {tau_b}"
    );
    let positive = |name: &str, v: Option<f64>| -> Result<Option<f64>> {
        match v {
            Some(x) if !(x.is_finite() && x >= 0.0) => {
                bail!("--{name} must be a non-negative number, got {x}")
            }
            o => Ok(o),
        }
    };
    // SI densities: options first, then the Kalibr file.
    let n_g = positive("arw", a.arw)?
        .map(gyro_density_from_arw)
        .or(k.map(|k| k.gyroscope_noise_density));
    let n_a = positive("vrw", a.vrw)?
        .map(accel_density_from_vrw)
        .or(k.map(|k| k.accelerometer_noise_density));
    let k_g = positive("gyro-rrw", a.gyro_rrw)?
        .map(|v| rad_s_from_deg_h(v) / 60.0)
        .or(k.map(|k| k.gyroscope_random_walk));
    let k_a = positive("accel-rrw", a.accel_rrw)?
        .map(|v| v / 3600.0 / 60.0)
        .or(k.map(|k| k.accelerometer_random_walk));
    let b_g = positive("gyro-bias-instability", a.gyro_bias_instability)?.map(rad_s_from_deg_h);
    let b_a = positive("accel-bias-instability", a.accel_bias_instability)?.map(m_s2_from_micro_g);
    if (b_g.is_some() || b_a.is_some()) && a.bias_tau.is_none() {
        notes.push(format!(
            "--bias-tau not given: the ADEV minimum is assumed at tau = {DEFAULT_BIAS_TAU} s"
        ));
    }

    let mut bias_gm = [None, None];
    let mut model = ImuModelToml {
        dt: 1.0 / rate,
        gyro: AxesToml::default(),
        accel: AxesToml::default(),
    };
    for (i, (name, n, b, kk)) in [("gyro", n_g, b_g, k_g), ("accel", n_a, b_a, k_a)]
        .into_iter()
        .enumerate()
    {
        let mut comps = Vec::new();
        if let Some(n) = n.filter(|&v| v > 0.0) {
            comps.push(ComponentToml(Component::White(WhiteNoise { density: n })));
        }
        if let Some(b) = b.filter(|&v| v > 0.0) {
            if let Some(gm) = bias_gauss_markov(b, tau_b, n.unwrap_or(0.0), kk.unwrap_or(0.0)) {
                notes.push(if gm.exact {
                    format!(
                        "{name} bias instability -> Gauss-Markov sigma {:.3e}, tau {:.4} s: total ADEV minimum 0.664 B at tau {tau_b} s",
                        gm.sigma, gm.tau
                    )
                } else {
                    format!(
                        "{name} bias instability -> Gauss-Markov sigma {:.3e}, tau {:.4} s by its own ADEV peak (white noise or random walk already exceed 0.664 B at tau {tau_b} s)",
                        gm.sigma, gm.tau
                    )
                });
                comps.push(ComponentToml(Component::GaussMarkov(GaussMarkov {
                    sigma: gm.sigma,
                    tau: gm.tau,
                })));
                bias_gm[i] = Some(gm);
            }
        }
        if let Some(kk) = kk.filter(|&v| v > 0.0) {
            comps.push(ComponentToml(Component::RandomWalk(RandomWalk {
                q: kk * kk,
                sigma0: 0.0,
            })));
        }
        ensure!(
            !comps.is_empty(),
            "no {name} figure given (need at least one of the {name} options or --kalibr)"
        );
        let axes = if i == 0 {
            &mut model.gyro
        } else {
            &mut model.accel
        };
        axes.x = comps.clone();
        axes.y = comps.clone();
        axes.z = comps;
    }
    model.validate("from-datasheet")?;
    let warnings = match a.grade {
        Some(g) => grade_warnings(
            g,
            [
                a.gyro_bias_instability,
                a.arw.or(n_g.map(crate::datasheet::arw_deg_sqrt_h)),
                a.accel_bias_instability,
                a.vrw.or(n_a.map(crate::datasheet::vrw_m_s_sqrt_h)),
            ],
        ),
        None => Vec::new(),
    };
    Ok(FromDatasheet {
        model,
        warnings,
        notes,
        bias_gm,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adis_figures_make_a_loadable_model_and_wrong_grade_warns() {
        let a = DatasheetArgs {
            arw: Some(2.0),
            vrw: Some(0.2),
            gyro_bias_instability: Some(25.2),
            accel_bias_instability: Some(200.0),
            bias_tau: Some(200.0),
            grade: Some(Grade::Tactical),
            ..DatasheetArgs::default()
        };
        let m = build(&a).expect("build");
        assert_eq!(m.model.gyro.x.len(), 2);
        // No exact minimum for these figures (datasheet.rs tests): the peak rule, noted.
        assert!(m.bias_gm[0].is_some_and(|g| !g.exact));
        assert!(
            m.notes.iter().any(|n| n.contains("by its own ADEV peak")),
            "{:?}",
            m.notes
        );
        // ARW 2 deg/sqrt(h) is far above tactical; 25.2 deg/h is within the wide tactical band.
        assert!(
            m.warnings.iter().any(|w| w.contains("angle random walk")),
            "{:?}",
            m.warnings
        );
        let text = m.model.to_text("").expect("text");
        crate::imu_model::parse(&text, "m.toml").expect("reload");
        let none = DatasheetArgs {
            arw: Some(2.0),
            ..DatasheetArgs::default()
        };
        assert!(format!("{:#}", build(&none).unwrap_err()).contains("no accel figure"));
        let neg = DatasheetArgs {
            arw: Some(-1.0),
            vrw: Some(0.1),
            ..DatasheetArgs::default()
        };
        assert!(format!("{:#}", build(&neg).unwrap_err()).contains("--arw"));
    }
}

/// `hal-sim model ...`.
#[derive(Debug, clap::Subcommand)]
pub enum ModelCommand {
    /// Write an IMU model TOML from datasheet figures or a Kalibr IMU YAML.
    FromDatasheet {
        #[command(flatten)]
        figures: DatasheetArgs,
        /// Output IMU model TOML.
        #[arg(long)]
        out: PathBuf,
    },
    /// Draw a static six-axis recording (CSV, SI) from an IMU model TOML.
    Simulate {
        /// IMU model TOML.
        #[arg(long)]
        model: PathBuf,
        /// Duration [s].
        #[arg(long)]
        seconds: f64,
        /// RNG seed (ChaCha8, one stream per axis).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output CSV (gyro_x_rads, ..., accel_z_mps2).
        #[arg(long)]
        out: PathBuf,
    },
}

impl ModelCommand {
    /// Runs the subcommand, printing what it wrote and any warning.
    pub fn run(self) -> Result<()> {
        match self {
            ModelCommand::FromDatasheet { figures, out } => {
                let r = build(&figures)?;
                let mut header =
                    String::from("# Written by `hal-sim model from-datasheet`: the same model on the three axes of each sensor, SI units.\n");
                for n in &r.notes {
                    header += &format!("# {n}\n");
                    println!("{n}");
                }
                for w in &r.warnings {
                    header += &format!("# WARNING: {w}\n");
                    eprintln!("warning: {w}");
                }
                crate::output::write_string(&out, &r.model.to_text(&header)?)?;
                println!("wrote {}", out.display());
            }
            ModelCommand::Simulate {
                model,
                seconds,
                seed,
                out,
            } => {
                let m = crate::imu_model::load(&model)?;
                ensure!(
                    seconds.is_finite() && seconds > 0.0,
                    "--seconds must be positive, got {seconds}"
                );
                let n = (seconds / m.dt).round() as usize;
                let cols = crate::imu_sim::simulate(&m, n, seed)?;
                crate::imu_sim::write_csv(&out, &cols)?;
                println!("wrote {n} rows to {}", out.display());
            }
        }
        Ok(())
    }
}
