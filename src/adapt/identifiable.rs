//! What the identification bank needs of an error model: the [`ErrorModel`] itself (scaling,
//! continuous system, observation rows) and a way to set its identified parameters.
//!
//! The bank ([`Bank`](crate::adapt::bank::Bank)) discretises each member's model with the crate's
//! one discretisation ([`discretise_block`](crate::model::discretise::discretise_block)) in the
//! scaling of the model it started with, and fuses each of the `Z` observation axes as a
//! sequential scalar update; it never looks inside the model. The one-channel
//! [`InsModel`](crate::model::InsModel) is the first implementation; another model gives its own
//! meaning to the [`ParamSpec`](crate::adapt::params::ParamSpec)s it is asked to set.
//!
//! ```
//! use imu_ident::adapt::identifiable::IdentifiableModel;
//! use imu_ident::adapt::params::{specs, theta_of, value};
//! use imu_ident::model::InsModel;
//! let paper = InsModel::<f64>::paper();
//! let sp = specs(&paper);
//! let mut theta = theta_of(&paper, &sp);
//! theta[1] += core::f64::consts::LN_2; // the accelerometer's correlation time, doubled
//! let moved = paper.with_parameters(&sp, &theta).unwrap();
//! let (was, now) = (value(&paper, &sp[1]).unwrap(), value(&moved, &sp[1]).unwrap());
//! assert!((now - 2.0 * was).abs() < 1e-9);
//! ```

use crate::adapt::params::{apply, specs, theta_of, Site, Specs, MAXP};
use crate::linalg::Arr;
use crate::model::{
    idx, Component, ComponentKind, ErrorModel, ErrorSource, ExpCosine, GaussMarkov, InsModel,
    ModelError, Quantity, StateRow, NX,
};
use crate::Real;

/// Loose initial standard deviations of a window pass's velocity [m/s] and tilt [rad] errors
/// (`window_start` of [`InsModel`]). The velocity starts at the first block mean, which differs
/// from the velocity error at the block's end by half a block of its slope (about 0.75 m/s for
/// a free Schuler loop 20 m/s in amplitude and 60-s blocks); a free one-channel INS's tilt
/// stays within a few mrad in a day. Not larger: the first update's `P - K S K^T` cancels about
/// `P / R` of precision, and with 300 m/s every f32 pass broke (measured).
const DIFFUSE_DV: f64 = 2.0;
const DIFFUSE_TILT: f64 = 0.01;

/// An [`ErrorModel`] whose noise parameters the bank can set. `theta` holds the natural
/// logarithms of the parameters `specs` names, in order (unused entries are ignored).
pub trait IdentifiableModel<T: Real, const N: usize, const Z: usize>:
    ErrorModel<T, N, Z> + Clone
{
    /// A compile-time placeholder (a bank is built inside a `static` on the firmware, then
    /// initialised in place).
    const BLANK: Self;

    /// What the adaptive filter keeps of the model to report its estimates, computed once per
    /// model ([`outputs`](Self::outputs)): for [`InsModel`], the rows that sum each sensor's
    /// component states.
    type Outputs: Copy + core::fmt::Debug;
    /// A compile-time placeholder of [`Outputs`](Self::Outputs).
    const NO_OUTPUTS: Self::Outputs;
    /// The [`Outputs`](Self::Outputs) of this model in the scaling `scale`.
    fn outputs(&self, scale: &[T; N]) -> Result<Self::Outputs, ModelError>;

    /// A copy with the parameters `specs` at `exp(theta)`; `None` if a spec does not address
    /// this model or a value is not positive and finite.
    fn with_parameters(&self, specs: &Specs, theta: &[T; MAXP]) -> Option<Self>;

    /// Every parameter this model lets the bank identify, in `theta` order (at most
    /// [`MAXP`]).
    fn identified(&self) -> Specs;

    /// The natural logarithms of the parameters `specs` names, in order (`0` for a spec that
    /// does not address this model; the entries after `specs.len()` are `0`).
    fn parameters(&self, specs: &Specs) -> [T; MAXP];

    /// The start of a pass of the global stage ([`window`](crate::adapt::window)), whose window
    /// begins hours into the run: `p0` (the model's `P0`) and `x0` (zero) are changed where the
    /// model's prior does not describe the states there, in the scaling `scale`; `z0` is the
    /// window's first finite block mean on each axis (NaN where an axis has none). The default
    /// keeps the prior: right for states that are stationary noise processes.
    fn window_start(&self, scale: &[T; N], p0: &mut Arr<T, N>, x0: &mut [T; N], z0: &[T; Z]) {
        let _ = (scale, p0, x0, z0);
    }

    /// The `k`-th component whose kind the structure test may replace, with the kind it would
    /// become ([`window::structure`](crate::adapt::window::structure)). The default offers none.
    fn site(&self, k: usize) -> Option<Site> {
        let _ = k;
        None
    }

    /// A copy with the component at `site` replaced by one of `site.kind` with the same `sigma`
    /// and `tau` (and `beta` when the new kind has one); `None` if there is no such site.
    fn swapped(&self, site: &Site, beta: T) -> Option<Self> {
        let _ = (site, beta);
        None
    }

    /// For each state of `to`, the state of `self` that carries the same quantity (`None`: a
    /// new state), to carry a filter's state across a structure switch. The default maps each
    /// state to itself when the layouts are the same. `None`: the state cannot be carried.
    fn state_map(&self, to: &Self) -> Option<[Option<usize>; N]> {
        if !self.same_layout(to) {
            return None;
        }
        let mut map = [None; N];
        for (i, m) in map.iter_mut().enumerate() {
            *m = Some(i);
        }
        Some(map)
    }
}

impl<T: Real> IdentifiableModel<T, NX, 1> for InsModel<T> {
    const BLANK: Self = InsModel::BLANK;

    /// The accelerometer's and the gyro's output rows ([`InsModel::output_row`]).
    type Outputs = (StateRow<T>, StateRow<T>);
    const NO_OUTPUTS: Self::Outputs = (
        StateRow::from_array_storage(nalgebra::ArrayStorage([[T::ZERO; 1]; NX])),
        StateRow::from_array_storage(nalgebra::ArrayStorage([[T::ZERO; 1]; NX])),
    );

    fn outputs(&self, scale: &[T; NX]) -> Result<Self::Outputs, ModelError> {
        self.output_rows(scale)
    }

    fn with_parameters(&self, specs: &Specs, theta: &[T; MAXP]) -> Option<Self> {
        apply(self, specs, theta)
    }

    fn identified(&self) -> Specs {
        specs(self)
    }

    fn parameters(&self, specs: &Specs) -> [T; MAXP] {
        theta_of(self, specs)
    }

    /// Diffuse velocity and tilt: the window begins hours into the run, where they are far
    /// outside the model's initial covariance (a free Schuler loop drifts to metres per
    /// second). A tight prior there makes the first innovations dominate the comparison and
    /// favours whichever model absorbs them fastest (measured: 386 nats for a 10x accelerometer
    /// sigma). Velocity starts at the first block mean.
    fn window_start(&self, scale: &[T; NX], p0: &mut Arr<T, NX>, x0: &mut [T; NX], z0: &[T; 1]) {
        for (i, sd) in [(idx::DV, DIFFUSE_DV), (idx::DELTA, DIFFUSE_TILT)] {
            let s = scale.get(i).copied().unwrap_or(T::one());
            for row in p0.iter_mut() {
                if let Some(v) = row.get_mut(i) {
                    *v = T::zero();
                }
            }
            if let Some(row) = p0.get_mut(i) {
                row.fill(T::zero());
                if let Some(v) = row.get_mut(i) {
                    let sd = T::lit(sd) / s;
                    *v = sd * sd;
                }
            }
        }
        if let (Some(x), Some(s)) = (x0.get_mut(idx::DV), scale.get(idx::DV)) {
            *x = z0[0] / *s;
        }
    }

    /// The Gauss-Markov and exponential-cosine components (the kind table's
    /// [`alternative`](ComponentKind::alternative)), accelerometer first, in component order.
    fn site(&self, k: usize) -> Option<Site> {
        components(self)
            .filter_map(|(sensor, i, c)| {
                let kind = c.kind().alternative()?;
                let index = u8::try_from(i).ok()?;
                Some(Site {
                    sensor,
                    index,
                    kind,
                })
            })
            .nth(k)
    }

    fn swapped(&self, site: &Site, beta: T) -> Option<Self> {
        let mut m = self.clone();
        let list = match site.sensor {
            ErrorSource::Accel => &mut m.accel,
            ErrorSource::Gyro => &mut m.gyro,
            ErrorSource::Observation => return None,
        };
        let c = list.get_mut(usize::from(site.index))?;
        if c.kind().alternative() != Some(site.kind) {
            return None;
        }
        let sigma = c.get(Quantity::Sigma)?;
        let tau = c.get(Quantity::Tau)?;
        *c = match site.kind {
            ComponentKind::GaussMarkov => Component::GaussMarkov(GaussMarkov { sigma, tau }),
            ComponentKind::ExpCosine => Component::ExpCosine(ExpCosine { sigma, tau, beta }),
            _ => return None,
        };
        Some(m)
    }

    /// The navigation errors map to themselves; a component's states to its twin in `self`
    /// (same sensor, index, width and kind).
    fn state_map(&self, to: &Self) -> Option<[Option<usize>; NX]> {
        let (lo, ln) = (self.layout().ok()?, to.layout().ok()?);
        let mut map = [None; NX];
        if let Some(m) = map.get_mut(idx::DV) {
            *m = Some(idx::DV);
        }
        if let Some(m) = map.get_mut(idx::DELTA) {
            *m = Some(idx::DELTA);
        }
        for s in &ln {
            let kind = to.component(s).map(|c| c.kind());
            let twin = lo.iter().find(|o| {
                o.sensor == s.sensor
                    && o.index == s.index
                    && o.states == s.states
                    && self.component(o).map(|c| c.kind()) == kind
            });
            if let Some(o) = twin {
                for k in 0..s.states {
                    if let Some(m) = map.get_mut(s.start + k) {
                        *m = Some(o.start + k);
                    }
                }
            }
        }
        Some(map)
    }
}

fn components<T: Real>(
    model: &InsModel<T>,
) -> impl Iterator<Item = (ErrorSource, usize, &Component<T>)> {
    let a = model
        .accel
        .iter()
        .enumerate()
        .map(|(i, c)| (ErrorSource::Accel, i, c));
    let g = model
        .gyro
        .iter()
        .enumerate()
        .map(|(i, c)| (ErrorSource::Gyro, i, c));
    a.chain(g)
}
