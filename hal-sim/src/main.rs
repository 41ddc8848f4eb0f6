//! `hal-sim`: the imu-ident host test bed. See the README for the file formats.

use anyhow::Result;
use clap::{Parser, Subcommand};
use hal_sim::commands;
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "hal-sim", version, about = "Host test bed for imu-ident")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
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
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Simulate {
            scenario,
            hours,
            seed,
            out,
        } => {
            let n = commands::simulate(&scenario, hours, seed, &out)?;
            eprintln!("wrote {n} rows to {}", out.display());
        }
        Command::Run { log, model, out } => {
            let s = commands::run(&log, &model, &out)?;
            println!("{}", serde_json::to_string_pretty(&s)?);
        }
        Command::Diagnose { log, model, out } => {
            let d = commands::diagnose(&log, &model, &out)?;
            match (d.sensor, d.effect) {
                (Some(s), Some(e)) => println!("missing-effect: {s}/{e}: {}", d.explanation),
                _ => println!("adequate: {}", d.explanation),
            }
            println!(
                "wrote {}/diagnosis.json, suggested-model.toml, report.html",
                out.display()
            );
        }
        Command::Compare { log, model, out } => {
            print!("{}", commands::compare(&log, &model, &out)?);
            println!("report: {}", out.join("report.html").display());
        }
        Command::Demo {
            effect,
            seed,
            hours,
            out,
        } => commands::demo(effect.as_deref(), seed, hours, &out)?,
    }
    Ok(())
}
