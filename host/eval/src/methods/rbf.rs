//! Gaussian radial basis function interpolation from measurements to PCA
//! weights (Seo and Magnenat-Thalmann 2003, as the paper reviews it).
//!
//! Training: the measurements of the N training bodies are standardised per
//! measurement (`z_j = (p_j - mean_j) / sd_j`, training mean and SD; a
//! measurement constant on the training set is left out of distances); the
//! targets are the bodies' normalised PCA weights `w` (N x K, the paper
//! model's PCA). The interpolant is
//! `w(z) = sum_i c_i exp(-|z - z_i|^2 / (2 eps^2))` with coefficients from
//! `(Phi + rho I) C = W` (Cholesky), `rho` a small regularisation
//! ([`RbfSettings::regularisation`], default 1e-6 of the kernel's unit
//! diagonal; 0 interpolates exactly).
//!
//! Width rule ([`Width::LeaveOneOut`], the default): `eps = c d_nn`, with
//! `d_nn` the mean distance from each training point to its nearest
//! neighbour (in standardised units), and `c` picked from [`LOO_FACTORS`] by
//! leave-one-out on the training set, minimising the mean squared vertex
//! error of the left-out bodies: with Rippa's closed form the left-out error
//! of body i is `C_i / (A^-1)_ii` (`A = Phi + rho I`), and the vertex error
//! of a weight error `e` is `sum_k sigma_k^2 e_k^2` because the PCA basis is
//! orthonormal. So the width is chosen for the shapes, not for the raw
//! weights (where the many small components would count as much as the
//! large ones).
//!
//! Missing measurements: distances are taken over the given (informative)
//! measurements only, `d_nn` is recomputed in that subspace with the same
//! factor `c`, and the system is solved anew (one N x N Cholesky, a few ms
//! at N = 360). Far from every training point a Gaussian interpolant falls to
//! 0 (the mean body): that is the method, not a bug.

use std::sync::Arc;

use nalgebra::DMatrix;
use tapeshape_model::ShapeModel;

use super::common::{fit_model, given_targets, predict_err, train_err, training_weights};
use crate::{Method, MethodError, MethodOutput, TrainingData};

/// Candidate width factors `c` (multiples of the mean nearest-neighbour
/// distance) for the leave-one-out rule.
pub const LOO_FACTORS: [f64; 12] = [
    0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0,
];

/// How the kernel width is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Width {
    /// `eps = c d_nn` with `c` from [`LOO_FACTORS`] by leave-one-out (module docs).
    LeaveOneOut,
    /// `eps = c d_nn` with this `c`.
    Factor(f64),
}

/// Settings of [`RbfInterpolation`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RbfSettings {
    /// Width rule.
    pub width: Width,
    /// Ridge `rho` added to the kernel matrix's unit diagonal (>= 0).
    pub regularisation: f64,
}

impl Default for RbfSettings {
    fn default() -> Self {
        Self {
            width: Width::LeaveOneOut,
            regularisation: 1e-6,
        }
    }
}

/// Gaussian RBF interpolation from measurements to PCA weights (module docs).
pub struct RbfInterpolation {
    model: Arc<ShapeModel>,
    names: Vec<String>,
    /// Per measurement (mean, SD) in metres.
    stats: Vec<(f64, f64)>,
    /// Informative measurement indices (SD > 0).
    used: Vec<usize>,
    /// Standardised training measurements, N x M (all columns; unused ones 0).
    z: Vec<Vec<f64>>,
    /// Normalised training weights, N x K.
    w: DMatrix<f64>,
    /// Width factor `c`.
    factor: f64,
    /// Width `eps` over all informative measurements.
    eps: f64,
    /// Coefficients over all informative measurements, N x K.
    coeffs: DMatrix<f64>,
    regularisation: f64,
}

fn sq_dist(a: &[f64], b: &[f64], dims: &[usize]) -> f64 {
    dims.iter().map(|&j| (a[j] - b[j]).powi(2)).sum()
}

/// Mean nearest-neighbour distance of the points over `dims`.
fn mean_nn(z: &[Vec<f64>], dims: &[usize]) -> f64 {
    let n = z.len();
    let mut total = 0.0;
    for i in 0..n {
        let best = (0..n)
            .filter(|&j| j != i)
            .map(|j| sq_dist(&z[i], &z[j], dims))
            .fold(f64::INFINITY, f64::min);
        total += best.sqrt();
    }
    total / n as f64
}

/// The kernel matrix `Phi + rho I` over `dims` with width `eps`.
fn kernel(z: &[Vec<f64>], dims: &[usize], eps: f64, rho: f64) -> DMatrix<f64> {
    let n = z.len();
    let s = 1.0 / (2.0 * eps * eps);
    DMatrix::from_fn(n, n, |i, j| {
        (-sq_dist(&z[i], &z[j], dims) * s).exp() + if i == j { rho } else { 0.0 }
    })
}

impl RbfInterpolation {
    /// Name in tables.
    pub const NAME: &'static str = "RBF";

    /// Fits the paper's PCA on `data`, then the interpolant.
    pub fn fit(data: &TrainingData, settings: RbfSettings) -> Result<Self, MethodError> {
        let model = Arc::new(fit_model(Self::NAME, data)?);
        Self::from_model(model, data, settings)
    }

    /// Fits the interpolant with the PCA of `model` (fitted on `data`).
    ///
    /// Errors if the bodies are too few (< 3), the measurements all constant,
    /// two bodies have identical measurements (the system is singular without
    /// regularisation), or the settings are invalid.
    pub fn from_model(
        model: Arc<ShapeModel>,
        data: &TrainingData,
        settings: RbfSettings,
    ) -> Result<Self, MethodError> {
        super::common::check_training(Self::NAME, data, 3)?;
        super::common::check_model(Self::NAME, &model, data)?;
        if !(settings.regularisation >= 0.0 && settings.regularisation.is_finite()) {
            return Err(train_err(
                Self::NAME,
                format!("regularisation {} must be >= 0", settings.regularisation),
            ));
        }
        if let Width::Factor(c) = settings.width {
            if !(c > 0.0 && c.is_finite()) {
                return Err(train_err(
                    Self::NAME,
                    format!("width factor {c} must be > 0"),
                ));
            }
        }
        let (names, stats, used) = super::common::informative_columns(Self::NAME, data)?;
        let z: Vec<Vec<f64>> = data
            .measurements
            .iter()
            .map(|row| {
                row.iter()
                    .enumerate()
                    .map(|(j, &x)| {
                        if used.contains(&j) {
                            (x - stats[j].0) / stats[j].1
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        let wt = training_weights(&model, data);
        let k = model.n_components();
        let w = DMatrix::from_fn(wt.len(), k, |i, c| wt[i][c]);
        let d_nn = mean_nn(&z, &used);
        if d_nn <= 0.0 {
            return Err(train_err(
                Self::NAME,
                "two training bodies have identical measurements: remove duplicates",
            ));
        }
        let rho = settings.regularisation;
        let var: Vec<f64> = model.pca.sigma.iter().map(|s| s * s).collect();
        let factor = match settings.width {
            Width::Factor(c) => c,
            Width::LeaveOneOut => {
                let mut best = (f64::INFINITY, LOO_FACTORS[0]);
                for &c in &LOO_FACTORS {
                    let a = kernel(&z, &used, c * d_nn, rho.max(1e-10));
                    let Some(inv) = a.cholesky().map(|ch| ch.inverse()) else {
                        continue;
                    };
                    let coeffs = &inv * &w;
                    let mut err = 0.0;
                    for i in 0..wt.len() {
                        let d = inv[(i, i)];
                        for (kk, v) in var.iter().enumerate() {
                            err += v * (coeffs[(i, kk)] / d).powi(2);
                        }
                    }
                    if err.is_finite() && err < best.0 {
                        best = (err, c);
                    }
                }
                if !best.0.is_finite() {
                    return Err(train_err(
                        Self::NAME,
                        "no width gave a solvable system: increase the regularisation",
                    ));
                }
                best.1
            }
        };
        let eps = factor * d_nn;
        let coeffs = kernel(&z, &used, eps, rho)
            .cholesky()
            .map(|ch| ch.solve(&w))
            .ok_or_else(|| {
                train_err(
                    Self::NAME,
                    format!("the kernel matrix (width {eps:.3} SD) is not positive definite: increase the regularisation"),
                )
            })?;
        Ok(Self {
            model,
            names,
            stats,
            used,
            z,
            w,
            factor,
            eps,
            coeffs,
            regularisation: rho,
        })
    }

    /// The width factor `c` in use (chosen by leave-one-out or given).
    pub fn width_factor(&self) -> f64 {
        self.factor
    }

    /// The kernel width `eps` over all measurements (standardised units).
    pub fn width(&self) -> f64 {
        self.eps
    }

    /// Normalised PCA weights (length K) for standardised measurements
    /// `zq` (length M) given on the informative indices `dims`.
    fn weights(&self, zq: &[f64], dims: &[usize]) -> Result<Vec<f64>, MethodError> {
        let full = dims == self.used.as_slice();
        let (eps, sub);
        let coeffs = if full {
            eps = self.eps;
            &self.coeffs
        } else {
            eps = self.factor * mean_nn(&self.z, dims);
            if eps <= 0.0 {
                return Err(predict_err(
                    Self::NAME,
                    "the given measurements do not distinguish the training bodies: give more",
                ));
            }
            sub = kernel(&self.z, dims, eps, self.regularisation.max(1e-10))
                .cholesky()
                .map(|ch| ch.solve(&self.w))
                .ok_or_else(|| {
                    predict_err(
                        Self::NAME,
                        "the kernel matrix of the given measurements is singular: give more measurements",
                    )
                })?;
            &sub
        };
        let s = 1.0 / (2.0 * eps * eps);
        let k = self.model.n_components();
        let mut w = vec![0.0; k];
        for (i, zi) in self.z.iter().enumerate() {
            let phi = (-sq_dist(zq, zi, dims) * s).exp();
            if phi == 0.0 {
                continue;
            }
            for (c, wc) in w.iter_mut().enumerate() {
                *wc += phi * coeffs[(i, c)];
            }
        }
        Ok(w)
    }
}

impl Method for RbfInterpolation {
    fn name(&self) -> &str {
        Self::NAME
    }

    /// Measurements constant on the training set are ignored when given.
    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let given = given_targets(Self::NAME, targets, &self.names)?;
        let mut zq = vec![0.0; self.names.len()];
        let mut dims = Vec::new();
        for &(j, x) in &given {
            if self.used.binary_search(&j).is_ok() {
                zq[j] = (x - self.stats[j].0) / self.stats[j].1;
                dims.push(j);
            }
        }
        if dims.is_empty() {
            return Err(predict_err(
                Self::NAME,
                "only measurements constant on the training set were given: they say nothing about the body",
            ));
        }
        let w = self.weights(&zq, &dims)?;
        let vertices = self
            .model
            .shape(&w)
            .map_err(|e| predict_err(Self::NAME, e.to_string()))?;
        Ok(MethodOutput {
            vertices,
            weights: Some(w),
        })
    }
}
