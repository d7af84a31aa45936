//! The boundary between the interface and the work it asks for: checking a
//! captured reading and estimating (and exporting) a body.
//!
//! Why a boundary: the interface thread must never block on the engine
//! (an estimate takes a fraction of a second to seconds), and the checks and
//! estimates have their own modules and tests (`crate::check`,
//! `crate::estimate`). The app only sees the small, plain types below; the
//! runner implements [`Services`] over the real modules and tests implement
//! it with fixtures.

use std::path::PathBuf;
use std::sync::Arc;

use crate::store::SessionId;

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
    /// The tape showed inches when the reading was taken (for messages and
    /// unit slips).
    pub tape_inches: bool,
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
pub struct EstimateJob {
    /// The session.
    pub session: SessionId,
    /// Readings (name, millimetres).
    pub readings: Vec<(String, f64)>,
}

/// A stage of the estimate: the engine's (one type from the model up).
pub use tapeshape_engine::predict::PredictStage as Stage;

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
    /// Finished.
    Done(Box<EstimateSummary>),
    /// Refused or failed: the message says why and what to do.
    Failed(String),
    /// Cancelled on request.
    Cancelled,
}

/// Mesh formats for export.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ExportFormat {
    /// Wavefront OBJ.
    Obj,
    /// Stanford PLY.
    Ply,
    /// Binary glTF.
    Glb,
}

impl ExportFormat {
    /// Every format, in the order the operator cycles through them.
    pub const ALL: [ExportFormat; 3] = [ExportFormat::Glb, ExportFormat::Obj, ExportFormat::Ply];

    /// File extension (also the label).
    pub fn ext(self) -> &'static str {
        match self {
            ExportFormat::Obj => "obj",
            ExportFormat::Ply => "ply",
            ExportFormat::Glb => "glb",
        }
    }
}

/// Sink for estimate progress (the runner turns it into app events).
pub type ProgressSink = Box<dyn Fn(EstimateEvent) + Send + Sync>;

/// Handle of a running estimate.
pub trait Cancel: Send {
    /// Asks the estimate to stop; it then reports [`EstimateEvent::Cancelled`].
    fn cancel(&self);
}

/// The work the interface asks for. Implemented by the runner over the
/// engine modules; tests use fixtures.
pub trait Services: Send + Sync {
    /// Checks one reading against the others (quick: called on the runner's
    /// thread after each capture).
    fn check(&self, request: &CheckRequest) -> CheckOutcome;

    /// Starts an estimate off the interface thread; progress goes to `sink`.
    fn start_estimate(&self, job: EstimateJob, sink: ProgressSink) -> Box<dyn Cancel>;

    /// Exports the last estimate of `session` as `format` plus the JSON
    /// report into `folder`; returns the files written.
    fn export(
        &self,
        session: &crate::store::Session,
        format: ExportFormat,
        folder: &std::path::Path,
    ) -> Result<Vec<PathBuf>, String>;
}

/// Shared handle to the services.
pub type SharedServices = Arc<dyn Services>;
