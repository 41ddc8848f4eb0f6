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
    }
    Ok(())
}
