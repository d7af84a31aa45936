//! Feature analysis and the joint Gaussian of (measurements, weights).
//!
//! *Feature analysis* (the paper's `W_new = B P_new`) is the least-squares
//! linear map, with intercept, from the M measurements (metres) to the K
//! normalised PCA weights. It is solved through the SVD of the standardised
//! design matrix (each measurement centred and divided by its training SD),
//! truncating singular values below `1e-10` times the largest: when M + 1 > N
//! or measurements are collinear this gives the minimum-norm least-squares
//! solution instead of a blow-up (the regularisation is therefore a truncated
//! SVD, not a ridge).
//!
//! The *joint Gaussian* of `z = (P, w)` (mean and covariance over the training
//! set, normalised by N - 1) generalises feature analysis to any subset of
//! observed measurements: the start is the conditional mean
//! `w | P_o = mu_w + S_wo (S_oo + R)^-1 (P_o - mu_o)`, where `R` is the diagonal
//! of the squared per-measurement tolerances (tape noise; zero for exact
//! readings). With every measurement observed and `R = 0` this equals the
//! least-squares map exactly (both are `Cov(w, P) Cov(P, P)^-1`).

use nalgebra::{DMatrix, DVector};

use crate::{ModelError, Result};

/// Relative cutoff of singular values in the feature-analysis solve.
pub const FA_RCOND: f64 = 1e-10;

/// Ridge added to `S_oo` (relative to its mean diagonal) when it is not
/// positive definite (fewer bodies than measurements, or constant readings).
pub const CONDITIONAL_RIDGE: f64 = 1e-9;

/// The learned linear map `w = B [P; 1]`.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct FeatureMap {
    /// K rows of M + 1 entries (row-major): `w_k = sum_j B[k][j] P_j + B[k][M]`,
    /// P in metres, w normalised (unitless).
    pub b: Vec<f64>,
    /// Number of measurements M.
    pub n_measurements: usize,
    /// Number of weights K.
    pub n_weights: usize,
    /// Numerical rank of the standardised design matrix used in the solve.
    pub rank: usize,
}

impl FeatureMap {
    /// Fits the map by least squares on `p` (N x M, metres) and `w` (N x K).
    pub fn fit(p: &DMatrix<f64>, w: &DMatrix<f64>) -> Result<Self> {
        let (n, m) = p.shape();
        let k = w.ncols();
        if w.nrows() != n {
            return Err(ModelError::InvalidTraining(format!(
                "{n} measurement rows but {} weight rows",
                w.nrows()
            )));
        }
        if n < 2 {
            return Err(ModelError::InvalidTraining(
                "feature analysis needs at least 2 bodies".into(),
            ));
        }
        let p_mean: DVector<f64> = p.row_mean().transpose();
        let w_mean: DVector<f64> = w.row_mean().transpose();
        let mut scale = DVector::<f64>::zeros(m);
        let mut z = p.clone();
        for j in 0..m {
            let mut col = z.column_mut(j);
            col.add_scalar_mut(-p_mean[j]);
            let sd = (col.norm_squared() / (n as f64 - 1.0)).sqrt();
            // A constant measurement carries no information: its column stays 0.
            scale[j] = if sd > 0.0 { sd } else { 1.0 };
            col /= scale[j];
        }
        let mut wc = w.clone();
        for j in 0..k {
            wc.column_mut(j).add_scalar_mut(-w_mean[j]);
        }
        let svd = z.svd(true, true);
        let smax = svd.singular_values.max();
        let rank = svd
            .singular_values
            .iter()
            .filter(|&&s| s > FA_RCOND * smax)
            .count();
        // Coefficients on standardised inputs: C = pinv(Z) Wc (M x K).
        let c = svd
            .pseudo_inverse(FA_RCOND * smax.max(f64::MIN_POSITIVE))
            .map_err(|e| ModelError::Numerical(format!("feature analysis: {e}")))?
            * wc;
        let mut b = vec![0.0; k * (m + 1)];
        for kk in 0..k {
            let mut intercept = w_mean[kk];
            for j in 0..m {
                let coef = c[(j, kk)] / scale[j];
                b[kk * (m + 1) + j] = coef;
                intercept -= coef * p_mean[j];
            }
            b[kk * (m + 1) + m] = intercept;
        }
        Ok(Self {
            b,
            n_measurements: m,
            n_weights: k,
            rank,
        })
    }

    /// Normalised weights `B [P; 1]` for measurements `p` (length M, metres).
    pub fn apply(&self, p: &[f64]) -> Vec<f64> {
        let m = self.n_measurements;
        assert_eq!(p.len(), m, "need all M measurements");
        (0..self.n_weights)
            .map(|k| {
                let row = &self.b[k * (m + 1)..(k + 1) * (m + 1)];
                row[m] + row[..m].iter().zip(p).map(|(a, b)| a * b).sum::<f64>()
            })
            .collect()
    }
}

/// Mean and covariance of `z = (P, w)` over the training set: the first M
/// entries are measurements (metres), the last K normalised weights.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct JointGaussian {
    /// Number of measurements M.
    pub n_measurements: usize,
    /// Number of weights K.
    pub n_weights: usize,
    /// Mean, length M + K.
    pub mean: Vec<f64>,
    /// Covariance, (M + K) x (M + K), row-major, normalised by N - 1.
    pub cov: Vec<f64>,
}

/// A Gaussian conditional: mean and covariance of the unobserved variables.
#[derive(Debug, Clone)]
pub struct Conditional {
    /// Conditional mean.
    pub mean: DVector<f64>,
    /// Conditional covariance.
    pub cov: DMatrix<f64>,
}

impl JointGaussian {
    /// Estimates the joint mean and covariance from `p` (N x M) and `w` (N x K).
    pub fn fit(p: &DMatrix<f64>, w: &DMatrix<f64>) -> Result<Self> {
        let (n, m) = p.shape();
        let k = w.ncols();
        if w.nrows() != n || n < 2 {
            return Err(ModelError::InvalidTraining(format!(
                "joint statistics need >= 2 matching rows, got {n} and {}",
                w.nrows()
            )));
        }
        let mut z = DMatrix::<f64>::zeros(n, m + k);
        z.columns_mut(0, m).copy_from(p);
        z.columns_mut(m, k).copy_from(w);
        let mean = z.row_mean();
        for j in 0..m + k {
            z.column_mut(j).add_scalar_mut(-mean[j]);
        }
        let cov = z.tr_mul(&z) / (n as f64 - 1.0);
        let dim = m + k;
        let mut cov_rm = vec![0.0; dim * dim];
        for r in 0..dim {
            for c in 0..dim {
                cov_rm[r * dim + c] = cov[(r, c)];
            }
        }
        Ok(Self {
            n_measurements: m,
            n_weights: k,
            mean: mean.iter().copied().collect(),
            cov: cov_rm,
        })
    }

    fn dim(&self) -> usize {
        self.n_measurements + self.n_weights
    }

    fn cov_entry(&self, r: usize, c: usize) -> f64 {
        self.cov[r * self.dim() + c]
    }

    /// Conditional distribution of the variables `wanted` (indices into z)
    /// given `observed` = (index into z, value, noise variance) triples.
    ///
    /// `mean = mu_u + S_uo (S_oo + R)^-1 (x_o - mu_o)`,
    /// `cov = S_uu - S_uo (S_oo + R)^-1 S_ou`, with `R = diag(noise)`. If
    /// `S_oo + R` is not positive definite a ridge of [`CONDITIONAL_RIDGE`]
    /// times its mean diagonal is added.
    pub fn conditional(
        &self,
        wanted: &[usize],
        observed: &[(usize, f64, f64)],
    ) -> Result<Conditional> {
        let u = wanted.len();
        let o = observed.len();
        let mut mean = DVector::from_iterator(u, wanted.iter().map(|&i| self.mean[i]));
        let mut cov = DMatrix::from_fn(u, u, |a, b| self.cov_entry(wanted[a], wanted[b]));
        if o == 0 {
            return Ok(Conditional { mean, cov });
        }
        let mut s_oo = DMatrix::from_fn(o, o, |a, b| {
            self.cov_entry(observed[a].0, observed[b].0) + if a == b { observed[a].2 } else { 0.0 }
        });
        let s_uo = DMatrix::from_fn(u, o, |a, b| self.cov_entry(wanted[a], observed[b].0));
        let resid = DVector::from_iterator(o, observed.iter().map(|&(i, x, _)| x - self.mean[i]));
        let chol = cholesky_with_ridge(&mut s_oo)?;
        mean += &s_uo * chol.solve(&resid);
        cov -= &s_uo * chol.solve(&s_uo.transpose());
        Ok(Conditional { mean, cov })
    }

    /// Mahalanobis distance of `values` at z-indices `indices` under their
    /// marginal Gaussian plus independent observation noise of variances
    /// `noise` (same ridge rule as [`JointGaussian::conditional`]).
    pub fn mahalanobis(&self, indices: &[usize], values: &[f64], noise: &[f64]) -> Result<f64> {
        let o = indices.len();
        let mut s = DMatrix::from_fn(o, o, |a, b| {
            self.cov_entry(indices[a], indices[b]) + if a == b { noise[a] } else { 0.0 }
        });
        let r = DVector::from_fn(o, |a, _| values[a] - self.mean[indices[a]]);
        let chol = cholesky_with_ridge(&mut s)?;
        Ok(r.dot(&chol.solve(&r)).max(0.0).sqrt())
    }
}

/// Cholesky factor of `s`, adding a ridge of [`CONDITIONAL_RIDGE`] times the
/// mean diagonal if `s` is not numerically positive definite.
fn cholesky_with_ridge(s: &mut DMatrix<f64>) -> Result<nalgebra::Cholesky<f64, nalgebra::Dyn>> {
    if let Some(c) = s.clone().cholesky() {
        return Ok(c);
    }
    let o = s.nrows();
    let ridge = CONDITIONAL_RIDGE * (s.trace() / o as f64).max(f64::MIN_POSITIVE);
    for a in 0..o {
        s[(a, a)] += ridge;
    }
    s.clone().cholesky().ok_or_else(|| {
        ModelError::Numerical(
            "covariance of the observed measurements is singular even with a ridge".into(),
        )
    })
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // index loops compare arrays entry by entry
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    #[test]
    fn recovers_an_exact_linear_model() {
        let (n, m, k) = (40, 5, 3);
        let mut s = 11;
        let p = DMatrix::from_fn(n, m, |_, _| 1.0 + lcg(&mut s));
        let b_true = DMatrix::from_fn(k, m, |_, _| 3.0 * lcg(&mut s));
        let c_true = DVector::from_fn(k, |_, _| lcg(&mut s));
        let w = DMatrix::from_fn(n, k, |i, kk| {
            c_true[kk] + (0..m).map(|j| b_true[(kk, j)] * p[(i, j)]).sum::<f64>()
        });
        let fa = FeatureMap::fit(&p, &w).unwrap();
        assert_eq!(fa.rank, m);
        for kk in 0..k {
            for j in 0..m {
                assert!((fa.b[kk * (m + 1) + j] - b_true[(kk, j)]).abs() < 1e-9);
            }
            assert!((fa.b[kk * (m + 1) + m] - c_true[kk]).abs() < 1e-9);
        }
        let x: Vec<f64> = (0..m).map(|j| 0.8 + 0.1 * j as f64).collect();
        let got = fa.apply(&x);
        for kk in 0..k {
            let want = c_true[kk] + (0..m).map(|j| b_true[(kk, j)] * x[j]).sum::<f64>();
            assert!((got[kk] - want).abs() < 1e-9);
        }
    }

    #[test]
    fn more_measurements_than_bodies_gives_a_finite_interpolating_map() {
        let (n, m, k) = (6, 10, 2);
        let mut s = 5;
        let p = DMatrix::from_fn(n, m, |_, _| lcg(&mut s));
        let w = DMatrix::from_fn(n, k, |_, _| lcg(&mut s));
        let fa = FeatureMap::fit(&p, &w).unwrap();
        assert!(fa.rank < n);
        // Minimum-norm least squares interpolates the training pairs.
        for i in 0..n {
            let row: Vec<f64> = p.row(i).iter().copied().collect();
            let got = fa.apply(&row);
            for kk in 0..k {
                assert!((got[kk] - w[(i, kk)]).abs() < 1e-8);
            }
        }
    }

    #[test]
    fn conditional_with_all_observed_equals_least_squares() {
        let (n, m, k) = (200, 4, 3);
        let mut s = 99;
        let p = DMatrix::from_fn(n, m, |_, _| lcg(&mut s));
        // Noisy, not exactly linear: the equality must hold anyway.
        let w = DMatrix::from_fn(n, k, |i, kk| {
            (kk as f64 + 1.0) * p[(i, 0)] - p[(i, kk + 1)] * p[(i, 0)] + 0.3 * lcg(&mut s)
        });
        let fa = FeatureMap::fit(&p, &w).unwrap();
        let joint = JointGaussian::fit(&p, &w).unwrap();
        let x = [0.1, -0.2, 0.3, 0.05];
        let obs: Vec<(usize, f64, f64)> = x.iter().enumerate().map(|(j, &v)| (j, v, 0.0)).collect();
        let wanted: Vec<usize> = (m..m + k).collect();
        let cond = joint.conditional(&wanted, &obs).unwrap();
        let ls = fa.apply(&x);
        for kk in 0..k {
            assert!(
                (cond.mean[kk] - ls[kk]).abs() < 1e-10,
                "{} vs {}",
                cond.mean[kk],
                ls[kk]
            );
        }
    }

    #[test]
    fn conditional_matches_a_direct_computation() {
        // A 3-D Gaussian with known covariance; condition on z0 and z2.
        let cov = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
        let joint = JointGaussian {
            n_measurements: 2,
            n_weights: 1,
            mean: vec![1.0, 2.0, 3.0],
            cov: cov.to_vec(),
        };
        let c = joint
            .conditional(&[1], &[(0, 2.0, 0.0), (2, 2.5, 0.0)])
            .unwrap();
        // Direct: S_oo = [[4, .5], [.5, 2]], S_uo = [1, .2].
        let det = 4.0 * 2.0 - 0.25;
        let inv = [2.0 / det, -0.5 / det, -0.5 / det, 4.0 / det];
        let r = [1.0, -0.5];
        let g = [1.0 * inv[0] + 0.2 * inv[2], 1.0 * inv[1] + 0.2 * inv[3]];
        let mean = 2.0 + g[0] * r[0] + g[1] * r[1];
        let var = 3.0 - (g[0] * 1.0 + g[1] * 0.2);
        assert!((c.mean[0] - mean).abs() < 1e-12);
        assert!((c.cov[(0, 0)] - var).abs() < 1e-12);
        // Nothing observed: the marginal.
        let c0 = joint.conditional(&[1], &[]).unwrap();
        assert_eq!(c0.mean[0], 2.0);
        assert_eq!(c0.cov[(0, 0)], 3.0);
        // Noise on the observation pulls the mean towards the prior.
        let noisy = joint.conditional(&[1], &[(0, 5.0, 100.0)]).unwrap();
        let exact = joint.conditional(&[1], &[(0, 5.0, 0.0)]).unwrap();
        assert!((noisy.mean[0] - 2.0).abs() < (exact.mean[0] - 2.0).abs());
    }
}
