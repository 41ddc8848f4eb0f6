//! Scenarios: truth models in model-TOML form under `hal-sim/scenarios/`, found by file path or
//! by name (`paper` is `scenarios/paper.toml`, embedded in the binary so it works from anywhere).

use crate::model_toml::{parse_file, ModelToml};
use anyhow::{bail, Context, Result};
use std::path::Path;

/// Scenarios shipped with hal-sim: (name, TOML text).
pub const BUILTIN: &[(&str, &str)] = &[("paper", include_str!("../scenarios/paper.toml"))];

/// Loads a scenario from a file path, or by built-in name.
pub fn load(spec: &str) -> Result<ModelToml> {
    let path = Path::new(spec);
    if path.exists() {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading {spec}"))?;
        return parse_file(&text, spec);
    }
    if let Some((name, text)) = BUILTIN.iter().find(|(n, _)| *n == spec) {
        return parse_file(text, &format!("built-in scenario {name}"));
    }
    let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
    bail!(
        "scenario {spec:?}: no such file, and not a built-in name ({})",
        names.join(", ")
    )
}
