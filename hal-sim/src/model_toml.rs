//! The model TOML format (README "Model TOML"), read into and written from the core's
//! [`InsModel`].
//!
//! ```
//! let text = r#"
//! dt = 1.0
//! [observation]
//! sigma_v = 0.03
//! [[accel]]
//! kind = "gauss-markov"
//! sigma = 1e-3
//! tau = 100.0
//! "#;
//! let m = hal_sim::model_toml::parse(text, "inline.toml").unwrap();
//! assert_eq!(m.accel.len(), 1);
//! ```

use anyhow::{anyhow, Context, Result};
use imu_ident::model::{
    Component, ExpCosine, GaussMarkov, InsModel, RandomConstant, RandomWalk, WhiteNoise,
};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `observation.sigma_v` written to `model.toml`: a static recording has no velocity
/// reference, so this is a placeholder (the diagnosis' default of 3 cm/s) to be replaced by
/// the real aiding noise before `hal-sim run` is used on a moving log.
pub const SIGMA_V_PLACEHOLDER: f64 = 0.03;

/// One component as written in TOML; `kind` selects the variant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum ComponentToml {
    /// First-order Gauss-Markov: `sigma` [units], `tau` [s].
    GaussMarkov { sigma: f64, tau: f64 },
    /// Exponential-cosine: `sigma`, `tau` [s], `beta` [rad/s].
    ExpCosine { sigma: f64, tau: f64, beta: f64 },
    /// Random walk: driving density `q` [units^2/s]; optional initial sigma `sigma0`.
    RandomWalk {
        q: f64,
        #[serde(default, skip_serializing_if = "is_zero")]
        sigma0: f64,
    },
    /// Random constant: `sigma` [units].
    RandomConstant { sigma: f64 },
    /// White noise: `density` [units/sqrt(Hz)].
    White { density: f64 },
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// A coloured observation-noise term: Gauss-Markov `sigma` [m/s], `tau` [s].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColoredToml {
    /// Must be "gauss-markov" when given.
    #[serde(default = "gm_kind")]
    pub kind: String,
    /// Standard deviation [m/s].
    pub sigma: f64,
    /// Correlation time [s].
    pub tau: f64,
}

fn gm_kind() -> String {
    "gauss-markov".into()
}

/// `[observation]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObservationToml {
    /// White observation noise [m/s].
    pub sigma_v: f64,
    /// Coloured observation-noise components.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colored: Vec<ColoredToml>,
}

/// `[initial]`: initial uncertainty of the INS states (optional).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitialToml {
    /// Initial velocity-error sigma [m/s] (default: `sigma_v`).
    pub sigma_dv: Option<f64>,
    /// Initial tilt-error sigma [rad] (default 1e-4).
    pub sigma_delta: Option<f64>,
}

/// A whole model file. Scenario files use the same structure, plus `name`, `description` and
/// `hours`, which `run` ignores.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelToml {
    /// Scenario name (scenario files only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    /// Free text (scenario files only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub description: Option<String>,
    /// Default duration [h] (scenario files only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hours: Option<f64>,
    /// Filter step [s].
    pub dt: f64,
    /// Observation noise.
    pub observation: ObservationToml,
    /// Initial INS-state uncertainty.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<InitialToml>,
    /// Accelerometer error components [m/s^2].
    #[serde(default)]
    pub accel: Vec<ComponentToml>,
    /// Gyro drift components [rad/s].
    #[serde(default)]
    pub gyro: Vec<ComponentToml>,
}

impl ComponentToml {
    /// Converts to the core type, checking the parameters.
    pub fn to_core(&self) -> Result<Component<f64>> {
        let c = match *self {
            Self::GaussMarkov { sigma, tau } => {
                Component::GaussMarkov(GaussMarkov::new(sigma, tau)?)
            }
            Self::ExpCosine { sigma, tau, beta } => {
                Component::ExpCosine(ExpCosine::new(sigma, tau, beta)?)
            }
            Self::RandomWalk { q, sigma0 } => Component::RandomWalk(RandomWalk::new(q, sigma0)?),
            Self::RandomConstant { sigma } => {
                Component::RandomConstant(RandomConstant::new(sigma)?)
            }
            Self::White { density } => Component::White(WhiteNoise::new(density)?),
        };
        Ok(c)
    }

    /// From the core type.
    pub fn from_core(c: &Component<f64>) -> Self {
        match *c {
            Component::GaussMarkov(g) => Self::GaussMarkov {
                sigma: g.sigma,
                tau: g.tau,
            },
            Component::ExpCosine(e) => Self::ExpCosine {
                sigma: e.sigma,
                tau: e.tau,
                beta: e.beta,
            },
            Component::RandomWalk(r) => Self::RandomWalk {
                q: r.q,
                sigma0: r.sigma0,
            },
            Component::RandomConstant(r) => Self::RandomConstant { sigma: r.sigma },
            Component::White(w) => Self::White { density: w.density },
        }
    }
}

impl ModelToml {
    /// Converts to the core model, naming the offending field on error.
    pub fn to_core(&self) -> Result<InsModel<f64>> {
        let mut m = InsModel::empty(self.dt, self.observation.sigma_v);
        for (i, c) in self.observation.colored.iter().enumerate() {
            if c.kind != "gauss-markov" {
                return Err(anyhow!(
                    "observation.colored[{i}].kind: expected \"gauss-markov\", found {:?}",
                    c.kind
                ));
            }
            let g = GaussMarkov::new(c.sigma, c.tau)
                .map_err(|e| anyhow!("observation.colored[{i}]: {e:?}"))?;
            m.colored
                .push(g)
                .map_err(|_| anyhow!("observation.colored: too many components"))?;
        }
        for (name, src, dst) in [
            ("accel", &self.accel, &mut m.accel),
            ("gyro", &self.gyro, &mut m.gyro),
        ] {
            for (i, c) in src.iter().enumerate() {
                let core = c.to_core().with_context(|| format!("{name}[{i}]"))?;
                dst.push(core)
                    .map_err(|_| anyhow!("{name}[{i}]: too many components"))?;
            }
        }
        if let Some(init) = self.initial {
            if let Some(s) = init.sigma_dv {
                m.sigma_dv0 = s;
            }
            if let Some(s) = init.sigma_delta {
                m.sigma_delta0 = s;
            }
        }
        m.layout()
            .map_err(|e| anyhow!("model: {e:?} (dt, sigma_v, initial or state count)"))?;
        Ok(m)
    }

    /// From the core model.
    pub fn from_core(m: &InsModel<f64>) -> Self {
        Self {
            name: None,
            description: None,
            hours: None,
            dt: m.dt,
            observation: ObservationToml {
                sigma_v: m.sigma_v,
                colored: m
                    .colored
                    .iter()
                    .map(|g| ColoredToml {
                        kind: gm_kind(),
                        sigma: g.sigma,
                        tau: g.tau,
                    })
                    .collect(),
            },
            initial: Some(InitialToml {
                sigma_dv: Some(m.sigma_dv0),
                sigma_delta: Some(m.sigma_delta0),
            }),
            accel: m.accel.iter().map(ComponentToml::from_core).collect(),
            gyro: m.gyro.iter().map(ComponentToml::from_core).collect(),
        }
    }
}

/// Parses model TOML text; `origin` names the source in errors.
pub fn parse(text: &str, origin: &str) -> Result<InsModel<f64>> {
    parse_file(text, origin)?
        .to_core()
        .with_context(|| format!("{origin}: invalid model"))
}

/// Parses the TOML structure without converting it.
pub fn parse_file(text: &str, origin: &str) -> Result<ModelToml> {
    toml::from_str(text).map_err(|e| anyhow!("{origin}: {e}"))
}

/// Reads a model TOML file.
pub fn load(path: &Path) -> Result<InsModel<f64>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text, &path.display().to_string())
}

/// Serialises a core model as TOML.
pub fn to_string(m: &InsModel<f64>) -> Result<String> {
    Ok(toml::to_string_pretty(&ModelToml::from_core(m))?)
}
