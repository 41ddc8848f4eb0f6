//! Streaming sliding-window sample autocorrelation of one channel (METHOD.md §3, eq. 11).
//!
//! # Definition
//!
//! Let the window hold the `n` most recent accepted samples `x_1 .. x_n`, oldest first
//! (`n = N` once the window is full, fewer right after [`Autocorrelator::reset`]). Then
//!
//! ```text
//! m   = (1/n) sum_{i=1}^{n} x_i
//! R_k = (1/n) sum_{i=k+1}^{n} (x_i - m)(x_{i-k} - m),      k = 0 ..= L,  (R_k = 0 for k >= n)
//! ```
//!
//! Lag `k` therefore uses the `n - k` products of the pairs of samples that are both inside the
//! window, `(x_{k+1}, x_1), (x_{k+2}, x_2), .., (x_n, x_{n-k})`, and divides by `n`, not `n - k`.
//! This is the standard biased (Box-Jenkins / Yule-Walker) estimator. METHOD.md prints the upper
//! limit as `N + k`, which would need `k` samples beyond the window; with the limit `N` the
//! sequence `R_0 .. R_L` is positive semi-definite, so `|R_k| <= R_0` and `r_k = R_k / R_0` is a
//! valid correlation. [`acf_batch`] computes exactly the same numbers from a slice, and the
//! tests check that the two agree.
//!
//! # Algorithm
//!
//! Every sum is kept relative to a *pivot* `c` (a recent sample), `d_i = x_i - c`, so that a large
//! constant offset (a turn-on bias) does not cancel catastrophically in `f32`:
//!
//! ```text
//! S_k = sum_{i=k+1}^{n} d_i d_{i-k},   A = sum d_i,   dm = A / n
//! n R_k = S_k - dm (2A - H_k - T_k - (n - k) dm)
//! ```
//!
//! with `H_k` the sum of the `k` oldest and `T_k` of the `k` newest `d_i` (computed in
//! [`Autocorrelator::acf`], `O(L)`). A push adds the `L + 1` products of the new sample and, when
//! the window is full, first removes the `L + 1` products of the sample that leaves: `O(L)` work.
//!
//! **No drift.** The running sums are compensated (Knuth's TwoSum, an error-free transformation,
//! so each sum is exact up to one rounding of its final value plus a second-order term). Removing a
//! sample subtracts bit-for-bit the same products that were added, so the only error left is that
//! of the compensated sum. In addition, a *shadow* set of sums only ever adds: it starts with a
//! new block of pushes (and a new pivot, the first sample of the block) and after `N` pushes it
//! holds exactly the sums over the current window, at which point it replaces the running sums.
//! So the running sums are never more than `2N` additions/subtractions away from an add-only
//! rebuild, whatever the stream length, and the pivot follows slow drifts. The cost is `O(L)` per
//! push (amortisation-free: every push does the same work).
//!
//! **Bad input.** `NaN`, `±Inf` and values with `|x| > MAX_ABS_INPUT` (`1e12`, far above any
//! sensor error in SI units, chosen so that no sum can overflow in `f32`) are rejected with a
//! [`PushError`] and leave the state unchanged.
//!
//! # Memory per channel
//!
//! The struct holds the ring `[T; N]`, two sets (running and shadow) of `L` compensated lag sums
//! (`2 T` each), four compensated sums for `S_0` and `A`, two pivots, and three `usize` counters:
//!
//! ```text
//! size_of::<Autocorrelator<T, N, L>>() = (N + 4 L + 10) size_of::<T>() + 3 size_of::<usize>()
//! ```
//!
//! rounded up to the alignment of `T`/`usize`. On the Cortex-M4F (`f32`, 4-byte `usize`) that is
//! `4 (N + 4 L + 13)` bytes: 5172 bytes for `N = 1024`, `L = 64`. A test checks this formula with
//! `core::mem::size_of`.
//!
//! # Example
//!
//! ```
//! use imu_ident::autocorr::{acf_batch, Autocorrelator, PushError};
//!
//! let mut ac = Autocorrelator::<f64, 8, 2>::new();
//! let xs = [1.0, 3.0, 2.0, 5.0, 4.0, 4.0, 1.0, 0.0, 2.0, 6.0];
//! for &x in &xs {
//!     ac.push(x).unwrap();
//! }
//! assert_eq!(ac.push(f64::NAN), Err(PushError::NonFinite)); // rejected, state unchanged
//! assert!(ac.is_full());
//!
//! let mut r = [0.0; 3];
//! ac.acf(&mut r).unwrap();
//! let mut b = [0.0; 3];
//! acf_batch(&xs[2..], &mut b).unwrap(); // the last 8 samples
//! for k in 0..3 {
//!     assert!((r[k] - b[k]).abs() < 1e-12);
//! }
//! assert_eq!(ac.r0(), Some(r[0]));
//! assert!((ac.mean().unwrap() - 3.0).abs() < 1e-12);
//! ```

use crate::Real;

/// Largest accepted `|x|`. With `N <= 2^24` (checked at compile time) every sum of products stays
/// below `4e24 * 2^24 ~ 7e31`, far from `f32::MAX ~ 3.4e38`.
pub const MAX_ABS_INPUT: f64 = 1e12;

/// Why a sample was rejected by [`Autocorrelator::push`]. The state is unchanged in every case.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PushError {
    /// The sample is `NaN` or infinite.
    NonFinite,
    /// `|x| > MAX_ABS_INPUT`.
    OutOfRange,
}

/// Errors of [`Autocorrelator::acf`] and [`acf_batch`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AcfError {
    /// No sample yet.
    Empty,
    /// The output slice is empty or longer than the available lags (`L + 1`, or the input
    /// length for [`acf_batch`]).
    BadLength,
    /// [`acf_batch`] only: the input contains a `NaN`, an infinity or `|x| > MAX_ABS_INPUT`.
    NonFinite,
}

/// A compensated running sum: `sum + comp` carries about twice the working precision.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Compensated<T> {
    sum: T,
    comp: T,
}

impl<T: Real> Compensated<T> {
    /// Knuth's TwoSum: `t + e == sum + x` exactly, branch-free (Neumaier's variant needs a
    /// compare). The rounding errors are accumulated in `comp`.
    #[inline(always)]
    fn add(&mut self, x: T) {
        let t = self.sum + x;
        let bp = t - self.sum;
        let e = (self.sum - (t - bp)) + (x - bp);
        self.sum = t;
        self.comp += e;
    }

    #[inline(always)]
    fn value(&self) -> T {
        self.sum + self.comp
    }
}

/// The input domain shared by the streaming and the batch computation.
#[inline(always)]
fn check_input<T: Real>(x: T) -> Result<(), PushError> {
    if !x.is_finite() {
        Err(PushError::NonFinite)
    } else if x.abs() > T::lit(MAX_ABS_INPUT) {
        Err(PushError::OutOfRange)
    } else {
        Ok(())
    }
}

/// The `count` ring elements before `pos` (exclusive), as `(buf[pos - a..pos], buf[N - b..N])`
/// with `a + b = count`: iterate each in reverse, the first one first, to go back in time.
/// Out-of-range requests give shorter (empty) segments, never a panic.
#[inline(always)]
fn ring_back<T>(buf: &[T], pos: usize, count: usize) -> (&[T], &[T]) {
    let n = buf.len();
    let a = pos.min(count);
    let b = count - a;
    let seg_a = buf.get(pos - a..pos).unwrap_or(&[]);
    let seg_b = buf.get(n.saturating_sub(b)..n).unwrap_or(&[]);
    (seg_a, seg_b)
}

/// The `count` ring elements from `start` on, as `(buf[start..start + a], buf[..b])`, `a + b =
/// count` (for `count <= buf.len()`): iterate the first, then the second, to go forward in time.
#[inline(always)]
fn ring_forward<T>(buf: &[T], start: usize, count: usize) -> (&[T], &[T]) {
    let end = buf.len().min(start.saturating_add(count));
    let seg_a = buf.get(start..end).unwrap_or(&[]);
    let seg_b = buf.get(..count - seg_a.len()).unwrap_or(&[]);
    (seg_a, seg_b)
}

/// Streaming sample autocorrelation `R_0 ..= R_L` over the last `N` samples of one channel.
///
/// See the [module documentation](self) for the exact definition, the algorithm and the memory
/// footprint. `L < N <= 2^24` is checked at compile time (when [`Autocorrelator::new`] is
/// instantiated), so the lags always fit in the window.
#[derive(Debug, Clone)]
pub struct Autocorrelator<T, const N: usize, const L: usize> {
    /// Ring buffer of raw samples; `buf[(head + i) % N]` is the `i`-th oldest, `i < len`.
    buf: [T; N],
    head: usize,
    len: usize,
    /// Pivot of the running sums.
    pivot: T,
    /// `S_0 = sum d_i^2`.
    s0: Compensated<T>,
    /// `A = sum d_i`.
    sum: Compensated<T>,
    /// `lag[k - 1] = S_k`, `k = 1 ..= L`.
    lag: [Compensated<T>; L],
    /// Pushes since the shadow block started, `0 .. N`.
    block: usize,
    /// Pivot of the shadow sums: the first sample of the block.
    shadow_pivot: T,
    shadow_s0: Compensated<T>,
    shadow_sum: Compensated<T>,
    shadow_lag: [Compensated<T>; L],
}

impl<T: Real, const N: usize, const L: usize> Default for Autocorrelator<T, N, L> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const N: usize, const L: usize> Autocorrelator<T, N, L> {
    /// Compile-time check of the const parameters (evaluated when `new` is monomorphised, so a
    /// bad `N`/`L` is a build error, never a run-time panic).
    const PARAMS_OK: () = assert!(
        L < N && N <= 1 << 24,
        "Autocorrelator<T, N, L> needs L < N <= 2^24"
    );

    /// An empty autocorrelator (a `const fn`: a `static` holding one costs no flash).
    pub const fn new() -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::PARAMS_OK;
        let z = Compensated {
            sum: T::ZERO,
            comp: T::ZERO,
        };
        Autocorrelator {
            buf: [T::ZERO; N],
            head: 0,
            len: 0,
            pivot: T::ZERO,
            s0: z,
            sum: z,
            lag: [z; L],
            block: 0,
            shadow_pivot: T::ZERO,
            shadow_s0: z,
            shadow_sum: z,
            shadow_lag: [z; L],
        }
    }

    /// Forgets every sample (in place: no copy of the window on the stack).
    pub fn reset(&mut self) {
        let z = Compensated::default();
        self.buf.fill(T::zero());
        self.head = 0;
        self.len = 0;
        self.pivot = T::zero();
        self.s0 = z;
        self.sum = z;
        self.lag.fill(z);
        self.block = 0;
        self.shadow_pivot = T::zero();
        self.shadow_s0 = z;
        self.shadow_sum = z;
        self.shadow_lag.fill(z);
    }

    /// Window length `N`.
    pub const fn capacity(&self) -> usize {
        N
    }

    /// Largest lag `L`.
    pub const fn max_lag(&self) -> usize {
        L
    }

    /// Number of samples in the window (`<= N`).
    pub fn len(&self) -> usize {
        self.len
    }

    /// No sample since construction or the last [`reset`](Self::reset).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The window holds `N` samples.
    pub fn is_full(&self) -> bool {
        self.len == N
    }

    /// Adds one sample, dropping the oldest when the window is full. `O(L)`.
    ///
    /// A `NaN`, an infinity or `|x| > MAX_ABS_INPUT` is rejected and the state is left unchanged.
    pub fn push(&mut self, x: T) -> Result<(), PushError> {
        check_input(x)?;
        if self.len == 0 {
            self.pivot = x;
        }
        if self.block == 0 {
            self.shadow_pivot = x;
        }
        if self.len >= N {
            self.remove_oldest();
        }
        // Now len < N. The new sample goes to `pos`; the sample k steps back is at pos - k.
        let n_old = self.len;
        let pos = (self.head + n_old) % N;
        let (c, cs) = (self.pivot, self.shadow_pivot);
        let d = x - c;
        let ds = x - cs;
        self.s0.add(d * d);
        self.sum.add(d);
        self.shadow_s0.add(ds * ds);
        self.shadow_sum.add(ds);
        // Products with the previous samples still in the window (main sums), and with those of
        // the current block (shadow sums); block <= n_old always, since the block is the newest
        // `block` samples of the window.
        let k_main = L.min(n_old);
        let k_shadow = k_main.min(self.block);
        // The k_main previous samples, newest first, as at most two contiguous ring segments.
        let (seg_a, seg_b) = ring_back(&self.buf, pos, k_main);
        let prev = seg_a.iter().rev().chain(seg_b.iter().rev());
        let mut sums = self.lag.iter_mut().zip(self.shadow_lag.iter_mut());
        for ((s, sh), &xo) in (&mut sums).zip(prev.clone()).take(k_shadow) {
            s.add(d * (xo - c));
            sh.add(ds * (xo - cs));
        }
        for ((s, _), &xo) in sums.zip(prev.skip(k_shadow)).take(k_main - k_shadow) {
            s.add(d * (xo - c));
        }
        self.buf[pos % N] = x;
        self.len = n_old + 1;
        self.block += 1;
        if self.block >= N {
            // The block is now exactly the window: the add-only shadow sums replace the running
            // ones (bounding their error whatever the stream length) and the pivot moves to the
            // first sample of the block.
            self.pivot = cs;
            self.s0 = self.shadow_s0;
            self.sum = self.shadow_sum;
            self.lag = self.shadow_lag;
            let z = Compensated::default();
            self.shadow_s0 = z;
            self.shadow_sum = z;
            self.shadow_lag = [z; L];
            self.block = 0;
        }
        Ok(())
    }

    /// Removes the products of the oldest sample (window full). They are bit-for-bit the products
    /// added when their partners arrived (same pivot, IEEE multiplication is commutative), so the
    /// subtraction cancels them exactly up to the compensated-sum error.
    fn remove_oldest(&mut self) {
        let c = self.pivot;
        let h = self.head;
        let d = self.buf[h % N] - c;
        self.s0.add(-(d * d));
        self.sum.add(-d);
        // Partners h + 1 ..= h + L are in the window because L < N.
        let (seg_a, seg_b) = ring_forward(&self.buf, (h + 1) % N, L);
        for (s, &xo) in self.lag.iter_mut().zip(seg_a.iter().chain(seg_b)) {
            s.add(-(d * (xo - c)));
        }
        self.head = (h + 1) % N;
        self.len = self.len.saturating_sub(1);
    }

    /// Window mean `m`, `None` when empty.
    pub fn mean(&self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        Some(self.pivot + self.sum.value() / T::lit(self.len as f64))
    }

    /// `R_0`, the (biased, `1/n`) window variance; `None` when empty. Never negative.
    pub fn r0(&self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        let n = T::lit(self.len as f64);
        let a = self.sum.value();
        Some(((self.s0.value() - a * (a / n)) / n).max(T::zero()))
    }

    /// Writes `R_0 .. R_{out.len() - 1}` into `out`; `1 <= out.len() <= L + 1`. `O(out.len())`.
    ///
    /// Before the window is full the same definition is applied to the `len()` samples present
    /// (division by `len()`, `R_k = 0` for `k >= len()`).
    pub fn acf(&self, out: &mut [T]) -> Result<(), AcfError> {
        let n = self.len;
        if n == 0 {
            return Err(AcfError::Empty);
        }
        if out.is_empty() || out.len() > L + 1 {
            return Err(AcfError::BadLength);
        }
        let Some((first, rest)) = out.split_first_mut() else {
            return Err(AcfError::BadLength);
        };
        *first = self.r0().unwrap_or_else(T::zero);
        let nt = T::lit(n as f64);
        let c = self.pivot;
        let a = self.sum.value();
        let dm = a / nt;
        // h = H_k (k oldest d_i), t = T_k (k newest d_i), grown by one term per lag.
        let mut h = T::zero();
        let mut t = T::zero();
        // nk = n - k as a scalar, stepped down (exact: integers below 2^24) rather than converted
        // per lag (a soft-float f64 conversion on the Cortex-M4F).
        let mut nk = nt;
        for (k0, (o, s)) in rest.iter_mut().zip(self.lag.iter()).enumerate() {
            let k = k0 + 1;
            nk -= T::one();
            if k >= n {
                *o = T::zero();
                continue;
            }
            h += self.buf[(self.head + k0) % N] - c;
            t += self.buf[(self.head + n - k) % N] - c;
            // n R_k = S_k - dm (2A - H_k - T_k - (n - k) dm)
            *o = (s.value() - dm * (a + a - h - t - nk * dm)) / nt;
        }
        Ok(())
    }
}

/// Batch version of the same estimator: `out[k] = R_k` over all of `x`, `k < out.len() <= x.len()`.
///
/// Two passes (mean, then centred products), each lag summed in blocks of 64 with a compensated
/// sum across blocks. `O(x.len() * out.len())`; meant for host-side analysis and tests.
pub fn acf_batch<T: Real>(x: &[T], out: &mut [T]) -> Result<(), AcfError> {
    let n = x.len();
    if n == 0 {
        return Err(AcfError::Empty);
    }
    if out.is_empty() || out.len() > n {
        return Err(AcfError::BadLength);
    }
    if x.iter().any(|&v| check_input(v).is_err()) {
        return Err(AcfError::NonFinite);
    }
    let nt = T::lit(n as f64);
    let mut s = Compensated::default();
    for &v in x {
        s.add(v);
    }
    let m = s.value() / nt;
    for (k, o) in out.iter_mut().enumerate() {
        let (Some(a), Some(b)) = (x.get(k..), x.get(..n - k)) else {
            return Err(AcfError::BadLength);
        };
        *o = centred_dot(a, b, m) / nt;
    }
    if let Some(r0) = out.first_mut() {
        *r0 = r0.max(T::zero());
    }
    Ok(())
}

/// `sum (a_i - m)(b_i - m)`: four independent partial sums per block of 64 (instruction-level
/// parallelism), blocks combined by a compensated sum.
fn centred_dot<T: Real>(a: &[T], b: &[T], m: T) -> T {
    const BLOCK: usize = 64;
    let mut acc = Compensated::default();
    for (ba, bb) in a.chunks(BLOCK).zip(b.chunks(BLOCK)) {
        let mut lanes = [T::zero(); 4];
        let mut qa = ba.chunks_exact(4);
        let mut qb = bb.chunks_exact(4);
        for (ca, cb) in (&mut qa).zip(&mut qb) {
            for ((l, &u), &v) in lanes.iter_mut().zip(ca).zip(cb) {
                *l += (u - m) * (v - m);
            }
        }
        let mut part = lanes.iter().fold(T::zero(), |p, &l| p + l);
        for (&u, &v) in qa.remainder().iter().zip(qb.remainder()) {
            part += (u - m) * (v - m);
        }
        acc.add(part);
    }
    acc.value()
}
