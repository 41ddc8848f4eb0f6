//! Kalibr's IMU noise file (`imu.yaml` of ethz-asl/kalibr, "IMU Noise Model" wiki page):
//! continuous-time densities shared by the three axes of each sensor.
//!
//! | key | unit |
//! |---|---|
//! | `gyroscope_noise_density` | rad/s/sqrt(Hz) (N of the gyro white noise) |
//! | `gyroscope_random_walk` | rad/s^2/sqrt(Hz) (K of the gyro bias random walk) |
//! | `accelerometer_noise_density` | m/s^2/sqrt(Hz) |
//! | `accelerometer_random_walk` | m/s^3/sqrt(Hz) |
//! | `update_rate` | Hz |
//!
//! The file is written by hand (five `key: number` lines and comments: a YAML library would add
//! a dependency for no gain, and could not write the comments); it is read with `yaml-rust2`,
//! a maintained YAML 1.2 parser, so that any valid Kalibr file (flow style, extra keys such as
//! `rostopic`) is accepted.

use std::path::Path;

use anyhow::{anyhow, Context, Result};
use serde::Serialize;
use yaml_rust2::{Yaml, YamlLoader};

use crate::imu_model::sig4;
use crate::output::write_string;

/// The five Kalibr figures (SI, continuous time).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct KalibrImu {
    pub accelerometer_noise_density: f64,
    pub accelerometer_random_walk: f64,
    pub gyroscope_noise_density: f64,
    pub gyroscope_random_walk: f64,
    pub update_rate: f64,
}

impl KalibrImu {
    /// The YAML text, with the unit of each key as a comment and 4 significant digits.
    pub fn to_yaml(&self, origin: &str) -> String {
        format!(
            "# Kalibr IMU noise model (continuous time), written by {origin}.\n\
             # rostopic is a placeholder: set it to the IMU topic of the bag.\n\
             rostopic: /imu0\n\
             accelerometer_noise_density: {}  # [m/s^2/sqrt(Hz)]\n\
             accelerometer_random_walk: {}  # [m/s^3/sqrt(Hz)]\n\
             gyroscope_noise_density: {}  # [rad/s/sqrt(Hz)]\n\
             gyroscope_random_walk: {}  # [rad/s^2/sqrt(Hz)]\n\
             update_rate: {}  # [Hz]\n",
            sig4(self.accelerometer_noise_density),
            sig4(self.accelerometer_random_walk),
            sig4(self.gyroscope_noise_density),
            sig4(self.gyroscope_random_walk),
            sig4(self.update_rate),
        )
    }

    /// Writes `path` atomically.
    pub fn write(&self, path: &Path, origin: &str) -> Result<()> {
        write_string(path, &self.to_yaml(origin))
    }
}

/// Parses a Kalibr IMU YAML; errors name the origin, and the line for a syntax error.
pub fn parse(text: &str, origin: &str) -> Result<KalibrImu> {
    let docs = YamlLoader::load_from_str(text).map_err(|e| {
        anyhow!(
            "{origin} line {}, column {}: YAML: {}",
            e.marker().line(),
            e.marker().col() + 1,
            e.info()
        )
    })?;
    let doc = docs
        .first()
        .ok_or_else(|| anyhow!("{origin}: empty YAML file"))?;
    let get = |key: &str| -> Result<f64> {
        let v = match &doc[key] {
            Yaml::Real(_) | Yaml::Integer(_) => doc[key]
                .as_f64()
                .or_else(|| doc[key].as_i64().map(|i| i as f64)),
            Yaml::BadValue => return Err(anyhow!("{origin}: key '{key}' is missing")),
            _ => None,
        };
        match v {
            Some(x) if x.is_finite() && x >= 0.0 => Ok(x),
            _ => Err(anyhow!(
                "{origin}, key '{key}': expected a non-negative number, found {:?}",
                doc[key]
            )),
        }
    };
    Ok(KalibrImu {
        accelerometer_noise_density: get("accelerometer_noise_density")?,
        accelerometer_random_walk: get("accelerometer_random_walk")?,
        gyroscope_noise_density: get("gyroscope_noise_density")?,
        gyroscope_random_walk: get("gyroscope_random_walk")?,
        update_rate: get("update_rate")?,
    })
}

/// Reads a Kalibr IMU YAML file.
pub fn load(path: &Path) -> Result<KalibrImu> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    parse(&text, &path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_file_reads_back_and_bad_files_are_named() {
        let k = KalibrImu {
            accelerometer_noise_density: 2.0e-3,
            accelerometer_random_walk: 3.0e-3,
            gyroscope_noise_density: 1.6968e-4,
            gyroscope_random_walk: 1.9393e-5,
            update_rate: 200.0,
        };
        let back = parse(&k.to_yaml("test"), "k.yaml").expect("parse");
        // Written with 4 significant digits: equal to 5e-4 relative.
        let close = |a: f64, b: f64| ((a - b) / b).abs() < 5e-4;
        assert!(close(
            back.gyroscope_noise_density,
            k.gyroscope_noise_density
        ));
        assert!(close(back.gyroscope_random_walk, k.gyroscope_random_walk));
        assert!(close(
            back.accelerometer_random_walk,
            k.accelerometer_random_walk
        ));
        assert_eq!(back.update_rate, 200.0);
        // Kalibr's own example style: integers, flow style and extra keys are accepted.
        let flow = "{rostopic: /imu0, update_rate: 200, accelerometer_noise_density: 0.01, \
                    accelerometer_random_walk: 0.0002, gyroscope_noise_density: 0.005, \
                    gyroscope_random_walk: 4.0e-06}";
        assert_eq!(parse(flow, "f.yaml").expect("flow").update_rate, 200.0);
        let e = parse("update_rate: 200\n", "m.yaml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.yaml") && e.contains("accelerometer_noise_density"),
            "{e}"
        );
        let e = parse("a: [1, 2\nb: 3\n", "s.yaml").unwrap_err().to_string();
        assert!(e.contains("s.yaml line"), "{e}");
        let bad = k
            .to_yaml("t")
            .replace("update_rate: 2.000e2", "update_rate: fast");
        let e = parse(&bad, "b.yaml").unwrap_err().to_string();
        assert!(e.contains("'update_rate'"), "{e}");
    }
}
