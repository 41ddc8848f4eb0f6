//! The real recordings in `../shared/data/real/` (beside the repository; never copied into it:
//! one set is CC BY-NC-SA). Tests that need them fail under `CI=true` when they are missing, and
//! elsewhere skip with a printed reason.

use std::path::{Path, PathBuf};

/// `<repository>/../shared/data/real`.
pub fn real_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/real")
}

/// True when every file exists. Otherwise panics under `CI=true` (the data must be there),
/// else prints why the caller skips and returns false.
pub fn present(files: &[&Path]) -> bool {
    let missing: Vec<String> = files
        .iter()
        .filter(|p| !p.is_file())
        .map(|p| p.display().to_string())
        .collect();
    if missing.is_empty() {
        return true;
    }
    let msg = format!("real-data files missing: {}", missing.join(", "));
    if std::env::var("CI").is_ok_and(|v| v == "true") {
        panic!("{msg} (CI=true: the shared data must be present)");
    }
    eprintln!("SKIPPED: {msg}");
    false
}

/// Median of a sample (NaN for an empty one); NaNs sort last.
pub fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}
