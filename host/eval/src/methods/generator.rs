//! Fitting the body generator's own parameters to the measurements: what
//! parametric-model tools (MakeHuman's measure tab, and the sliders of
//! commercial avatar tools) do, and the baseline that needs no training data.
//!
//! Parameters ([`GeneratorFit::parameters`]): the macro parameters gender,
//! age, muscle, weight, height, proportions and cup size, and MakeHuman's
//! `measure-*` local changes (the modifiers of its measure tab: bust, waist,
//! hips, neck, arm and leg lengths and girths, ...), each bounded to its valid
//! range ([`tapeshape_body::Param::range`]). Race weights and breast
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
//! Optimiser: the one generator fitter the population generation also uses
//! ([`tapeshape_population::fit::GeneratorFitter`]: damped Gauss-Newton with
//! exact derivatives and bounds as an active set), here with the prior SD
//! `span_k / sqrt(prior_weight)`, two starts (the default phenotype as a man
//! and as a woman; the lower cost wins) and a start stopping when a step
//! lowers the cost by less than 1e-6 of it or moves no parameter by more
//! than 1e-7.
//!
//! Missing measurements: only the given ones enter the objective.

use std::sync::Arc;

use tapeshape_body::{BodyModel, LocalChanges, Param, Phenotype};
use tapeshape_measure::CompiledSet;
use tapeshape_mesh::Vec3;
use tapeshape_population::fit::{FitError, FitOptions, Free, GeneratorFitter, Stop};

use super::common::{given_targets, measurement_names, predict_err, train_err};
use crate::{Method, MethodError, MethodOutput, TrainingData};

/// Settings of [`GeneratorFit`].
#[derive(Debug, Clone, PartialEq)]
pub struct GeneratorFitSettings {
    /// Gauss-Newton iterations at most per start.
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
    free: Vec<Free>,
    options: FitOptions,
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
        let sw = settings.prior_weight.sqrt();
        let free = params
            .into_iter()
            .map(|param| {
                let (lo, hi) = param.range();
                Free {
                    param,
                    prior_sd: (hi - lo) / sw,
                }
            })
            .collect();
        let gf = Self {
            body,
            compiled: data.compiled.clone(),
            names: measurement_names(data),
            free,
            options: FitOptions {
                max_iterations: settings.max_iterations,
                stop: Stop {
                    misfit_m: 0.0,
                    min_relative_gain: 1e-6,
                    min_step: 1e-7,
                },
            },
        };
        gf.fitter()
            .map_err(|e| train_err(Self::NAME, e.to_string()))?;
        Ok(gf)
    }

    fn fitter(&self) -> Result<GeneratorFitter<'_>, FitError> {
        GeneratorFitter::new(self.body, &self.compiled, &self.free, self.options.clone())
    }

    /// The fitted parameters, in the order of the parameter vector.
    pub fn parameters(&self) -> Vec<Param> {
        self.free.iter().map(|f| f.param).collect()
    }

    /// Fits the generator to `targets` (length M, metres, `None` = not
    /// given) and returns the best of the two starts.
    pub fn fit_parameters(
        &self,
        targets: &[Option<f64>],
    ) -> Result<GeneratorSolution, MethodError> {
        let given = given_targets(Self::NAME, targets, &self.names)?;
        let err = |e: FitError| predict_err(Self::NAME, e.to_string());
        let starts = [0.0, 1.0].map(|gender| {
            (
                Phenotype {
                    gender,
                    ..Phenotype::default()
                },
                LocalChanges::new(),
            )
        });
        let fit = self
            .fitter()
            .map_err(err)?
            .fit(&given, &starts)
            .map_err(err)?;
        Ok(GeneratorSolution {
            rms_mm: fit.rms_mm(&given),
            phenotype: fit.phenotype,
            local_changes: fit.local_changes,
            vertices: fit.mesh.vertices,
            cost: fit.cost,
            iterations: fit.iterations,
        })
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
