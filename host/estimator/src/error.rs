//! The estimator's one error type: what was wrong and what to do.

use tapeshape_measure::MeasureError;
use tapeshape_model::{ModelError, SettingsError};
use tapeshape_population::DatasetError;

use crate::warning::{AgainstOthers, OutOfRange};

fn out_of_population_text(reading: &OutOfRange, kept: bool) -> String {
    if kept {
        format!("{reading}; kept by the operator, but beyond any person")
    } else {
        reading.to_string()
    }
}

fn contradiction_text(readings: &[AgainstOthers]) -> String {
    let list: Vec<String> = readings.iter().map(ToString::to_string).collect();
    format!(
        "{}; re-take these readings, or keep them if they are right (the estimate then fits them as far as a human-looking body allows)",
        list.join("; ")
    )
}

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
    /// A value that cannot be shared out (a loop total no body with the
    /// other readings has).
    #[error("{0}")]
    OutOfRange(String),
    /// A reading that only makes sense in another unit, or far outside the
    /// population; `kept`: the operator kept it, but it lies beyond any
    /// person.
    #[error("{}", out_of_population_text(.reading, *.kept))]
    OutOfPopulation {
        /// The reading and how far off it is.
        reading: Box<OutOfRange>,
        /// Whether the operator kept it.
        kept: bool,
    },
    /// Readings that contradict each other (the worst first), none kept.
    #[error("the readings contradict each other: {}", contradiction_text(.0))]
    Contradiction(Vec<AgainstOthers>),
    /// Malformed input (syntax, duplicates, files).
    #[error("{0}")]
    Input(String),
    /// A prediction option out of its range ("lambda must lie in [0, 1], got 2").
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The prediction was cancelled by its observer
    /// ([`crate::Estimator::predict_observed`]); the text names the stage.
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
