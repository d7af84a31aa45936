//! Step 2 in a reduced smooth basis: the displacement from the step-1 shape
//! restricted to the span of the template's `k` smoothest modes
//! ([`crate::smooth_basis`]), minimised by damped Gauss-Newton
//! (Levenberg-Marquardt) in the 3k coefficients.
//!
//! Why: the full step 2 has 3V = 41,154 unknowns. L-BFGS needs its 100
//! iterations per round there (each a pass over every edge and vertex), and
//! the sparse Gauss-Newton solver ([`crate::gauss_newton`]) a factorisation
//! of a 41,154-unknown system; both cost about 200 ms per prediction. The
//! objective's smoothness term is diagonal in the basis, and each segment
//! term of `E_m` sees the coefficients through one k-vector `b_e` (its end
//! points' interpolated basis rows), so a Gauss-Newton iteration is a
//! Woodbury solve over the residuals: an m x m Cholesky for the m segment
//! terms (a few hundred), or an M x M one for the M readings
//! ([`ReducedObjective::fit_readings`]); a round needs a handful.
//!
//! The objective is step 2's, `(1 - lambda) E_m + lambda E_s`, at
//! `x = x0 + B C` (`x0` the round's start, `x_ref` the step-1 shape, `B`
//! V x k orthonormal with `B^T L B = diag(sigma)`, `u = x0 - x_ref`): with
//! `d_e(x) = d_e(x0) + C^T b_e`,
//!
//! `F(C) = (1 - lambda) sum_e c_e (|d_e|^2 - l_t(e)^2)^2
//!        + lambda (E_s(u) + 4 sum_a C_a^T B^T L u_a + 2 sum_i sigma_i |C_i|^2)`,
//!
//! or with `E_m` in its readings' form ([`ReducedObjective::fit_readings`]).
//! What was measured (`docs/results/predict-sreal.md`,
//! `docs/results/predict-iso.md`): the readings' form meets generated
//! bodies' readings as the default does, the per-segment form cannot (the
//! smooth modes cannot move length along a support), and both bend real
//! people with contradicting readings where L-BFGS does not.
//!
//! Unknowns are ordered by coordinate: `c[a k + i]` is mode `i`'s
//! coefficient of coordinate `a` (mm). Deterministic: one thread, a fixed
//! order.

use std::cell::RefCell;

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::{Accum, Mat, MatMut, MatRef, Par, Side};

use crate::energy::SegmentTerm;
use crate::gauss_newton::{GaussNewtonStop, MAX_REJECTS};
use crate::lbfgs::{dot, Control, MinimiseError, Objective, RunInfo, Termination};
use crate::smooth_basis::SmoothBasis;

/// Step 2's objective over the 3k coefficients of the smooth basis (see the
/// module docs).
pub struct ReducedObjective<'a> {
    basis: &'a SmoothBasis,
    lambda: f64,
    terms: Vec<SegmentTerm>,
    /// m x k, row-major: per term, `b_e = sum_v coef_v B[v, :]`.
    bt: Vec<f64>,
    /// m x 3, column-major: the terms' segment vectors at the start `x0` (mm).
    dref: Vec<f64>,
    /// `4 B^T L u` (3k, by coordinate), `u = x0 - x_ref`: `E_s`'s linear
    /// term in the coefficients.
    linear: Vec<f64>,
    /// `E_s(u)`.
    es0: f64,
    /// Scratch: segment vectors and their energy gradients (m x 3 each).
    scratch: RefCell<(Vec<f64>, Vec<f64>)>,
    /// Fit each reading's length instead of each segment's
    /// ([`ReducedObjective::fit_readings`]).
    readings: Option<ReadingsFit>,
    /// The energy of a 1 mm error on one reading at the reference
    /// tolerance ([`ReducedObjective::with_reading_energy`]), where known.
    per_mm2: Option<f64>,
}

/// The readings' form of `E_m`: per reading `j`, `W_j (m_j - T_j)^2`, with
/// `m_j` the sum of its segments' lengths, `T_j = sum_e l_t(e)` and
/// `W_j = 4 sum_e c_e l_t(e)^4 / T_j^2`, the weight the segment terms give
/// an error spread over the reading in proportion to its segments (the
/// per-measurement weighting's derivation, `predict/terms.rs`).
struct ReadingsFit {
    /// Per term, its reading.
    owner: Vec<usize>,
    /// Per reading, `T_j` (mm) and `W_j`.
    target: Vec<f64>,
    weight: Vec<f64>,
}

/// The four vertices of a term and each one's coefficient in `d = q1 - q0`.
fn term_vertices(t: &SegmentTerm) -> [(u32, f64); 4] {
    [
        (t.p1.a, 1.0 - t.p1.t),
        (t.p1.b, t.p1.t),
        (t.p0.a, -(1.0 - t.p0.t)),
        (t.p0.b, -t.p0.t),
    ]
}

impl<'a> ReducedObjective<'a> {
    /// The objective for measurement `terms` (over mesh vertex indices),
    /// the `basis` of the template and its undirected `edges`, the
    /// reference (step-1) shape `reference` and the start `x0` (flat, 3V,
    /// mm; the unknowns are the coefficients of `x = x0 + B C`), and the
    /// smoothness weight `lambda`.
    ///
    /// Panics if `reference` or `x0` is not 3V long or a term or edge names
    /// a vertex beyond V (all come from the template the basis was
    /// computed for).
    ///
    /// Where `x0 - reference` is itself `B C0` (earlier rounds of this
    /// solver alone), [`ReducedObjective::with_offset`] is cheaper.
    pub fn new(
        terms: Vec<SegmentTerm>,
        basis: &'a SmoothBasis,
        edges: &[[u32; 2]],
        reference: &[f64],
        x0: &[f64],
        lambda: f64,
    ) -> Self {
        let (n, k) = (basis.n_vertices(), basis.k());
        assert_eq!(reference.len(), 3 * n, "reference is 3V");
        assert_eq!(x0.len(), 3 * n, "x0 is 3V");
        let m = terms.len();
        let mut bt = vec![0.0; m * k];
        let mut dref = vec![0.0; 3 * m];
        for (e, t) in terms.iter().enumerate() {
            let row = &mut bt[e * k..(e + 1) * k];
            for (v, coef) in term_vertices(t) {
                if coef == 0.0 {
                    continue;
                }
                let v = v as usize;
                for (r, b) in row.iter_mut().zip(basis.row(v)) {
                    *r += coef * b;
                }
                for a in 0..3 {
                    dref[a * m + e] += coef * x0[3 * v + a];
                }
            }
        }
        // E_s(u + B C) = E_s(u) + 4 sum_a C_a^T B^T L u_a + 2 sum_i sigma_i |C_i|^2.
        let mut lu = vec![0.0; 3 * n];
        let mut es0 = 0.0;
        if x0 != reference {
            for &[p, q] in edges {
                let (p, q) = (p as usize, q as usize);
                for a in 0..3 {
                    let du = (x0[3 * p + a] - reference[3 * p + a])
                        - (x0[3 * q + a] - reference[3 * q + a]);
                    es0 += 2.0 * du * du;
                    lu[a * n + p] += du;
                    lu[a * n + q] -= du;
                }
            }
        }
        let mut linear = vec![0.0; 3 * k];
        if es0 > 0.0 {
            matmul(
                MatMut::from_column_major_slice_mut(&mut linear, k, 3),
                Accum::Replace,
                MatRef::from_row_major_slice(basis.rows(), n, k).transpose(),
                MatRef::from_column_major_slice(&lu, n, 3),
                4.0,
                Par::Seq,
            );
        }
        Self {
            basis,
            lambda,
            terms,
            bt,
            dref,
            linear,
            es0,
            scratch: RefCell::new((vec![0.0; 3 * m], vec![0.0; 3 * m])),
            readings: None,
            per_mm2: None,
        }
    }

    /// [`ReducedObjective::new`] for a start `x0 = reference + B c0`
    /// (`c0`: 3k, by coordinate), whose smoothness terms follow from `c0`
    /// without a pass over the mesh: `B^T L B c0 = sigma c0`.
    ///
    /// Panics as [`ReducedObjective::new`], or if `c0` is not 3k long.
    pub fn with_offset(
        terms: Vec<SegmentTerm>,
        basis: &'a SmoothBasis,
        x0: &[f64],
        c0: &[f64],
        lambda: f64,
    ) -> Self {
        let k = basis.k();
        assert_eq!(c0.len(), 3 * k, "c0 is 3k");
        // With x0 as its own reference `new` skips the pass over the edges.
        let mut obj = Self::new(terms, basis, &[], x0, x0, lambda);
        obj.es0 = 0.0;
        for (j, &c) in c0.iter().enumerate() {
            let s = basis.values()[j % k];
            obj.linear[j] = 4.0 * s * c;
            obj.es0 += 2.0 * s * c * c;
        }
        obj
    }

    /// The same objective with `E_m` fitted per reading instead of per
    /// segment (see `ReadingsFit` in this module): `owner[e]` is term `e`'s reading
    /// (0-based, dense). The per-segment targets spread each reading over
    /// its segments in proportion to their lengths on the round's start;
    /// the readings' form asks only for each reading's length, so the
    /// smooth modes need not redistribute length along a support.
    ///
    /// Panics if `owner` does not have one entry per term.
    pub fn fit_readings(mut self, owner: &[usize]) -> Self {
        assert_eq!(owner.len(), self.terms.len(), "one owner per term");
        let n_readings = owner.iter().max().map_or(0, |m| m + 1);
        let mut target = vec![0.0; n_readings];
        let mut l4 = vec![0.0; n_readings];
        for (t, &j) in self.terms.iter().zip(owner) {
            target[j] += t.target_sq.sqrt();
            l4[j] += 4.0 * t.weight * t.target_sq * t.target_sq;
        }
        let weight = target
            .iter()
            .zip(&l4)
            .map(|(&t, &l)| if t > 0.0 { l / (t * t) } else { 0.0 })
            .collect();
        self.readings = Some(ReadingsFit {
            owner: owner.to_vec(),
            target,
            weight,
        });
        self
    }

    /// The same objective, told that its `E_m` costs about `reading_weight`
    /// per mm^2 of one reading's error at the reference tolerance (the
    /// per-measurement weighting's scale, [`crate::Step2Weighting`]), so
    /// that [`minimise_reduced`] can stop on a decrease worth less than
    /// `min_decrease_mm` of a reading: the energy of such an error is
    /// `(1 - lambda) reading_weight min_decrease_mm^2`.
    ///
    /// Panics if `reading_weight` is not a positive number.
    pub fn with_reading_energy(mut self, reading_weight: f64) -> Self {
        assert!(
            reading_weight.is_finite() && reading_weight > 0.0,
            "reading_weight is a positive number"
        );
        self.per_mm2 = Some((1.0 - self.lambda) * reading_weight);
        self
    }

    /// Per term, its length and the length's gradient with respect to the
    /// segment vector (unit; 0 for a zero-length segment), from `d`.
    fn lengths(&self, d: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let m = self.terms.len();
        let mut len = vec![0.0; m];
        let mut u = vec![0.0; 3 * m];
        for (e, t) in self.terms.iter().enumerate() {
            let de = [d[e], d[m + e], d[2 * m + e]];
            let (l, ue) = match t.axis {
                Some(n) => {
                    let nd = n[0] * de[0] + n[1] * de[1] + n[2] * de[2];
                    let sg = if nd > 0.0 {
                        1.0
                    } else if nd < 0.0 {
                        -1.0
                    } else {
                        0.0
                    };
                    (nd.abs(), [sg * n[0], sg * n[1], sg * n[2]])
                }
                None => {
                    let l = (de[0] * de[0] + de[1] * de[1] + de[2] * de[2]).sqrt();
                    if l > 0.0 {
                        (l, [de[0] / l, de[1] / l, de[2] / l])
                    } else {
                        (0.0, [0.0; 3])
                    }
                }
            };
            len[e] = l;
            for a in 0..3 {
                u[a * m + e] = ue[a];
            }
        }
        (len, u)
    }

    /// The readings' Jacobian `J` at coefficients `c` (M x 3k, row-major:
    /// row `j` is reading `j`'s length's gradient in the coefficients,
    /// by coordinate). It depends on `c` alone, so a refused step's retry
    /// at a larger damping reuses it.
    fn readings_jacobian(&self, fit: &ReadingsFit, c: &[f64]) -> Vec<f64> {
        let (m, k) = (self.terms.len(), self.basis.k());
        let n_r = fit.target.len();
        let mut guard = self.scratch.borrow_mut();
        let (d, _) = &mut *guard;
        self.segments(c, d);
        let (_, u) = self.lengths(d);
        // Each term adds to contiguous runs of its reading's row.
        let mut jac = vec![0.0; n_r * 3 * k];
        for (e, &j) in fit.owner.iter().enumerate() {
            let row = &self.bt[e * k..(e + 1) * k];
            for a in 0..3 {
                let ua = u[a * m + e];
                if ua != 0.0 {
                    let dst = &mut jac[j * 3 * k + a * k..j * 3 * k + (a + 1) * k];
                    for (o, b) in dst.iter_mut().zip(row) {
                        *o += ua * b;
                    }
                }
            }
        }
        jac
    }

    /// The Gauss-Newton step of the readings' form at damping `mu` from
    /// the Jacobian `jac` ([`ReducedObjective::readings_jacobian`]) and
    /// the gradient `g`: `(2 (1 - lambda) J^T W J + D) delta = -g`, by the
    /// Woodbury identity over the M readings,
    /// `delta = -(y - D^-1 J^T W^1/2 S^-1 W^1/2 J y)`, `y = D^-1 g`,
    /// `S = I + W^1/2 J D^-1 J^T W^1/2` (M x M; only its lower triangle is
    /// formed, as `X X^T` with `X = W^1/2 J D^-1/2`). `None` if `S` is not
    /// numerically definite or the step is not finite.
    fn readings_solve(
        &self,
        fit: &ReadingsFit,
        jac: &[f64],
        g: &[f64],
        mu: f64,
    ) -> Option<Vec<f64>> {
        let k = self.basis.k();
        let n = 3 * k;
        let n_r = fit.target.len();
        let dinv: Vec<f64> = (0..n)
            .map(|j| 1.0 / (4.0 * self.lambda * self.basis.values()[j % k] + mu))
            .collect();
        let omega: Vec<f64> = fit
            .weight
            .iter()
            .map(|w| (2.0 * (1.0 - self.lambda) * w).max(0.0).sqrt())
            .collect();
        let sqrt_dinv: Vec<f64> = dinv.iter().map(|d| d.sqrt()).collect();
        let mut x = vec![0.0; n_r * n];
        for ((xr, jr), om) in x.chunks_exact_mut(n).zip(jac.chunks_exact(n)).zip(&omega) {
            for ((o, j), s) in xr.iter_mut().zip(jr).zip(&sqrt_dinv) {
                *o = om * j * s;
            }
        }
        let xm = MatRef::from_row_major_slice(&x, n_r, n);
        let mut smat = Mat::<f64>::zeros(n_r, n_r);
        faer::linalg::matmul::triangular::matmul(
            &mut smat,
            faer::linalg::matmul::triangular::BlockStructure::TriangularLower,
            Accum::Replace,
            xm,
            faer::linalg::matmul::triangular::BlockStructure::Rectangular,
            xm.transpose(),
            faer::linalg::matmul::triangular::BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        for r in 0..n_r {
            smat[(r, r)] += 1.0;
        }
        let y: Vec<f64> = g.iter().zip(&dinv).map(|(g, d)| g * d).collect();
        let mut z =
            Mat::<f64>::from_fn(n_r, 1, |r, _| omega[r] * dot(&jac[r * n..(r + 1) * n], &y));
        smat.llt(Side::Lower).ok()?.solve_in_place(z.as_mut());
        // back = J^T W^1/2 z, a row at a time.
        let mut back = vec![0.0; n];
        for (r, jr) in jac.chunks_exact(n).enumerate() {
            let s = omega[r] * z[(r, 0)];
            if s != 0.0 {
                for (b, j) in back.iter_mut().zip(jr) {
                    *b += s * j;
                }
            }
        }
        let delta: Vec<f64> = y
            .iter()
            .zip(&dinv)
            .zip(&back)
            .map(|((y, d), b)| -(y - d * b))
            .collect();
        delta.iter().all(|v| v.is_finite()).then_some(delta)
    }

    /// The number of unknowns, 3k.
    pub fn len(&self) -> usize {
        3 * self.basis.k()
    }

    /// Whether there are no unknowns (never: a basis has at least one mode).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn bt(&self) -> MatRef<'_, f64> {
        MatRef::from_row_major_slice(&self.bt, self.terms.len(), self.basis.k())
    }

    /// The segment vectors at coefficients `c` into `d` (m x 3, column-major).
    fn segments(&self, c: &[f64], d: &mut [f64]) {
        let (m, k) = (self.terms.len(), self.basis.k());
        if m == 0 {
            return;
        }
        // One pass over the m x k rows (a GEMM would pack them first, at
        // every evaluation).
        let (c0, rest) = c.split_at(k);
        let (c1, c2) = rest.split_at(k);
        let mut sums = vec![[0.0; 3]; m];
        crate::kernels::rows_dot3(&self.bt, k, [c0, c1, c2], &mut sums);
        for (e, s) in sums.iter().enumerate() {
            for a in 0..3 {
                d[a * m + e] = self.dref[a * m + e] + s[a];
            }
        }
    }

    /// `grad = scale B_t^T gd` (3k, by coordinate) for per-term segment
    /// gradients `gd` (m x 3, column-major): each term's row added into
    /// the three coordinates' blocks, in term order.
    fn pull_back(&self, gd: &[f64], scale: f64, grad: &mut [f64]) {
        let (m, k) = (self.terms.len(), self.basis.k());
        grad.fill(0.0);
        for (e, row) in self.bt.chunks_exact(k).enumerate() {
            for a in 0..3 {
                let g = scale * gd[a * m + e];
                if g != 0.0 {
                    for (o, b) in grad[a * k..(a + 1) * k].iter_mut().zip(row) {
                        *o += g * b;
                    }
                }
            }
        }
    }

    /// `H = 2 (1 - lambda) sum_e c_e g_e g_e^T + 4 lambda diag(sigma) + mu I`
    /// at `c` (3k x 3k, the Gauss-Newton Hessian of [`Objective::eval`]'s
    /// energy; exact for `E_s`), with `g_e = b_e (x) dr_e/dd_e`.
    #[cfg(test)]
    fn hessian(&self, c: &[f64], mu: f64) -> Mat<f64> {
        let (m, k) = (self.terms.len(), self.basis.k());
        let mut guard = self.scratch.borrow_mut();
        let (d, _) = &mut *guard;
        self.segments(c, d);
        // dr/dd per term (m x 3).
        let mut h = vec![0.0; 3 * m];
        for (e, t) in self.terms.iter().enumerate() {
            let de = [d[e], d[m + e], d[2 * m + e]];
            let he = match t.axis {
                Some(n) => {
                    let nd = n[0] * de[0] + n[1] * de[1] + n[2] * de[2];
                    [2.0 * nd * n[0], 2.0 * nd * n[1], 2.0 * nd * n[2]]
                }
                None => [2.0 * de[0], 2.0 * de[1], 2.0 * de[2]],
            };
            for a in 0..3 {
                h[a * m + e] = he[a];
            }
        }
        let mut out = Mat::<f64>::zeros(3 * k, 3 * k);
        let mut scaled = vec![0.0; m * k];
        let s0 = 2.0 * (1.0 - self.lambda);
        for a in 0..3 {
            for b in a..3 {
                for (e, t) in self.terms.iter().enumerate() {
                    let s = s0 * t.weight * h[a * m + e] * h[b * m + e];
                    let src = &self.bt[e * k..(e + 1) * k];
                    for (o, v) in scaled[e * k..(e + 1) * k].iter_mut().zip(src) {
                        *o = s * v;
                    }
                }
                matmul(
                    out.as_mut().submatrix_mut(a * k, b * k, k, k),
                    Accum::Replace,
                    self.bt().transpose(),
                    MatRef::from_row_major_slice(&scaled, m, k),
                    1.0,
                    Par::Seq,
                );
            }
        }
        for a in 0..3 {
            for b in 0..a {
                for i in 0..k {
                    for j in 0..k {
                        out[(a * k + i, b * k + j)] = out[(b * k + j, a * k + i)];
                    }
                }
            }
            for (i, &s) in self.basis.values().iter().enumerate() {
                out[(a * k + i, a * k + i)] += 4.0 * self.lambda * s + mu;
            }
        }
        out
    }

    /// `D^-1` (k: `1 / (4 lambda sigma_i + mu)`, the same for the three
    /// coordinates) and `K = B_t D^-1 B_t^T` (m x m), the parts of the
    /// Gauss-Newton system at damping `mu` that do not depend on `c`.
    fn kernel(&self, mu: f64) -> (Vec<f64>, Mat<f64>) {
        let (m, k) = (self.terms.len(), self.basis.k());
        let dinv: Vec<f64> = self
            .basis
            .values()
            .iter()
            .map(|&s| 1.0 / (4.0 * self.lambda * s + mu))
            .collect();
        let mut scaled = self.bt.clone();
        for row in scaled.chunks_exact_mut(k) {
            row.iter_mut().zip(&dinv).for_each(|(r, d)| *r *= d);
        }
        let mut kmat = Mat::<f64>::zeros(m, m);
        matmul(
            &mut kmat,
            Accum::Replace,
            self.bt(),
            MatRef::from_row_major_slice(&scaled, m, k).transpose(),
            1.0,
            Par::Seq,
        );
        (dinv, kmat)
    }

    /// The Gauss-Newton step at `c` with gradient `g`: `delta` solving
    /// `(H + mu I) delta = -g` (`H` the Gauss-Newton Hessian of the
    /// per-segment energy) by the
    /// Woodbury identity over the m segment terms,
    /// `(D + J^T W J)^-1 = D^-1 - D^-1 J^T W^1/2 S^-1 W^1/2 J D^-1`,
    /// `S = I + W^1/2 J D^-1 J^T W^1/2`, where `J D^-1 J^T` is `K`
    /// (`ReducedObjective::kernel`) times `h_e . h_f` entry by entry
    /// (`J`'s row `e` is `b_e (x) h_e`). An m x m Cholesky (m a few
    /// hundred segments) instead of a 3k x 3k one. `None` if `S` is not
    /// numerically definite.
    fn step(&self, c: &[f64], g: &[f64], dinv: &[f64], kmat: &Mat<f64>) -> Option<Vec<f64>> {
        let (m, k) = (self.terms.len(), self.basis.k());
        let mut guard = self.scratch.borrow_mut();
        let (d, _) = &mut *guard;
        self.segments(c, d);
        // h_e = dr_e/dd_e (m x 3, column-major) and omega_e = sqrt(W_e).
        let mut h = vec![0.0; 3 * m];
        let mut omega = vec![0.0; m];
        for (e, t) in self.terms.iter().enumerate() {
            let de = [d[e], d[m + e], d[2 * m + e]];
            let he = match t.axis {
                Some(n) => {
                    let nd = n[0] * de[0] + n[1] * de[1] + n[2] * de[2];
                    [2.0 * nd * n[0], 2.0 * nd * n[1], 2.0 * nd * n[2]]
                }
                None => [2.0 * de[0], 2.0 * de[1], 2.0 * de[2]],
            };
            for a in 0..3 {
                h[a * m + e] = he[a];
            }
            omega[e] = (2.0 * (1.0 - self.lambda) * t.weight).max(0.0).sqrt();
        }
        let mut smat = Mat::<f64>::from_fn(m, m, |e, f| {
            let hh = h[e] * h[f] + h[m + e] * h[m + f] + h[2 * m + e] * h[2 * m + f];
            omega[e] * omega[f] * hh * kmat[(e, f)]
        });
        for e in 0..m {
            smat[(e, e)] += 1.0;
        }
        // y = D^-1 g; z = W^1/2 J y.
        let y: Vec<f64> = g
            .iter()
            .enumerate()
            .map(|(j, gj)| gj * dinv[j % k])
            .collect();
        let mut by = Mat::<f64>::zeros(m, 3);
        matmul(
            &mut by,
            Accum::Replace,
            self.bt(),
            MatRef::from_column_major_slice(&y, k, 3),
            1.0,
            Par::Seq,
        );
        let mut z = Mat::<f64>::from_fn(m, 1, |e, _| {
            omega[e] * (h[e] * by[(e, 0)] + h[m + e] * by[(e, 1)] + h[2 * m + e] * by[(e, 2)])
        });
        let llt = smat.llt(Side::Lower).ok()?;
        llt.solve_in_place(z.as_mut());
        // r = J^T W^1/2 s, by coordinate: B_t^T (h_a o omega o s).
        let hq = Mat::<f64>::from_fn(m, 3, |e, a| h[a * m + e] * omega[e] * z[(e, 0)]);
        let mut r = Mat::<f64>::zeros(k, 3);
        matmul(
            &mut r,
            Accum::Replace,
            self.bt().transpose(),
            &hq,
            1.0,
            Par::Seq,
        );
        let delta: Vec<f64> = (0..3 * k)
            .map(|j| -(y[j] - dinv[j % k] * r[(j % k, j / k)]))
            .collect();
        delta.iter().all(|v| v.is_finite()).then_some(delta)
    }

    /// The vertices `x = x0 + B C` (flat, 3V, mm) into `out`, `x0` the
    /// start the objective was built for, with `B` rounded to f32
    /// ([`SmoothBasis::rows_f32`]: half the bytes of this memory-bound
    /// pass; the displacement `B C` is then within about 1e-7 of itself, a
    /// micrometre of a 10 mm move; the body is measured afresh from these
    /// vertices).
    pub fn vertices(&self, x0: &[f64], c: &[f64], out: &mut [f64]) {
        let k = self.basis.k();
        let (c0, rest) = c.split_at(k);
        let (c1, c2) = rest.split_at(k);
        // One pass over the V x k basis (a GEMM with three columns would
        // first copy all of it into its packed layout).
        let mut sums = vec![[0.0; 3]; self.basis.n_vertices()];
        crate::kernels::rows_dot3(self.basis.rows_f32(), k, [c0, c1, c2], &mut sums);
        for ((o, x), s) in out.chunks_exact_mut(3).zip(x0.chunks_exact(3)).zip(&sums) {
            for a in 0..3 {
                o[a] = x[a] + s[a];
            }
        }
    }
}

impl Objective for ReducedObjective<'_> {
    /// The energy at coefficients `c` (3k, by coordinate) and its gradient
    /// into `grad` (3k).
    fn eval(&self, c: &[f64], grad: &mut [f64]) -> f64 {
        let (m, k) = (self.terms.len(), self.basis.k());
        let mut guard = self.scratch.borrow_mut();
        let (d, gd) = &mut *guard;
        self.segments(c, d);
        let mut em = 0.0;
        if let Some(fit) = &self.readings {
            let (len, u) = self.lengths(d);
            let mut value = vec![0.0; fit.target.len()];
            for (&j, l) in fit.owner.iter().zip(&len) {
                value[j] += l;
            }
            let r: Vec<f64> = value.iter().zip(&fit.target).map(|(v, t)| v - t).collect();
            em = r.iter().zip(&fit.weight).map(|(r, w)| w * r * r).sum();
            for (e, &j) in fit.owner.iter().enumerate() {
                let s = 2.0 * fit.weight[j] * r[j];
                for a in 0..3 {
                    gd[a * m + e] = s * u[a * m + e];
                }
            }
        } else {
            for (e, t) in self.terms.iter().enumerate() {
                let de = [d[e], d[m + e], d[2 * m + e]];
                let (len2, half) = match t.axis {
                    Some(n) => {
                        let nd = n[0] * de[0] + n[1] * de[1] + n[2] * de[2];
                        (nd * nd, [nd * n[0], nd * n[1], nd * n[2]])
                    }
                    None => (de[0] * de[0] + de[1] * de[1] + de[2] * de[2], de),
                };
                let r = len2 - t.target_sq;
                em += t.weight * r * r;
                let s = 4.0 * t.weight * r;
                for a in 0..3 {
                    gd[a * m + e] = s * half[a];
                }
            }
        }
        self.pull_back(gd, 1.0 - self.lambda, grad);
        let mut es = self.es0;
        for a in 0..3 {
            for (i, &s) in self.basis.values().iter().enumerate() {
                let j = a * k + i;
                let ci = c[j];
                es += 2.0 * s * ci * ci + self.linear[j] * ci;
                grad[j] += self.lambda * (4.0 * s * ci + self.linear[j]);
            }
        }
        (1.0 - self.lambda) * em + self.lambda * es
    }
}

/// Minimises `obj` from coefficients `c0` (3k) by damped Gauss-Newton,
/// asking `watch(n)` before evaluation `n` as
/// [`crate::lbfgs::minimise_watched`] does, with the stopping rules of
/// [`crate::gauss_newton::minimise_vertices`] (the same `stop`; the
/// model-error rule measured against the energy after the step), and,
/// where `min_decrease_mm > 0` and `obj` knows its readings' energy
/// ([`ReducedObjective::with_reading_energy`]), an absolute one: the run
/// ends ([`Termination::DecreaseBelowReading`]) when an accepted step
/// lowered the energy by at most what an error of `min_decrease_mm` on
/// one reading costs, or before evaluating a step whose predicted decrease
/// (the damped Gauss-Newton model's) is at most that. Returns the best
/// coefficients and what the run did.
///
/// Errors if the objective is not finite at `c0`.
pub fn minimise_reduced(
    obj: &ReducedObjective<'_>,
    c0: Vec<f64>,
    stop: &GaussNewtonStop,
    min_decrease_mm: f64,
    watch: &dyn Fn(u64) -> Control,
) -> Result<(Vec<f64>, RunInfo), MinimiseError> {
    // The energy a step must gain to be worth its evaluation (0: none).
    let abs_tol = match obj.per_mm2 {
        Some(w) if min_decrease_mm > 0.0 => w * min_decrease_mm * min_decrease_mm,
        _ => 0.0,
    };
    let n = c0.len();
    let info = |iterations, evaluations, cost_start, cost_end, reason| RunInfo {
        iterations,
        evaluations,
        cost_start,
        cost_end,
        reason,
    };
    if watch(0) == Control::Cancel {
        return Ok((c0, info(0, 0, f64::NAN, f64::NAN, Termination::Interrupted)));
    }
    let mut g = vec![0.0; n];
    let mut evaluations = 1u64;
    let mut f = obj.eval(&c0, &mut g);
    if !f.is_finite() || g.iter().any(|v| !v.is_finite()) {
        return Err(MinimiseError::NonFiniteStart);
    }
    let f0 = f;
    if n == 0 {
        return Ok((c0, info(0, evaluations, f0, f, Termination::NoVariables)));
    }
    let mut c = c0;
    let mut c_try = vec![0.0; n];
    let mut g_try = vec![0.0; n];
    // Damping relative to the smoothness term's mean diagonal: it pins
    // the rigid translation (sigma_0 = 0, which E_m does not see either),
    // is raised when a step is refused and lowered threefold, not below
    // `mu_min`, when one is taken. The per-segment kernel (`fit:
    // Segments`, not the default) depends on mu alone and is computed
    // again whenever mu changes, so with the damped start below nearly
    // every iteration of that form computes it; the readings' form (the
    // default) solves per iteration anyway.
    let scale = {
        let v = obj.basis.values();
        let s = 4.0 * obj.lambda * v.iter().sum::<f64>() / v.len() as f64;
        if s > 0.0 && s.is_finite() {
            s
        } else {
            1.0
        }
    };
    let mu_min = 1e-6 * scale;
    // A round starts damped at the mean diagonal itself, not at `mu_min`:
    // a round's first step from a re-measured shape, nearly undamped,
    // overshot (the readings' lengths are not linear that far), and the
    // round then spent five or six refused steps raising mu eightfold each
    // time before one was taken. Started here, the bench's paper34 body
    // took 13 evaluations in step 2 instead of 35 (soft pull 0.5; 21
    // instead of 40 at 0.75), the same energies, and on all 1,505 ANSUR II
    // test-split people (quick with sex) the same errors
    // (docs/results/predict-bench.md, 2026-12-07).
    let mut mu = scale;
    let mut kernel: Option<(f64, Vec<f64>, Mat<f64>)> = None;
    // The readings' Jacobian at `c`, kept until a step is accepted.
    let mut readings_jac: Option<Vec<f64>> = None;
    let mut rejects = 0u32;
    let mut iterations = 0u64;
    let reason = loop {
        if dot(&g, &g).sqrt() < stop.grad_tol {
            break Termination::GradientBelowTolerance;
        }
        if iterations >= stop.max_iters {
            break Termination::MaxIterations;
        }
        iterations += 1;
        let step = match &obj.readings {
            Some(fit) => {
                let jac = readings_jac.get_or_insert_with(|| obj.readings_jacobian(fit, &c));
                obj.readings_solve(fit, jac, &g, mu)
            }
            None => {
                if kernel.as_ref().is_none_or(|k| k.0 != mu) {
                    let (dinv, kmat) = obj.kernel(mu);
                    kernel = Some((mu, dinv, kmat));
                }
                let (_, dinv, kmat) = kernel.as_ref().expect("set above");
                obj.step(&c, &g, dinv, kmat)
            }
        };
        let Some(delta) = step else {
            rejects += 1;
            if rejects >= MAX_REJECTS {
                break Termination::LineSearchFailed;
            }
            mu = (mu * 10.0).max(1e-3 * scale);
            continue;
        };
        let predicted = 0.5 * (-dot(&g, &delta) + mu * dot(&delta, &delta));
        if predicted <= abs_tol {
            break Termination::DecreaseBelowReading;
        }
        for ((t, ci), di) in c_try.iter_mut().zip(&c).zip(&delta) {
            *t = ci + di;
        }
        if watch(evaluations) == Control::Cancel {
            break Termination::Interrupted;
        }
        evaluations += 1;
        let f_try = obj.eval(&c_try, &mut g_try);
        if f_try.is_finite() && f_try < f {
            let decrease = f - f_try;
            std::mem::swap(&mut c, &mut c_try);
            std::mem::swap(&mut g, &mut g_try);
            readings_jac = None;
            let f_prev = f;
            f = f_try;
            rejects = 0;
            mu = (mu / 3.0).max(mu_min);
            let tol = stop.rel_cost_tol * f_prev.abs().max(f.abs());
            let model_error = if predicted > 0.0 {
                (1.0 - decrease / predicted).abs()
            } else {
                1.0
            };
            // The decrease the next step could still find, against the
            // energy now (not before: a first step that removes nearly all
            // of a large start would otherwise end the run short of the
            // minimum).
            if decrease <= tol || decrease * model_error <= stop.rel_cost_tol * f.abs() {
                break Termination::RelativeChangeBelowTolerance;
            }
            if decrease <= abs_tol {
                break Termination::DecreaseBelowReading;
            }
        } else {
            rejects += 1;
            if rejects >= MAX_REJECTS {
                break Termination::LineSearchFailed;
            }
            mu = (mu * 8.0).max(1e-3 * scale);
        }
    };
    Ok((c, info(iterations, evaluations, f0, f, reason)))
}

#[cfg(test)]
mod tests;
