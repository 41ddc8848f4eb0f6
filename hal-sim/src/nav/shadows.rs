//! The core's online identification by a bank of shadow filters
//! ([`imu_ident::nav::online`]) inside the host's replay loop (`nav --adapt --adapt-method
//! bank`): the observer the loop's navigator carries, and the record of its decisions. The
//! same core code the firmware would run; the host only keeps the record.

use imu_ident::linalg::Arr;
use imu_ident::nav::error_model::StrapdownErrorModel;
use imu_ident::nav::{NavObserver, ObservationKind, OnlineIdent, NAV_N};
use imu_ident::Real;

/// Shadow filters in the host's bank: two per coordinate and the centre, up to 18 coordinates (three
/// quantities on each of the six axes, per axis).
pub const BANK_M: usize = 48;

/// The core's identification, boxed (a bank is ~170 kB in f64; the loop is a value that the
/// window search copies).
pub type Ident<T> = OnlineIdent<T, NAV_N, BANK_M>;

/// One decision of the bank.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// Time [s].
    pub t: f64,
    /// GNSS fixes scored so far.
    pub fixes: u32,
    /// log10 factors on the starting model (tied) after the decision.
    pub log10_factors: Vec<f64>,
    /// Cramér-Rao sd of each factor [decades] at the decision.
    pub cr_sd: Vec<f64>,
}

/// The navigator's observer in the host loop: the bank, when the run identifies with it.
#[derive(Debug, Clone, Default)]
pub struct Shadows<T: Real> {
    /// The bank.
    pub ident: Option<Box<Ident<T>>>,
    /// Its decisions so far.
    pub log: Vec<Decision>,
}

impl<T: Real> Shadows<T> {
    /// At time `t`, after a filter step: a decision when one is due; returns the model the
    /// running filter must take, if it moved.
    pub fn decide(&mut self, t: f64) -> Option<imu_ident::nav::ImuErrorModel<T>> {
        let id = self.ident.as_mut()?;
        let before = id.decisions();
        let m = id.decide(t);
        if id.decisions() != before {
            self.log.push(Decision {
                t,
                fixes: id.fixes(),
                log10_factors: id.log10_factors().to_vec(),
                cr_sd: id.cr_sd().to_vec(),
            });
        }
        m
    }
}

#[allow(non_snake_case)]
impl<T: Real> NavObserver<T, NAV_N> for Shadows<T> {
    fn propagated(
        &mut self,
        model: &StrapdownErrorModel<T>,
        scale: &[T; NAV_N],
        x: &[T; NAV_N],
        p0: &Arr<T, NAV_N>,
    ) {
        if let Some(id) = self.ident.as_mut() {
            id.propagated(model, scale, x, p0);
        }
    }

    fn observed<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; NAV_N]; Z],
        R: &[T; Z],
    ) {
        if let Some(id) = self.ident.as_mut() {
            id.observed(kind, z, H, R);
        }
    }

    fn corrected(&mut self, x: &[T; NAV_N], p0: &Arr<T, NAV_N>) {
        if let Some(id) = self.ident.as_mut() {
            id.corrected(x, p0);
        }
    }

    fn heading_restarted(&mut self, scale: &[T; NAV_N], sd: T, vel: bool) {
        if let Some(id) = self.ident.as_mut() {
            id.heading_restarted(scale, sd, vel);
        }
    }

    fn sensors_seeded(&mut self, x: &[T; NAV_N]) {
        if let Some(id) = self.ident.as_mut() {
            id.sensors_seeded(x);
        }
    }

    fn decide(&mut self, t: f64) -> Option<imu_ident::nav::ImuErrorModel<T>> {
        Shadows::decide(self, t)
    }
}
