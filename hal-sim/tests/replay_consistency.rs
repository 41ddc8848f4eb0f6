//! One replay rule for every command (issue 14): a 3-h `paper` log (seeded) with a 1-min gap, a
//! 2-day clock jump, a repeated and a backwards time stamp gives the same ticks, the same
//! estimates and the same innovation log-likelihood through `run`, `compare` and `diagnose`.
//!
//! The three go through one driver (`hal_sim::replay`, i.e. the firmware's
//! `Estimator::push`, in f64) and one likelihood definition (`records::log_likelihood`), so
//! equality is asserted exactly (bitwise): any difference is a second code path.
//!
//! `cargo test -p hal-sim --test host replay_consistency:: -- --nocapture`

use hal_sim::log::{self, LogRow};
use hal_sim::records::{self, EstimateRow, RunCounts};
use hal_sim::{commands, compare, diagnose, replay, scenario, sim};
use std::path::Path;

const HOURS: usize = 3;
const SEED: u64 = 14;
const DAY: f64 = 86_400.0;

/// The log and what its time defects must do: (rows removed for the gap, rows skipped).
fn defective_log() -> Vec<LogRow> {
    let model = scenario::load("paper").unwrap().to_core().unwrap();
    let mut rows = sim::simulate(&model, HOURS * 3600, SEED).unwrap();
    // 2-day jump of the clock from row 7000 on (a reset clock or a long outage).
    for r in &mut rows[7000..] {
        r.t += 2.0 * DAY;
    }
    // A backwards time stamp (5 s behind) before row 5000, a repeated one before row 4000.
    let back = LogRow {
        t: rows[4999].t - 5.0,
        ..rows[4999]
    };
    rows.insert(5000, back);
    let again = rows[3999];
    rows.insert(4000, again);
    // A 1-min gap: 60 rows missing after row 1999.
    rows.drain(2000..2060);
    rows
}

fn read_estimates(path: &Path) -> Vec<EstimateRow> {
    let mut rdr = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = rdr.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(
        header.join(","),
        "t,dv_hat,delta_hat,da_hat,dw_hat,sigma_dv,sigma_delta,sigma_da,sigma_dw,innovation,innovation_var,nis,flags"
    );
    rdr.records()
        .map(|r| {
            let r = r.unwrap();
            let f = |i: usize| r[i].parse::<f64>().unwrap();
            EstimateRow {
                t: f(0),
                dv_hat: f(1),
                delta_hat: f(2),
                da_hat: f(3),
                dw_hat: f(4),
                sigma_dv: f(5),
                sigma_delta: f(6),
                sigma_da: f(7),
                sigma_dw: f(8),
                innovation: f(9),
                innovation_var: f(10),
                nis: f(11),
                flags: r[12].parse().unwrap(),
            }
        })
        .collect()
}

/// Bitwise equality of two estimate tables (NaN equal to NaN of the same bits).
fn assert_same_estimates(a: &[EstimateRow], b: &[EstimateRow], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: number of ticks");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let fx = [
            x.t,
            x.dv_hat,
            x.delta_hat,
            x.da_hat,
            x.dw_hat,
            x.sigma_dv,
            x.sigma_delta,
            x.sigma_da,
            x.sigma_dw,
            x.innovation,
            x.innovation_var,
            x.nis,
        ];
        let fy = [
            y.t,
            y.dv_hat,
            y.delta_hat,
            y.da_hat,
            y.dw_hat,
            y.sigma_dv,
            y.sigma_delta,
            y.sigma_da,
            y.sigma_dw,
            y.innovation,
            y.innovation_var,
            y.nis,
        ];
        let same = fx
            .iter()
            .zip(&fy)
            .all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()));
        assert!(
            same && x.flags == y.flags,
            "{what}: tick {i} differs: {x:?} vs {y:?}"
        );
    }
}

#[test]
fn run_compare_and_diagnose_replay_the_same_ticks() {
    let dir = tempfile::tempdir().unwrap();
    let rows = defective_log();
    let log_path = dir.path().join("log.csv");
    log::write(&log_path, &rows).unwrap();
    // What the commands read back is what they run on (the CSV round-trips f64 exactly).
    let rows = log::read(&log_path).unwrap();
    let model_path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/paper.toml"));
    let model = hal_sim::model_toml::load(model_path).unwrap();

    // `run`, through its library function: files on disk.
    let out = dir.path().join("run");
    let summary =
        commands::run(&log_path, model_path, &out, hal_sim::qemu::Ident::Off, None).unwrap();
    let run_est = read_estimates(&out.join("estimates.csv"));
    let run_counts: RunCounts = RunCounts {
        steps: summary["counts"]["steps"].as_u64().unwrap() as usize,
        rows: summary["counts"]["rows"].as_u64().unwrap() as usize,
        updated: summary["counts"]["updated"].as_u64().unwrap() as usize,
        missing: summary["counts"]["missing"].as_u64().unwrap() as usize,
        bridged: summary["counts"]["bridged"].as_u64().unwrap() as usize,
        gated: summary["counts"]["gated"].as_u64().unwrap() as usize,
        gaps: summary["counts"]["gaps"].as_u64().unwrap() as usize,
        time_jumps: summary["counts"]["time_jumps"].as_u64().unwrap() as usize,
        skipped_time: summary["counts"]["skipped_time"].as_u64().unwrap() as usize,
        repairs: summary["counts"]["repairs"].as_u64().unwrap() as usize,
        sensor_changes: summary["counts"]["sensor_changes"].as_u64().unwrap() as usize,
        not_identifiable: summary["counts"]["not_identifiable"].as_u64().unwrap() as usize,
    };
    let (run_ll, run_n) = records::log_likelihood(&run_est);
    println!("run: {run_counts:?}, log-likelihood {run_ll} over {run_n} innovations");

    // The time rules of the step, on this log: the gap bridges 60 ticks, the confirmed 2-day
    // jump bridges the longest bridge (one day) and ticks its row flagged `time_jump`; the
    // repeated and the backwards stamps and the first row after the jump (suspect until the
    // next row confirms it) are skipped.
    let max_bridge = imu_ident::step::StepConfig::<f64>::default().max_bridge as usize;
    assert_eq!(run_counts.skipped_time, 3);
    assert_eq!(run_counts.rows, rows.len() - 3);
    assert_eq!(run_counts.bridged, 60 + max_bridge);
    assert_eq!(run_counts.gaps, 2);
    assert_eq!(run_counts.time_jumps, 1);
    assert_eq!(run_counts.steps, run_counts.rows + run_counts.bridged);
    assert_eq!(run_counts.steps, run_est.len());
    assert!(run_counts.missing >= run_counts.bridged);
    let bridged: Vec<&EstimateRow> = run_est.iter().filter(|e| e.is_bridged()).collect();
    assert_eq!(bridged.len(), run_counts.bridged);
    assert!(bridged
        .iter()
        .all(|e| e.innovation.is_nan() && e.nis.is_nan()));
    // The 1-min gap: rows 2000..2060 (t = 2001..2060) are ticks without an observation.
    let gap_t: Vec<f64> = bridged.iter().take(60).map(|e| e.t).collect();
    assert_eq!(gap_t, (2001..=2060).map(f64::from).collect::<Vec<_>>());

    // `compare`, through its library function.
    let cmp = compare::evaluate("paper", &model, &rows).unwrap();
    assert_same_estimates(&run_est, &cmp.estimates, "run vs compare");
    assert_eq!(cmp.summary.counts, run_counts, "run vs compare counts");
    assert_eq!(
        cmp.summary.steps,
        summary["steps"].as_u64().unwrap() as usize
    );
    assert_eq!(
        cmp.log_likelihood.to_bits(),
        run_ll.to_bits(),
        "run vs compare likelihood"
    );

    // The streaming likelihood of the diagnosis' fits: the same number.
    let (fit_ll, fit_n) = replay::log_likelihood(&model, &rows).unwrap();
    assert_eq!((fit_ll.to_bits(), fit_n), (run_ll.to_bits(), run_n));

    // `diagnose`, through its library function.
    let d = diagnose::diagnose(&model, &rows).unwrap();
    println!(
        "diagnose: log-likelihood {} over {} innovations, verdict {}",
        d.evidence.log_likelihood, d.evidence.n, d.verdict
    );
    assert_eq!(
        (d.evidence.log_likelihood.to_bits(), d.evidence.n),
        (run_ll.to_bits(), run_n),
        "run vs diagnose likelihood"
    );
    let windows = |w: &[diagnose::whiteness::NisWindow]| -> Vec<(u64, u64)> {
        w.iter()
            .map(|x| (x.t_start.to_bits(), x.nis_mean.to_bits()))
            .collect()
    };
    assert_eq!(
        windows(&d.evidence.nis_windows),
        windows(&cmp.nis_windows),
        "diagnose vs compare NIS windows"
    );
    assert_eq!(
        d.evidence.whiteness.p_value.to_bits(),
        cmp.whiteness.p_value.to_bits()
    );
}
