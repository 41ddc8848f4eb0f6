//! The `hal-sim` command line: the clap definitions of every subcommand and its options
//! ([`Cli`], [`Command`]), with their help texts and defaults. `main.rs` parses them and
//! dispatches each command to the library; the definitions live here, beside the other clap
//! definitions of the library (`datasheet_model::ModelCommand`), so that the binary holds only
//! the dispatch.

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// The online identification's defaults, for `nav`'s options.
const ADAPT: crate::nav::adapt::AdaptConfig = crate::nav::adapt::AdaptConfig::DEFAULT;

#[derive(Parser)]
#[command(name = "hal-sim", version, about = "Host test bed for imu-ident")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

// One command is parsed once per process: the size of its largest variant (`nav`'s options)
// costs nothing, and boxing it would only obscure the clap definitions.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
pub enum Command {
    /// Simulate a log from a scenario's truth model.
    Simulate {
        /// Scenario TOML file, or a built-in name (paper).
        #[arg(long)]
        scenario: String,
        /// Duration [h] (default: the scenario's `hours`, else 12).
        #[arg(long)]
        hours: Option<f64>,
        /// RNG seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output log CSV.
        #[arg(long)]
        out: PathBuf,
    },
    /// Strapdown INS/GNSS: an IMU CSV and a GNSS CSV or RTKLIB .pos through the core's
    /// closed-loop navigator; writes estimates.csv, solution.pos, summary.json, report.html
    /// (outages.json; errors.csv with --truth; identified.json, identified-model.toml with
    /// --identify).
    Nav {
        /// IMU CSV (t,gx,gy,gz,ax,ay,az; s, rad/s FRD, m/s^2), or a serial wire (.bin: `hal-sim
        /// wire`, or a recording of a board's IMU port; a hub's counted samples are put on GPS
        /// time as the firmware puts them).
        #[arg(long)]
        imu: PathBuf,
        /// GNSS CSV, an RTKLIB .pos file or a u-blox .ubx log (by its extension).
        #[arg(long)]
        gnss: PathBuf,
        /// Noise model: an IMU model TOML, or drive-datasheet / drive-inflated.
        #[arg(long)]
        model: String,
        /// GNSS outages START,LEN,PERIOD,MARGIN [s] from the first GNSS epoch.
        #[arg(long)]
        outages: Option<crate::nav_io::OutageSpec>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// GNSS antenna from the IMU, forward,right,down [m].
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.0, 0.0, 0.0])]
        lever_arm: Vec<f64>,
        /// Filter step [s].
        #[arg(long, default_value_t = 1.0)]
        step: f64,
        /// Shortest interval between fused GNSS fixes [s]; 0 (the default) fuses every fix.
        /// A fix between filter steps is fused at its own time, the filter first propagated
        /// over the part of the step elapsed. 1 fuses one fix per 1-s step.
        #[arg(long, default_value_t = 0.0)]
        fix_interval: f64,
        /// Static levelling window at the start [s].
        #[arg(long, default_value_t = 20.0)]
        align: f64,
        /// Initial yaw [deg] (default: from the GNSS course once moving).
        #[arg(long, allow_negative_numbers = true)]
        yaw: Option<f64>,
        /// Speed [m/s] from which the GNSS course gives the heading.
        #[arg(long, default_value_t = 2.0)]
        yaw_speed: f64,
        /// Do not seed the gyro biases from the mean rate of the static window.
        #[arg(long)]
        no_static_gyro_bias: bool,
        /// Initial attitude uncertainty roll,pitch,yaw [deg].
        #[arg(long, value_delimiter = ',', default_values_t = [2.0, 2.0, 10.0])]
        sd_att: Vec<f64>,
        /// Initial velocity uncertainty [m/s].
        #[arg(long, default_value_t = 0.1)]
        sd_vel: f64,
        /// Initial position uncertainty [m].
        #[arg(long, default_value_t = 1.0)]
        sd_pos: f64,
        /// Gate multiplier on the chi-square 1e-4 quantile (0: no gate).
        #[arg(long, default_value_t = 1.0)]
        gate: f64,
        /// Fuse GNSS positions only.
        #[arg(long)]
        no_velocity: bool,
        /// Run the core in f32.
        #[arg(long)]
        f32: bool,
        /// Keep .pos epochs with 1 <= Q <= MAX_Q.
        #[arg(long, default_value_t = 2)]
        max_q: u8,
        /// Estimate gyro and accelerometer scale-factor errors, random constants with these
        /// standard deviations GYRO,ACCEL (dimensionless: 0.01 = 1 %).
        #[arg(long, value_delimiter = ',')]
        scale_factors: Option<Vec<f64>>,
        /// Also run the navigation firmware ELF (imu-ident-nav-qemu) on QEMU with the same
        /// inputs and options; writes firmware.json (parity with the host, instruction counts,
        /// stack; with --adapt --adapt-method bank, the firmware's online decisions against
        /// the host's). Not with --identify: pass the identified model and options instead.
        #[arg(long, conflicts_with = "identify")]
        qemu_elf: Option<PathBuf>,
        /// Also stream the log through the live loop as a navigation computer receives it,
        /// each fix DELAY [s] after its time, the samples held LATENCY [s] for them, and write
        /// the solution at the newest sample (the output predictor) at every sample to
        /// present.csv (the truth CSV's columns) and its figures to present.json (with --truth,
        /// against the truth; else against the run's own later solution). The stream withholds
        /// nothing (no outage schedule) and runs no online identification.
        #[arg(long, value_delimiter = ',', value_name = "DELAY,LATENCY",
              conflicts_with_all = ["identify", "adapt", "diagnose"])]
        present: Option<Vec<f64>>,
        /// Added to every IMU time [s] (a residual logging delay).
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        imu_time_shift: f64,
        /// First identify the noise model on this log (maximum likelihood), then run with it.
        #[arg(long)]
        identify: bool,
        /// With --identify: then untie the four IMU factors over x, y, z (a factor per axis),
        /// search again from the tied answer, and keep the per-axis answer when it gains more
        /// than half the chi-square 0.99 quantile (two degrees of freedom per factor the model
        /// carries) over the tied one; identified.json gives both. About twice the runs.
        #[arg(long, requires = "identify")]
        identify_axes: bool,
        /// Name the effect the model lacks: each candidate (a Gauss-Markov, random walk or
        /// random constant on the gyros or the accelerometers) is added, fitted by maximum
        /// likelihood and tested against the model (likelihood ratio, 1 % false alarms over
        /// the candidates); the significant one with the largest excess is added and the run
        /// repeated with it. Writes diagnosis.json and diagnosed-model.toml. With --identify
        /// the model's magnitudes are identified first and the identified model is diagnosed
        /// (otherwise a candidate may stand in for a magnitude that is only wrong).
        #[arg(long, conflicts_with_all = ["adapt", "qemu_elf"])]
        diagnose: bool,
        /// With --diagnose: test every candidate split over the three axes too (its magnitude
        /// per axis), not only the named one. Finds an effect on one axis that the tied
        /// candidate misses (a walk on one horizontal accelerometer, which the tied candidate
        /// also puts on the vertical one, where the heights reject it); about three times the runs.
        #[arg(long, requires = "diagnose")]
        diagnose_axes: bool,
        /// Non-holonomic constraint: the body lateral and vertical velocity at --nhc-lever are
        /// zero with this standard deviation [m/s], every filter step while moving faster than
        /// 1 m/s with the heading known (also during outages). Off by default; with --identify
        /// its factor is identified too. With --qemu-elf the firmware applies it too (the
        /// replay carries it).
        #[arg(long)]
        nhc: Option<f64>,
        /// Where the constraint holds, from the IMU, forward,right,down [m] (the body origin).
        /// Default: minus import.imu_lever of a meta.json beside --imu (hal-sim import-drive),
        /// else 0,0,0.
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
        nhc_lever: Option<Vec<f64>>,
        /// Zero-velocity updates: after every filter step at rest, the velocity is zero with
        /// this standard deviation [m/s] on each axis (also during outages). Rest: every IMU
        /// sample of the step within the --zupt-detector bounds, and the solution slower than
        /// its speed bound. Off by default; with --qemu-elf the firmware applies it too.
        #[arg(long)]
        zupt: Option<f64>,
        /// The rest detector's bounds: rate magnitude [rad/s], departure of the specific force
        /// resolved in NED from (0, 0, -g), normal gravity [m/s^2] (both on every sample of the
        /// step), and the solution's speed [m/s].
        #[arg(long, value_delimiter = ',', default_values_t = [0.15, 0.6, 0.5])]
        zupt_detector: Vec<f64>,
        /// Factors on the GNSS position,velocity standard deviations.
        #[arg(long, value_delimiter = ',', default_values_t = [1.0, 1.0])]
        gnss_sd_factor: Vec<f64>,
        /// Truth CSV (simulation): write errors.csv and the error statistics (RMS, 3-sigma
        /// fractions, NEES) into summary.json and the report.
        #[arg(long)]
        truth: Option<PathBuf>,
        /// Identify the sensor noise online while navigating (causal: each search sees the
        /// data up to its time): every --adapt-every seconds, the window's innovation
        /// likelihood is maximised over factors on the model's intensities and correlation
        /// times; writes adapt.json and adapt.csv.
        #[arg(long, conflicts_with = "identify")]
        adapt: bool,
        /// First online search and interval between searches FIRST,EVERY [s] (default 600,1200;
        /// with `--adapt-method bank` the bank's `OnlineConfig::DEFAULT`, 600,600).
        #[arg(long, value_delimiter = ',')]
        adapt_every: Option<Vec<f64>>,
        /// How the online identification maximises the likelihood: a pattern search over
        /// replays of the window (host only), or the core's bank of shadow filters and
        /// parabola steps (what the MCU runs; docs/ADAPTATION.md §9).
        #[arg(long, value_enum, default_value_t = ADAPT.method)]
        adapt_method: crate::nav::adapt::AdaptMethod,
        /// Window of the online searches [s] (from the start while the run is shorter).
        #[arg(long, default_value_t = ADAPT.window)]
        adapt_window: f64,
        /// One factor per axis instead of one per sensor and component.
        #[arg(long)]
        adapt_per_axis: bool,
        /// With --adapt-method bank and --adapt-per-axis: tied until the bank settles, then
        /// per axis from its point (host only; docs/ADAPTATION.md §9, "Tied first").
        #[arg(long)]
        adapt_tied_first: bool,
        /// The correlation times: searched like the intensities (free), held at the model's
        /// values, or tested (moved only when the window's likelihood rejects the held values
        /// at 1 %); chosen by measurement, BENCHMARKS.md "Online identification in the
        /// navigator". With --adapt-method bank, `tested` holds a correlation time whose
        /// Cramér-Rao sd is above 0.5 decade (OnlineConfig::hold_flat_taus).
        #[arg(long, value_enum, default_value_t = ADAPT.taus)]
        adapt_taus: crate::nav::adapt::TauMode,
        /// With --adapt-method bank: the time constant [s] with which the bank's window
        /// forgets its fixes (OnlineConfig::memory), so that a sensor that changes in service
        /// is followed; `inf` keeps every fix since the shadows last moved. BENCHMARKS.md
        /// "A sensor that changes in service".
        #[arg(long, default_value_t = ADAPT.bank.memory)]
        adapt_memory: f64,
        /// Also identify factors on the GNSS position and velocity standard deviations (the
        /// measurement noise, on top of --gnss-sd-factor), as `--identify` does offline; with
        /// either method (the bank's factors scale a fix's default deviations too).
        /// BENCHMARKS.md "The GNSS noise online" and "The GNSS factors in the bank".
        #[arg(long, default_value_t = ADAPT.gnss_sd, action = clap::ArgAction::Set, value_name = "BOOL")]
        adapt_gnss_sd: bool,
        /// With --adapt-method bank: a coordinate the window does not bound yet (its parabola
        /// not concave) waits while a bounded one moves out of the shadows' grid
        /// (OnlineConfig::flat_waits). BENCHMARKS.md "Flat coordinates wait in the bank".
        #[arg(long, default_value_t = ADAPT.bank.flat_waits, action = clap::ArgAction::Set, value_name = "BOOL")]
        adapt_flat_waits: bool,
        /// With --adapt-method bank: a coordinate the window bounds leaves the shadows' grid
        /// (which restarts the window) only when its vertex is beyond the grid's edge by this
        /// many Cramér-Rao sds; otherwise it stops at the edge (OnlineConfig::exit_z). 0: it
        /// leaves whenever its vertex is beyond the edge.
        #[arg(long, default_value_t = ADAPT.bank.exit_z, value_name = "Z")]
        adapt_exit_z: f64,
    },
    /// Simulate a strapdown drive (figure-eights, climbs): imu.csv, truth.csv, gnss.csv.
    SimulateDrive {
        /// Duration [h].
        #[arg(long, default_value_t = 1.0)]
        hours: f64,
        /// IMU rate [Hz].
        #[arg(long, default_value_t = 100.0)]
        rate: f64,
        /// RNG seed (sensor errors; GNSS noise uses seed + 1).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// GNSS outage window START:END [s] (repeatable).
        #[arg(long, value_parser = crate::trajectory::write::parse_outage)]
        outage: Vec<(f64, f64)>,
        /// GNSS antenna from the IMU, forward,right,down [m] (give the same to `nav
        /// --lever-arm`).
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true, num_args = 3, default_values_t = [0.0, 0.0, 0.0])]
        lever_arm: Vec<f64>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
    },
    /// Run the filter over a log with a model; writes estimates.csv and summary.json.
    Run {
        /// Log CSV (columns t, z; optional truth).
        #[arg(long)]
        log: PathBuf,
        /// Model TOML.
        #[arg(long)]
        model: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Identify the noise model online (adaptive loop), starting from --model.
        #[arg(long)]
        adapt: bool,
        /// Identify with the global stage (maximum likelihood over a buffered window, searched
        /// from a grid around --model; implies --adapt; docs/ADAPTATION.md §7).
        #[arg(long)]
        global: bool,
        /// With the global stage's structure test: a Gauss-Markov component may become an
        /// exponential-cosine and back (implies --global; docs/ADAPTATION.md §7.6).
        #[arg(long)]
        structure: bool,
        /// True model TOML (simulated logs): drawn in report.html beside the identified
        /// parameters (with --adapt).
        #[arg(long)]
        truth: Option<PathBuf>,
    },
    /// Reproduce the paper's Fig. 3-5 on the `paper` scenario as SVG files.
    Figures {
        /// Seed of the simulated log.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output folder.
        #[arg(long, default_value = "out/figures")]
        out: PathBuf,
    },
    /// Compare a model with a log, name the missing effect, and suggest the corrected model.
    Diagnose {
        /// Log CSV.
        #[arg(long)]
        log: PathBuf,
        /// Model TOML.
        #[arg(long)]
        model: PathBuf,
        /// Output folder (diagnosis.json, suggested-model.toml, report.html).
        #[arg(long)]
        out: PathBuf,
    },
    /// Compare models on one log: before/after table and report.html.
    Compare {
        /// Log CSV.
        #[arg(long)]
        log: PathBuf,
        /// Model TOML (repeat: --model A.toml --model B.toml).
        #[arg(long, required = true)]
        model: Vec<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Identify a composite noise model of one axis (--column) or of a whole IMU
    /// (--columns gx,gy,gz,ax,ay,az or --imu) of a static recording (ADEV + ACF).
    Identify {
        /// CSV or gzip CSV with a header row.
        #[arg(long)]
        series: PathBuf,
        /// Column to analyse (one axis).
        #[arg(long, required_unless_present_any = ["columns", "imu"], conflicts_with_all = ["columns", "imu"])]
        column: Option<String>,
        /// Six columns gx,gy,gz,ax,ay,az: the whole IMU in one pass over the file.
        #[arg(long, value_delimiter = ',', conflicts_with = "imu")]
        columns: Option<Vec<String>>,
        /// The whole IMU, the six columns found by name (gyro_x_dps, acc_z_g, ...).
        #[arg(long)]
        imu: bool,
        /// Unit of the gyro columns (default: from the name suffix _dps / _rads).
        #[arg(long, value_enum, conflicts_with = "column")]
        gyro_unit: Option<crate::identify::imu::Unit>,
        /// Unit of the accelerometer columns (default: from the name suffix _g / _mps2).
        #[arg(long, value_enum, conflicts_with = "column")]
        accel_unit: Option<crate::identify::imu::Unit>,
        /// Datasheet to set the figures against in datasheet.md (e.g. ADIS16405).
        #[arg(long, conflicts_with = "column")]
        reference: Option<String>,
        /// Sample rate [Hz].
        #[arg(long)]
        rate: f64,
        /// Factor applied to every value (give the factor to SI for a usable model.toml).
        #[arg(long, default_value_t = 1.0, conflicts_with_all = ["columns", "imu"])]
        scale: f64,
        /// Block-average factor for the ACF.
        #[arg(long, default_value_t = 1)]
        decimate: usize,
        /// gyro or accel (default: from the column name).
        #[arg(long, conflicts_with_all = ["columns", "imu"])]
        sensor: Option<String>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// IMU model files: from datasheet figures, or simulated into a static recording.
    Model {
        #[command(subcommand)]
        command: crate::datasheet_model::ModelCommand,
    },
    /// Run the firmware under QEMU on a log; writes the files of `run` plus firmware.json.
    Qemu {
        /// Log CSV.
        #[arg(long)]
        log: PathBuf,
        /// Model TOML.
        #[arg(long)]
        model: PathBuf,
        /// Identify the noise model online, starting from --model.
        #[arg(long)]
        adapt: bool,
        /// Identify with the global stage (implies --adapt; as `run --global`).
        #[arg(long)]
        global: bool,
        /// With the structure test (implies --global; as `run --structure`).
        #[arg(long)]
        structure: bool,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Firmware ELF (default: $IMU_IDENT_FIRMWARE_ELF, else the QEMU firmware in the target
        /// folder, built first when it is missing or older than its sources).
        #[arg(long)]
        elf: Option<PathBuf>,
    },
    /// Hide an effect in `paper` data, diagnose the nominal model, add the effect, rerun.
    Demo {
        /// The hidden effect, e.g. gyro/exp-cosine (default: drawn at random).
        #[arg(long)]
        effect: Option<String>,
        /// Seed (default: random, printed).
        #[arg(long)]
        seed: Option<u64>,
        /// Duration [h].
        #[arg(long, default_value_t = 12.0)]
        hours: f64,
        /// Output folder.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
    },
    /// Import the real RTKLIB drive (logger IMU CSV + .tag + RTKLIB .pos) into imu.csv,
    /// gnss.csv and meta.json (README "Strapdown INS/GNSS formats").
    ImportDrive {
        /// Logger IMU CSV (no header: ax,ay,az [g], gx,gy,gz [deg/s], tick [ms]).
        #[arg(long)]
        imu: PathBuf,
        /// Its binary time-tag file (default: the IMU path + ".tag").
        #[arg(long)]
        tag: Option<PathBuf>,
        /// RTKLIB .pos solution (llh, GPST).
        #[arg(long)]
        pos: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// IMU mounting roll,pitch,yaw [deg].
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_values_t = [180.0, 0.0, 180.0])]
        mount: Vec<f64>,
        /// Misalignment roll,pitch,yaw [deg], added angle by angle to --mount.
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.0, -6.79, 5.35])]
        misalign: Vec<f64>,
        /// Added to every IMU time [s] (logging delay).
        #[arg(long, allow_negative_numbers = true, default_value_t = -0.125)]
        imu_time_offset: f64,
        /// 1 g [m/s^2].
        #[arg(long, default_value_t = 9.80665)]
        g: f64,
        /// Keep .pos epochs with 1 <= Q <= MAX_Q (1 fix, 2 float, 5 single).
        #[arg(long, default_value_t = 2)]
        max_q: u8,
        /// IMU position from the body origin, forward,right,down [m].
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.0, 0.0, -0.65])]
        imu_lever: Vec<f64>,
        /// Antenna position from the body origin, forward,right,down [m].
        #[arg(long, value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.0, -0.05, -0.65])]
        antenna_lever: Vec<f64>,
    },
    /// Write a log as a navigation computer's serial wire (README "The serial wire"): an IMU
    /// frame per sample and each fix's UBX NAV-TIMEGPS + NAV-PVT, in arrival order; without
    /// --imu, a u-blox .ubx log of the fixes alone.
    Wire {
        /// IMU CSV or serial wire (omit for a .ubx log of the fixes).
        #[arg(long)]
        imu: Option<PathBuf>,
        /// GNSS CSV, RTKLIB .pos or .ubx.
        #[arg(long)]
        gnss: PathBuf,
        /// Each fix goes on the wire when the IMU passes its time plus this [s] (a receiver's
        /// latency; negative: ahead of the IMU).
        #[arg(long, allow_negative_numbers = true, default_value_t = 0.0)]
        delay: f64,
        /// Keep .pos epochs with 1 <= Q <= MAX_Q.
        #[arg(long, default_value_t = 2)]
        max_q: u8,
        /// A hub that counts its samples with its own timer instead of stamping them with GPS
        /// time (README "Samples counted by a hub's timer"): counted-sample frames, the
        /// receiver's pulse edges on that timer and its TIM-TP messages. The timer's frequency
        /// error [ppm]; an 84-MHz counter on an ordinary crystal (its noise drawn, seeded).
        #[arg(long, allow_negative_numbers = true)]
        hub_ppm: Option<f64>,
        /// Seed of the hub timer's noise and pulse jitter.
        #[arg(long, default_value_t = 1)]
        hub_seed: u64,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
    },
}
