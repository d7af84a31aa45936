//! Row-by-row products over the prediction's large dense matrices (the PCA
//! basis, 3V x K; the smooth basis, V x k), several rows at a time.
//!
//! Why: a sum is one chain of dependent additions (floating-point addition
//! is not reassociated), so a loop with one running sum per row waits on
//! the adder's latency at every entry and runs at a fraction of the
//! memory's speed. These keep several independent partial sums in a fixed
//! order (that of [`crate::lbfgs::dot`] for each row), so the results are
//! the same on every run and bit for bit those of `dot` (tests below).
//! Hand-written: a GEMM (faer, matrixmultiply) first copies the whole
//! matrix into its packed layout and sums in its own order; these are
//! single passes.

/// Rows of the PCA basis handled together.
const BLOCK: usize = 4;

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

/// For each row `r` of `rows` (`n x k`, row-major, `k >= 1`), the three dot
/// products `[dot(row, c[0]), dot(row, c[1]), dot(row, c[2])]` (`c[a]`: `k`
/// entries), each bit for bit as `crate::lbfgs::dot` sums it (four partial
/// sums), into `out[r]` (`n` entries). Units: those of the inputs' product.
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
pub(crate) fn rows_dot3(rows: &[f64], k: usize, c: [&[f64]; 3], out: &mut [[f64; 3]]) {
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
                acc[0][l] += x[l] * p[l];
                acc[1][l] += x[l] * q[l];
                acc[2][l] += x[l] * s[l];
            }
        }
        let tail = |c: &[f64]| -> f64 {
            row[whole..]
                .iter()
                .zip(&c[whole..])
                .map(|(x, y)| x * y)
                .sum()
        };
        let sums = [tail(c0), tail(c1), tail(c2)];
        *o = std::array::from_fn(|a| (acc[a][0] + acc[a][1]) + (acc[a][2] + acc[a][3]) + sums[a]);
    }
}

/// For each row `r` of `rows` (`n x k`, row-major, `k >= 1`, entries f32 or
/// f64), `crate::lbfgs::dot_widened(row, s)` (`s`: `k` entries), bit for
/// bit, passed as `out(r, value)` in row order.
///
/// Panics if `rows.len()` is not a multiple of `k` or `s` is shorter than `k`.
pub(crate) fn rows_dot_widened<T: Copy + Into<f64>>(
    rows: &[T],
    k: usize,
    s: &[f64],
    mut out: impl FnMut(usize, f64),
) {
    assert!(k > 0 && rows.len().is_multiple_of(k), "rows must be n x k");
    clear_upper_registers();
    let s = &s[..k];
    let whole = k - k % 4;
    let (s_main, s_tail) = s.split_at(whole);
    // What `dot_widened` adds after its four partial sums: the products of
    // the last k mod 4 entries, summed as its `tail` is.
    let tail = |row: &[T]| -> f64 {
        row[whole..]
            .iter()
            .zip(s_tail)
            .map(|(x, y)| (*x).into() * y)
            .sum()
    };
    let blocks = rows.chunks_exact(BLOCK * k);
    let rest = blocks.remainder();
    let mut r = 0;
    for block in blocks {
        let rs: [&[T]; BLOCK] = std::array::from_fn(|b| &block[b * k..(b + 1) * k]);
        let mut acc = [[0.0f64; 4]; BLOCK];
        for (j, sj) in s_main.chunks_exact(4).enumerate() {
            for (a, row) in acc.iter_mut().zip(&rs) {
                let x = &row[4 * j..4 * j + 4];
                for l in 0..4 {
                    a[l] += x[l].into() * sj[l];
                }
            }
        }
        for (a, row) in acc.iter().zip(&rs) {
            out(r, (a[0] + a[1]) + (a[2] + a[3]) + tail(row));
            r += 1;
        }
    }
    for row in rest.chunks_exact(k) {
        out(r, crate::lbfgs::dot_widened(row, s));
        r += 1;
    }
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
    fn rows_dot_widened_matches_dot_widened_bit_for_bit() {
        for k in [1, 3, 4, 6, 100, 101] {
            for n in [0, 1, 4, 6, 11] {
                let wide: Vec<f64> = (0..n * k).map(noise).collect();
                let narrow: Vec<f32> = wide.iter().map(|&v| v as f32).collect();
                let s: Vec<f64> = (0..k).map(|i| 0.05 * noise(104_729 + i)).collect();
                let mut got = Vec::new();
                rows_dot_widened(&wide, k, &s, |r, v| got.push((r, v)));
                let mut got32 = Vec::new();
                rows_dot_widened(&narrow, k, &s, |r, v| got32.push((r, v)));
                assert_eq!(got.len(), n);
                assert_eq!(got32.len(), n);
                for ((r, v), (r32, v32)) in got.into_iter().zip(got32) {
                    assert_eq!(r, r32);
                    let want = crate::lbfgs::dot_widened(&wide[r * k..(r + 1) * k], &s);
                    let want32 = crate::lbfgs::dot_widened(&narrow[r * k..(r + 1) * k], &s);
                    assert_eq!(v.to_bits(), want.to_bits(), "k {k} n {n} row {r}");
                    assert_eq!(v32.to_bits(), want32.to_bits(), "k {k} n {n} row {r} (f32)");
                }
            }
        }
    }

    #[test]
    #[should_panic(expected = "n x k")]
    fn a_ragged_matrix_is_refused() {
        rows_dot3(
            &[1.0; 5],
            2,
            [&[1.0; 2], &[1.0; 2], &[1.0; 2]],
            &mut [[0.0; 3]; 2],
        );
    }
}
