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

use crate::adapt::params::{apply, specs, theta_of, Specs, MAXP};
use crate::model::{ErrorModel, InsModel, NX};
use crate::Real;

/// An [`ErrorModel`] whose noise parameters the bank can set. `theta` holds the natural
/// logarithms of the parameters `specs` names, in order (unused entries are ignored).
pub trait IdentifiableModel<T: Real, const N: usize, const Z: usize>:
    ErrorModel<T, N, Z> + Clone
{
    /// A compile-time placeholder (a bank is built inside a `static` on the firmware, then
    /// initialised in place).
    const BLANK: Self;

    /// A copy with the parameters `specs` at `exp(theta)`; `None` if a spec does not address
    /// this model or a value is not positive and finite.
    fn with_parameters(&self, specs: &Specs, theta: &[T; MAXP]) -> Option<Self>;

    /// Every parameter this model lets the bank identify, in `theta` order (at most
    /// [`MAXP`]).
    fn identified(&self) -> Specs;

    /// The natural logarithms of the parameters `specs` names, in order (`0` for a spec that
    /// does not address this model; the entries after `specs.len()` are `0`).
    fn parameters(&self, specs: &Specs) -> [T; MAXP];
}

impl<T: Real> IdentifiableModel<T, NX, 1> for InsModel<T> {
    const BLANK: Self = InsModel::BLANK;

    fn with_parameters(&self, specs: &Specs, theta: &[T; MAXP]) -> Option<Self> {
        apply(self, specs, theta)
    }

    fn identified(&self) -> Specs {
        specs(self)
    }

    fn parameters(&self, specs: &Specs) -> [T; MAXP] {
        theta_of(self, specs)
    }
}
