//! The smoothest deformations of the template: the `k` eigenvectors of the
//! mesh's graph Laplacian with the smallest eigenvalues, for step 2 in a
//! reduced basis ([`crate::reduced`]).
//!
//! Why: step 2's smoothness term `E_s = 2 sum_c D_c^T L D_c` (`L` the
//! combinatorial Laplacian of the template's edges, `D_c` one coordinate of
//! the displacement from the step-1 shape) depends on the topology alone.
//! In the basis `B` (V x k) of its smallest eigenvectors, `B^T B = I` and
//! `B^T L B = diag(sigma)`, so a displacement `D = B C` (C: k x 3) costs
//! `E_s = 2 sum_i sigma_i |C_i|^2`, a diagonal quadratic, and step 2 becomes
//! a problem in 3k unknowns instead of 3V. The basis is computed once per
//! topology (a few seconds) and kept for the process ([`SmoothBasis::shared`]).
//!
//! How: block Krylov iteration with the shift-inverted operator
//! `(L + s I)^-1` (faer's sparse Cholesky of `L + s I`, AMD ordering), whose
//! largest eigenvalues are `L`'s smallest, fully re-orthogonalised (two
//! passes of block Gram-Schmidt); then Rayleigh-Ritz with `L` itself on the
//! Krylov space: `Q^T L Q = W Theta W^T`, `B = Q W_k`. The Rayleigh-Ritz
//! step makes `B` orthonormal and `B^T L B` diagonal to rounding whatever
//! the Krylov space's convergence, so the reduced energy is exactly the full
//! one restricted to the span of `B`; the Krylov space (about twice `k`
//! dimensions) only decides how close the span is to the true smoothest
//! modes (their Ritz values are checked against a dense eigen-decomposition
//! in the tests). Written here: faer, already a dependency, has a sparse
//! Cholesky and a dense eigen-decomposition but no sparse eigen-solver,
//! and these are about 100 lines on top of the two.
//!
//! Deterministic: a fixed pseudo-random start block, one thread, the same
//! numbers on every run on a machine.

use std::sync::{Arc, Condvar, Mutex, MutexGuard};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::matmul::matmul;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Conj, Mat, MatMut, MatRef, Par, Side};

/// Why a smooth basis could not be computed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BasisError {
    /// The mesh has no vertices, or an edge names a vertex it does not have.
    #[error("invalid mesh for a smooth basis: {0}")]
    InvalidMesh(String),
    /// `k` is 0 or more than the vertices.
    #[error("a smooth basis needs between 1 and {max} modes, got {k}")]
    Modes {
        /// What was asked.
        k: usize,
        /// The vertex count.
        max: usize,
    },
    /// The factorisation or the dense eigen-decomposition failed.
    #[error("numerical failure computing the smooth basis: {0}")]
    Numerical(String),
}

/// The `k` smoothest modes of a mesh (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothBasis {
    n_vertices: usize,
    k: usize,
    /// V x k, row-major: row `v` is vertex `v`'s coefficients (unitless;
    /// the columns are orthonormal).
    rows: Vec<f64>,
    /// `rows` rounded to f32, for the vertex map of every step-2 round
    /// ([`crate::reduced::ReducedObjective::vertices`]): half the bytes of
    /// a pass that is bound by memory (issue 13).
    rows_f32: Vec<f32>,
    /// `sigma_i = b_i^T L b_i`, ascending (per unit coefficient squared).
    values: Vec<f64>,
    /// [`edges_key`] of the mesh it was computed for.
    key: u64,
}

/// A fingerprint of a mesh's vertex count and edges (FNV-1a, 64 bits): which
/// topology a basis belongs to.
///
/// Remembered for the last few meshes of the process (a copy of their
/// edges, compared in full): the hash is a serial pass over every byte,
/// about 0.4 ms for the template, and each prediction asks for it twice.
pub fn edges_key(n_vertices: usize, edges: &[[u32; 2]]) -> u64 {
    type Seen = Vec<(usize, Vec<[u32; 2]>, u64)>;
    static SEEN: Mutex<Seen> = Mutex::new(Vec::new());
    const REMEMBERED: usize = 4;
    {
        let seen = SEEN.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(&(_, _, key)) = seen
            .iter()
            .find(|(n, e, _)| *n == n_vertices && e[..] == edges[..])
        {
            return key;
        }
    }
    let key = fnv_edges(n_vertices, edges);
    let mut seen = SEEN.lock().unwrap_or_else(|e| e.into_inner());
    if seen.len() == REMEMBERED {
        seen.remove(0);
    }
    seen.push((n_vertices, edges.to_vec(), key));
    key
}

/// [`edges_key`]'s hash itself.
fn fnv_edges(n_vertices: usize, edges: &[[u32; 2]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |v: u64| {
        for b in v.to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(n_vertices as u64);
    for &[a, b] in edges {
        eat((u64::from(a) << 32) | u64::from(b));
    }
    h
}

/// `rows` rounded to f32 (the f32 copy of a basis).
fn narrow(rows: &[f64]) -> Vec<f32> {
    rows.iter().map(|&v| v as f32).collect()
}

/// Extra Krylov dimensions beyond `k` (and at least `k` more): the span of
/// the `k` Ritz vectors is then close to the smoothest `k` modes.
const KRYLOV_EXTRA: usize = 48;
/// Columns per Krylov block (one sparse solve with this many right-hand sides).
const BLOCK: usize = 8;

/// The bases of this process (few: one per topology and `k`), and those
/// another thread is preparing ([`SmoothBasis::preparing`]).
struct Shared {
    ready: Vec<Arc<SmoothBasis>>,
    /// `(n_vertices, key, k)` of bases being prepared.
    pending: Vec<(usize, u64, usize)>,
}

static SHARED: Mutex<Shared> = Mutex::new(Shared {
    ready: Vec::new(),
    pending: Vec::new(),
});
/// Signalled when a pending basis is shared or given up.
static SHARED_CHANGED: Condvar = Condvar::new();

fn shared_state() -> MutexGuard<'static, Shared> {
    SHARED.lock().unwrap_or_else(|e| e.into_inner())
}

impl Shared {
    fn find(&self, n_vertices: usize, key: u64, k: usize) -> Option<Arc<SmoothBasis>> {
        self.ready
            .iter()
            .find(|b| b.key == key && b.k == k && b.n_vertices == n_vertices)
            .cloned()
    }
}

/// A promise that this thread (or one it hands this to) prepares a basis
/// and shares it ([`SmoothBasis::share`]); see [`SmoothBasis::preparing`].
/// Dropped, it is given up: waiting threads go on and compute it.
#[derive(Debug)]
pub struct Preparing {
    id: (usize, u64, usize),
}

impl Drop for Preparing {
    fn drop(&mut self) {
        shared_state().pending.retain(|&p| p != self.id);
        SHARED_CHANGED.notify_all();
    }
}

impl SmoothBasis {
    /// The basis of `k` modes for the mesh with `n_vertices` vertices and
    /// undirected `edges` (each once), computed on first use and then kept
    /// for the process (a prediction reuses it); while another thread
    /// prepares it ([`SmoothBasis::preparing`]), waits for that. Errors as
    /// [`SmoothBasis::compute`].
    pub fn shared(
        n_vertices: usize,
        edges: &[[u32; 2]],
        k: usize,
    ) -> Result<Arc<Self>, BasisError> {
        let key = edges_key(n_vertices, edges);
        let id = (n_vertices, key, k);
        {
            let mut state = shared_state();
            loop {
                if let Some(b) = state.find(n_vertices, key, k) {
                    return Ok(b);
                }
                if !state.pending.contains(&id) {
                    break;
                }
                state = SHARED_CHANGED
                    .wait(state)
                    .unwrap_or_else(|e| e.into_inner());
            }
        }
        // Computed outside the lock: another thread may compute the same
        // basis meanwhile (the same numbers); the first one stored wins.
        let basis = Arc::new(Self::compute(n_vertices, edges, k)?);
        let mut state = shared_state();
        if let Some(b) = state.find(n_vertices, key, k) {
            return Ok(b);
        }
        state.ready.push(basis.clone());
        Ok(basis)
    }

    /// The basis of `k` modes for the mesh with fingerprint `key`
    /// ([`edges_key`]) and `n_vertices` vertices, if this process has it.
    pub fn find_shared(n_vertices: usize, key: u64, k: usize) -> Option<Arc<Self>> {
        shared_state().find(n_vertices, key, k)
    }

    /// Claims the preparation of the basis of `k` modes for the mesh with
    /// fingerprint `key` and `n_vertices` vertices (reading it from a file,
    /// say, on another thread): until the returned [`Preparing`] is dropped,
    /// [`SmoothBasis::shared`] waits for it instead of computing it. `None`
    /// if the process has the basis already or another claim is open.
    pub fn preparing(n_vertices: usize, key: u64, k: usize) -> Option<Preparing> {
        let id = (n_vertices, key, k);
        let mut state = shared_state();
        if state.find(n_vertices, key, k).is_some() || state.pending.contains(&id) {
            return None;
        }
        state.pending.push(id);
        Some(Preparing { id })
    }

    /// Keeps `basis` for the process (e.g. one read from a cache file), so
    /// that [`SmoothBasis::shared`] returns it.
    pub fn share(basis: Self) -> Arc<Self> {
        let b = {
            let mut state = shared_state();
            if let Some(b) = state.find(basis.n_vertices, basis.key, basis.k) {
                return b;
            }
            let b = Arc::new(basis);
            state.ready.push(b.clone());
            b
        };
        SHARED_CHANGED.notify_all();
        b
    }

    /// Computes the `k` smoothest modes of the mesh with `n_vertices`
    /// vertices and undirected `edges` (see the module docs).
    ///
    /// Errors if the mesh is empty or an edge is out of range, if `k` is 0
    /// or above the vertex count, or if a factorisation fails.
    pub fn compute(n_vertices: usize, edges: &[[u32; 2]], k: usize) -> Result<Self, BasisError> {
        let n = n_vertices;
        if n == 0 {
            return Err(BasisError::InvalidMesh("no vertices".into()));
        }
        if k == 0 || k > n {
            return Err(BasisError::Modes { k, max: n });
        }
        if let Some(e) = edges
            .iter()
            .find(|e| e[0] as usize >= n || e[1] as usize >= n || e[0] == e[1])
        {
            return Err(BasisError::InvalidMesh(format!(
                "edge {e:?} with {n} vertices"
            )));
        }
        let lap = Laplacian::new(n, edges);
        let m = (k + KRYLOV_EXTRA.max(k)).min(n);
        let q = krylov(&lap, m)?;
        // Rayleigh-Ritz with L on span(Q).
        let mut lq = vec![0.0; n * m];
        for (qj, lqj) in q.chunks_exact(n).zip(lq.chunks_exact_mut(n)) {
            lap.times(qj, lqj);
        }
        let qm = MatRef::from_column_major_slice(&q, n, m);
        let lqm = MatRef::from_column_major_slice(&lq, n, m);
        let mut t = Mat::<f64>::zeros(m, m);
        matmul(&mut t, Accum::Replace, qm.transpose(), lqm, 1.0, Par::Seq);
        let ts = Mat::<f64>::from_fn(m, m, |i, j| 0.5 * (t[(i, j)] + t[(j, i)]));
        let evd = ts.self_adjoint_eigen(Side::Lower).map_err(|e| {
            BasisError::Numerical(format!("Rayleigh-Ritz eigen-decomposition: {e:?}"))
        })?;
        let w = evd.U();
        let mut b = Mat::<f64>::zeros(n, k);
        matmul(&mut b, Accum::Replace, qm, w.subcols(0, k), 1.0, Par::Seq);
        let values: Vec<f64> = (0..k)
            .map(|i| evd.S().column_vector()[i].max(0.0))
            .collect();
        let mut rows = vec![0.0; n * k];
        for j in 0..k {
            for i in 0..n {
                rows[i * k + j] = b[(i, j)];
            }
        }
        Ok(Self {
            n_vertices: n,
            k,
            rows_f32: narrow(&rows),
            rows,
            values,
            key: edges_key(n, edges),
        })
    }

    /// The vertex count V.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// The number of modes k.
    pub fn k(&self) -> usize {
        self.k
    }

    /// Row `v` (k coefficients) of the V x k basis.
    #[inline]
    pub fn row(&self, v: usize) -> &[f64] {
        &self.rows[v * self.k..(v + 1) * self.k]
    }

    /// The V x k basis, row-major.
    pub fn rows(&self) -> &[f64] {
        &self.rows
    }

    /// The Laplacian's value of each mode, `sigma_i = b_i^T L b_i`, ascending.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Which mesh it belongs to ([`edges_key`]).
    pub fn key(&self) -> u64 {
        self.key
    }

    /// The V x k basis rounded to f32, row-major (each entry the nearest
    /// f32 to the same entry of [`SmoothBasis::rows`]).
    pub fn rows_f32(&self) -> &[f32] {
        &self.rows_f32
    }

    /// Bytes in memory (the basis, its f32 copy and its values).
    pub fn size_bytes(&self) -> usize {
        8 * (self.rows.len() + self.values.len()) + 4 * self.rows_f32.len()
    }

    /// `out = B c` for one coordinate: `c` has k entries, `out` V.
    pub fn apply(&self, c: &[f64], out: &mut [f64]) {
        for (o, row) in out.iter_mut().zip(self.rows.chunks_exact(self.k)) {
            *o = row.iter().zip(c).map(|(a, b)| a * b).sum();
        }
    }

    /// Rebuilds a basis from its parts (e.g. a cache file); checks the
    /// shapes and that every value is finite.
    pub fn from_parts(
        n_vertices: usize,
        k: usize,
        rows: Vec<f64>,
        values: Vec<f64>,
        key: u64,
    ) -> Result<Self, BasisError> {
        if k == 0 || k > n_vertices {
            return Err(BasisError::Modes { k, max: n_vertices });
        }
        if rows.len() != n_vertices * k || values.len() != k {
            return Err(BasisError::InvalidMesh(format!(
                "a basis of {n_vertices} x {k} needs {} coefficients and {k} values, got {} and {}",
                n_vertices * k,
                rows.len(),
                values.len()
            )));
        }
        if rows.iter().chain(&values).any(|v| !v.is_finite()) {
            return Err(BasisError::Numerical("non-finite coefficient".into()));
        }
        Ok(Self {
            n_vertices,
            k,
            rows_f32: narrow(&rows),
            rows,
            values,
            key,
        })
    }
}

/// The combinatorial Laplacian of a mesh's edges: `(L u)_a = deg(a) u_a -
/// sum_{b in N(a)} u_b`, so that `u^T L u = sum_edges (u_a - u_b)^2`.
struct Laplacian<'a> {
    n: usize,
    edges: &'a [[u32; 2]],
    degree: Vec<f64>,
}

impl<'a> Laplacian<'a> {
    fn new(n: usize, edges: &'a [[u32; 2]]) -> Self {
        let mut degree = vec![0.0; n];
        for &[a, b] in edges {
            degree[a as usize] += 1.0;
            degree[b as usize] += 1.0;
        }
        Self { n, edges, degree }
    }

    fn times(&self, u: &[f64], out: &mut [f64]) {
        for ((o, &d), &ui) in out.iter_mut().zip(&self.degree).zip(u) {
            *o = d * ui;
        }
        for &[a, b] in self.edges {
            let (a, b) = (a as usize, b as usize);
            out[a] -= u[b];
            out[b] -= u[a];
        }
    }

    /// The lower triangle of `L + shift I` in compressed columns.
    fn lower(&self, shift: f64) -> (Vec<u32>, Vec<u32>, Vec<f64>) {
        let mut below: Vec<Vec<u32>> = vec![Vec::new(); self.n];
        for &[a, b] in self.edges {
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            below[lo as usize].push(hi);
        }
        let mut col_ptr = Vec::with_capacity(self.n + 1);
        let mut row_idx = Vec::new();
        let mut vals = Vec::new();
        col_ptr.push(0u32);
        for (j, rows) in below.iter_mut().enumerate() {
            rows.sort_unstable();
            rows.dedup();
            row_idx.push(j as u32);
            vals.push(self.degree[j] + shift);
            for &r in rows.iter() {
                row_idx.push(r);
                vals.push(-1.0);
            }
            col_ptr.push(row_idx.len() as u32);
        }
        (col_ptr, row_idx, vals)
    }
}

/// An orthonormal basis (n x m, column-major) of the block Krylov space of
/// `(L + s I)^-1` from a fixed pseudo-random block.
fn krylov(lap: &Laplacian<'_>, m: usize) -> Result<Vec<f64>, BasisError> {
    let n = lap.n;
    // A small shift keeps L + s I definite (L's constants have eigenvalue
    // 0) and barely changes the operator's ordering of the smooth modes.
    let mean_degree = lap.degree.iter().sum::<f64>() / n as f64;
    let shift = 1e-6 * mean_degree.max(1.0);
    let (col_ptr, row_idx, vals) = lap.lower(shift);
    let sym = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
    let symbolic = factorize_symbolic_cholesky(
        sym,
        Side::Lower,
        SymmetricOrdering::Amd,
        CholeskySymbolicParams::default(),
    )
    .map_err(|e| BasisError::Numerical(format!("symbolic factorisation: {e:?}")))?;
    let p = BLOCK.min(m);
    let req = symbolic
        .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
        .or(symbolic.solve_in_place_scratch::<f64>(p, Par::Seq));
    let mut stack = MemBuffer::try_new(req)
        .map_err(|_| BasisError::Numerical("out of memory for the factorisation".into()))?;
    let mut l_values = vec![0.0; symbolic.len_val()];
    symbolic
        .factorize_numeric_llt::<f64>(
            &mut l_values,
            SparseColMatRef::new(sym, &vals),
            Side::Lower,
            Default::default(),
            Par::Seq,
            MemStack::new(&mut stack),
            Default::default(),
        )
        .map_err(|e| BasisError::Numerical(format!("factorising L + s I: {e:?}")))?;
    let llt = LltRef::new(&symbolic, &l_values);

    let mut seed = 0x5eed_b10c_u64;
    let mut random = |x: &mut [f64]| {
        for v in x {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            *v = ((seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5;
        }
    };
    let mut q = vec![0.0; n * m];
    let mut block = vec![0.0; n * p];
    random(&mut block);
    let mut width = p;
    let mut filled = 0;
    let mut stalls = 0;
    while filled < m {
        // Against Q[:, ..filled]: two passes of block classical Gram-Schmidt.
        for _ in 0..2 {
            if filled > 0 {
                let qf = MatRef::from_column_major_slice(&q[..n * filled], n, filled);
                let mut h = Mat::<f64>::zeros(filled, width);
                let b = MatRef::from_column_major_slice(&block[..n * width], n, width);
                matmul(&mut h, Accum::Replace, qf.transpose(), b, 1.0, Par::Seq);
                let b = MatMut::from_column_major_slice_mut(&mut block[..n * width], n, width);
                matmul(b, Accum::Add, qf, &h, -1.0, Par::Seq);
            }
        }
        // Within the block: modified Gram-Schmidt (twice); a column that
        // vanishes (the space stopped growing there) is dropped.
        let start = filled;
        for j in 0..width {
            if filled >= m {
                break;
            }
            let col = &mut block[j * n..(j + 1) * n];
            let before = norm(col);
            for _ in 0..2 {
                for i in start..filled {
                    let qi = &q[i * n..(i + 1) * n];
                    let d = dot(qi, col);
                    col.iter_mut().zip(qi).for_each(|(c, q)| *c -= d * q);
                }
            }
            let after = norm(col);
            if after > 1e-8 * before && after.is_finite() && after > 0.0 {
                let s = 1.0 / after;
                q[filled * n..(filled + 1) * n]
                    .iter_mut()
                    .zip(col.iter())
                    .for_each(|(q, c)| *q = c * s);
                filled += 1;
            }
        }
        if filled >= m {
            break;
        }
        if filled == start {
            stalls += 1;
            if stalls > 4 {
                return Err(BasisError::Numerical(
                    "the Krylov space stopped growing".into(),
                ));
            }
            width = p;
            block.resize(n * width, 0.0);
            random(&mut block);
            continue;
        }
        // The next block: (L + s I)^-1 applied to the columns just added.
        width = filled - start;
        block.clear();
        block.extend_from_slice(&q[start * n..filled * n]);
        let rhs = MatMut::from_column_major_slice_mut(&mut block, n, width);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut stack));
    }
    Ok(q)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests;
