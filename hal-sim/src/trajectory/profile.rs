//! Smooth vehicle motion from segments: speed `s`, heading `psi` and flight-path angle `gamma`
//! driven by their rates (longitudinal acceleration, turn rate, climb-angle rate), each of which
//! moves between constant levels along the smooth step
//!
//! ```text
//! S(u) = u - sin(2 pi u) / (2 pi),   S'(u) = 1 - cos(2 pi u),   S''(u) = 2 pi sin(2 pi u)
//! ```
//!
//! over a piece `u = (t - t0) / T in [0, 1]`. `S'` and `S''` vanish at both ends, so the rates
//! and their first two derivatives are continuous everywhere: the body rate (which contains the
//! roll rate, hence `psi''`) and the specific force (which contains `s'`, `psi'`, `gamma'`) are
//! continuous with continuous first derivatives, which is what lets the simulator integrate
//! exact IMU increments. The values have closed forms,
//! `x(t) = x0 + r0 tau + (r1 - r0) T I(u)` with `I(u) = u^2/2 + (cos(2 pi u) - 1)/(4 pi^2)`.
//!
//! Attitude: yaw = heading, pitch = flight-path angle (no sideslip, no angle of attack), roll
//! from the coordinated-turn relation `tan(roll) = bank s psi' / g0` (`bank = 1` for an
//! aircraft, `0` for a level ground vehicle).

use anyhow::{bail, Result};
use std::f64::consts::PI;

/// Standard gravity used by the coordinated-turn roll [m/s^2].
const G0: f64 = imu_ident::model::ins::G0;

/// One piece: over `duration` the three rates move smoothly from the previous piece's end
/// values to these.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Piece {
    /// Length [s].
    pub duration: f64,
    /// Longitudinal acceleration `s'` at the end [m/s^2].
    pub accel: f64,
    /// Turn rate `psi'` at the end [rad/s].
    pub turn_rate: f64,
    /// Flight-path-angle rate `gamma'` at the end [rad/s].
    pub climb_rate: f64,
}

/// The kinematic state at one time and the derivatives the IMU model needs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Kinematics {
    /// Speed [m/s] and its rate.
    pub s: f64,
    /// `s'` [m/s^2].
    pub sd: f64,
    /// Heading [rad] (unwrapped), `psi'`, `psi''`.
    pub psi: f64,
    /// `psi'` [rad/s].
    pub psid: f64,
    /// `psi''` [rad/s^2].
    pub psidd: f64,
    /// Flight-path angle [rad], `gamma'`.
    pub gamma: f64,
    /// `gamma'` [rad/s].
    pub gammad: f64,
    /// Roll [rad] and roll rate [rad/s].
    pub roll: f64,
    /// Roll rate [rad/s].
    pub rolld: f64,
}

/// A start state and a list of pieces.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    speed0: f64,
    heading0: f64,
    gamma0: f64,
    bank: f64,
    /// Transition time of the composite segments [s].
    pub transition: f64,
    pieces: Vec<Piece>,
    /// Per piece: start time, start values (s, psi, gamma) and start rates.
    starts: Vec<(f64, [f64; 3], [f64; 3])>,
}

/// `(S(u), S'(u), I(u))` of the module docs.
fn smooth(u: f64) -> (f64, f64, f64) {
    let w = 2.0 * PI * u;
    (
        u - w.sin() / (2.0 * PI),
        1.0 - w.cos(),
        u * u / 2.0 + (w.cos() - 1.0) / (4.0 * PI * PI),
    )
}

impl Profile {
    /// Starts at `speed` [m/s], `heading` [rad], level flight path; `bank` in `[0, 1]` scales
    /// the coordinated-turn roll.
    pub fn new(speed: f64, heading: f64, bank: f64) -> Result<Self> {
        if !(speed.is_finite() && speed >= 0.0 && heading.is_finite()) {
            bail!("start speed must be finite and >= 0, heading finite");
        }
        if !(0.0..=1.0).contains(&bank) {
            bail!("bank must be in [0, 1]");
        }
        Ok(Self {
            speed0: speed,
            heading0: heading,
            gamma0: 0.0,
            bank,
            transition: 2.0,
            pieces: Vec::new(),
            starts: Vec::new(),
        })
    }

    /// Appends a raw piece.
    pub fn piece(mut self, p: Piece) -> Result<Self> {
        if !(p.duration.is_finite() && p.duration > 0.0) {
            bail!("piece duration must be positive");
        }
        if ![p.accel, p.turn_rate, p.climb_rate]
            .iter()
            .all(|x| x.is_finite())
        {
            bail!("piece rates must be finite");
        }
        let (t0, x0, r0) = self.end();
        let mut x1 = x0;
        let r1 = [p.accel, p.turn_rate, p.climb_rate];
        for i in 0..3 {
            // Closed form at u = 1: I(1) = 1/2.
            x1[i] += r0[i] * p.duration + (r1[i] - r0[i]) * p.duration / 2.0;
        }
        if x1[0] < -1e-9 {
            bail!("the speed would become negative ({:.3} m/s)", x1[0]);
        }
        self.starts.push((t0, x0, r0));
        self.pieces.push(p);
        Ok(self)
    }

    /// End time, values and rates of the profile so far.
    fn end(&self) -> (f64, [f64; 3], [f64; 3]) {
        match (self.pieces.last(), self.starts.last()) {
            (Some(p), Some((t0, x0, r0))) => {
                let r1 = [p.accel, p.turn_rate, p.climb_rate];
                let mut x = *x0;
                for i in 0..3 {
                    x[i] += r0[i] * p.duration + (r1[i] - r0[i]) * p.duration / 2.0;
                }
                (t0 + p.duration, x, r1)
            }
            _ => (0.0, [self.speed0, self.heading0, self.gamma0], [0.0; 3]),
        }
    }

    /// Total duration [s].
    pub fn duration(&self) -> f64 {
        self.end().0
    }

    /// Current end speed [m/s].
    pub fn end_speed(&self) -> f64 {
        self.end().1[0]
    }

    /// A rate pulse on one channel (0 speed, 1 heading, 2 flight path): ramp up over the
    /// transition, hold, ramp down, changing the value by `change` in `duration` seconds.
    fn pulse(self, channel: usize, change: f64, duration: f64) -> Result<Self> {
        if !(duration.is_finite() && duration > 0.0 && change.is_finite()) {
            bail!("segment duration must be positive and the change finite");
        }
        let tr = self.transition.min(duration / 4.0);
        // Change = rate (hold + tr): each ramp contributes rate tr / 2.
        let rate = change / (duration - tr);
        let mk = |r: f64, d: f64| {
            let mut rates = [0.0; 3];
            rates[channel] = r;
            Piece {
                duration: d,
                accel: rates[0],
                turn_rate: rates[1],
                climb_rate: rates[2],
            }
        };
        self.piece(mk(rate, tr))?
            .piece(mk(rate, duration - 2.0 * tr))?
            .piece(mk(0.0, tr))
    }

    /// Constant speed, heading and flight path for `duration` s (static when the speed is 0).
    pub fn hold(self, duration: f64) -> Result<Self> {
        self.piece(Piece {
            duration,
            accel: 0.0,
            turn_rate: 0.0,
            climb_rate: 0.0,
        })
    }

    /// Changes the speed by `dv` [m/s] in `duration` s.
    pub fn accelerate(self, dv: f64, duration: f64) -> Result<Self> {
        self.pulse(0, dv, duration)
    }

    /// Turns by `angle` [rad] (positive to the right) in `duration` s.
    pub fn turn(self, angle: f64, duration: f64) -> Result<Self> {
        self.pulse(1, angle, duration)
    }

    /// Changes the flight-path angle by `dgamma` [rad] (positive up) in `duration` s.
    pub fn pitch_to(self, dgamma: f64, duration: f64) -> Result<Self> {
        self.pulse(2, dgamma, duration)
    }

    /// A climb (or descent for negative `gamma`) of `duration` s at flight-path angle `gamma`,
    /// entered and left in `duration / 8` each.
    pub fn climb(self, gamma: f64, duration: f64) -> Result<Self> {
        let e = duration / 8.0;
        self.pitch_to(gamma, e)?
            .hold(duration - 2.0 * e)?
            .pitch_to(-gamma, e)
    }

    /// A figure-eight: a full right turn then a full left turn, `loop_time` s each.
    pub fn figure_eight(self, loop_time: f64) -> Result<Self> {
        self.turn(2.0 * PI, loop_time)?.turn(-2.0 * PI, loop_time)
    }

    /// A test course of about `hours`: 60 s static, accelerate to 40 m/s, then repeated
    /// figure-eights (60-s loops), 8-% climbs and descents of 60 s, a quarter turn and a
    /// speed dip, and a final stop; `bank` as in [`Profile::new`].
    pub fn figure_eight_course(hours: f64, bank: f64) -> Result<Self> {
        let mut p = Self::new(0.0, 0.4, bank)?
            .hold(60.0)?
            .accelerate(40.0, 40.0)?;
        while p.duration() < hours * 3600.0 - 400.0 {
            p = p
                .figure_eight(60.0)?
                .climb(0.08, 60.0)?
                .turn(PI / 2.0, 20.0)?
                .climb(-0.08, 60.0)?
                .accelerate(-10.0, 10.0)?
                .accelerate(10.0, 10.0)?;
        }
        p.accelerate(-40.0, 60.0)?.hold(10.0)
    }

    /// A stop-and-go drive (the zero-velocity update's tests): 60 s static, away to 10 m/s in
    /// 10 s, 100 s straight, a right quarter turn in 20 s, 60 s straight, braking to rest in
    /// 10 s (at 260 s), `stop` s at rest, away to 10 m/s in 10 s, 60 s straight.
    pub fn stop_and_go(stop: f64) -> Result<Self> {
        Self::new(0.0, 0.4, 1.0)?
            .hold(60.0)?
            .accelerate(10.0, 10.0)?
            .hold(100.0)?
            .turn(PI / 2.0, 20.0)?
            .hold(60.0)?
            .accelerate(-10.0, 10.0)?
            .hold(stop)?
            .accelerate(10.0, 10.0)?
            .hold(60.0)
    }

    /// The kinematics at time `t` (clamped to the profile).
    pub fn at(&self, t: f64) -> Kinematics {
        let idx = self
            .starts
            .partition_point(|(t0, _, _)| *t0 <= t)
            .saturating_sub(1);
        let (val, rate, rated) = match (self.pieces.get(idx), self.starts.get(idx)) {
            (Some(p), Some((t0, x0, r0))) => {
                let tau = (t - t0).clamp(0.0, p.duration);
                let u = tau / p.duration;
                let (s, sd, i) = smooth(u);
                let r1 = [p.accel, p.turn_rate, p.climb_rate];
                let mut out = ([0.0; 3], [0.0; 3], [0.0; 3]);
                for k in 0..3 {
                    let dr = r1[k] - r0[k];
                    out.0[k] = x0[k] + r0[k] * tau + dr * p.duration * i;
                    out.1[k] = r0[k] + dr * s;
                    out.2[k] = dr * sd / p.duration;
                }
                out
            }
            _ => (
                [self.speed0, self.heading0, self.gamma0],
                [0.0; 3],
                [0.0; 3],
            ),
        };
        let (s, sd) = (val[0], rate[0]);
        let (psid, psidd) = (rate[1], rated[1]);
        // Coordinated turn: tan(roll) = bank s psi' / g0.
        let x = self.bank * s * psid / G0;
        let xd = self.bank * (sd * psid + s * psidd) / G0;
        Kinematics {
            s,
            sd,
            psi: val[1],
            psid,
            psidd,
            gamma: val[2],
            gammad: rate[2],
            roll: x.atan(),
            rolld: xd / (1.0 + x * x),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_reach_their_targets_and_derivatives_match() {
        let p = Profile::new(0.0, 0.3, 1.0)
            .unwrap()
            .hold(10.0)
            .unwrap()
            .accelerate(20.0, 30.0)
            .unwrap()
            .turn(PI / 2.0, 40.0)
            .unwrap()
            .climb(0.1, 80.0)
            .unwrap();
        let end = p.at(p.duration());
        assert!((end.s - 20.0).abs() < 1e-12);
        assert!((end.psi - 0.3 - PI / 2.0).abs() < 1e-12);
        assert!(end.gamma.abs() < 1e-12 && end.psid == 0.0 && end.roll == 0.0);
        // Central differences agree with the analytic derivatives (h^2 error ~ 1e-8).
        let h = 1e-4;
        for &t in &[15.0, 41.3, 55.0, 79.9, 120.0, 150.2] {
            let (a, b, c) = (p.at(t - h), p.at(t), p.at(t + h));
            let d = |f: fn(&Kinematics) -> f64| (f(&c) - f(&a)) / (2.0 * h);
            assert!((d(|k| k.s) - b.sd).abs() < 1e-7, "{t}");
            assert!((d(|k| k.psi) - b.psid).abs() < 1e-7, "{t}");
            assert!((d(|k| k.psid) - b.psidd).abs() < 1e-7, "{t}");
            assert!((d(|k| k.gamma) - b.gammad).abs() < 1e-7, "{t}");
            assert!((d(|k| k.roll) - b.rolld).abs() < 1e-7, "{t}");
        }
        assert!(Profile::new(5.0, 0.0, 0.0)
            .unwrap()
            .accelerate(-10.0, 5.0)
            .is_err());
    }
}
