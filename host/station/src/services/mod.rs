//! The station's services: the work every front end asks for (checking a
//! captured reading, estimating a body, exporting it, showing a stored
//! estimate), behind one trait with small plain types.
//!
//! Why a boundary: the interface thread must never block on the estimator
//! (an estimate takes a fraction of a second to seconds), and the checks and
//! estimates have their own modules and tests (`crate::check`,
//! `crate::estimate`). A front end only sees [`Services`] and the types
//! below; [`station::StationServices`] implements it over the real modules
//! and the session layer (an estimate is stored with its session as it
//! finishes, and exports are made from what is stored), and the interface's
//! tests answer its effects with fixtures instead.
//!
//! Layer: above the session layer, below the front ends (the kiosk
//! interface, the headless demo, the `session export` command).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use tapeshape_estimator::{PredictError, Unit};

use crate::estimate::{EstimateError, ExportError, MeshFormat};
use crate::store::{SessionId, StoreError};

pub mod station;

/// A reading to check against the readings already taken.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckRequest {
    /// Measurement set of the session (built-in name or file).
    pub set: String,
    /// Name of the reading checked.
    pub name: String,
    /// Its value, millimetres.
    pub value_mm: f64,
    /// The other readings of the session (name, millimetres), in order.
    pub others: Vec<(String, f64)>,
    /// The unit the tape showed when the reading was taken (for messages
    /// and unit slips; a keyboard capture says what the tape showed then).
    pub tape_unit: Unit,
}

/// What the check found. `None` fields mean nothing to say.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CheckOutcome {
    /// The reading is far from what the others predict (or from the
    /// population): the message says by how much; the operator is asked to
    /// measure again.
    pub flag: Option<String>,
    /// The value fits another unit (a tape read in inches, typed as cm).
    pub unit_slip: Option<String>,
    /// Unusual but not flagged ("check it"), or why the reading could not
    /// be checked: shown, the reading is kept.
    pub note: Option<String>,
}

/// What to estimate: one session's accepted readings.
#[derive(Clone, Debug, PartialEq)]
pub struct EstimateRequest {
    /// The session.
    pub session: SessionId,
    /// Readings (name, millimetres).
    pub readings: Vec<(String, f64)>,
    /// The customer's sex, when the operator gave it.
    pub sex: Option<tapeshape_population::ansur::Sex>,
    /// Readings the operator kept after a check flagged them: estimated
    /// with a warning rather than refused.
    pub kept: Vec<String>,
}

/// A stage of the estimate: the estimator's (one type from the model up).
pub use tapeshape_estimator::PredictStage as Stage;

/// The stages the estimating screen lists, in order (`Done` is the result).
pub const STAGES: [Stage; 4] = [Stage::Check, Stage::Start, Stage::Step1, Stage::Step2];

/// Operator words for a stage.
pub fn stage_label(stage: Stage) -> &'static str {
    match stage {
        Stage::Check => "check readings",
        Stage::Start => "first guess (feature analysis)",
        Stage::Step1 => "fit shape space",
        Stage::Step2 => "refine surface",
        Stage::Done => "done",
    }
}

/// One row of the result table.
#[derive(Clone, Debug, PartialEq)]
pub struct ResultRow {
    /// Measurement name.
    pub name: String,
    /// Target (the reading), millimetres.
    pub target_mm: f64,
    /// Measured on the estimated body, millimetres.
    pub achieved_mm: f64,
}

/// Front and side outlines of a body for the terminal: points in metres,
/// station frame (front: (x, z); side: (y, z)), already thinned to what a
/// braille canvas can show.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Silhouettes {
    /// Points (x, z), metres, seen from the front.
    pub front: Vec<(f64, f64)>,
    /// Points (y, z), metres, seen from the body's right side.
    pub side: Vec<(f64, f64)>,
}

/// What an estimate produced, as the interface shows it.
#[derive(Clone, Debug, PartialEq)]
pub struct EstimateSummary {
    /// The session estimated.
    pub session: SessionId,
    /// One row per reading.
    pub rows: Vec<ResultRow>,
    /// Plausibility in words ("typical", "unusual" with its distance).
    pub plausibility: String,
    /// Warnings of the checks and the method.
    pub warnings: Vec<String>,
    /// The body's outlines.
    pub silhouettes: Silhouettes,
    /// Wall time of the estimate, seconds.
    pub seconds: f64,
    /// One line per garment of the store's size chart (empty without a
    /// chart).
    pub sizes: Vec<String>,
}

/// Progress of a running estimate, sent to the app as events.
#[derive(Clone, Debug, PartialEq)]
pub enum EstimateEvent {
    /// A stage started (`fraction` of the whole, 0 to 1).
    Stage {
        /// The stage.
        stage: Stage,
        /// Fraction of the whole done when it started.
        fraction: f64,
    },
    /// Finished (and stored with its session).
    Done(Box<EstimateSummary>),
    /// Refused or failed: the text (a [`ServiceError`]'s) says why and what to do.
    Failed(String),
    /// Cancelled on request.
    Cancelled,
}

/// Why a service could not do what was asked. Every message says what
/// happened and what to do.
#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    /// The embedded shape model could not be loaded.
    #[error("loading the shape model: {0}")]
    Model(#[source] PredictError),
    /// The estimate was refused or failed.
    #[error(transparent)]
    Estimate(#[from] EstimateError),
    /// The session store refused or failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The session's measurement set could not be read (careful mode
    /// needs its allowable errors).
    #[error(transparent)]
    Session(crate::session::SessionError),
    /// Writing the export failed.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// Making or writing the customer's card failed.
    #[error(transparent)]
    Card(#[from] crate::estimate::card::CardError),
    /// The session has no stored estimate.
    #[error("session {0} has no estimate yet: estimate it first")]
    NoEstimate(SessionId),
    /// The stored report does not read (damaged, or from an incompatible program).
    #[error(
        "the stored estimate of session {session} cannot be read ({source}); \
         estimate it again (its readings are kept)"
    )]
    StoredReport {
        /// The session.
        session: SessionId,
        /// Why.
        #[source]
        source: serde_json::Error,
    },
    /// The stored body was made on another template than the model's now.
    #[error(
        "the stored estimate of session {session} was made by {model} on another body template \
         than the model this program uses; estimate it again to export it"
    )]
    OtherTemplate {
        /// The session.
        session: SessionId,
        /// The model that made it.
        model: String,
    },
    /// An operating system thread could not be started.
    #[error("could not start the estimate's thread ({0}); try again")]
    Thread(#[source] std::io::Error),
}

/// Sink for estimate progress (the runner turns it into app events).
pub type ProgressSink = Box<dyn Fn(EstimateEvent) + Send + Sync>;

/// Handle of a running estimate.
pub trait Cancel: Send {
    /// Asks the estimate to stop; it then reports [`EstimateEvent::Cancelled`].
    fn cancel(&self);
}

/// The work the front ends ask for. Implemented over the estimator modules
/// and the session layer by [`station::StationServices`]; tests use fixtures.
pub trait Services: Send + Sync {
    /// Checks one reading against the others (quick: called on a blocking
    /// thread after each capture).
    fn check(&self, request: &CheckRequest) -> CheckOutcome;

    /// Starts an estimate off the caller's thread; progress goes to `sink`,
    /// ending with `Done` once the estimate is stored with its session.
    fn start_estimate(&self, request: EstimateRequest, sink: ProgressSink) -> Box<dyn Cancel>;

    /// Exports the stored estimate of `session` as `format` plus the JSON
    /// report into `folder`; returns the files written.
    fn export(
        &self,
        session: SessionId,
        format: MeshFormat,
        folder: &Path,
    ) -> Result<Vec<PathBuf>, ServiceError>;

    /// Writes the customer's card of the stored estimate of `session`
    /// (`crate::estimate::card`: lengths in `unit`, the sizes when the services have
    /// a chart) into `folder` as `session<ID>-card.pdf`, atomically; returns
    /// the file. The session and its estimate are untouched either way.
    fn card(
        &self,
        session: SessionId,
        unit: tapeshape_estimator::Unit,
        folder: &Path,
    ) -> Result<PathBuf, ServiceError>;

    /// The stored estimate of `session` as the interface shows it, if it
    /// has one (after a restart: without estimating again).
    fn stored_result(&self, session: SessionId) -> Result<Option<EstimateSummary>, ServiceError>;
}

/// Shared handle to the services.
pub type SharedServices = Arc<dyn Services>;
