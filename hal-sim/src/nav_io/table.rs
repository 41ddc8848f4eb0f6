//! The CSV plumbing shared by the pinned formats: a header row, columns found by name in any
//! order (others ignored), rows deserialised with serde, and errors that name the file, the line
//! and the column.

use anyhow::{anyhow, bail, Context, Result};
use serde::de::DeserializeOwned;
use std::io::Read;
use std::path::Path;

/// Opens `path` and reads every row as `T` (see [`read_rows_from`]).
fn read_rows<T: DeserializeOwned>(
    path: &Path,
    what: &str,
    required: &[&str],
) -> Result<Vec<(u64, T)>> {
    let file = path.display().to_string();
    let f = std::fs::File::open(path).with_context(|| format!("opening {what} {file}"))?;
    read_rows_from(std::io::BufReader::new(f), &file, required)
}

/// Reads every row of a headed CSV as `T` with its line number. `required` columns must be in
/// the header (checked first, so a missing one is named before any row is read).
fn read_rows_from<T: DeserializeOwned, R: Read>(
    reader: R,
    file: &str,
    required: &[&str],
) -> Result<Vec<(u64, T)>> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(reader);
    let headers = rdr
        .headers()
        .map_err(|e| anyhow!("{file} line 1: reading the header: {e}"))?
        .clone();
    let names: Vec<String> = headers.iter().map(str::to_string).collect();
    for r in required {
        if !names.iter().any(|h| h == r) {
            bail!(
                "{file} line 1: no column '{r}' (found: {})",
                names.join(",")
            );
        }
    }
    let mut rows = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                bail!("{file} line {line}: malformed CSV record: {e}");
            }
        }
        let line = record.position().map_or(0, |p| p.line());
        // Empty cells and "NaN" are both "no value" for optional columns.
        let cleaned: csv::StringRecord = record
            .iter()
            .map(|c| if c.eq_ignore_ascii_case("nan") { "" } else { c })
            .collect();
        let row: T = cleaned.deserialize(Some(&headers)).map_err(|e| {
            let (field, what) = match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => (err.field(), err.kind().to_string()),
                _ => (None, e.to_string()),
            };
            match field.and_then(|i| names.get(i as usize).map(|n| (i as usize, n))) {
                Some((i, col)) => {
                    let cell = record.get(i).unwrap_or("");
                    anyhow!("{file} line {line}, column {col}: expected a number, found {cell:?} ({what})")
                }
                None => anyhow!("{file} line {line}: {what}"),
            }
        })?;
        rows.push((line, row));
    }
    Ok(rows)
}

/// A value with a time, which must increase from row to row.
pub(crate) trait Timed {
    /// Time [s].
    fn time(&self) -> f64;
}

/// A format's conversion of one raw row (file name, line number, row) into its value.
pub(crate) type RowFn<T, O> = fn(&str, u64, T) -> Result<O>;

/// Converts every row and checks that the times increase strictly.
fn convert_rows<T, O: Timed>(file: &str, rows: Vec<(u64, T)>, row: RowFn<T, O>) -> Result<Vec<O>> {
    let mut out: Vec<O> = Vec::with_capacity(rows.len());
    for (line, r) in rows {
        let v = row(file, line, r)?;
        check_increasing(file, out.last().map(Timed::time), line, v.time())?;
        out.push(v);
    }
    Ok(out)
}

/// Reads `path` (a headed CSV with the `required` columns) into values, one per row.
pub(crate) fn read_file<T: DeserializeOwned, O: Timed>(
    path: &Path,
    what: &str,
    required: &[&str],
    row: RowFn<T, O>,
) -> Result<Vec<O>> {
    let file = path.display().to_string();
    convert_rows(&file, read_rows(path, what, required)?, row)
}

/// [`read_file`] from any reader; `file` names it in errors.
pub(crate) fn read_from<T: DeserializeOwned, O: Timed, R: Read>(
    reader: R,
    file: &str,
    required: &[&str],
    row: RowFn<T, O>,
) -> Result<Vec<O>> {
    convert_rows(file, read_rows_from(reader, file, required)?, row)
}

/// An optional triple as three optional cells (empty cells when absent).
pub(crate) fn split3(v: Option<[f64; 3]>) -> [Option<f64>; 3] {
    v.map_or([None; 3], |a| a.map(Some))
}

/// A required finite value: `Err` naming the file, line and column otherwise.
pub(crate) fn finite(file: &str, line: u64, col: &str, v: Option<f64>) -> Result<f64> {
    match v {
        Some(x) if x.is_finite() => Ok(x),
        Some(x) => bail!("{file} line {line}, column {col}: expected a finite number, found {x}"),
        None => {
            bail!("{file} line {line}, column {col}: expected a number, found an empty cell or NaN")
        }
    }
}

/// An optional group of three columns: all present (finite) or all empty.
pub(crate) fn triple(
    file: &str,
    line: u64,
    cols: [&str; 3],
    v: [Option<f64>; 3],
) -> Result<Option<[f64; 3]>> {
    match v {
        [None, None, None] => Ok(None),
        _ => {
            let mut out = [0.0; 3];
            for k in 0..3 {
                out[k] = finite(file, line, cols[k], v[k])
                    .map_err(|e| anyhow!("{e} (columns {} go together)", cols.join(",")))?;
            }
            Ok(Some(out))
        }
    }
}

/// Times must be finite and strictly increasing (a filter cannot go back in time).
fn check_increasing(file: &str, prev: Option<f64>, line: u64, t: f64) -> Result<()> {
    if let Some(p) = prev {
        if t <= p {
            bail!("{file} line {line}, column t: time {t} does not increase (previous {p})");
        }
    }
    Ok(())
}
