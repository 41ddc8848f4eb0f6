//! `hal-sim`: the imu-ident host test bed. See the README for the file formats.
//!
//! This file dispatches each command to the library; the arguments are defined in
//! [`hal_sim::cli`].

use anyhow::{Context, Result};
use clap::Parser;
use hal_sim::cli::{Cli, Command};
use hal_sim::commands;

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
        Command::Nav {
            imu,
            gnss,
            model,
            outages,
            out,
            lever_arm,
            step,
            fix_interval,
            align,
            yaw,
            yaw_speed,
            no_static_gyro_bias,
            sd_att,
            sd_vel,
            sd_pos,
            gate,
            no_velocity,
            f32,
            max_q,
            gnss_sd_factor,
            identify,
            identify_axes,
            diagnose,
            diagnose_axes,
            nhc,
            nhc_lever,
            zupt,
            zupt_detector,
            scale_factors,
            imu_time_shift,
            truth,
            adapt,
            adapt_every,
            adapt_method,
            adapt_window,
            adapt_per_axis,
            adapt_tied_first,
            adapt_taus,
            adapt_memory,
            adapt_gnss_sd,
            adapt_flat_waits,
            adapt_exit_z,
            qemu_elf,
            present,
        } => {
            // Read first: a bad truth file should stop the command before the run.
            let truth_rows = truth
                .as_deref()
                .map(hal_sim::nav_io::read_truth_csv)
                .transpose()?;
            let three = |v: Vec<f64>, name: &str| -> Result<[f64; 3]> {
                <[f64; 3]>::try_from(v)
                    .map_err(|_| anyhow::anyhow!("--{name}: expected three numbers"))
            };
            let sd_att = three(sd_att, "sd-att")?;
            if let Some(sd) = nhc {
                if !(sd.is_finite() && sd > 0.0) {
                    anyhow::bail!("--nhc: expected a positive standard deviation, got {sd}");
                }
            }
            if !(fix_interval.is_finite() && fix_interval >= 0.0) {
                anyhow::bail!("--fix-interval: expected seconds >= 0, got {fix_interval}");
            }
            let zupt = zupt
                .map(|sd| -> Result<imu_ident::nav::Zupt<f64>> {
                    let [gyro_max, accel_max, speed_max] = three(zupt_detector, "zupt-detector")?;
                    imu_ident::nav::Zupt {
                        sd,
                        gyro_max,
                        accel_max,
                        speed_max,
                    }
                    .checked()
                    .map_err(|_| {
                        anyhow::anyhow!(
                            "--zupt, --zupt-detector: expected positive numbers, got {sd} and {gyro_max},{accel_max},{speed_max}"
                        )
                    })
                })
                .transpose()?;
            let nhc_lever = match nhc_lever {
                Some(v) => three(v, "nhc-lever")?,
                None => hal_sim::nav::nhc_lever_from_meta(&imu)?.unwrap_or([0.0; 3]),
            };
            let args = hal_sim::nav::NavArgs {
                imu,
                gnss,
                max_q,
                model: hal_sim::nav::model::load(&model)?,
                model_name: model,
                outages,
                lever_arm: three(lever_arm, "lever-arm")?,
                step,
                fix_interval,
                // `nav` is the batch run: every fix in time order, no budget.
                latency: 0.0,
                align,
                yaw_deg: yaw,
                yaw_speed,
                static_gyro_bias: !no_static_gyro_bias,
                init: imu_ident::nav::NavInit {
                    sd_att: nalgebra::Vector3::from(sd_att.map(f64::to_radians)),
                    sd_vel,
                    sd_pos,
                },
                gate: (gate > 0.0).then_some(gate),
                use_velocity: !no_velocity,
                single: f32,
                gnss_sd_factor: <[f64; 2]>::try_from(gnss_sd_factor)
                    .map_err(|_| anyhow::anyhow!("--gnss-sd-factor: expected two numbers"))?,
                scale_factor_sd: scale_factors
                    .map(|v| {
                        <[f64; 2]>::try_from(v)
                            .map_err(|_| anyhow::anyhow!("--scale-factors: expected two numbers"))
                    })
                    .transpose()?,
                imu_time_shift,
                nhc,
                nhc_lever,
                zupt,
                adapt: if adapt {
                    let bank = adapt_method == hal_sim::nav::adapt::AdaptMethod::Bank;
                    let cfg = hal_sim::nav::adapt::AdaptConfig::DEFAULT;
                    let default_every = if bank {
                        vec![cfg.bank.first, cfg.bank.every]
                    } else {
                        vec![cfg.first, cfg.every]
                    };
                    let [first, every] = <[f64; 2]>::try_from(adapt_every.unwrap_or(default_every))
                        .map_err(|_| anyhow::anyhow!("--adapt-every: expected FIRST,EVERY"))?;
                    if !(first > 0.0 && every > 0.0 && adapt_window > 0.0 && adapt_memory > 0.0) {
                        anyhow::bail!(
                            "--adapt-every, --adapt-window, --adapt-memory: expected positive seconds"
                        );
                    }
                    if !adapt_flat_waits && !bank {
                        anyhow::bail!(
                            "--adapt-flat-waits: the rule is the bank's; add --adapt-method bank"
                        );
                    }
                    if !(adapt_exit_z.is_finite() && adapt_exit_z >= 0.0) {
                        anyhow::bail!("--adapt-exit-z: expected a finite number >= 0");
                    }
                    if adapt_exit_z != imu_ident::nav::OnlineConfig::DEFAULT.exit_z && !bank {
                        anyhow::bail!(
                            "--adapt-exit-z: the rule is the bank's; add --adapt-method bank"
                        );
                    }
                    if adapt_memory.is_finite() && !bank {
                        anyhow::bail!(
                            "--adapt-memory: the window's memory is the bank's; add \
                             --adapt-method bank"
                        );
                    }
                    if adapt_tied_first && !(bank && adapt_per_axis && qemu_elf.is_none()) {
                        anyhow::bail!(
                            "--adapt-tied-first: the switch from the tied bank to the per-axis \
                             one runs on the host; use it with --adapt-method bank and \
                             --adapt-per-axis, without --qemu-elf"
                        );
                    }
                    if qemu_elf.is_some() && !bank {
                        anyhow::bail!(
                            "--adapt with --qemu-elf: the firmware runs the core's bank, not the \
                             host's window replay; add --adapt-method bank"
                        );
                    }
                    Some(hal_sim::nav::adapt::AdaptConfig {
                        first,
                        every,
                        window: adapt_window,
                        per_axis: adapt_per_axis,
                        tied_first: adapt_tied_first,
                        taus: adapt_taus,
                        method: adapt_method,
                        bank: imu_ident::nav::OnlineConfig {
                            first,
                            every,
                            memory: adapt_memory,
                            flat_waits: adapt_flat_waits,
                            exit_z: adapt_exit_z,
                            ..cfg.bank
                        },
                        gnss_sd: adapt_gnss_sd,
                        ..cfg
                    })
                } else {
                    None
                },
            };
            // Checked before the run, which it follows.
            let present = present
                .map(|p| {
                    <[f64; 2]>::try_from(p)
                        .ok()
                        .filter(|[d, l]| d.is_finite() && l.is_finite() && *l >= 0.0)
                        .ok_or_else(|| {
                            anyhow::anyhow!(
                                "--present: expected DELAY,LATENCY, finite, LATENCY >= 0"
                            )
                        })
                })
                .transpose()?;
            let identify = identify.then_some(if identify_axes {
                hal_sim::nav::identify::Axes::Tested
            } else {
                hal_sim::nav::identify::Axes::Tied
            });
            if diagnose {
                let d = hal_sim::nav::diagnose::run_diagnosed(
                    &args,
                    identify,
                    diagnose_axes,
                    truth_rows.as_deref(),
                    truth.as_deref(),
                    &out,
                )?;
                eprintln!(
                    "diagnosis: {}{}{} (loglik {:.1} -> {:.1}, {} runs); diagnosis.json, diagnosed-model.toml",
                    d.verdict,
                    d.named_on_axes().map(|n| format!(": {n}")).unwrap_or_default(),
                    d.tied_with.as_ref().map(|t| format!(", tied with {t}")).unwrap_or_default(),
                    d.loglik_model,
                    d.after.as_ref().or(d.before.as_ref()).map_or(f64::NAN, |s| s.loglik),
                    d.evaluations
                );
                return Ok(());
            }
            let (mut run, id) = if let Some(axes) = identify {
                let (run, id) = hal_sim::nav::run_identified(&args, axes, &out)?;
                eprintln!("{}", id.summary_line());
                (run, Some(id))
            } else {
                (hal_sim::nav::run(&args)?, None)
            };
            let cmp = match (&truth, &truth_rows) {
                (Some(p), Some(rows)) => Some(hal_sim::nav::truth::attach(&mut run, rows, p)?),
                _ => None,
            };
            hal_sim::nav::records::write_outputs(&out, &run, cmp.as_ref(), id.as_ref(), &[])?;
            println!("{}", serde_json::to_string_pretty(&run.summary)?);
            if let Some([delay, latency]) = present {
                let s = hal_sim::present::write_present(
                    &args,
                    truth_rows.as_deref(),
                    (delay, latency),
                    &out,
                )?;
                eprintln!("{s}");
            }
            if let Some(elf) = qemu_elf {
                let imu = hal_sim::nav_io::read_imu_any(&args.imu)?;
                let fixes = hal_sim::nav_io::read_gnss_any(&args.gnss, args.max_q)?;
                let fw = hal_sim::nav_qemu::compare_with_host(&elf, &args, &imu, &fixes, &run)?;
                hal_sim::output::write_string(
                    &out.join("firmware.json"),
                    &serde_json::to_string_pretty(&fw)?,
                )?;
                eprintln!(
                    "firmware: exit {}, {} epochs, worst position difference from the host {:.2e} sigma",
                    if fw.exit_success { "ok" } else { "FAILED" },
                    fw.epochs[0],
                    fw.worst_position_diff_sigma
                );
                if let Some(o) = &fw.online {
                    eprintln!(
                        "firmware: {} online decisions (host {}), worst factor difference {:.2e} decade, {} identifiable flags differ",
                        o.decisions[0], o.decisions[1], o.worst_factor_diff_decades, o.flags_differ
                    );
                }
                if !fw.exit_success {
                    anyhow::bail!(
                        "the navigation firmware failed (see {})",
                        out.join("firmware.json").display()
                    );
                }
            }
        }
        Command::SimulateDrive {
            hours,
            rate,
            seed,
            outage,
            lever_arm,
            out,
        } => {
            let arm = <[f64; 3]>::try_from(lever_arm.as_slice())
                .map_err(|_| anyhow::anyhow!("--lever-arm takes three numbers"))?;
            let (n, g) = hal_sim::trajectory::write::simulate_drive_files(
                hours,
                rate,
                seed,
                (outage, arm),
                &out,
            )?;
            eprintln!("wrote {n} IMU rows and {g} GNSS fixes to {}", out.display());
        }
        Command::Run {
            log,
            model,
            out,
            adapt,
            global,
            structure,
            truth,
        } => {
            let ident = hal_sim::qemu::Ident::from_flags(adapt, global, structure);
            let s = commands::run(&log, &model, &out, ident, truth.as_deref())?;
            println!("{}", serde_json::to_string_pretty(&s)?);
        }
        Command::Qemu {
            log,
            model,
            adapt,
            global,
            structure,
            out,
            elf,
        } => {
            let ident = hal_sim::qemu::Ident::from_flags(adapt, global, structure);
            let s = commands::qemu(&log, &model, ident, &out, elf)?;
            println!("{}", serde_json::to_string_pretty(&s)?);
        }
        Command::Figures { seed, out } => {
            hal_sim::figures::write(&out, seed)?;
            println!(
                "wrote {}/fig3_acf.svg, fig4_mismatched.svg, fig5_adaptive.svg",
                out.display()
            );
        }
        Command::Diagnose { log, model, out } => {
            let d = commands::diagnose(&log, &model, &out)?;
            match (d.sensor, d.effect) {
                (Some(s), Some(e)) => println!("{}: {s}/{e}: {}", d.verdict, d.explanation),
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
        Command::Model { command } => command.run()?,
        Command::Identify {
            series,
            column: None,
            columns,
            imu,
            gyro_unit,
            accel_unit,
            reference,
            rate,
            decimate,
            out,
            quiet,
            ..
        } => {
            let args = hal_sim::identify::imu::ImuArgs {
                series,
                columns: if imu { None } else { columns },
                rate,
                gyro_unit,
                accel_unit,
                decimate,
                out,
                quiet,
                reference,
            };
            let s = hal_sim::identify::imu::run(&args)?;
            print!("{}", hal_sim::identify::imu::report(&s));
            println!(
                "read {} bytes, {} rows in one pass; wrote {}/<axis>/..., imu-model.toml, kalibr-imu.yaml, datasheet.md, datasheet.json",
                s.read.bytes,
                s.read.rows,
                args.out.display()
            );
        }
        Command::Identify {
            series,
            column: Some(column),
            rate,
            scale,
            decimate,
            sensor,
            out,
            quiet,
            ..
        } => {
            use hal_sim::identify::{run, IdentifyArgs, SensorArg};
            let sensor = match sensor.as_deref() {
                None => None,
                Some("gyro") => Some(SensorArg::Gyro),
                Some("accel") => Some(SensorArg::Accel),
                Some(o) => anyhow::bail!("--sensor: expected gyro or accel, found '{o}'"),
            };
            let args = IdentifyArgs {
                series,
                column,
                rate,
                scale,
                decimate,
                out,
                quiet,
                sensor,
            };
            let s = run(&args)?;
            for c in &s.components {
                println!("{}: {}", c.label, c.explanation);
            }
            println!(
                "model inside the ADEV 95 % CI at {:.0} % of {} taus; wrote {}/adev.csv, acf.csv, model.toml, summary.json, adev.svg, acf.svg",
                100.0 * s.inside_ci,
                s.taus,
                args.out.display()
            );
        }
        Command::Demo {
            effect,
            seed,
            hours,
            out,
        } => commands::demo(effect.as_deref(), seed, hours, &out)?,
        Command::Wire {
            imu,
            gnss,
            delay,
            max_q,
            hub_ppm,
            hub_seed,
            out,
        } => {
            let fixes = hal_sim::nav_io::read_gnss_any(&gnss, max_q)?;
            let samples = match &imu {
                Some(p) => hal_sim::nav_io::read_imu_any(p)?,
                None => vec![],
            };
            let bytes = match (hub_ppm, samples.first()) {
                (None, _) => hal_sim::nav_io::ubx::serial_stream(&samples, &fixes, delay),
                (Some(ppm), Some(first)) => {
                    use hal_sim::trajectory::oscillator::Oscillator;
                    use imu_ident::nav::gps_clock::ClockConfig;
                    if !ppm.is_finite() || ppm.abs() > 1e3 {
                        anyhow::bail!(
                            "--hub-ppm {ppm}: a crystal's frequency error within +-1000 ppm"
                        );
                    }
                    let cfg = ClockConfig::crystal(hal_sim::nav_io::ubx::HUB_TIMER_HZ);
                    let spec = hal_sim::clock::oscillator_spec(&cfg, ppm * 1e-6, 1.0);
                    let mut osc = Oscillator::new(spec, first.t - 2.0, hub_seed);
                    hal_sim::clock::counted_stream(&samples, &fixes, delay, &mut osc)
                }
                (Some(_), None) => {
                    anyhow::bail!("--hub-ppm needs --imu (a hub counts IMU samples)")
                }
            }
            .with_context(|| format!("{}", gnss.display()))?;
            std::fs::write(&out, &bytes).with_context(|| format!("writing {}", out.display()))?;
            let kind = match hub_ppm {
                Some(_) => "counted-sample frames (and a pulse edge and TIM-TP a second)",
                None => "IMU frames",
            };
            println!(
                "wrote {}: {} {kind}, {} fixes (NAV-TIMEGPS + NAV-PVT), {} bytes",
                out.display(),
                samples.len(),
                fixes.len(),
                bytes.len()
            );
        }
        Command::ImportDrive {
            imu,
            tag,
            pos,
            out,
            mount,
            misalign,
            imu_time_offset,
            g,
            max_q,
            imu_lever,
            antenna_lever,
        } => {
            let tag = tag.unwrap_or_else(|| {
                let mut p = imu.clone().into_os_string();
                p.push(".tag");
                p.into()
            });
            let three = |v: Vec<f64>, name: &str| -> Result<[f64; 3]> {
                <[f64; 3]>::try_from(v)
                    .map_err(|_| anyhow::anyhow!("--{name}: expected three numbers"))
            };
            let mut opt = hal_sim::nav_io::drive::DriveImport::drive_0708(imu, tag, pos, out);
            opt.mount_deg = three(mount, "mount")?;
            opt.misalign_deg = three(misalign, "misalign")?;
            opt.imu_time_offset = imu_time_offset;
            opt.g = g;
            opt.max_q = max_q;
            opt.imu_lever = three(imu_lever, "imu-lever")?;
            opt.antenna_lever = three(antenna_lever, "antenna-lever")?;
            let m = hal_sim::nav_io::drive::import(&opt)?;
            println!(
                "IMU: {} samples over {:.3} s from {} GPST ({:+.3} s after the first GNSS epoch, then {:+.3} s offset); GNSS: {} of {} epochs written ({} fixed, {} float)",
                m.imu_samples,
                m.imu_span,
                m.imu_start_gpst,
                m.imu_start_after_gnss,
                opt.imu_time_offset,
                m.gnss_epochs,
                m.pos_epochs,
                m.pos_fixed,
                m.pos_float
            );
            println!(
                "wrote {0}/imu.csv, {0}/gnss.csv, {0}/meta.json",
                opt.out.display()
            );
        }
    }
    Ok(())
}
