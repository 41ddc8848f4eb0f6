//! Datasheet figures of an IMU and their conversions to and from the SI model parameters
//! (docs/IDENTIFY.md "Datasheet figures"; IEEE Std 952-1997 Annex C, IEEE Std 1293-2018).
//!
//! | figure | datasheet unit | model parameter (SI) |
//! |---|---|---|
//! | angle random walk (ARW) | deg/sqrt(h) | gyro white density N [rad/s/sqrt(Hz)] = ARW · (pi/180) / 60 |
//! | velocity random walk (VRW) | m/s/sqrt(h) | accel white density N [m/s^2/sqrt(Hz)] = VRW / 60 |
//! | gyro bias instability | deg/h | B [rad/s] = BI · (pi/180) / 3600 |
//! | accel bias instability | µg | B [m/s^2] = BI · 1e-6 · 9.80665 |
//! | gyro rate random walk | deg/h/sqrt(h) | K [rad/s^2/sqrt(Hz)] = RRW · (pi/180) / 3600 / 60 |
//! | accel rate random walk | m/s/h/sqrt(h) | K [m/s^3/sqrt(Hz)] = RRW / 3600 / 60 |
//!
//! The bias instability B is the flicker floor of the ADEV, ADEV_min = 0.664 B (IEEE 952
//! Annex C: σ² = (2 ln 2/π) B²). The model has no flicker kind, so [`bias_gauss_markov`]
//! turns B into a Gauss-Markov component whose ADEV, added to the white noise and the random
//! walk, has its minimum 0.664 B at the datasheet's averaging time.

use std::f64::consts::PI;

use serde::Serialize;

use crate::allan::theory::avar_gauss_markov;

/// Standard gravity [m/s^2] (the µg of datasheets).
pub const G0: f64 = 9.80665;
/// ADEV_min / B for flicker noise: sqrt(2 ln 2 / pi) = 0.6643 (IEEE 952 Annex C).
pub const FLICKER_FACTOR: f64 = 0.664;
/// deg/s per rad/s.
const DEG: f64 = 180.0 / PI;

/// Gyro white density [rad/s/sqrt(Hz)] → ARW [deg/sqrt(h)].
pub fn arw_deg_sqrt_h(n: f64) -> f64 {
    n * DEG * 60.0
}
/// ARW [deg/sqrt(h)] → gyro white density [rad/s/sqrt(Hz)].
pub fn gyro_density_from_arw(arw: f64) -> f64 {
    arw / DEG / 60.0
}
/// Accel white density [m/s^2/sqrt(Hz)] → VRW [m/s/sqrt(h)].
pub fn vrw_m_s_sqrt_h(n: f64) -> f64 {
    n * 60.0
}
/// VRW [m/s/sqrt(h)] → accel white density [m/s^2/sqrt(Hz)].
pub fn accel_density_from_vrw(vrw: f64) -> f64 {
    vrw / 60.0
}
/// Gyro rate [rad/s] → [deg/h].
pub fn deg_h(w: f64) -> f64 {
    w * DEG * 3600.0
}
/// [deg/h] → [rad/s].
pub fn rad_s_from_deg_h(w: f64) -> f64 {
    w / DEG / 3600.0
}
/// Acceleration [m/s^2] → [µg].
pub fn micro_g(a: f64) -> f64 {
    a / G0 * 1e6
}
/// [µg] → [m/s^2].
pub fn m_s2_from_micro_g(a: f64) -> f64 {
    a * 1e-6 * G0
}
/// Gyro rate random walk K [rad/s^2/sqrt(Hz)] → [deg/h/sqrt(h)].
pub fn gyro_rrw_deg_h_sqrt_h(k: f64) -> f64 {
    k * DEG * 3600.0 * 60.0
}
/// Accel rate random walk K [m/s^3/sqrt(Hz)] → [m/s/h/sqrt(h)].
pub fn accel_rrw_m_s_h_sqrt_h(k: f64) -> f64 {
    k * 3600.0 * 60.0
}

/// Where the ADEV of a Gauss-Markov process of unit σ and correlation time 1 peaks:
/// `(x*, ADEV_max/σ)` with x* = τ_peak / T_c. From the exact curve σ² h(τ/T_c),
/// h(x) = (2x − 3 + 4e^{−x} − e^{−2x})/x² ([`avar_gauss_markov`]): golden-section search,
/// giving x* = 1.893 and ADEV_max = 0.6174 σ (the "0.62 σ at 1.89 T_c" of the literature).
pub fn gm_peak() -> (f64, f64) {
    let f = |ln_x: f64| -avar_gauss_markov(1.0, 1.0, ln_x.exp());
    let (mut a, mut b) = (0.5_f64.ln(), 5.0_f64.ln());
    let r = 0.5 * (5.0_f64.sqrt() - 1.0);
    for _ in 0..100 {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if f(c) < f(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let x = (0.5 * (a + b)).exp();
    (x, avar_gauss_markov(1.0, 1.0, x).sqrt())
}

/// How a bias instability became a Gauss-Markov component.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BiasGm {
    /// Stationary standard deviation [SI].
    pub sigma: f64,
    /// Correlation time [s].
    pub tau: f64,
    /// `true`: the total ADEV (white + GM + random walk) has its minimum 0.664 B exactly at
    /// the averaging time; `false`: the white noise or random walk alone already exceed
    /// 0.664 B there, and the GM was set by its own peak (σ = 0.664 B / 0.6174,
    /// T_c = τ_B / 1.893), which the total curve then lies above.
    pub exact: bool,
}

/// The Gauss-Markov component for bias instability `b` [SI] whose ADEV minimum lies at the
/// averaging time `tau_b` [s], given the white density `n` and random-walk density `k`.
///
/// Exact matching: with A(τ) = n²/τ + k²τ/3 + σ² h(τ/T_c), require A(τ_b) = (0.664 b)² and
/// A'(τ_b) = 0. Let R = (0.664 b)² − n²/τ_b − k²τ_b/3 (what the GM must supply). The second
/// condition fixes the GM's log-slope x h'(x)/h(x) = (n²/τ_b − k²τ_b/3)/R at x = τ_b/T_c;
/// that slope falls monotonically from +1 (x → 0) to −1 (x → ∞), so x follows by bisection,
/// then σ² = R/h(x). The stationary point is checked to be a minimum; when R ≤ 0, the slope
/// is out of (−1, 1) or it is not a minimum, the peak rule is used instead (`exact = false`).
pub fn bias_gauss_markov(b: f64, tau_b: f64, n: f64, k: f64) -> Option<BiasGm> {
    if !(b > 0.0 && tau_b > 0.0 && n >= 0.0 && k >= 0.0) {
        return None;
    }
    let target = (FLICKER_FACTOR * b).powi(2);
    let white = n * n / tau_b;
    let rw = k * k * tau_b / 3.0;
    let r = target - white - rw;
    let h = |x: f64| avar_gauss_markov(1.0, 1.0, x);
    let slope = |x: f64| {
        let e = 1e-5;
        (h(x * (1.0 + e)).ln() - h(x * (1.0 - e)).ln()) / ((1.0 + e).ln() - (1.0 - e).ln())
    };
    let (x_peak, peak) = gm_peak();
    let fallback = BiasGm {
        sigma: FLICKER_FACTOR * b / peak,
        tau: tau_b / x_peak,
        exact: false,
    };
    if r <= 0.0 {
        return Some(fallback);
    }
    let s_target = (white - rw) / r;
    if !(s_target > -0.999 && s_target < 0.999) {
        return Some(fallback);
    }
    let (mut lo, mut hi) = (1e-4_f64.ln(), 1e4_f64.ln());
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if slope(mid.exp()) > s_target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let x = (0.5 * (lo + hi)).exp();
    let gm = BiasGm {
        sigma: (r / h(x)).sqrt(),
        tau: tau_b / x,
        exact: true,
    };
    let total =
        |tau: f64| n * n / tau + k * k * tau / 3.0 + avar_gauss_markov(gm.sigma, gm.tau, tau);
    let at = total(tau_b);
    let is_min = total(tau_b * 1.25) >= at && total(tau_b / 1.25) >= at;
    Some(if is_min && gm.sigma.is_finite() {
        gm
    } else {
        fallback
    })
}

/// A published datasheet to set the identified figures against (`identify --reference NAME`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Reference {
    pub name: &'static str,
    pub source: &'static str,
    pub gyro_bias_instability_deg_h: f64,
    pub arw_deg_sqrt_h: f64,
    pub accel_bias_instability_ug: f64,
    pub vrw_m_s_sqrt_h: f64,
    /// How the datasheet defines its figures.
    pub note: &'static str,
}

/// The datasheets known to `--reference`.
pub const REFERENCES: [Reference; 1] = [Reference {
    name: "ADIS16405",
    source: concat!(
        "Analog Devices, ADIS16405 data sheet Rev. B, Specifications table, typical values: ",
        "gyroscope in-run bias stability 0.007 deg/s (1 sigma) = 25.2 deg/h, angular random ",
        "walk 2.0 deg/sqrt(h); accelerometer in-run bias stability 0.2 mg (1 sigma) = 200 ug, ",
        "velocity random walk 0.2 m/s/sqrt(h)"
    ),
    gyro_bias_instability_deg_h: 0.007 * 3600.0,
    arw_deg_sqrt_h: 2.0,
    accel_bias_instability_ug: 200.0,
    vrw_m_s_sqrt_h: 0.2,
    note: "Analog Devices quotes in-run bias stability as the 1-sigma minimum of the Allan \
           deviation curve, so the datasheet value compares with the measured ADEV minimum \
           column; B = min/0.664 is the IEEE 952 flicker coefficient of the same curve.",
}];

/// The reference datasheet named `name` (case-insensitive).
pub fn reference(name: &str) -> Option<&'static Reference> {
    REFERENCES
        .iter()
        .find(|r| r.name.eq_ignore_ascii_case(name))
}

/// The grade an IMU claims (`--grade`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Grade {
    Consumer,
    Industrial,
    Tactical,
    Navigation,
}

/// Plausible range `[lo, hi]` of each datasheet figure per grade:
/// `(gyro BI deg/h, ARW deg/sqrt(h), accel BI µg, VRW m/s/sqrt(h))`.
///
/// Order-of-magnitude bands, deliberately wide and overlapping: gyro bias and accelerometer
/// bias classes after Groves, *Principles of GNSS, Inertial, and Multisensor Integrated
/// Navigation Systems*, 2nd ed. (2013), §4.4 (navigation/marine-aviation 0.001-0.01 deg/h and
/// 30-100 µg, tactical 1-100 deg/h... MEMS consumer ≥ 100 deg/h), and the noise figures of
/// published datasheets of each class (navigation RLG/FOG ARW ≈ 0.001-0.005 deg/sqrt(h);
/// tactical FOG/MEMS 0.02-0.3; industrial MEMS such as ADIS16405 2 deg/sqrt(h), 25 deg/h,
/// 200 µg, 0.2 m/s/sqrt(h); consumer MEMS 0.3-10 deg/sqrt(h)). A figure outside its band is a
/// warning: it is either a typing error (units) or the grade claimed is not the sensor's.
pub fn grade_ranges(g: Grade) -> [[f64; 2]; 4] {
    match g {
        Grade::Navigation => [[1e-4, 0.05], [1e-4, 0.02], [1.0, 150.0], [1e-3, 0.05]],
        Grade::Tactical => [[0.05, 30.0], [0.01, 0.5], [30.0, 3000.0], [0.01, 0.5]],
        Grade::Industrial => [[0.5, 200.0], [0.05, 5.0], [20.0, 10_000.0], [0.02, 1.0]],
        Grade::Consumer => [[5.0, 1e5], [0.1, 50.0], [100.0, 1e5], [0.03, 10.0]],
    }
}

/// Names and units of the four graded figures, in [`grade_ranges`] order.
pub const GRADED: [(&str, &str); 4] = [
    ("gyro bias instability", "deg/h"),
    ("angle random walk", "deg/sqrt(h)"),
    ("accel bias instability", "ug"),
    ("velocity random walk", "m/s/sqrt(h)"),
];

/// Warnings for the figures (same order as [`GRADED`]; `None` = not given) outside the
/// grade's range.
pub fn grade_warnings(g: Grade, figures: [Option<f64>; 4]) -> Vec<String> {
    let ranges = grade_ranges(g);
    let mut out = Vec::new();
    for ((v, [lo, hi]), (name, unit)) in figures.iter().zip(ranges).zip(GRADED) {
        if let Some(v) = v {
            if !(*v >= lo && *v <= hi) {
                out.push(format!(
                    "{name} {} {unit} is outside the {:?} range [{}, {}] {unit}: check the unit, or the grade",
                    crate::imu_model::sig4(*v),
                    g,
                    lo,
                    hi
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gm_peak_is_the_textbook_relation() {
        let (x, p) = gm_peak();
        assert!((x - 1.893).abs() < 2e-3, "{x}");
        assert!((p - 0.6174).abs() < 1e-4, "{p}");
    }

    #[test]
    fn bias_gm_puts_the_total_minimum_at_tau_b() {
        // Tactical gyro: ARW 0.3 deg/sqrt(h), B = 10 deg/h, minimum at 20 s.
        let n = gyro_density_from_arw(0.3);
        let b = rad_s_from_deg_h(10.0);
        let gm = bias_gauss_markov(b, 20.0, n, 0.0).expect("gm");
        assert!(gm.exact);
        let total = |t: f64| n * n / t + avar_gauss_markov(gm.sigma, gm.tau, t);
        // The local minimum (on 1-60 s): without a random walk the curve falls again beyond
        // the GM peak, as white noise (docs/IDENTIFY.md).
        let min = (0..178)
            .map(|i| 10f64.powf(i as f64 / 100.0))
            .map(|t| (t, total(t).sqrt()))
            .fold((0.0, f64::MAX), |a, b| if b.1 < a.1 { b } else { a });
        assert!((min.0 / 20.0 - 1.0).abs() < 0.03, "{min:?}");
        assert!((min.1 / (FLICKER_FACTOR * b) - 1.0).abs() < 1e-3, "{min:?}");
        // White noise alone above 0.664 B at tau_b: the peak rule.
        let gm = bias_gauss_markov(b, 0.01, n, 0.0).expect("gm");
        assert!(!gm.exact);
        // ADIS16405 figures (2 deg/sqrt(h), 25.2 deg/h): at 100 s the white noise needs a GM
        // log-slope of 1.07 (> 1, impossible); at 200 s the stationary point is a maximum of
        // the total (the GM turns over faster than the white noise falls). Both: the peak rule.
        let (n, b) = (gyro_density_from_arw(2.0), rad_s_from_deg_h(25.2));
        for tau_b in [100.0, 200.0] {
            let gm = bias_gauss_markov(b, tau_b, n, 0.0).expect("gm");
            assert!(!gm.exact, "{tau_b}");
            let (x, p) = gm_peak();
            assert!((gm.tau * x / tau_b - 1.0).abs() < 1e-12);
            assert!((gm.sigma * p / (FLICKER_FACTOR * b) - 1.0).abs() < 1e-12);
        }
        assert!(bias_gauss_markov(-1.0, 1.0, n, 0.0).is_none());
    }

    #[test]
    fn conversions_invert_and_grades_warn() {
        for v in [1e-3, 0.2, 7.0] {
            assert!((arw_deg_sqrt_h(gyro_density_from_arw(v)) / v - 1.0).abs() < 1e-12);
            assert!((deg_h(rad_s_from_deg_h(v)) / v - 1.0).abs() < 1e-12);
            assert!((micro_g(m_s2_from_micro_g(v)) / v - 1.0).abs() < 1e-12);
        }
        let adis = [Some(25.2), Some(2.0), Some(200.0), Some(0.2)];
        assert!(grade_warnings(Grade::Industrial, adis).is_empty());
        let w = grade_warnings(Grade::Navigation, adis);
        assert_eq!(w.len(), 4, "{w:?}");
        assert!(w[0].contains("deg/h"), "{w:?}");
    }
}
