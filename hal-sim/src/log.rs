//! The log CSV format (README "Log CSV"): a header row, columns found by name.
//!
//! Required: `t` [s], `z` [m/s] (INS velocity minus reference velocity; an empty or `NaN` cell
//! is a missing observation). Optional truth: `true_dv` [m/s], `true_delta` [rad], `true_da`
//! [m/s^2], `true_dw` [rad/s]. Other columns are ignored.

use anyhow::{anyhow, bail, Context, Result};
use std::path::Path;

/// Ground truth of one row (simulated logs only).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Truth {
    /// Velocity error [m/s].
    pub dv: f64,
    /// Tilt error [rad].
    pub delta: f64,
    /// Total accelerometer error [m/s^2] (state components; white noise has no sample value).
    pub da: f64,
    /// Total gyro drift [rad/s] (state components).
    pub dw: f64,
}

/// One log row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogRow {
    /// Time [s].
    pub t: f64,
    /// Observation [m/s]; NaN when missing.
    pub z: f64,
    /// Truth, when the log has all four truth columns.
    pub truth: Option<Truth>,
}

fn parse_cell(file: &str, line: u64, col: &str, cell: &str, allow_empty: bool) -> Result<f64> {
    let s = cell.trim();
    if s.is_empty() || s.eq_ignore_ascii_case("nan") {
        if allow_empty {
            return Ok(f64::NAN);
        }
        bail!("{file} line {line}, column {col}: expected a number, found an empty cell");
    }
    s.parse::<f64>()
        .map_err(|_| anyhow!("{file} line {line}, column {col}: expected a number, found {s:?}"))
}

/// Reads a log CSV. Errors name the file, the line and the column.
pub fn read(path: &Path) -> Result<Vec<LogRow>> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).with_context(|| format!("opening log {file}"))?;
    read_from(std::io::BufReader::new(f), &file)
}

/// Reads a log CSV from any reader; `file` names it in errors.
pub fn read_from<R: std::io::Read>(reader: R, file: &str) -> Result<Vec<LogRow>> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(reader);
    let headers = rdr
        .headers()
        .with_context(|| format!("{file} line 1: reading the header"))?
        .clone();
    let find = |name: &str| headers.iter().position(|h| h == name);
    let cols: Vec<String> = headers.iter().map(str::to_string).collect();
    let t_col = find("t")
        .ok_or_else(|| anyhow!("{file} line 1: no column 't' (found: {})", cols.join(",")))?;
    let z_col = find("z")
        .ok_or_else(|| anyhow!("{file} line 1: no column 'z' (found: {})", cols.join(",")))?;
    let truth_cols = ["true_dv", "true_delta", "true_da", "true_dw"].map(find);
    let has_truth = truth_cols.iter().all(Option::is_some);
    let mut rows = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        let more = rdr.read_record(&mut record).map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            anyhow!("{file} line {line}: malformed CSV record: {e}")
        })?;
        if !more {
            break;
        }
        let line = record.position().map_or(0, |p| p.line());
        let cell = |i: usize, name: &str| -> Result<&str> {
            record
                .get(i)
                .ok_or_else(|| anyhow!("{file} line {line}, column {name}: missing cell"))
        };
        let t = parse_cell(file, line, "t", cell(t_col, "t")?, false)?;
        if !t.is_finite() {
            bail!("{file} line {line}, column t: expected a finite time, found {t}");
        }
        let z = parse_cell(file, line, "z", cell(z_col, "z")?, true)?;
        let truth = if has_truth {
            let mut v = [0.0; 4];
            for (k, (c, name)) in truth_cols
                .iter()
                .zip(["true_dv", "true_delta", "true_da", "true_dw"])
                .enumerate()
            {
                let i = c.unwrap_or(0);
                v[k] = parse_cell(file, line, name, cell(i, name)?, false)?;
            }
            Some(Truth {
                dv: v[0],
                delta: v[1],
                da: v[2],
                dw: v[3],
            })
        } else {
            None
        };
        rows.push(LogRow { t, z, truth });
    }
    Ok(rows)
}

/// Writes a log CSV atomically (temporary file in the same folder, then rename).
pub fn write(path: &Path, rows: &[LogRow]) -> Result<()> {
    crate::output::write_atomic(path, |w| {
        let with_truth = rows.iter().all(|r| r.truth.is_some()) && !rows.is_empty();
        if with_truth {
            writeln!(w, "t,z,true_dv,true_delta,true_da,true_dw")?;
        } else {
            writeln!(w, "t,z")?;
        }
        for r in rows {
            match r.truth {
                Some(tr) if with_truth => writeln!(
                    w,
                    "{},{:e},{:e},{:e},{:e},{:e}",
                    r.t, r.z, tr.dv, tr.delta, tr.da, tr.dw
                )?,
                _ => writeln!(w, "{},{:e}", r.t, r.z)?,
            }
        }
        Ok(())
    })
}
