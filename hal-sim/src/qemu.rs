//! Runs the `imu-ident-qemu` firmware under QEMU on a log and reads back its telemetry.
//!
//! The log is written in the core's binary replay format ([`imu_ident::replay`]) into a fresh
//! temporary directory, QEMU is started there (so the firmware opens it by a short relative
//! name, passed as a semihosting argument), and everything the firmware writes to semihosting
//! stdout is decoded as defmt frames with the ELF's own format table.
//!
//! Telemetry frames are parsed structurally: defmt-decoder hands out each format parameter as
//! its own fragment, and the literal before each one names it (`k=`, `t=`, ... see
//! [`imu_ident::telemetry::WIRE_FIELDS`]), so a layout change on the firmware side is an
//! error here rather than silently shifted columns.
//!
//! ```no_run
//! use hal_sim::qemu::{run_firmware, QemuConfig};
//! let rows: Vec<(f64, f64)> = (1..=600).map(|k| (k as f64, 0.0)).collect();
//! let run = run_firmware("imu-ident-qemu".as_ref(), &rows, &QemuConfig::default())?;
//! assert!(run.success());
//! assert_eq!(run.records.len(), 600);
//! # Ok::<(), anyhow::Error>(())
//! ```

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{anyhow, bail, Context, Result};
use defmt_decoder::{DecodeError, Frame, Table};
use defmt_parser::Fragment;
use imu_ident::replay::{encode, encoded_len, Row};
use imu_ident::telemetry::{Record, WIRE_FIELDS, WIRE_TAG};

/// Name of the log inside QEMU's working directory.
const LOG_NAME: &str = "replay.bin";

/// How to start QEMU.
#[derive(Debug, Clone)]
pub struct QemuConfig {
    /// The emulator binary.
    pub program: PathBuf,
    /// Wall-clock limit for one run; QEMU is killed after it.
    pub timeout: Duration,
}

impl Default for QemuConfig {
    fn default() -> Self {
        // A 600-step replay takes well under a second; the margin is for loaded CI machines.
        Self {
            program: PathBuf::from("qemu-system-arm"),
            timeout: Duration::from_secs(120),
        }
    }
}

/// What one firmware run produced.
#[derive(Debug, Clone)]
pub struct FirmwareRun {
    /// Telemetry records, in the order received.
    pub records: Vec<Record>,
    /// Every other defmt frame, formatted (`LEVEL message`), e.g. the final summary or error.
    pub messages: Vec<String>,
    /// QEMU's exit status: the firmware's semihosting exit code.
    pub status: ExitStatus,
    /// QEMU's own diagnostics.
    pub stderr: String,
}

impl FirmwareRun {
    /// True when the firmware exited with success (complete, valid log).
    pub fn success(&self) -> bool {
        self.status.success()
    }
}

/// Encodes `(t [s], z [m/s])` rows in the replay format (`z` is narrowed to `f32`, NaN for a
/// missing observation).
pub fn encode_log(rows: &[(f64, f64)]) -> Result<Vec<u8>> {
    let rows: Vec<Row> = rows.iter().map(|&(t, z)| Row { t, z: z as f32 }).collect();
    let len = encoded_len(rows.len()).ok_or_else(|| anyhow!("{} rows is too many", rows.len()))?;
    let mut buf = vec![0u8; len];
    let n = encode(&rows, &mut buf).map_err(|e| anyhow!("encoding the log: {e}"))?;
    buf.truncate(n);
    Ok(buf)
}

/// Runs the firmware `elf` on `rows` (see [`encode_log`]) and decodes its telemetry.
///
/// An `Err` means the run could not be carried out or understood (QEMU missing, timeout,
/// undecodable output); the firmware's own failure is reported in [`FirmwareRun::status`].
pub fn run_firmware(elf: &Path, rows: &[(f64, f64)], cfg: &QemuConfig) -> Result<FirmwareRun> {
    run_firmware_bytes(elf, &encode_log(rows)?, cfg)
}

/// Like [`run_firmware`] with the log given as raw bytes (to test corrupt logs).
pub fn run_firmware_bytes(elf: &Path, log: &[u8], cfg: &QemuConfig) -> Result<FirmwareRun> {
    let elf_bytes = std::fs::read(elf).with_context(|| format!("reading {}", elf.display()))?;
    // An absolute path: QEMU runs in the temporary directory.
    let elf = elf
        .canonicalize()
        .with_context(|| format!("resolving {}", elf.display()))?;
    let dir = tempfile::tempdir().context("creating a temporary directory")?;
    std::fs::write(dir.path().join(LOG_NAME), log).context("writing the replay log")?;

    let mut child = Command::new(&cfg.program)
        .args(["-cpu", "cortex-m4", "-machine", "mps2-an386"])
        // No display, monitor or UART on stdio: stdout carries nothing but defmt frames.
        .args(["-display", "none", "-monitor", "none", "-serial", "null"])
        .arg("-semihosting-config")
        .arg(format!(
            "enable=on,target=native,arg=imu-ident-qemu,arg={LOG_NAME}"
        ))
        .arg("-kernel")
        .arg(&elf)
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("starting {} (is QEMU installed?)", cfg.program.display()))?;

    // Drain both pipes on their own threads so a chatty child never blocks on a full pipe.
    let mut out = child
        .stdout
        .take()
        .ok_or_else(|| anyhow!("no stdout pipe"))?;
    let mut err = child
        .stderr
        .take()
        .ok_or_else(|| anyhow!("no stderr pipe"))?;
    let out_thread = thread::spawn(move || {
        let mut buf = Vec::new();
        out.read_to_end(&mut buf).map(|_| buf)
    });
    let err_thread = thread::spawn(move || {
        let mut buf = Vec::new();
        err.read_to_end(&mut buf).map(|_| buf)
    });

    let deadline = Instant::now() + cfg.timeout;
    let status = loop {
        if let Some(status) = child.try_wait().context("waiting for QEMU")? {
            break status;
        }
        if Instant::now() >= deadline {
            // Best effort: the process may have exited between the two calls.
            let _ = child.kill();
            let _ = child.wait();
            bail!(
                "QEMU did not finish within {:?} (firmware hung?)",
                cfg.timeout
            );
        }
        thread::sleep(Duration::from_millis(10));
    };
    let stdout = out_thread
        .join()
        .map_err(|_| anyhow!("stdout reader panicked"))??;
    let stderr = err_thread
        .join()
        .map_err(|_| anyhow!("stderr reader panicked"))??;

    let (records, messages) = decode_telemetry(&elf_bytes, &stdout)
        .with_context(|| format!("decoding the output of {}", elf.display()))?;
    Ok(FirmwareRun {
        records,
        messages,
        status,
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
    })
}

/// Decodes a defmt byte stream produced by the firmware `elf_bytes`: telemetry frames become
/// [`Record`]s, all other frames formatted messages.
pub fn decode_telemetry(elf_bytes: &[u8], stream: &[u8]) -> Result<(Vec<Record>, Vec<String>)> {
    let table = Table::parse(elf_bytes)
        .context("reading the defmt table")?
        .ok_or_else(|| anyhow!("the ELF has no defmt table (not built with defmt?)"))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(stream);
    let (mut records, mut messages) = (Vec::new(), Vec::new());
    loop {
        match decoder.decode() {
            Ok(frame) => match parse_record(&frame)? {
                Some(rec) => records.push(rec),
                None => messages.push(frame.display(false).to_string()),
            },
            // The end of the stream (a cut-off last frame also ends here).
            Err(DecodeError::UnexpectedEof) => break,
            Err(DecodeError::Malformed) if table.encoding().can_recover() => {
                messages.push("<malformed defmt frame skipped>".to_string());
            }
            Err(DecodeError::Malformed) => bail!("malformed defmt frame in a raw-encoded stream"),
        }
    }
    Ok((records, messages))
}

/// Parses a telemetry frame (`tlm k=.. t=.. ...`, written by `Record::log`); `None` for any
/// other frame.
fn parse_record(frame: &Frame<'_>) -> Result<Option<Record>> {
    let fragments = frame.fragments();
    match fragments.first() {
        Some(Fragment::Literal(s)) if s.starts_with(&format!("{WIRE_TAG} ")) => {}
        _ => return Ok(None),
    }
    let mut values = Vec::with_capacity(WIRE_FIELDS.len());
    let mut name = String::new();
    for (fragment, shown) in fragments.iter().zip(frame.display_fragments()) {
        match fragment {
            Fragment::Literal(s) => {
                name = s
                    .trim_end_matches('=')
                    .rsplit(' ')
                    .next()
                    .unwrap_or("")
                    .to_string()
            }
            Fragment::Parameter(_) => {
                let expected = WIRE_FIELDS.get(values.len()).copied().unwrap_or("<none>");
                if name != expected {
                    bail!(
                        "telemetry field {} is `{name}`, expected `{expected}`",
                        values.len()
                    );
                }
                values.push(shown);
            }
        }
    }
    let n = values.len();
    let [k, t, z, nu, s, nis, delta, sd, flags]: [String; 9] = values.try_into().map_err(|_| {
        anyhow!(
            "telemetry frame has {n} fields, expected {}",
            WIRE_FIELDS.len()
        )
    })?;
    Ok(Some(Record {
        k: field("k", &k)?,
        t: field("t", &t)?,
        z: field("z", &z)?,
        innovation: field("nu", &nu)?,
        variance: field("s", &s)?,
        nis: field("nis", &nis)?,
        delta: field("delta", &delta)?,
        sigma_delta: field("sd", &sd)?,
        flags: field("flags", &flags)?,
    }))
}

/// Parses one displayed value. defmt-decoder prints floats with `ryu` (shortest round-trip
/// form, `NaN`, `inf`), which `str::parse` reads back bit-exactly.
fn field<T: std::str::FromStr>(name: &str, shown: &str) -> Result<T>
where
    T::Err: std::error::Error + Send + Sync + 'static,
{
    shown
        .parse()
        .with_context(|| format!("telemetry field {name} = `{shown}`"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use imu_ident::replay::decode;

    #[test]
    fn encode_log_round_trips_through_the_core_decoder() {
        let rows = [(1.0e7, 0.25), (1.0e7 + 1.0, f64::NAN)];
        let bytes = encode_log(&rows).unwrap();
        let mut back = Vec::new();
        assert_eq!(decode(&bytes, |r| back.push(r)), Ok(2));
        assert_eq!(back[0], Row { t: 1.0e7, z: 0.25 });
        assert_eq!(back[1].t, 1.0e7 + 1.0);
        assert!(back[1].z.is_nan());
    }

    #[test]
    fn decoding_needs_a_defmt_table() {
        assert!(decode_telemetry(b"not an elf", &[]).is_err());
    }
}
