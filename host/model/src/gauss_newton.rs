//! Step 2 by Gauss-Newton with a sparse Cholesky factorisation
//! (Levenberg-Marquardt damping), beside the paper's L-BFGS.
//!
//! Why: step 2 minimises `(1 - lambda) E_m + lambda E_s` over the 3V vertex
//! coordinates (41,154 on the template). `E_s` is a quadratic form (the
//! mesh Laplacian, once per coordinate) and `E_m` a sum of a few hundred to
//! a few thousand squared segment residuals `r_e = |d_e|^2 - l_t(e)^2`,
//! each touching at most four vertices. Per-measurement weighting makes
//! those residuals five to six decades stiffer than the Laplacian, so
//! L-BFGS, which learns curvature from a few gradient differences, spends
//! its 100 iterations per round and stops short; Gauss-Newton solves the
//! linearised problem exactly in each iteration and needs a handful.
//!
//! Each iteration solves `(H + mu I) delta = -g` with
//! `H = 2 (1 - lambda) sum_e c_e grad r_e grad r_e^T + 4 lambda (L (x) I_3)`,
//! the Gauss-Newton Hessian (exact for `E_s`; for `E_m` without the
//! second-order residual term, which vanishes at a fit), by faer's sparse
//! Cholesky (AMD ordering, supernodal where it pays). The sparsity pattern,
//! the symbolic factorisation and the last numeric factor are kept between
//! iterations and rounds ([`SymbolicCache`]); an iteration refills the
//! values and solves by conjugate gradients preconditioned with the kept
//! factor, factorising again only when that does not converge at once (a
//! prediction of the quick set factorises once). `mu` (Levenberg-Marquardt) makes the
//! system definite (`E_m` and `E_s` are both blind to a rigid translation)
//! and damps steps the energy does not accept: a trial that does not lower
//! the energy is refused and retried with a larger `mu`, an accepted one
//! lowers `mu`.
//!
//! Deterministic: one thread (`Par::Seq`), a fixed assembly order, the same
//! numbers on every run on a machine.
//!
//! Stopping: the paper's relative energy change (`rel_cost_tol`), the
//! gradient norm (`grad_tol`), or `max_iters` iterations; a run that cannot
//! lower the energy in [`MAX_REJECTS`] tries in a row ends at its best point
//! ([`Termination::LineSearchFailed`]). [`crate::lbfgs`]'s watcher and
//! cancel rules apply unchanged.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};

use crate::energy::SegmentTerm;
use crate::lbfgs::{dot, Control, MinimiseError, Objective, RunInfo, Termination};
use crate::refine::VertexObjective;

/// Stopping rules of a Gauss-Newton run of step 2.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GaussNewtonStop {
    /// At most this many iterations (accepted or refused steps; each costs a
    /// numeric factorisation and one evaluation).
    pub max_iters: u64,
    /// Stop when an accepted step changes the energy by at most this share
    /// of it (the paper's L-BFGS rule, `1e8` machine epsilons).
    pub rel_cost_tol: f64,
    /// Stop when the gradient's Euclidean norm is below this.
    pub grad_tol: f64,
}

impl Default for GaussNewtonStop {
    fn default() -> Self {
        Self {
            max_iters: 20,
            rel_cost_tol: 1e8 * f64::EPSILON,
            grad_tol: 1e-8,
        }
    }
}

/// A run gives up after this many refused steps in a row.
pub const MAX_REJECTS: u32 = 12;

/// The lower triangle of the system matrix in compressed columns, and where
/// each contribution goes.
struct Pattern {
    n: usize,
    lambda: f64,
    /// Weight of the bending term inside the smoothness energy (0: none).
    bending: f64,
    col_ptr: Vec<u32>,
    row_idx: Vec<u32>,
    /// Values of `4 lambda (L (x) I_3)` (plus `2 lambda mu (L^T L (x) I_3)`
    /// with the bending term) in the pattern's order.
    laplacian: Vec<f64>,
    /// Position of each value's diagonal entry (per unknown).
    diag: Vec<u32>,
    /// Per term, the positions of its 12 x 12 outer product's lower
    /// triangle (78 entries, row-major over the lower triangle of the
    /// term's 12 unknowns), `u32::MAX` for a coefficient that is zero.
    term_pos: Vec<u32>,
}

/// Flag of a term position whose contribution counts twice (see
/// [`Pattern::new`]); the pattern has fewer than 2^31 entries.
const TWICE: u32 = 1 << 31;

/// The 12 unknowns of a term (4 points' vertices x 3 coordinates) and the
/// coefficient of each vertex in its segment vector `d = q1 - q0`.
fn term_vertices(t: &SegmentTerm) -> [(u32, f64); 4] {
    [
        (t.p1.a, 1.0 - t.p1.t),
        (t.p1.b, t.p1.t),
        (t.p0.a, -(1.0 - t.p0.t)),
        (t.p0.b, -t.p0.t),
    ]
}

/// The graph Laplacian `L = D - A` of the mesh edges, one row per vertex as
/// `(column, value)` pairs (the diagonal first), for the bending term's
/// Hessian `2 L^T L` (`E_b = |L D|^2` per coordinate).
fn laplacian_rows(vertices: usize, edges: &[[u32; 2]]) -> Vec<Vec<(u32, f64)>> {
    let mut rows: Vec<Vec<(u32, f64)>> = (0..vertices).map(|i| vec![(i as u32, 0.0)]).collect();
    for &[a, b] in edges {
        rows[a as usize][0].1 += 1.0;
        rows[b as usize][0].1 += 1.0;
        rows[a as usize].push((b, -1.0));
        rows[b as usize].push((a, -1.0));
    }
    rows
}

impl Pattern {
    fn new(n: usize, edges: &[[u32; 2]], terms: &[SegmentTerm], lambda: f64, bending: f64) -> Self {
        let rows = if bending > 0.0 {
            laplacian_rows(n / 3, edges)
        } else {
            Vec::new()
        };
        // (col, row) with row >= col, as one u64 key each, sorted and
        // deduplicated: the compressed lower triangle.
        let mut keys: Vec<u64> = Vec::with_capacity(n + 3 * edges.len() + 78 * terms.len());
        let key = |r: usize, c: usize| -> u64 {
            let (r, c) = if r >= c { (r, c) } else { (c, r) };
            ((c as u64) << 32) | r as u64
        };
        keys.extend((0..n).map(|i| key(i, i)));
        for &[a, b] in edges {
            for c in 0..3 {
                keys.push(key(3 * a as usize + c, 3 * b as usize + c));
            }
        }
        // L^T L couples every two vertices of one vertex's closed
        // neighbourhood (the two-ring).
        for row in &rows {
            for &(i, _) in row {
                for &(j, _) in row {
                    if i <= j {
                        for c in 0..3 {
                            keys.push(key(3 * i as usize + c, 3 * j as usize + c));
                        }
                    }
                }
            }
        }
        for t in terms {
            let unknowns = term_unknowns(t);
            for (i, &ui) in unknowns.iter().enumerate() {
                for &uj in &unknowns[..=i] {
                    if let (Some(ui), Some(uj)) = (ui, uj) {
                        keys.push(key(ui, uj));
                    }
                }
            }
        }
        keys.sort_unstable();
        keys.dedup();
        let mut col_ptr = vec![0u32; n + 1];
        let mut row_idx = Vec::with_capacity(keys.len());
        for &k in &keys {
            col_ptr[(k >> 32) as usize + 1] += 1;
            row_idx.push(k as u32);
        }
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j];
        }
        let pos = |r: usize, c: usize| -> u32 {
            let (r, c) = if r >= c { (r, c) } else { (c, r) };
            let (s, e) = (col_ptr[c] as usize, col_ptr[c + 1] as usize);
            let k = row_idx[s..e]
                .binary_search(&(r as u32))
                .expect("every contribution is in the pattern");
            (s + k) as u32
        };
        let diag: Vec<u32> = (0..n).map(|i| pos(i, i)).collect();
        let mut laplacian = vec![0.0; row_idx.len()];
        for &[a, b] in edges {
            for c in 0..3 {
                let (ia, ib) = (3 * a as usize + c, 3 * b as usize + c);
                laplacian[diag[ia] as usize] += 4.0 * lambda;
                laplacian[diag[ib] as usize] += 4.0 * lambda;
                laplacian[pos(ia, ib) as usize] -= 4.0 * lambda;
            }
        }
        // lambda mu E_b: Hessian 2 lambda mu L^T L, the sum over vertices k
        // of the outer product of L's row k with itself.
        let s = 2.0 * lambda * bending;
        for row in &rows {
            for &(i, li) in row {
                for &(j, lj) in row {
                    if i <= j {
                        for c in 0..3 {
                            let (ii, ij) = (3 * i as usize + c, 3 * j as usize + c);
                            laplacian[pos(ii, ij) as usize] += s * li * lj;
                        }
                    }
                }
            }
        }
        let mut term_pos = Vec::with_capacity(78 * terms.len());
        for t in terms {
            let unknowns = term_unknowns(t);
            for (i, &ui) in unknowns.iter().enumerate() {
                for (j, &uj) in unknowns[..=i].iter().enumerate() {
                    term_pos.push(match (ui, uj) {
                        // Two of the term's points on one vertex: the
                        // pair (i, j) and (j, i) both land on the diagonal.
                        (Some(ui), Some(uj)) if ui == uj && i != j => pos(ui, uj) | TWICE,
                        (Some(ui), Some(uj)) => pos(ui, uj),
                        _ => u32::MAX,
                    });
                }
            }
        }
        Self {
            n,
            lambda,
            bending,
            col_ptr,
            row_idx,
            laplacian,
            diag,
            term_pos,
        }
    }

    fn symbolic(&self) -> SymbolicSparseColMatRef<'_, u32> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
}

/// The 12 unknowns of a term (`None` where the vertex's coefficient is 0).
fn term_unknowns(t: &SegmentTerm) -> [Option<usize>; 12] {
    let mut u = [None; 12];
    for (k, (v, coef)) in term_vertices(t).into_iter().enumerate() {
        if coef != 0.0 {
            for c in 0..3 {
                u[3 * k + c] = Some(3 * v as usize + c);
            }
        }
    }
    u
}

/// The gradient of a term's residual `r_e = len2 - l_t^2` with respect to
/// its 12 unknowns at `x` (flat, 3V), in the order of [`term_unknowns`].
fn residual_gradient(t: &SegmentTerm, x: &[f64]) -> [f64; 12] {
    let at = |q: &tapeshape_measure::SupportPoint| -> [f64; 3] {
        let (a, b) = (3 * q.a as usize, 3 * q.b as usize);
        let s = 1.0 - q.t;
        [
            s * x[a] + q.t * x[b],
            s * x[a + 1] + q.t * x[b + 1],
            s * x[a + 2] + q.t * x[b + 2],
        ]
    };
    let (q0, q1) = (at(&t.p0), at(&t.p1));
    let d = [q1[0] - q0[0], q1[1] - q0[1], q1[2] - q0[2]];
    // d(len2)/dd = 2 d (or 2 (n . d) n with an axis).
    let h = match t.axis {
        Some(n) => {
            let nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
            [2.0 * nd * n[0], 2.0 * nd * n[1], 2.0 * nd * n[2]]
        }
        None => [2.0 * d[0], 2.0 * d[1], 2.0 * d[2]],
    };
    let mut g = [0.0; 12];
    for (k, (_, coef)) in term_vertices(t).into_iter().enumerate() {
        for c in 0..3 {
            g[3 * k + c] = coef * h[c];
        }
    }
    g
}

/// What one step's Gauss-Newton runs keep between iterations and rounds:
/// the pattern of the last terms, its symbolic analysis (the AMD ordering,
/// the elimination tree), and the last numeric factor.
///
/// Why keep the factor: within a round the terms' supports are held and
/// each step moves the vertices by fractions of a millimetre, and the next
/// round's supports are the same ones re-measured, so the last factor is a
/// near-exact preconditioner. Each step is first solved by conjugate
/// gradients preconditioned with it (a solve costs a few per cent of a
/// factorisation); only if that does not converge in [`PCG_MAX`] iterations
/// is the matrix factorised again. The result is the same step up to the
/// solve's tolerance ([`PCG_TOL`]), and every choice depends on the
/// numbers alone (deterministic).
#[derive(Default)]
pub struct SymbolicCache {
    last: Option<Kept>,
}

struct Kept {
    /// What the pattern was built from: the edge count and the unknowns
    /// each term touches.
    key: (usize, Vec<[u32; 4]>),
    pattern: Pattern,
    symbolic: SymbolicCholesky<u32>,
    l_values: Vec<f64>,
    /// `l_values` holds a factor of a matrix with this pattern.
    factored: bool,
    stack: MemBuffer,
}

/// Conjugate-gradient iterations a step may take before the matrix is
/// factorised again.
pub const PCG_MAX: usize = 6;

/// A conjugate-gradient solve is done when the residual is this share of
/// the right-hand side.
pub const PCG_TOL: f64 = 1e-10;

/// The vertices with a non-zero coefficient in each term, in a fixed order.
fn term_key(terms: &[SegmentTerm]) -> Vec<[u32; 4]> {
    let ends = |q: &tapeshape_measure::SupportPoint| -> [u32; 2] {
        [
            if q.t == 1.0 { q.b } else { q.a },
            if q.t == 0.0 { q.a } else { q.b },
        ]
    };
    terms
        .iter()
        .map(|t| {
            let ([a, b], [c, d]) = (ends(&t.p0), ends(&t.p1));
            [a, b, c, d]
        })
        .collect()
}

impl SymbolicCache {
    /// The kept pattern, analysis and factor for these terms: the last
    /// ones if the terms touch the same unknowns, else new ones.
    fn prepare(
        &mut self,
        n: usize,
        edges: &[[u32; 2]],
        terms: &[SegmentTerm],
        lambda: f64,
        bending: f64,
    ) -> Option<&mut Kept> {
        let key = (edges.len(), term_key(terms));
        let same = self.last.as_ref().is_some_and(|k| {
            k.key == key
                && k.pattern.n == n
                && k.pattern.lambda == lambda
                && k.pattern.bending == bending
        });
        if !same {
            let pattern = Pattern::new(n, edges, terms, lambda, bending);
            let symbolic_same = self.last.as_ref().is_some_and(|k| {
                k.pattern.col_ptr == pattern.col_ptr && k.pattern.row_idx == pattern.row_idx
            });
            if symbolic_same {
                let kept = self.last.as_mut().expect("checked");
                kept.key = key;
                kept.pattern = pattern;
            } else {
                let symbolic = factorize_symbolic_cholesky(
                    pattern.symbolic(),
                    Side::Lower,
                    SymmetricOrdering::Amd,
                    CholeskySymbolicParams::default(),
                )
                .ok()?;
                let req = symbolic
                    .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
                    .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
                self.last = Some(Kept {
                    key,
                    l_values: vec![0.0; symbolic.len_val()],
                    factored: false,
                    stack: MemBuffer::try_new(req).ok()?,
                    pattern,
                    symbolic,
                });
            }
        }
        self.last.as_mut()
    }
}

impl Kept {
    fn factorise(&mut self, values: &[f64]) -> bool {
        let a = SparseColMatRef::new(self.pattern.symbolic(), values);
        self.factored = self
            .symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                a,
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.stack),
                Default::default(),
            )
            .is_ok();
        self.factored
    }

    fn solve(&mut self, rhs: &mut [f64]) {
        let n = rhs.len();
        LltRef::new(&self.symbolic, &self.l_values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            MemStack::new(&mut self.stack),
        );
    }

    /// `out = A v` for the symmetric matrix whose lower triangle `values`
    /// holds in the pattern's order.
    fn times(&self, values: &[f64], v: &[f64], out: &mut [f64]) {
        let p = &self.pattern;
        out.iter_mut().for_each(|o| *o = 0.0);
        for j in 0..p.n {
            let (s, e) = (p.col_ptr[j] as usize, p.col_ptr[j + 1] as usize);
            let vj = v[j];
            let mut acc = 0.0;
            for (&i, &a) in p.row_idx[s..e].iter().zip(&values[s..e]) {
                let i = i as usize;
                if i == j {
                    acc += a * vj;
                } else {
                    out[i] += a * vj;
                    acc += a * v[i];
                }
            }
            out[j] += acc;
        }
    }

    /// Solves `A x = b` (`values` as in [`Kept::times`]) by conjugate
    /// gradients preconditioned with the kept factor, from `x = 0`, into
    /// `x`; false if it did not converge in [`PCG_MAX`] iterations.
    fn pcg(&mut self, values: &[f64], b: &[f64], x: &mut [f64], work: &mut PcgWork) -> bool {
        let PcgWork { r, z, p, q } = work;
        x.iter_mut().for_each(|v| *v = 0.0);
        r.copy_from_slice(b);
        let b_norm = dot(b, b).sqrt();
        if b_norm == 0.0 {
            return true;
        }
        z.copy_from_slice(r);
        self.solve(z);
        p.copy_from_slice(z);
        let mut rz = dot(r, z);
        for _ in 0..PCG_MAX {
            self.times(values, p, q);
            let pq = dot(p, q);
            if pq.is_nan() || pq <= 0.0 {
                return false;
            }
            let alpha = rz / pq;
            for ((xi, ri), (pi, qi)) in x.iter_mut().zip(r.iter_mut()).zip(p.iter().zip(q.iter())) {
                *xi += alpha * pi;
                *ri -= alpha * qi;
            }
            if dot(r, r).sqrt() <= PCG_TOL * b_norm {
                return true;
            }
            z.copy_from_slice(r);
            self.solve(z);
            let rz_new = dot(r, z);
            let beta = rz_new / rz;
            rz = rz_new;
            for (pi, zi) in p.iter_mut().zip(z.iter()) {
                *pi = zi + beta * *pi;
            }
        }
        false
    }
}

/// The conjugate-gradient vectors (3V each), allocated once per run.
struct PcgWork {
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
}

/// Minimises the step-2 objective `obj` from `x0` (flat, 3V, mm) by
/// damped Gauss-Newton (see the module docs), asking `watch(n)` before
/// evaluation `n` as [`crate::lbfgs::minimise_watched`] does; `cache`
/// keeps the pattern, its analysis and the last factor between the runs
/// of one step ([`SymbolicCache`]). Returns the best point and what the
/// run did.
///
/// Stops when an accepted step's decrease, times how far the quadratic
/// model's prediction of it was off (`|1 - actual / predicted|`, the share
/// the next step could still find), is at most `rel_cost_tol` of the
/// energy; when an accepted step changed the energy by at most
/// `rel_cost_tol` of it; at `grad_tol`; or after `max_iters` iterations.
///
/// Errors if the objective is not finite at `x0`, or if the system has no
/// symbolic factorisation (out of memory).
pub fn minimise_vertices(
    obj: &VertexObjective<'_>,
    x0: Vec<f64>,
    stop: &GaussNewtonStop,
    cache: &mut SymbolicCache,
    watch: &dyn Fn(u64) -> Control,
) -> Result<(Vec<f64>, RunInfo), MinimiseError> {
    let n = x0.len();
    let mut g = vec![0.0; n];
    let info = |iterations, evaluations, cost_start, cost_end, reason| RunInfo {
        iterations,
        evaluations,
        cost_start,
        cost_end,
        reason,
    };
    if watch(0) == Control::Cancel {
        return Ok((x0, info(0, 0, f64::NAN, f64::NAN, Termination::Interrupted)));
    }
    let mut evaluations = 1u64;
    let mut f = obj.eval(&x0, &mut g);
    if !f.is_finite() || g.iter().any(|v| !v.is_finite()) {
        return Err(MinimiseError::NonFiniteStart);
    }
    let f0 = f;
    if n == 0 {
        return Ok((x0, info(0, evaluations, f0, f, Termination::NoVariables)));
    }
    let (terms, edges, lambda, bending) = obj.parts();
    let kept = cache
        .prepare(n, edges, terms, lambda, bending)
        .ok_or(MinimiseError::NoFactorisation)?;
    let mut x = x0;
    let mut values = vec![0.0; kept.pattern.row_idx.len()];
    let mut delta = vec![0.0; n];
    let mut rhs = vec![0.0; n];
    let mut x_try = vec![0.0; n];
    let mut g_try = vec![0.0; n];
    let mut work = PcgWork {
        r: vec![0.0; n],
        z: vec![0.0; n],
        p: vec![0.0; n],
        q: vec![0.0; n],
    };
    // Damping: a tiny share of the Laplacian's diagonal scale, so that it
    // only pins the translations until a step is refused.
    let scale = {
        let p = &kept.pattern;
        let s: f64 = p.diag.iter().map(|&d| p.laplacian[d as usize]).sum::<f64>() / n as f64;
        if s > 0.0 {
            s
        } else {
            1.0
        }
    };
    let mu_min = 1e-9 * scale;
    let mut mu = 1e-6 * scale;
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
        assemble(&kept.pattern, terms, lambda, &x, mu, &mut values);
        for (r, gi) in rhs.iter_mut().zip(&g) {
            *r = -gi;
        }
        let solved = kept.factored && kept.pcg(&values, &rhs, &mut delta, &mut work);
        if !solved {
            if !kept.factorise(&values) {
                // Not numerically definite at this damping: damp more.
                rejects += 1;
                if rejects >= MAX_REJECTS {
                    break Termination::LineSearchFailed;
                }
                mu = (mu * 10.0).max(1e-3 * scale);
                continue;
            }
            delta.copy_from_slice(&rhs);
            kept.solve(&mut delta);
        }
        // The quadratic model's decrease: with (H + mu I) delta = -g,
        // -(g . delta + delta^T H delta / 2) = (-g . delta + mu |delta|^2) / 2.
        let predicted = 0.5 * (-dot(&g, &delta) + mu * dot(&delta, &delta));
        for ((t, xi), di) in x_try.iter_mut().zip(&x).zip(&delta) {
            *t = xi + di;
        }
        if watch(evaluations) == Control::Cancel {
            break Termination::Interrupted;
        }
        evaluations += 1;
        let f_try = obj.eval(&x_try, &mut g_try);
        if f_try.is_finite() && f_try < f {
            let decrease = f - f_try;
            std::mem::swap(&mut x, &mut x_try);
            std::mem::swap(&mut g, &mut g_try);
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
            if decrease <= tol || decrease * model_error <= tol {
                break Termination::RelativeChangeBelowTolerance;
            }
        } else {
            rejects += 1;
            if rejects >= MAX_REJECTS {
                break Termination::LineSearchFailed;
            }
            mu = (mu * 8.0).max(1e-3 * scale);
        }
    };
    Ok((x, info(iterations, evaluations, f0, f, reason)))
}

/// Fills `values` (the pattern's order) with `H + mu I` at `x`.
fn assemble(
    pattern: &Pattern,
    terms: &[SegmentTerm],
    lambda: f64,
    x: &[f64],
    mu: f64,
    values: &mut [f64],
) {
    values.copy_from_slice(&pattern.laplacian);
    for &p in &pattern.diag {
        values[p as usize] += mu;
    }
    for (t, pos) in terms.iter().zip(pattern.term_pos.chunks_exact(78)) {
        let gr = residual_gradient(t, x);
        // E = c r^2: the Gauss-Newton Hessian 2 c grad r grad r^T, times
        // (1 - lambda). (The second-order term 2 c r hess r was tried: with
        // it, or with its positive part, the runs took more iterations to
        // the same energy.)
        let s = 2.0 * (1.0 - lambda) * t.weight;
        let mut k = 0;
        for i in 0..12 {
            let si = s * gr[i];
            for &gj in &gr[..=i] {
                let p = pos[k];
                if p != u32::MAX {
                    let v = si * gj;
                    if p & TWICE != 0 {
                        values[(p & !TWICE) as usize] += 2.0 * v;
                    } else {
                        values[p as usize] += v;
                    }
                }
                k += 1;
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
