//! The one interface every method of the evaluation sits behind: the paper's
//! method and each baseline is trained on the same [`TrainingData`] and
//! answers [`Method::predict`] with a mesh in the template topology.
//!
//! Units and frame: metres, station frame (Z up, +Y the body's front, +X the
//! body's right), as everywhere in tapeshape.

use std::sync::Arc;

use tapeshape_measure::CompiledSet;
use tapeshape_mesh::{Topology, Vec3};

/// What every method is trained on: N registered bodies in the template
/// topology and their M measurements of one measurement set.
pub struct TrainingData {
    /// Bodies, `N x V` vertices, metres, station frame.
    pub meshes: Vec<Vec<Vec3>>,
    /// Measurements, `N x M`, metres, in the order of `compiled`'s set.
    pub measurements: Vec<Vec<f64>>,
    /// The measurement set compiled for the template (measures a `V`-vertex body).
    pub compiled: Arc<CompiledSet>,
    /// Shared topology of the bodies.
    pub topology: Arc<Topology>,
}

/// Errors of training or predicting with a method. The message says what
/// was wrong and what to do.
#[derive(Debug, thiserror::Error)]
pub enum MethodError {
    /// Training failed (too few bodies, singular system, ...).
    #[error("training {method}: {message}")]
    Train {
        /// Method name.
        method: String,
        /// What went wrong.
        message: String,
    },
    /// Prediction failed (bad targets, optimiser failure, ...).
    #[error("predicting with {method}: {message}")]
    Predict {
        /// Method name.
        method: String,
        /// What went wrong.
        message: String,
    },
}

/// A body predicted by a method.
#[derive(Debug, Clone)]
pub struct MethodOutput {
    /// `V` vertices in the template topology, metres, station frame.
    pub vertices: Vec<Vec3>,
    /// PCA weights of the result where the method works in the PCA space
    /// (for plausibility), else `None`.
    pub weights: Option<Vec<f64>>,
}

/// A trained method: maps a subset of the set's measurements to a body.
pub trait Method: Send + Sync {
    /// Short name used in tables ("ours", "feature analysis", "SGPLVM", ...).
    fn name(&self) -> &str;
    /// Predicts a body from `targets` (length `M`, metres, `None` = not given).
    fn predict(&self, targets: &[Option<f64>]) -> Result<MethodOutput, MethodError>;
}
