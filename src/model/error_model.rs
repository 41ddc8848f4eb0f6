//! The error-model abstraction: what a Kalman filter of INS errors needs to know about a model,
//! whatever the number of axes.
//!
//! An error model gives, in *scaled* states `x' = S^-1 x` (every state O(1), see
//! [`Scaling`](crate::model::Scaling)):
//! - its named state blocks with their widths (PX4-style: `tilt{1,1}`, `vel{0,1}`,
//!   `accel_gm{2,1}`...), for records, reports and per-block access;
//! - the continuous dynamics `A` and noise intensity `Qc = S^-1 G Q G^T S^-1`, and the initial
//!   covariance `P0`, over its `n <= N` active states;
//! - `Z` observation rows `H_i` (scaled) with their noise variances `R_i` (independent axes, so
//!   that a vector observation is fused as `Z` sequential scalar updates);
//! - the step `dt`.
//!
//! The one-channel Schuler model of METHOD.md §5 ([`InsModel`](crate::model::InsModel)) is the
//! first implementation (`N = NX`, `Z = 1`); the strapdown error state of issue 16 is the next.
//! [`ErrorStateFilter`](crate::filter::ErrorStateFilter) runs any of them on the one Kalman
//! kernel.

use crate::linalg::Arr;
use crate::model::discretise::discretise_block;
use crate::model::{ComponentKind, ModelError};
use crate::Real;

/// A named block of consecutive states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StateBlock {
    /// Name used in records and reports: a navigation error (`"vel"`, `"tilt"`) or the sensor
    /// a noise component belongs to (`"accel"`, `"gyro"`, `"observation"`).
    pub name: &'static str,
    /// The noise component's kind, for sensor-error blocks.
    pub component: Option<ComponentKind>,
    /// First state index.
    pub start: u8,
    /// Number of states.
    pub width: u8,
}

/// The continuous-time system of an error model in scaled states, as the kernel's row-major
/// arrays.
#[allow(non_snake_case)]
#[derive(Debug, Clone, PartialEq)]
pub struct ContinuousSystem<T: Real, const N: usize, const Z: usize> {
    /// Dynamics `A'`.
    pub A: Arr<T, N>,
    /// Noise intensity `Qc'`.
    pub Qc: Arr<T, N>,
    /// Initial covariance `P0'`.
    pub P0: Arr<T, N>,
    /// Observation rows `H_i' = H_i S`.
    pub H: [[T; N]; Z],
    /// Observation noise variances `R_i` (physical units of the observation).
    pub R: [T; Z],
    /// Number of active states (the leading block; the rest is decoupled and zero).
    pub n: usize,
}

/// An INS error model with up to `N` states and `Z` observation axes.
pub trait ErrorModel<T: Real, const N: usize, const Z: usize> {
    /// The filter step [s].
    fn dt(&self) -> T;
    /// The diagonal state scaling `S` (physical = `S` x scaled), chosen from the model's
    /// magnitudes; a filter keeps the scaling of the model it started with.
    fn scaling(&self) -> Result<[T; N], ModelError>;
    /// The continuous system in the states scaled by `scale`.
    fn system(&self, scale: &[T; N]) -> Result<ContinuousSystem<T, N, Z>, ModelError>;
    /// `(A', Qc', n)`: the part of [`system`](Self::system) a prediction needs. A model may
    /// override it to skip building `P0`, `H` and `R` (the strapdown error model does: the
    /// navigator relinearises it at every filter step, and the bank's shadows each take it).
    #[allow(non_snake_case, clippy::type_complexity)]
    fn dynamics(&self, scale: &[T; N]) -> Result<(Arr<T, N>, Arr<T, N>, usize), ModelError> {
        let ContinuousSystem { A, Qc, n, .. } = self.system(scale)?;
        Ok((A, Qc, n))
    }
    /// `(Phi, Qd)` over the active block in the states scaled by `scale`: the crate's one
    /// discretisation ([`discretise_block`]) of [`dynamics`](Self::dynamics) at
    /// [`dt`](Self::dt). A model may override it to skip building the parts of the system it
    /// does not need (the identification bank calls it once per member and parameter move).
    #[allow(non_snake_case)]
    fn discrete(&self, scale: &[T; N]) -> Result<(Arr<T, N>, Arr<T, N>), ModelError> {
        let (A, Qc, n) = self.dynamics(scale)?;
        discretise_block(&A, &Qc, self.dt(), n)
    }
    /// Calls `f` with each named state block, in state order.
    fn blocks(&self, f: &mut dyn FnMut(StateBlock));
    /// True when `other` has the same state layout (same blocks), so that a filter's `x, P`
    /// stay meaningful when it switches from `self` to `other`.
    fn same_layout(&self, other: &Self) -> bool;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{InsModel, NX};

    /// The system with `discrete` left to the trait's default.
    struct ByDefault(InsModel<f32>);

    impl ErrorModel<f32, NX, 1> for ByDefault {
        fn dt(&self) -> f32 {
            self.0.dt
        }
        fn scaling(&self) -> Result<[f32; NX], ModelError> {
            ErrorModel::scaling(&self.0)
        }
        fn system(&self, scale: &[f32; NX]) -> Result<ContinuousSystem<f32, NX, 1>, ModelError> {
            self.0.system(scale)
        }
        fn blocks(&self, f: &mut dyn FnMut(StateBlock)) {
            self.0.blocks(f)
        }
        fn same_layout(&self, other: &Self) -> bool {
            self.0.same_layout(&other.0)
        }
    }

    /// `InsModel` overrides `discrete` only to skip building `P0` and `H`: its `(Phi, Qd)` are
    /// the default's bit for bit (the one discretisation), in a scaling other than its own.
    #[test]
    fn the_one_channel_shortcut_is_the_default_discretisation() {
        let model = InsModel::<f32>::paper();
        let mut scale = ErrorModel::scaling(&model).unwrap();
        scale[0] *= 4.0;
        scale[3] *= 0.125;
        let ours = model.discrete(&scale).unwrap();
        let default = ByDefault(model).discrete(&scale).unwrap();
        assert_eq!(ours, default);
        assert!(ours.0[0][0] != 0.0 && ours.1[0][0] > 0.0);
    }
}
