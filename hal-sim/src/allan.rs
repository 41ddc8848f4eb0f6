//! Maximum-overlap (overlapping) Allan variance and deviation, with confidence intervals.
//!
//! # Estimator
//! For a rate series `y_0 … y_{n-1}` sampled at `rate` Hz and a cluster of `m` samples
//! (τ = m / rate), the maximum-overlap estimator (IEEE Std 1139-2008; NIST SP 1065 eq. 11;
//! Percival & Guttorp 1994) is
//!
//! ```text
//! AVAR(τ) = 1 / (2 (n − 2m + 1)) · Σ_{k=0}^{n−2m} ( ȳ_{k+m}(m) − ȳ_k(m) )²,
//! ȳ_k(m) = (1/m) Σ_{i=k}^{k+m−1} y_i .
//! ```
//!
//! With the running sum (the "phase") `S_0 = 0`, `S_{j+1} = S_j + (y_j − ȳ)`, a cluster mean
//! difference is `(S_{k+2m} − 2 S_{k+m} + S_k) / m`, so each τ costs O(n) whatever `m` is.
//! Two precautions keep the second difference from cancelling: the series is centred on its
//! mean before summing (the Allan variance ignores a constant, but a large offset would make
//! `S` grow linearly and swamp the differences: allantools does the same), and `S` is
//! accumulated with Neumaier's compensated summation so its rounding error does not grow
//! with `n`.
//!
//! # The `avar` R package convention
//! `avar::avar(x, freq)` (SMAC-Group/avar, `src/allan_variance.cpp`, `avar_mo_cpp`) uses the
//! clusters m = 2, 4, …, 2^J with J = ⌊log₂ n⌋ − 1, sums only the first `n − 2m` differences
//! (its loop stops one short) but still divides by `2 (n − 2m + 1)`, and reports
//! `adev · (1 ± 2 e)` with `e = 1 / sqrt(2 (n/m − 1))` as its 95 % interval (`R/avar.r`).
//! [`AdevConfig::avar_r`] reproduces all three exactly, so its output can be compared with
//! published `avar` tables; [`AdevConfig::octave`] is the standard estimator with
//! chi-square intervals, the one to use for new work.
//!
//! # Confidence intervals
//! [`CiMethod::ChiSquare`]: `edf · AVAR / χ²_{1−α/2}(edf) ≤ σ² ≤ edf · AVAR / χ²_{α/2}(edf)`
//! (NIST SP 1065 eq. 45), with the simple EDF approximations of SP 1065 Table 5 (Howe,
//! Allan & Barnes 1981) for the chosen power-law noise type. `N` there is the number of
//! phase points, `n + 1`.

mod chi2;
pub mod theory;

use std::path::{Path, PathBuf};

pub use chi2::chi2_quantile;

/// Why an Allan deviation could not be computed or written.
#[derive(Debug, thiserror::Error)]
pub enum AllanError {
    #[error("series too short: {n} samples, need at least {min}")]
    TooShort { n: usize, min: usize },
    #[error("sample {index} is not finite ({value})")]
    NonFinite { index: usize, value: f64 },
    #[error("sample rate must be positive and finite, got {0}")]
    BadRate(f64),
    #[error("cluster size m = {m} is invalid for {n} samples (need 1 <= m <= n/2)")]
    BadCluster { m: usize, n: usize },
    #[error("confidence level must lie in (0, 1), got {0}")]
    BadConfidence(f64),
    #[error("noise parameter {name} = {value} is out of range")]
    BadParameter { name: &'static str, value: f64 },
    #[error("{path}: cannot write Allan deviation table: {source}")]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// Which cluster sizes to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub enum TauGrid {
    /// m = 1, 2, 4, … up to the largest power of two with 2m ≤ n (allantools `"octave"`).
    Octave,
    /// m = 2, 4, …, 2^J with J = ⌊log₂ n⌋ − 1, the grid of the R package `avar`.
    AvarR,
    /// Explicit cluster sizes; each must satisfy 1 ≤ m ≤ n/2. Evaluated in the given order.
    Clusters(Vec<usize>),
}

/// Power-law noise type that selects the EDF formula (SP 1065 Table 5). Names follow the
/// frequency-stability convention, where the measured quantity ("frequency") is the sensor
/// output itself: for a gyro, `WhiteFrequency` is angle random walk and
/// `RandomWalkFrequency` is rate random walk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseType {
    /// α = +2 (e.g. quantization noise of the integrated output).
    WhitePhase,
    /// α = +1.
    FlickerPhase,
    /// α = 0: white noise of the output (angle / velocity random walk).
    WhiteFrequency,
    /// α = −1: flicker of the output (bias instability).
    FlickerFrequency,
    /// α = −2: random walk of the output (rate random walk).
    RandomWalkFrequency,
}

/// How to compute `ci_lo`, `ci_hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CiMethod {
    /// Chi-square interval at `confidence` (e.g. 0.95) with the EDF of `noise`.
    ChiSquare { noise: NoiseType, confidence: f64 },
    /// The conservative chi-square interval: at each τ the smallest EDF among white-,
    /// flicker- and random-walk-frequency noise, for when the noise type is unknown or
    /// changes along the curve (real IMU data). Still not conservative for narrow-band
    /// noise: an exponential cosine that decorrelates over ~100 samples has far fewer
    /// degrees of freedom at small τ than any power law (see `tests/allan_reference.rs`).
    ChiSquareConservative { confidence: f64 },
    /// `adev · (1 ± 2/sqrt(2 (n/m − 1)))`, exactly as `avar::avar` reports it.
    AvarR,
}

/// Which normalisation of the sum of squares.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimator {
    /// All `n − 2m + 1` differences, divided by `2 (n − 2m + 1)` (SP 1065 eq. 11,
    /// allantools `oadev`).
    Standard,
    /// The first `n − 2m` differences divided by `2 (n − 2m + 1)`, as `avar_mo_cpp` does.
    /// Differs from `Standard` by O(m/n); kept only to reproduce `avar` output exactly (up
    /// to floating-point summation order).
    AvarR,
}

/// Settings of [`overlapping_adev`].
#[derive(Debug, Clone, PartialEq)]
pub struct AdevConfig {
    /// Sample rate in Hz (τ = m / rate).
    pub rate: f64,
    pub taus: TauGrid,
    pub ci: CiMethod,
    pub estimator: Estimator,
}

impl AdevConfig {
    /// Standard estimator on the octave grid, 95 % conservative chi-square intervals.
    pub fn octave(rate: f64) -> Self {
        Self {
            rate,
            taus: TauGrid::Octave,
            ci: CiMethod::ChiSquareConservative { confidence: 0.95 },
            estimator: Estimator::Standard,
        }
    }

    /// Everything as in `avar::avar(x, freq = rate)` with `type = "mo"`.
    pub fn avar_r(rate: f64) -> Self {
        Self {
            rate,
            taus: TauGrid::AvarR,
            ci: CiMethod::AvarR,
            estimator: Estimator::AvarR,
        }
    }
}

/// One point of an Allan deviation curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdevRow {
    /// Averaging time τ = m / rate [s].
    pub tau: f64,
    /// Cluster size in samples.
    pub m: usize,
    /// Allan deviation (square root of the Allan variance), in the unit of the series.
    pub adev: f64,
    /// Lower bound of the confidence interval of `adev`.
    pub ci_lo: f64,
    /// Upper bound of the confidence interval of `adev`.
    pub ci_hi: f64,
    /// Equivalent degrees of freedom behind the interval (for `CiMethod::AvarR`, the EDF
    /// whose Gaussian approximation gives the same relative half-width, `n/m − 1`).
    pub edf: f64,
}

impl AdevRow {
    /// The Allan variance, `adev²`.
    pub fn avar(&self) -> f64 {
        self.adev * self.adev
    }
}

/// The centred, compensated running sum of a series: the one O(n) preprocessing shared by
/// every τ. Build it once when evaluating many cluster sizes on the same data.
#[derive(Debug, Clone)]
pub struct RunningSum {
    s: Vec<f64>,
}

impl RunningSum {
    /// `S_0 = 0`, `S_{j+1} = Σ_{i≤j} (y_i − mean)`. Fails on non-finite samples and on fewer
    /// than 2 samples (no cluster difference exists).
    pub fn new(y: &[f64]) -> Result<Self, AllanError> {
        if y.len() < 2 {
            return Err(AllanError::TooShort { n: y.len(), min: 2 });
        }
        if let Some((index, &value)) = y.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(AllanError::NonFinite { index, value });
        }
        let mean = neumaier_sum(y.iter().copied()) / y.len() as f64;
        let mut s = Vec::with_capacity(y.len() + 1);
        s.push(0.0);
        let mut acc = Neumaier::default();
        for &v in y {
            acc.add(v - mean);
            s.push(acc.value());
        }
        Ok(Self { s })
    }

    /// Number of samples of the underlying series.
    pub fn len(&self) -> usize {
        self.s.len() - 1
    }

    /// Always false: construction needs at least two samples.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Overlapping Allan variance at cluster size `m` (units of the series squared).
    pub fn avar(&self, m: usize, estimator: Estimator) -> Result<f64, AllanError> {
        let n = self.len();
        if m == 0 || 2 * m > n {
            return Err(AllanError::BadCluster { m, n });
        }
        let count = n - 2 * m + 1;
        let used = match estimator {
            Estimator::Standard => count,
            Estimator::AvarR => count - 1,
        };
        let sum = sum_sq_second_diff(&self.s, m, used);
        Ok(sum / (2.0 * (m as f64) * (m as f64) * count as f64))
    }
}

/// Σ_{k<count} (S_{k+2m} − 2 S_{k+m} + S_k)², with four independent accumulators: they hide
/// the floating-point add latency (the workspace release profile is `opt-level = "s"`, which
/// does not auto-vectorise, so this is what keeps the scalar loop fast) and keep partial
/// sums smaller, which also helps accuracy.
fn sum_sq_second_diff(s: &[f64], m: usize, count: usize) -> f64 {
    let a = &s[..count];
    let b = &s[m..m + count];
    let c = &s[2 * m..2 * m + count];
    let (ac, bc, cc) = (a.chunks_exact(4), b.chunks_exact(4), c.chunks_exact(4));
    let (ar, br, cr) = (ac.remainder(), bc.remainder(), cc.remainder());
    let (mut s0, mut s1, mut s2, mut s3) = (0.0_f64, 0.0_f64, 0.0_f64, 0.0_f64);
    for ((x0, x1), x2) in ac.zip(bc).zip(cc) {
        let d0 = (x2[0] - x1[0]) - (x1[0] - x0[0]);
        let d1 = (x2[1] - x1[1]) - (x1[1] - x0[1]);
        let d2 = (x2[2] - x1[2]) - (x1[2] - x0[2]);
        let d3 = (x2[3] - x1[3]) - (x1[3] - x0[3]);
        s0 += d0 * d0;
        s1 += d1 * d1;
        s2 += d2 * d2;
        s3 += d3 * d3;
    }
    for ((x0, x1), x2) in ar.iter().zip(br).zip(cr) {
        let d = (x2 - x1) - (x1 - x0);
        s0 += d * d;
    }
    (s0 + s1) + (s2 + s3)
}

/// Neumaier's compensated sum: the rounding error of `sum + v` is recovered into `comp`, so the
/// total's error does not grow with the number of terms.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Neumaier {
    sum: f64,
    comp: f64,
}

impl Neumaier {
    pub(crate) fn add(&mut self, v: f64) {
        let t = self.sum + v;
        if self.sum.abs() >= v.abs() {
            self.comp += (self.sum - t) + v;
        } else {
            self.comp += (v - t) + self.sum;
        }
        self.sum = t;
    }

    pub(crate) fn value(&self) -> f64 {
        self.sum + self.comp
    }
}

fn neumaier_sum(it: impl Iterator<Item = f64>) -> f64 {
    let mut acc = Neumaier::default();
    it.for_each(|v| acc.add(v));
    acc.value()
}

/// Cluster sizes of a grid for `n` samples.
pub fn cluster_sizes(grid: &TauGrid, n: usize) -> Result<Vec<usize>, AllanError> {
    match grid {
        TauGrid::Octave => Ok(std::iter::successors(Some(1_usize), |&m| m.checked_mul(2))
            .take_while(|&m| 2 * m <= n)
            .collect()),
        TauGrid::AvarR => {
            // J = floor(log2 n) − 1, m = 2^1 … 2^J (avar_mo_cpp).
            let j = (usize::BITS - 1 - n.max(1).leading_zeros()).saturating_sub(1);
            Ok((1..=j).map(|i| 1_usize << i).collect())
        }
        TauGrid::Clusters(ms) => {
            if let Some(&m) = ms.iter().find(|&&m| m == 0 || 2 * m > n) {
                return Err(AllanError::BadCluster { m, n });
            }
            Ok(ms.clone())
        }
    }
}

/// Equivalent degrees of freedom of the overlapping Allan variance: NIST SP 1065 Table 5
/// (simple approximations), `n_phase` = number of phase points (samples + 1), `m` = cluster.
pub fn edf_simple(noise: NoiseType, n_phase: usize, m: usize) -> f64 {
    let n = n_phase as f64;
    let m = m as f64;
    match noise {
        NoiseType::WhitePhase => (n + 1.0) * (n - 2.0 * m) / (2.0 * (n - m)),
        NoiseType::FlickerPhase => {
            let a = (n - 1.0) / (2.0 * m);
            let b = (2.0 * m + 1.0) * (n - 1.0) / 4.0;
            (a.ln() * b.ln()).sqrt().exp()
        }
        NoiseType::WhiteFrequency => {
            (3.0 * (n - 1.0) / (2.0 * m) - 2.0 * (n - 2.0) / n) * (4.0 * m * m)
                / (4.0 * m * m + 5.0)
        }
        NoiseType::FlickerFrequency => {
            // SP 1065 Table 5 has (N − 2)² here; allantools 2024.6 `edf_simple` drops the
            // square, which gives EDF < 1 for every N.
            if m <= 1.0 {
                2.0 * (n - 2.0).powi(2) / (2.3 * n - 4.9)
            } else {
                5.0 * n * n / (4.0 * m * (n + 3.0 * m))
            }
        }
        NoiseType::RandomWalkFrequency => {
            (n - 2.0) / (m * (n - 3.0).powi(2))
                * ((n - 1.0).powi(2) - 3.0 * m * (n - 1.0) + 4.0 * m * m)
        }
    }
}

/// Chi-square interval for a deviation: `(sqrt(edf·avar/χ²_hi), sqrt(edf·avar/χ²_lo))`.
pub fn chi2_interval(adev: f64, edf: f64, confidence: f64) -> Result<(f64, f64), AllanError> {
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(AllanError::BadConfidence(confidence));
    }
    let alpha = 1.0 - confidence;
    // A degenerate EDF (tiny series) gives an unbounded interval rather than an error.
    let (Some(lo_q), Some(hi_q)) = (
        chi2_quantile(0.5 * alpha, edf),
        chi2_quantile(1.0 - 0.5 * alpha, edf),
    ) else {
        return Ok((0.0, f64::INFINITY));
    };
    let var = adev * adev;
    Ok(((edf * var / hi_q).sqrt(), (edf * var / lo_q).sqrt()))
}

/// Overlapping Allan deviation of `y` at the cluster sizes of `cfg.taus`, with intervals.
pub fn overlapping_adev(y: &[f64], cfg: &AdevConfig) -> Result<Vec<AdevRow>, AllanError> {
    if !(cfg.rate > 0.0 && cfg.rate.is_finite()) {
        return Err(AllanError::BadRate(cfg.rate));
    }
    let sums = RunningSum::new(y)?;
    adev_from_sums(&sums, cfg)
}

/// Same as [`overlapping_adev`] on a prepared [`RunningSum`].
pub fn adev_from_sums(sums: &RunningSum, cfg: &AdevConfig) -> Result<Vec<AdevRow>, AllanError> {
    if !(cfg.rate > 0.0 && cfg.rate.is_finite()) {
        return Err(AllanError::BadRate(cfg.rate));
    }
    let n = sums.len();
    let ms = cluster_sizes(&cfg.taus, n)?;
    let mut rows = Vec::with_capacity(ms.len());
    for m in ms {
        let avar = sums.avar(m, cfg.estimator)?;
        let adev = avar.sqrt();
        let (edf, ci_lo, ci_hi) = match cfg.ci {
            CiMethod::AvarR => {
                let ratio = n as f64 / m as f64 - 1.0;
                let e = 1.0 / (2.0 * ratio).sqrt();
                (ratio, adev - 2.0 * e * adev, adev + 2.0 * e * adev)
            }
            CiMethod::ChiSquare { noise, confidence } => {
                let edf = edf_simple(noise, n + 1, m);
                let (lo, hi) = chi2_interval(adev, edf, confidence)?;
                (edf, lo, hi)
            }
            CiMethod::ChiSquareConservative { confidence } => {
                let edf = [
                    NoiseType::WhiteFrequency,
                    NoiseType::FlickerFrequency,
                    NoiseType::RandomWalkFrequency,
                ]
                .into_iter()
                .map(|t| edf_simple(t, n + 1, m))
                .fold(f64::INFINITY, f64::min);
                let (lo, hi) = chi2_interval(adev, edf, confidence)?;
                (edf, lo, hi)
            }
        };
        rows.push(AdevRow {
            tau: m as f64 / cfg.rate,
            m,
            adev,
            ci_lo,
            ci_hi,
            edf,
        });
    }
    Ok(rows)
}

/// Overlapping Allan variance of `y` at one cluster size (standard estimator).
pub fn overlapping_avar(y: &[f64], m: usize) -> Result<f64, AllanError> {
    RunningSum::new(y)?.avar(m, Estimator::Standard)
}

/// Writes `tau,adev,ci_lo,ci_hi` rows to `path` atomically: the table goes to a temporary
/// file in the same directory, which is then renamed over `path`, so a reader never sees a
/// half-written table and a failed run leaves the previous one intact.
pub fn write_adev_csv(path: impl AsRef<Path>, rows: &[AdevRow]) -> Result<(), AllanError> {
    let path = path.as_ref();
    crate::output::write_atomic(path, |w| {
        writeln!(w, "tau,adev,ci_lo,ci_hi")?;
        for r in rows {
            // `{:e}` prints the shortest representation that round-trips exactly.
            writeln!(w, "{:e},{:e},{:e},{:e}", r.tau, r.adev, r.ci_lo, r.ci_hi)?;
        }
        Ok(())
    })
    .map_err(|e| AllanError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(format!("{e:#}")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Direct O(n·m) evaluation of the textbook formula, for cross-checking.
    fn naive_avar(y: &[f64], m: usize) -> f64 {
        let n = y.len();
        let mean_at = |k: usize| y[k..k + m].iter().sum::<f64>() / m as f64;
        let count = n - 2 * m + 1;
        let s: f64 = (0..count)
            .map(|k| (mean_at(k + m) - mean_at(k)).powi(2))
            .sum();
        s / (2.0 * count as f64)
    }

    fn lcg_series(n: usize, seed: u64) -> Vec<f64> {
        let mut state = seed;
        (0..n)
            .map(|i| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) + 1e-3 * i as f64
            })
            .collect()
    }

    #[test]
    fn fast_matches_naive_on_every_cluster() {
        let y = lcg_series(257, 7);
        let sums = RunningSum::new(&y).expect("valid");
        for m in 1..=128 {
            let fast = sums.avar(m, Estimator::Standard).expect("valid m");
            let slow = naive_avar(&y, m);
            assert!(
                ((fast - slow) / slow).abs() < 1e-11,
                "m={m}: {fast} vs {slow}"
            );
        }
    }

    #[test]
    fn large_offset_does_not_cost_precision() {
        let y = lcg_series(100_000, 3);
        let shifted: Vec<f64> = y.iter().map(|v| v + 1e6).collect();
        let cfg = AdevConfig::octave(100.0);
        let a = overlapping_adev(&y, &cfg).expect("valid");
        let b = overlapping_adev(&shifted, &cfg).expect("valid");
        for (ra, rb) in a.iter().zip(&b) {
            // 1e6 offset on O(1) data: the shift itself rounds each sample at ~1e-10.
            assert!(
                ((ra.adev - rb.adev) / ra.adev).abs() < 1e-8,
                "{ra:?} {rb:?}"
            );
        }
    }

    #[test]
    fn edf_formulas_reference_values() {
        // N = 1025 phase points (1024 samples), hand-evaluated SP 1065 Table 5 formulas.
        let n = 1025;
        let wf = (3.0 * 1024.0 / 8.0 - 2.0 * 1023.0 / 1025.0) * 64.0 / 69.0;
        assert!((edf_simple(NoiseType::WhiteFrequency, n, 4) - wf).abs() < 1e-12);
        let ff1 = 2.0 * 1023.0_f64.powi(2) / (2.3 * 1025.0 - 4.9);
        assert!((edf_simple(NoiseType::FlickerFrequency, n, 1) - ff1).abs() < 1e-9);
        let ff = 5.0 * 1025.0_f64.powi(2) / (16.0 * (1025.0 + 12.0));
        assert!((edf_simple(NoiseType::FlickerFrequency, n, 4) - ff).abs() < 1e-12);
        let rw = 1023.0 / (4.0 * 1022.0_f64.powi(2)) * (1024.0_f64.powi(2) - 12.0 * 1024.0 + 64.0);
        assert!((edf_simple(NoiseType::RandomWalkFrequency, n, 4) - rw).abs() < 1e-12);
        let wp = 1026.0 * (1025.0 - 8.0) / (2.0 * 1021.0);
        assert!((edf_simple(NoiseType::WhitePhase, n, 4) - wp).abs() < 1e-12);
    }

    #[test]
    fn grids() {
        assert_eq!(cluster_sizes(&TauGrid::Octave, 9).unwrap(), vec![1, 2, 4]);
        assert_eq!(cluster_sizes(&TauGrid::Octave, 8).unwrap(), vec![1, 2, 4]);
        assert_eq!(cluster_sizes(&TauGrid::AvarR, 1_000_000).unwrap().len(), 18);
        assert_eq!(
            cluster_sizes(&TauGrid::AvarR, 1_000_000).unwrap()[17],
            1 << 18
        );
        assert_eq!(
            cluster_sizes(&TauGrid::Octave, 1_000_000).unwrap().last(),
            Some(&(1 << 18))
        );
        assert!(cluster_sizes(&TauGrid::Clusters(vec![3, 6]), 11).is_err());
    }

    #[test]
    fn bad_inputs_are_errors() {
        let cfg = AdevConfig::octave(100.0);
        assert!(matches!(
            overlapping_adev(&[1.0], &cfg),
            Err(AllanError::TooShort { .. })
        ));
        assert!(matches!(
            overlapping_adev(&[1.0, f64::NAN, 2.0], &cfg),
            Err(AllanError::NonFinite { index: 1, .. })
        ));
        assert!(matches!(
            overlapping_adev(&[1.0, 2.0], &AdevConfig::octave(0.0)),
            Err(AllanError::BadRate(_))
        ));
        assert!(overlapping_avar(&[1.0, 2.0, 3.0], 2).is_err());
        let mut c = cfg.clone();
        c.ci = CiMethod::ChiSquare {
            noise: NoiseType::WhiteFrequency,
            confidence: 1.5,
        };
        assert!(matches!(
            overlapping_adev(&[1.0, 2.0, 3.0, 4.0], &c),
            Err(AllanError::BadConfidence(_))
        ));
    }

    #[test]
    fn csv_round_trip() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = dir.path().join("adev.csv");
        let rows = overlapping_adev(&lcg_series(1000, 1), &AdevConfig::octave(10.0)).unwrap();
        write_adev_csv(&p, &rows).expect("write");
        let text = std::fs::read_to_string(&p).expect("read back");
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("tau,adev,ci_lo,ci_hi"));
        for (line, r) in lines.zip(&rows) {
            let v: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
            assert_eq!(v, vec![r.tau, r.adev, r.ci_lo, r.ci_hi]);
        }
        // Parent folders are created, but not under a regular file.
        let bad = p.join("adev.csv");
        assert!(matches!(
            write_adev_csv(bad, &rows),
            Err(AllanError::Write { .. })
        ));
    }
}
