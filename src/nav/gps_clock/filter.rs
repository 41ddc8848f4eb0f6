//! The clock's two-state Kalman filter over one pulse (the model in the module docs of
//! [`gps_clock`](super)): kept relative to the last pulse fused, so that no quantity is
//! larger than the time between pulses.

/// The last pulse fused: its GPS time and count, and the filter there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Anchor {
    /// GPS time [s].
    pub t: f64,
    /// Extended count.
    pub count: u64,
    /// The filter's offset minus the pulse's own reading [s].
    pub resid: f64,
    /// Fractional frequency error.
    pub y: f64,
    /// Covariance of (offset, frequency).
    pub p: [[f64; 2]; 2],
}

/// A pulse through the filter of an [`Anchor`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Step {
    /// Innovation [s]: the pulse's offset reading minus the predicted offset.
    pub nu: f64,
    /// Its variance [s^2].
    pub s: f64,
    /// The predicted frequency variance (for a re-anchoring).
    pub p11: f64,
    /// The anchor after the update.
    pub next: Anchor,
}

impl Step {
    /// The pulse's Gaussian log-likelihood under the filter's model (nats, without the
    /// constant `-ln(2 pi) / 2`).
    pub fn log_likelihood(&self) -> f64 {
        -0.5 * (libm::log(self.s) + self.nu * self.nu / self.s)
    }
}

impl Anchor {
    /// Local seconds from this anchor's count to `count` (a counter at `hz`).
    pub fn local_since(&self, count: u64, hz: f64) -> f64 {
        // The extended counts' difference, signed: a count before the anchor is negative.
        (count.wrapping_sub(self.count) as i64) as f64 / hz
    }

    /// The first pulse of an acquisition: the offset its reading (variance `r`), the
    /// frequency unknown within `sd_freq`.
    pub fn first(t: f64, count: u64, r: f64, sd_freq: f64) -> Self {
        Self {
            t,
            count,
            resid: 0.0,
            y: 0.0,
            p: [[r, 0.0], [0.0, sd_freq * sd_freq]],
        }
    }

    /// The pulse at GPS time `t`, captured `dl` local seconds after this anchor's count, with
    /// white and random-walk frequency noise `q1`, `q2` and the capture's variance `R`:
    /// `Phi = [[1, dt], [0, 1]]`, the exact `Qd`, a Joseph-form update with `H = [1, 0]`.
    #[allow(non_snake_case)]
    pub fn step(&self, t: f64, count: u64, dl: f64, q1: f64, q2: f64, R: f64) -> Step {
        let dt = t - self.t;
        let p = self.p;
        let p00 =
            p[0][0] + 2.0 * dt * p[0][1] + dt * dt * p[1][1] + q1 * dt + q2 * dt * dt * dt / 3.0;
        let p01 = p[0][1] + dt * p[1][1] + q2 * dt * dt / 2.0;
        let p11 = p[1][1] + q2 * dt;
        let nu = dl - self.resid - dt * (1.0 + self.y);
        let s = p00 + R;
        let (k0, k1) = (p00 / s, p01 / s);
        // (I - K H) P (I - K H)' + K R K'.
        let g = 1.0 - k0;
        let n00 = g * g * p00 + k0 * k0 * R;
        let n01 = g * (p01 - k1 * p00) + k0 * k1 * R;
        let n11 = p11 - 2.0 * k1 * p01 + k1 * k1 * p00 + k1 * k1 * R;
        Step {
            nu,
            s,
            p11,
            next: Anchor {
                t,
                count,
                resid: -g * nu,
                y: self.y + k1 * nu,
                p: [[n00, n01], [n01, n11]],
            },
        }
    }

    /// Re-anchored at a refused step's pulse: the offset its reading, the frequency the
    /// refused pulses show (their drift over the gap), that drift's square added to its
    /// variance.
    pub fn reanchored(&self, step: &Step, r: f64) -> Self {
        let next = step.next;
        let dt = next.t - self.t;
        let dy = step.nu / dt;
        Self {
            resid: 0.0,
            y: self.y + dy,
            p: [[r, 0.0], [0.0, step.p11 + dy * dy + 2.0 * r / (dt * dt)]],
            ..next
        }
    }
}
