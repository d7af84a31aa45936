//! Dense passes of the prediction over its large matrices (the PCA basis,
//! 3V x K; the smooth basis, V x k), and the register state they need.
//!
//! Why: a sum is one chain of dependent additions (floating-point addition
//! is not reassociated), so a loop with one running sum per row waits on
//! the adder's latency at every entry and runs at a fraction of the
//! memory's speed. [`rows_dot3`] keeps twelve independent partial sums in
//! a fixed order (that of [`crate::lbfgs::dot`] for each row), so its
//! results are the same on every run and bit for bit those of `dot` (tests
//! below). [`points`] (a PCA shape) and [`accumulate_rows`] (a PCA
//! projection) do the same for the PCA basis. Hand-written: a GEMM (faer,
//! matrixmultiply) first copies the whole matrix into its packed layout and
//! sums in its own order; this is a single pass, in `dot`'s order.
//!
//! Where the processor has AVX, each kernel runs a version with AVX
//! registers (`avx`): the same sums in the same order, so the same bits
//! (tests below), with two vertices' or rows' sums side by side and the
//! next block's cache lines prefetched. Measured on one core, the 16 MB
//! PCA basis of the default model (`docs/results/predict-bench.md`): a
//! shape 1.08 -> 0.35-0.45 ms, a projection 0.67 -> 0.39-0.44 ms; the
//! baseline x86-64 code's twelve sums were not the limit, the loads were
//! (interleaving rows without prefetching was slower than one row at a
//! time).

/// Clears the upper halves of the vector registers (`vzeroupper`) where
/// the processor has AVX; nothing elsewhere.
///
/// Why: faer's matrix products run AVX-512 code and can leave the
/// registers' upper halves in use; until they are cleared, every SSE
/// instruction of this crate (compiled for the baseline x86-64, which has
/// no AVX) carries a false dependency on them. Measured: one pass of
/// [`rows_dot3`] over the smooth basis 6.9 ms after a step-2 iteration,
/// 1.6 ms after this (issue 13). Called at the start of each dense pass
/// and before each measuring of a shape.
#[inline]
pub(crate) fn clear_upper_registers() {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx")]
        fn zero_upper() {
            // The intrinsic is modelled by the compiler, which keeps no
            // value in the upper halves across it. (`unsafe` for Rust
            // before 1.87's safe intrinsics.)
            #[allow(unused_unsafe)]
            // SAFETY: only called where AVX is available (checked below).
            unsafe {
                std::arch::x86_64::_mm256_zeroupper()
            }
        }
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: AVX is available (checked on the line above).
            unsafe { zero_upper() }
        }
    }
}

/// Runs `body` compiled for AVX where the processor has it, as compiled
/// for the baseline elsewhere; the same operations in the same order
/// either way, so the results are bit for bit the same.
///
/// Why: the crate is built for the baseline x86-64 (SSE2), where a sum of
/// f64 products moves two lanes per instruction; with AVX the four partial
/// sums of a row are one register and f32 entries widen four at a time.
/// Without FMA (not enabled here) a product and a sum are rounded apart,
/// as in the baseline code. Runtime detection rather than a build for a
/// newer processor: the station's binary runs on any x86-64.
macro_rules! dispatch_avx {
    ($body:ident::<$t:ident>($($arg:expr),*)) => {{
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx") {
                // SAFETY: AVX is available (checked on the line above).
                unsafe { avx::$body::<$t>($($arg),*) }
            } else {
                $body::<$t>($($arg),*)
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            $body::<$t>($($arg),*)
        }
    }};
}

/// A basis entry type the kernels read (f64, or f32 widened to f64).
pub(crate) trait Entry: Copy + Into<f64> {
    /// `v[at..at + 4]` widened into one AVX register (lane `l` = `v[at +
    /// l]`), without a bounds check.
    ///
    /// # Safety
    /// Only where AVX is available, and with `at + 4 <= v.len()`.
    #[cfg(target_arch = "x86_64")]
    unsafe fn load4_unchecked(v: &[Self], at: usize) -> std::arch::x86_64::__m256d;
}

impl Entry for f64 {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load4_unchecked(v: &[f64], at: usize) -> std::arch::x86_64::__m256d {
        // SAFETY: `at + 4 <= v.len()` and AVX by the contract.
        unsafe { std::arch::x86_64::_mm256_loadu_pd(v.as_ptr().add(at)) }
    }
}

impl Entry for f32 {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn load4_unchecked(v: &[f32], at: usize) -> std::arch::x86_64::__m256d {
        use std::arch::x86_64::{_mm256_cvtps_pd, _mm_loadu_ps};
        // SAFETY: `at + 4 <= v.len()` and AVX by the contract.
        unsafe { _mm256_cvtps_pd(_mm_loadu_ps(v.as_ptr().add(at))) }
    }
}

/// The kernels' loops with AVX registers: each row's four partial sums
/// are the four lanes of one register, added in the baseline loops' order
/// (a product rounded, then the sum; no FMA), so the results are bit for
/// bit the baseline's.
#[cfg(target_arch = "x86_64")]
mod avx {
    use std::arch::x86_64::{
        __m256d, _mm256_add_pd, _mm256_loadu_pd, _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd,
        _mm256_storeu_pd, _mm_prefetch, _MM_HINT_T0,
    };

    use super::Entry;

    /// `(l0 + l1) + (l2 + l3) + tail`, the baseline's reduction.
    #[target_feature(enable = "avx")]
    fn reduce(a: __m256d, tail: f64) -> f64 {
        let mut l = [0.0; 4];
        // SAFETY: four f64 of room.
        unsafe { _mm256_storeu_pd(l.as_mut_ptr(), a) };
        (l[0] + l[1]) + (l[2] + l[3]) + tail
    }

    /// Four f64 of `c` from `j` (in bounds: `j + 4 <= c.len()`, asserted).
    #[target_feature(enable = "avx")]
    fn load(c: &[f64], j: usize) -> __m256d {
        let c = &c[j..j + 4];
        // SAFETY: four f64 in bounds (the slice above).
        unsafe { _mm256_loadu_pd(c.as_ptr()) }
    }

    /// Cache lines of the next block to prefetch at each 4-entry step of
    /// a block of `entries` basis entries of type `T` whose rows are `k`
    /// long: the whole next block, spread evenly over the steps (two lines
    /// a step for the f32 basis's blocks with k = 100).
    fn prefetch_per_step<T>(entries: usize, k: usize) -> usize {
        let lines = (entries * std::mem::size_of::<T>()).div_ceil(64);
        let steps = (k / 4).max(1);
        lines.div_ceil(steps)
    }

    /// Prefetches line `p` of step `step` of the block starting at `next`
    /// (`per_step` lines a step; a prefetch past the end of the basis is
    /// dropped, not a fault).
    #[target_feature(enable = "avx")]
    fn prefetch_next(next: *const i8, step: usize, per_step: usize) {
        for p in 0..per_step {
            _mm_prefetch::<_MM_HINT_T0>(next.wrapping_add((step * per_step + p) * 64));
        }
    }

    /// Rows taken two at a time (six independent sums), the next pair's
    /// lines prefetched.
    #[target_feature(enable = "avx")]
    pub(super) fn rows_dot3_body<T: Entry>(
        rows: &[T],
        k: usize,
        c: [&[f64]; 3],
        out: &mut [[f64; 3]],
    ) {
        let pairs = out.len() / 2;
        let (head, rest) = out.split_at_mut(2 * pairs);
        for (o, r) in head.chunks_exact_mut(2).zip(rows.chunks_exact(2 * k)) {
            row_block::<T, 2>(r, k, c, o);
        }
        for (o, r) in rest
            .chunks_exact_mut(1)
            .zip(rows[2 * pairs * k..].chunks_exact(k))
        {
            row_block::<T, 1>(r, k, c, o);
        }
    }

    /// [`rows_dot3_body`] for `N` consecutive rows (`rows`: N x k).
    #[target_feature(enable = "avx")]
    fn row_block<T: Entry, const N: usize>(
        rows: &[T],
        k: usize,
        c: [&[f64]; 3],
        out: &mut [[f64; 3]],
    ) {
        assert!(rows.len() >= N * k && out.len() >= N && c.iter().all(|c| c.len() >= k));
        let whole = k - k % 4;
        let next = rows.as_ptr().wrapping_add(N * k).cast::<i8>();
        let per_step = prefetch_per_step::<T>(N * k, k);
        let mut acc = [[_mm256_setzero_pd(); 3]; N];
        for j in (0..whole).step_by(4) {
            prefetch_next(next, j / 4, per_step);
            let cj = [load(c[0], j), load(c[1], j), load(c[2], j)];
            for (r, acc) in acc.iter_mut().enumerate() {
                // SAFETY: `r k + j + 4 <= N k <= rows.len()` (asserted above;
                // `j + 4 <= whole <= k`); AVX is enabled.
                let x = unsafe { T::load4_unchecked(rows, r * k + j) };
                for (acc, cj) in acc.iter_mut().zip(&cj) {
                    *acc = _mm256_add_pd(*acc, _mm256_mul_pd(x, *cj));
                }
            }
        }
        for (r, acc) in acc.iter().enumerate() {
            let row = &rows[r * k..(r + 1) * k];
            for (a, acc) in acc.iter().enumerate() {
                let tail: f64 = row[whole..]
                    .iter()
                    .zip(&c[a][whole..k])
                    .map(|(x, y)| (*x).into() * y)
                    .sum();
                out[r][a] = reduce(*acc, tail);
            }
        }
    }

    /// The points of `N` consecutive vertices (`m`: 3N mean entries,
    /// `rows`: 3N x k) into `out` (N): `3N` independent sums side by side,
    /// so the adder's latency overlaps across vertices.
    #[target_feature(enable = "avx")]
    fn vertex_block<T: Entry, const N: usize>(
        m: &[f64],
        rows: &[T],
        k: usize,
        s: &[f64],
        out: &mut [[f64; 3]],
    ) {
        assert!(rows.len() >= 3 * N * k && s.len() >= k && m.len() >= 3 * N && out.len() >= N);
        let whole = k - k % 4;
        let mut acc = [[_mm256_setzero_pd(); 3]; N];
        let next = rows.as_ptr().wrapping_add(3 * N * k).cast::<i8>();
        let per_step = prefetch_per_step::<T>(3 * N * k, k);
        for j in (0..whole).step_by(4) {
            prefetch_next(next, j / 4, per_step);
            let y = load(s, j);
            for (v, acc) in acc.iter_mut().enumerate() {
                for (a, acc) in acc.iter_mut().enumerate() {
                    // SAFETY: `(3 v + a) k + j + 4 <= 3 N k <= rows.len()`
                    // (asserted above; `j + 4 <= whole <= k`); AVX is enabled.
                    let x = unsafe { T::load4_unchecked(rows, (3 * v + a) * k + j) };
                    *acc = _mm256_add_pd(*acc, _mm256_mul_pd(x, y));
                }
            }
        }
        for (v, acc) in acc.iter().enumerate() {
            for (a, acc) in acc.iter().enumerate() {
                let r = &rows[(3 * v + a) * k..(3 * v + a + 1) * k];
                let tail: f64 = r[whole..]
                    .iter()
                    .zip(&s[whole..k])
                    .map(|(x, y)| (*x).into() * y)
                    .sum();
                out[v][a] = m[3 * v + a] + reduce(*acc, tail);
            }
        }
    }

    #[target_feature(enable = "avx")]
    pub(super) fn points_body<T: Entry>(
        mean: &[f64],
        rows: &[T],
        k: usize,
        s: &[f64],
    ) -> Vec<[f64; 3]> {
        const N: usize = 2;
        let mut out = vec![[0.0; 3]; mean.len() / 3];
        let blocks = out.len() / N;
        let (head, rest) = out.split_at_mut(blocks * N);
        for ((o, m), r) in head
            .chunks_exact_mut(N)
            .zip(mean.chunks_exact(3 * N))
            .zip(rows.chunks_exact(3 * N * k))
        {
            vertex_block::<T, N>(m, r, k, s, o);
        }
        for ((o, m), r) in rest
            .chunks_exact_mut(1)
            .zip(mean[3 * N * blocks..].chunks_exact(3))
            .zip(rows[3 * N * blocks * k..].chunks_exact(3 * k))
        {
            vertex_block::<T, 1>(m, r, k, s, o);
        }
        out
    }

    /// Rows taken `R` at a time: `w`'s entries are loaded and stored once
    /// per `R` rows, each entry's sums still in row order.
    #[target_feature(enable = "avx")]
    pub(super) fn accumulate_body<T: Entry>(x: &[f64], mean: &[f64], rows: &[T], w: &mut [f64]) {
        const R: usize = 4;
        let k = w.len();
        let whole = k - k % 4;
        let groups = x.len() / R;
        for ((xr, m), group) in x
            .chunks_exact(R)
            .zip(mean.chunks_exact(R))
            .zip(rows.chunks_exact(R * k))
        {
            let mut dx = [0.0; R];
            let mut d = [_mm256_setzero_pd(); R];
            for i in 0..R {
                dx[i] = xr[i] - m[i];
                d[i] = _mm256_set1_pd(dx[i]);
            }
            let next = group.as_ptr().wrapping_add(R * k).cast::<i8>();
            for j in (0..whole).step_by(4) {
                // The next group's lines, two per step (a prefetch past the
                // end of the basis is dropped, not a fault).
                let line = j / 4 * 128;
                _mm_prefetch::<_MM_HINT_T0>(next.wrapping_add(line));
                _mm_prefetch::<_MM_HINT_T0>(next.wrapping_add(line + 64));
                let mut sum = load(w, j);
                for (i, d) in d.iter().enumerate() {
                    // SAFETY: `i k + j + 4 <= R k = group.len()` (`j + 4 <=
                    // whole <= k`); AVX is enabled.
                    let a = unsafe { T::load4_unchecked(group, i * k + j) };
                    sum = _mm256_add_pd(sum, _mm256_mul_pd(a, *d));
                }
                let out = &mut w[j..j + 4];
                // SAFETY: four f64 in bounds (the slice above).
                unsafe { _mm256_storeu_pd(out.as_mut_ptr(), sum) };
            }
            for (j, wj) in w.iter_mut().enumerate().skip(whole) {
                for (i, dx) in dx.iter().enumerate() {
                    *wj += group[i * k + j].into() * dx;
                }
            }
        }
        let done = groups * R;
        for ((xr, m), row) in x[done..]
            .iter()
            .zip(&mean[done..])
            .zip(rows[done * k..].chunks_exact(k))
        {
            let dx = xr - m;
            for (wj, a) in w.iter_mut().zip(row) {
                *wj += (*a).into() * dx;
            }
        }
    }
}

/// For each row `r` of `rows` (`n x k`, row-major, `k >= 1`, entries f64 or
/// f32), the three dot products `[dot(row, c[0]), dot(row, c[1]), dot(row,
/// c[2])]` (`c[a]`: `k` entries), each bit for bit as
/// `crate::lbfgs::dot_widened` sums it (the row's entries widened to f64,
/// four partial sums), into `out[r]` (`n` entries). Units: those of the
/// inputs' product.
///
/// One pass over the row for all three: twelve independent partial sums,
/// which the compiler keeps in vector registers (measured on the 22 MB
/// smooth basis: 6 ms per pass for three serial sums per row, 2 ms for
/// this; issue 13).
///
/// Not inlined: inlined into a caller with its own stores around it, the
/// compiler vectorised the loop worse (4.7 ms a pass instead of 1.6).
///
/// Panics if `rows.len()` is not a multiple of `k`, a `c[a]` is shorter
/// than `k` or `out` does not have one entry per row.
#[inline(never)]
pub(crate) fn rows_dot3<T: Entry>(rows: &[T], k: usize, c: [&[f64]; 3], out: &mut [[f64; 3]]) {
    assert!(k > 0 && rows.len().is_multiple_of(k), "rows must be n x k");
    assert_eq!(out.len(), rows.len() / k, "one output per row");
    clear_upper_registers();
    dispatch_avx!(rows_dot3_body::<T>(rows, k, c, out))
}

/// [`rows_dot3`]'s loop (inlined into each of its compilations).
#[inline(always)]
fn rows_dot3_body<T: Copy + Into<f64>>(rows: &[T], k: usize, c: [&[f64]; 3], out: &mut [[f64; 3]]) {
    let (c0, c1, c2) = (&c[0][..k], &c[1][..k], &c[2][..k]);
    let whole = k - k % 4;
    for (o, row) in out.iter_mut().zip(rows.chunks_exact(k)) {
        let mut acc = [[0.0f64; 4]; 3];
        let chunks = row[..whole]
            .chunks_exact(4)
            .zip(c0.chunks_exact(4))
            .zip(c1.chunks_exact(4))
            .zip(c2.chunks_exact(4));
        for (((x, p), q), s) in chunks {
            for l in 0..4 {
                let x: f64 = x[l].into();
                acc[0][l] += x * p[l];
                acc[1][l] += x * q[l];
                acc[2][l] += x * s[l];
            }
        }
        let tail = |c: &[f64]| -> f64 {
            row[whole..]
                .iter()
                .zip(&c[whole..])
                .map(|(x, y)| (*x).into() * y)
                .sum()
        };
        let sums = [tail(c0), tail(c1), tail(c2)];
        *o = std::array::from_fn(|a| (acc[a][0] + acc[a][1]) + (acc[a][2] + acc[a][3]) + sums[a]);
    }
}

/// The points `mean_v + [dot(A_3v, s), dot(A_3v+1, s), dot(A_3v+2, s)]`
/// for every vertex `v` (`mean`: D = 3V entries; `rows`: D x k, row-major,
/// `k >= 1`, entries f64 or f32; `s`: k entries), each dot product bit for
/// bit as `crate::lbfgs::dot_widened` sums it. Units: those of `mean` (a
/// PCA shape in metres, `s` the weights times their SDs).
///
/// One pass over the basis with the vertex's three rows side by side
/// (twelve independent partial sums) instead of three dot products one
/// after the other, each waiting on its own four sums.
///
/// Panics if `mean` is not a multiple of 3 long, `rows` is not
/// `mean.len() x k` or `s` is shorter than `k`.
#[inline(never)]
pub(crate) fn points<T: Entry>(mean: &[f64], rows: &[T], k: usize, s: &[f64]) -> Vec<[f64; 3]> {
    assert!(
        k > 0 && mean.len().is_multiple_of(3),
        "shapes must be points"
    );
    assert_eq!(rows.len(), mean.len() * k, "rows must be D x k");
    clear_upper_registers();
    dispatch_avx!(points_body::<T>(mean, rows, k, &s[..k]))
}

/// [`points`]' loop (inlined into each of its compilations).
#[inline(always)]
fn points_body<T: Copy + Into<f64>>(
    mean: &[f64],
    rows: &[T],
    k: usize,
    s: &[f64],
) -> Vec<[f64; 3]> {
    // A loop and not `map(..).collect()`: `collect` is a function of its
    // own, compiled without the caller's AVX.
    let mut out = vec![[0.0; 3]; mean.len() / 3];
    for ((o, m), rows3) in out
        .iter_mut()
        .zip(mean.chunks_exact(3))
        .zip(rows.chunks_exact(3 * k))
    {
        let d = dots3(rows3, &s[..k]);
        for a in 0..3 {
            o[a] = m[a] + d[a];
        }
    }
    out
}

/// `w += rows^T (x - mean)`, row by row in order: for each row `r` of
/// `rows` (`D x k`, row-major, entries f64 or f32)
/// `w[j] += rows[r][j] * (x[r] - mean[r])`. Units: those of the product (a
/// PCA projection: metres times the basis's unit).
///
/// Panics if `x`, `mean` and the rows do not have the same count D, or
/// `rows` is not `D x w.len()`.
#[inline(never)]
pub(crate) fn accumulate_rows<T: Entry>(x: &[f64], mean: &[f64], rows: &[T], w: &mut [f64]) {
    assert_eq!(x.len(), mean.len(), "a shape and the mean");
    assert_eq!(rows.len(), x.len() * w.len(), "rows must be D x k");
    if w.is_empty() {
        return;
    }
    clear_upper_registers();
    dispatch_avx!(accumulate_body::<T>(x, mean, rows, w))
}

/// [`accumulate_rows`]' loop (inlined into each of its compilations).
#[inline(always)]
fn accumulate_body<T: Copy + Into<f64>>(x: &[f64], mean: &[f64], rows: &[T], w: &mut [f64]) {
    let k = w.len();
    for ((xr, m), row) in x.iter().zip(mean).zip(rows.chunks_exact(k)) {
        let dx = xr - m;
        for (wj, a) in w.iter_mut().zip(row) {
            *wj += (*a).into() * dx;
        }
    }
}

/// The three dot products of the rows of `rows3` (`3 x k`, row-major,
/// `k = w.len()`) with `w`: `[dot(row0, w), dot(row1, w), dot(row2, w)]`,
/// each bit for bit as `crate::lbfgs::dot` sums it, in one pass (twelve
/// partial sums instead of three chains of four one after the other).
///
/// Entries f64 or f32 (widened). Panics if `rows3` does not have `3 k`
/// entries.
#[inline(always)]
pub(crate) fn dots3<T: Copy + Into<f64>>(rows3: &[T], w: &[f64]) -> [f64; 3] {
    let k = w.len();
    assert_eq!(rows3.len(), 3 * k, "rows3 must be 3 x k");
    let (r0, rest) = rows3.split_at(k);
    let (r1, r2) = rest.split_at(k);
    let whole = k - k % 4;
    let mut acc = [[0.0f64; 4]; 3];
    let chunks = w[..whole]
        .chunks_exact(4)
        .zip(r0.chunks_exact(4))
        .zip(r1.chunks_exact(4))
        .zip(r2.chunks_exact(4));
    for (((x, p), q), s) in chunks {
        for l in 0..4 {
            acc[0][l] += p[l].into() * x[l];
            acc[1][l] += q[l].into() * x[l];
            acc[2][l] += s[l].into() * x[l];
        }
    }
    let tail = |r: &[T]| -> f64 {
        r[whole..]
            .iter()
            .zip(&w[whole..])
            .map(|(x, y)| (*x).into() * y)
            .sum()
    };
    let tails = [tail(r0), tail(r1), tail(r2)];
    std::array::from_fn(|a| (acc[a][0] + acc[a][1]) + (acc[a][2] + acc[a][3]) + tails[a])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random value in [-1, 1) with a long mantissa.
    fn noise(i: usize) -> f64 {
        let x = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        ((x >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    #[test]
    fn rows_dot3_matches_dot_bit_for_bit() {
        for k in [1, 2, 3, 7, 8, 200] {
            for n in [0, 1, 3, 4, 5, 9] {
                let rows: Vec<f64> = (0..n * k).map(noise).collect();
                let c: Vec<Vec<f64>> = (0..3)
                    .map(|a| (0..k).map(|i| 1e3 * noise(7919 * (a + 1) + i)).collect())
                    .collect();
                let mut got = vec![[f64::NAN; 3]; n];
                rows_dot3(&rows, k, [&c[0], &c[1], &c[2]], &mut got);
                // The baseline compilation gives the same bits as the
                // dispatched one (AVX where the machine has it).
                let mut base = vec![[f64::NAN; 3]; n];
                rows_dot3_body(&rows, k, [&c[0], &c[1], &c[2]], &mut base);
                assert_eq!(bits(&got), bits(&base), "k {k} n {n}");
                let narrow: Vec<f32> = rows.iter().map(|&v| v as f32).collect();
                let mut got32 = vec![[f64::NAN; 3]; n];
                rows_dot3(&narrow, k, [&c[0], &c[1], &c[2]], &mut got32);
                let mut base32 = vec![[f64::NAN; 3]; n];
                rows_dot3_body(&narrow, k, [&c[0], &c[1], &c[2]], &mut base32);
                assert_eq!(bits(&got32), bits(&base32), "f32, k {k} n {n}");
                for (r, s) in got32.iter().enumerate() {
                    for a in 0..3 {
                        let want = crate::lbfgs::dot_widened(&narrow[r * k..(r + 1) * k], &c[a]);
                        assert_eq!(s[a].to_bits(), want.to_bits(), "f32, k {k} n {n} row {r}");
                    }
                }
                for (r, s) in got.into_iter().enumerate() {
                    let row = &rows[r * k..(r + 1) * k];
                    for a in 0..3 {
                        let want = crate::lbfgs::dot(row, &c[a]);
                        assert_eq!(s[a].to_bits(), want.to_bits(), "k {k} n {n} row {r}");
                        // And the value itself, against a plain sum.
                        let plain: f64 = row.iter().zip(&c[a]).map(|(x, y)| x * y).sum();
                        assert!((s[a] - plain).abs() <= 1e-9 * (1.0 + plain.abs()));
                    }
                }
            }
        }
    }

    fn bits(v: &[[f64; 3]]) -> Vec<[u64; 3]> {
        v.iter().map(|p| p.map(f64::to_bits)).collect()
    }

    #[test]
    fn points_match_dot_bit_for_bit() {
        for k in [1, 2, 3, 4, 5, 7, 8, 100, 103] {
            for n in [0, 1, 2, 3, 5] {
                let mean: Vec<f64> = (0..3 * n).map(|i| noise(977 + i)).collect();
                let rows: Vec<f64> = (0..3 * n * k).map(|i| 1e-2 * noise(i)).collect();
                let narrow: Vec<f32> = rows.iter().map(|&v| v as f32).collect();
                let s: Vec<f64> = (0..k).map(|i| 30.0 * noise(4099 + i)).collect();
                let want = |rows: &dyn Fn(usize) -> f64| -> Vec<[f64; 3]> {
                    (0..n)
                        .map(|v| {
                            std::array::from_fn(|a| {
                                let row: Vec<f64> =
                                    (0..k).map(|j| rows((3 * v + a) * k + j)).collect();
                                mean[3 * v + a] + crate::lbfgs::dot(&row, &s)
                            })
                        })
                        .collect()
                };
                let wide = want(&|i| rows[i]);
                let thin = want(&|i| f64::from(narrow[i]));
                assert_eq!(
                    bits(&points(&mean, &rows, k, &s)),
                    bits(&wide),
                    "k {k} n {n}"
                );
                assert_eq!(bits(&points_body(&mean, &rows, k, &s)), bits(&wide));
                assert_eq!(
                    bits(&points(&mean, &narrow, k, &s)),
                    bits(&thin),
                    "f32 k {k} n {n}"
                );
                assert_eq!(bits(&points_body(&mean, &narrow, k, &s)), bits(&thin));
            }
        }
    }

    #[test]
    fn accumulate_rows_sums_in_row_order_bit_for_bit() {
        for k in [1, 3, 4, 5, 100, 103] {
            for d in [0, 1, 3, 4, 5, 9, 13] {
                let x: Vec<f64> = (0..d).map(|i| noise(31 + i)).collect();
                let mean: Vec<f64> = (0..d).map(|i| 0.5 * noise(6007 + i)).collect();
                let rows: Vec<f64> = (0..d * k).map(noise).collect();
                let narrow: Vec<f32> = rows.iter().map(|&v| v as f32).collect();
                let start: Vec<f64> = (0..k).map(|j| noise(50_000 + j)).collect();
                // Row by row, each entry's products added in row order.
                let want = |row: &dyn Fn(usize) -> f64| -> Vec<u64> {
                    let mut w = start.clone();
                    for r in 0..d {
                        let dx = x[r] - mean[r];
                        for (j, wj) in w.iter_mut().enumerate() {
                            *wj += row(r * k + j) * dx;
                        }
                    }
                    w.into_iter().map(f64::to_bits).collect()
                };
                let run = |f: &dyn Fn(&mut [f64])| -> Vec<u64> {
                    let mut w = start.clone();
                    f(&mut w);
                    w.into_iter().map(f64::to_bits).collect()
                };
                let wide = want(&|i| rows[i]);
                let thin = want(&|i| f64::from(narrow[i]));
                assert_eq!(
                    run(&|w| accumulate_rows(&x, &mean, &rows, w)),
                    wide,
                    "k {k} d {d}"
                );
                assert_eq!(run(&|w| accumulate_body(&x, &mean, &rows, w)), wide);
                assert_eq!(
                    run(&|w| accumulate_rows(&x, &mean, &narrow, w)),
                    thin,
                    "f32"
                );
                assert_eq!(run(&|w| accumulate_body(&x, &mean, &narrow, w)), thin);
            }
        }
    }

    #[test]
    fn dots3_matches_dot_bit_for_bit() {
        for k in [1, 2, 4, 5, 100, 103] {
            let rows: Vec<f64> = (0..3 * k).map(|i| noise(31 + i)).collect();
            let w: Vec<f64> = (0..k).map(|i| 3.0 * noise(5003 + i)).collect();
            let got = dots3(&rows, &w);
            for a in 0..3 {
                let want = crate::lbfgs::dot(&rows[a * k..(a + 1) * k], &w);
                assert_eq!(got[a].to_bits(), want.to_bits(), "k {k} row {a}");
            }
        }
    }

    #[test]
    #[should_panic(expected = "n x k")]
    fn a_ragged_matrix_is_refused() {
        rows_dot3(
            &[1.0f64; 5],
            2,
            [&[1.0; 2], &[1.0; 2], &[1.0; 2]],
            &mut [[0.0; 3]; 2],
        );
    }
}
