//! The customer's sex as prior knowledge (issue 12, item 3: "a
//! sex-conditioned start").
//!
//! Why: the model's own prior over the normalised weights is the standard
//! normal of the whole training population, whose centre lies between the
//! sexes. With a few readings (the nine of `quick`) the start's conditional
//! and step 1's MAP estimate are pulled towards that centre wherever the
//! readings leave the shape open, so a woman's estimate came out measurably
//! male on every sex axis (measured on the ANSUR II test split:
//! `docs/results/sex-check.md`). Given the sex, the same two stages use the
//! statistics of the training bodies of that sex instead:
//!
//! * the start: the Gaussian conditional of the weights on the readings under
//!   the joint Gaussian of (measurements, weights) of that sex's bodies;
//! * step 1: the MAP prior `(w - mu_s)^T Sigma_s^-1 (w - mu_s)` in place of
//!   `|w|^2` (the Gauss-Newton rounds and the L-BFGS rounds alike).
//!
//! The weights stay the pooled model's normalised weights (the clamp, the
//! report and step 2 are unchanged); only the prior moves. Fitted at
//! training time ([`SexPriors::fit`]) when the population records each
//! body's sex and each sex has more bodies than the model has components
//! (so that `Sigma_s` is full rank); a model without them predicts as before.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use crate::regress::JointGaussian;
use crate::{ModelError, Result};

/// A body's sex as the model knows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Sex {
    /// Male.
    Male,
    /// Female.
    Female,
}

/// The training bodies of one sex: their count, the mean and covariance of
/// their normalised weights, and their joint Gaussian of (measurements,
/// weights).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct SexStats {
    /// Number of training bodies of this sex.
    pub n: usize,
    /// Mean of their normalised weights, length K.
    pub mean: Vec<f64>,
    /// Covariance of their normalised weights, K x K row-major (N - 1).
    pub cov: Vec<f64>,
    /// Joint Gaussian of (measurements in metres, normalised weights).
    pub joint: JointGaussian,
}

/// The statistics of each sex (see the module docs).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct SexPriors {
    /// The male training bodies.
    pub male: SexStats,
    /// The female training bodies.
    pub female: SexStats,
}

/// Relative ridge added to a sex's weight covariance before it is inverted:
/// `1e-6` of its mean diagonal, far below any component's spread (the
/// smallest kept component's within-sex SD is a few percent of the
/// pooled one) and enough to keep the Cholesky factor well defined.
const RIDGE: f64 = 1e-6;

impl SexPriors {
    /// Fits the statistics from the training bodies' measurements `p`
    /// (N x M, metres), normalised weights `w` (N x K) and `sexes` (N;
    /// `None` where unknown, left out). `None` (no priors) when a sex has
    /// fewer than K + 2 bodies: its weight covariance would be singular.
    ///
    /// Errors: mismatched sizes.
    pub fn fit(
        p: &DMatrix<f64>,
        w: &DMatrix<f64>,
        sexes: &[Option<Sex>],
    ) -> Result<Option<SexPriors>> {
        let (n, k) = w.shape();
        if p.nrows() != n || sexes.len() != n {
            return Err(ModelError::InvalidTraining(format!(
                "{} measurement rows, {n} weight rows and {} sexes",
                p.nrows(),
                sexes.len()
            )));
        }
        let stats = |sex: Sex| -> Result<Option<SexStats>> {
            let rows: Vec<usize> = (0..n).filter(|&i| sexes[i] == Some(sex)).collect();
            if rows.len() < k + 2 {
                return Ok(None);
            }
            let ps = p.select_rows(&rows);
            let ws = w.select_rows(&rows);
            let ns = rows.len() as f64;
            let mean: DVector<f64> = ws.row_mean().transpose();
            let centred = DMatrix::from_fn(rows.len(), k, |i, j| ws[(i, j)] - mean[j]);
            let cov = centred.transpose() * &centred / (ns - 1.0);
            Ok(Some(SexStats {
                n: rows.len(),
                mean: mean.iter().copied().collect(),
                cov: cov.transpose().iter().copied().collect(),
                joint: JointGaussian::fit(&ps, &ws)?,
            }))
        };
        Ok(match (stats(Sex::Male)?, stats(Sex::Female)?) {
            (Some(male), Some(female)) => Some(SexPriors { male, female }),
            _ => None,
        })
    }

    /// The statistics of `sex`.
    pub fn get(&self, sex: Sex) -> &SexStats {
        match sex {
            Sex::Male => &self.male,
            Sex::Female => &self.female,
        }
    }

    /// Checks sizes and finiteness against a model of `m` measurements and
    /// `k` components.
    pub fn validate(&self, m: usize, k: usize) -> Result<()> {
        for (word, s) in [("male", &self.male), ("female", &self.female)] {
            let j = &s.joint;
            if s.mean.len() != k
                || s.cov.len() != k * k
                || j.n_measurements != m
                || j.n_weights != k
                || j.mean.len() != m + k
                || j.cov.len() != (m + k) * (m + k)
            {
                return Err(ModelError::InvalidInput(format!(
                    "inconsistent model: the {word} prior's dimensions"
                )));
            }
            let all = s.mean.iter().chain(&s.cov).chain(&j.mean).chain(&j.cov);
            if all.into_iter().any(|x| !x.is_finite()) {
                return Err(ModelError::NonFinite(format!(
                    "the {word} prior contains NaN or infinite numbers"
                )));
            }
        }
        Ok(())
    }
}

/// A Gaussian prior `N(mean, cov)` over the K normalised weights, ready
/// for step 1: its penalty `(w - mean)^T cov^-1 (w - mean)` (dimensionless,
/// the role `|w|^2` plays for the standard normal), its gradient and its
/// conditional on held weights.
#[derive(Debug, Clone)]
pub struct WeightPrior {
    mean: DVector<f64>,
    cov: DMatrix<f64>,
    /// `cov^-1`.
    precision: DMatrix<f64>,
}

impl WeightPrior {
    /// The prior of one sex's training bodies.
    ///
    /// Errors: a covariance that is not positive definite even with the
    /// ridge (a damaged model).
    pub fn of(stats: &SexStats) -> Result<WeightPrior> {
        let k = stats.mean.len();
        let mut cov = DMatrix::from_row_slice(k, k, &stats.cov);
        let ridge = RIDGE * cov.trace() / k.max(1) as f64;
        for i in 0..k {
            cov[(i, i)] += ridge;
        }
        let chol: Cholesky<f64, Dyn> = cov.clone().cholesky().ok_or_else(|| {
            ModelError::Numerical(
                "a sex prior's weight covariance is not positive definite; retrain the model"
                    .into(),
            )
        })?;
        Ok(WeightPrior {
            mean: DVector::from_column_slice(&stats.mean),
            precision: chol.inverse(),
            cov,
        })
    }

    /// Number of weights K.
    pub fn len(&self) -> usize {
        self.mean.len()
    }

    /// Whether the prior has no weights.
    pub fn is_empty(&self) -> bool {
        self.mean.is_empty()
    }

    /// `(w - mean)^T cov^-1 (w - mean)`; `w` has K entries.
    /// Allocation-free (step 1's L-BFGS evaluates it every iteration).
    pub fn penalty(&self, w: &[f64]) -> f64 {
        (0..self.len())
            .map(|j| (w[j] - self.mean[j]) * self.precision_row_dot(j, w))
            .sum()
    }

    /// Adds `scale` times the penalty's gradient, `2 cov^-1 (w - mean)`, to
    /// `grad` (K entries). Allocation-free.
    pub fn add_gradient(&self, w: &[f64], scale: f64, grad: &mut [f64]) {
        for (j, g) in grad.iter_mut().enumerate().take(self.len()) {
            *g += 2.0 * scale * self.precision_row_dot(j, w);
        }
    }

    /// Row `j` of `cov^-1` times `w - mean` (the precision is symmetric, so
    /// its column `j`, contiguous in nalgebra's column-major storage).
    fn precision_row_dot(&self, j: usize, w: &[f64]) -> f64 {
        self.precision
            .column(j)
            .iter()
            .zip(w.iter().zip(self.mean.iter()))
            .map(|(p, (a, b))| p * (a - b))
            .sum()
    }

    /// Mean and covariance of the weights `free` given the others held at
    /// their values in `w` (K entries): the Gaussian conditional.
    pub fn conditional(&self, w: &[f64], free: &[usize]) -> (DVector<f64>, DMatrix<f64>) {
        let k = self.len();
        let held: Vec<usize> = (0..k).filter(|i| !free.contains(i)).collect();
        let cff = self.cov.select_rows(free).select_columns(free);
        let mf = DVector::from_iterator(free.len(), free.iter().map(|&i| self.mean[i]));
        if held.is_empty() {
            return (mf, cff);
        }
        let cfh = self.cov.select_rows(free).select_columns(&held);
        let chh = self.cov.select_rows(&held).select_columns(&held);
        let dh = DVector::from_iterator(held.len(), held.iter().map(|&i| w[i] - self.mean[i]));
        match chh.cholesky() {
            Some(c) => {
                let mean = mf + &cfh * c.solve(&dh);
                let cov = &cff - &cfh * c.solve(&cfh.transpose());
                (mean, cov)
            }
            None => (mf, cff),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stats_2d() -> SexStats {
        SexStats {
            n: 10,
            mean: vec![1.0, -0.5],
            cov: vec![0.5, 0.2, 0.2, 0.3],
            joint: JointGaussian {
                n_measurements: 0,
                n_weights: 2,
                mean: vec![1.0, -0.5],
                cov: vec![0.5, 0.2, 0.2, 0.3],
            },
        }
    }

    #[test]
    fn penalty_is_the_mahalanobis_square_and_its_gradient_matches() {
        let p = WeightPrior::of(&stats_2d()).unwrap();
        // cov^-1 = 1/(0.15-0.04) [0.3 -0.2; -0.2 0.5] (ridge negligible).
        let det = 0.5 * 0.3 - 0.2 * 0.2;
        let w = [2.0, 0.5];
        let d = [1.0, 1.0];
        let want = (0.3 * d[0] * d[0] - 2.0 * 0.2 * d[0] * d[1] + 0.5 * d[1] * d[1]) / det;
        assert!(
            (p.penalty(&w) - want).abs() < 1e-4 * want,
            "{} vs {want}",
            p.penalty(&w)
        );
        assert!(p.penalty(&[1.0, -0.5]).abs() < 1e-12);
        let mut g = [0.0; 2];
        p.add_gradient(&w, 1.0, &mut g);
        for i in 0..2 {
            let h = 1e-6;
            let mut a = w;
            a[i] += h;
            let mut b = w;
            b[i] -= h;
            let fd = (p.penalty(&a) - p.penalty(&b)) / (2.0 * h);
            assert!(
                (g[i] - fd).abs() < 1e-5 * fd.abs().max(1.0),
                "{i}: {} vs {fd}",
                g[i]
            );
        }
    }

    #[test]
    fn conditional_on_a_held_weight_is_the_gaussian_one() {
        let p = WeightPrior::of(&stats_2d()).unwrap();
        // Weight 1 held at 0.1: mean_0 = 1 + 0.2 / 0.3 (0.1 + 0.5), var = 0.5 - 0.04 / 0.3.
        let (m, c) = p.conditional(&[7.0, 0.1], &[0]);
        assert!((m[0] - (1.0 + 0.2 / 0.3 * 0.6)).abs() < 1e-5);
        assert!((c[(0, 0)] - (0.5 - 0.04 / 0.3)).abs() < 1e-5);
        let (m, c) = p.conditional(&[7.0, 0.1], &[0, 1]);
        assert_eq!(m.as_slice(), &[1.0, -0.5]);
        assert!((c[(0, 1)] - 0.2).abs() < 1e-12);
    }

    #[test]
    fn fit_separates_the_sexes_and_needs_enough_bodies() {
        // K = 2 weights, M = 1 measurement; men around (+1, 0), women (-1, 0).
        let n = 40;
        let sexes: Vec<Option<Sex>> = (0..n)
            .map(|i| match i % 3 {
                0 => Some(Sex::Male),
                1 => Some(Sex::Female),
                _ => None,
            })
            .collect();
        let jitter = |i: usize, s: f64| ((i * 7919 % 101) as f64 / 101.0 - 0.5) * s;
        let w = DMatrix::from_fn(n, 2, |i, j| {
            let base = match (sexes[i], j) {
                (Some(Sex::Male), 0) => 1.0,
                (Some(Sex::Female), 0) => -1.0,
                _ => 0.0,
            };
            base + jitter(i + 13 * j, 0.4)
        });
        let p = DMatrix::from_fn(n, 1, |i, _| 1.7 + 0.1 * w[(i, 0)]);
        let priors = SexPriors::fit(&p, &w, &sexes)
            .unwrap()
            .expect("enough bodies");
        assert_eq!(priors.male.n, 14);
        assert_eq!(priors.female.n, 13);
        assert!(priors.male.mean[0] > 0.8 && priors.female.mean[0] < -0.8);
        priors.validate(1, 2).unwrap();
        // Fewer than K + 2 of a sex: no priors.
        let few: Vec<Option<Sex>> = (0..n)
            .map(|i| {
                if i < 3 {
                    Some(Sex::Female)
                } else {
                    Some(Sex::Male)
                }
            })
            .collect();
        assert!(SexPriors::fit(&p, &w, &few).unwrap().is_none());
        assert!(SexPriors::fit(&p, &w, &few[..5]).is_err());
    }
}
