//! [`Services`] over the station's modules: the reading check is
//! [`crate::check`], the estimate (its own thread, progress, cancel) and the
//! export (OBJ/PLY/GLB + JSON report) are [`crate::estimate`], and every
//! finished estimate is stored with its session through the session layer
//! ([`Sessions::store_estimate`]), so exports, and the result screen after a
//! restart, come from the store rather than from memory; so does the
//! customer's card ([`stored_card`], `crate::estimate::card`).
//!
//! Why a separate module: the front ends know only the [`Services`] trait;
//! this is the one place that knows which module does the work, so swapping
//! one (or a test fixture) touches nothing else.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use tapeshape_estimator::{Estimate, Estimator, Inputs, PredictOptions};
use tapeshape_mesh::{Mesh, Topology, Vec3};

use crate::check::{check_reading_with_tolerance, Flag};
use crate::estimate::{self, ExportReport, MeshFormat, SessionInfo};
use crate::i18n::{self, tr};
use crate::services::{
    Cancel, CheckOutcome, CheckRequest, EstimateEvent, EstimateRequest, EstimateSummary,
    ProgressSink, ResultRow, ServiceError, Services, Silhouettes, Stage,
};
use crate::session::Sessions;
use crate::store::{Session, SessionId, StoredEstimate};

/// The station's services: the embedded default model, and the session
/// layer that keeps each session's estimate.
#[derive(Debug)]
pub struct StationServices {
    sessions: Sessions,
    /// The operator's reading uncertainty (standard deviation, metres), or
    /// `None` for each measurement's ISO 20685-1 class (a skilled measurer).
    reading_tolerance: Option<f64>,
    /// The store's size chart: the result shows a size per garment.
    chart: Option<std::sync::Arc<tapeshape_sizes::Chart>>,
}

impl StationServices {
    /// Services over the embedded default model (loaded on first use),
    /// storing estimates through `sessions`. With `reading_tolerance_m`
    /// every reading is judged and fitted with this standard uncertainty
    /// (metres): a novice's readings (about 1 cm) are then neither flagged
    /// for an expert's few millimetres of disagreement nor fitted as if
    /// exact (see docs/results/demo-e2e.md: with the ansur set, 1 cm of
    /// reading noise gave 36 mm mean vertex distance fitted as exact and
    /// 15 mm with the tolerance stated). `None`: a skilled measurer.
    pub fn new(sessions: Sessions, reading_tolerance_m: Option<f64>) -> Self {
        Self {
            sessions,
            reading_tolerance: reading_tolerance_m,
            chart: None,
        }
    }

    /// The same services showing sizes from `chart` with every result
    /// (`tapeshape station --chart FILE`).
    pub fn with_chart(mut self, chart: tapeshape_sizes::Chart) -> Self {
        self.chart = Some(std::sync::Arc::new(chart));
        self
    }
}

/// Loads the embedded default model, prepares what its estimates need (the
/// smooth basis of step 2) and estimates one body of the training
/// population's mean `quick` readings, discarded, on a thread of its own,
/// as the station does at start while the operator types the first
/// customer: the first estimate then finds every page of the model and
/// the bases mapped and the allocator's arenas grown, and is about as fast
/// as the tenth (`cargo bench -p tapeshape --bench first_estimate`, 1 s
/// after start: median 34.5 ms against 34.7 for the tenth; without the
/// warm-up estimate 51.0 against 33.2). A model that
/// cannot be loaded is left to the first estimate, which reports the error
/// where the operator sees it. Returns the thread (dropped, it runs on
/// detached); `None` if no thread could be started (the first estimate
/// then loads the model).
pub fn warm_up_in_background() -> Option<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("model-warm-up".into())
        .spawn(|| {
            let Ok(e) = tapeshape_estimator::Estimator::default_model() else {
                return;
            };
            let options = tapeshape_estimator::PredictOptions::default();
            e.warm_up(&options);
            let stats = e.file().model.measurement_stats();
            let mut inputs = tapeshape_estimator::Inputs::new();
            for name in e.set_members("quick").unwrap_or_default() {
                if let Some(&(mean, _)) = e.set().index_of(&name).and_then(|j| stats.get(j)) {
                    let _ = inputs.insert_metres(&name, mean);
                }
            }
            if let Err(err) = e.predict(&inputs, &options) {
                tracing::debug!(error = %err, "the warm-up estimate failed (the first estimate loads what it needs)");
            }
        })
        .ok()
}

/// The body of a stored estimate as binary glTF (Y up, metres), for the
/// chain's hub and its 3D viewer; `None` if it is not on the default
/// model's template (or the model cannot be loaded).
pub fn glb_of(stored: &StoredEstimate) -> Option<Vec<u8>> {
    let estimator = estimator().ok()?;
    if stored.template_sha256 != default_template_sha256(estimator) {
        return None;
    }
    let mesh = Mesh::new(stored.vertices.clone(), estimator.topology().clone()).ok()?;
    tapeshape_mesh::io::glb_bytes(&mesh, "body").ok()
}

/// `--reading-tolerance MM` is not a sensible number of millimetres.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "--reading-tolerance must be a number of millimetres between 0 and 100 \
     (about 10 for a novice with a tape), got {0}"
)]
pub struct BadTolerance(pub f64);

/// Parses `--reading-tolerance MM` (millimetres, positive, finite, at most
/// 100) into metres.
pub fn reading_tolerance_m(mm: Option<f64>) -> Result<Option<f64>, BadTolerance> {
    match mm {
        None => Ok(None),
        Some(v) if v.is_finite() && v > 0.0 && v <= 100.0 => Ok(Some(v / 1000.0)),
        Some(v) => Err(BadTolerance(v)),
    }
}

fn estimator() -> Result<&'static Estimator, ServiceError> {
    Estimator::default_model().map_err(ServiceError::Model)
}

/// SHA-256 (hex) of a template topology: its vertex count and triangles
/// (little-endian u32 indices): what a stored body's vertices belong to.
pub fn template_sha256(topology: &Topology) -> String {
    let faces = topology.faces();
    let mut bytes = Vec::with_capacity(8 + faces.len() * 12);
    bytes.extend_from_slice(&(topology.n_vertices() as u64).to_le_bytes());
    for f in faces {
        for i in f {
            bytes.extend_from_slice(&i.to_le_bytes());
        }
    }
    crate::text::sha256_hex(&bytes)
}

/// [`template_sha256`] of the default model's template, computed once.
fn default_template_sha256(estimator: &Estimator) -> &'static str {
    static SHA: OnceLock<String> = OnceLock::new();
    SHA.get_or_init(|| template_sha256(estimator.topology()))
}

fn session_info(s: &Session, exported_at_ms: i64) -> SessionInfo {
    SessionInfo {
        customer_id: s.customer_id.clone(),
        session_id: s.id.0,
        set: s.measurement_set.clone().unwrap_or_default(),
        exported_at_ms,
    }
}

impl StationServices {
    /// Stores `est` (made from `request` in `seconds`) with its session.
    fn store(
        &self,
        estimator: &Estimator,
        request: &EstimateRequest,
        est: &Estimate,
        seconds: f64,
    ) -> Result<StoredEstimate, ServiceError> {
        let session = self.sessions.store().session(request.session)?;
        let report = estimate::report(est, &session_info(&session, 0), Vec::new());
        let report_json =
            serde_json::to_string(&report).map_err(|source| ServiceError::StoredReport {
                session: request.session,
                source,
            })?;
        let stored = StoredEstimate {
            session_id: request.session,
            made_at_ms: crate::store::now_ms(),
            seconds,
            model_source: est.report.model.source.clone(),
            template_sha256: default_template_sha256(estimator).to_string(),
            vertices: est.mesh.vertices.clone(),
            readings: request
                .readings
                .iter()
                .map(|(n, mm)| (n.clone(), (mm * 10.0).round() as u32))
                .collect(),
            report_json,
        };
        self.sessions.store_estimate(&stored)?;
        Ok(stored)
    }

    fn stored(&self, session: SessionId) -> Result<(StoredEstimate, ExportReport), ServiceError> {
        let stored = self
            .sessions
            .store()
            .estimate(session)?
            .ok_or(ServiceError::NoEstimate(session))?;
        let report = serde_json::from_str(&stored.report_json)
            .map_err(|source| ServiceError::StoredReport { session, source })?;
        Ok((stored, report))
    }
}

impl Services for StationServices {
    fn check(&self, req: &CheckRequest) -> CheckOutcome {
        // The operator's words: the kiosk's name of the measurement, in the
        // chosen language (`ReadingCheck::message` is the line mode's).
        let label = i18n::measurement_label(&req.set, &req.name, &req.name);
        let estimator = match estimator() {
            Ok(e) => e,
            Err(e) => {
                return CheckOutcome {
                    note: Some(tr!(
                        "check-not-checked",
                        name = label.as_str(),
                        error = e.to_string()
                    )),
                    ..CheckOutcome::default()
                }
            }
        };
        let taken: Vec<(&str, f64)> = req
            .others
            .iter()
            .map(|(n, mm)| (n.as_str(), mm / 1000.0))
            .collect();
        match check_reading_with_tolerance(
            estimator,
            &taken,
            (&req.name, req.value_mm / 1000.0),
            req.tape_unit,
            self.reading_tolerance,
        ) {
            Ok(c) => {
                let slip = c.unit_slip.is_some();
                let words = c.message_in(i18n::lang(), &label);
                match c.flag {
                    Flag::Ok => CheckOutcome::default(),
                    Flag::Warn => CheckOutcome {
                        note: Some(words),
                        ..CheckOutcome::default()
                    },
                    Flag::Flag if slip => CheckOutcome {
                        unit_slip: Some(words),
                        ..CheckOutcome::default()
                    },
                    Flag::Flag => CheckOutcome {
                        flag: Some(words),
                        ..CheckOutcome::default()
                    },
                }
            }
            // An unknown name (a custom set's measurement the model lacks)
            // cannot be checked; the reading is kept and the operator told.
            Err(e) => CheckOutcome {
                note: Some(tr!(
                    "check-not-checked",
                    name = label.as_str(),
                    error = e.to_string()
                )),
                ..CheckOutcome::default()
            },
        }
    }

    fn start_estimate(&self, request: EstimateRequest, sink: ProgressSink) -> Box<dyn Cancel> {
        sink(EstimateEvent::Stage {
            stage: Stage::Check,
            fraction: 0.0,
        });
        let estimator = match estimator() {
            Ok(e) => e,
            Err(e) => {
                sink(EstimateEvent::Failed(e.to_string()));
                return Box::new(NoCancel);
            }
        };
        let mut inputs = Inputs::new();
        for (name, mm) in &request.readings {
            let input = estimate::tape_input(name.clone(), mm / 1000.0, self.reading_tolerance);
            if let Err(e) = inputs.push(input) {
                sink(EstimateEvent::Failed(e.to_string()));
                return Box::new(NoCancel);
            }
        }
        inputs.sex = request.sex;
        inputs.kept = request.kept.clone();
        let t0 = Instant::now();
        let running = match estimate::start_estimate(estimator, &inputs, &PredictOptions::default())
        {
            Ok(j) => j,
            Err(e) => {
                sink(EstimateEvent::Failed(e.to_string()));
                return Box::new(NoCancel);
            }
        };
        let cancel = running.cancel_handle();
        let this = StationServices {
            sessions: self.sessions.clone(),
            reading_tolerance: self.reading_tolerance,
            chart: self.chart.clone(),
        };
        // Forwards the job's progress to the sink, then stores the body and
        // reports it.
        let watcher = std::thread::Builder::new()
            .name("estimate-progress".into())
            .spawn(move || {
                loop {
                    match running.next_progress(Duration::from_millis(50)) {
                        Some(p) => sink(EstimateEvent::Stage {
                            stage: p.stage,
                            fraction: p.fraction,
                        }),
                        None if running.is_finished() => {
                            // Reports sent just before the end.
                            for p in running.progress() {
                                sink(EstimateEvent::Stage {
                                    stage: p.stage,
                                    fraction: p.fraction,
                                });
                            }
                            break;
                        }
                        None => {}
                    }
                }
                let ev = match running.wait() {
                    Ok(est) => {
                        let seconds = t0.elapsed().as_secs_f64();
                        match this
                            .store(estimator, &request, &est, seconds)
                            .and_then(|stored| summarise(&stored, this.chart.as_deref()))
                        {
                            Ok(summary) => EstimateEvent::Done(Box::new(summary)),
                            Err(e) => EstimateEvent::Failed(format!(
                                "the body was estimated but could not be stored ({e}); \
                                 estimate again to export it"
                            )),
                        }
                    }
                    Err(estimate::EstimateError::Cancelled(_)) => EstimateEvent::Cancelled,
                    // A refusal the operator acts on, in the operator's
                    // language; other failures keep their English text.
                    Err(estimate::EstimateError::Predict(p)) => EstimateEvent::Failed(
                        crate::warning_text::refusal_text(&p).unwrap_or_else(|| p.to_string()),
                    ),
                    Err(e) => EstimateEvent::Failed(e.to_string()),
                };
                sink(ev);
            });
        if let Err(e) = watcher {
            // The job is dropped with the closure, which cancels it; the
            // sink went with it, so the failure can only be logged.
            tracing::error!("{}", ServiceError::Thread(e));
        }
        Box::new(cancel)
    }

    fn export(
        &self,
        session: SessionId,
        format: MeshFormat,
        folder: &Path,
    ) -> Result<Vec<PathBuf>, ServiceError> {
        let estimator = estimator()?;
        let (stored, mut report) = self.stored(session)?;
        if stored.template_sha256 != default_template_sha256(estimator) {
            return Err(ServiceError::OtherTemplate {
                session,
                model: stored.model_source,
            });
        }
        let mesh = Mesh::new(stored.vertices, estimator.topology().clone()).map_err(|_| {
            ServiceError::OtherTemplate {
                session,
                model: stored.model_source.clone(),
            }
        })?;
        let header = self.sessions.store().session(session)?;
        report.session = session_info(&header, crate::store::now_ms());
        // Careful mode's rounds and TEM, from the readings as stored now.
        let detail = self.sessions.store().open_session(session)?;
        report.careful = self
            .sessions
            .careful_report(&detail)
            .map_err(ServiceError::Session)?
            .and_then(|c| serde_json::to_value(c).ok());
        if let Some(chart) = &self.chart {
            if let Ok(r) = serde_json::from_value::<tapeshape_estimator::EstimateReport>(
                report.estimator.clone(),
            ) {
                let rec = estimate::sizes::sizes(estimator, &r, chart);
                report.sizes = serde_json::to_value(&rec).ok();
            }
        }
        Ok(estimate::export_report(&mesh, report, folder, &[format])?)
    }

    fn card(
        &self,
        session: SessionId,
        unit: tapeshape_estimator::Unit,
        folder: &Path,
    ) -> Result<PathBuf, ServiceError> {
        let (stored, _) = self.stored(session)?;
        let header = self.sessions.store().session(session)?;
        let pdf = stored_card(&stored, &header, self.chart.as_deref(), unit)?;
        let path = folder.join(crate::estimate::card::file_name(Some(session.0)));
        crate::estimate::card::write_card(&path, &pdf)?;
        Ok(path)
    }

    fn stored_result(&self, session: SessionId) -> Result<Option<EstimateSummary>, ServiceError> {
        match self.stored(session) {
            Ok((stored, _)) => summarise(&stored, self.chart.as_deref()).map(Some),
            Err(ServiceError::NoEstimate(_)) => Ok(None),
            Err(e) => Err(e),
        }
    }
}

impl Cancel for estimate::CancelHandle {
    fn cancel(&self) {
        estimate::CancelHandle::cancel(self);
    }
}

/// The cancel handle of an estimate that never started.
struct NoCancel;

impl Cancel for NoCancel {
    fn cancel(&self) {}
}

/// The customer's card (PDF bytes) of the estimate `stored` with `session`
/// (its id, its measurement set, when the body was estimated; nothing of
/// the customer), lengths in `unit`, with the sizes on `chart` if given.
/// `tapeshape session show --card` and the result screen's `p`.
pub fn stored_card(
    stored: &StoredEstimate,
    session: &Session,
    chart: Option<&tapeshape_sizes::Chart>,
    unit: tapeshape_estimator::Unit,
) -> Result<Vec<u8>, ServiceError> {
    let estimator = estimator()?;
    let other_template = || ServiceError::OtherTemplate {
        session: stored.session_id,
        model: stored.model_source.clone(),
    };
    if stored.template_sha256 != default_template_sha256(estimator) {
        return Err(other_template());
    }
    let mesh = Mesh::new(stored.vertices.clone(), estimator.topology().clone())
        .map_err(|_| other_template())?;
    let report: ExportReport =
        serde_json::from_str(&stored.report_json).map_err(|source| ServiceError::StoredReport {
            session: stored.session_id,
            source,
        })?;
    let r: tapeshape_estimator::EstimateReport =
        serde_json::from_value(report.estimator).map_err(|source| ServiceError::StoredReport {
            session: stored.session_id,
            source,
        })?;
    let sizes = chart.map(|c| estimate::sizes::sizes(estimator, &r, c));
    let mut card = crate::estimate::card::Card::new(
        estimator,
        &r,
        mesh,
        session.measurement_set.as_deref(),
        sizes,
    );
    card.session = Some(stored.session_id.0);
    card.made_at_ms = stored.made_at_ms;
    card.unit = unit;
    Ok(crate::estimate::card::card_pdf(&card)?)
}

/// The interface's view of a stored estimate: the station's report (rows,
/// plausibility, warnings) and the body's outlines. The same for an
/// estimate just made and one stored before a restart.
pub fn summarise(
    stored: &StoredEstimate,
    chart: Option<&tapeshape_sizes::Chart>,
) -> Result<EstimateSummary, ServiceError> {
    let report: ExportReport =
        serde_json::from_str(&stored.report_json).map_err(|source| ServiceError::StoredReport {
            session: stored.session_id,
            source,
        })?;
    let rows = report
        .measurements
        .iter()
        .filter_map(|m| {
            Some(ResultRow {
                name: m.name.clone(),
                target_mm: m.target_mm,
                achieved_mm: m.achieved_mm?,
            })
        })
        .collect();
    // Sizes from the estimator's own report kept with the estimate (a
    // report it cannot read shows as one line; the rest of the result
    // stands).
    let sizes = match chart {
        None => Vec::new(),
        Some(chart) => match (
            estimator(),
            serde_json::from_value::<tapeshape_estimator::EstimateReport>(report.estimator.clone()),
        ) {
            (Ok(e), Ok(r)) => estimate::sizes::screen_lines(&estimate::sizes::sizes(e, &r, chart)),
            (Err(err), _) => vec![tr!("sizes-none", error = err.to_string())],
            (_, Err(err)) => vec![tr!("sizes-none-report", error = err.to_string())],
        },
    };
    let pl = &report.plausibility;
    Ok(EstimateSummary {
        session: stored.session_id,
        rows,
        plausibility: tr!(
            "result-plausibility-value",
            shape = plausibility_word(&pl.shape),
            body = format!("{:.1}", pl.shape_mahalanobis),
            readings = plausibility_word(&pl.readings),
            distance = format!("{:.1}", pl.readings_mahalanobis)
        ),
        // Worded in the operator's language from the codes; a report from
        // before the codes keeps its English lines.
        warnings: if report.warning_codes.is_empty() {
            report.warnings
        } else {
            report
                .warning_codes
                .iter()
                .map(crate::warning_text::warning_text)
                .collect()
        },
        silhouettes: silhouettes(&stored.vertices),
        seconds: stored.seconds,
        sizes,
    })
}

/// A plausibility label of the report (`typical`, `unusual`,
/// `implausible`, as the report writes them) in the operator's language; a
/// word the catalogue does not know as the report has it, in lower case.
fn plausibility_word(label: &str) -> String {
    let word = label.to_lowercase();
    match word.as_str() {
        "typical" => tr!("plausibility-typical"),
        "unusual" => tr!("plausibility-unusual"),
        "implausible" => tr!("plausibility-implausible"),
        _ => word,
    }
}

/// Front (x, z) and side (y, z) silhouettes of a body (vertices in metres,
/// station frame), thinned to one point per 5 mm cell: enough for a braille
/// canvas, and small enough to keep in the app's state.
pub fn silhouettes(vertices: &[Vec3]) -> Silhouettes {
    fn thin(points: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
        const CELL: f64 = 0.005;
        let mut seen = std::collections::BTreeSet::new();
        let mut out = Vec::new();
        for (a, b) in points {
            if !(a.is_finite() && b.is_finite()) {
                continue;
            }
            let key = ((a / CELL).round() as i64, (b / CELL).round() as i64);
            if seen.insert(key) {
                out.push((key.0 as f64 * CELL, key.1 as f64 * CELL));
            }
        }
        out
    }
    Silhouettes {
        front: thin(vertices.iter().map(|v| (v[0], v[2]))),
        // Seen from the body's right side (+X): the front (+Y) to the right.
        side: thin(vertices.iter().map(|v| (v[1], v[2]))),
    }
}
