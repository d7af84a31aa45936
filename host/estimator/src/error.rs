//! The estimator's one error type: what was wrong and what to do.

use tapeshape_measure::MeasureError;
use tapeshape_model::{ModelError, SettingsError};
use tapeshape_population::DatasetError;

/// Errors of training and prediction. The message says what was wrong and
/// what to do.
#[derive(Debug, thiserror::Error)]
pub enum PredictError {
    /// A measurement name the model does not know.
    #[error("unknown measurement `{name}`{suggestion}")]
    UnknownMeasurement {
        /// The name given.
        name: String,
        /// "; did you mean `x`?" or a pointer to the list.
        suggestion: String,
    },
    /// A value that is no length (zero, negative, NaN, infinite).
    #[error("{0}")]
    BadValue(String),
    /// A value that only makes sense in another unit, or far outside the population.
    #[error("{0}")]
    OutOfRange(String),
    /// Readings that contradict each other.
    #[error("the readings contradict each other: {0}")]
    Contradiction(String),
    /// Malformed input (syntax, duplicates, files).
    #[error("{0}")]
    Input(String),
    /// A prediction option out of its range ("lambda must lie in [0, 1], got 2").
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The prediction was cancelled by its observer
    /// ([`Estimator::predict_observed`]); the text names the stage.
    #[error("estimate cancelled ({0})")]
    Cancelled(String),
    /// Training failed or was asked for something impossible.
    #[error("training: {0}")]
    Training(String),
    /// The model (file, fit or prediction) failed.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// A measurement set could not be loaded or compiled.
    #[error(transparent)]
    Measure(#[from] MeasureError),
    /// A dataset problem.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// I/O with the file it concerns.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The error.
        #[source]
        source: std::io::Error,
    },
}
