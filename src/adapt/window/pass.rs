//! One pass of the global stage over its frozen window: the exact likelihood of the block
//! means for one parameter point, and optionally its score and Fisher information by central
//! differences (`2p + 1` filters, as in the likelihood bank, [`accumulate`]).

// Small fixed-size code reads best with explicit indices (they mirror the equations).
#![allow(clippy::needless_range_loop)]

use crate::adapt::bank::{Member, MemberInnovation, MEMBERS};
use crate::adapt::information::{accumulate, Information};

/// Filters of a pass at most (`2 MAXP + 1`).
pub const MEMBERS_MAX: usize = MEMBERS;
use crate::adapt::identifiable::IdentifiableModel;
use crate::adapt::params::{Specs, MAXP};
use crate::adapt::AdaptError;
use crate::filter::UpdateStatus;
use crate::linalg::{dot, mul, mul_t_sym, zeros, Arr};
use crate::model::NX;
use crate::Real;

/// Longest block [ticks] (bounds the loop of [`block_system`]).
pub const MAX_BLOCK: u32 = 600;
/// Leading innovations of a pass not summed: a model's diffuse states
/// ([`IdentifiableModel::window_start`]; the one-channel INS's velocity and tilt) are fixed by
/// the first two observations; one more for margin.
pub const BURN: usize = 3;

/// The exact discrete system of block sums: over `m` ticks of `(phi, qd)` (`n` states), the
/// state at the block's end and, for each of the `Z` observation rows `h_k`,
/// `s_k = sum_{j=1..m} h_k x_j`, the sum of the noise-free observations over the block, as one
/// `n + Z`-state step `[x; s]' = A [x; s] + w`:
///
/// ```text
/// A = [[Phi^m, 0], [sum_j h_k Phi^j, 0]],   Cov(w) = [[E_m, C_m], [C_m^T, V_m]]
/// E_j = Phi E_{j-1} Phi^T + Qd                          (noise accumulated in x)
/// C_j^k = Phi C_{j-1}^k + E_j h_k^T                     (its covariance with sum k's noise)
/// V_j^kl = V_{j-1}^kl + h_k Phi C_{j-1}^l + h_l Phi C_{j-1}^k + h_k E_j h_l^T
/// ```
///
/// (`e_j = Phi e_{j-1} + w_j`, `sigma_j^k = sigma_{j-1}^k + h_k e_j`, `E_0 = 0`, `C_0 = 0`,
/// `V_0 = 0`). The block mean is then `s / m` plus the mean of `m` white observation errors:
/// the likelihood of the block means is exact, not the sampled-point approximation.
/// `None` when `n + Z` states do not fit in `N`.
#[allow(clippy::type_complexity)]
pub fn block_system<T: Real, const N: usize, const Z: usize>(
    phi: &Arr<T, N>,
    qd: &Arr<T, N>,
    h: &[[T; N]; Z],
    n: usize,
    m: u32,
) -> Option<(Arr<T, N>, Arr<T, N>, usize)> {
    if n + Z > N || n == 0 {
        return None;
    }
    // Restated so that the optimiser sees `n < N` for the indexing below (no panic path).
    let n = n.min(N - 1);
    let mut pj: Arr<T, N> = zeros();
    for i in 0..n {
        pj[i][i] = T::one();
    }
    let mut e: Arr<T, N> = zeros();
    let mut c = [[T::zero(); N]; Z];
    let mut v = [[T::zero(); Z]; Z];
    let mut r = [[T::zero(); N]; Z];
    for _ in 0..m.min(MAX_BLOCK) {
        let mut phic = [[T::zero(); N]; Z];
        for (pc, ck) in phic.iter_mut().zip(c.iter()) {
            for i in 0..n {
                pc[i] = dot(&phi[i], ck, n);
            }
        }
        let pe = mul(phi, &e, n);
        e = mul_t_sym(&pe, phi, qd, n);
        let mut eh = [[T::zero(); N]; Z];
        for (ek, hk) in eh.iter_mut().zip(h.iter()) {
            for i in 0..n {
                ek[i] = dot(&e[i], hk, n);
            }
        }
        for ((ck, pc), ek) in c.iter_mut().zip(phic.iter()).zip(eh.iter()) {
            for i in 0..n {
                ck[i] = pc[i] + ek[i];
            }
        }
        for (k, (vk, hk)) in v.iter_mut().zip(h.iter()).enumerate() {
            for (l, vkl) in vk.iter_mut().enumerate() {
                let (Some(pcl), Some(el)) = (phic.get(l), eh.get(l)) else {
                    continue;
                };
                *vkl += if k == l {
                    T::lit(2.0) * dot(hk, pcl, n) + dot(hk, el, n)
                } else {
                    let (hl, pck) = (h.get(l).unwrap_or(hk), phic.get(k).unwrap_or(pcl));
                    dot(hk, pcl, n) + dot(hl, pck, n) + dot(hk, el, n)
                };
            }
        }
        pj = mul(phi, &pj, n);
        for (rk, hk) in r.iter_mut().zip(h.iter()) {
            for k in 0..n {
                let mut acc = T::zero();
                for i in 0..n {
                    acc += hk[i] * pj[i][k];
                }
                rk[k] += acc;
            }
        }
    }
    // `pj` and `e` are zero outside their leading n x n blocks (`mul` and `mul_t_sym` write
    // only those), so they are the blocks of A and Q; rows and columns n.. are the block sums'.
    let (mut a, mut q) = (pj, e);
    for (k, ((rk, ck), vk)) in r.iter().zip(c.iter()).zip(v.iter()).enumerate() {
        if let Some(row) = a.get_mut(n + k) {
            row.copy_from_slice(rk);
        }
        for (i, row) in q.iter_mut().enumerate().take(n) {
            if let (Some(x), Some(ci)) = (row.get_mut(n + k), ck.get(i)) {
                *x = *ci;
            }
        }
        if let Some(row) = q.get_mut(n + k) {
            for (x, ci) in row.iter_mut().zip(ck.iter()).take(n) {
                *x = *ci;
            }
            for (x, vkl) in row.iter_mut().skip(n).zip(vk.iter()) {
                *x = *vkl;
            }
        }
    }
    Some((a, q, n + Z))
}

/// Builds `mem` as the filter of the block sums of `base` with `theta` (`ln` parameters of
/// `specs`) over blocks of `block` ticks, started for a window whose first finite block means
/// are `z0` ([`IdentifiableModel::window_start`]). Returns the block means' observation rows
/// and noise variances.
#[allow(clippy::type_complexity)]
pub fn block_filter<T: Real, M: IdentifiableModel<T, N, Z>, const N: usize, const Z: usize>(
    base: &M,
    specs: &Specs,
    theta: &[T; MAXP],
    block: u32,
    z0: &[T; Z],
    mem: &mut Member<T, N>,
) -> Result<([[T; N]; Z], [T; Z]), AdaptError> {
    let k = T::lit(f64::from(block.max(1)));
    let m = base
        .with_parameters(specs, theta)
        .ok_or(AdaptError::BadParameter)?;
    let scale = m.scaling().map_err(AdaptError::Model)?;
    let sys = m.system(&scale).map_err(AdaptError::Model)?;
    let (phi1, qd1) = m.discrete(&scale).map_err(AdaptError::Model)?;
    let (phi, qd, n) =
        block_system(&phi1, &qd1, &sys.H, sys.n, block).ok_or(AdaptError::BadParameter)?;
    // The window begins hours into the run: the model says where its prior does not hold
    // there (the INS's diffuse velocity and tilt); the first BURN terms are not summed.
    let mut p0 = sys.P0;
    let mut x0 = [T::zero(); N];
    m.window_start(&scale, &mut p0, &mut x0, z0);
    mem.reset(&p0, n);
    mem.kf.x = x0;
    mem.set_system(&phi, &qd);
    // z_block,k = s_k / m + the mean of m white observation errors.
    let mut h = [[T::zero(); N]; Z];
    let mut r = [T::zero(); Z];
    for (i, (hk, (rk, rs))) in h.iter_mut().zip(r.iter_mut().zip(sys.R.iter())).enumerate() {
        if let Some(v) = hk.get_mut((n.saturating_sub(Z) + i).min(N - 1)) {
            *v = T::one() / k;
        }
        *rk = *rs / k;
    }
    Ok((h, r))
}

/// A pass in progress: `count` filters (`1`, or `2p + 1` with derivatives) over the window.
#[derive(Debug, Clone)]
pub struct Pass<T: Real, const N: usize = NX, const Z: usize = 1> {
    members: [Member<T, N>; MEMBERS],
    count: usize,
    np: usize,
    h: [[T; N]; Z],
    r: [T; Z],
    /// Finite-difference step (`ln`).
    step: T,
    /// The point.
    pub theta: [T; MAXP],
    /// Log-likelihood of the centre so far (`-inf` once a filter broke).
    pub ll: T,
    /// Score and information so far (with derivatives).
    pub info: Information<T>,
    /// Blocks consumed.
    pub pos: usize,
    block: u32,
    z0: [T; Z],
    prepared: usize,
}

impl<T: Real, const N: usize, const Z: usize> Pass<T, N, Z> {
    /// Nothing (a compile-time value).
    pub const BLANK: Self = Self {
        members: [Member::BLANK; MEMBERS],
        count: 0,
        np: 0,
        h: [[T::ZERO; N]; Z],
        r: [T::ZERO; Z],
        step: T::ZERO,
        theta: [T::ZERO; MAXP],
        ll: T::ZERO,
        info: Information::BLANK,
        pos: 0,
        block: 0,
        z0: [T::ZERO; Z],
        prepared: 0,
    };

    /// Starts a pass at `theta` (with `derivs`, also at `theta +- step e_i`) for blocks of
    /// `block` ticks whose first finite mean is `z0`. Its filters are then built one per
    /// [`prepare`](Self::prepare) call (each is a discretisation and a block system: spreading
    /// them over ticks bounds the worst tick).
    pub fn start(
        &mut self,
        theta: &[T; MAXP],
        np: usize,
        derivs: Option<T>,
        block: u32,
        z0: &[T; Z],
    ) {
        let np = np.min(MAXP);
        self.count = if derivs.is_some() { 2 * np + 1 } else { 1 }.min(MEMBERS);
        self.np = np;
        self.step = derivs.unwrap_or(T::zero());
        self.block = block.max(1);
        self.z0 = *z0;
        self.prepared = 0;
        self.theta = *theta;
        self.ll = T::zero();
        self.info = Information::BLANK;
        self.pos = 0;
    }

    /// Active states of the pass's filters (`0` before the first is built).
    pub fn states(&self) -> usize {
        self.members.first().map_or(0, |m| m.kf.active())
    }

    /// The budget's filter steps one block of the pass costs, in steps of a filter with
    /// `model_states` active states (the model's): its filters times the square of the ratio
    /// of the active sizes, rounded up. A structure alternative's filter has one or two states
    /// more than the model's; counted as one step each, 64 of its steps on a block's last tick
    /// took 538k Cortex-M4 instructions (`docs/ADAPTATION.md` §7.15).
    pub fn cost(&self, model_states: usize) -> usize {
        let n = self.states().max(1);
        let m = model_states.max(1).min(n);
        let filters = self.count.max(1);
        (filters * n * n + m * m - 1)
            .checked_div(m * m)
            .unwrap_or(filters)
    }

    /// Whether every filter of the pass is built.
    pub fn ready(&self) -> bool {
        self.prepared >= self.count
    }

    /// Builds the next filter of the pass: the model at its point as the exact system of the
    /// block sums, with a diffuse start.
    pub fn prepare<M: IdentifiableModel<T, N, Z>>(
        &mut self,
        base: &M,
        specs: &Specs,
    ) -> Result<(), AdaptError> {
        let j = self.prepared;
        if j >= self.count {
            return Ok(());
        }
        let mut th = self.theta;
        if j > 0 {
            let i = (j - 1) / 2;
            let sign = if j % 2 == 1 { T::one() } else { -T::one() };
            if let Some(v) = th.get_mut(i) {
                *v += sign * self.step;
            }
        }
        let mem = self.members.get_mut(j).ok_or(AdaptError::BadParameter)?;
        (self.h, self.r) = block_filter(base, specs, &th, self.block, &self.z0, mem)?;
        self.prepared += 1;
        Ok(())
    }

    /// Filters in the pass (`1` or `2p + 1`).
    pub fn count(&self) -> usize {
        self.count
    }

    /// One block mean (per axis; non-finite: missing on that axis) through every filter of the
    /// pass, fused axis by axis (sequential scalar updates: exact for independent axes, as in
    /// the bank). The score and information are added when every axis was finite and used.
    pub fn push(&mut self, z: &[T; Z]) {
        self.pos += 1;
        let summed = self.pos > BURN;
        let mut inn = [[MemberInnovation::<T>::default(); MEMBERS]; Z];
        let mut all = z.iter().all(|v| v.is_finite()) && summed;
        for (j, m) in self.members.iter_mut().take(self.count).enumerate() {
            m.predict();
            for (k, (zk, (h, r))) in z.iter().zip(self.h.iter().zip(self.r.iter())).enumerate() {
                let i = m.update(*zk, h, *r, None);
                match i.status {
                    UpdateStatus::Updated => {
                        if let Some(out) = inn.get_mut(k).and_then(|a| a.get_mut(j)) {
                            *out = MemberInnovation {
                                nu: i.innovation,
                                s: i.variance,
                            };
                        }
                        if j == 0 && summed {
                            self.ll += i.loglik();
                        }
                    }
                    UpdateStatus::Missing => all = false,
                    UpdateStatus::Gated | UpdateStatus::BadInnovationVariance => {
                        all = false;
                        if j == 0 {
                            self.ll = T::lit(f64::NEG_INFINITY);
                        }
                    }
                }
            }
            if !m.kf.diagonal_healthy() && j == 0 {
                self.ll = T::lit(f64::NEG_INFINITY);
            }
        }
        if all && self.count > 1 {
            for axis in inn.iter() {
                accumulate(axis, self.np, self.step, &mut self.info);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::InsModel;

    /// `block_system` against the plain propagation of the augmented per-tick system
    /// `[x; s]_j = [[Phi, 0], [h Phi, 1]] [x; s]_{j-1} + [w; h w]` from `s = 0` over `m` ticks:
    /// the transition's first `n` columns and the accumulated noise covariance must agree.
    #[test]
    fn block_system_equals_the_augmented_propagation() {
        let m = InsModel::<f64>::paper();
        let scale = m.scaling().unwrap();
        let sys = m.continuous(&scale).unwrap();
        let h = crate::linalg::from_vec(&sys.H);
        augmented_propagation(&m, [h]);
        // Two axes: the velocity and a second row that also sees the gyro's drift (the cross
        // terms `V^kl` of the block sums).
        let mut h2 = h.map(|v| 0.5 * v);
        h2[2] += 1.0;
        augmented_propagation(&m, [h, h2]);
    }

    /// `block_system` of `m` with the rows `h` against the per-tick augmented system
    /// `[x; s]_j = [[Phi, 0], [H Phi, I]] [x; s]_{j-1} + [w; H w]` propagated from `s = 0`.
    fn augmented_propagation<const Z: usize>(m: &InsModel<f64>, h: [[f64; NX]; Z]) {
        let scale = m.scaling().unwrap();
        let n = m.continuous(&scale).unwrap().n;
        let (phi, qd) = m.discretise_block(&scale).unwrap();
        let ticks = 60;
        let (a, q, na) = block_system(&phi, &qd, &h, n, ticks).unwrap();
        assert_eq!(na, n + Z);
        // Per-tick augmented transition and noise.
        let mut t: Arr<f64, NX> = zeros();
        let mut w: Arr<f64, NX> = zeros();
        for i in 0..n {
            for k in 0..n {
                t[i][k] = phi[i][k];
                w[i][k] = qd[i][k];
            }
        }
        let qh = |i: usize, hk: &[f64; NX]| -> f64 { (0..n).map(|k| qd[i][k] * hk[k]).sum() };
        for (a, ha) in h.iter().enumerate() {
            for k in 0..n {
                t[n + a][k] = (0..n).map(|i| ha[i] * phi[i][k]).sum();
            }
            t[n + a][n + a] = 1.0;
            for i in 0..n {
                w[i][n + a] = qh(i, ha);
                w[n + a][i] = qh(i, ha);
            }
            for (b, hb) in h.iter().enumerate() {
                w[n + a][n + b] = (0..n).map(|i| ha[i] * qh(i, hb)).sum();
            }
        }
        let na = n + Z;
        let mut prod: Arr<f64, NX> = zeros();
        for i in 0..na {
            prod[i][i] = 1.0;
        }
        let mut cov: Arr<f64, NX> = zeros();
        for _ in 0..ticks {
            prod = mul(&t, &prod, na);
            let tc = mul(&t, &cov, na);
            cov = mul_t_sym(&tc, &t, &w, na);
        }
        for i in 0..na {
            for k in 0..n {
                let d = (a[i][k] - prod[i][k]).abs();
                assert!(d <= 1e-9 * (1.0 + prod[i][k].abs()), "A[{i}][{k}]");
            }
            for k in n..na {
                assert_eq!(a[i][k], 0.0, "the block sums restart every block");
            }
            for k in 0..na {
                let d = (q[i][k] - cov[i][k]).abs();
                assert!(
                    d <= 1e-9 * (1.0 + cov[i][k].abs()),
                    "Q[{i}][{k}] {} vs {}",
                    q[i][k],
                    cov[i][k]
                );
            }
        }
    }

    /// A pass's block costs its filters in steps of the model's filter, weighted by the square
    /// of the active sizes: the paper model's block filter has 5 states, its exponential-cosine
    /// alternative's 6 (`ceil(36 / 25) = 2` per filter).
    #[test]
    fn an_alternative_s_steps_cost_more() {
        use crate::adapt::identifiable::IdentifiableModel;
        use crate::adapt::params::{specs, theta_of};
        let paper = InsModel::<f64>::paper();
        let alt = paper.swapped(&paper.site(1).unwrap(), 0.01).unwrap();
        let built = |m: &InsModel<f64>, derivs: bool| {
            let s = specs(m);
            let mut p: Pass<f64> = Pass::BLANK;
            p.start(&theta_of(m, &s), s.len(), derivs.then_some(0.1), 60, &[0.0]);
            while !p.ready() {
                p.prepare(m, &s).unwrap();
            }
            p
        };
        let (model, single, polish) = (built(&paper, false), built(&alt, false), built(&alt, true));
        assert_eq!((model.states(), single.states()), (5, 6));
        assert_eq!(model.cost(5), 1);
        assert_eq!(single.cost(5), 2);
        assert_eq!(single.cost(6), 1);
        // 2p + 1 = 11 filters of the five-parameter alternative: ceil(11 x 36 / 25).
        assert_eq!((polish.count(), polish.cost(5)), (11, 16));
        // A model size above the pass's counts as the pass's own.
        assert_eq!(model.cost(9), 1);
    }
}
