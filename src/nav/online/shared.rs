//! The discretisation the shadows share: a coordinate's shadows at `+-d` on an intensity (a
//! white-noise density, a Gauss-Markov or exp-cosine sigma, a random walk's `q`) have the
//! centre's `A`, so its `Phi`; and `Qd` is linear in `Qc` (Van Loan's integral,
//! [`crate::model::discretise`]), with `Qc` moving along one direction `B` as the coordinate
//! moves:
//!
//! ```text
//! Qc(+d) = Qc0 + B,   Qc(-d) = Qc0 + alpha B,   Qd(+d) = Qd0 + Qd(B),   Qd(-d) = Qd0 + alpha Qd(B)
//! ```
//!
//! So one `Q` series over `B` (with the centre's `exp(A h)`, [`Expm`]) serves both shadows,
//! instead of two full discretisations. Nothing about the component kinds is assumed: `A`
//! is compared exactly, `alpha` is read off the two differences and checked on every entry,
//! and a coordinate that fails either test is discretised in full as before. The correlation
//! times, which move `A`, are not offered (`OnlineIdent`'s prediction hook).

use super::shadow::Shadow;
use crate::linalg::Arr;
use crate::model::discretise::Expm;
use crate::nav::error_model::StrapdownErrorModel;
use crate::Real;

/// Largest mismatch allowed between `Qc(-d) - Qc0` and `alpha (Qc(+d) - Qc0)`, relative to
/// the larger difference: far above rounding (`1e-7` in f32), far below a different shape.
const SHAPE_TOL: f64 = 1e-3;

/// The centre shadow's continuous `A, Qc` and discrete `Phi, Qd` of this step.
#[derive(Debug)]
pub(super) struct Centre<T: Real, const N: usize> {
    a: Arr<T, N>,
    qc: Arr<T, N>,
    n: usize,
    expm: Expm<T, N>,
    phi: Arr<T, N>,
    qd: Arr<T, N>,
}

impl<T: Real, const N: usize> Centre<T, N> {
    /// Predicts the centre shadow `sh` over the running filter's step (as
    /// [`Shadow::propagate`]) and keeps what the others can share; `None` when its model
    /// cannot be discretised (then nothing was predicted).
    #[inline(never)]
    pub(super) fn propagate(
        sh: &mut Shadow<T, N>,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x_run: &[T; N],
        p0: &Arr<T, N>,
    ) -> Option<Self> {
        let mut a = [[T::zero(); N]; N];
        let mut qc = [[T::zero(); N]; N];
        let n = sh.dynamics_into(run, scale, &mut a, &mut qc).ok()?;
        let expm = Expm::new(&a, run.dt, n).ok()?;
        let (phi, qd) = expm.discretise(&a, &qc).ok()?;
        sh.predict(&phi, &qd, x_run, p0);
        Some(Self {
            a,
            qc,
            n,
            expm,
            phi,
            qd,
        })
    }

    /// Predicts a GNSS factor's `+d` and `-d` shadows, whose noise model is the centre's: its
    /// `Phi` and `Qd`.
    pub(super) fn propagate_same(
        &self,
        shadows: [&mut Shadow<T, N>; 2],
        x_run: &[T; N],
        p0: &Arr<T, N>,
    ) {
        for sh in shadows {
            sh.predict(&self.phi, &self.qd, x_run, p0);
        }
    }

    /// Predicts a coordinate's `+d` and `-d` shadows, sharing this centre's discretisation
    /// when they differ from it in `Qc` only, along one direction (module docs); otherwise
    /// each in full. Returns the number of shadows that could not be predicted.
    pub(super) fn propagate_coordinate(
        &self,
        plus: &mut Shadow<T, N>,
        minus: &mut Shadow<T, N>,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
        x_run: &[T; N],
        p0: &Arr<T, N>,
    ) -> u32 {
        if let Some((qd_b, alpha)) = self.shared_qd(plus, minus, run, scale) {
            // One buffer for both: `Qd0 + Qd(B)`, then `Qd0 + alpha Qd(B)`.
            let mut qd = self.qd;
            add_scaled(&mut qd, T::one(), &qd_b);
            plus.predict(&self.phi, &qd, x_run, p0);
            qd = self.qd;
            add_scaled(&mut qd, alpha, &qd_b);
            minus.predict(&self.phi, &qd, x_run, p0);
            return 0;
        }
        propagate_each([plus, minus], run, scale, x_run, p0)
    }

    /// `Qd(B)` and `alpha` of a coordinate's `+d` and `-d` shadows (module docs), or `None`
    /// when they do not share the centre's `A` or their `Qc` do not differ from its along
    /// one direction. Kept out of line, as are its helpers, so that their temporaries
    /// (continuous systems, the `Q` series) do not all stay on the firmware's stack at once.
    #[inline(never)]
    pub(super) fn shared_qd(
        &self,
        plus: &mut Shadow<T, N>,
        minus: &mut Shadow<T, N>,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
    ) -> Option<(Arr<T, N>, T)> {
        let b = self.difference(plus, run, scale)?;
        let alpha = self.alpha(minus, &b, run, scale)?;
        Some((self.qd_of(&b)?, alpha))
    }

    /// `Qd(b)` over the centre's `A`.
    #[inline(never)]
    fn qd_of(&self, b: &Arr<T, N>) -> Option<Arr<T, N>> {
        self.expm.discretise(&self.a, b).ok().map(|(_, q)| q)
    }

    /// `alpha` with `Qc - Qc0 = alpha b` for shadow `sh` ([`along`]).
    #[inline(never)]
    fn alpha(
        &self,
        sh: &mut Shadow<T, N>,
        b: &Arr<T, N>,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
    ) -> Option<T> {
        let bm = self.difference(sh, run, scale)?;
        along(&bm, b, self.n)
    }

    /// `Qc - Qc0` of shadow `sh`, when its `A` (and its number of states) is the centre's.
    #[inline(never)]
    fn difference(
        &self,
        sh: &mut Shadow<T, N>,
        run: &StrapdownErrorModel<T>,
        scale: &[T; N],
    ) -> Option<Arr<T, N>> {
        let mut a = [[T::zero(); N]; N];
        let mut qc = [[T::zero(); N]; N];
        let n = sh.dynamics_into(run, scale, &mut a, &mut qc).ok()?;
        if n != self.n || a != self.a {
            return None;
        }
        for (r, r0) in qc.iter_mut().zip(self.qc.iter()) {
            for (v, v0) in r.iter_mut().zip(r0.iter()) {
                *v -= *v0;
            }
        }
        Some(qc)
    }
}

/// `q += k c`.
fn add_scaled<T: Real, const N: usize>(q: &mut Arr<T, N>, k: T, c: &Arr<T, N>) {
    for (rq, rc) in q.iter_mut().zip(c.iter()) {
        for (v, w) in rq.iter_mut().zip(rc.iter()) {
            *v += k * *w;
        }
    }
}

/// `alpha` with `bm = alpha b` on the leading `n` states (to [`SHAPE_TOL`]), or `None`.
fn along<T: Real, const N: usize>(bm: &Arr<T, N>, b: &Arr<T, N>, n: usize) -> Option<T> {
    // The largest entry of `b` fixes alpha.
    let mut big = T::zero();
    let mut alpha = T::zero();
    let mut big_m = T::zero();
    for (rm, r) in bm.iter().zip(b.iter()).take(n) {
        for (vm, v) in rm.iter().zip(r.iter()).take(n) {
            if v.abs() > big {
                big = v.abs();
                alpha = *vm / *v;
            }
            big_m = big_m.max(vm.abs());
        }
    }
    if big == T::zero() {
        // No difference at all (a quantity that moves P0 only): alpha is moot.
        return (big_m == T::zero()).then_some(T::zero());
    }
    let tol = T::lit(SHAPE_TOL) * big_m.max(big * alpha.abs());
    let fits = bm.iter().zip(b.iter()).take(n).all(|(rm, r)| {
        rm.iter()
            .zip(r.iter())
            .take(n)
            .all(|(vm, v)| (*vm - alpha * *v).abs() <= tol)
    });
    (alpha.is_finite() && fits).then_some(alpha)
}

/// Predicts `shadows` each with its own full discretisation; returns how many could not be.
pub(super) fn propagate_each<T: Real, const N: usize>(
    shadows: [&mut Shadow<T, N>; 2],
    run: &StrapdownErrorModel<T>,
    scale: &[T; N],
    x_run: &[T; N],
    p0: &Arr<T, N>,
) -> u32 {
    shadows
        .into_iter()
        .map(|sh| u32::from(sh.propagate(run, scale, x_run, p0).is_err()))
        .sum()
}
