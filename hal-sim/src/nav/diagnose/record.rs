//! What `nav --diagnose` records ([`super`]): the candidates as fitted, the scores of the runs
//! before and after, the verdict (`diagnosis.json`), and its section of the report.

use super::AxisSplit;
use crate::nav::NavRun;
use imu_ident::model::Component;
use imu_ident::nav::ImuErrorModel;
use serde::Serialize;

/// One candidate effect, fitted (or why it was left out).
#[derive(Debug, Clone, Serialize)]
pub struct NavCandidate {
    /// `sensor/kind`, e.g. `accel/random-walk` (an addition), or `sensor/old->new`, e.g.
    /// `gyro/gauss-markov->exp-cosine` (a replacement, [`super::NavReplacement`]).
    pub label: String,
    /// Free parameters (tied over the three axes), the test's `k`; a replacement's is 3 in
    /// both directions ([`super::NavReplacement::k`]).
    pub n_params: usize,
    /// The fitted component (its quantities by name, SI units: rad/s for gyros, m/s^2 for
    /// accelerometers, s for correlation times); a replacement's on the x axis.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub component: Option<ComponentJson>,
    /// Log-likelihood with the candidate added, or the component replaced (gate off).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub loglik: Option<f64>,
    /// `loglik - loglik_model` [nats].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gain_nats: Option<f64>,
    /// Half the chi-square(`n_params`) `1 - ALPHA / m` quantile [nats].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub threshold_nats: Option<f64>,
    /// Gain above the threshold (or, with `--diagnose-axes`, the split's above its own).
    pub significant: bool,
    /// With `--diagnose-axes`: the gain of the candidate split over the axes (its magnitude
    /// per axis, `n_params + 2` parameters) over the model [nats].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_gain_nats: Option<f64>,
    /// With `--diagnose-axes`: half the chi-square(`n_params + 2`) `1 - ALPHA / m` quantile.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub split_threshold_nats: Option<f64>,
    /// Filter runs spent on it.
    pub evaluations: usize,
    /// What the fitted effect means physically.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub explanation: Option<String>,
    /// Why it was not tested.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub skipped: Option<&'static str>,
}

/// One form of a candidate in the naming rule (module docs of [`super`], item 4): tied over
/// the axes, or split.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Form {
    /// Gain over the model [nats].
    pub gain: f64,
    /// Its significance threshold [nats].
    pub threshold: f64,
    /// The candidate's parameters tied (Gauss-Markov 2, random walk and constant 1).
    pub k_tied: usize,
    /// The split form (two more parameters).
    pub split: bool,
}

impl Form {
    /// Free parameters.
    pub fn k(&self) -> usize {
        self.k_tied + if self.split { 2 } else { 0 }
    }

    /// `other` is a limit of `self`: a random walk or a random constant (fewer tied
    /// parameters) inside a Gauss-Markov, a tied form inside a split one but not the reverse.
    pub fn contains(&self, other: &Form) -> bool {
        other.k_tied < self.k_tied && (self.split || !other.split)
    }

    /// Half the chi-square(`k - other.k`) `1 - ALPHA` quantile: what `self` must gain over
    /// `other`, a limit of it, to be named instead.
    pub fn nested_threshold(&self, other: &Form) -> Option<f64> {
        let dk = self.k().checked_sub(other.k()).filter(|d| *d > 0)?;
        super::threshold_nested(dk).ok()
    }
}

impl NavCandidate {
    /// Records the tied fit: the component with what it means, the gain over the model,
    /// the threshold and the runs spent (the log-likelihood is set by the caller).
    pub(super) fn record_fit(
        &mut self,
        comp: Option<(&Component<f64>, String)>,
        gain: f64,
        threshold: f64,
        runs: usize,
    ) {
        self.component = comp.as_ref().map(|(c, _)| ComponentJson::of(c));
        self.explanation = comp.map(|(_, e)| e);
        self.gain_nats = Some(gain);
        self.threshold_nats = Some(threshold);
        self.significant = gain > threshold;
        self.evaluations = runs;
    }

    /// The significant form with the larger excess over its threshold (tied when neither is
    /// significant); `None` when not fitted.
    pub fn best_form(&self) -> Option<Form> {
        let tied = Form {
            gain: self.gain_nats?,
            threshold: self.threshold_nats?,
            k_tied: self.n_params,
            split: false,
        };
        let split = self
            .split_gain_nats
            .zip(self.split_threshold_nats)
            .map(|(gain, threshold)| Form {
                gain,
                threshold,
                k_tied: self.n_params,
                split: true,
            });
        Some(match split {
            Some(s) if s.gain - s.threshold > tied.gain - tied.threshold => s,
            _ => tied,
        })
    }
}

/// A component's quantities, for `diagnosis.json`.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ComponentJson {
    /// Kind name (model TOML).
    pub kind: &'static str,
    /// Standard deviation (stationary, constant or initial).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sigma: Option<f64>,
    /// Correlation time [s].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tau: Option<f64>,
    /// Random-walk intensity.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub q: Option<f64>,
    /// Oscillation period `2 pi / beta` [s] (exponential-cosine).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub period: Option<f64>,
}

impl ComponentJson {
    /// Its quantities by name, for the report (absent ones `None`).
    pub fn quantities(&self) -> [(&'static str, Option<f64>); 4] {
        [
            ("sigma", self.sigma),
            ("tau", self.tau),
            ("period", self.period),
            ("q", self.q),
        ]
    }

    /// The quantities of `c`.
    pub fn of(c: &Component<f64>) -> Self {
        let (sigma, tau, q) = match *c {
            Component::GaussMarkov(g) => (Some(g.sigma), Some(g.tau), None),
            Component::RandomWalk(r) => (Some(r.sigma0), None, Some(r.q)),
            Component::RandomConstant(r) => (Some(r.sigma), None, None),
            Component::ExpCosine(e) => (Some(e.sigma), Some(e.tau), None),
            Component::White(w) => (Some(w.density), None, None),
        };
        let period = match *c {
            Component::ExpCosine(e) if e.beta > 0.0 => Some(2.0 * std::f64::consts::PI / e.beta),
            _ => None,
        };
        Self {
            kind: c.kind().name(),
            sigma,
            tau,
            q,
            period,
        }
    }
}

/// The scores of one run, before or after the named effect is added.
#[derive(Debug, Clone, Serialize)]
pub struct RunScores {
    /// Innovation log-likelihood, gate off (the test's).
    pub loglik: f64,
    /// Mean per-axis NIS of the run (gated, as written): pos N, E, D, vel N, E, D.
    pub mean_nis_axis: [f64; 6],
    /// Horizontal error at the outage ends, RMS and max [m] (with `--outages`).
    pub outage_rms_m: Option<f64>,
    /// Max [m].
    pub outage_max_m: Option<f64>,
    /// RMS horizontal error against the truth [m] (with `--truth`).
    pub truth_rms_horizontal_m: Option<f64>,
    /// RMS roll, pitch, yaw error against the truth [deg] (with `--truth`).
    pub truth_rms_att_deg: Option<[f64; 3]>,
    /// The largest fraction of epochs outside 3 sigma over the nine position, velocity and
    /// attitude axes (with `--truth`; 0.0027 for a consistent filter).
    pub truth_outside_3sigma_max: Option<f64>,
    /// Mean NEES of the nine navigation errors (with `--truth`; 9 for a consistent filter).
    pub truth_nees_mean: Option<f64>,
    /// The mean NEES inside its 99 % band for the series' effective number of independent
    /// epochs (with `--truth`; `TruthSummary::nees_consistent`).
    pub truth_nees_consistent: Option<bool>,
}

impl RunScores {
    /// The scores of `run` (its truth summary, if attached) with the ungated `loglik`.
    pub fn of(run: &NavRun, loglik: f64) -> Self {
        let s = &run.summary;
        Self {
            loglik,
            mean_nis_axis: s.mean_nis_axis,
            outage_rms_m: s.outage_rms_m,
            outage_max_m: s.outage_max_m,
            truth_rms_horizontal_m: s.truth.as_ref().map(|t| t.rms_horizontal_m),
            truth_rms_att_deg: s.truth.as_ref().map(|t| t.rms_att_deg),
            truth_outside_3sigma_max: s.truth.as_ref().map(|t| {
                t.outside_3sigma_pos
                    .iter()
                    .chain(&t.outside_3sigma_vel)
                    .chain(&t.outside_3sigma_att)
                    .fold(0.0f64, |a, b| a.max(*b))
            }),
            truth_nees_mean: s.truth.as_ref().map(|t| t.nees_mean),
            truth_nees_consistent: s.truth.as_ref().map(|t| t.nees_consistent),
        }
    }
}

/// The verdict.
#[derive(Debug, Clone, Serialize)]
pub struct NavDiagnosis {
    /// `"adequate"`, `"missing-effect"` (an addition named) or `"wrong-kind"` (a
    /// replacement named).
    pub verdict: &'static str,
    /// The named change's label.
    pub named: Option<String>,
    /// Family-wise false-alarm probability of the tests.
    pub alpha: f64,
    /// Log-likelihood of the model as given (gate off).
    pub loglik_model: f64,
    /// Log-likelihood of the diagnosed model (gate off; `loglik_model` when adequate).
    pub loglik_diagnosed: f64,
    /// The addition (or replacement) of the same kind on the same sensor when its gain is
    /// within 3.3 nats of the named one's: the data do not tell whether the old component
    /// stays ([`super`] item 8).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tied_with: Option<String>,
    /// Every candidate, tested or not.
    pub candidates: Vec<NavCandidate>,
    /// Filter runs in all.
    pub evaluations: usize,
    /// The named effect split over the axes ([`super::axes`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axes: Option<AxisSplit>,
    /// The model as given.
    pub before: Option<RunScores>,
    /// With the named effect.
    pub after: Option<RunScores>,
    /// The model with the named change (the model as given when adequate).
    #[serde(skip)]
    pub model: ImuErrorModel<f64>,
}

impl NavDiagnosis {
    /// The named effect with the axes that carry it, e.g. `accel/random-walk on x`.
    pub fn named_on_axes(&self) -> Option<String> {
        let n = self.named.as_ref()?;
        Some(match &self.axes {
            Some(a) if a.significant => format!("{n} on {}", a.axes_label()),
            _ => n.clone(),
        })
    }

    /// The named change in words: `accel/random-walk on x added`, or
    /// `gyro/gauss-markov->exp-cosine (replaced)`.
    pub fn change(&self) -> Option<String> {
        let n = self.named_on_axes()?;
        Some(if self.verdict == "wrong-kind" {
            format!("{n} (replaced)")
        } else {
            format!("{n} added")
        })
    }

    /// The report's section: the verdict, the candidates, the scores before and after.
    pub fn html(&self) -> String {
        let num = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |x| format!("{x:.d$}"));
        let mut h =
            format!(
            "<p>Verdict: <b>{}</b>{}. Each candidate is added to the three axes of its sensor \
             (or, <code>old-&gt;new</code>, a component the three axes have is replaced by its \
             alternative kind, its values scaled alike on every axis), fitted by maximum likelihood and tested against the model: significant when its \
             gain exceeds half the chi-square(k) quantile at {} / m (m candidates tested; \
             <code>diagnosis.json</code>, <code>diagnosed-model.toml</code>). A candidate can \
             stand in for a magnitude that is only too small: diagnose a model whose \
             magnitudes are fitted (<code>--identify --diagnose</code>).</p><table><tr>\
             <th>candidate</th><th>k</th><th>fitted</th><th>gain [nats]</th>\
             <th>threshold [nats]</th><th>runs</th></tr>",
            self.verdict,
            self.change().map(|n| format!(": {n}")).unwrap_or_default(),
            self.alpha
        );
        for c in &self.candidates {
            let fitted = match (&c.component, c.skipped) {
                (_, Some(why)) => format!("not tested: {why}"),
                (Some(j), None) => j
                    .quantities()
                    .iter()
                    .filter_map(|(n, v)| v.map(|v| format!("{n} {v:.3e}")))
                    .collect::<Vec<_>>()
                    .join(", "),
                (None, None) => "-".to_string(),
            };
            let class = if c.significant { " class=\"bad\"" } else { "" };
            let split = |v: Option<f64>| v.map_or(String::new(), |x| format!("; split {x:.1}"));
            h += &format!(
                "<tr><td>{}</td><td>{}</td><td>{fitted}</td><td{class}>{}{}</td><td>{}{}</td><td>{}</td></tr>",
                c.label,
                c.n_params,
                num(c.gain_nats, 1),
                split(c.split_gain_nats),
                num(c.threshold_nats, 1),
                split(c.split_threshold_nats),
                c.evaluations
            );
        }
        h += "</table>";
        if let Some(t) = &self.tied_with {
            h += &format!(
                "<p>Tied with <b>{t}</b> (within 3.3 nats): both put the same kind of \
                 component on this sensor, and the data do not tell whether the model's old \
                 component stays.</p>"
            );
        }
        if let Some(a) = &self.axes {
            h += &a.html();
        }
        h += "<table><tr><th></th><th>log-likelihood</th><th>mean NIS per axis (pos N, E, D, vel N, E, D)</th><th>outage ends RMS / max [m]</th><th>horizontal RMS vs truth [m]</th><th>outside 3 sigma, worst axis</th><th>mean NEES (9)</th></tr>";
        for (name, s) in [
            ("model", &self.before),
            ("with the named change", &self.after),
        ] {
            if let Some(s) = s {
                let nis: Vec<String> = s.mean_nis_axis.iter().map(|v| format!("{v:.2}")).collect();
                h += &format!(
                    "<tr><td>{name}</td><td>{:.1}</td><td>{}</td><td>{} / {}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                    s.loglik,
                    nis.join(", "),
                    num(s.outage_rms_m, 2),
                    num(s.outage_max_m, 2),
                    num(s.truth_rms_horizontal_m, 2),
                    s.truth_outside_3sigma_max
                        .map_or("-".to_string(), |v| format!("{:.2} %", 100.0 * v)),
                    num(s.truth_nees_mean, 2)
                );
            }
        }
        h + "</table>"
    }
}
