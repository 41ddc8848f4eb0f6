//! What one step of the [`AdaptiveFilter`](super::AdaptiveFilter) reports ([`StepStatus`],
//! [`StepReport`]): the per-step telemetry the firmware logs and the host tools count, kept
//! apart from the filter's state and its update.

use crate::filter::UpdateStatus;

/// What one step did: the kernel's [`UpdateStatus`], as the bank's centre saw the observation.
/// `Updated`: used by every bank member; `Missing`: non-finite, prediction only; `Gated`: failed
/// the outlier gate, used by no filter; `BadInnovationVariance`: the centre's variance was
/// invalid (its state is repaired).
pub type StepStatus = UpdateStatus;

/// The result of one step.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StepReport<T> {
    /// Centre innovation `nu` (NaN when missing).
    pub innovation: T,
    /// Centre innovation variance `S` (NaN when missing).
    pub variance: T,
    /// What happened.
    pub status: StepStatus,
    /// The parameters moved at the end of this step.
    pub moved: bool,
    /// The move was a jump to a probe (basin change).
    pub jumped: bool,
    /// A parameter update was attempted and failed (the model was rejected; `theta` kept).
    pub rejected: bool,
    /// A parameter update hit a physical bound and was clamped.
    pub clamped: bool,
    /// The model's structure changed at the end of this step (one component's kind replaced
    /// by the global stage's structure test; `jumped` and `moved` are set too).
    pub switched: bool,
    /// The change detector found a change in service on this step
    /// ([`change`](super::change)): the global stage's windows start after it.
    pub changed: bool,
}
