//! The scalar type of the estimator: `f64` on the host, `f32` on the Cortex-M4F.
//!
//! Everything numerical in the crate is generic over [`Real`], so the same code runs in double
//! precision (the reference) and in single precision (the firmware), and the two are compared by
//! tests on long runs rather than assumed to agree.

/// A floating-point scalar usable by the filter and the identification code.
///
/// It is nalgebra's [`RealField`](nalgebra::RealField) (so `sqrt`, `exp`, `ln`, ... come from
/// libm in `no_std`) plus lossless-enough conversions to and from `f64` literals.
///
/// ```
/// use imu_ident::Real;
/// fn half<T: Real>(x: T) -> T { x * T::lit(0.5) }
/// assert_eq!(half(3.0f32), 1.5);
/// assert_eq!(half(3.0f64).as_f64(), 1.5);
/// ```
pub trait Real: nalgebra::RealField + Copy + core::fmt::Debug + Default {
    /// Converts an `f64` constant (rounding to nearest for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both implementations).
    fn as_f64(self) -> f64;
    /// Machine epsilon of this precision.
    const EPS: f64;
    /// `0`, usable in `const` items (blank filters built at compile time, see
    /// [`Estimator::BLANK`](crate::step::Estimator::BLANK)).
    const ZERO: Self;
}

impl Real for f64 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn as_f64(self) -> f64 {
        self
    }
    const EPS: f64 = f64::EPSILON;
    const ZERO: Self = 0.0;
}

impl Real for f32 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn as_f64(self) -> f64 {
        self as f64
    }
    const EPS: f64 = f32::EPSILON as f64;
    const ZERO: Self = 0.0;
}
