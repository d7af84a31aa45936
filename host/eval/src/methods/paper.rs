//! The paper's method and its two reductions, all on one
//! [`ShapeModel`] (PCA, feature map, joint Gaussian of measurements and
//! weights):
//!
//! * [`Ours`]: `ShapeModel::predict` with the paper's settings (start, step 1
//!   over the weights, step 2 over the vertices).
//! * [`StepOneOnly`]: start and step 1 only (the model's stage functions
//!   [`ShapeModel::start`] and [`ShapeModel::step1`], clamp included); the
//!   result is the step-1 shape `mu + A (sigma .* w_step1)`, inside the PCA
//!   space (Baek and Lee's approach is "conceptually similar to the first
//!   optimization step", paper section 2).
//! * [`FeatureAnalysis`]: the start alone (Allen et al.): `w = B [P; 1]` when
//!   every measurement is given, else the Gaussian conditional of the weights
//!   on the given ones (as the model's own start). Not clamped by default
//!   (Allen et al. do not clamp; the paper's figures show its shapes leaving
//!   the human shape space), optionally clamped to `[-l, l]`.
//!
//! Missing measurements: `None` targets are simply not given to the model;
//! the start is then the Gaussian conditional and the refinement fits only the
//! given ones.

use std::sync::Arc;

use tapeshape_measure::CompiledSet;
use tapeshape_mesh::Topology;
use tapeshape_model::predict::{Control, PredictProgress};
use tapeshape_model::{PredictConfig, PredictSettings, ShapeModel, Target};

use super::common::{fit_model, given_targets, predict_err, train_err};
use crate::{Method, MethodError, MethodOutput, TrainingData};

/// The trained model with the operators and topology it predicts with.
#[derive(Clone)]
struct Trained {
    model: Arc<ShapeModel>,
    compiled: Arc<CompiledSet>,
    topology: Arc<Topology>,
}

impl Trained {
    fn fit(method: &str, data: &TrainingData) -> Result<Self, MethodError> {
        Ok(Self {
            model: Arc::new(fit_model(method, data)?),
            compiled: data.compiled.clone(),
            topology: data.topology.clone(),
        })
    }

    fn from_model(
        method: &str,
        model: Arc<ShapeModel>,
        data: &TrainingData,
    ) -> Result<Self, MethodError> {
        super::common::check_model(method, &model, data)?;
        Ok(Self {
            model,
            compiled: data.compiled.clone(),
            topology: data.topology.clone(),
        })
    }

    fn targets(
        &self,
        method: &str,
        targets: &[Option<f64>],
    ) -> Result<Vec<Option<Target>>, MethodError> {
        given_targets(method, targets, &self.model.measurement_names)?;
        Ok(targets.iter().map(|t| t.map(Target::exact)).collect())
    }

    fn predict(
        &self,
        method: &str,
        targets: &[Option<f64>],
        config: &PredictConfig,
    ) -> Result<tapeshape_model::Prediction, MethodError> {
        let t = self.targets(method, targets)?;
        self.model
            .predict(&t, self.compiled.as_ref(), &self.topology, config)
            .map_err(|e| predict_err(method, e.to_string()))
    }
}

/// `settings` resolved for `method`, or why not.
fn resolve(method: &str, settings: &PredictSettings) -> Result<PredictConfig, MethodError> {
    settings
        .resolve()
        .map_err(|e| train_err(method, e.to_string()))
}

/// The paper's method (see the module docs).
#[derive(Clone)]
pub struct Ours {
    trained: Trained,
    config: PredictConfig,
}

impl Ours {
    /// Name in tables.
    pub const NAME: &'static str = "ours";

    /// Fits the shape model on `data` (all PCA components) and predicts with
    /// `settings`; errors if they are out of range or the fit fails.
    pub fn fit(data: &TrainingData, settings: PredictSettings) -> Result<Self, MethodError> {
        let config = resolve(Self::NAME, &settings)?;
        Ok(Self {
            trained: Trained::fit(Self::NAME, data)?,
            config,
        })
    }

    /// Uses a model already fitted on `data` (so the three paper variants
    /// share one fit). Errors if its measurement names or vertex count differ
    /// from `data`'s.
    pub fn from_model(
        model: Arc<ShapeModel>,
        data: &TrainingData,
        settings: PredictSettings,
    ) -> Result<Self, MethodError> {
        let config = resolve(Self::NAME, &settings)?;
        Ok(Self {
            trained: Trained::from_model(Self::NAME, model, data)?,
            config,
        })
    }

    /// The prediction settings (`l`, `lambda`, `s`, stopping rules).
    pub fn settings(&self) -> &PredictSettings {
        self.config.settings()
    }

    /// The fitted model.
    pub fn model(&self) -> &Arc<ShapeModel> {
        &self.trained.model
    }

    /// Full prediction with the model's report (stages, plausibility, flipped
    /// triangles), for experiments that need more than the mesh.
    pub fn predict_full(
        &self,
        targets: &[Option<f64>],
    ) -> Result<tapeshape_model::Prediction, MethodError> {
        self.trained.predict(Self::NAME, targets, &self.config)
    }
}

impl Method for Ours {
    fn name(&self) -> &str {
        Self::NAME
    }

    /// The step-2 mesh; `weights` are the step-1 weights (the last point in
    /// the PCA space; step 2 leaves it).
    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let p = self.predict_full(targets)?;
        Ok(MethodOutput {
            vertices: p.vertices,
            weights: Some(p.report.weights_step1),
        })
    }
}

/// The paper's start and step 1 only (see the module docs).
#[derive(Clone)]
pub struct StepOneOnly {
    trained: Trained,
    config: PredictConfig,
}

impl StepOneOnly {
    /// Name in tables.
    pub const NAME: &'static str = "step 1 only";

    /// Fits the shape model on `data`; `settings`' `l`, `s` and step-1
    /// settings apply (step 2's are not used).
    pub fn fit(data: &TrainingData, settings: PredictSettings) -> Result<Self, MethodError> {
        let config = resolve(Self::NAME, &settings)?;
        Ok(Self {
            trained: Trained::fit(Self::NAME, data)?,
            config,
        })
    }

    /// Uses a model already fitted on `data` (see [`Ours::from_model`]).
    pub fn from_model(
        model: Arc<ShapeModel>,
        data: &TrainingData,
        settings: PredictSettings,
    ) -> Result<Self, MethodError> {
        let config = resolve(Self::NAME, &settings)?;
        Ok(Self {
            trained: Trained::from_model(Self::NAME, model, data)?,
            config,
        })
    }

    /// The settings used (their step-2 part is not used).
    pub fn settings(&self) -> &PredictSettings {
        self.config.settings()
    }
}

impl Method for StepOneOnly {
    fn name(&self) -> &str {
        Self::NAME
    }

    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let t = &self.trained;
        let err = |e: tapeshape_model::ModelError| predict_err(Self::NAME, e.to_string());
        let c = &self.config;
        let readings = t
            .model
            .readings(&t.targets(Self::NAME, targets)?, c.readings())
            .map_err(err)?;
        let start = t
            .model
            .start(&readings, c.start(), t.compiled.as_ref())
            .map_err(err)?;
        let step1 = t
            .model
            .step1(
                &readings,
                &start,
                c.step1(),
                c.rounds(),
                t.compiled.as_ref(),
                &|_: &PredictProgress| Control::Continue,
            )
            .map_err(err)?;
        Ok(MethodOutput {
            vertices: step1.vertices,
            weights: Some(step1.weights),
        })
    }
}

/// Feature analysis alone (see the module docs).
#[derive(Clone)]
pub struct FeatureAnalysis {
    trained: Trained,
    /// Clamp each normalised weight to `[-l, l]` (`None`: no clamp, as Allen et al.).
    pub clamp: Option<f64>,
}

impl FeatureAnalysis {
    /// Name in tables.
    pub const NAME: &'static str = "feature analysis";

    /// Fits the shape model on `data`.
    pub fn fit(data: &TrainingData, clamp: Option<f64>) -> Result<Self, MethodError> {
        Ok(Self {
            trained: Trained::fit(Self::NAME, data)?,
            clamp,
        })
    }

    /// Uses a model already fitted on `data` (see [`Ours::from_model`]).
    pub fn from_model(
        model: Arc<ShapeModel>,
        data: &TrainingData,
        clamp: Option<f64>,
    ) -> Result<Self, MethodError> {
        Ok(Self {
            trained: Trained::from_model(Self::NAME, model, data)?,
            clamp,
        })
    }
}

impl Method for FeatureAnalysis {
    fn name(&self) -> &str {
        Self::NAME
    }

    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError> {
        let model = &self.trained.model;
        let given = given_targets(Self::NAME, targets, &model.measurement_names)?;
        let observed: Vec<(usize, f64, f64)> = given.iter().map(|&(j, x)| (j, x, 0.0)).collect();
        let mut w = model
            .start_weights(&observed)
            .map_err(|e| predict_err(Self::NAME, e.to_string()))?;
        if let Some(l) = self.clamp {
            for x in &mut w {
                *x = x.clamp(-l, l);
            }
        }
        let vertices = model
            .shape(&w)
            .map_err(|e| predict_err(Self::NAME, e.to_string()))?;
        Ok(MethodOutput {
            vertices,
            weights: Some(w),
        })
    }
}
