//! Runs the `imu-ident-qemu` firmware under QEMU on a log and reads back its telemetry.
//!
//! The model (with its run options, [`imu_ident::model::wire`]) and the log (the core's binary
//! replay format, [`imu_ident::replay`]) are written into a fresh temporary directory, QEMU is
//! started there with `-icount shift=0` (so the firmware's SysTick counts instructions and
//! opens both files by short relative names, passed as semihosting arguments), and everything
//! the firmware writes to semihosting stdout is decoded as defmt frames with the ELF's own
//! format table.
//!
//! Frames are parsed structurally: defmt-decoder hands out each format parameter as its own
//! fragment, and the literal before each one names it (`k=`, `t=`, ... see
//! [`imu_ident::telemetry::WIRE_FIELDS`]), so a layout change on the firmware side is an
//! error here rather than silently shifted columns.
//!
//! ```no_run
//! use hal_sim::qemu::{run_firmware, Ident, QemuConfig};
//! use imu_ident::model::InsModel;
//! let rows: Vec<(f64, f64)> = (1..=600).map(|k| (k as f64, 0.0)).collect();
//! let run = run_firmware("imu-ident-qemu".as_ref(), &InsModel::paper(), Ident::Off, &rows, &QemuConfig::default())?;
//! assert!(run.success());
//! assert_eq!(run.telemetry.records.len(), 600);
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
use imu_ident::model::{wire, ComponentKind, ErrorSource, InsModel};
use imu_ident::replay::{encode, encoded_len, Row};
use imu_ident::step::{AcfRecord, ParamRecord};
use imu_ident::telemetry::{Record, WIRE_FIELDS, WIRE_TAG};
use imu_ident::telemetry::{ACF_WIRE_TAG, PARAM_WIRE_FIELDS, PARAM_WIRE_TAG};
use serde::Serialize;

use crate::replay::Telemetry;

/// Name of the log inside QEMU's working directory.
const LOG_NAME: &str = "replay.bin";
/// Name of the model file inside QEMU's working directory.
const MODEL_NAME: &str = "model.bin";
/// Fields of the firmware's autocorrelation frame.
const ACF_FIELDS: [&str; 5] = ["k", "t", "sensor", "tau", "sigma"];
/// Fields of the firmware's instruction-count summary.
pub(crate) const ICOUNT_FIELDS: [&str; 5] = ["class", "n", "mean", "worst", "worst_k"];
/// Fields of the firmware's stack summary.
pub(crate) const STACK_FIELDS: [&str; 4] = ["phase", "high_water", "statics_end", "ram_top"];

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
        // A 12 h adaptive replay takes well under a minute; the margin is for loaded CI machines.
        Self {
            program: PathBuf::from("qemu-system-arm"),
            timeout: Duration::from_secs(600),
        }
    }
}

/// The firmware's instruction counts of one class of ticks (`-icount shift=0`, SysTick).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Icount {
    /// `ordinary` or `reident` (a tick at the end of an identification block or probe epoch).
    pub class: String,
    /// Ticks counted.
    pub n: u32,
    /// Mean instructions per tick (40-instruction resolution).
    pub mean: u64,
    /// Largest count.
    pub worst: u32,
    /// Tick index of the largest count.
    pub worst_k: u32,
}

/// The firmware's stack measurement (painted at boot, scanned at exit).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stack {
    /// `init` (building the estimator) or `run` (the ticks).
    pub phase: String,
    /// Deepest stack use [bytes].
    pub high_water: u32,
    /// End of the statics (`.data` + `.bss`): RAM used by statics is `statics_end - 0x2000_0000`.
    pub statics_end: u32,
    /// Top of RAM (initial stack pointer).
    pub ram_top: u32,
}

/// What one firmware run produced.
#[derive(Debug, Clone)]
pub struct FirmwareRun {
    /// Telemetry, in the order received.
    pub telemetry: Telemetry,
    /// Instruction counts per class of ticks.
    pub icount: Vec<Icount>,
    /// Stack high-water marks of start-up and of the ticks.
    pub stack: Vec<Stack>,
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

/// Encodes the model and the identification option for the firmware.
pub fn encode_model(model: &InsModel<f64>, ident: Ident) -> Result<Vec<u8>> {
    let mut buf = vec![0u8; wire::MAX_LEN];
    let opts = match ident {
        Ident::Off => 0,
        Ident::Recursive => wire::OPT_ADAPT,
        Ident::Global => wire::OPT_ADAPT | wire::OPT_GLOBAL,
        Ident::Structure => wire::OPT_ADAPT | wire::OPT_GLOBAL | wire::OPT_STRUCTURE,
    };
    let n = wire::encode_options(model, opts, &mut buf)
        .map_err(|e| anyhow!("encoding the model: {e:?}"))?;
    buf.truncate(n);
    Ok(buf)
}

/// How the step identifies the noise model online.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ident {
    /// Not at all (the model is fixed).
    Off,
    /// `AdaptConfig::default()`: recursive Gauss-Newton with the probe grid.
    Recursive,
    /// `AdaptConfig::global()`: the global stage over a buffered window.
    Global,
    /// The global stage with its structure test on (Gauss-Markov <-> exp-cosine switching).
    Structure,
}

impl Ident {
    /// From the command-line flags `--adapt`, `--global` and `--structure` (each implies the
    /// ones before).
    pub fn from_flags(adapt: bool, global: bool, structure: bool) -> Self {
        match (adapt, global) {
            _ if structure => Self::Structure,
            (_, true) => Self::Global,
            (true, false) => Self::Recursive,
            (false, false) => Self::Off,
        }
    }

    /// The host's settings for it (`None`: fixed model).
    pub fn config(self) -> Option<imu_ident::adapt::AdaptConfig<f64>> {
        match self {
            Self::Off => None,
            Self::Recursive => Some(imu_ident::adapt::AdaptConfig::default()),
            Self::Global => Some(imu_ident::adapt::AdaptConfig::global()),
            Self::Structure => {
                let mut c = imu_ident::adapt::AdaptConfig::global();
                c.global = imu_ident::adapt::window::WindowConfig::with_structure();
                Some(c)
            }
        }
    }
}

/// Runs the firmware `elf` with `model` (identified online as `ident` says) on `rows` (see
/// [`encode_log`]) and decodes its telemetry.
///
/// An `Err` means the run could not be carried out or understood (QEMU missing, timeout,
/// undecodable output); the firmware's own failure is reported in [`FirmwareRun::status`].
pub fn run_firmware(
    elf: &Path,
    model: &InsModel<f64>,
    ident: Ident,
    rows: &[(f64, f64)],
    cfg: &QemuConfig,
) -> Result<FirmwareRun> {
    run_firmware_bytes(elf, &encode_model(model, ident)?, &encode_log(rows)?, cfg)
}

/// Like [`run_firmware`] with the model and log given as raw bytes (to test corrupt files).
pub fn run_firmware_bytes(
    elf: &Path,
    model: &[u8],
    log: &[u8],
    cfg: &QemuConfig,
) -> Result<FirmwareRun> {
    let out = run_qemu(
        elf,
        "imu-ident-qemu",
        &[(MODEL_NAME, model), (LOG_NAME, log)],
        cfg,
    )?;
    let decoded = decode_telemetry(&out.elf_bytes, &out.stdout)
        .with_context(|| format!("decoding the output of {}", elf.display()))?;
    Ok(FirmwareRun {
        telemetry: decoded.telemetry,
        icount: decoded.icount,
        stack: decoded.stack,
        messages: decoded.messages,
        status: out.status,
        stderr: out.stderr,
    })
}

/// What a QEMU run of a firmware left behind, undecoded.
#[derive(Debug)]
pub struct QemuOutput {
    /// The ELF that ran (for its defmt table).
    pub elf_bytes: Vec<u8>,
    /// Everything written to semihosting stdout (defmt frames).
    pub stdout: Vec<u8>,
    /// QEMU's exit status: the firmware's semihosting exit code.
    pub status: ExitStatus,
    /// QEMU's own diagnostics.
    pub stderr: String,
}

/// Runs the firmware `elf` under QEMU in a fresh temporary directory holding `files` (name,
/// contents), with the semihosting command line `program` followed by the file names, and
/// returns its raw output. Shared by the estimator firmware and the navigation firmware
/// (`hal_sim::nav_qemu`).
pub fn run_qemu(
    elf: &Path,
    program: &str,
    files: &[(&str, &[u8])],
    cfg: &QemuConfig,
) -> Result<QemuOutput> {
    let elf_bytes = std::fs::read(elf).with_context(|| format!("reading {}", elf.display()))?;
    // An absolute path: QEMU runs in the temporary directory.
    let elf = elf
        .canonicalize()
        .with_context(|| format!("resolving {}", elf.display()))?;
    let dir = tempfile::tempdir().context("creating a temporary directory")?;
    let mut semihosting = format!("enable=on,target=native,arg={program}");
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).with_context(|| format!("writing {name}"))?;
        semihosting.push_str(&format!(",arg={name}"));
    }

    let mut child = Command::new(&cfg.program)
        .args(["-cpu", "cortex-m4", "-machine", "mps2-an386"])
        // No display, monitor or UART on stdio: stdout carries nothing but defmt frames.
        .args(["-display", "none", "-monitor", "none", "-serial", "null"])
        // 1 ns of virtual time per instruction: the firmware's SysTick counts instructions.
        .args(["-icount", "shift=0"])
        .arg("-semihosting-config")
        .arg(semihosting)
        .arg("-kernel")
        .arg(&elf)
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| {
            format!(
                "starting {} (QEMU; install it with `{}`)",
                cfg.program.display(),
                crate::firmware::QEMU_HINT
            )
        })?;

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
    Ok(QemuOutput {
        elf_bytes,
        stdout,
        status,
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
    })
}

/// Everything decoded from a firmware's defmt stream.
#[derive(Debug, Clone, Default)]
pub struct Decoded {
    /// Tick records, parameters and autocorrelation identifications.
    pub telemetry: Telemetry,
    /// Instruction-count summaries.
    pub icount: Vec<Icount>,
    /// The stack summaries.
    pub stack: Vec<Stack>,
    /// Every other frame, formatted (`LEVEL message`).
    pub messages: Vec<String>,
}

/// Decodes a defmt byte stream produced by the firmware `elf_bytes`.
pub fn decode_telemetry(elf_bytes: &[u8], stream: &[u8]) -> Result<Decoded> {
    let table = Table::parse(elf_bytes)
        .context("reading the defmt table")?
        .ok_or_else(|| anyhow!("the ELF has no defmt table (not built with defmt?)"))?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(stream);
    let mut out = Decoded::default();
    loop {
        match decoder.decode() {
            Ok(frame) => parse_frame(&frame, &mut out)?,
            // The end of the stream (a cut-off last frame also ends here).
            Err(DecodeError::UnexpectedEof) => break,
            Err(DecodeError::Malformed) if table.encoding().can_recover() => {
                out.messages
                    .push("<malformed defmt frame skipped>".to_string());
            }
            Err(DecodeError::Malformed) => bail!("malformed defmt frame in a raw-encoded stream"),
        }
    }
    Ok(out)
}

/// The displayed parameters of a frame whose first literal starts with `tag`, checked against
/// the expected field names; `None` for a frame with another tag.
pub(crate) fn tagged<const N: usize>(
    frame: &Frame<'_>,
    tag: &str,
    expected: &[&str; N],
) -> Result<Option<[String; N]>> {
    let fragments = frame.fragments();
    match fragments.first() {
        Some(Fragment::Literal(s)) if s.starts_with(&format!("{tag} ")) => {}
        _ => return Ok(None),
    }
    let mut values = Vec::with_capacity(N);
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
                let want = expected.get(values.len()).copied().unwrap_or("<none>");
                if name != want {
                    bail!(
                        "`{tag}` frame field {} is `{name}`, expected `{want}`",
                        values.len()
                    );
                }
                values.push(shown);
            }
        }
    }
    let n = values.len();
    values
        .try_into()
        .map(Some)
        .map_err(|_| anyhow!("`{tag}` frame has {n} fields, expected {N}"))
}

fn sensor(code: u8) -> Result<ErrorSource> {
    [
        ErrorSource::Accel,
        ErrorSource::Gyro,
        ErrorSource::Observation,
    ]
    .get(usize::from(code))
    .copied()
    .ok_or_else(|| anyhow!("unknown sensor code {code}"))
}

fn kind(code: u8) -> Result<ComponentKind> {
    [
        ComponentKind::GaussMarkov,
        ComponentKind::ExpCosine,
        ComponentKind::RandomWalk,
        ComponentKind::RandomConstant,
        ComponentKind::White,
    ]
    .get(usize::from(code))
    .copied()
    .ok_or_else(|| anyhow!("unknown component kind code {code}"))
}

/// Sorts one frame into `out`.
fn parse_frame(frame: &Frame<'_>, out: &mut Decoded) -> Result<()> {
    if let Some(v) = tagged(frame, WIRE_TAG, &WIRE_FIELDS)? {
        let [k, t, z, nu, s, nis, dv, sdv, delta, sd, da, sda, dw, sdw, flags] = v;
        out.telemetry.records.push(Record {
            k: field("k", &k)?,
            t: field("t", &t)?,
            z: field("z", &z)?,
            innovation: field("nu", &nu)?,
            variance: field("s", &s)?,
            nis: field("nis", &nis)?,
            dv: field("dv", &dv)?,
            sigma_dv: field("sdv", &sdv)?,
            delta: field("delta", &delta)?,
            sigma_delta: field("sd", &sd)?,
            da: field("da", &da)?,
            sigma_da: field("sda", &sda)?,
            dw: field("dw", &dw)?,
            sigma_dw: field("sdw", &sdw)?,
            flags: field("flags", &flags)?,
        });
    } else if let Some(v) = tagged(frame, PARAM_WIRE_TAG, &PARAM_WIRE_FIELDS)? {
        let [k, t, s, comp, kd, tau, sigma, beta, sd_tau, sd_sigma, sd_beta, flat] = v;
        out.telemetry.params.push(ParamRecord {
            k: field("k", &k)?,
            t: field("t", &t)?,
            sensor: sensor(field("sensor", &s)?)?,
            component: field("comp", &comp)?,
            kind: kind(field("kind", &kd)?)?,
            tau: field("tau", &tau)?,
            sigma: field("sigma", &sigma)?,
            beta: field("beta", &beta)?,
            sd_tau: field("sd_tau", &sd_tau)?,
            sd_sigma: field("sd_sigma", &sd_sigma)?,
            sd_beta: field("sd_beta", &sd_beta)?,
            flat: field("flat", &flat)?,
        });
    } else if let Some(v) = tagged(frame, ACF_WIRE_TAG, &ACF_FIELDS)? {
        let [k, t, s, tau, sigma] = v;
        out.telemetry.acf.push(AcfRecord {
            k: field("k", &k)?,
            t: field("t", &t)?,
            sensor: sensor(field("sensor", &s)?)?,
            tau: field("tau", &tau)?,
            sigma: field("sigma", &sigma)?,
        });
    } else if let Some(v) = tagged(frame, "icount", &ICOUNT_FIELDS)? {
        let [class, n, mean, worst, worst_k] = v;
        out.icount.push(Icount {
            class,
            n: field("n", &n)?,
            mean: field("mean", &mean)?,
            worst: field("worst", &worst)?,
            worst_k: field("worst_k", &worst_k)?,
        });
    } else if let Some(v) = tagged(frame, "stack", &STACK_FIELDS)? {
        let [phase, h, e, top] = v;
        out.stack.push(Stack {
            phase,
            high_water: field("high_water", &h)?,
            statics_end: field("statics_end", &e)?,
            ram_top: field("ram_top", &top)?,
        });
    } else {
        out.messages.push(frame.display(false).to_string());
    }
    Ok(())
}

/// Parses one displayed value. defmt-decoder prints floats with `ryu` (shortest round-trip
/// form, `NaN`, `inf`), which `str::parse` reads back bit-exactly.
pub(crate) fn field<T: std::str::FromStr>(name: &str, shown: &str) -> Result<T>
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
