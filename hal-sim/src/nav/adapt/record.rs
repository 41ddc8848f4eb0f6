//! The record of the online identification: `adapt.csv` and the report's section
//! (`adapt.json` is [`AdaptLog`]'s serialisation).

use super::{apply, gnss_factors, AdaptLog, Coordinate, Search};
use anyhow::Result;
use imu_ident::nav::ImuErrorModel;

impl AdaptLog {
    /// `adapt.csv`: one row per search (time and window start [s], fixes, window
    /// log-likelihoods of the model before, of the best found and of the model taken,
    /// replays, the correlation-time test), then the value of every coordinate's quantity
    /// after the search in SI units ([`Coordinate::column`]; a GNSS coordinate: the factor on
    /// the fixes' standard deviations), then every coordinate's
    /// Cramér-Rao sd of its log10 factor (`..._sd_log10`).
    pub fn write_csv(&self, path: &std::path::Path) -> Result<()> {
        let mut w =
            csv::Writer::from_path(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        let mut head: Vec<String> = [
            "t",
            "window_start",
            "fixes",
            "loglik_before",
            "loglik_max",
            "loglik",
            "evaluations",
            "tau_gain",
            "tau_threshold",
            "taus_moved",
        ]
        .map(String::from)
        .to_vec();
        head.extend(self.coordinates.iter().map(Coordinate::column));
        // Then the Cramér-Rao sd of each coordinate's log10 factor (`inf`: not bounded).
        head.extend(
            self.coordinates
                .iter()
                .map(|c| format!("{}_sd_log10", c.column())),
        );
        w.write_record(&head)?;
        for s in &self.searches {
            let mut row = vec![
                s.t.to_string(),
                s.window_start.to_string(),
                s.fixes.to_string(),
                s.loglik_before.to_string(),
                s.loglik_max.to_string(),
                s.loglik.to_string(),
                s.evaluations.to_string(),
            ];
            // Empty unless the correlation times were tested (TauMode::Tested).
            let t = s.tau_test;
            row.push(t.map_or(String::new(), |t| t.gain.to_string()));
            row.push(t.map_or(String::new(), |t| t.threshold.to_string()));
            row.push(t.map_or(String::new(), |t| u8::from(t.moved).to_string()));
            let m = apply(&self.base, &self.coordinates, &s.log10_factors);
            let g = gnss_factors(
                self.gnss_sd_factor_start,
                &self.coordinates,
                &s.log10_factors,
            );
            for c in &self.coordinates {
                row.push(value(&m, g, c).to_string());
            }
            for sd in &s.cr_sd_log10 {
                row.push(sd.to_string());
            }
            w.write_record(&row)?;
        }
        w.flush()?;
        Ok(())
    }
}

/// The value of coordinate `c` at a point whose model is `m` and whose GNSS factors are `gnss`
/// ([`gnss_factors`]): an IMU quantity on its first axis, or a factor on the fixes' standard
/// deviations.
pub fn value(m: &ImuErrorModel<f64>, gnss: [f64; 2], c: &Coordinate) -> f64 {
    let (s, q) = match c.target {
        super::Target::Imu(k) => (k.sensor, k.quantity),
        super::Target::GnssSd(i) => return gnss.get(i).copied().unwrap_or(f64::NAN),
    };
    c.axes
        .first()
        .and_then(|&a| m.sensor(s).get(a))
        .and_then(|axis| axis.get(c.component))
        .and_then(|comp| comp.get(q))
        .unwrap_or(f64::NAN)
}

impl AdaptLog {
    /// The factors on the GNSS standard deviations in use at the end (`--gnss-sd-factor`
    /// times the last search's GNSS factors).
    pub fn gnss_sd_factor_end(&self) -> [f64; 2] {
        let x = self
            .searches
            .last()
            .map_or(&[][..], |s| &s.log10_factors[..]);
        gnss_factors(self.gnss_sd_factor_start, &self.coordinates, x)
    }

    /// The coordinates search `s` flagged as not identifiable, with their Cramér-Rao sd
    /// (`none` when all were bounded).
    fn flat_names(&self, s: &Search) -> String {
        let names: Vec<String> = self
            .coordinates
            .iter()
            .zip(s.identifiable.iter().zip(&s.cr_sd_log10))
            .filter(|(_, (ok, _))| !**ok)
            .map(|(c, (_, sd))| {
                let sd = if sd.is_finite() {
                    format!("sd {sd:.2}")
                } else {
                    String::from("unbounded")
                };
                format!("{} ({sd})", c.label())
            })
            .collect();
        if names.is_empty() {
            String::from("none")
        } else {
            names.join(", ")
        }
    }

    /// The report's section: the values over time (log10 of each coordinate's factor on the
    /// starting model, tied) and one table row per search. Times from `t0` [s].
    pub fn html_section(&self, t0: f64) -> Result<String> {
        let lines: Vec<crate::nav::plot::Line> = self
            .coordinates
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let mut pts = vec![(0.0, 0.0)];
                pts.extend(self.searches.iter().map(|s| {
                    (
                        s.t - t0,
                        s.log10_factors.get(i).copied().unwrap_or(f64::NAN),
                    )
                }));
                (c.label(), pts)
            })
            .collect();
        let mut h = String::from(
            "<p>Online identification (<code>adapt.json</code>, <code>adapt.csv</code>, <code>adapt-model.toml</code>): each search maximises the innovation log-likelihood of its window, using only the data up to its time; the running filter takes its answer.</p>",
        );
        h += &crate::nav::plot::chart(
            "Identified factors on the starting model",
            "time from t0 [s]",
            "log10 factor",
            &lines,
            &[],
            true,
        )?;
        h += "<table><tr><th>t [s]</th><th>window from [s]</th><th>fixes</th><th>log-likelihood before</th><th>best</th><th>taken</th><th>replays</th><th>correlation times: gain / threshold</th><th>not identifiable yet (Cramér-Rao sd of the log10 factor &gt; 0.5)</th></tr>";
        for s in &self.searches {
            h += &format!(
                "<tr><td>{:.0}</td><td>{:.0}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                s.t - t0,
                s.window_start - t0,
                s.fixes,
                crate::report::sig4(s.loglik_before, "nats"),
                crate::report::sig4(s.loglik_max, "nats"),
                crate::report::sig4(s.loglik, "nats"),
                s.evaluations,
                s.tau_test.map_or(String::from("held or free"), |t| format!(
                    "{:.1} / {:.1} nats: {}",
                    t.gain,
                    t.threshold,
                    if t.moved { "moved" } else { "held" }
                )),
                self.flat_names(s)
            );
        }
        Ok(h + "</table>")
    }
}
