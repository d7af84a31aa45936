//! The start: feature analysis or the Gaussian conditional, clamped (paper,
//! section Approach).
//!
//! With every measurement given exactly, the start is the paper's feature
//! analysis `w = B [P; 1]` (least squares on the training pairs); with a
//! subset, or with tolerances, it is the Gaussian conditional of the
//! normalised weights on the given readings under the training statistics
//! (tolerances as observation noise), which coincides with feature analysis
//! when everything is given and the training set is large (method notes).
//! Each weight is then clamped to `[-l, l]` ([`super::clamp`]). With the
//! customer's sex, the conditional is that sex's training bodies'
//! ([`crate::sexprior`]).

use tapeshape_measure::Measured;
use tapeshape_mesh::Vec3;

use super::clamp::clamp_weights;
use super::readings::Readings;
use super::settings::StartConfig;
use super::Measurer;
use crate::{ModelError, Result, ShapeModel, MM_PER_M};

/// How the start weights were found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum StartMethod {
    /// Feature analysis `B [P; 1]` (every measurement given, no tolerances).
    FeatureAnalysis,
    /// Gaussian conditional of the weights on the given measurements.
    Conditional,
}

/// The start shape and the given readings measured on it.
#[derive(Debug, Clone)]
pub struct StartShape {
    /// How the weights were found.
    pub method: StartMethod,
    /// Normalised weights (K), clamped.
    pub weights: Vec<f64>,
    /// Components the clamp changed.
    pub clamped: Vec<usize>,
    /// The shape (V vertices, metres, station frame).
    pub vertices: Vec<Vec3>,
    /// The given readings measured on it, in the order of the readings.
    pub measured: Vec<Measured>,
}

impl ShapeModel {
    /// The start of a prediction from `readings` (see the module docs):
    /// weights, clamped to `[-l, l]`, the shape and the readings measured on
    /// it with `measurer`.
    ///
    /// Errors if the statistics cannot be conditioned on the readings, if
    /// the weights are not finite, or if measuring fails.
    pub fn start(
        &self,
        readings: &Readings,
        config: &StartConfig,
        measurer: &dyn Measurer,
    ) -> Result<StartShape> {
        let method = if readings.complete_and_exact() {
            StartMethod::FeatureAnalysis
        } else {
            StartMethod::Conditional
        };
        let observed: Vec<(usize, f64, f64)> = readings
            .iter()
            .map(|g| {
                let tol = match method {
                    StartMethod::FeatureAnalysis => 0.0,
                    StartMethod::Conditional => g.tolerance.unwrap_or(0.0),
                };
                (g.index, g.target_mm / MM_PER_M, tol)
            })
            .collect();
        let mut weights = self.start_weights_for(&observed, config.sex)?;
        if weights.iter().any(|x| !x.is_finite()) {
            return Err(ModelError::NonFinite("start weights".into()));
        }
        let clamped = clamp_weights(&mut weights, config.l);
        let vertices = self.shape_unchecked(&weights);
        let measured = self.measure_checked(measurer, &vertices, &readings.indices())?;
        Ok(StartShape {
            method,
            weights,
            clamped,
            vertices,
            measured,
        })
    }
}
