//! The core's online identification by a bank of shadow filters
//! ([`imu_ident::nav::online`]) inside the host's replay loop (`nav --adapt --adapt-method
//! bank`): the observer the loop's navigator carries, and the record of its decisions. The
//! same core code the firmware would run; the host only keeps the record.

use imu_ident::linalg::Arr;
use imu_ident::nav::error_model::StrapdownErrorModel;
use imu_ident::nav::{ImuErrorModel, NavObserver, ObservationKind, OnlineIdent, NAV_N};
use imu_ident::Real;

/// Shadow filters in the host's bank: two per coordinate, the centre and one per pair of a
/// component's quantities (18 coordinates per axis with 6 pairs: 43).
pub const BANK_M: usize = 48;

/// The core's identification, boxed (a bank is ~170 kB in f64; the loop is a value that the
/// window search copies).
pub type Ident<T> = OnlineIdent<T, NAV_N, BANK_M>;

/// One decision of the bank.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// Time [s].
    pub t: f64,
    /// Start of the fixes the decision scored: the last move, or the start [s].
    pub window_start: f64,
    /// GNSS fixes the decision scored.
    pub fixes: u32,
    /// log10 factors on the starting model (tied) after the decision.
    pub log10_factors: Vec<f64>,
    /// Cramér-Rao sd of each factor [decades] at the decision.
    pub cr_sd: Vec<f64>,
    /// Each factor identifiable from the data so far (the core's flag,
    /// [`OnlineIdent::identifiable`]).
    pub identifiable: Vec<bool>,
}

/// The navigator's observer in the host loop: the bank, when the run identifies with it.
#[derive(Debug, Clone, Default)]
pub struct Shadows<T: Real> {
    /// The bank.
    pub ident: Option<Box<Ident<T>>>,
    /// Its decisions so far.
    pub log: Vec<Decision>,
    /// With `--adapt-tied-first`: the per-axis bank's settings, while the tied bank runs
    /// ([`crate::nav::adapt::switch_if_settled`]).
    pub per_axis_next: Option<imu_ident::nav::OnlineConfig>,
    /// The tied bank's first decision inside its grid was taken: the loop starts the
    /// per-axis bank.
    pub settled: bool,
    /// The tied bank, once the per-axis bank took over: its record.
    pub tied: Option<TiedBank<T>>,
}

/// The tied bank's record after the per-axis bank took over (`--adapt-tied-first`).
#[derive(Debug, Clone)]
pub struct TiedBank<T: Real> {
    /// Its coordinates (the IMU's).
    pub coords: Vec<imu_ident::nav::online::coords::Coordinate>,
    /// Its reference: the starting model, tied.
    pub base: ImuErrorModel<T>,
    /// Its decisions.
    pub log: Vec<Decision>,
    /// The navigator's GNSS factors when the per-axis bank took over.
    pub gnss_sd_factor: [f64; 2],
    /// When the per-axis bank took over [s].
    pub t: f64,
}

/// Every hook goes to the bank when there is one (through the core's `Option<&mut O>`
/// observer); `decide` also records the decision.
#[allow(non_snake_case)]
impl<T: Real> NavObserver<T, NAV_N> for Shadows<T> {
    fn propagated(
        &mut self,
        model: &StrapdownErrorModel<T>,
        scale: &[T; NAV_N],
        x: &[T; NAV_N],
        p0: &Arr<T, NAV_N>,
    ) {
        self.ident.as_deref_mut().propagated(model, scale, x, p0);
    }

    fn observed<const Z: usize>(
        &mut self,
        kind: ObservationKind,
        z: &[T; Z],
        H: &[[T; NAV_N]; Z],
        R: &[T; Z],
    ) {
        self.ident.as_deref_mut().observed(kind, z, H, R);
    }

    fn corrected(&mut self, x: &[T; NAV_N], p0: &Arr<T, NAV_N>) {
        self.ident.as_deref_mut().corrected(x, p0);
    }

    fn heading_restarted(&mut self, scale: &[T; NAV_N], sd: T, vel: bool) {
        self.ident.as_deref_mut().heading_restarted(scale, sd, vel);
    }

    fn sensors_seeded(&mut self, x: &[T; NAV_N]) {
        self.ident.as_deref_mut().sensors_seeded(x);
    }

    fn decide(&mut self, t: f64) -> Option<ImuErrorModel<T>> {
        let id = self.ident.as_deref_mut()?;
        let (before, window_start, fixes) = (id.decisions(), id.window_start(), id.fixes());
        let m = id.decide(t);
        // The tied bank settled (the decision kept its window): the per-axis bank is due.
        if self.per_axis_next.is_some() && id.decisions() != before && id.window_start() < t {
            self.settled = true;
        }
        if id.decisions() != before {
            self.log.push(Decision {
                t,
                window_start,
                fixes,
                log10_factors: id.log10_factors().to_vec(),
                cr_sd: id.cr_sd().to_vec(),
                identifiable: (0..id.log10_factors().len())
                    .map(|i| id.identifiable(i))
                    .collect(),
            });
        }
        m
    }

    fn gnss_sd_factor(&self) -> Option<[f64; 2]> {
        self.ident
            .as_deref()
            .and_then(NavObserver::<T, NAV_N>::gnss_sd_factor)
    }
}
