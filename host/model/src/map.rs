//! Step 1 as a Gauss-Newton MAP estimate over the normalised weights.
//!
//! With the supports of one round held fixed (their points are fixed
//! barycentric combinations of vertices, and the vertices are affine in the
//! weights), every segment vector is affine in the weights,
//! `d_e(w) = C_e w + c_e` (C_e: 3 x K, mm per unit weight), and a
//! measurement's value is the sum of its segments' lengths,
//! `m_j(w) = sum_{e in j} |d_e(w)|` (or `|n . d_e(w)|` with a projection
//! axis `n`). The objective is the negative log-posterior of the readings
//! under Gaussian reading noise `sd_j` (mm) and the training Gaussian of the
//! normalised weights (identity covariance):
//!
//! `F(w) = sum_j ((m_j(w) - T_j) / sd_j)^2 + |w|^2`.
//!
//! Gauss-Newton linearises `m` at `w`, `m(w') ~ m(w) + J (w' - w)` (J: M x K,
//! exact from the segment directions), and solves the linear-Gaussian MAP in
//! closed form through the M x M system (M readings, far fewer than K
//! weights, Woodbury): `w' = J^T (J J^T + S)^{-1} (T - m(w) + J w)`,
//! `S = diag(sd^2)`. Held weights are taken out of `J` and keep their
//! values. A backtracking step keeps `F` decreasing.
//!
//! Why not L-BFGS on the same objective: the readings make the problem
//! stiff in the (at most M) directions they inform and leave it isotropic in
//! the K - M others; L-BFGS scales its steps to the stiff directions and
//! barely moves in the soft ones within its iteration cap, so the prior's
//! shrinkage of the weights the readings do not inform is mostly lost
//! (measured: `docs/results/predict-sreal.md`). Gauss-Newton solves both
//! parts exactly in a few iterations. Hand-written because no crate offers a
//! Gauss-Newton for this under-determined, prior-regularised form with a
//! Woodbury solve; the linear algebra is nalgebra's.

use nalgebra::{DMatrix, DVector};

use crate::energy::SegmentTerm;
use crate::lbfgs::dot;
use crate::refine::segment_rows;

/// The step-1 MAP problem of one round (see the module docs).
pub struct MapProblem {
    k: usize,
    /// Per segment, 3 rows of K entries (`C_e`, row-major, mm per unit weight).
    rows: Vec<f64>,
    /// Per segment, `c_e` (mm).
    base: Vec<f64>,
    /// Per segment, the projection axis.
    axis: Vec<Option<[f64; 3]>>,
    /// Per segment, the reading it belongs to (index into `targets`).
    owner: Vec<usize>,
    /// Per reading, the target `T_j` (mm).
    targets: Vec<f64>,
    /// Per reading, the noise standard deviation `sd_j` (mm, > 0).
    sd: Vec<f64>,
}

/// How a [`MapProblem::solve`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapRun {
    /// Gauss-Newton iterations taken.
    pub iterations: usize,
    /// `F` at the start and at the end.
    pub objective: (f64, f64),
}

impl MapProblem {
    /// Builds the problem from `terms` whose points index local vertices
    /// with scaled basis rows `vertex_rows` ((3 n_local) x K row-major, mm per
    /// unit weight) and mean positions `vertex_base` (flat, 3 n_local, mm).
    /// `owner[e]` is the reading of term `e`, `targets` and `sd` are per
    /// reading (mm).
    pub fn new(
        k: usize,
        vertex_rows: &[f64],
        vertex_base: &[f64],
        terms: &[SegmentTerm],
        owner: Vec<usize>,
        targets: Vec<f64>,
        sd: Vec<f64>,
    ) -> Self {
        assert_eq!(terms.len(), owner.len());
        assert_eq!(targets.len(), sd.len());
        let (rows, base) = segment_rows(k, vertex_rows, vertex_base, terms);
        Self {
            k,
            rows,
            base,
            axis: terms.iter().map(|t| t.axis).collect(),
            owner,
            targets,
            sd,
        }
    }

    /// Number of readings M.
    pub fn n_readings(&self) -> usize {
        self.targets.len()
    }

    /// The readings' values `m(w)` (M, mm) and, if `jacobian`, `dm/dw`
    /// (M x K, mm per unit weight).
    pub fn values(&self, w: &[f64], jacobian: bool) -> (Vec<f64>, Option<DMatrix<f64>>) {
        let (vals, dirs) = self.values_dirs(w);
        (vals, jacobian.then(|| self.jacobian(&dirs)))
    }

    /// The readings' values `m(w)` (M, mm) and, per segment, the unit
    /// direction of its length's gradient with respect to its segment
    /// vector (zero for a segment of length zero): what [`MapProblem::jacobian`]
    /// needs, so that a solve sums each segment's dot products once per
    /// weights.
    fn values_dirs(&self, w: &[f64]) -> (Vec<f64>, Vec<[f64; 3]>) {
        crate::kernels::clear_upper_registers();
        let k = self.k;
        let mut vals = vec![0.0; self.targets.len()];
        let mut dirs = Vec::with_capacity(self.owner.len());
        for (e, (&j, axis)) in self.owner.iter().zip(&self.axis).enumerate() {
            let r3 = &self.rows[3 * e * k..3 * (e + 1) * k];
            let dots = crate::kernels::dots3(r3, w);
            let d: [f64; 3] = std::array::from_fn(|c| self.base[3 * e + c] + dots[c]);
            // Length and its direction (d length / d d).
            let (len, u) = match axis {
                Some(n) => {
                    let nd = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                    let s = if nd >= 0.0 { 1.0 } else { -1.0 };
                    (nd.abs(), [s * n[0], s * n[1], s * n[2]])
                }
                None => {
                    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    if l > 0.0 {
                        (l, [d[0] / l, d[1] / l, d[2] / l])
                    } else {
                        (0.0, [0.0; 3])
                    }
                }
            };
            vals[j] += len;
            dirs.push(u);
        }
        (vals, dirs)
    }

    /// `dm/dw` (M x K, mm per unit weight) from the segments' directions of
    /// [`MapProblem::values_dirs`] at the same weights.
    fn jacobian(&self, dirs: &[[f64; 3]]) -> DMatrix<f64> {
        crate::kernels::clear_upper_registers();
        let k = self.k;
        let m = self.targets.len();
        // Row-major while it is summed (each segment adds to contiguous
        // runs of its reading's row; the same additions in the same order
        // as into the matrix itself).
        let mut jac = vec![0.0; m * k];
        for (e, (&j, u)) in self.owner.iter().zip(dirs).enumerate() {
            let r3 = &self.rows[3 * e * k..3 * (e + 1) * k];
            let row = &mut jac[j * k..(j + 1) * k];
            for c in 0..3 {
                if u[c] != 0.0 {
                    for (o, a) in row.iter_mut().zip(&r3[c * k..(c + 1) * k]) {
                        *o += u[c] * a;
                    }
                }
            }
        }
        DMatrix::from_row_slice(m, k, &jac)
    }

    /// `F(w)` (see the module docs), dimensionless.
    pub fn objective(&self, w: &[f64]) -> f64 {
        self.objective_at(&self.values_dirs(w).0, w)
    }

    /// `F` from the readings' values `vals` at `w`.
    fn objective_at(&self, vals: &[f64], w: &[f64]) -> f64 {
        let data: f64 = vals
            .iter()
            .zip(&self.targets)
            .zip(&self.sd)
            .map(|((v, t), s)| ((v - t) / s).powi(2))
            .sum();
        data + dot(w, w)
    }

    /// Minimises `F` from `w` (K normalised weights), moving only the
    /// weights with `held[i] == false` (`held` empty: all move), for at most
    /// `max_iters` Gauss-Newton iterations or until an iteration lowers `F`
    /// by less than `rel_tol` of its value. Returns the weights and how the
    /// run ended; `w` itself if the M x M system cannot be solved.
    pub fn solve(
        &self,
        w: &[f64],
        held: &[bool],
        max_iters: usize,
        rel_tol: f64,
    ) -> (Vec<f64>, MapRun) {
        let free: Vec<usize> = (0..self.k)
            .filter(|&i| held.get(i).is_none_or(|h| !h))
            .collect();
        let mut w = w.to_vec();
        // The values and directions at the current weights: from the start,
        // then from the accepted trial (each evaluated once).
        let (mut vals, mut dirs) = self.values_dirs(&w);
        let f0 = self.objective_at(&vals, &w);
        let mut f = f0;
        let mut iterations = 0;
        let m = self.n_readings();
        if m == 0 || free.is_empty() || !f.is_finite() {
            return (
                w,
                MapRun {
                    iterations,
                    objective: (f0, f),
                },
            );
        }
        while iterations < max_iters {
            iterations += 1;
            let jac = self.jacobian(&dirs);
            let jf = jac.select_columns(&free);
            let wf = DVector::from_iterator(free.len(), free.iter().map(|&i| w[i]));
            let rhs =
                DVector::from_iterator(m, (0..m).map(|j| self.targets[j] - vals[j])) + &jf * &wf;
            let mut a = &jf * jf.transpose();
            for j in 0..m {
                a[(j, j)] += self.sd[j] * self.sd[j];
            }
            let Some(chol) = a.cholesky() else {
                break;
            };
            let target = jf.transpose() * chol.solve(&rhs);
            // Backtracking along the Gauss-Newton step.
            let mut alpha = 1.0;
            let mut accepted = None;
            for _ in 0..20 {
                let mut trial = w.clone();
                for (p, &i) in free.iter().enumerate() {
                    trial[i] = w[i] + alpha * (target[p] - w[i]);
                }
                let (tv, td) = self.values_dirs(&trial);
                let ft = self.objective_at(&tv, &trial);
                if ft.is_finite() && ft < f {
                    accepted = Some((trial, ft, tv, td));
                    break;
                }
                alpha *= 0.5;
            }
            let Some((trial, ft, tv, td)) = accepted else {
                break;
            };
            let gain = f - ft;
            w = trial;
            f = ft;
            vals = tv;
            dirs = td;
            if gain <= rel_tol * f.max(f64::MIN_POSITIVE) {
                break;
            }
        }
        (
            w,
            MapRun {
                iterations,
                objective: (f0, f),
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tapeshape_measure::SupportPoint;

    /// Two local vertices, K = 2: vertex 0 fixed at the origin, vertex 1 at
    /// (100 + 10 w0, 5 w1, 0) mm; one Euclidean reading of their distance.
    fn problem(target: f64, sd: f64) -> MapProblem {
        let rows = vec![
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, // vertex 0
            10.0, 0.0, 0.0, 5.0, 0.0, 0.0, // vertex 1
        ];
        let base = vec![0.0, 0.0, 0.0, 100.0, 0.0, 0.0];
        let term = SegmentTerm {
            p0: SupportPoint::vertex(0),
            p1: SupportPoint::vertex(1),
            axis: None,
            target_sq: target * target,
            weight: 1.0,
        };
        MapProblem::new(2, &rows, &base, &[term], vec![0], vec![target], vec![sd])
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let p = problem(120.0, 1.0);
        let w = [0.7, -1.3];
        let (_, j) = p.values(&w, true);
        let j = j.unwrap();
        for i in 0..2 {
            let h = 1e-6;
            let mut a = w;
            let mut b = w;
            a[i] += h;
            b[i] -= h;
            let fd = (p.values(&a, false).0[0] - p.values(&b, false).0[0]) / (2.0 * h);
            assert!((fd - j[(0, i)]).abs() < 1e-6, "{fd} vs {}", j[(0, i)]);
        }
    }

    #[test]
    fn linear_case_is_the_closed_form_map() {
        // Near w = 0 the length is ~ 100 + 10 w0 (w1 enters at second order):
        // the MAP of (100 + 10 w0 - 120)^2 / sd^2 + w0^2 is
        // w0 = 10 * 20 / (100 + sd^2), and w1 = 0.
        let sd = 2.0;
        let p = problem(120.0, sd);
        let (w, run) = p.solve(&[0.0, 0.0], &[], 50, 1e-14);
        let want = 200.0 / (100.0 + sd * sd);
        assert!((w[0] - want).abs() < 1e-9, "{} vs {want}", w[0]);
        assert!(w[1].abs() < 1e-12);
        assert!(run.objective.1 < run.objective.0);
    }

    #[test]
    fn the_prior_takes_the_smallest_weights_that_fit() {
        // A tiny sd fits the reading; of all weights that do, the MAP keeps
        // the norm smallest: w1 stays 0 although (w0, w1) on a circle fit too.
        let p = problem(130.0, 1e-3);
        let (w, _) = p.solve(&[0.5, 2.0], &[], 50, 1e-15);
        let (v, _) = p.values(&w, false);
        assert!((v[0] - 130.0).abs() < 1e-3, "{}", v[0]);
        assert!(w[1].abs() < 1e-6, "{}", w[1]);
    }

    #[test]
    fn held_weights_do_not_move() {
        let p = problem(130.0, 1e-3);
        let (w, _) = p.solve(&[0.5, 2.0], &[true, false], 50, 1e-15);
        assert_eq!(w[0], 0.5);
        // Then only w1 can fit: 105^2 + (5 w1)^2 = 130^2.
        let want = (130.0f64.powi(2) - 105.0f64.powi(2)).sqrt() / 5.0;
        assert!((w[1].abs() - want).abs() < 1e-3, "{} vs {want}", w[1]);
    }
}
