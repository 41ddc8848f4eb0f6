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

/// The global stage's settings overridden from the environment, each key over the value `w`
/// already holds (so a bench sets its own defaults first): `BLOCK`, `WIN`, `FIRST`, `EVERY`,
/// `BUDGET`, `PEN` (structure penalty), `CHANGE`, `HOLD` (0/1), `FLAT_EVERY`, `AFTER`,
/// `MARGIN`, `KEEP` (0/1), `KEEPID` (0/1). The one list for `anystart_bench`,
/// `structure_bench` and `change_bench`.
pub fn window_env(w: &mut imu_ident::adapt::window::WindowConfig<f64>) {
    w.block = env_or("BLOCK", w.block);
    w.window = env_or("WIN", w.window);
    w.first = env_or("FIRST", w.first);
    w.every = env_or("EVERY", w.every);
    w.filling_every = env_or("FILLING", w.filling_every);
    w.budget = env_or("BUDGET", w.budget);
    w.structure = env_or("PEN", w.structure);
    w.change = env_or("CHANGE", w.change);
    w.hold_flat = env_or("HOLD", u8::from(w.hold_flat)) != 0;
    w.flat_every = env_or("FLAT_EVERY", w.flat_every);
    w.after_change = env_or("AFTER", w.after_change);
    w.margin = env_or("MARGIN", w.margin);
    w.keep_start = env_or("KEEP", u8::from(w.keep_start)) != 0;
    w.keep_identified = env_or("KEEPID", u8::from(w.keep_identified)) != 0;
    w.conservative = env_or("CONS", w.conservative);
    w.prior = env_or("PRIOR", w.prior);
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
