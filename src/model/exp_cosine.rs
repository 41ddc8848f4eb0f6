//! Exponential-cosine process (METHOD.md §2, paper eq. 16-17, shaping filter corrected).
//!
//! `K(t) = sigma^2 exp(-alpha |t|) cos(beta t)` is produced by the shaping filter
//! `W(s) = c (s + b) / (s^2 + 2 alpha s + b^2)`, `c = sigma sqrt(2 alpha)`, `b^2 = alpha^2 + beta^2`,
//! realised as
//!
//! ```text
//! x1' = -2 alpha x1 - b^2 x2 + c (b - 2 alpha) xi
//! x2' =  x1                  + c xi
//! ```
//!
//! The sensor error is `x2` (the paper's printed `G` vector is garbled; this is the corrected one).
//! With `beta = 0` the ACF reduces to the Gauss-Markov one.
//!
//! # Two realisations: the paper's for simulation, a damped rotation for the filter
//! At `beta = 0` the paper's realisation cancels a pole against its zero (`W = c / (s + alpha)`):
//! it is not controllable, and its stationary covariance is singular,
//! `det P_inf = sigma^4 (b - alpha)^2 ~ sigma^4 beta^4 / (4 alpha^2)`. A filter started there
//! meets a covariance that is not positive definite once `beta / alpha` is below about `1e-3`
//! in f64 (a Gauss-Markov gyro fitted as an exponential-cosine of a near-zero `beta` lost
//! 3 276 nats of likelihood in 6 h against the same model as a Gauss-Markov). The filter's
//! block ([`crate::model::Component::block`]) therefore uses the same process as a damped
//! rotation driven by two independent white noises of intensity `2 alpha sigma^2` each:
//!
//! ```text
//! [y1']   [-alpha  -beta ] [y1]
//! [y2'] = [ beta   -alpha] [y2] + w,   E[w w^T] = 2 alpha sigma^2 I,   sensor error y1
//! ```
//!
//! Its stationary covariance is `sigma^2 I` (`A + A^T = -2 alpha I`) for every `beta`, and
//! `E[y(t + s) y(t)^T] = sigma^2 exp(-alpha s) R(beta s)`, so `y1` has the same ACF
//! `sigma^2 exp(-alpha |s|) cos(beta s)`: the same Gaussian process, hence the same
//! observations' likelihood, with states that stay well conditioned as `beta -> 0` (where
//! `y2` is an independent Gauss-Markov the output does not see). The simulators keep the
//! paper's realisation ([`ExpCosine::phi`], [`ExpCosine::qd`]), so that a seed draws the same
//! log as before.
//!
//! ```
//! use imu_ident::model::ExpCosine;
//! let ec = ExpCosine::new(1.0f64, 50.0, 0.1).unwrap();
//! assert!((ec.acf(0.0) - 1.0).abs() < 1e-15);
//! // First zero of the ACF at beta t = pi/2.
//! assert!(ec.acf(core::f64::consts::FRAC_PI_2 / 0.1).abs() < 1e-12);
//! ```

use crate::model::ModelError;
use crate::Real;
use nalgebra::{Matrix2, Vector2};

/// An exponential-cosine sensor error: `sigma`, correlation time `tau = 1/alpha`, and angular
/// frequency `beta` [rad/s].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExpCosine<T> {
    /// Stationary standard deviation of the sensor error (`x2`).
    pub sigma: T,
    /// Envelope correlation time [s]; `alpha = 1/tau`.
    pub tau: T,
    /// Oscillation angular frequency [rad/s] (period `2 pi / beta`).
    pub beta: T,
}

impl<T: Real> ExpCosine<T> {
    /// Checks the parameters: `sigma, tau > 0`, `beta >= 0`, all finite.
    pub fn new(sigma: T, tau: T, beta: T) -> Result<Self, ModelError> {
        if !(sigma.is_finite() && sigma > T::zero()) {
            return Err(ModelError::BadSigma);
        }
        if !(tau.is_finite() && tau > T::zero()) {
            return Err(ModelError::BadTau);
        }
        if !(beta.is_finite() && beta >= T::zero()) {
            return Err(ModelError::BadBeta);
        }
        Ok(Self { sigma, tau, beta })
    }

    /// `alpha = 1 / tau`.
    pub fn alpha(&self) -> T {
        T::one() / self.tau
    }

    /// `b = sqrt(alpha^2 + beta^2)`.
    pub fn b(&self) -> T {
        let a = self.alpha();
        (a * a + self.beta * self.beta).sqrt()
    }

    /// Continuous dynamics `A` of `[x1, x2]`.
    pub fn a_matrix(&self) -> Matrix2<T> {
        let a = self.alpha();
        let b = self.b();
        Matrix2::new(-T::lit(2.0) * a, -b * b, T::one(), T::zero())
    }

    /// Noise input vector `G` (unit white noise): `c [b - 2 alpha, 1]`.
    pub fn g_vector(&self) -> Vector2<T> {
        let a = self.alpha();
        let c = self.sigma * (T::lit(2.0) * a).sqrt();
        Vector2::new(c * (self.b() - T::lit(2.0) * a), c)
    }

    /// Stationary covariance of `[x1, x2]` (solution of `A P + P A^T + G G^T = 0`).
    pub fn p_inf(&self) -> Matrix2<T> {
        let a = self.alpha();
        let b = self.b();
        let s2 = self.sigma * self.sigma;
        let d = b - T::lit(2.0) * a;
        Matrix2::new(s2 * (b * b + d * d) / T::lit(2.0), -a * s2, -a * s2, s2)
    }

    /// The filter's realisation (module docs): continuous dynamics of `[y1, y2]`, a damped
    /// rotation.
    pub fn rotation_a(&self) -> Matrix2<T> {
        let a = self.alpha();
        Matrix2::new(-a, -self.beta, self.beta, -a)
    }

    /// The filter's realisation: the intensity `2 alpha sigma^2` of each of its two
    /// independent white noises; its stationary covariance is `sigma^2 I`.
    pub fn rotation_qc(&self) -> T {
        T::lit(2.0) * self.alpha() * self.sigma * self.sigma
    }

    /// Exact transition matrix
    /// `Phi = exp(-alpha dt) [cos(beta dt) I + sin(beta dt)/beta (A + alpha I)]`
    /// (the limit `sin(beta dt)/beta -> dt` is used when `beta dt` is tiny).
    pub fn phi(&self, dt: T) -> Matrix2<T> {
        let a = self.alpha();
        let bd = self.beta * dt;
        // sin(x)/x by its series below 1e-4: the truncation error x^4/120 is under f64 epsilon.
        let sinc_dt = if bd.abs() < T::lit(1e-4) {
            dt * (T::one() - bd * bd / T::lit(6.0))
        } else {
            bd.sin() / self.beta
        };
        let shifted = self.a_matrix() + Matrix2::identity() * a;
        (Matrix2::identity() * bd.cos() + shifted * sinc_dt) * (-a * dt).exp()
    }

    /// Exact `Qd = P_inf - Phi P_inf Phi^T`, valid for any stationary shaping filter.
    pub fn qd(&self, dt: T) -> Matrix2<T> {
        let phi = self.phi(dt);
        let p = self.p_inf();
        let q = p - phi * p * phi.transpose();
        (q + q.transpose()) * T::lit(0.5)
    }

    /// Analytic autocorrelation of the sensor error `x2`.
    pub fn acf(&self, t: T) -> T {
        self.sigma * self.sigma * (-self.alpha() * t.abs()).exp() * (self.beta * t).cos()
    }
}
