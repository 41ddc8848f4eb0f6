//! Streaming reader for named numeric columns of a CSV or gzip-compressed CSV file.
//!
//! Recorded IMU logs are large (the ADIS16405 static runs are 1e6 rows, 38.5 MB unpacked), so
//! the file is never loaded into memory as text: bytes flow File -> BufReader -> (gzip decoder)
//! -> csv::Reader, and each row is parsed into one reused [`csv::ByteRecord`]. Only the
//! requested columns are kept, as `f64`.
//!
//! Compression is detected from the gzip magic bytes (`1f 8b`), not from the file name, so a
//! misnamed file still reads. Multi-member gzip streams (concatenated `.gz` files) are read
//! to the end.
//!
//! Errors name the file, the 1-based line number, the column and what was expected, e.g.
//! `adis.csv.gz line 1234, column gyro_z_dps: expected a finite number, found 'abc'`.

use std::cell::Cell;
use std::fs::File;
use std::io::{self, BufRead, BufReader, IsTerminal, Read};
use std::path::Path;
use std::rc::Rc;

use indicatif::{ProgressBar, ProgressStyle};

/// Why a column could not be read. Every variant carries the file name so that a message
/// printed by a command-line tool is actionable on its own.
#[derive(Debug, thiserror::Error)]
pub enum SeriesError {
    /// The file could not be opened or its size queried.
    #[error("{file}: cannot open: {source}")]
    Open {
        file: String,
        #[source]
        source: io::Error,
    },
    /// Reading failed part-way (I/O error or corrupt gzip stream).
    #[error("{file} line {line}: read error: {source}")]
    Read {
        file: String,
        line: u64,
        #[source]
        source: io::Error,
    },
    /// The csv crate rejected the input for a reason other than I/O.
    #[error("{file} line {line}: malformed CSV: {message}")]
    Csv {
        file: String,
        line: u64,
        message: String,
    },
    /// The file has no header row at all.
    #[error("{file}: empty file, expected a header row naming the columns")]
    NoHeader { file: String },
    /// A requested column is not in the header.
    #[error("{file} line 1: no column named '{column}'; available columns: {available}")]
    MissingColumn {
        file: String,
        column: String,
        available: String,
    },
    /// A data row is too short to contain the requested column.
    #[error(
        "{file} line {line}, column {column}: expected at least {expected} fields, found {found}"
    )]
    ShortRow {
        file: String,
        line: u64,
        column: String,
        expected: usize,
        found: usize,
    },
    /// A field is not a finite decimal number.
    #[error("{file} line {line}, column {column}: expected a finite number, found '{found}'")]
    NotANumber {
        file: String,
        line: u64,
        column: String,
        found: String,
    },
    /// The scale factor is NaN or infinite (it would silently poison every sample).
    #[error("scale factor must be finite, got {0}")]
    InvalidScale(f64),
    /// No column names were requested.
    #[error("{file}: no column requested")]
    NoColumns { file: String },
}

/// Options of [`read_column`] / [`read_columns`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadOptions {
    /// Every value is multiplied by this factor (e.g. counts -> physical units).
    pub scale: f64,
    /// Never draw the progress bar (it is also hidden when stderr is not a terminal).
    pub quiet: bool,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            scale: 1.0,
            quiet: false,
        }
    }
}

impl ReadOptions {
    /// Options with the given scale factor, progress bar as by default.
    pub fn scaled(scale: f64) -> Self {
        Self {
            scale,
            ..Self::default()
        }
    }

    /// Same options with the progress bar suppressed.
    pub fn quiet(mut self) -> Self {
        self.quiet = true;
        self
    }
}

/// Reads one named column as `f64`, each value multiplied by `opts.scale`.
///
/// Works on plain CSV and gzip CSV alike. An empty data section (header only) gives an
/// empty vector; deciding whether that is enough data is the caller's business.
pub fn read_column(
    path: impl AsRef<Path>,
    column: &str,
    opts: &ReadOptions,
) -> Result<Vec<f64>, SeriesError> {
    let mut cols = read_columns(path, &[column], opts)?;
    Ok(cols.pop().unwrap_or_default())
}

/// Reads several named columns in a single pass over the file (decompressing a 1e6-row gzip
/// file once instead of once per column). The result is in the order of `columns`.
pub fn read_columns(
    path: impl AsRef<Path>,
    columns: &[&str],
    opts: &ReadOptions,
) -> Result<Vec<Vec<f64>>, SeriesError> {
    read_columns_counted(path, columns, opts).map(|(c, _)| c)
}

/// What one call of [`read_columns_counted`] read: the bytes taken from the file on disk
/// (compressed bytes for a gzip file) and the data rows parsed. A single pass over a file
/// reads each of its bytes once, so `bytes` equals the file size; a second pass would double it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct ReadStats {
    pub bytes: u64,
    pub rows: u64,
}

/// [`read_columns`] that also reports what it read ([`ReadStats`]), so that a caller can show
/// (and a test check) that a multi-column analysis made one pass over the file.
pub fn read_columns_counted(
    path: impl AsRef<Path>,
    columns: &[&str],
    opts: &ReadOptions,
) -> Result<(Vec<Vec<f64>>, ReadStats), SeriesError> {
    let path = path.as_ref();
    let file_name = path.display().to_string();
    if !opts.scale.is_finite() {
        return Err(SeriesError::InvalidScale(opts.scale));
    }
    if columns.is_empty() {
        return Err(SeriesError::NoColumns { file: file_name });
    }

    let (source, bar, bytes) = open_csv(path, &file_name, opts.quiet)?;
    let result = parse_csv(source, &file_name, columns, opts.scale);
    bar.finish_and_clear();
    let cols = result?;
    let stats = ReadStats {
        bytes: bytes.get(),
        rows: cols.first().map_or(0, |c| c.len() as u64),
    };
    Ok((cols, stats))
}

/// The decompressed byte stream, its progress bar and the count of bytes read from disk.
type OpenCsv = (Box<dyn Read>, ProgressBar, Rc<Cell<u64>>);

/// Opens a plain or gzip CSV (told apart by the magic bytes) behind a byte counter and the
/// progress bar.
fn open_csv(path: &Path, file_name: &str, quiet: bool) -> Result<OpenCsv, SeriesError> {
    let open_err = |source| SeriesError::Open {
        file: file_name.to_string(),
        source,
    };
    let file = File::open(path).map_err(open_err)?;
    let total_bytes = file.metadata().map_err(open_err)?.len();

    let bar = progress_bar(total_bytes, quiet, path);
    // The counter sits under the BufReader, so it sees compressed bytes: the bar's length is
    // the file size on disk whether or not the file is compressed.
    let bytes = Rc::new(Cell::new(0u64));
    let counted = CountingReader {
        inner: file,
        bar: bar.clone(),
        bytes: Rc::clone(&bytes),
    };
    let mut buffered = BufReader::with_capacity(1 << 16, counted);
    let is_gzip = {
        let head = buffered.fill_buf().map_err(|source| SeriesError::Read {
            file: file_name.to_string(),
            line: 1,
            source,
        })?;
        head.starts_with(&[0x1f, 0x8b])
    };
    let source: Box<dyn Read> = if is_gzip {
        Box::new(flate2::bufread::MultiGzDecoder::new(buffered))
    } else {
        Box::new(buffered)
    };
    Ok((source, bar, bytes))
}

/// The column names of the header row only (reads the first buffer of the file, not the data):
/// `hal-sim identify --imu` finds the six axes by name with it before the one pass over the data.
pub fn read_header(path: impl AsRef<Path>) -> Result<Vec<String>, SeriesError> {
    let path = path.as_ref();
    let file_name = path.display().to_string();
    let (source, bar, _) = open_csv(path, &file_name, true)?;
    bar.finish_and_clear();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .from_reader(source);
    header_names(&mut rdr, &file_name)
}

/// The trimmed names of the header row.
fn header_names<R: Read>(
    rdr: &mut csv::Reader<R>,
    file_name: &str,
) -> Result<Vec<String>, SeriesError> {
    let headers = rdr
        .byte_headers()
        .map_err(|e| csv_error(e, file_name, 1))?
        .clone();
    if headers.is_empty() {
        return Err(SeriesError::NoHeader {
            file: file_name.to_string(),
        });
    }
    Ok(headers
        .iter()
        .map(|h| String::from_utf8_lossy(trim_ascii(h)).into_owned())
        .collect())
}

/// The CSV part, separated from file handling so that the reader type is erased once.
fn parse_csv(
    source: Box<dyn Read>,
    file_name: &str,
    columns: &[&str],
    scale: f64,
) -> Result<Vec<Vec<f64>>, SeriesError> {
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        // Row lengths are checked against the requested columns below, which gives a
        // clearer message than csv's own "unequal lengths" error.
        .flexible(true)
        .buffer_capacity(1 << 16)
        .from_reader(source);

    let names = header_names(&mut rdr, file_name)?;

    let mut index = Vec::with_capacity(columns.len());
    for &col in columns {
        match names.iter().position(|n| n == col.trim()) {
            Some(i) => index.push(i),
            None => {
                return Err(SeriesError::MissingColumn {
                    file: file_name.to_string(),
                    column: col.to_string(),
                    available: names.join(", "),
                })
            }
        }
    }
    let needed = index.iter().max().map_or(0, |&i| i + 1);

    let mut out: Vec<Vec<f64>> = vec![Vec::new(); columns.len()];
    let mut record = csv::ByteRecord::new();
    loop {
        let more = rdr.read_byte_record(&mut record).map_err(|e| {
            // Position of the failing record is the best line estimate csv gives us.
            let line = e
                .position()
                .map_or_else(|| rdr.position().line(), |p| p.line());
            csv_error(e, file_name, line)
        })?;
        if !more {
            break;
        }
        let line = record.position().map_or(0, |p| p.line());
        if record.len() < needed {
            // Name the first requested column that is missing from this row.
            let (k, &i) = index
                .iter()
                .enumerate()
                .find(|(_, &i)| i >= record.len())
                .unwrap_or((0, &index[0]));
            return Err(SeriesError::ShortRow {
                file: file_name.to_string(),
                line,
                column: columns[k].to_string(),
                expected: i + 1,
                found: record.len(),
            });
        }
        for (k, &i) in index.iter().enumerate() {
            let field = &record[i];
            match parse_f64(field) {
                Some(v) => out[k].push(v * scale),
                None => {
                    return Err(SeriesError::NotANumber {
                        file: file_name.to_string(),
                        line,
                        column: columns[k].to_string(),
                        found: String::from_utf8_lossy(field).into_owned(),
                    })
                }
            }
        }
    }
    Ok(out)
}

/// Parses a finite `f64` from ASCII bytes, tolerating surrounding blanks. `NaN` and `inf`
/// are rejected: one of them would turn every Allan variance containing it into NaN.
fn parse_f64(field: &[u8]) -> Option<f64> {
    let s = std::str::from_utf8(trim_ascii(field)).ok()?;
    let v: f64 = s.parse().ok()?;
    v.is_finite().then_some(v)
}

fn trim_ascii(mut b: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = b {
        if first.is_ascii_whitespace() {
            b = rest;
        } else {
            break;
        }
    }
    while let [rest @ .., last] = b {
        if last.is_ascii_whitespace() {
            b = rest;
        } else {
            break;
        }
    }
    b
}

fn csv_error(e: csv::Error, file_name: &str, line: u64) -> SeriesError {
    let file = file_name.to_string();
    match e.into_kind() {
        csv::ErrorKind::Io(source) => SeriesError::Read { file, line, source },
        other => SeriesError::Csv {
            file,
            line,
            message: format!("{other:?}"),
        },
    }
}

/// A progress bar over the bytes of the file on disk, or a hidden one when `quiet` is set or
/// stderr is not a terminal (CI logs, pipes): redraws there would only add noise.
fn progress_bar(total_bytes: u64, quiet: bool, path: &Path) -> ProgressBar {
    if quiet || !io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total_bytes);
    let style = ProgressStyle::with_template(
        "{msg} [{bar:40}] {bytes}/{total_bytes} ({bytes_per_sec}, {eta})",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar())
    .progress_chars("=> ");
    bar.set_style(style);
    let name = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    );
    bar.set_message(name);
    bar
}

/// Advances the progress bar by the number of raw bytes read from the file.
struct CountingReader<R> {
    inner: R,
    bar: ProgressBar,
    /// Total bytes read, shared with [`read_columns_counted`] ([`ReadStats::bytes`]).
    bytes: Rc<Cell<u64>>,
}

impl<R: Read> Read for CountingReader<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bar.inc(n as u64);
        self.bytes.set(self.bytes.get() + n as u64);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn write_tmp(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).expect("write temp file");
        p
    }

    fn gzip(bytes: &[u8]) -> Vec<u8> {
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(bytes).expect("gzip");
        enc.finish().expect("gzip finish")
    }

    const CSV: &str = "a,b, c \n1,2,3\n4, 5.5 ,6\n-7,8e-1,9\n";

    #[test]
    fn reads_plain_and_gzip_identically() {
        let dir = tempfile::tempdir().expect("tempdir");
        let plain = write_tmp(&dir, "p.csv", CSV.as_bytes());
        // Misnamed on purpose: compression is detected by magic bytes, not by extension.
        let gz = write_tmp(&dir, "x.csv", &gzip(CSV.as_bytes()));
        let gz2 = write_tmp(&dir, "y.dat", &gzip(CSV.as_bytes()));
        let o = ReadOptions::default().quiet();
        let b = read_column(&gz, "b", &o).expect("gz");
        assert_eq!(b, vec![2.0, 5.5, 0.8]);
        assert_eq!(read_column(&plain, "b", &o).expect("plain"), b);
        let cols = read_columns(&gz2, &["c", "a"], &o).expect("two columns");
        assert_eq!(cols, vec![vec![3.0, 6.0, 9.0], vec![1.0, 4.0, -7.0]]);
    }

    #[test]
    fn multi_member_gzip_is_read_to_the_end() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut bytes = gzip(b"a\n1\n2\n");
        bytes.extend(gzip(b"3\n4\n"));
        let p = write_tmp(&dir, "m.csv.gz", &bytes);
        let v = read_column(&p, "a", &ReadOptions::default().quiet()).expect("read");
        assert_eq!(v, vec![1.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn scale_factor_is_applied() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = write_tmp(&dir, "s.csv", b"cnt\n10\n-3\n");
        let v = read_column(&p, "cnt", &ReadOptions::scaled(0.5).quiet()).expect("read");
        assert_eq!(v, vec![5.0, -1.5]);
        let e = read_column(&p, "cnt", &ReadOptions::scaled(f64::NAN)).unwrap_err();
        assert!(matches!(e, SeriesError::InvalidScale(_)));
    }

    #[test]
    fn bad_number_names_file_line_column_and_value() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = write_tmp(
            &dir,
            "adis.csv.gz",
            &gzip(b"gyro_x_dps,gyro_z_dps\n1,2\n3,4\n5,abc\n")[..],
        );
        let e = read_column(&p, "gyro_z_dps", &ReadOptions::default().quiet()).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.ends_with(
                "adis.csv.gz line 4, column gyro_z_dps: expected a finite number, found 'abc'"
            ),
            "{msg}"
        );
        // Non-finite values are refused too.
        let p = write_tmp(&dir, "n.csv", b"x\n1\nNaN\n");
        let msg = read_column(&p, "x", &ReadOptions::default().quiet())
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("line 3, column x: expected a finite number, found 'NaN'"),
            "{msg}"
        );
    }

    #[test]
    fn missing_column_lists_available_ones() {
        let dir = tempfile::tempdir().expect("tempdir");
        let p = write_tmp(&dir, "h.csv", b"acc_x_g,acc_y_g\n1,2\n");
        let msg = read_column(&p, "gyro_x_dps", &ReadOptions::default().quiet())
            .unwrap_err()
            .to_string();
        assert!(
            msg.contains("no column named 'gyro_x_dps'; available columns: acc_x_g, acc_y_g"),
            "{msg}"
        );
    }

    #[test]
    fn short_row_empty_file_and_missing_file() {
        let dir = tempfile::tempdir().expect("tempdir");
        let q = ReadOptions::default().quiet();
        let p = write_tmp(&dir, "r.csv", b"a,b,c\n1,2,3\n4,5\n");
        let msg = read_column(&p, "c", &q).unwrap_err().to_string();
        assert!(
            msg.contains("line 3, column c: expected at least 3 fields, found 2"),
            "{msg}"
        );
        let p = write_tmp(&dir, "e.csv", b"");
        let e = read_column(&p, "a", &q).unwrap_err();
        assert!(matches!(e, SeriesError::NoHeader { .. }), "{e}");
        let p = write_tmp(&dir, "h.csv", b"a\n");
        assert_eq!(
            read_column(&p, "a", &q).expect("header only"),
            Vec::<f64>::new()
        );
        let e = read_column(dir.path().join("absent.csv"), "a", &q).unwrap_err();
        assert!(e.to_string().contains("absent.csv: cannot open"), "{e}");
    }

    #[test]
    fn corrupt_gzip_is_a_read_error() {
        let dir = tempfile::tempdir().expect("tempdir");
        let mut bytes = gzip(b"a\n1\n2\n3\n");
        let n = bytes.len();
        bytes.truncate(n - 6);
        let p = write_tmp(&dir, "t.csv.gz", &bytes);
        let e = read_column(&p, "a", &ReadOptions::default().quiet()).unwrap_err();
        assert!(matches!(e, SeriesError::Read { .. }), "{e}");
    }
}
