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
    /// The binary exponent `x` of `self = m 2^x`, `m` in `[1/2, 1)` (`frexp`'s; 0 for zero, NaN
    /// and infinities). Bit operations in this precision: on the MCU's single-precision FPU an
    /// `f64` detour is software arithmetic.
    fn binary_exponent(self) -> i32;
    /// `2^e` in this precision (`ldexp(1, e)`): exact while `e` is within the exponent range.
    fn pow2(e: i32) -> Self;
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
    #[inline]
    fn binary_exponent(self) -> i32 {
        libm::frexp(self).1
    }
    #[inline]
    fn pow2(e: i32) -> Self {
        libm::ldexp(1.0, e)
    }
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
    #[inline]
    fn binary_exponent(self) -> i32 {
        libm::frexpf(self).1
    }
    #[inline]
    fn pow2(e: i32) -> Self {
        libm::ldexpf(1.0, e)
    }
}

#[cfg(test)]
mod tests {
    use super::Real;

    /// The single-precision exponent helpers give the bits the `f64` detour gave (the
    /// discretisation's balancing relies on it: the same `D`, so the same orders, as before).
    #[test]
    fn f32_exponents_match_the_f64_detour() {
        let mut x = 1.0e-38f32;
        while x < 3.0e38 {
            for v in [x, -x, x * 1.37, x * 0.51] {
                assert_eq!(v.binary_exponent(), libm::frexp(f64::from(v)).1, "{v}");
            }
            x *= 1.9;
        }
        for v in [0.0f32, f32::MIN_POSITIVE / 8.0, f32::INFINITY, f32::NAN] {
            assert_eq!(v.binary_exponent(), libm::frexp(f64::from(v)).1, "{v}");
        }
        for e in -126..=127 {
            assert_eq!(f32::pow2(e), f64::pow2(e) as f32, "{e}");
            assert_eq!(f64::from(f32::pow2(e)), libm::ldexp(1.0, e));
        }
    }
}
