//! The one-channel INS error model of METHOD.md §5, composed with the sensor-error components.
//!
//! State layout (named indices in [`idx`]): `[dV, delta, accel components..., gyro
//! components..., coloured-observation components..., unused]`, at most [`NX`] states.
//!
//! ```text
//! dV'    = -g delta + sum_accel C_c x_c + w_a        (w_a: accelerometer white noise)
//! delta' = dV / R   + sum_gyro  C_c x_c + w_g        (w_g: gyro white noise)
//! x_c'   = A_c x_c + G_c xi_c                        (each component's shaping filter)
//! z      = dV + sum_colored x_o + v,   v ~ N(0, sigma_v^2)
//! ```
//!
//! Unused slots are decoupled (zero rows and columns in `A`, `Qc` and `P`).
//!
//! The filter works in *scaled* states `x' = S^-1 x` with `S` diagonal powers of two chosen from
//! the model's magnitudes (see [`Scaling`]): every state is then O(1), which keeps single
//! precision away from underflow in products such as `P_dw^2` (about 1e-25 in SI units) and the
//! Van Loan series terms. Powers of two make the scaling itself exact.

use crate::linalg::{from_mat, Arr, At};
use crate::model::discretise::{discretise, discretise_block, Discrete};
use crate::model::{Component, GaussMarkov, ModelError, Realisation};
use crate::Real;
use heapless::Vec;
use nalgebra::{RowSVector, SMatrix, SVector};

/// Maximum number of filter states (compile-time).
pub const NX: usize = 8;
/// Maximum number of components per sensor.
pub const MAX_COMPONENTS: usize = 4;
/// Maximum number of coloured observation-noise components.
pub const MAX_COLORED: usize = 2;
/// Standard gravity [m/s^2].
pub const G0: f64 = 9.80665;
/// Earth radius used by the Schuler loop [m].
pub const EARTH_RADIUS: f64 = 6_371_000.0;

/// Named state indices.
pub mod idx {
    /// Velocity error [m/s].
    pub const DV: usize = 0;
    /// Tilt (vertical) error [rad].
    pub const DELTA: usize = 1;
    /// First sensor-component state.
    pub const FIRST_COMPONENT: usize = 2;
}

/// A state vector.
pub type StateVec<T> = SVector<T, NX>;
/// A state-sized square matrix.
pub type StateMat<T> = SMatrix<T, NX, NX>;
/// An observation row.
pub type StateRow<T> = RowSVector<T, NX>;

/// The error source a noise component models: a sensor (the accelerometer or the gyro) or
/// the observation (its coloured noise).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ErrorSource {
    /// Accelerometer error [m/s^2].
    Accel,
    /// Gyro drift [rad/s].
    Gyro,
    /// Coloured observation noise [m/s].
    Observation,
}

impl ErrorSource {
    /// Lower-case name used in files: `accel`, `gyro`, `observation`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Accel => "accel",
            Self::Gyro => "gyro",
            Self::Observation => "observation",
        }
    }
}

/// The full noise model: the INS channel, its sensors and its observation.
#[derive(Debug, Clone, PartialEq)]
pub struct InsModel<T> {
    /// Filter step [s].
    pub dt: T,
    /// White observation noise standard deviation [m/s].
    pub sigma_v: T,
    /// Coloured observation-noise components [m/s].
    pub colored: Vec<GaussMarkov<T>, MAX_COLORED>,
    /// Accelerometer error components [m/s^2].
    pub accel: Vec<Component<T>, MAX_COMPONENTS>,
    /// Gyro drift components [rad/s].
    pub gyro: Vec<Component<T>, MAX_COMPONENTS>,
    /// Initial standard deviation of the velocity error [m/s].
    pub sigma_dv0: T,
    /// Initial standard deviation of the tilt error [rad].
    pub sigma_delta0: T,
}

/// Where one component's states sit in the state vector.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Slot {
    /// The error source it belongs to.
    pub sensor: ErrorSource,
    /// Its position in that error source's component list.
    pub index: usize,
    /// Its first state index.
    pub start: usize,
    /// Its number of states (0 for white noise).
    pub states: usize,
}

/// The positions of every component, in state order.
pub type Layout = Vec<Slot, { 2 * MAX_COMPONENTS + MAX_COLORED }>;

/// Diagonal state scaling `S` (powers of two): physical `x = S x'`.
pub type Scaling<T> = StateVec<T>;

/// The continuous-time system in scaled states.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq)]
pub struct Continuous<T: Real> {
    /// Dynamics `A'`.
    pub A: StateMat<T>,
    /// Noise intensity `Qc' = S^-1 G Q G^T S^-1`.
    pub Qc: StateMat<T>,
    /// Observation row `H' = H S`.
    pub H: StateRow<T>,
    /// Initial covariance `P0'`.
    pub P0: StateMat<T>,
    /// Number of active states.
    pub n: usize,
}

impl<T: Real> InsModel<T> {
    /// The paper's reference model (`paper` scenario, METHOD.md §5 with the issue's values):
    /// accelerometer GM 1e-3 m/s^2 / 100 s, gyro GM 0.1 deg/h / 1200 s, sigma_v 0.03 m/s, dt 1 s.
    pub fn paper() -> Self {
        let deg_h = core::f64::consts::PI / 180.0 / 3600.0;
        let mut m = Self::empty(T::one(), T::lit(0.03));
        // Capacity is MAX_COMPONENTS >= 1, so these pushes cannot fail.
        let _ = m.accel.push(Component::GaussMarkov(GaussMarkov {
            sigma: T::lit(1e-3),
            tau: T::lit(100.0),
        }));
        let _ = m.gyro.push(Component::GaussMarkov(GaussMarkov {
            sigma: T::lit(0.1 * deg_h),
            tau: T::lit(1200.0),
        }));
        m
    }

    /// The same model in another precision (parameters rounded to nearest).
    pub fn cast<U: Real>(&self) -> InsModel<U> {
        let c = |x: T| U::lit(x.as_f64());
        InsModel {
            dt: c(self.dt),
            sigma_v: c(self.sigma_v),
            colored: self
                .colored
                .iter()
                .map(|g| GaussMarkov {
                    sigma: c(g.sigma),
                    tau: c(g.tau),
                })
                .collect(),
            accel: self.accel.iter().map(|k| k.cast()).collect(),
            gyro: self.gyro.iter().map(|k| k.cast()).collect(),
            sigma_dv0: c(self.sigma_dv0),
            sigma_delta0: c(self.sigma_delta0),
        }
    }

    /// All zeros, no components (a compile-time placeholder for blank filters; not a valid
    /// model).
    pub const BLANK: Self = Self {
        dt: T::ZERO,
        sigma_v: T::ZERO,
        colored: Vec::new(),
        accel: Vec::new(),
        gyro: Vec::new(),
        sigma_dv0: T::ZERO,
        sigma_delta0: T::ZERO,
    };

    /// A model with no sensor components; initial sigmas default to `sigma_v` and 1e-4 rad
    /// (a static levelling error of an accelerometer bias of 1e-3 m/s^2).
    pub fn empty(dt: T, sigma_v: T) -> Self {
        Self {
            dt,
            sigma_v,
            colored: Vec::new(),
            accel: Vec::new(),
            gyro: Vec::new(),
            sigma_dv0: sigma_v,
            sigma_delta0: T::lit(1e-4),
        }
    }

    /// Checks every parameter and that the states fit in [`NX`]; returns the layout.
    pub fn layout(&self) -> Result<Layout, ModelError> {
        let pos = |x: T| x.is_finite() && x > T::zero();
        if !pos(self.dt) {
            return Err(ModelError::BadDt);
        }
        if !pos(self.sigma_v) {
            return Err(ModelError::BadSigma);
        }
        if !(pos(self.sigma_dv0) || self.sigma_dv0 == T::zero())
            || !(pos(self.sigma_delta0) || self.sigma_delta0 == T::zero())
        {
            return Err(ModelError::BadSigma);
        }
        let mut layout = Layout::new();
        let mut next = idx::FIRST_COMPONENT;
        let colored = self.colored.iter().map(|g| Component::GaussMarkov(*g));
        let all = (self.accel.iter().copied().map(|c| (ErrorSource::Accel, c)))
            .chain(self.gyro.iter().copied().map(|c| (ErrorSource::Gyro, c)))
            .chain(colored.map(|c| (ErrorSource::Observation, c)));
        let (mut ia, mut ig, mut io) = (0, 0, 0);
        for (sensor, comp) in all {
            comp.validate()?;
            let counter = match sensor {
                ErrorSource::Accel => &mut ia,
                ErrorSource::Gyro => &mut ig,
                ErrorSource::Observation => &mut io,
            };
            let states = comp.states();
            if next + states > NX {
                return Err(ModelError::TooManyStates);
            }
            let slot = Slot {
                sensor,
                index: *counter,
                start: next,
                states,
            };
            layout.push(slot).map_err(|_| ModelError::TooManyStates)?;
            *counter += 1;
            next += states;
        }
        Ok(layout)
    }

    /// The component a slot refers to (coloured observation terms are Gauss-Markov).
    pub fn component(&self, slot: &Slot) -> Option<Component<T>> {
        match slot.sensor {
            ErrorSource::Accel => self.accel.get(slot.index).copied(),
            ErrorSource::Gyro => self.gyro.get(slot.index).copied(),
            ErrorSource::Observation => self
                .colored
                .get(slot.index)
                .map(|g| Component::GaussMarkov(*g)),
        }
    }

    /// Number of active states.
    pub fn states(&self) -> Result<usize, ModelError> {
        let layout = self.layout()?;
        Ok(layout
            .last()
            .map_or(idx::FIRST_COMPONENT, |s| s.start + s.states))
    }

    /// A power-of-two scaling that brings every state to O(1) magnitude.
    pub fn scaling(&self) -> Result<Scaling<T>, ModelError> {
        self.scaling_in(Realisation::Filter)
    }

    /// [`InsModel::scaling`] of the components in realisation `r`.
    pub fn scaling_in(&self, r: Realisation) -> Result<Scaling<T>, ModelError> {
        let layout = self.layout()?;
        let mut s = Scaling::from_element(T::one());
        s[idx::DV] = pow2_near(self.sigma_v);
        let accel: T = self
            .accel
            .iter()
            .fold(T::zero(), |acc, c| acc + c.magnitude());
        s[idx::DELTA] = pow2_near(if accel > T::zero() {
            accel / T::lit(G0)
        } else {
            self.sigma_delta0
        });
        for slot in &layout {
            if let Some(comp) = self.component(slot) {
                let block = comp.block_in(r);
                for k in 0..slot.states.min(2) {
                    if let Some(v) = s.get_mut(slot.start + k) {
                        *v = pow2_near(block.p0[(k, k)].sqrt().max(comp.magnitude()));
                    }
                }
            }
        }
        Ok(s)
    }

    /// The continuous-time system in the states scaled by `scale`.
    pub fn continuous(&self, scale: &Scaling<T>) -> Result<Continuous<T>, ModelError> {
        self.continuous_in(scale, Realisation::Filter)
    }

    /// [`InsModel::continuous`] with the components in realisation `r`.
    #[allow(non_snake_case)]
    pub fn continuous_in(
        &self,
        scale: &Scaling<T>,
        r: Realisation,
    ) -> Result<Continuous<T>, ModelError> {
        let layout = self.layout()?;
        let mut A = StateMat::zeros();
        let mut Qc = StateMat::zeros();
        let mut H = StateRow::zeros();
        let mut P0 = StateMat::zeros();
        let (dv, dl) = (idx::DV, idx::DELTA);
        A[(dv, dl)] = -T::lit(G0);
        A[(dl, dv)] = T::one() / T::lit(EARTH_RADIUS);
        H[dv] = T::one();
        P0[(dv, dv)] = self.sigma_dv0 * self.sigma_dv0;
        P0[(dl, dl)] = self.sigma_delta0 * self.sigma_delta0;
        let mut n = idx::FIRST_COMPONENT;
        for slot in &layout {
            let Some(comp) = self.component(slot) else {
                continue;
            };
            let b = comp.block_in(r);
            // The INS state this sensor drives; observation terms enter H instead.
            let driven = match slot.sensor {
                ErrorSource::Accel => Some(dv),
                ErrorSource::Gyro => Some(dl),
                ErrorSource::Observation => None,
            };
            if let Some(d) = driven {
                Qc[(d, d)] += comp.white_qc();
            }
            for i in 0..slot.states.min(2) {
                let si = slot.start + i;
                if si >= NX {
                    return Err(ModelError::TooManyStates);
                }
                match driven {
                    Some(d) => A.set_at(d, si, A.at(d, si) + b.c.el(i)),
                    None => H.set_el(si, H.el(si) + b.c.el(i)),
                }
                for j in 0..slot.states.min(2) {
                    let sj = slot.start + j;
                    if sj >= NX {
                        return Err(ModelError::TooManyStates);
                    }
                    A.set_at(si, sj, b.a.at(i, j));
                    Qc.set_at(si, sj, b.qc.at(i, j));
                    P0.set_at(si, sj, b.p0.at(i, j));
                }
            }
            n = n.max(slot.start + slot.states);
        }
        // Similarity transform to scaled states: A' = S^-1 A S, Qc' = S^-1 Qc S^-1, H' = H S.
        for i in 0..NX {
            for j in 0..NX {
                A[(i, j)] = A[(i, j)] * scale[j] / scale[i];
                Qc[(i, j)] /= scale[i] * scale[j];
                P0[(i, j)] /= scale[i] * scale[j];
            }
            H[i] *= scale[i];
        }
        Ok(Continuous { A, Qc, H, P0, n })
    }

    /// Exact discretisation at `dt` of the scaled system: `Phi = exp(A dt)` and the Van Loan
    /// integral `Qd = int_0^dt exp(A s) Qc exp(A^T s) ds`.
    pub fn discretise(
        &self,
        scale: &Scaling<T>,
    ) -> Result<(Continuous<T>, Discrete<T, NX>), ModelError> {
        self.discretise_in(scale, Realisation::Filter)
    }

    /// [`InsModel::discretise`] with the components in realisation `r`.
    pub fn discretise_in(
        &self,
        scale: &Scaling<T>,
        r: Realisation,
    ) -> Result<(Continuous<T>, Discrete<T, NX>), ModelError> {
        let c = self.continuous_in(scale, r)?;
        let d = discretise(&c.A, &c.Qc, self.dt)?;
        Ok((c, d))
    }

    /// The same discretisation over the active states only, as the filters' row-major arrays
    /// `(Phi, Qd)` (what the fixed filter and every identification-bank member run on).
    pub fn discretise_block(
        &self,
        scale: &Scaling<T>,
    ) -> Result<(Arr<T, NX>, Arr<T, NX>), ModelError> {
        let c = self.continuous(scale)?;
        discretise_block(&from_mat(&c.A), &from_mat(&c.Qc), self.dt, c.n)
    }

    /// Row that extracts one error source's total error (sum over its components) from the scaled
    /// state, in physical units.
    pub fn output_row(
        &self,
        sensor: ErrorSource,
        scale: &Scaling<T>,
    ) -> Result<StateRow<T>, ModelError> {
        self.output_row_in(sensor, scale, Realisation::Filter)
    }

    /// The accelerometer's and the gyro's [`output_row`](Self::output_row)s, for the scaling as
    /// the kernel's array: what a filter keeps to report its estimates.
    pub fn output_rows(&self, scale: &[T; NX]) -> Result<(StateRow<T>, StateRow<T>), ModelError> {
        let scale = crate::linalg::to_vec(scale);
        let accel = self.output_row(ErrorSource::Accel, &scale)?;
        let gyro = self.output_row(ErrorSource::Gyro, &scale)?;
        Ok((accel, gyro))
    }

    /// [`InsModel::output_row`] with the components in realisation `r`.
    pub fn output_row_in(
        &self,
        sensor: ErrorSource,
        scale: &Scaling<T>,
        r: Realisation,
    ) -> Result<StateRow<T>, ModelError> {
        let layout = self.layout()?;
        let mut row = StateRow::zeros();
        for slot in layout.iter().filter(|s| s.sensor == sensor) {
            let Some(comp) = self.component(slot) else {
                continue;
            };
            let c = comp.block_in(r).c;
            for k in 0..slot.states.min(2) {
                if let (Some(out), Some(s)) =
                    (row.get_mut(slot.start + k), scale.get(slot.start + k))
                {
                    *out += c[k] * *s;
                }
            }
        }
        Ok(row)
    }
}

/// The power of two nearest (in log scale) to `x`; 1 for zero, negative or non-finite `x`.
pub fn pow2_near<T: Real>(x: T) -> T {
    if !(x.is_finite() && x > T::zero()) {
        return T::one();
    }
    let e = libm::round(libm::log2(x.as_f64())).clamp(-120.0, 120.0);
    T::lit(libm::exp2(e))
}

impl<T: Real> crate::model::ErrorModel<T, NX, 1> for InsModel<T> {
    fn dt(&self) -> T {
        self.dt
    }

    fn scaling(&self) -> Result<[T; NX], ModelError> {
        InsModel::scaling(self).map(|s| crate::linalg::from_vec(&s.transpose()))
    }

    #[allow(non_snake_case)]
    fn system(
        &self,
        scale: &[T; NX],
    ) -> Result<crate::model::ContinuousSystem<T, NX, 1>, ModelError> {
        let c = self.continuous(&crate::linalg::to_vec(scale))?;
        Ok(crate::model::ContinuousSystem {
            A: from_mat(&c.A),
            Qc: from_mat(&c.Qc),
            P0: from_mat(&c.P0),
            H: [crate::linalg::from_vec(&c.H)],
            R: [self.sigma_v * self.sigma_v],
            n: c.n,
        })
    }

    /// The inherent [`InsModel::discretise_block`] (the same function on the same matrices,
    /// without building `P0` and `H`): a jump re-discretises every bank member in one tick.
    fn discrete(&self, scale: &[T; NX]) -> Result<(Arr<T, NX>, Arr<T, NX>), ModelError> {
        self.discretise_block(&crate::linalg::to_vec(scale))
    }

    fn blocks(&self, f: &mut dyn FnMut(crate::model::StateBlock)) {
        let nav = |name, start| crate::model::StateBlock {
            name,
            start,
            width: 1,
            component: None,
        };
        f(nav("vel", idx::DV as u8));
        f(nav("tilt", idx::DELTA as u8));
        if let Ok(layout) = self.layout() {
            for slot in layout.iter().filter(|s| s.states > 0) {
                f(crate::model::StateBlock {
                    name: slot.sensor.name(),
                    start: slot.start as u8,
                    width: slot.states as u8,
                    component: self.component(slot).map(|c| c.kind()),
                });
            }
        }
    }

    fn same_layout(&self, other: &Self) -> bool {
        matches!((self.layout(), other.layout()), (Ok(a), Ok(b)) if a == b)
    }
}
