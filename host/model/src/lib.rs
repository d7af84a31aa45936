//! The Wuhrer & Shu shape model: PCA, feature analysis, refinement in two
//! steps.
//!
//! This crate is the paper's method ("Estimating 3D Human Shapes from
//! Measurements", sections Approach and Shape Refinement) as a library, in the
//! scikit-learn style: settings ([`FitSettings`], [`PredictSettings`]) are kept
//! apart from learned state ([`ShapeModel`]); [`ShapeModel::fit`] learns, then
//! [`ShapeModel::predict`] estimates a body from measurements, stage by stage
//! ([`ShapeModel::start`], [`ShapeModel::step1`], [`ShapeModel::step2`], each
//! callable on its own; see [`predict`]).
//!
//! * [`pca`]: PCA of the registered meshes, `X = A W + mu`, computed from the
//!   N x N Gram matrix because N (bodies) is far below 3V (coordinates).
//! * [`regress`]: feature analysis (least-squares map from measurements to
//!   normalised weights) and the joint Gaussian of (measurements, weights),
//!   which gives the start for any subset of measurements and the reading
//!   checks of the station ([`ShapeModel::conditional_measurements`]).
//! * [`energy`]: the paper's energies `E_e`, `E_g`, `E_c` (one per-segment form
//!   over the measurement supports) and `E_s`, with analytic gradients.
//! * [`lbfgs`]: the one L-BFGS (hand-written, allocation-free) with the
//!   paper's stopping rules, a backtracking and a strong-Wolfe line search.
//! * [`refine`]: the objectives of step 1 (over the weights) and step 2 (over
//!   the vertices).
//! * [`map`]: step 1 as a Gauss-Newton MAP estimate (the default).
//! * `kernels` (private): the dense passes over the bases, and clearing the
//!   vector registers' upper halves that AVX-512 code elsewhere leaves in use.
//! * [`predict`]: the prediction as stages (start, step 1, step 2, the clamp,
//!   the shared round driver), its settings and its report ([`Prediction`]).
//! * [`mod@file`]: the versioned model file (see `docs/model-format.md`).
//!
//! Units and frame: the public API takes and returns **metres** in the station
//! frame (Z up, +Y front, +X the body's right). Inside the optimiser everything
//! is in **millimetres** (positions and targets scaled by 1000 on the way in,
//! 1/1000 on the way out): the paper's data were in mm, its energies are in
//! length^4 and its stopping rules are absolute, so `lambda = 0.1` and
//! "gradient norm below 1e-8" only mean what the paper meant in mm.

pub mod energy;
pub mod file;
pub mod gauss_newton;
mod kernels;
pub mod lbfgs;
pub mod map;
pub mod pca;
pub mod predict;
pub mod reduced;
pub mod refine;
pub mod regress;
pub mod smooth_basis;

mod model;

pub use file::{MeasurementSetText, ModelFile, Provenance, TemplateInfo};
pub use lbfgs::{RunInfo, StopRule, Termination};
pub use model::{FitSettings, ShapeModel};
pub use predict::{
    Continuation, Control, EnergyWeighting, MeasurementReport, Measurer, Plausibility,
    PlausibilityLabel, PredictConfig, PredictObserver, PredictProgress, PredictSettings,
    PredictStage, Prediction, PredictionReport, Readings, Round, SettingsError, SmoothFit,
    StageTimings, StartMethod, Step1Clamp, Step1Settings, Step1Solver, Step2Settings, Step2Solver,
    Step2Weighting, Target, Warning, DEFAULT_SMOOTH_MIN_DECREASE_MM, DEFAULT_STEP1_MIN_DECREASE_MM,
};
pub use tapeshape_measure::{Measured, Support, SupportPoint};

/// Millimetres per metre: the optimiser works in mm (see the crate docs).
pub const MM_PER_M: f64 = 1000.0;

/// Errors of the shape model.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    /// The training data are not usable (too few bodies, ragged arrays, ...).
    #[error("invalid training data: {0}")]
    InvalidTraining(String),
    /// An input (targets, vertices, settings) is not usable.
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// A number that must be finite was NaN or infinite.
    #[error("non-finite value: {0}")]
    NonFinite(String),
    /// A linear-algebra step failed (singular covariance, eigen-solver failure).
    #[error("numerical failure: {0}")]
    Numerical(String),
    /// The measurer failed to measure a mesh.
    #[error("measuring the mesh failed: {0}")]
    Measure(String),
    /// Reading or writing a model file failed.
    #[error("model file {path}: {message}")]
    File {
        /// The file.
        path: String,
        /// What went wrong and what to do.
        message: String,
    },
    /// The prediction was cancelled by its [`predict::PredictObserver`]
    /// (nothing was produced; predict again to get a body).
    #[error("prediction cancelled at {0}")]
    Cancelled(String),
    /// I/O error with the file it concerns.
    #[error("model file {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

/// Result type of this crate.
pub type Result<T, E = ModelError> = std::result::Result<T, E>;
