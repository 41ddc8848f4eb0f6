//! What the benches (`anystart_bench`, `structure_bench`, `change_bench`, `nav_adapt_bench`,
//! `nav_change_bench`, ...) share: their `key=value` arguments, their environment overrides,
//! their percentiles, the maximum-likelihood reference (`ml`) and the navigation benches' score
//! (`nav`).
#![allow(dead_code)]

pub mod ml;
pub mod nav;

/// The value of `key=value` among the command-line arguments.
pub fn arg(key: &str) -> Option<String> {
    std::env::args()
        .skip(1)
        .find_map(|a| a.strip_prefix(&format!("{key}=")).map(str::to_string))
}

/// `key=value` parsed, or `default`.
pub fn arg_or<T: std::str::FromStr>(key: &str, default: T) -> T {
    arg(key).and_then(|s| s.parse().ok()).unwrap_or(default)
}

/// Whether a bare flag is among the arguments.
pub fn flag(name: &str) -> bool {
    std::env::args().skip(1).any(|a| a == name)
}

/// The environment variable `key` parsed, or `default`.
pub fn env_or<T: std::str::FromStr>(key: &str, default: T) -> T {
    std::env::var(key)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// The `q`-quantile of `v` (nearest rank; NaN when empty). Sorts `v`.
pub fn pct(v: &mut [f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let i = ((v.len() - 1) as f64 * q).round() as usize;
    v[i]
}
