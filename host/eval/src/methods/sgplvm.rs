//! Shared Gaussian-process latent variable model (SGPLVM; Shon et al. 2005,
//! Ek, Torr and Lawrence 2007) of the measurements and the PCA weights, the
//! baseline the paper compares with (it used Ek et al.'s code; this is a
//! reimplementation in Rust, nalgebra for the linear algebra and argmin's
//! L-BFGS through `tapeshape_model::refine::minimise`).
//!
//! # Model
//!
//! N training bodies share latent points `X` (N x q, q small, default 8:
//! see [`SgplvmSettings::latent_dim`]).
//! Two output spaces, each a Gaussian process over `X` with its own kernel
//! `k_s(x, x') = alpha_s exp(-gamma_s |x - x'|^2 / 2) + b_s + sigma_s^2 [x = x']`
//! (RBF + bias + white noise):
//!
//! * **P**: the measurements, standardised per measurement (training mean and
//!   SD; measurements constant on the training set are left out), `N x M_p`.
//! * **W**: the leading PCA weights explaining [`SgplvmSettings::variance_fraction`]
//!   of the shape variance, each scaled by `sigma_k / sigma_0` (so the W space
//!   is, up to the orthonormal PCA basis and the dropped components, the
//!   meshes themselves relative to the first component's SD: `Y Y^T` is the
//!   Gram matrix of the centred meshes), `N x D_w`.
//!
//! Learning maximises the joint log likelihood, i.e. minimises
//! `L = sum_s [D_s/2 log|K_s| + 1/2 tr(K_s^-1 Y_s Y_s^T)] + 1/2 |X|_F^2`
//! (an isotropic Gaussian prior on the latent points, as in Ek et al.'s code,
//! keeps them from drifting), over `X` and the log hyperparameters
//! `(log alpha_s, log gamma_s, log b_s, log(sigma_s^2 - floor))`, with
//! analytic gradients ([`JointLikelihood`]) and L-BFGS. With
//! `G_s = 1/2 (D_s K_s^-1 - K_s^-1 Y_s Y_s^T K_s^-1)`, `dL = sum tr(G_s dK_s)`,
//! so `dL/dx_i = -2 gamma_s sum_j G_ij k_rbf(x_i, x_j) (x_i - x_j) + x_i`
//! summed over both spaces, and the hyperparameter gradients follow the same
//! way. The latent points start at the PCA of `[P, W]` (each block scaled
//! to unit total variance so both spaces count alike), scaled to unit SD
//! along the first latent axis.
//!
//! # Prediction
//!
//! Given measurements `p*` (any subset O of the measurements), the latent
//! point `x*` minimises the negative log predictive density of the
//! standardised `p*_O` under the P process plus the latent prior
//! ([`LatentObjective`]): `|O|/2 log v(x) + |p*_O - mu_O(x)|^2 / (2 v(x)) + |x|^2/2`,
//! with `mu(x) = k(x)^T K_P^-1 Y_P` and `v(x) = k(x, x) - k(x)^T K_P^-1 k(x)`
//! (noise included). L-BFGS starts from the latent points of the
//! [`SgplvmSettings::starts`] training bodies nearest to `p*` over O; the best
//! end wins. The weights are the W process's posterior mean at `x*`,
//! `k_W(x*)^T K_W^-1 W`, applied to **all** K normalised weights (the
//! components left out of the likelihood get the same kernel's posterior
//! mean, which costs nothing and loses nothing), and the mesh is the PCA
//! reconstruction. Missing measurements are simply left out of O.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};
use tapeshape_model::lbfgs::{minimise, Lbfgs, LineSearch, Objective, RunInfo, StopRule};
use tapeshape_model::ShapeModel;

use super::common::{fit_model, given_targets, predict_err, train_err, training_weights};
use crate::{Method, MethodError, MethodOutput, TrainingData};

/// Noise variance floor added to every kernel diagonal (keeps the Cholesky
/// factorisation defined while the optimiser explores).
pub const NOISE_FLOOR: f64 = 1e-6;
/// Number of hyperparameters per output space.
pub const N_HYPER: usize = 4;
/// Log hyperparameters are held within `+-LOG_BOUND` (a factor of about
/// 1.6e5 either way from 1, far beyond any sensible value for standardised
/// data), smoothly, so that a long first L-BFGS step cannot overflow `exp`.
pub const LOG_BOUND: f64 = 12.0;

/// `LOG_BOUND tanh(t / LOG_BOUND)`: the identity near 0, bounded by `+-LOG_BOUND`.
pub fn bounded_log(t: f64) -> f64 {
    LOG_BOUND * (t / LOG_BOUND).tanh()
}

/// Inverse of [`bounded_log`] (for starting values well inside the bound).
/// The L-BFGS of the model crate with the strong-Wolfe line search (the
/// likelihoods are far from quadratic; see `tapeshape_model::lbfgs`).
fn lbfgs(stop: StopRule) -> Lbfgs {
    Lbfgs {
        stop,
        line_search: LineSearch::StrongWolfe,
    }
}

fn unbounded_log(l: f64) -> f64 {
    LOG_BOUND * (l / LOG_BOUND).clamp(-0.999, 0.999).atanh()
}

/// Derivative of [`bounded_log`].
fn bounded_log_slope(t: f64) -> f64 {
    1.0 - (t / LOG_BOUND).tanh().powi(2)
}

/// Settings of [`Sgplvm`].
#[derive(Debug, Clone, PartialEq)]
pub struct SgplvmSettings {
    /// Latent dimension q (1..=10). Default 8: on held-out generated bodies
    /// (N = 360, paper34) the error fell from 8.3 mm (q = 2) and 7.3 mm
    /// (q = 4) to 5.4 mm (q = 8) and then hardly (5.3 mm at q = 10); a
    /// second validation population (seed 3) agreed (8.7 mm at q = 4, 6.6 mm
    /// at q = 8). A baseline should be as strong as a fair rule makes it.
    pub latent_dim: usize,
    /// Keep the leading PCA components explaining this share of the shape
    /// variance in the W space's likelihood (0 < f <= 1).
    pub variance_fraction: f64,
    /// L-BFGS iterations at most when learning.
    pub train_iterations: u64,
    /// Latent starts per prediction (nearest training bodies).
    pub starts: usize,
    /// L-BFGS iterations at most per start when predicting.
    pub predict_iterations: u64,
}

impl Default for SgplvmSettings {
    fn default() -> Self {
        Self {
            latent_dim: 8,
            variance_fraction: 0.99,
            train_iterations: 400,
            starts: 5,
            predict_iterations: 200,
        }
    }
}

/// Kernel hyperparameters of one space (natural scale).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kernel {
    /// RBF variance `alpha`.
    pub alpha: f64,
    /// RBF inverse squared width `gamma`.
    pub gamma: f64,
    /// Bias variance `b`.
    pub bias: f64,
    /// White-noise variance `sigma^2` (including [`NOISE_FLOOR`]).
    pub noise: f64,
}

impl Kernel {
    /// From the unconstrained parameters `t` (length 4): `log alpha`,
    /// `log gamma`, `log b`, `log(sigma^2 - floor)` are each
    /// [`bounded_log`]`(t_i)`, i.e. held within `+-LOG_BOUND`.
    pub fn from_log(t: &[f64]) -> Self {
        Self {
            alpha: bounded_log(t[0]).exp(),
            gamma: bounded_log(t[1]).exp(),
            bias: bounded_log(t[2]).exp(),
            noise: bounded_log(t[3]).exp() + NOISE_FLOOR,
        }
    }

    /// The RBF part `alpha exp(-gamma r2 / 2)` for squared distance `r2`.
    pub fn rbf(&self, r2: f64) -> f64 {
        self.alpha * (-0.5 * self.gamma * r2).exp()
    }

    /// The kernel matrix over the rows of `x` (N x q), noise on the diagonal.
    pub fn matrix(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        let n = x.nrows();
        let mut k = DMatrix::zeros(n, n);
        for i in 0..n {
            for j in 0..=i {
                let r2 = sq_dist_rows(x, i, x, j);
                let v = self.rbf(r2) + self.bias;
                k[(i, j)] = v;
                k[(j, i)] = v;
            }
            k[(i, i)] += self.noise;
        }
        k
    }
}

fn sq_dist_rows(a: &DMatrix<f64>, i: usize, b: &DMatrix<f64>, j: usize) -> f64 {
    (0..a.ncols())
        .map(|c| (a[(i, c)] - b[(j, c)]).powi(2))
        .sum()
}

/// The negative joint log likelihood of the SGPLVM (module docs), times
/// [`JointLikelihood::scale`], as an [`Objective`] over
/// `theta = [X row-major (N q), P hyper (4), W hyper (4)]`, hyperparameters
/// in the unconstrained form [`Kernel::from_log`] reads.
pub struct JointLikelihood {
    /// Output spaces, each `N x D_s`.
    pub spaces: Vec<DMatrix<f64>>,
    /// Latent dimension q.
    pub q: usize,
}

impl JointLikelihood {
    /// Number of parameters: `N q + 4 * spaces`.
    pub fn n_params(&self) -> usize {
        self.spaces[0].nrows() * self.q + N_HYPER * self.spaces.len()
    }

    /// The objective is the negative log likelihood times this,
    /// `1 / (N sum_s D_s)` (per body and output dimension), so that its
    /// gradient is of order 1 whatever the data's size: L-BFGS's first step
    /// is the raw gradient, and an unscaled one throws the latent points
    /// far apart.
    pub fn scale(&self) -> f64 {
        let n = self.spaces[0].nrows() as f64;
        let d: usize = self.spaces.iter().map(|y| y.ncols()).sum();
        1.0 / (n * d as f64)
    }

    /// The latent points of `theta` as an N x q matrix.
    pub fn latent(&self, theta: &[f64]) -> DMatrix<f64> {
        let n = self.spaces[0].nrows();
        DMatrix::from_fn(n, self.q, |i, c| theta[i * self.q + c])
    }

    /// Contribution of space `s`: its `D/2 log|K| + 1/2 tr(K^-1 Y Y^T)` and
    /// the gradients by X (N x q, row-major) and by its 4 log hyperparameters.
    /// `None` if the kernel matrix is not positive definite.
    fn space_term(
        &self,
        s: usize,
        x: &DMatrix<f64>,
        t: &[f64],
    ) -> Option<(f64, Vec<f64>, [f64; N_HYPER])> {
        let y = &self.spaces[s];
        let (n, d) = (y.nrows(), y.ncols() as f64);
        let kern = Kernel::from_log(t);
        let k = kern.matrix(x);
        let chol = k.cholesky()?;
        let logdet = chol.ln_determinant();
        let a = chol.solve(y);
        let fit: f64 = a.iter().zip(y.iter()).map(|(p, q)| p * q).sum();
        let cost = 0.5 * d * logdet + 0.5 * fit;
        let kinv = chol.inverse();
        let aat = &a * a.transpose();
        // G = 1/2 (D K^-1 - A A^T), dL = tr(G dK).
        let g = (kinv * d - aat) * 0.5;
        let mut gx = vec![0.0; n * self.q];
        let (mut ga, mut gg, mut gb) = (0.0, 0.0, 0.0);
        for i in 0..n {
            for j in 0..n {
                let gij = g[(i, j)];
                gb += gij;
                if i == j {
                    ga += gij * kern.alpha;
                    continue;
                }
                let r2 = sq_dist_rows(x, i, x, j);
                let kr = kern.rbf(r2);
                ga += gij * kr;
                gg += gij * kr * (-0.5 * kern.gamma * r2);
                // d k_ij / d x_i = -gamma (x_i - x_j) k_rbf; G symmetric, so
                // the (i, j) and (j, i) entries give twice this.
                let f = -2.0 * gij * kern.gamma * kr;
                for c in 0..self.q {
                    gx[i * self.q + c] += f * (x[(i, c)] - x[(j, c)]);
                }
            }
        }
        let gnoise = g.trace() * (kern.noise - NOISE_FLOOR);
        let gh = [ga, gg, gb * kern.bias, gnoise];
        Some((
            cost,
            gx,
            std::array::from_fn(|h| gh[h] * bounded_log_slope(t[h])),
        ))
    }
}

impl Objective for JointLikelihood {
    /// Returns NaN (which ends an L-BFGS run at its best point) where a
    /// kernel matrix is not positive definite.
    fn eval(&self, theta: &[f64], grad: &mut [f64]) -> f64 {
        let n = self.spaces[0].nrows();
        let nx = n * self.q;
        let x = self.latent(theta);
        let hyper = |s: usize| &theta[nx + N_HYPER * s..nx + N_HYPER * (s + 1)];
        let terms: Vec<_> = if self.spaces.len() == 2 {
            // The two spaces are independent given X: one core each.
            let (a, b) = rayon::join(
                || self.space_term(0, &x, hyper(0)),
                || self.space_term(1, &x, hyper(1)),
            );
            vec![a, b]
        } else {
            (0..self.spaces.len())
                .map(|s| self.space_term(s, &x, hyper(s)))
                .collect()
        };
        grad.iter_mut().for_each(|g| *g = 0.0);
        let mut cost = 0.0;
        for (s, term) in terms.into_iter().enumerate() {
            let Some((c, gx, gh)) = term else {
                return f64::NAN;
            };
            cost += c;
            for (g, v) in grad[..nx].iter_mut().zip(&gx) {
                *g += v;
            }
            grad[nx + N_HYPER * s..nx + N_HYPER * (s + 1)].copy_from_slice(&gh);
        }
        for (g, v) in grad[..nx].iter_mut().zip(&theta[..nx]) {
            cost += 0.5 * v * v;
            *g += v;
        }
        let scale = self.scale();
        grad.iter_mut().for_each(|g| *g *= scale);
        cost * scale
    }
}

/// The latent search of a prediction (module docs) as an [`Objective`] over
/// one latent point `x` (length q).
pub struct LatentObjective<'a> {
    /// Training latent points, N x q.
    pub x: &'a DMatrix<f64>,
    /// The P kernel.
    pub kernel: Kernel,
    /// `K_P^-1`, N x N.
    pub kinv: &'a DMatrix<f64>,
    /// `K_P^-1 Y_P` restricted to the observed columns, N x |O|.
    pub alpha: DMatrix<f64>,
    /// Observed standardised measurements, length |O|.
    pub y: Vec<f64>,
}

impl Objective for LatentObjective<'_> {
    fn eval(&self, xs: &[f64], grad: &mut [f64]) -> f64 {
        let (n, q) = (self.x.nrows(), self.x.ncols());
        let o = self.y.len() as f64;
        let mut k = DVector::zeros(n);
        let mut dk = DMatrix::zeros(n, q); // d k_j / d x*
        for j in 0..n {
            let r2: f64 = (0..q).map(|c| (xs[c] - self.x[(j, c)]).powi(2)).sum();
            let kr = self.kernel.rbf(r2);
            k[j] = kr + self.kernel.bias;
            for c in 0..q {
                dk[(j, c)] = -self.kernel.gamma * (xs[c] - self.x[(j, c)]) * kr;
            }
        }
        let kinv_k = self.kinv * &k;
        let kss = self.kernel.alpha + self.kernel.bias + self.kernel.noise;
        let v = (kss - k.dot(&kinv_k)).max(self.kernel.noise);
        let mu = self.alpha.transpose() * &k;
        let r: Vec<f64> = self.y.iter().zip(mu.iter()).map(|(a, b)| a - b).collect();
        let r2: f64 = r.iter().map(|a| a * a).sum();
        let xx: f64 = xs.iter().map(|a| a * a).sum();
        let cost = 0.5 * o * v.ln() + 0.5 * r2 / v + 0.5 * xx;
        // dv/dx = -2 (K^-1 k)^T dk; dmu_d/dx = alpha[:, d]^T dk.
        let dv = dk.transpose() * &kinv_k * -2.0;
        let dmu = dk.transpose() * &self.alpha; // q x |O|
        let rv = DVector::from_vec(r);
        let dfit = &dmu * &rv; // q: sum_d r_d dmu_d
        let coef = 0.5 * o / v - 0.5 * r2 / (v * v);
        for c in 0..q {
            grad[c] = coef * dv[c] - dfit[c] / v + xs[c];
        }
        cost
    }
}

/// The SGPLVM baseline (module docs).
pub struct Sgplvm {
    model: Arc<ShapeModel>,
    names: Vec<String>,
    stats: Vec<(f64, f64)>,
    /// Informative measurement indices (columns of the P space, in order).
    used: Vec<usize>,
    /// Standardised training measurements, N x M_p.
    y_p: DMatrix<f64>,
    /// Learned latent points, N x q.
    x: DMatrix<f64>,
    kernels: [Kernel; 2],
    kinv_p: DMatrix<f64>,
    /// `K_P^-1 Y_P`, N x M_p.
    alpha_p: DMatrix<f64>,
    /// `K_W^-1 W_all` (all K normalised weights), N x K.
    beta_w: DMatrix<f64>,
    /// Weight dimensions in the W space's likelihood.
    w_dims: usize,
    /// What the learning run did (L-BFGS iterations, likelihood at start and end, why it stopped).
    fit_info: RunInfo,
    settings: SgplvmSettings,
}

impl Sgplvm {
    /// Name in tables.
    pub const NAME: &'static str = "SGPLVM";

    /// Fits the paper's PCA on `data`, then the SGPLVM.
    pub fn fit(data: &TrainingData, settings: SgplvmSettings) -> Result<Self, MethodError> {
        let model = Arc::new(fit_model(Self::NAME, data)?);
        Self::from_model(model, data, settings)
    }

    /// Fits the SGPLVM with the PCA of `model` (fitted on `data`).
    pub fn from_model(
        model: Arc<ShapeModel>,
        data: &TrainingData,
        settings: SgplvmSettings,
    ) -> Result<Self, MethodError> {
        super::common::check_training(Self::NAME, data, 3)?;
        super::common::check_model(Self::NAME, &model, data)?;
        let n = data.meshes.len();
        if !(1..=10).contains(&settings.latent_dim) || settings.latent_dim >= n {
            return Err(train_err(
                Self::NAME,
                format!(
                    "latent dimension {} must be in 1..=10 and below the {n} bodies",
                    settings.latent_dim
                ),
            ));
        }
        if !(settings.variance_fraction > 0.0 && settings.variance_fraction <= 1.0) {
            return Err(train_err(
                Self::NAME,
                format!(
                    "variance fraction {} must be in (0, 1]",
                    settings.variance_fraction
                ),
            ));
        }
        if settings.starts == 0 {
            return Err(train_err(Self::NAME, "need at least one latent start"));
        }
        let (names, stats, used) = super::common::informative_columns(Self::NAME, data)?;
        let y_p = DMatrix::from_fn(n, used.len(), |i, c| {
            let j = used[c];
            (data.measurements[i][j] - stats[j].0) / stats[j].1
        });
        let wt = training_weights(&model, data);
        let k = model.n_components();
        let sigma = &model.pca.sigma;
        let total: f64 = sigma.iter().map(|s| s * s).sum();
        let mut acc = 0.0;
        let mut w_dims = k;
        for (c, s) in sigma.iter().enumerate() {
            acc += s * s;
            if acc >= settings.variance_fraction * total {
                w_dims = c + 1;
                break;
            }
        }
        let y_w = DMatrix::from_fn(n, w_dims, |i, c| wt[i][c] * sigma[c] / sigma[0]);
        let w_all = DMatrix::from_fn(n, k, |i, c| wt[i][c]);
        let q = settings.latent_dim;
        let x0 = init_latent(&y_p, &y_w, q);
        let objective = JointLikelihood {
            spaces: vec![y_p.clone(), y_w],
            q,
        };
        let mut theta: Vec<f64> = x0.transpose().iter().copied().collect();
        for y in &objective.spaces {
            let var = y.iter().map(|v| v * v).sum::<f64>() / (y.len() as f64);
            theta.extend([var.ln(), 0.0, (0.01 * var).ln(), (0.05 * var).ln()].map(unbounded_log));
        }
        let stop = StopRule {
            max_iters: settings.train_iterations,
            grad_tol: 1e-6,
            rel_cost_tol: 1e-10,
            history: 10,
        };
        let (theta, info) = minimise(&objective, theta, &lbfgs(stop))
            .map_err(|e| train_err(Self::NAME, format!("learning the latent points: {e}")))?;
        let x = objective.latent(&theta);
        let nx = n * q;
        let kp = Kernel::from_log(&theta[nx..nx + N_HYPER]);
        let kw = Kernel::from_log(&theta[nx + N_HYPER..nx + 2 * N_HYPER]);
        let chol_p = kp.matrix(&x).cholesky().ok_or_else(|| {
            train_err(
                Self::NAME,
                "the learned measurement kernel is not positive definite",
            )
        })?;
        let chol_w = kw.matrix(&x).cholesky().ok_or_else(|| {
            train_err(
                Self::NAME,
                "the learned weight kernel is not positive definite",
            )
        })?;
        let alpha_p = chol_p.solve(&y_p);
        let beta_w = chol_w.solve(&w_all);
        Ok(Self {
            model,
            names,
            stats,
            used,
            y_p,
            x,
            kernels: [kp, kw],
            kinv_p: chol_p.inverse(),
            alpha_p,
            beta_w,
            w_dims,
            fit_info: info,
            settings,
        })
    }

    /// Learned latent points, N x q.
    pub fn latent_points(&self) -> &DMatrix<f64> {
        &self.x
    }

    /// Learned kernels of the P (measurement) and W (weight) spaces.
    pub fn kernels(&self) -> [Kernel; 2] {
        self.kernels
    }

    /// Weight dimensions in the W space's likelihood.
    pub fn weight_dims(&self) -> usize {
        self.w_dims
    }

    /// What the learning run did: iterations, the negative joint log
    /// likelihood at the start and the end, and why it stopped.
    pub fn fit_info(&self) -> &RunInfo {
        &self.fit_info
    }

    /// The latent point explaining the standardised measurements `y` on the
    /// P-space columns `cols` (module docs), and its objective value.
    fn find_latent(&self, cols: &[usize], y: &[f64]) -> Result<(Vec<f64>, f64), MethodError> {
        let n = self.x.nrows();
        let alpha = self.alpha_p.select_columns(cols.iter());
        let obj = LatentObjective {
            x: &self.x,
            kernel: self.kernels[0],
            kinv: &self.kinv_p,
            alpha,
            y: y.to_vec(),
        };
        let mut order: Vec<(f64, usize)> = (0..n)
            .map(|i| {
                let d: f64 = cols
                    .iter()
                    .zip(y)
                    .map(|(&c, v)| (self.y_p[(i, c)] - v).powi(2))
                    .sum();
                (d, i)
            })
            .collect();
        order.sort_by(|a, b| a.0.total_cmp(&b.0));
        let stop = StopRule {
            max_iters: self.settings.predict_iterations,
            grad_tol: 1e-8,
            rel_cost_tol: 1e-12,
            history: 7,
        };
        let mut best: Option<(Vec<f64>, f64)> = None;
        let mut last_err = String::new();
        for &(_, i) in order.iter().take(self.settings.starts) {
            let x0: Vec<f64> = self.x.row(i).iter().copied().collect();
            match minimise(&obj, x0, &lbfgs(stop)) {
                Ok((xs, info)) => {
                    if best.as_ref().is_none_or(|b| info.cost_end < b.1) {
                        best = Some((xs, info.cost_end));
                    }
                }
                Err(e) => last_err = e.to_string(),
            }
        }
        best.ok_or_else(|| {
            predict_err(
                Self::NAME,
                format!("the latent search failed from every start: {last_err}"),
            )
        })
    }
}

/// PCA initialisation of the latent points (module docs): N x q.
fn init_latent(y_p: &DMatrix<f64>, y_w: &DMatrix<f64>, q: usize) -> DMatrix<f64> {
    let n = y_p.nrows();
    let scale = |y: &DMatrix<f64>| {
        let t: f64 = y.iter().map(|v| v * v).sum::<f64>() / n as f64;
        1.0 / t.sqrt().max(1e-300)
    };
    let z = DMatrix::from_fn(n, y_p.ncols() + y_w.ncols(), |i, c| {
        if c < y_p.ncols() {
            y_p[(i, c)] * scale(y_p)
        } else {
            y_w[(i, c - y_p.ncols())] * scale(y_w)
        }
    });
    // Both blocks are centred (standardised measurements, PCA weights).
    let gram = &z * z.transpose();
    let eig = gram.symmetric_eigen();
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let mut x = DMatrix::from_fn(n, q, |i, c| {
        let k = idx[c];
        eig.eigenvectors[(i, k)] * eig.eigenvalues[k].max(0.0).sqrt()
    });
    let sd0 = (x.column(0).iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt();
    if sd0 > 0.0 {
        x /= sd0;
    }
    x
}

impl Method for Sgplvm {
    fn name(&self) -> &str {
        Self::NAME
    }

    /// Measurements constant on the training set are ignored when given.
    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let given = given_targets(Self::NAME, targets, &self.names)?;
        let mut cols = Vec::new();
        let mut y = Vec::new();
        for &(j, v) in &given {
            if let Ok(c) = self.used.binary_search(&j) {
                cols.push(c);
                y.push((v - self.stats[j].0) / self.stats[j].1);
            }
        }
        if cols.is_empty() {
            return Err(predict_err(
                Self::NAME,
                "only measurements constant on the training set were given: they say nothing about the body",
            ));
        }
        let (xs, _) = self.find_latent(&cols, &y)?;
        let kw = self.kernels[1];
        let n = self.x.nrows();
        let kvec = DVector::from_fn(n, |j, _| {
            let r2: f64 = xs
                .iter()
                .enumerate()
                .map(|(c, v)| (v - self.x[(j, c)]).powi(2))
                .sum();
            kw.rbf(r2) + kw.bias
        });
        let w: Vec<f64> = (self.beta_w.transpose() * kvec).iter().copied().collect();
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
