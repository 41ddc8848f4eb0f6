//! The WGS-84 Earth model of the NED mechanisation: radii of curvature, normal gravity, Earth
//! rate and transport rate (Groves, *Principles of GNSS, Inertial and Multisensor Integrated
//! Navigation Systems*, 2nd ed., §2.4 and §2.4.7; NIMA TR8350.2 for the constants).
//!
//! Every function is generic over [`Real`]: the host evaluates them in `f64`, the firmware in
//! `f32` (the geodetic origin of [`Strapdown`](super::Strapdown) is evaluated in `f64` on both).
//!
//! Gravity is the normal (ellipsoidal) gravity along the local down axis only: its north
//! component (below 1e-8 g below 10 km, Groves eq. 2.140) is neglected here *and* in the
//! simulator of hal-sim, which calls these same functions.
//!
//! ```
//! use imu_ident::strapdown::earth;
//! // Somigliana at the equator and pole gives the defining values back.
//! assert!((earth::normal_gravity(0.0f64, 0.0) - earth::GAMMA_E).abs() < 1e-12);
//! let pole = core::f64::consts::FRAC_PI_2;
//! assert!((earth::normal_gravity(pole, 0.0f64) - earth::GAMMA_P).abs() < 1e-9);
//! ```

use crate::Real;
use nalgebra::Vector3;

/// Semi-major axis `a` [m].
pub const A: f64 = 6_378_137.0;
/// Flattening `f`.
pub const F: f64 = 1.0 / 298.257_223_563;
/// Semi-minor axis `b = a (1 - f)` [m].
pub const B: f64 = A * (1.0 - F);
/// First eccentricity squared `e^2 = f (2 - f)`.
pub const E2: f64 = F * (2.0 - F);
/// Earth rotation rate `omega_ie` [rad/s].
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// Earth gravitational constant `mu = GM` [m^3/s^2].
pub const GM: f64 = 3.986_004_418e14;
/// Normal gravity at the equator [m/s^2].
pub const GAMMA_E: f64 = 9.780_325_335_9;
/// Normal gravity at the poles [m/s^2].
pub const GAMMA_P: f64 = 9.832_184_937_8;

/// `1 - e^2 sin^2(lat)`, the common factor of the radii, from `sin(lat)`.
fn one_minus_e2_sin2<T: Real>(s: T) -> T {
    T::one() - T::lit(E2) * s * s
}

/// `R_N` from `d = 1 - e^2 sin^2 L` and its square root (the one expression of [`Latitude`]
/// and [`radius_north`]).
fn radius_north_of<T: Real>(d: T, sqrt_d: T) -> T {
    T::lit(A * (1.0 - E2)) / (d * sqrt_d)
}

/// `R_E` from `sqrt(1 - e^2 sin^2 L)`.
fn radius_east_of<T: Real>(sqrt_d: T) -> T {
    T::lit(A) / sqrt_d
}

/// Somigliana's `gamma_0(L)` from `sin L` and `sqrt(1 - e^2 sin^2 L)`.
fn gamma0_of<T: Real>(s: T, sqrt_d: T) -> T {
    T::lit(GAMMA_E) * (T::one() + T::lit(SOMIGLIANA_K) * s * s) / sqrt_d
}

/// The functions of the latitude the mechanisation needs at every IMU sample (the sine, cosine
/// and tangent, the two radii and Somigliana's gravity on the ellipsoid), each evaluated once:
/// the free functions below give the same values bit for bit (they share the expressions, or
/// are this type's), but one step had evaluated the sine seven times and the tangent twice
/// (perf: the trigonometry was a third of the mechanisation; BENCHMARKS.md "CI time:
/// bit-exact kernels").
#[derive(Debug, Clone, Copy)]
pub struct Latitude<T> {
    sin: T,
    cos: T,
    tan: T,
    /// `R_N` and `R_E` [m].
    rn: T,
    re: T,
    /// `gamma_0(L)` [m/s^2].
    g0: T,
}

impl<T: Real> Latitude<T> {
    /// The functions of `lat` [rad].
    pub fn new(lat: T) -> Self {
        let s = lat.sin();
        let d = one_minus_e2_sin2(s);
        let sqrt_d = d.sqrt();
        Self {
            sin: s,
            cos: lat.cos(),
            tan: lat.tan(),
            rn: radius_north_of(d, sqrt_d),
            re: radius_east_of(sqrt_d),
            g0: gamma0_of(s, sqrt_d),
        }
    }

    /// `sin L`.
    pub fn sin(&self) -> T {
        self.sin
    }

    /// `cos L`.
    pub fn cos(&self) -> T {
        self.cos
    }

    /// [`radius_north`].
    pub fn radius_north(&self) -> T {
        self.rn
    }

    /// [`radius_east`].
    pub fn radius_east(&self) -> T {
        self.re
    }

    /// [`normal_gravity`] at height `h` [m].
    pub fn normal_gravity(&self, h: T) -> T {
        self.g0 * free_air(h)
    }

    /// [`earth_rate_ned`].
    pub fn earth_rate_ned(&self) -> Vector3<T> {
        let w = T::lit(OMEGA_IE);
        Vector3::new(w * self.cos, T::zero(), -w * self.sin)
    }

    /// [`transport_rate_ned`] at velocity `v` and height `h`.
    pub fn transport_rate_ned(&self, v: &Vector3<T>, h: T) -> Vector3<T> {
        let re = self.re + h;
        let rn = self.rn + h;
        Vector3::new(v.y / re, -v.x / rn, -v.y * self.tan / re)
    }
}

/// Meridian (north-south) radius of curvature `R_N = a (1 - e^2) / (1 - e^2 sin^2 L)^(3/2)`
/// (Groves eq. 2.105) [m].
pub fn radius_north<T: Real>(lat: T) -> T {
    let d = one_minus_e2_sin2(lat.sin());
    radius_north_of(d, d.sqrt())
}

/// Transverse (east-west) radius of curvature `R_E = a / sqrt(1 - e^2 sin^2 L)`
/// (Groves eq. 2.106) [m].
pub fn radius_east<T: Real>(lat: T) -> T {
    radius_east_of(one_minus_e2_sin2(lat.sin()).sqrt())
}

/// Somigliana's `k = b gamma_p / (a gamma_e) - 1`.
const SOMIGLIANA_K: f64 = B * GAMMA_P / (A * GAMMA_E) - 1.0;

/// The free-air factor `1 - 2/a (1 + f + omega^2 a^2 b / mu) h + 3 h^2 / a^2`.
fn free_air<T: Real>(h: T) -> T {
    const M: f64 = OMEGA_IE * OMEGA_IE * A * A * B / GM;
    let lin = T::lit(2.0 / A * (1.0 + F + M));
    let quad = T::lit(3.0 / (A * A));
    T::one() - lin * h + quad * h * h
}

/// Normal gravity on the ellipsoid by Somigliana's closed form (Groves eq. 2.134):
/// `gamma_0(L) = gamma_e (1 + k sin^2 L) / sqrt(1 - e^2 sin^2 L)`, `k = b gamma_p / (a gamma_e) - 1`;
/// then the free-air height correction to second order (Groves eq. 2.139):
/// `gamma(L, h) = gamma_0(L) [1 - 2/a (1 + f + omega^2 a^2 b / mu) h + 3 h^2 / a^2]` [m/s^2].
pub fn normal_gravity<T: Real>(lat: T, h: T) -> T {
    let s = lat.sin();
    gamma0_of(s, one_minus_e2_sin2(s).sqrt()) * free_air(h)
}

/// Gravity vector in NED, `g^n = (0, 0, gamma(L, h))` (down positive).
pub fn gravity_ned<T: Real>(lat: T, h: T) -> Vector3<T> {
    Vector3::new(T::zero(), T::zero(), normal_gravity(lat, h))
}

/// Earth rate resolved in NED, `omega_ie^n = omega_ie (cos L, 0, -sin L)` (Groves eq. 2.123)
/// [rad/s].
pub fn earth_rate_ned<T: Real>(lat: T) -> Vector3<T> {
    Latitude::new(lat).earth_rate_ned()
}

/// Transport rate (rotation of NED over the Earth) from the NED velocity and position
/// (Groves eq. 5.44):
/// `omega_en^n = (v_E / (R_E + h), -v_N / (R_N + h), -v_E tan L / (R_E + h))` [rad/s].
pub fn transport_rate_ned<T: Real>(v: &Vector3<T>, lat: T, h: T) -> Vector3<T> {
    Latitude::new(lat).transport_rate_ned(v, h)
}

/// Rates of the curvilinear position `(L', lambda', h')` from the NED velocity
/// (Groves eq. 2.111): `L' = v_N / (R_N + h)`, `lambda' = v_E / ((R_E + h) cos L)`, `h' = -v_D`.
pub fn geodetic_rates<T: Real>(v: &Vector3<T>, lat: T, h: T) -> Vector3<T> {
    let re = radius_east(lat) + h;
    let rn = radius_north(lat) + h;
    Vector3::new(v.x / rn, v.y / (re * lat.cos()), -v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gravity_matches_published_values() {
        // WGS-84 defining normal gravity at the equator and at the poles (NIMA TR8350.2 §4).
        assert!((normal_gravity(0.0f64, 0.0) - 9.780_325_335_9).abs() < 1e-9);
        let pole = core::f64::consts::FRAC_PI_2;
        assert!((normal_gravity(pole, 0.0f64) - 9.832_184_937_8).abs() < 1e-9);
        assert!((normal_gravity(-pole, 0.0f64) - 9.832_184_937_8).abs() < 1e-9);
        // Free-air gradient: the conventional -0.3086 mGal/m (Groves §2.4.7) within 1 %.
        let l = 45f64.to_radians();
        let grad = (normal_gravity(l, 100.0f64) - normal_gravity(l, 0.0f64)) / 100.0;
        assert!((grad + 3.086e-6).abs() < 0.03e-6, "{grad}");
        // f32 agrees to its precision.
        assert!(
            (f64::from(normal_gravity(0.7f32, 300.0)) - normal_gravity(0.7, 300.0)).abs() < 2e-6
        );
    }

    /// The functions evaluated once per latitude are the free functions' values, bit for bit,
    /// in both precisions, from pole to pole.
    #[test]
    fn latitude_gives_the_free_functions_bits() {
        fn check<T: Real>(lat: T, h: T, v: Vector3<T>) {
            let at = Latitude::new(lat);
            let bits = |x: Vector3<T>| x.map(|c| c.as_f64().to_bits());
            assert_eq!(
                at.normal_gravity(h).as_f64().to_bits(),
                normal_gravity(lat, h).as_f64().to_bits()
            );
            assert_eq!(bits(at.earth_rate_ned()), bits(earth_rate_ned(lat)));
            let radii = (at.radius_north(), at.radius_east());
            assert_eq!(radii, (radius_north(lat), radius_east(lat)));
            assert_eq!((at.sin(), at.cos()), (lat.sin(), lat.cos()));
            assert_eq!(
                bits(at.transport_rate_ned(&v, h)),
                bits(transport_rate_ned(&v, lat, h))
            );
        }
        for k in -89..=89 {
            let lat = f64::from(k) * 0.0175 + 1e-3 * f64::from(k % 7);
            let h = f64::from(k) * 37.0;
            let v = Vector3::new(12.5 - f64::from(k), 0.3 * f64::from(k), -1.5);
            check(lat, h, v);
            check(lat as f32, h as f32, v.map(|x| x as f32));
        }
    }

    #[test]
    fn radii_at_equator_and_pole() {
        assert!((radius_east(0.0f64) - A).abs() < 1e-6);
        assert!((radius_north(0.0f64) - A * (1.0 - E2)).abs() < 1e-6);
        let pole = core::f64::consts::FRAC_PI_2;
        // At the pole both radii equal a^2 / b.
        assert!((radius_north(pole) - A * A / B).abs() < 1e-6);
        assert!((radius_east(pole) - A * A / B).abs() < 1e-6);
    }

    #[test]
    fn rates_signs() {
        let w = earth_rate_ned(0.5f64);
        assert!(w.x > 0.0 && w.z < 0.0 && (w.norm() - OMEGA_IE).abs() < 1e-18);
        // Moving north tilts NED about -east; moving east about +north and (north hemisphere) -down.
        let t = transport_rate_ned(&Vector3::new(10.0, 0.0, 0.0), 0.5f64, 0.0);
        assert!(t.y < 0.0 && t.x == 0.0);
        let t = transport_rate_ned(&Vector3::new(0.0, 10.0, 0.0), 0.5f64, 0.0);
        assert!(t.x > 0.0 && t.z < 0.0);
        let r = geodetic_rates(&Vector3::new(0.0, 0.0, -2.0), 0.5f64, 0.0);
        assert_eq!(r.z, 2.0);
    }
}
