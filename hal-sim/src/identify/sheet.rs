//! The datasheet figures of an identified IMU (`datasheet.json`, `datasheet.md`): per axis the
//! angle / velocity random walk, the bias instability from the Allan minimum, the rate random
//! walk and every Gauss-Markov component, with their 95 % intervals, in datasheet units, each
//! value with 4 significant digits and its unit. Conversions: [`crate::datasheet`].

use serde::Serialize;

use super::fit::Kind;
use super::{IdentifySummary, SensorArg};
use crate::datasheet::{
    accel_rrw_m_s_h_sqrt_h, arw_deg_sqrt_h, deg_h, gyro_rrw_deg_h_sqrt_h, micro_g, vrw_m_s_sqrt_h,
    Reference, FLICKER_FACTOR,
};
use crate::imu_model::{round4, sig4};

/// A value with its 95 % interval and unit, rounded to 4 significant digits.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Figure {
    pub value: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ci95: Option<[f64; 2]>,
    pub unit: &'static str,
}

impl Figure {
    fn new(value: f64, ci: Option<[f64; 2]>, unit: &'static str) -> Self {
        Self {
            value: round4(value),
            ci95: ci
                .filter(|c| c[0].is_finite() && c[1].is_finite())
                .map(|c| [round4(c[0]), round4(c[1])]),
            unit,
        }
    }
    /// `2.013 [1.998, 2.027] deg/sqrt(h)`.
    pub fn text(&self) -> String {
        match self.ci95 {
            Some([lo, hi]) => format!(
                "{} [{}, {}] {}",
                sig4(self.value),
                sig4(lo),
                sig4(hi),
                self.unit
            ),
            None => format!("{} {}", sig4(self.value), self.unit),
        }
    }
}

/// One Gauss-Markov component in datasheet units.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GmFigure {
    pub sigma: Figure,
    pub tau: Figure,
}

/// The figures of one axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisFigures {
    /// `gyro_x` ... `accel_z`.
    pub axis: String,
    pub column: String,
    /// ARW (gyro, deg/sqrt(h)) or VRW (accel, m/s/sqrt(h)) from the fitted white level
    /// (every term correlated over ≤ 0.1 s), with the fit's interval.
    pub random_walk: Figure,
    /// The same read off the measured ADEV as IEEE 952 does, ADEV(τ)·sqrt(τ) at the octave
    /// τ nearest 1 s (`random_walk_tau`), with the Allan interval.
    pub random_walk_at_1s: Figure,
    pub random_walk_tau: f64,
    /// Minimum of the measured ADEV (deg/h or µg) and its τ [s], with the Allan interval.
    pub adev_min: Figure,
    pub adev_min_tau: f64,
    /// Bias instability B = ADEV_min / 0.664 (flicker floor, IEEE 952 Annex C).
    pub bias_instability: Figure,
    /// Rate random walk (deg/h/sqrt(h) or m/s/h/sqrt(h)) of the fitted random-walk term.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rate_random_walk: Option<Figure>,
    pub gauss_markov: Vec<GmFigure>,
}

/// The datasheet figures of one identified axis (`s` in SI units).
pub fn axis_figures(axis: &str, s: &IdentifySummary) -> AxisFigures {
    let gyro = s.sensor == SensorArg::Gyro;
    let (rw, rw_unit): (fn(f64) -> f64, _) = if gyro {
        (arw_deg_sqrt_h, "deg/sqrt(h)")
    } else {
        (vrw_m_s_sqrt_h, "m/s/sqrt(h)")
    };
    let (bias, bias_unit): (fn(f64) -> f64, _) = if gyro {
        (deg_h, "deg/h")
    } else {
        (micro_g, "ug")
    };
    let (rrw, rrw_unit): (fn(f64) -> f64, _) = if gyro {
        (gyro_rrw_deg_h_sqrt_h, "deg/h/sqrt(h)")
    } else {
        (accel_rrw_m_s_h_sqrt_h, "m/s/h/sqrt(h)")
    };
    let wd = s.white_density.unwrap_or([f64::NAN; 3]);
    let random_walk = Figure::new(rw(wd[0]), Some([rw(wd[1]), rw(wd[2])]), rw_unit);
    let rows = &s.residuals;
    let near1 = rows
        .iter()
        .min_by(|a, b| a.tau.ln().abs().total_cmp(&b.tau.ln().abs()));
    let (random_walk_at_1s, random_walk_tau) = match near1 {
        Some(r) => {
            let k = r.tau.sqrt();
            (
                Figure::new(
                    rw(r.adev * k),
                    Some([rw(r.ci_lo * k), rw(r.ci_hi * k)]),
                    rw_unit,
                ),
                r.tau,
            )
        }
        None => (Figure::new(f64::NAN, None, rw_unit), f64::NAN),
    };
    let min = flat_bottom(rows);
    let (adev_min, bias_instability, adev_min_tau) = match min {
        Some(r) => (
            Figure::new(
                bias(r.adev),
                Some([bias(r.ci_lo), bias(r.ci_hi)]),
                bias_unit,
            ),
            Figure::new(
                bias(r.adev) / FLICKER_FACTOR,
                Some([
                    bias(r.ci_lo) / FLICKER_FACTOR,
                    bias(r.ci_hi) / FLICKER_FACTOR,
                ]),
                bias_unit,
            ),
            r.tau,
        ),
        None => (
            Figure::new(f64::NAN, None, bias_unit),
            Figure::new(f64::NAN, None, bias_unit),
            f64::NAN,
        ),
    };
    let rate_random_walk = s
        .components
        .iter()
        .find(|c| c.kind == Kind::RandomWalk)
        .map(|c| {
            Figure::new(
                rrw(c.amplitude),
                c.amplitude_ci.map(|x| [rrw(x[0]), rrw(x[1])]),
                rrw_unit,
            )
        });
    let gauss_markov = s
        .components
        .iter()
        .filter(|c| c.kind == Kind::GaussMarkov)
        .map(|c| GmFigure {
            sigma: Figure::new(
                bias(c.amplitude),
                c.amplitude_ci.map(|x| [bias(x[0]), bias(x[1])]),
                bias_unit,
            ),
            tau: Figure::new(c.tc.unwrap_or(f64::NAN), c.tc_ci, "s"),
        })
        .collect();
    AxisFigures {
        axis: axis.to_string(),
        column: s.column.clone(),
        random_walk,
        random_walk_at_1s,
        random_walk_tau,
        adev_min,
        adev_min_tau: round4(adev_min_tau),
        bias_instability,
        rate_random_walk,
        gauss_markov,
    }
}

/// The ADEV point where IEEE 952 reads the bias instability: the first local minimum of the
/// measured curve (the first octave point not above either neighbour; the last point if the
/// curve still falls). Not the global minimum: the last octaves rest on a few clusters, and
/// their noise (intervals of a factor 2-4) would make a lower point there more likely than
/// not; nor does a Gauss-Markov term, whose ADEV falls again as white noise beyond its peak,
/// leave a floor.
pub fn flat_bottom(rows: &[super::Residual]) -> Option<&super::Residual> {
    let n = rows.len();
    (0..n)
        .find(|&i| {
            let left = i == 0 || rows[i].adev <= rows[i - 1].adev;
            let right = i + 1 == n || rows[i].adev <= rows[i + 1].adev;
            left && right && i > 0
        })
        .or(n.checked_sub(1))
        .map(|i| &rows[i])
}

/// `datasheet.md`: one table per sensor, the Kalibr figures, and the reference datasheet
/// side by side when one was named.
pub fn markdown(
    series: &str,
    axes: &[AxisFigures],
    kalibr: &crate::kalibr::KalibrImu,
    reference: Option<&Reference>,
) -> String {
    let mut md = format!(
        "# Datasheet figures of `{series}`\n\n\
         Written by `hal-sim identify --columns`. 95 % intervals in brackets. Random walk from the \
         fitted white level (ADEV·sqrt(τ) at τ ≈ 1 s in the next column, IEEE Std 952-1997 Annex C); \
         bias instability B = ADEV_min / 0.664 (flicker floor, IEEE 952 Annex C; the ADEV minimum \
         itself is given too, as many datasheets quote it); rate random walk from the fitted \
         random-walk term; Gauss-Markov components of the fit. Conversions in docs/IDENTIFY.md.\n"
    );
    for (sensor, rw, bias) in [
        ("Gyroscopes", "ARW", "deg/h"),
        ("Accelerometers", "VRW", "ug"),
    ] {
        let rows: Vec<&AxisFigures> = axes
            .iter()
            .filter(|a| (a.axis.starts_with("gyro")) == (sensor == "Gyroscopes"))
            .collect();
        md += &format!(
            "\n## {sensor}\n\n| axis | {rw} (fit) | {rw} from ADEV at τ [s] | ADEV min [{bias}] at τ [s] | bias instability B | rate random walk | Gauss-Markov σ, τ |\n|---|---|---|---|---|---|---|\n"
        );
        for a in rows {
            let gm: Vec<String> = a
                .gauss_markov
                .iter()
                .map(|g| format!("σ {}, τ {}", g.sigma.text(), g.tau.text()))
                .collect();
            md += &format!(
                "| {} | {} | {} at {} | {} at {} | {} | {} | {} |\n",
                a.axis,
                a.random_walk.text(),
                a.random_walk_at_1s.text(),
                sig4(a.random_walk_tau),
                a.adev_min.text(),
                sig4(a.adev_min_tau),
                a.bias_instability.text(),
                a.rate_random_walk
                    .as_ref()
                    .map_or("not found".into(), Figure::text),
                if gm.is_empty() {
                    "none".into()
                } else {
                    gm.join("; ")
                },
            );
        }
    }
    md += &format!(
        "\n## Kalibr (`kalibr-imu.yaml`)\n\n| key | value |\n|---|---|\n\
         | gyroscope_noise_density | {} rad/s/sqrt(Hz) |\n| gyroscope_random_walk | {} rad/s^2/sqrt(Hz) |\n\
         | accelerometer_noise_density | {} m/s^2/sqrt(Hz) |\n| accelerometer_random_walk | {} m/s^3/sqrt(Hz) |\n\
         | update_rate | {} Hz |\n",
        sig4(kalibr.gyroscope_noise_density),
        sig4(kalibr.gyroscope_random_walk),
        sig4(kalibr.accelerometer_noise_density),
        sig4(kalibr.accelerometer_random_walk),
        sig4(kalibr.update_rate),
    );
    if let Some(r) = reference {
        md += &reference_table(axes, r);
    }
    md
}

/// Range `[min, max]` over axes of a figure.
fn span(axes: &[AxisFigures], gyro: bool, f: impl Fn(&AxisFigures) -> f64) -> [f64; 2] {
    axes.iter()
        .filter(|a| a.axis.starts_with("gyro") == gyro)
        .map(f)
        .fold([f64::INFINITY, f64::NEG_INFINITY], |r, v| {
            [r[0].min(v), r[1].max(v)]
        })
}

/// The measured figures (range over the three axes) beside the datasheet's typical values.
fn reference_table(axes: &[AxisFigures], r: &Reference) -> String {
    let rng = |s: [f64; 2]| format!("{} to {}", sig4(s[0]), sig4(s[1]));
    let arw = span(axes, true, |a| a.random_walk.value);
    let vrw = span(axes, false, |a| a.random_walk.value);
    let gmin = span(axes, true, |a| a.adev_min.value);
    let gb = span(axes, true, |a| a.bias_instability.value);
    let amin = span(axes, false, |a| a.adev_min.value);
    let ab = span(axes, false, |a| a.bias_instability.value);
    format!(
        "\n## Against the {} datasheet (typical values)\n\nSource: {}\n\n\
         | figure | datasheet (typical) | measured, ADEV minimum (3 axes) | measured, B = min/0.664 (3 axes) |\n|---|---|---|---|\n\
         | gyro in-run bias stability | {} deg/h | {} deg/h | {} deg/h |\n\
         | angle random walk | {} deg/sqrt(h) | {} deg/sqrt(h) (fit) | |\n\
         | accel in-run bias stability | {} ug | {} ug | {} ug |\n\
         | velocity random walk | {} m/s/sqrt(h) | {} m/s/sqrt(h) (fit) | |\n\n{}\n",
        r.name,
        r.source,
        sig4(r.gyro_bias_instability_deg_h),
        rng(gmin),
        rng(gb),
        sig4(r.arw_deg_sqrt_h),
        rng(arw),
        sig4(r.accel_bias_instability_ug),
        rng(amin),
        rng(ab),
        sig4(r.vrw_m_s_sqrt_h),
        rng(vrw),
        r.note,
    )
}
