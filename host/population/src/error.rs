//! Why making, reading or writing a dataset failed: one error type for the
//! whole crate, each variant naming the file or setting involved.

use std::path::PathBuf;

/// Errors making, reading or writing datasets.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// File system error with the path involved.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// Not a dataset file, or a damaged one.
    #[error("{path} is not a readable tapeshape dataset: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// An imported mesh does not match the others.
    #[error("{path}: {message}")]
    Import {
        /// The offending file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// Bad settings.
    #[error("invalid setting: {0}")]
    Settings(String),
    /// The body generator failed.
    #[error(transparent)]
    Body(#[from] tapeshape_body::BodyError),
    /// A measurement failed.
    #[error(transparent)]
    Measure(#[from] tapeshape_measure::MeasureError),
    /// ANSUR II could not be read.
    #[error(transparent)]
    Ansur(#[from] crate::ansur::AnsurError),
    /// The generator fit failed.
    #[error(transparent)]
    Fit(#[from] crate::fit::FitError),
}
