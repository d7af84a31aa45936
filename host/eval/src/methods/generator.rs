//! Fitting the body generator's own parameters to the measurements: what
//! parametric-model tools (MakeHuman's measure tab, and the sliders of
//! commercial avatar tools) do, and the baseline that needs no training data.
//!
//! Parameters ([`GeneratorFit::parameters`]): the macro parameters gender,
//! age, muscle, weight, height, proportions and cup size, and MakeHuman's
//! `measure-*` local changes (the modifiers of its measure tab: bust, waist,
//! hips, neck, arm and leg lengths and girths, ...), each bounded to its valid
//! range ([`tapeshape_engine::body::Param::range`]). Race weights and breast
//! firmness stay at the default (they are not measurements' business); the
//! other 236 local changes stay at 0 (a parametric tool's user does not
//! sculpt).
//!
//! Objective: `sum_j (1000 (m_j(theta) - t_j))^2` over the given measurements
//! (squared mm), measured on the generated body with the **same compiled
//! measurement set** as every other method, plus a weak prior
//! `prior_weight sum_k ((theta_k - theta0_k) / span_k)^2` (span = the width
//! of the parameter's range) that only decides directions no measurement
//! constrains (with the default weight 1, moving a parameter across its whole
//! range costs as much as a 1 mm misfit).
//!
//! Optimiser: projected Levenberg-Marquardt with exact derivatives, the
//! generator's Jacobian ([`tapeshape_engine::body::BodyModel::generate_with_jacobian`])
//! chained with each measurement's support gradient. Written by hand because
//! no well-kept crate offers bounded nonlinear least squares with a
//! user-supplied Jacobian (argmin's Gauss-Newton has neither bounds nor
//! damping; its Nelder-Mead or L-BFGS with finite differences would need 27
//! body generations per gradient where this needs one Jacobian). Bounds are
//! an active set: a parameter at a bound whose step points outwards is held
//! for that step. Two starts (the default phenotype as a man and as a
//! woman); the lower cost wins.
//!
//! Missing measurements: only the given ones enter the objective.

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};
use tapeshape_engine::body::{BodyModel, LocalChanges, Param, Phenotype};
use tapeshape_engine::measure::CompiledSet;
use tapeshape_engine::mesh::Vec3;

use super::common::{given_targets, measurement_names, predict_err, train_err};
use crate::{Method, MethodError, MethodOutput, TrainingData};

/// Settings of [`GeneratorFit`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratorFitSettings {
    /// Levenberg-Marquardt iterations at most per start.
    pub max_iterations: usize,
    /// Weight of the prior towards the start, squared mm per squared range (>= 0).
    pub prior_weight: f64,
    /// Also fit the `measure-*` local changes (default true); false: macro
    /// parameters only.
    pub measure_modifiers: bool,
}

impl Default for GeneratorFitSettings {
    fn default() -> Self {
        Self {
            max_iterations: 30,
            prior_weight: 1.0,
            measure_modifiers: true,
        }
    }
}

/// The result of one fit.
#[derive(Debug, Clone)]
pub struct GeneratorSolution {
    /// Fitted macro parameters.
    pub phenotype: Phenotype,
    /// Fitted local changes.
    pub local_changes: LocalChanges,
    /// The generated body, V vertices, metres, station frame.
    pub vertices: Vec<Vec3>,
    /// Final cost (squared mm, prior included).
    pub cost: f64,
    /// Root-mean-square misfit of the given measurements, mm.
    pub rms_mm: f64,
    /// Iterations used (both starts).
    pub iterations: usize,
}

/// The generator-fit baseline (module docs).
pub struct GeneratorFit {
    body: &'static BodyModel,
    compiled: Arc<CompiledSet>,
    names: Vec<String>,
    params: Vec<Param>,
    settings: GeneratorFitSettings,
}

impl GeneratorFit {
    /// Name in tables.
    pub const NAME: &'static str = "generator fit";

    /// Uses `data`'s compiled measurement set (its bodies are not needed).
    ///
    /// Errors if the set is not compiled for the generator's topology (a
    /// face dataset, or meshes imported from elsewhere) or the settings are
    /// invalid.
    pub fn new(data: &TrainingData, settings: GeneratorFitSettings) -> Result<Self, MethodError> {
        let body = BodyModel::shared().map_err(|e| train_err(Self::NAME, e.to_string()))?;
        let v = body.topology().n_vertices();
        if data.compiled.n_vertices() != v || data.topology.n_vertices() != v {
            return Err(train_err(
                Self::NAME,
                format!(
                    "the measurement set is compiled for {} vertices, the body generator makes {v}: generator fitting needs whole bodies in the generator's topology",
                    data.compiled.n_vertices()
                ),
            ));
        }
        if !(settings.prior_weight >= 0.0 && settings.prior_weight.is_finite()) {
            return Err(train_err(
                Self::NAME,
                format!("prior weight {} must be >= 0", settings.prior_weight),
            ));
        }
        let mut params = vec![
            Param::Gender,
            Param::Age,
            Param::Muscle,
            Param::Weight,
            Param::Height,
            Param::Proportions,
            Param::Cupsize,
        ];
        if settings.measure_modifiers {
            for label in LocalChanges::labels() {
                if label.starts_with("measure-") {
                    params.push(
                        Param::local(label).map_err(|e| train_err(Self::NAME, e.to_string()))?,
                    );
                }
            }
        }
        Ok(Self {
            body,
            compiled: data.compiled.clone(),
            names: measurement_names(data),
            params,
            settings,
        })
    }

    /// The fitted parameters, in the order of the parameter vector.
    pub fn parameters(&self) -> &[Param] {
        &self.params
    }

    fn bounds(p: Param) -> (f64, f64) {
        p.range()
    }

    fn apply(&self, theta: &[f64]) -> Result<(Phenotype, LocalChanges), MethodError> {
        let mut ph = Phenotype::default();
        let mut lc = LocalChanges::new();
        for (&p, &t) in self.params.iter().zip(theta) {
            p.set(&mut ph, &mut lc, t)
                .map_err(|e| predict_err(Self::NAME, e.to_string()))?;
        }
        Ok((ph, lc))
    }

    /// Misfits (mm) of the given measurements on `vertices`, and optionally
    /// their gradients as sparse (vertex, d value / d position) lists.
    #[allow(clippy::type_complexity)]
    fn residuals(
        &self,
        vertices: &[Vec3],
        given: &[(usize, f64)],
        with_gradient: bool,
    ) -> Result<(Vec<f64>, Vec<Vec<(usize, Vec3)>>), MethodError> {
        let mut r = Vec::with_capacity(given.len());
        let mut grads = Vec::new();
        for &(j, t) in given {
            let m = self.compiled.measure_one(j, vertices).map_err(|e| {
                predict_err(Self::NAME, format!("measuring '{}': {e}", self.names[j]))
            })?;
            r.push((m.value - t) * 1000.0);
            if with_gradient {
                let g = m.support.gradient(vertices);
                grads.push(
                    g.into_iter()
                        .enumerate()
                        .filter(|(_, d)| d.iter().any(|x| *x != 0.0))
                        .collect(),
                );
            }
        }
        Ok((r, grads))
    }

    fn prior(&self, theta: &[f64], theta0: &[f64]) -> f64 {
        self.params
            .iter()
            .zip(theta.iter().zip(theta0))
            .map(|(&p, (a, b))| {
                let (lo, hi) = Self::bounds(p);
                ((a - b) / (hi - lo)).powi(2)
            })
            .sum::<f64>()
            * self.settings.prior_weight
    }

    /// One projected Levenberg-Marquardt run from `start`.
    fn run(
        &self,
        given: &[(usize, f64)],
        start: Phenotype,
    ) -> Result<GeneratorSolution, MethodError> {
        let np = self.params.len();
        let nm = given.len();
        let lc0 = LocalChanges::new();
        let theta0: Vec<f64> = self.params.iter().map(|p| p.get(&start, &lc0)).collect();
        let mut theta = theta0.clone();
        let gen_err = |e: tapeshape_engine::body::BodyError| predict_err(Self::NAME, e.to_string());
        let (ph, lc) = self.apply(&theta)?;
        let mut vertices = self.body.generate(&ph, &lc).map_err(gen_err)?.vertices;
        let (r, _) = self.residuals(&vertices, given, false)?;
        let mut cost = r.iter().map(|x| x * x).sum::<f64>() + self.prior(&theta, &theta0);
        let mut mu = 1e-3;
        let mut iterations = 0;
        let sw = self.settings.prior_weight.sqrt();
        for _ in 0..self.settings.max_iterations {
            iterations += 1;
            let (ph, lc) = self.apply(&theta)?;
            let (mesh, jac) = self
                .body
                .generate_with_jacobian(&ph, &lc, &self.params)
                .map_err(gen_err)?;
            let (r, grads) = self.residuals(&mesh.vertices, given, true)?;
            let mut jm = DMatrix::<f64>::zeros(nm + np, np);
            let mut rv = DVector::<f64>::zeros(nm + np);
            for i in 0..nm {
                rv[i] = r[i];
                for (k, dk) in jac.iter().enumerate() {
                    let s: f64 = grads[i]
                        .iter()
                        .map(|(v, g)| g[0] * dk[*v][0] + g[1] * dk[*v][1] + g[2] * dk[*v][2])
                        .sum();
                    jm[(i, k)] = s * 1000.0;
                }
            }
            for (k, &p) in self.params.iter().enumerate() {
                let (lo, hi) = Self::bounds(p);
                rv[nm + k] = sw * (theta[k] - theta0[k]) / (hi - lo);
                jm[(nm + k, k)] = sw / (hi - lo);
            }
            let jtj = jm.transpose() * &jm;
            let g = jm.transpose() * &rv;
            let mut accepted = None;
            for _ in 0..10 {
                let step = self.bounded_step(&jtj, &g, &theta, mu);
                let trial: Vec<f64> = self
                    .params
                    .iter()
                    .zip(theta.iter().zip(step.iter()))
                    .map(|(&p, (t, s))| {
                        let (lo, hi) = Self::bounds(p);
                        (t + s).clamp(lo, hi)
                    })
                    .collect();
                let (ph2, lc2) = self.apply(&trial)?;
                let v2 = self.body.generate(&ph2, &lc2).map_err(gen_err)?.vertices;
                let (r2, _) = self.residuals(&v2, given, false)?;
                let c2 = r2.iter().map(|x| x * x).sum::<f64>() + self.prior(&trial, &theta0);
                if c2 < cost {
                    accepted = Some((trial, v2, c2));
                    mu = (mu / 3.0).max(1e-9);
                    break;
                }
                mu *= 10.0;
            }
            let Some((trial, v2, c2)) = accepted else {
                break;
            };
            let gain = (cost - c2) / cost.max(1e-300);
            let moved = trial
                .iter()
                .zip(&theta)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            theta = trial;
            vertices = v2;
            cost = c2;
            if gain < 1e-6 || moved < 1e-7 {
                break;
            }
        }
        let (ph, lc) = self.apply(&theta)?;
        let (r, _) = self.residuals(&vertices, given, false)?;
        let rms_mm = (r.iter().map(|x| x * x).sum::<f64>() / nm as f64).sqrt();
        Ok(GeneratorSolution {
            phenotype: ph,
            local_changes: lc,
            vertices,
            cost,
            rms_mm,
            iterations,
        })
    }

    /// The damped Gauss-Newton step `-(J^T J + mu (diag + 1)) ^-1 J^T r`
    /// over the parameters not held at a bound (active set).
    fn bounded_step(
        &self,
        jtj: &DMatrix<f64>,
        g: &DVector<f64>,
        theta: &[f64],
        mu: f64,
    ) -> DVector<f64> {
        let np = theta.len();
        let mut free = vec![true; np];
        let mut step = DVector::zeros(np);
        for _ in 0..np {
            let idx: Vec<usize> = (0..np).filter(|&k| free[k]).collect();
            if idx.is_empty() {
                break;
            }
            let mut a = DMatrix::from_fn(idx.len(), idx.len(), |x, y| jtj[(idx[x], idx[y])]);
            for d in 0..idx.len() {
                a[(d, d)] += mu * (1.0 + a[(d, d)]);
            }
            let b = DVector::from_fn(idx.len(), |x, _| -g[idx[x]]);
            let Some(s) = a.cholesky().map(|c| c.solve(&b)) else {
                break;
            };
            step.fill(0.0);
            for (d, &k) in idx.iter().enumerate() {
                step[k] = s[d];
            }
            let mut blocked = false;
            for &k in &idx {
                let (lo, hi) = Self::bounds(self.params[k]);
                if (theta[k] <= lo + 1e-12 && step[k] < 0.0)
                    || (theta[k] >= hi - 1e-12 && step[k] > 0.0)
                {
                    free[k] = false;
                    blocked = true;
                }
            }
            if !blocked {
                break;
            }
        }
        step
    }

    /// Fits the generator to `targets` (length M, metres, `None` = not
    /// given) and returns the best of the two starts.
    pub fn fit_parameters(
        &self,
        targets: &[Option<f64>],
    ) -> Result<GeneratorSolution, MethodError> {
        let given = given_targets(Self::NAME, targets, &self.names)?;
        let mut best: Option<GeneratorSolution> = None;
        let mut iterations = 0;
        for gender in [0.0, 1.0] {
            let start = Phenotype {
                gender,
                ..Phenotype::default()
            };
            let sol = self.run(&given, start)?;
            iterations += sol.iterations;
            if best.as_ref().is_none_or(|b| sol.cost < b.cost) {
                best = Some(sol);
            }
        }
        let mut best = best.expect("two starts ran");
        best.iterations = iterations;
        Ok(best)
    }
}

impl Method for GeneratorFit {
    fn name(&self) -> &str {
        Self::NAME
    }

    /// The generated body; no PCA weights (the body is not in the PCA space).
    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let sol = self.fit_parameters(targets)?;
        Ok(MethodOutput {
            vertices: sol.vertices,
            weights: None,
        })
    }
}
