//! Dense passes of the prediction over its large matrices (the PCA basis,
//! 3V x K; the smooth basis, V x k), and the register state they need.
//!
//! Why: a sum is one chain of dependent additions (floating-point addition
//! is not reassociated), so a loop with one running sum per row waits on
//! the adder's latency at every entry and runs at a fraction of the
//! memory's speed. [`rows_dot3`] keeps twelve independent partial sums in
//! a fixed order (that of [`crate::lbfgs::dot`] for each row), so its
//! results are the same on every run and bit for bit those of `dot` (tests
//! below). (Four rows of the PCA basis at a time, each in `dot`'s order,
//! measured no faster than one at a time: 52.8 against 50.6 ms a paper34
//! prediction.) Hand-written: a GEMM (faer, matrixmultiply) first copies
//! the whole matrix into its packed layout and sums in its own order; this
//! is a single pass.

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
pub(crate) fn rows_dot3<T: Copy + Into<f64>>(
    rows: &[T],
    k: usize,
    c: [&[f64]; 3],
    out: &mut [[f64; 3]],
) {
    assert!(k > 0 && rows.len().is_multiple_of(k), "rows must be n x k");
    assert_eq!(out.len(), rows.len() / k, "one output per row");
    clear_upper_registers();
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

/// The three dot products of the rows of `rows3` (`3 x k`, row-major,
/// `k = w.len()`) with `w`: `[dot(row0, w), dot(row1, w), dot(row2, w)]`,
/// each bit for bit as `crate::lbfgs::dot` sums it, in one pass (twelve
/// partial sums instead of three chains of four one after the other).
///
/// Panics if `rows3` does not have `3 k` entries.
pub(crate) fn dots3(rows3: &[f64], w: &[f64]) -> [f64; 3] {
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
            acc[0][l] += p[l] * x[l];
            acc[1][l] += q[l] * x[l];
            acc[2][l] += s[l] * x[l];
        }
    }
    let tail = |r: &[f64]| -> f64 { r[whole..].iter().zip(&w[whole..]).map(|(x, y)| x * y).sum() };
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
                let narrow: Vec<f32> = rows.iter().map(|&v| v as f32).collect();
                let mut got32 = vec![[f64::NAN; 3]; n];
                rows_dot3(&narrow, k, [&c[0], &c[1], &c[2]], &mut got32);
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
