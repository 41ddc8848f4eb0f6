//! What one step of the [`AdaptiveFilter`](super::AdaptiveFilter) reports ([`StepStatus`],
//! [`StepReport`]): the per-step telemetry the firmware logs and the host tools count, kept
//! apart from the filter's state and its update.

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StepStatus {
    /// The observation was used by every bank member.
    Updated,
    /// The observation was missing (non-finite): prediction only.
    Missing,
    /// The centre filter had an invalid innovation variance (its state was repaired).
    BadInnovationVariance,
    /// The observation failed the outlier gate and no filter used it (prediction only).
    Gated,
}

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
