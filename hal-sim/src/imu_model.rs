//! The IMU model TOML: one noise model per axis of a six-axis IMU (README "IMU model TOML").
//!
//! ```toml
//! dt = 1.000e-2          # sample interval [s]
//! [[gyro.x]]             # components of gyro x [rad/s], summed; same syntax as [[gyro]]
//! kind = "white"
//! density = 1.234e-4     # [rad/s/sqrt(Hz)]
//! [[accel.z]]
//! kind = "gauss-markov"
//! sigma = 1.000e-4       # [m/s^2]
//! tau = 5.000e1          # [s]
//! ```
//!
//! Each `[[<sensor>.<axis>]]` list uses the component syntax of the one-channel model TOML
//! ([`crate::model_toml::ComponentToml`]); [`ImuModelToml::channel`] gives the one-channel
//! model of an axis, which `hal-sim run` can load. Numbers are written exactly (the shortest
//! text that reads back to the same value), with their unit and, when long, their 4-digit
//! reading ([`readable_toml`]).

use std::path::Path;

use anyhow::{anyhow, Context, Result};
use imu_ident::model::Quantity;
use serde::{Deserialize, Serialize};

use crate::model_toml::{ComponentToml, ModelToml, ObservationToml};

/// The three axes of one sensor.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxesToml {
    /// Shorthand: components on each of the three axes (before the axis's own ones).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub all: Vec<ComponentToml>,
    #[serde(default)]
    pub x: Vec<ComponentToml>,
    #[serde(default)]
    pub y: Vec<ComponentToml>,
    #[serde(default)]
    pub z: Vec<ComponentToml>,
}

impl AxesToml {
    /// Every component of axis `a`: the `all` shorthand, then the axis's own.
    pub fn components(&self, a: char) -> Option<Vec<ComponentToml>> {
        let own = self.axis(a)?;
        Some(self.all.iter().chain(own.iter()).cloned().collect())
    }

    /// The components of axis `a` (`x`, `y` or `z`).
    pub fn axis(&self, a: char) -> Option<&Vec<ComponentToml>> {
        match a {
            'x' => Some(&self.x),
            'y' => Some(&self.y),
            'z' => Some(&self.z),
            _ => None,
        }
    }
    /// Mutable access to axis `a`.
    pub fn axis_mut(&mut self, a: char) -> Option<&mut Vec<ComponentToml>> {
        match a {
            'x' => Some(&mut self.x),
            'y' => Some(&mut self.y),
            'z' => Some(&mut self.z),
            _ => None,
        }
    }
}

/// `imu-model.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuModelToml {
    /// Sample interval [s].
    #[serde(default = "default_dt")]
    pub dt: f64,
    /// Gyro axes [rad/s].
    #[serde(default)]
    pub gyro: AxesToml,
    /// Accelerometer axes [m/s^2].
    #[serde(default)]
    pub accel: AxesToml,
}

/// `dt` when a file has none (a navigation model needs none: `hal-sim nav` takes the times from
/// the IMU log).
fn default_dt() -> f64 {
    1.0
}

/// Axis labels in file order.
pub const AXES: [char; 3] = ['x', 'y', 'z'];

impl ImuModelToml {
    /// The one-channel model TOML of `sensor` (`gyro` or `accel`) axis `a`, with the
    /// placeholder observation noise of `identify` (a static record has no velocity reference).
    pub fn channel(&self, sensor: &str, a: char) -> Result<ModelToml> {
        let axes = match sensor {
            "gyro" => &self.gyro,
            "accel" => &self.accel,
            o => return Err(anyhow!("unknown sensor '{o}' (gyro or accel)")),
        };
        let comps = axes
            .components(a)
            .ok_or_else(|| anyhow!("unknown axis '{a}' (x, y or z)"))?;
        let mut m = ModelToml {
            name: None,
            description: None,
            hours: None,
            dt: self.dt,
            observation: ObservationToml {
                sigma_v: crate::model_toml::SIGMA_V_PLACEHOLDER,
                colored: vec![],
            },
            initial: None,
            accel: vec![],
            gyro: vec![],
        };
        if sensor == "gyro" {
            m.gyro = comps;
        } else {
            m.accel = comps;
        }
        Ok(m)
    }

    /// Every axis must load as a one-channel core model (parameters in range, state count).
    pub fn validate(&self, origin: &str) -> Result<()> {
        for sensor in ["gyro", "accel"] {
            for a in AXES {
                self.channel(sensor, a)?
                    .to_core()
                    .with_context(|| format!("{origin}: [[{sensor}.{a}]]"))?;
            }
        }
        Ok(())
    }

    /// The strapdown navigator's per-axis noise model (core units: rad/s, m/s^2).
    pub fn to_nav(&self, origin: &str) -> Result<imu_ident::nav::ImuErrorModel<f64>> {
        let mut m = imu_ident::nav::ImuErrorModel::default();
        for (name, axes, out) in [
            ("gyro", &self.gyro, &mut m.gyro),
            ("accel", &self.accel, &mut m.accel),
        ] {
            for (a, slot) in AXES.iter().zip(out.iter_mut()) {
                for c in axes.components(*a).unwrap_or_default() {
                    let core = c
                        .to_core()
                        .with_context(|| format!("{origin}: [[{name}.{a}]]"))?;
                    slot.push(core).map_err(|_| {
                        anyhow!(
                            "{origin}: [[{name}.{a}]] has more than {} components",
                            imu_ident::nav::MAX_AXIS_COMPONENTS
                        )
                    })?;
                }
            }
        }
        Ok(m)
    }

    /// The file text: a comment header, then the TOML with readable numbers.
    pub fn to_text(&self, header: &str) -> Result<String> {
        let body = toml::to_string_pretty(self)?;
        Ok(format!("{header}{}", readable_toml(&body)))
    }
}

/// Parses an IMU model TOML; errors name the origin (and the line, from the toml crate).
pub fn parse(text: &str, origin: &str) -> Result<ImuModelToml> {
    let m: ImuModelToml = toml::from_str(text).with_context(|| format!("{origin}: IMU model"))?;
    m.validate(origin)?;
    Ok(m)
}

/// Reads and checks an IMU model TOML file.
pub fn load(path: &Path) -> Result<ImuModelToml> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text, &path.display().to_string())
}

/// Unit of `key` in a model TOML section (`[[gyro.x]]`, `[[accel]]`, `[observation]`, top).
fn unit_of(section: &str, key: &str) -> Option<String> {
    let u = if section.starts_with("gyro") {
        "rad/s"
    } else if section.starts_with("accel") {
        "m/s^2"
    } else {
        "m/s"
    };
    // A component's quantity: its unit by the core's table of quantities (a new quantity
    // does not compile until it has a unit here).
    if let Some(q) = Quantity::from_name(key) {
        return Some(match q {
            Quantity::Tau => "s".into(),
            Quantity::Beta => "rad/s".into(),
            Quantity::Sigma | Quantity::Sigma0 => u.into(),
            Quantity::Density => format!("{u}/sqrt(Hz)"),
            Quantity::Q => format!("({u})^2/s"),
        });
    }
    Some(match key {
        "dt" => "s".into(),
        "sigma_v" | "sigma_dv" => u.into(),
        "sigma_delta" => "rad".into(),
        "hours" => "h".into(),
        _ => return None,
    })
}

/// Rewrites every `key = number` line of a model TOML with its exact value, its unit and, when
/// the exact text is long, its 4-digit reading as a comment
/// (`sigma = 2.9362341082725943e-6  # [rad/s] ~ 2.936e-6`), so that a person can read the file
/// and a program reads back exactly the value that was written.
pub fn readable_toml(text: &str) -> String {
    let mut section = String::new();
    let mut out = String::with_capacity(text.len() + text.len() / 2);
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            section = t.trim_matches(|c| c == '[' || c == ']').to_string();
        }
        // The value exactly (Rust's shortest text that parses back to the same f64: a model
        // written here and read back runs the same filter), its unit, and when the exact text
        // is long, its 4-digit reading.
        let rewritten = t.split_once(" = ").and_then(|(k, v)| {
            let x: f64 = v.trim().parse().ok()?;
            let unit = unit_of(&section, k.trim())?;
            let (exact, short) = (format!("{x:e}"), sig4(x));
            let approx = if exact.len() > short.len() {
                format!(" ~ {short}")
            } else {
                String::new()
            };
            Some(format!("{} = {exact}  # [{unit}]{approx}", k.trim()))
        });
        out.push_str(rewritten.as_deref().unwrap_or(line));
        out.push('\n');
    }
    out
}

/// `x` with 4 significant digits in scientific notation (`2.936e-6`): the comments of
/// [`readable_toml`] and the JSON outputs meant to be read.
pub fn sig4(x: f64) -> String {
    format!("{x:.3e}")
}

/// `x` rounded to 4 significant digits (for JSON outputs meant to be read).
pub fn round4(x: f64) -> f64 {
    sig4(x).parse().unwrap_or(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use imu_ident::model::{Component, GaussMarkov, WhiteNoise};

    #[test]
    fn round_trip_and_one_channel_extraction() {
        let mut m = ImuModelToml {
            dt: 0.01,
            gyro: AxesToml::default(),
            accel: AxesToml::default(),
        };
        for a in AXES {
            m.gyro
                .axis_mut(a)
                .expect("axis")
                .push(ComponentToml(Component::White(WhiteNoise {
                    density: 2.9362341082725943e-6,
                })));
            m.accel
                .axis_mut(a)
                .expect("axis")
                .push(ComponentToml(Component::GaussMarkov(GaussMarkov {
                    sigma: 1e-4,
                    tau: 50.0,
                })));
        }
        let text = m.to_text("# test\n").expect("text");
        assert!(
            text.contains("density = 2.9362341082725943e-6  # [rad/s/sqrt(Hz)] ~ 2.936e-6"),
            "{text}"
        );
        assert!(text.contains("tau = 5e1  # [s]\n"), "{text}");
        assert!(text.contains("[[accel.z]]"), "{text}");
        let back = parse(&text, "t.toml").expect("parse");
        assert_eq!(back.gyro.x.len(), 1);
        // Exactly the values written.
        assert_eq!(back, m);
        let one = back.channel("accel", 'y').expect("channel");
        let core = one.to_core().expect("core");
        assert_eq!(core.accel.len(), 1);
        // Unknown fields are errors, naming the line.
        let bad = text.replace("tau = ", "tua = ");
        let e = format!("{:#}", parse(&bad, "bad.toml").unwrap_err());
        assert!(e.contains("bad.toml") && e.contains("line"), "{e}");
    }
}
