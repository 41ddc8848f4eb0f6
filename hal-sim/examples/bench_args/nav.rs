//! What the navigation benches (`nav_adapt_bench`, `nav_change_bench`) share: the options of
//! a run on a simulated drive, and its score against the truth.

use hal_sim::nav::{NavArgs, NavRun};
use hal_sim::nav_io::outages::OutageSpec;
use hal_sim::nav_io::{GnssFix, TruthRow};
use imu_ident::nav::ImuErrorModel;
use std::path::Path;

/// The options of a run of `model` (named `name`) on the simulated drive written to `dir`
/// (`imu.csv`, `gnss.csv`; its fixes and truth as read back), with the benches' GNSS
/// outages every 20 min from the first fix.
pub fn simulated(
    dir: &Path,
    fixes: &[GnssFix],
    truth: &[TruthRow],
    model: ImuErrorModel<f64>,
    name: &str,
) -> NavArgs {
    NavArgs {
        outages: Some(OutageSpec::every_20_min(
            0.0,
            fixes.first().map_or(0.0, |f| f.t),
        )),
        ..NavArgs::simulated(
            dir.join("imu.csv"),
            dir.join("gnss.csv"),
            model,
            name,
            truth.first().map_or(0.0, |r| r.rpy_deg[2]),
        )
    }
}

/// Horizontal RMS [m], attitude RMS [deg], worst 3-sigma fraction of the 9 errors, over
/// epochs at or after `from`.
pub fn score(run: &NavRun, truth: &[TruthRow], from: f64) -> (f64, f64, f64) {
    let epochs: Vec<_> = run.epochs.iter().filter(|e| e.t >= from).cloned().collect();
    let c = hal_sim::nav::truth::compare(&epochs, truth, "truth.csv")
        .unwrap_or_else(|e| panic!("{e:#}"))
        .summary;
    let att = (c.rms_att_deg.iter().map(|x| x * x).sum::<f64>() / 3.0).sqrt();
    let worst = c.worst_outside_3sigma();
    if std::env::var("AXES").is_ok() {
        println!(
            "  outside 3 sigma: pos {:?} vel {:?} att {:?}; rms att {:?} deg",
            c.outside_3sigma_pos, c.outside_3sigma_vel, c.outside_3sigma_att, c.rms_att_deg
        );
    }
    (c.rms_horizontal_m, att, worst)
}
