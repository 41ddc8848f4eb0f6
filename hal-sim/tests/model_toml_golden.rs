//! The model TOML and the IMU model TOML against golden outputs (issue 14: the per-kind parsing
//! and writing go through the core's kind table; the format must not change by a byte).
//!
//! Every scenario file, every TOML example of the README and the docs, the built-in navigation
//! models and a set of inline texts (every kind, optional fields, integers, errors) are loaded,
//! written back, and compared with `tests/golden/model_toml/*.txt`: the model as loaded (its
//! `Debug`, exact to the bit), `to_string`'s text, the JSON form (reports) and, for bad input,
//! the error message (file, line and field). The goldens were written by the code before the
//! kind table (`BLESS=1 cargo test -p hal-sim --test host model_toml_golden::` rewrites
//! them); the one change since is `err-second-component`, whose error now points at the
//! offending second `[[accel]]` (line 7) where the serde enum pointed at the first (line 4).

use std::path::{Path, PathBuf};

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

/// One-channel model TOML texts beyond the scenario files and the docs.
const INLINE: &[(&str, &str)] = &[
    (
        "every-kind",
        r#"
dt = 1.0
[observation]
sigma_v = 0.03
[[observation.colored]]
sigma = 0.01
tau = 20.0
[[accel]]
kind = "gauss-markov"
sigma = 1e-3
tau = 100.0
[[accel]]
kind = "white"
density = 1e-4
[[gyro]]
kind = "exp-cosine"
sigma = 5e-7
tau = 900.0
beta = 0.0105
[[gyro]]
kind = "random-walk"
q = 1e-18
[[gyro]]
kind = "random-constant"
sigma = 1e-7
"#,
    ),
    (
        "random-walk-sigma0-integers",
        r#"
dt = 1
[observation]
sigma_v = 0.03
[[observation.colored]]
kind = "gauss-markov"
sigma = 0.01
tau = 30
[initial]
sigma_dv = 0.05
[[accel]]
kind = "random-walk"
q = 1e-10
sigma0 = 0.002
[[accel]]
tau = 50
sigma = 2e-3
kind = "gauss-markov"
[[gyro]]
kind = "random-walk"
sigma0 = 0.0
q = 4e-20
"#,
    ),
    (
        "no-components",
        "dt = 0.5\n[observation]\nsigma_v = 0.1\n[initial]\nsigma_delta = 2e-4\n",
    ),
    // Errors: each must name the file, and the line or the component and field.
    (
        "err-unknown-kind",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nkind = \"pink\"\nsigma = 1.0\n",
    ),
    (
        "err-negative-tau",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"gauss-markov\"\nsigma = 1e-3\ntau = -5.0\n",
    ),
    (
        "err-typo",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"gauss-markov\"\nsigma = 1e-3\ntua = 5.0\n",
    ),
    (
        "err-field-of-other-kind",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nkind = \"white\"\ndensity = 1e-4\nsigma0 = 1.0\n",
    ),
    (
        "err-missing-kind",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nsigma = 1e-3\ntau = 5.0\n",
    ),
    (
        "err-missing-tau",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n\n[[gyro]]\nkind = \"gauss-markov\"\nsigma = 1e-3\n",
    ),
    (
        "err-missing-beta",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nkind = \"exp-cosine\"\nsigma = 1e-3\ntau = 5.0\n",
    ),
    (
        "err-missing-q",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nkind = \"random-walk\"\nsigma0 = 1e-3\n",
    ),
    (
        "err-string-value",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"gauss-markov\"\nsigma = \"big\"\ntau = 5.0\n",
    ),
    (
        "err-kind-not-string",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = 3\nsigma = 1.0\ntau = 5.0\n",
    ),
    (
        "err-duplicate-field",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"white\"\ndensity = 1e-4\ndensity = 2e-4\n",
    ),
    (
        "err-second-component",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[accel]]\nkind = \"white\"\ndensity = 1e-4\n[[accel]]\nkind = \"random-constant\"\nsigma = 1e-3\nbeta = 2.0\n",
    ),
    (
        "err-colored-kind",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[observation.colored]]\nkind = \"white\"\nsigma = 0.01\ntau = 3.0\n",
    ),
    (
        "err-too-many-states",
        "dt = 1.0\n[observation]\nsigma_v = 0.03\n[[gyro]]\nkind = \"exp-cosine\"\nsigma = 1e-3\ntau = 5.0\nbeta = 0.1\n[[gyro]]\nkind = \"exp-cosine\"\nsigma = 1e-3\ntau = 5.0\nbeta = 0.1\n[[gyro]]\nkind = \"exp-cosine\"\nsigma = 1e-3\ntau = 5.0\nbeta = 0.1\n[[gyro]]\nkind = \"exp-cosine\"\nsigma = 1e-3\ntau = 5.0\nbeta = 0.1\n",
    ),
];

/// IMU model TOML texts beyond the docs.
const INLINE_IMU: &[(&str, &str)] = &[
    (
        "imu-every-kind",
        r#"
dt = 0.01
[[gyro.all]]
kind = "white"
density = 1e-4
[[gyro.x]]
kind = "random-walk"
q = 1e-12
sigma0 = 1e-3
[[gyro.y]]
kind = "exp-cosine"
sigma = 1e-4
tau = 30.0
beta = 0.2
[[gyro.z]]
kind = "random-constant"
sigma = 1e-5
[[accel.all]]
kind = "gauss-markov"
sigma = 1e-3
tau = 300
[[accel.z]]
kind = "random-walk"
q = 1e-9
"#,
    ),
    (
        "imu-err-typo",
        "dt = 0.01\n[[gyro.x]]\nkind = \"gauss-markov\"\nsigma = 1e-3\ntua = 5.0\n",
    ),
    (
        "imu-err-kind",
        "dt = 0.01\n[[accel.all]]\nkind = \"flicker\"\nsigma = 1e-3\n",
    ),
    (
        "imu-err-value",
        "dt = 0.01\n[[accel.y]]\nkind = \"white\"\ndensity = -1.0\n",
    ),
    (
        "imu-err-missing",
        "dt = 0.01\n[[accel.y]]\nkind = \"exp-cosine\"\nsigma = 1e-3\nbeta = 1.0\n",
    ),
];

fn one_channel(origin: &str, text: &str) -> String {
    let mut out = String::new();
    match hal_sim::model_toml::parse(text, origin) {
        Ok(m) => {
            out += &format!("model: {m:?}\n");
            let written = hal_sim::model_toml::to_string(&m).expect("to_string");
            out += &format!("to_string:\n{written}\n");
            let file = hal_sim::model_toml::parse_file(text, origin).expect("parse_file");
            out += &format!(
                "json of the file:\n{}\n",
                serde_json::to_string(&file).expect("json")
            );
            let again = hal_sim::model_toml::parse(&written, "again").expect("re-read");
            assert_eq!(again, m, "{origin}: to_string does not read back");
        }
        Err(e) => out += &format!("error: {e:#}\n"),
    }
    out
}

fn imu(origin: &str, text: &str) -> String {
    let mut out = String::new();
    match hal_sim::imu_model::parse(text, origin) {
        Ok(m) => {
            out += &format!(
                "nav: {:?}\n",
                m.to_nav(origin).map_err(|e| format!("{e:#}"))
            );
            out += &format!("to_text:\n{}\n", m.to_text("# header\n").expect("text"));
            out += &format!("json: {}\n", serde_json::to_string(&m).expect("json"));
            for s in ["gyro", "accel"] {
                for a in hal_sim::imu_model::AXES {
                    let c = m.channel(s, a).expect("channel");
                    out += &format!(
                        "{s}.{a}: {}",
                        toml::to_string_pretty(&c).expect("channel toml")
                    );
                }
            }
        }
        Err(e) => out += &format!("error: {e:#}\n"),
    }
    out
}

/// The fenced `toml` blocks of a Markdown file.
fn toml_blocks(md: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(md).expect("markdown");
    let mut blocks = Vec::new();
    let mut cur: Option<String> = None;
    for line in text.lines() {
        match (&mut cur, line.trim_start()) {
            (None, l) if l.starts_with("```toml") => cur = Some(String::new()),
            (Some(_), l) if l.starts_with("```") => blocks.extend(cur.take()),
            (Some(b), _) => {
                b.push_str(line);
                b.push('\n');
            }
            _ => {}
        }
    }
    blocks
}

/// Every case: (golden name, output).
fn cases() -> Vec<(String, String)> {
    let mut cases = Vec::new();
    let scen = Path::new(ROOT).join("hal-sim/scenarios");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&scen)
        .expect("scenarios")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(!files.is_empty());
    for f in files {
        let name = f.file_stem().expect("stem").to_string_lossy().to_string();
        let text = std::fs::read_to_string(&f).expect("scenario");
        let origin = format!("scenarios/{name}.toml");
        let out = one_channel(&origin, &text);
        let loaded = hal_sim::model_toml::load(&f).expect("load");
        assert_eq!(
            Some(format!("model: {loaded:?}").as_str()),
            out.lines().next()
        );
        cases.push((format!("scenario-{name}"), out));
    }
    let mut docs: Vec<PathBuf> = vec![Path::new(ROOT).join("README.md")];
    let mut more: Vec<PathBuf> = std::fs::read_dir(Path::new(ROOT).join("docs"))
        .expect("docs")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    more.sort();
    docs.extend(more);
    for md in docs {
        let stem = md.file_stem().expect("stem").to_string_lossy().to_string();
        for (i, block) in toml_blocks(&md).iter().enumerate() {
            let origin = format!("{stem}.md block {i}");
            let per_axis = block.contains("[[gyro.") || block.contains("[[accel.");
            let out = if per_axis {
                imu(&origin, block)
            } else {
                one_channel(&origin, block)
            };
            cases.push((format!("doc-{stem}-{i}"), out));
        }
    }
    for (name, text) in INLINE {
        cases.push((name.to_string(), one_channel(&format!("{name}.toml"), text)));
    }
    for (name, text) in INLINE_IMU {
        cases.push((name.to_string(), imu(&format!("{name}.toml"), text)));
    }
    for name in hal_sim::nav::model::BUILT_IN {
        let m = hal_sim::nav::model::load(name).expect("built-in");
        let t = hal_sim::nav::model::to_toml(&m).expect("to_toml");
        let text = t.to_text("# built-in\n").expect("text");
        let back = hal_sim::imu_model::parse(&text, name).expect("re-read");
        let out = format!(
            "to_text:\n{text}\njson: {}\nre-read equal: {}\n",
            serde_json::to_string(&t).expect("json"),
            back == t
        );
        cases.push((format!("built-in-{name}"), out));
    }
    cases
}

#[test]
fn model_toml_and_imu_model_match_the_goldens() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/model_toml");
    let bless = std::env::var_os("BLESS").is_some();
    if bless {
        std::fs::create_dir_all(&dir).expect("golden dir");
    }
    let mut failed = Vec::new();
    for (name, out) in cases() {
        let path = dir.join(format!("{name}.txt"));
        if bless {
            std::fs::write(&path, &out).expect("write golden");
            continue;
        }
        let want = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (BLESS=1 writes it)", path.display()));
        if want != out {
            failed.push(format!("{name}:\n--- golden\n{want}--- now\n{out}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
