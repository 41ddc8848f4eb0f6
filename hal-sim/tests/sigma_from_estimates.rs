//! Issue 3 bar: sigma identified from the estimates of a filter running the true model is
//! unbiased within ±5 % once the filter's own P is added back (`sigma^2 = R0 + mean(P)`,
//! METHOD.md §4), while plain `R0` is biased low.
//!
//! Bound: over one 12-h run the relative standard deviation of a sample variance of a
//! Gauss-Markov process is about sqrt(2 tau / T) (0.068 for the accelerometer, 0.236 for the
//! gyro), i.e. half that for sigma; over 20 seeds the mean's standard error is 0.008 and 0.026.
//! A 5 % bias bound is then 6 and 2 standard errors.

use hal_sim::{replay, scenario, sim};
use imu_ident::autocorr::acf_batch;
use imu_ident::ident::sigma2;

#[test]
fn sigma_from_filter_estimates_is_unbiased_with_p_added() {
    let truth = scenario::load("paper").unwrap().to_core().unwrap();
    let true_sigma = [1e-3, 4.848_136_811_095_36e-7];
    let (mut plain, mut corrected) = ([0.0; 2], [0.0; 2]);
    let seeds = 20;
    for seed in 0..seeds {
        let log = sim::simulate(&truth, 43_200, 9000 + seed).unwrap();
        let (est, _) = replay::estimates::<f64>(&truth, &log).unwrap();
        // Skip the first hour: the initial covariance is not yet the filter's steady state.
        let est = &est[3600..];
        for (k, (x, p)) in [
            (
                est.iter().map(|e| e.da_hat).collect::<Vec<_>>(),
                est.iter().map(|e| e.sigma_da.powi(2)).collect::<Vec<_>>(),
            ),
            (
                est.iter().map(|e| e.dw_hat).collect(),
                est.iter().map(|e| e.sigma_dw.powi(2)).collect(),
            ),
        ]
        .into_iter()
        .enumerate()
        {
            let mut r = [0.0; 1];
            acf_batch(&x, &mut r).unwrap();
            let p_mean = p.iter().sum::<f64>() / p.len() as f64;
            let s = sigma2(r[0], p_mean).unwrap();
            plain[k] += s.r0.sqrt() / true_sigma[k] / seeds as f64;
            corrected[k] += s.corrected.sqrt() / true_sigma[k] / seeds as f64;
        }
    }
    println!("mean sigma / truth over {seeds} seeds: R0 only: accel {:.3}, gyro {:.3}; R0 + mean(P): accel {:.3}, gyro {:.3}", plain[0], plain[1], corrected[0], corrected[1]);
    for k in 0..2 {
        assert!(
            (corrected[k] - 1.0).abs() <= 0.05,
            "sensor {k}: bias {:.3}",
            corrected[k] - 1.0
        );
        assert!(plain[k] < corrected[k], "R0 alone must be the smaller");
    }
}
