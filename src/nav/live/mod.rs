//! A navigation run fed live: IMU samples and GNSS fixes as they arrive, interleaved, with no
//! host to prepare the start. [`LiveNav`] levels over the first seconds at rest
//! ([`Alignment`]), places the run at the fix nearest the end of that window, decides each
//! fix as the host does ([`FixPlanner`]) and drives the same loop as the replay
//! ([`NavReplay`]). A log streamed through it in time order gives the host's replay records
//! and so the host's run, bit for bit (`hal-sim/tests/nav_live.rs`).
//!
//! The order of a stream: the host takes a fix after the first IMU sample at or past its time.
//! A fix that arrives before that sample waits in a small queue ([`PENDING`] fixes). A fix
//! that arrives after it (a receiver's latency) is taken at once, after the samples it missed,
//! compared with the solution moved back to its time along the velocities the navigator keeps
//! for a second ([`super::navigator::history`]): the run then differs from the host's by
//! taking each correction that much later. Or the samples wait for it: with a latency budget
//! ([`LiveConfig::latency`]) each sample is mechanised that long after it arrived, so every
//! fix up to that late is taken in the host's order, bit for bit, at the price of a solution
//! that much behind the newest sample (the delayed fusion horizon of PX4's EKF2;
//! [`LiveNav::present`] is its output predictor, the solution carried to the newest sample,
//! [`super::predictor`]), which costs a mechanisation of the waiting samples per change of the
//! run. Measured on a simulated drive with fixes 0.25 s late (`hal-sim/tests/nav_live.rs`):
//! without a budget, within 1.21 sigma of the host's run at every epoch (44 sigma before the
//! history); with a 0.3-s budget, bit for bit. On 20 drives and on the real drive the two
//! ways are equally accurate at the newest sample (BENCHMARKS.md "Late fixes without a
//! budget").
//!
//! The start is the fix nearest the end of the levelling window, before or after it (its
//! position is the start's: that fix is recorded, not fused again, [`FixPlanner::placed_at`]); the
//! samples after the window wait in a buffer of `B` samples until a fix after the window has
//! come. When the buffer fills first, the nearest fix so far is taken; with none at all, the
//! levelling starts again ([`LiveEvent::NoFix`]), as it does when the window was not at rest
//! ([`LiveEvent::Realigning`]). Nothing here allocates or panics; every queue is bounded and
//! reports what it dropped ([`LiveEvent::FixDropped`]). A corrupted time stamp costs one
//! sample or one fix, not the run ([`MAX_IMU_JUMP`], [`MAX_FIX_LEAD`]).
//!
//! ```
//! use imu_ident::nav::live::{LiveConfig, LiveEvent, LiveFix, LiveNav};
//! use imu_ident::nav::{ImuErrorModel, NavInit, NavSetup};
//! use imu_ident::strapdown::Geodetic;
//! use nalgebra::Vector3;
//! // The noise model aside (none here), the defaults of `hal-sim nav`.
//! let init = NavInit { sd_att: Vector3::repeat(0.01), sd_vel: 0.1, sd_pos: 3.0 };
//! let setup = || NavSetup::new(ImuErrorModel::default(), init);
//! let cfg = LiveConfig::new(2.0);
//! let mut nav = LiveNav::<f64, 24>::new(setup(), cfg, LiveNav::<f64, 24>::no_observer);
//! let ant = Geodetic { lat: 0.8, lon: 0.1, h: 50.0 };
//! let (mut started, mut epochs) = (false, 0);
//! let mut on = |e: LiveEvent<'_, f64>| match e {
//!     LiveEvent::Started(_) => started = true,
//!     LiveEvent::Fix { .. } => epochs += 1,
//!     _ => {}
//! };
//! for k in 0..500u32 {
//!     let t = 0.01 * f64::from(k);
//!     nav.imu(t, [0.0; 3], [0.0, 0.0, -9.806], &mut on).unwrap();
//!     if k % 100 == 50 {
//!         let fix = LiveFix { t, pos: ant, vel: Some([0.0; 3]), sd_pos: None, sd_vel: None };
//!         nav.gnss(&fix, &mut on).unwrap();
//!     }
//! }
//! assert!(started && epochs == 3); // fixes at 2.5, 3.5 and 4.5 s, after the start at 2.01 s
//! ```

mod inputs;

use super::navigator::{NavObserver, NavSd};
use super::predictor::{OutputPredictor, Present};
use super::replay::{ImuRecord, NavSetup};
use super::run::NavReplay;
pub use super::start::{Alignment, FixPlan, FixPlanner, StartState};
use super::NavError;
use crate::strapdown::AlignError;
use crate::Real;
use heapless::Deque;
pub use inputs::{
    record_of, DropReason, LiveConfig, LiveEvent, LiveFix, MAX_FIX_LEAD, MAX_IMU_JUMP, PENDING,
};

/// Attaches the run's observer (the online identification's bank) once the run is built.
pub type Attach<T, const N: usize, O> = fn(&NavSetup, &NavReplay<T, N>) -> Result<O, NavError>;

/// Where the start is.
// The run is large and the other phases small: boxing it is not an option without a heap, and
// the live loop sits in one static, so the enum's size is the run's either way.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone)]
enum Phase<T: Real, const N: usize, O> {
    /// Levelling.
    Aligning,
    /// The window ended at this time; waiting for the fix that places the run.
    Placing(f64),
    /// Running.
    Running(NavReplay<T, N, O>),
}

/// A live navigation run (module docs); `B` IMU samples wait for the start's fix, and then
/// for the latency budget ([`LiveConfig::latency`]).
#[derive(Debug, Clone)]
pub struct LiveNav<T: Real, const N: usize, O = (), const B: usize = 256> {
    cfg: LiveConfig,
    /// The run's settings; the start state once started.
    setup: NavSetup,
    attach: Attach<T, N, O>,
    phase: Phase<T, N, O>,
    alignment: Alignment,
    /// The last fix before the window's end.
    before: Option<LiveFix>,
    /// The samples after the window's end until the start, then the latency's delay line.
    buffer: Deque<ImuRecord, B>,
    pending: Deque<LiveFix, PENDING>,
    planner: FixPlanner,
    t_imu: f64,
    t_fix: f64,
    /// A sample time refused as a jump, which the next sample may confirm.
    suspect: f64,
    /// The solution at the newest sample ([`present`](Self::present)).
    present: Option<OutputPredictor<T>>,
    /// The run's solution changed other than by mechanising a sample since the predictor's
    /// copy (a step, a fix, an error): the copy is taken again.
    moved: bool,
    /// Samples the predictor has mechanised.
    predicted: u64,
    /// The predictor runs ([`set_present`](Self::set_present); on by default).
    predicting: bool,
}

impl<T: Real, const N: usize, const B: usize> LiveNav<T, N, (), B> {
    /// No observer.
    pub fn no_observer(_: &NavSetup, _: &NavReplay<T, N>) -> Result<(), NavError> {
        Ok(())
    }
}

impl<T: Real, const N: usize, O: NavObserver<T, N>, const B: usize> LiveNav<T, N, O, B> {
    /// A run with the settings `setup` (the model, the initial uncertainty, the
    /// observations, the aiding; its start state, `t0`, `pos`, `att`, `vel`, `gyro_bias` and
    /// `heading_known`, is the alignment's), started by the rules `cfg`, whose observer
    /// `attach` builds at the start.
    pub fn new(setup: NavSetup, cfg: LiveConfig, attach: Attach<T, N, O>) -> Self {
        let setup = NavSetup {
            live: Some(cfg),
            ..setup
        };
        let planner = FixPlanner::new(cfg.yaw.is_some(), cfg.yaw_speed, cfg.fix_interval);
        let alignment = Alignment::new(cfg.align);
        Self {
            cfg,
            setup,
            attach,
            phase: Phase::Aligning,
            alignment,
            before: None,
            buffer: Deque::new(),
            pending: Deque::new(),
            planner,
            t_imu: f64::NAN,
            t_fix: f64::NAN,
            suspect: f64::NAN,
            present: None,
            moved: false,
            predicted: 0,
            predicting: true,
        }
    }

    /// The solution at the newest sample, once running: the run's, carried through the
    /// samples still waiting for the latency budget ([`super::predictor`]); the run's own
    /// when none waits (no budget: nothing is copied). None while levelling, when switched
    /// off ([`set_present`](Self::set_present)), and after a sample the predictor's copy
    /// refused, until the run's next change.
    pub fn present(&self) -> Option<Present<'_, T>> {
        let Phase::Running(run) = &self.phase else {
            return None;
        };
        if !self.predicting {
            return None;
        }
        match &self.present {
            Some(p) => Some(p.present()),
            None if self.buffer.is_empty() => {
                let nav = run.navigator();
                Some(Present::new(nav.time(), nav.ins()))
            }
            None => None,
        }
    }

    /// Standard deviations of the navigation errors of [`present`](Self::present)'s
    /// solution, at its time: the run's filter covariance carried from its last propagation
    /// ([`Navigator::sd_at`](super::Navigator::sd_at)). None when there is no present, or
    /// when the error model cannot be built.
    pub fn present_sd(&self) -> Option<NavSd<T>> {
        let t = self.present()?.time();
        let Phase::Running(run) = &self.phase else {
            return None;
        };
        run.navigator().sd_at(t).ok()
    }

    /// Runs the output predictor, or not (on by default): a board that reads only the run's
    /// solutions saves its cost (about one more mechanisation per sample at 100 Hz with 4-Hz
    /// fixes and a 0.25-s budget, BENCHMARKS.md "The present solution"); off, [`present`]
    /// is none.
    ///
    /// [`present`]: Self::present
    pub fn set_present(&mut self, on: bool) {
        self.predicting = on;
        self.moved = true;
        self.predict();
    }

    /// Samples the output predictor has mechanised so far: each sample once as it arrives,
    /// and the waiting samples again after each change of the run's solution (the
    /// predictor's cost, in samples mechanised).
    pub fn predicted_samples(&self) -> u64 {
        self.predicted
    }

    /// Carries the predictor to the newest sample ([`OutputPredictor::carry`]).
    fn predict(&mut self) {
        let Phase::Running(run) = &self.phase else {
            self.present = None;
            return;
        };
        if !self.predicting || self.buffer.is_empty() {
            // Nothing to carry: the present is the run's own solution (`present`), and the
            // next sample that waits takes a new copy.
            self.present = None;
            self.moved = false;
            return;
        }
        let (n, ok) = OutputPredictor::carry(
            &mut self.present,
            run.navigator(),
            self.moved,
            self.buffer.iter(),
        );
        self.predicted = self.predicted.saturating_add(n);
        self.moved = !ok;
    }

    /// Marks the run's solution as changed when `r` failed (a sample or fix half taken),
    /// then carries the predictor to the newest sample.
    fn predicted_after<R>(&mut self, r: Result<R, NavError>) -> Result<R, NavError> {
        if r.is_err() {
            self.moved = true;
        }
        self.predict();
        r
    }

    /// The run, once started.
    pub fn run(&self) -> Option<&NavReplay<T, N, O>> {
        match &self.phase {
            Phase::Running(r) => Some(r),
            _ => None,
        }
    }

    /// The setup: the configured one until the start, then the run's.
    pub fn setup(&self) -> &NavSetup {
        &self.setup
    }

    /// The IMU sample at `t` [s]: mean rates `gyro` [rad/s] and specific force `accel`
    /// [m/s^2], body FRD, over the interval since the previous sample. A time that is not
    /// finite or does not increase, or a jump of more than [`MAX_IMU_JUMP`] that the next
    /// sample has not confirmed, is refused ([`NavError::BadTime`]) and changes nothing;
    /// while levelling, a time that goes back starts the levelling again from it.
    pub fn imu(
        &mut self,
        t: f64,
        gyro: [f64; 3],
        accel: [f64; 3],
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        let r = self.take_imu(t, gyro, accel, out);
        self.predicted_after(r)
    }

    fn take_imu(
        &mut self,
        t: f64,
        gyro: [f64; 3],
        accel: [f64; 3],
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        if t.is_finite() && t <= self.t_imu && matches!(self.phase, Phase::Aligning) {
            // Time went back while levelling (a corrupted first stamp, a restarted clock):
            // nothing is running yet, so the levelling starts again from this sample.
            out(LiveEvent::Realigning(AlignError::NoData));
            self.realign();
            self.t_imu = f64::NAN;
        }
        let first = self.t_imu.is_nan();
        if !(t.is_finite() && (first || t > self.t_imu)) {
            return Err(NavError::BadTime);
        }
        let confirmed = t > self.suspect && t - self.suspect <= MAX_IMU_JUMP;
        if !first && t - self.t_imu > MAX_IMU_JUMP && !confirmed {
            self.suspect = t;
            return Err(NavError::BadTime);
        }
        self.suspect = f64::NAN;
        let record = ImuRecord {
            t,
            gyro: gyro.map(|x| x as f32),
            accel: accel.map(|x| x as f32),
        };
        self.t_imu = t;
        match self.phase {
            Phase::Aligning => {
                let ended = self.alignment.sample(t, &gyro, &accel);
                // Queued fixes this sample passed are candidates for the start; one at the
                // window's end (`t` is the run's `t0`) is also the run's first epoch: it stays.
                while let Some(f) = self.pending.front().copied().filter(|f| f.t <= t) {
                    self.before = Some(f);
                    if ended && f.t == t {
                        break;
                    }
                    self.pending.pop_front();
                }
                if ended {
                    self.phase = Phase::Placing(t);
                    self.try_place(out)?;
                }
            }
            Phase::Placing(_) => {
                if self.buffer.push_back(record).is_err() {
                    return self.buffer_full(record, out);
                }
            }
            Phase::Running(_) => self.delay(record, out)?,
        }
        Ok(())
    }

    /// The fix `f`.
    pub fn gnss(
        &mut self,
        f: &LiveFix,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        let r = self.take_gnss(f, out);
        self.predicted_after(r)
    }

    fn take_gnss(
        &mut self,
        f: &LiveFix,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        let plausible = f.t.is_finite() && f.t <= self.t_imu + MAX_FIX_LEAD;
        if !self.t_imu.is_nan() && !plausible {
            out(LiveEvent::FixDropped(f.t, DropReason::Ahead));
            return Ok(());
        }
        if self.t_imu.is_nan() {
            // Before the first sample: a candidate for the start, nothing more (its time is
            // not yet checked against the samples', so it does not set the fixes' order).
            if f.t.is_finite() && self.before.map_or(true, |b| f.t > b.t) {
                self.before = Some(*f);
            }
            return Ok(());
        }
        if !(f.t > self.t_fix || self.t_fix.is_nan()) {
            out(LiveEvent::FixDropped(f.t, DropReason::NotIncreasing));
            return Ok(());
        }
        self.t_fix = f.t;
        match &mut self.phase {
            // Passed by the samples: before the window's end.
            Phase::Aligning if f.t <= self.t_imu => self.before = Some(*f),
            Phase::Aligning => self.queue(f, out),
            Phase::Placing(t_start) => {
                let t_start = *t_start;
                if f.t <= t_start {
                    self.before = Some(*f);
                }
                if f.t >= t_start {
                    self.queue(f, out);
                }
                self.try_place(out)?;
            }
            Phase::Running(run) => {
                if f.t < self.setup.t0 {
                    out(LiveEvent::FixDropped(f.t, DropReason::BeforeStart));
                } else if f.t <= run.time() && self.pending.is_empty() {
                    let (cfg, planner) = (&self.cfg, &mut self.planner);
                    self.moved = true;
                    take_fix(run, cfg, planner, f, out)?;
                } else {
                    self.queue(f, out);
                }
            }
        }
        Ok(())
    }

    fn queue(&mut self, f: &LiveFix, out: &mut impl FnMut(LiveEvent<'_, T>)) {
        if self.pending.push_back(*f).is_err() {
            out(LiveEvent::FixDropped(f.t, DropReason::QueueFull));
        }
    }

    /// Places the run once a fix after the window's end has come: at the nearer of it and
    /// the last fix before (the earlier on a tie, as the batch start's `min_by`).
    fn try_place(&mut self, out: &mut impl FnMut(LiveEvent<'_, T>)) -> Result<(), NavError> {
        let Phase::Placing(t_start) = self.phase else {
            return Ok(());
        };
        let Some(after) = self.pending.iter().find(|f| f.t > t_start).copied() else {
            return Ok(());
        };
        // The batch start's order: `total_cmp` of the distances, the first on a tie.
        let dist = |f: &LiveFix| (f.t - t_start).abs();
        let fix = match self.before {
            Some(b) if dist(&after).total_cmp(&dist(&b)).is_ge() => b,
            _ => after,
        };
        self.place(t_start, &fix, out)?;
        self.drain(out)
    }

    /// The start's buffer is full at `record`: the nearest fix so far places the run, or
    /// the levelling starts again.
    fn buffer_full(
        &mut self,
        record: ImuRecord,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        let Phase::Placing(t_start) = self.phase else {
            return Ok(());
        };
        match self.before {
            Some(b) => {
                self.place(t_start, &b, out)?;
                self.drain(out)?;
                self.delay(record, out)
            }
            None => {
                out(LiveEvent::NoFix);
                self.realign();
                Ok(())
            }
        }
    }

    fn realign(&mut self) {
        self.phase = Phase::Aligning;
        self.alignment = Alignment::new(self.cfg.align);
        self.before = None;
        self.buffer.clear();
        self.pending.clear();
    }

    /// Starts the run at `t_start` from the antenna position of `fix`; the caller then runs
    /// the buffered samples ([`drain`](Self::drain)). Never inlined, and the samples are not
    /// run from here: the navigator's construction holds large temporaries (the run, the run
    /// with its observer), and in the caller's frame, or under the filter steps of the
    /// buffered samples, they would sit on the stack of every later call (measured on the
    /// firmware with the bank: 117 500 B of stack, against 110 000 B for the replay's run).
    #[inline(never)]
    fn place(
        &mut self,
        t_start: f64,
        fix: &LiveFix,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        let c = &self.cfg;
        let lever = self.setup.lever_arm;
        let st = match self
            .alignment
            .start(&fix.pos, c.yaw, c.static_gyro_bias, &lever)
        {
            Ok(st) => st,
            Err(e) => {
                out(LiveEvent::Realigning(e));
                self.realign();
                return Ok(());
            }
        };
        self.planner.placed_at(fix.t);
        let setup = &mut self.setup;
        setup.t0 = t_start;
        setup.pos = st.pos;
        setup.att = st.att;
        setup.vel = [0.0; 3];
        setup.gyro_bias = st.gyro_bias;
        setup.heading_known = self.cfg.yaw.is_some();
        let plain = NavReplay::<T, N>::new(setup)?;
        let obs = (self.attach)(setup, &plain)?;
        self.phase = Phase::Running(plain.with_observer(obs));
        out(LiveEvent::Started(&self.setup));
        // Fixes before the start are not the run's (the batch run starts at the first fix
        // at or after `t0`).
        while self.pending.front().is_some_and(|f| f.t < t_start) {
            self.pending.pop_front();
        }
        Ok(())
    }

    /// A sample of the running run into the latency's delay line, then the samples due.
    fn delay(
        &mut self,
        record: ImuRecord,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        if !matches!(self.phase, Phase::Running(_)) {
            return Ok(());
        }
        if self.buffer.is_empty() && record.t <= self.t_imu - self.cfg.latency {
            // Nothing waits and the sample is due (no budget): run it, not through the line.
            return self.run_sample(&record, out);
        }
        if let Err(record) = self.buffer.push_back(record) {
            // A delay line longer than the buffer: the oldest sample goes now.
            if let Some(r) = self.buffer.pop_front() {
                self.run_sample(&r, out)?;
            }
            let _ = self.buffer.push_back(record);
        }
        self.drain(out)
    }

    /// The end of the stream (a log's end, or before a shutdown): the samples still waiting
    /// for the latency budget are mechanised, each followed by the queued fixes it passes.
    pub fn flush(&mut self, out: &mut impl FnMut(LiveEvent<'_, T>)) -> Result<(), NavError> {
        let r = match self.phase {
            Phase::Running(_) => self.drain_to(f64::INFINITY, out),
            _ => Ok(()),
        };
        self.predicted_after(r)
    }

    /// Mechanises the buffered samples older than the latency budget, each followed by the
    /// queued fixes it passes.
    fn drain(&mut self, out: &mut impl FnMut(LiveEvent<'_, T>)) -> Result<(), NavError> {
        self.drain_to(self.t_imu - self.cfg.latency, out)
    }

    /// Mechanises the buffered samples at or before `limit` [s].
    fn drain_to(
        &mut self,
        limit: f64,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        while let Some(r) = self.buffer.front().copied().filter(|r| r.t <= limit) {
            self.buffer.pop_front();
            self.run_sample(&r, out)?;
        }
        Ok(())
    }

    /// One sample through the run, then the queued fixes it passes.
    fn run_sample(
        &mut self,
        record: &ImuRecord,
        out: &mut impl FnMut(LiveEvent<'_, T>),
    ) -> Result<(), NavError> {
        let Phase::Running(run) = &mut self.phase else {
            return Ok(());
        };
        let step = run.imu(record)?;
        // A filter step changes the solution (its aiding, a retuned model) and the sensor
        // errors removed: the predictor copies the run again.
        self.moved |= step.stepped;
        out(LiveEvent::Imu(record, &step));
        while let Some(f) = self.pending.front().copied().filter(|f| f.t <= record.t) {
            self.pending.pop_front();
            self.moved = true;
            take_fix(run, &self.cfg, &mut self.planner, &f, out)?;
        }
        Ok(())
    }
}

/// One fix through the run: the planner's decisions as the replay's flags, the fusion, the
/// solution at its time (`hal_sim::nav_qemu::replay_records` writes the same record).
fn take_fix<T: Real, const N: usize, O: NavObserver<T, N>>(
    run: &mut NavReplay<T, N, O>,
    cfg: &LiveConfig,
    planner: &mut FixPlanner,
    f: &LiveFix,
    out: &mut impl FnMut(LiveEvent<'_, T>),
) -> Result<(), NavError> {
    let plan = planner.plan(f.t, f.vel, false);
    let record = record_of(f, &plan, cfg.use_velocity);
    let fused = run.gnss(&record)?;
    let epoch = run.epoch(&record, fused.as_ref());
    out(LiveEvent::Fix {
        record: &record,
        fused: fused.as_ref(),
        epoch: &epoch,
    });
    Ok(())
}
