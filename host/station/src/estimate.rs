//! Estimating a customer's body off the interface thread, and exporting it.
//!
//! Why a thread and a channel: an estimate takes a fraction of a second to a
//! few seconds (more on a loaded kiosk), and the terminal interface must keep
//! drawing, reading keys and talking to the tape meanwhile. [`start_estimate`]
//! runs [`Estimator::predict_observed`] on its own thread; the interface polls
//! [`EstimateJob::progress`] for stage and fraction and may
//! [`EstimateJob::cancel`] at any time (the estimator stops within one objective
//! evaluation, a few milliseconds). The channel is `std::sync::mpsc`, so a
//! caller needs no async runtime.
//!
//! [`export`] writes the body as OBJ / PLY (station frame: Z up, +Y front,
//! +X the body's right, metres) and GLB (glTF's Y-up frame, metres, converted
//! by `tapeshape_mesh::io`), plus a JSON report of the session (customer,
//! session, set, each reading's target / achieved / error in mm, the
//! capture-time check, plausibility, warnings, model, timings, and the units
//! and frames stated), each written to a temporary name and renamed. The
//! report is also what the station stores with the estimate
//! ([`ExportReport`] reads back from its JSON), so a body estimated before a
//! restart is exported again after it without estimating again
//! ([`export_report`]).
//!
//! [`card`] makes the customer's card (a PDF) of an estimate; [`sizes`]
//! the size per garment on a store's chart.
//!
//! Layer: a service (with `crate::check`), over the estimator; it knows nothing
//! of sessions, screens or the store.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, TryRecvError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tapeshape_common::fs::write_atomic;
use tapeshape_estimator::{
    Control, Estimate, Estimator, Input, Inputs, Length, PredictError, PredictOptions,
    PredictProgress, PredictStage, Unit,
};
use tapeshape_mesh::io::{write_glb, write_obj, write_ply, MeshIoError, PlyPrecision};
use tapeshape_mesh::Mesh;

/// A tape reading as the estimator takes it: `metres` as the tape shows it
/// (centimetres, so that a unit slip is explained in the tape's unit), with
/// its standard uncertainty in metres (`None`: the measurement's ISO class).
pub fn tape_input(name: impl Into<String>, metres: f64, tolerance: Option<f64>) -> Input {
    Input {
        name: name.into(),
        value: Length {
            metres,
            unit: Unit::Cm,
            unit_typed: true,
            number: metres * 100.0,
        },
        tolerance,
    }
}

/// A progress report of a running estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// The stage (check, start, step 1, step 2, done).
    pub stage: PredictStage,
    /// Share of the estimate done, 0 to 1, non-decreasing over one job.
    pub fraction: f64,
}

/// Why an estimate produced no body.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The operator cancelled it.
    #[error("estimate cancelled ({0})")]
    Cancelled(String),
    /// The estimator refused the readings or failed; the message says why and
    /// what to do.
    #[error(transparent)]
    Predict(PredictError),
    /// The estimating thread died (a bug): the readings are untouched.
    #[error("the estimate failed unexpectedly ({0}); the readings are kept, try again")]
    Panicked(String),
}

impl From<PredictError> for EstimateError {
    fn from(e: PredictError) -> Self {
        match e {
            PredictError::Cancelled(s) => Self::Cancelled(s),
            e => Self::Predict(e),
        }
    }
}

/// Asks a running estimate to stop; cloneable, usable from any thread.
#[derive(Debug, Clone, Default)]
pub struct CancelHandle(Arc<AtomicBool>);

impl CancelHandle {
    /// Asks the estimate to stop (it then ends with [`EstimateError::Cancelled`]).
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// Whether cancelling was asked for.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

/// A running estimate (see the module docs).
#[derive(Debug)]
pub struct EstimateJob {
    progress: Receiver<Progress>,
    cancel: CancelHandle,
    thread: Option<JoinHandle<Result<Estimate, EstimateError>>>,
}

/// Progress reports closer than this in fraction are merged (a stage change
/// is always reported), so the channel carries a few hundred at most.
const MIN_STEP: f64 = 0.005;

/// Starts estimating a body from `inputs` on a new thread with
/// `options` (the pipeline and the paper's l, lambda, s). `estimator` is any shared handle to an estimator
/// (`Estimator::default_model()` gives a `&'static Estimator`; an `Arc<Estimator>`
/// works too).
///
/// The readings are checked before the thread starts (so a typo fails at
/// once): a value or tolerance that is not a positive finite length is an
/// error ([`Inputs`] already refuses a name given twice); the estimator's own
/// checks (unknown names, unit slips, contradictions) run on the thread and
/// end the job with [`EstimateError::Predict`].
pub fn start_estimate<E>(
    estimator: E,
    inputs: &Inputs,
    options: &PredictOptions,
) -> Result<EstimateJob, EstimateError>
where
    E: std::ops::Deref<Target = Estimator> + Send + 'static,
{
    check_inputs(inputs)?;
    let inputs = inputs.clone();
    let options = options.clone();
    let (tx, rx) = mpsc::channel();
    let cancel = CancelHandle::default();
    let flag = cancel.clone();
    let thread = std::thread::Builder::new()
        .name("tapeshape-estimate".into())
        .spawn(move || {
            let last: std::cell::Cell<Option<Progress>> = std::cell::Cell::new(None);
            let observer = |p: &PredictProgress| {
                if flag.is_cancelled() {
                    return Control::Cancel;
                }
                let now = Progress {
                    stage: p.stage,
                    fraction: p.fraction(),
                };
                let send = match last.get() {
                    None => true,
                    Some(prev) => {
                        prev.stage != now.stage || now.fraction - prev.fraction >= MIN_STEP
                    }
                };
                if send {
                    last.set(Some(now));
                    // A receiver that went away just stops listening.
                    let _ = tx.send(now);
                }
                Control::Continue
            };
            Ok(estimator.predict_observed(&inputs, &options, &observer)?)
        })
        .map_err(|e| EstimateError::Panicked(format!("could not start a thread: {e}")))?;
    Ok(EstimateJob {
        progress: rx,
        cancel,
        thread: Some(thread),
    })
}

fn check_inputs(inputs: &Inputs) -> Result<(), EstimateError> {
    for r in &inputs.readings {
        let metres = r.value.metres;
        if !(metres.is_finite() && metres > 0.0) {
            return Err(PredictError::BadValue(format!(
                "{} is {metres} m: a length must be positive and finite; measure it again",
                r.name
            ))
            .into());
        }
        if let Some(t) = r.tolerance {
            if !(t.is_finite() && t > 0.0) {
                return Err(PredictError::BadValue(format!(
                    "the tolerance of {} is {t} m: it must be a positive length",
                    r.name
                ))
                .into());
            }
        }
    }
    Ok(())
}

impl EstimateJob {
    /// The progress reports that arrived since the last call (non-blocking).
    pub fn progress(&self) -> Vec<Progress> {
        let mut out = Vec::new();
        loop {
            match self.progress.try_recv() {
                Ok(p) => out.push(p),
                Err(TryRecvError::Empty | TryRecvError::Disconnected) => return out,
            }
        }
    }

    /// Waits up to `timeout` for the next progress report; `None` when none
    /// came (or the job has ended and every report was taken).
    pub fn next_progress(&self, timeout: Duration) -> Option<Progress> {
        self.progress.recv_timeout(timeout).ok()
    }

    /// A handle that cancels this job from anywhere.
    pub fn cancel_handle(&self) -> CancelHandle {
        self.cancel.clone()
    }

    /// Asks the job to stop; [`EstimateJob::wait`] then returns
    /// [`EstimateError::Cancelled`] (unless the body was already done).
    pub fn cancel(&self) {
        self.cancel.cancel();
    }

    /// Whether the thread has finished (the result is ready).
    pub fn is_finished(&self) -> bool {
        self.thread.as_ref().is_none_or(JoinHandle::is_finished)
    }

    /// Waits for the result.
    pub fn wait(mut self) -> Result<Estimate, EstimateError> {
        let Some(thread) = self.thread.take() else {
            return Err(EstimateError::Panicked(
                "the result was already taken".into(),
            ));
        };
        match thread.join() {
            Ok(r) => r,
            Err(panic) => Err(EstimateError::Panicked(
                panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "panic".into()),
            )),
        }
    }
}

impl Drop for EstimateJob {
    /// A job dropped unfinished is cancelled (its thread ends on its own).
    fn drop(&mut self) {
        if self.thread.is_some() {
            self.cancel.cancel();
        }
    }
}

/// A mesh file name ends in neither `.obj`, `.ply` nor `.glb`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: unknown mesh format '{ext}': name the output .obj, .ply or .glb", path = .path.display())]
pub struct UnknownMeshFormat {
    /// The file name given.
    pub path: PathBuf,
    /// Its extension.
    pub ext: String,
}

/// A mesh file format the station writes (the one name for it: exports,
/// `tapeshape predict -o`, the result screen's format choice).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub enum MeshFormat {
    /// Wavefront OBJ (station frame, metres).
    Obj,
    /// Binary PLY, f64 coordinates (station frame, metres).
    Ply,
    /// Binary glTF 2.0 (glTF frame: Y up, +Z front, metres).
    Glb,
}

impl MeshFormat {
    /// Every format.
    pub const ALL: [MeshFormat; 3] = [MeshFormat::Obj, MeshFormat::Ply, MeshFormat::Glb];

    /// File extension.
    pub fn ext(self) -> &'static str {
        match self {
            MeshFormat::Obj => "obj",
            MeshFormat::Ply => "ply",
            MeshFormat::Glb => "glb",
        }
    }

    /// The format a file name asks for, by its extension (any case).
    pub fn from_path(path: &Path) -> Result<MeshFormat, UnknownMeshFormat> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .unwrap_or_default();
        MeshFormat::ALL
            .into_iter()
            .find(|f| f.ext() == ext)
            .ok_or_else(|| UnknownMeshFormat {
                path: path.to_path_buf(),
                ext,
            })
    }

    /// Writes `mesh` to `path` in this format (atomically: a temporary
    /// name, then renamed). PLY keeps f64 coordinates.
    pub fn write(self, mesh: &Mesh, path: &Path) -> Result<(), MeshIoError> {
        match self {
            MeshFormat::Obj => write_obj(mesh, path),
            MeshFormat::Ply => write_ply(mesh, path, PlyPrecision::F64),
            MeshFormat::Glb => write_glb(mesh, path),
        }
    }
}

/// Who and what an export is for (goes into the report and file names).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionInfo {
    /// Opaque customer id.
    pub customer_id: String,
    /// Session id in the store.
    pub session_id: i64,
    /// Measurement set of the session.
    pub set: String,
    /// When the export was made, ms since the Unix epoch (UTC).
    pub exported_at_ms: i64,
}

/// Why an export failed; nothing half-written is left under a final name.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The folder could not be created.
    #[error("cannot create the export folder {}: {source}; choose another folder", .path.display())]
    Folder {
        /// The folder.
        path: PathBuf,
        /// The error.
        #[source]
        source: std::io::Error,
    },
    /// Writing a mesh failed.
    #[error("writing {}: {source}", .path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        #[source]
        source: MeshIoError,
    },
    /// Writing the report failed.
    #[error("writing {}: {source}", .path.display())]
    WriteReport {
        /// The report file.
        path: PathBuf,
        /// What went wrong.
        #[source]
        source: std::io::Error,
    },
    /// The report could not be encoded as JSON.
    #[error("encoding the report {}: {source}", .path.display())]
    Encode {
        /// The report file.
        path: PathBuf,
        /// What went wrong.
        #[source]
        source: serde_json::Error,
    },
}

/// One given measurement in the report (millimetres).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportMeasurement {
    /// Measurement name.
    pub name: String,
    /// The reading, mm.
    pub target_mm: f64,
    /// Its tolerance, mm (if one was given).
    pub tolerance_mm: Option<f64>,
    /// Measured on the estimated body, mm.
    pub achieved_mm: Option<f64>,
    /// `achieved - target`, mm.
    pub error_mm: Option<f64>,
    /// What the other readings predicted for it, mm.
    pub predicted_mm: Option<f64>,
    /// SD of that prediction, mm.
    pub predicted_sd_mm: Option<f64>,
    /// `(reading - predicted) / sd`.
    pub conditional_z: Option<f64>,
    /// Recorded, not fitted: an ANSUR II dimension the standing body model
    /// cannot take as ANSUR defines it (the estimator's
    /// `priors::CANNOT_FOLLOW_ANSUR`); `achieved_mm` is the body's own value.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub recorded_only: bool,
}

/// The plausibility part of the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportPlausibility {
    /// "Typical", "Unusual" or "Implausible" for the readings.
    pub readings: String,
    /// Mahalanobis distance of the readings.
    pub readings_mahalanobis: f64,
    /// Its chi-square quantile.
    pub readings_quantile: f64,
    /// The same for the body's shape weights.
    pub shape: String,
    /// Mahalanobis distance of the shape weights.
    pub shape_mahalanobis: f64,
    /// RMS distance of the body from the learned shape space, mm.
    pub out_of_space_rms_mm: f64,
}

/// Stage timings, milliseconds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportTimings {
    /// Input checks.
    pub check_ms: f64,
    /// Start weights.
    pub start_ms: f64,
    /// Step 1.
    pub step1_ms: f64,
    /// Step 2.
    pub step2_ms: f64,
    /// Prediction total (checks excluded).
    pub total_ms: f64,
}

/// The JSON report [`export`] writes, and the station stores with the
/// estimate (then with no files and `exported_at_ms` 0). The parts the
/// estimator owns (`model`, `estimator`) are kept as JSON values, so that a report
/// stored by one version of the program reads back in another.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExportReport {
    /// Always "tapeshape estimate report".
    pub format: String,
    /// Report format version (1).
    pub version: u32,
    /// Units of every number and file.
    pub units: String,
    /// Coordinate frames of the mesh files.
    pub frames: String,
    /// The session.
    pub session: SessionInfo,
    /// Each reading given, in the model's order.
    pub measurements: Vec<ReportMeasurement>,
    /// The set's other measurements, measured on the body (name, mm).
    pub measured_not_given: Vec<(String, f64)>,
    /// Plausibility of the readings and the body.
    pub plausibility: ReportPlausibility,
    /// Everything the operator or an engineer should know, in English.
    pub warnings: Vec<String>,
    /// The same warnings coded (`code` and values), for scripts and for
    /// wording them in the operator's language. Empty in reports written
    /// before the codes (their `warnings` stand).
    #[serde(default)]
    pub warning_codes: Vec<tapeshape_estimator::Warning>,
    /// The model used (the estimator's `ModelSummary`).
    pub model: serde_json::Value,
    /// Stage timings.
    pub timings: ReportTimings,
    /// Mesh vertices and triangles.
    pub mesh: (usize, usize),
    /// The files written with this report (names, same folder).
    pub files: Vec<String>,
    /// The estimator's full report (stage values, L-BFGS runs, settings: its
    /// `EstimateReport`).
    pub estimator: serde_json::Value,
    /// The size per garment on the store's chart, when the station has one
    /// (`tapeshape station --chart`; [`sizes`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sizes: Option<serde_json::Value>,
    /// Careful mode (`tapeshape station --careful`): each measurement's
    /// readings round by round, the value kept and the technical error of
    /// measurement, per measurement and for the session
    /// (`crate::session::careful::CarefulReport`); absent for a session
    /// that took each measurement once.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub careful: Option<serde_json::Value>,
}

/// A plausibility label of the estimator's report by its serialised name
/// (`Typical`, `Unusual`, `Implausible`: the estimator's stable word for it),
/// as the report and the interface write it.
fn label_word(label: &impl Serialize) -> String {
    match serde_json::to_value(label) {
        Ok(serde_json::Value::String(s)) => s,
        _ => "unknown".to_string(),
    }
}

/// Plain data as a JSON value. Serialising the estimator's report types cannot
/// fail (no maps with non-string keys, no failing `Serialize`); if it ever
/// did, the report would hold `null` for that part, never lose the station's.
fn json_value(v: &impl Serialize) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or(serde_json::Value::Null)
}

/// Builds the report of `estimate` for `session` (listing `files`).
pub fn report(estimate: &Estimate, session: &SessionInfo, files: Vec<String>) -> ExportReport {
    let r = &estimate.report;
    let p = &r.prediction;
    let checks = |name: &str| r.inputs.iter().find(|c| c.name == name);
    let measurements = p
        .measurements
        .iter()
        .filter_map(|m| {
            let target = m.target_mm?;
            // Entered readings only: a soft target from real people
            // (estimator's `priors`) was fitted but not measured.
            let c = Some(checks(&m.name)?);
            Some(ReportMeasurement {
                name: m.name.clone(),
                target_mm: target,
                tolerance_mm: m.tolerance_mm,
                achieved_mm: m.step2_mm,
                error_mm: m.step2_mm.map(|a| a - target),
                predicted_mm: c.and_then(|c| c.predicted_mm),
                predicted_sd_mm: c.and_then(|c| c.predicted_sd_mm),
                conditional_z: c.and_then(|c| c.conditional_z),
                recorded_only: m.recorded_only,
            })
        })
        .collect();
    let measured_not_given = p
        .measurements
        .iter()
        .filter(|m| m.target_mm.is_none() || checks(&m.name).is_none())
        .filter_map(|m| Some((m.name.clone(), m.step2_mm?)))
        .collect();
    let pl = &p.plausibility;
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    ExportReport {
        format: "tapeshape estimate report".into(),
        version: 1,
        units: "lengths in the report in millimetres (mm); mesh coordinates in metres; times in milliseconds".into(),
        frames: "OBJ and PLY: station frame, Z up, +Y = the body's front, +X = the body's right, feet at z = 0; GLB: glTF frame, +Y up, +Z = the body's front, converted by (x, y, z) -> (-x, z, y)".into(),
        session: session.clone(),
        measurements,
        measured_not_given,
        plausibility: ReportPlausibility {
            readings: label_word(&pl.measurements_label),
            readings_mahalanobis: pl.measurements_mahalanobis,
            readings_quantile: pl.measurements_quantile,
            shape: label_word(&pl.label),
            shape_mahalanobis: pl.mahalanobis,
            out_of_space_rms_mm: pl.out_of_space_rms_mm,
        },
        warnings: r.warnings.iter().map(ToString::to_string).collect(),
        warning_codes: r.warnings.clone(),
        model: json_value(&r.model),
        timings: ReportTimings {
            check_ms: ms(r.check_time),
            start_ms: ms(p.timings.start),
            step1_ms: ms(p.timings.step1),
            step2_ms: ms(p.timings.step2),
            total_ms: ms(p.timings.total),
        },
        mesh: (
            estimate.mesh.vertices.len(),
            estimate.mesh.faces().len(),
        ),
        files,
        estimator: r.to_json().unwrap_or(serde_json::Value::Null),
        sizes: None,
        careful: None,
    }
}

/// The file-name stem of an export: `<customer>-session<id>`, the customer
/// id reduced to letters, digits, `-` and `_` (an opaque id may hold
/// anything, a file name may not).
pub fn file_stem(session: &SessionInfo) -> String {
    let customer: String = session
        .customer_id
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(64)
        .collect();
    let customer = if customer.is_empty() {
        "customer".to_string()
    } else {
        customer
    };
    format!("{customer}-session{}", session.session_id)
}

/// Writes `estimate` into `folder` (created if missing) in each of
/// `formats`, then the JSON report (always, last). Every file is written to
/// a temporary name and renamed; an existing export of the same session is
/// replaced. Returns the paths written, meshes in the order of `formats`,
/// the report last.
pub fn export(
    estimate: &Estimate,
    session: &SessionInfo,
    folder: &Path,
    formats: &[MeshFormat],
) -> Result<Vec<PathBuf>, ExportError> {
    export_report(
        &estimate.mesh,
        report(estimate, session, Vec::new()),
        folder,
        formats,
    )
}

/// Writes `mesh` and `report` (with its `files` replaced by the files
/// written) as [`export`] does: the export of an estimate kept in the store.
/// The files are named after `report.session` ([`file_stem`]).
pub fn export_report(
    mesh: &Mesh,
    mut report: ExportReport,
    folder: &Path,
    formats: &[MeshFormat],
) -> Result<Vec<PathBuf>, ExportError> {
    std::fs::create_dir_all(folder).map_err(|source| ExportError::Folder {
        path: folder.to_path_buf(),
        source,
    })?;
    let stem = file_stem(&report.session);
    let mut written = Vec::new();
    for (i, &f) in formats.iter().enumerate() {
        if formats[..i].contains(&f) {
            continue; // asked twice: written once
        }
        let path = folder.join(format!("{stem}.{}", f.ext()));
        f.write(mesh, &path).map_err(|source| ExportError::Write {
            path: path.clone(),
            source,
        })?;
        written.push(path);
    }
    let report_path = folder.join(format!("{stem}-report.json"));
    report.files = written
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    let json = serde_json::to_vec_pretty(&report).map_err(|source| ExportError::Encode {
        path: report_path.clone(),
        source,
    })?;
    write_atomic(&report_path, &json).map_err(|source| ExportError::WriteReport {
        path: report_path.clone(),
        source,
    })?;
    written.push(report_path);
    Ok(written)
}

pub mod card;
pub mod sizes;

#[cfg(test)]
mod tests;
