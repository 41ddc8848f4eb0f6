//! What the navigation benches (`nav_adapt_bench`, `nav_change_bench`) share: a run's score
//! against the truth (the options of a run on a simulated drive are
//! `hal_sim::nav::NavArgs::simulated_drive`).

use hal_sim::nav::NavRun;
use hal_sim::nav_io::TruthRow;

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
