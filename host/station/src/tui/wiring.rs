//! [`Services`] over the station's engine modules: the reading check is
//! [`crate::check`], the estimate (its own thread, progress, cancel) and the
//! export (OBJ/PLY/GLB + JSON report) are [`crate::estimate`].
//!
//! Why a separate module: the app and the runner know only the
//! [`Services`] trait; this is the one place that knows which module does
//! the work, so swapping one (or a test fixture) touches nothing else.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tapeshape_engine::predict::{Engine, Estimate, PredictOptions, Unit};
use tapeshape_mesh::Vec3;

use crate::check::{check_reading_with_tolerance, Flag};
use crate::estimate;
use crate::store::{Session, SessionId};
use crate::tui::services::{
    Cancel, CheckOutcome, CheckRequest, EstimateEvent, EstimateJob, EstimateSummary, ExportFormat,
    ProgressSink, ResultRow, Services, Silhouettes, Stage,
};

/// The station's services: the embedded default model.
#[derive(Default)]
pub struct StationServices {
    /// Last estimate per session (mesh and report), for export.
    last: Arc<Mutex<HashMap<SessionId, Arc<Estimate>>>>,
    /// The operator's reading uncertainty (standard deviation, metres), or
    /// `None` for each measurement's ISO 20685-1 class (a skilled measurer).
    reading_tolerance: Option<f64>,
}

impl StationServices {
    /// Services over the embedded default model (loaded on first use).
    pub fn new() -> Self {
        Self::default()
    }

    /// The same, judging and fitting every reading with this standard
    /// uncertainty (metres): a novice's readings (about 1 cm) are then
    /// neither flagged for an expert's few millimetres of disagreement nor
    /// fitted as if exact (see docs/results/demo-e2e.md: with the ansur
    /// set, 1 cm of reading noise gave 36 mm mean vertex distance fitted as
    /// exact and 15 mm with the tolerance stated).
    pub fn with_reading_tolerance(tolerance_m: Option<f64>) -> Self {
        Self {
            reading_tolerance: tolerance_m,
            ..Self::default()
        }
    }
}

/// Parses `--reading-tolerance MM` (millimetres, positive and finite) into
/// metres.
pub fn reading_tolerance_m(mm: Option<f64>) -> anyhow::Result<Option<f64>> {
    match mm {
        None => Ok(None),
        Some(v) if v.is_finite() && v > 0.0 && v <= 100.0 => Ok(Some(v / 1000.0)),
        Some(v) => anyhow::bail!(
            "--reading-tolerance must be a number of millimetres between 0 and 100 \
             (about 10 for a novice with a tape), got {v}"
        ),
    }
}

fn engine() -> Result<&'static Engine, String> {
    Engine::default_model().map_err(|e| format!("loading the shape model: {e}"))
}

impl Services for StationServices {
    fn check(&self, req: &CheckRequest) -> CheckOutcome {
        let engine = match engine() {
            Ok(e) => e,
            Err(e) => {
                return CheckOutcome {
                    note: Some(format!("{} not checked: {e}", req.name)),
                    ..CheckOutcome::default()
                }
            }
        };
        let taken: Vec<(&str, f64)> = req
            .others
            .iter()
            .map(|(n, mm)| (n.as_str(), mm / 1000.0))
            .collect();
        let shown = if req.tape_inches { Unit::In } else { Unit::Cm };
        match check_reading_with_tolerance(
            engine,
            &taken,
            (&req.name, req.value_mm / 1000.0),
            shown,
            self.reading_tolerance,
        ) {
            Ok(c) => {
                let slip = c.unit_slip.is_some();
                match c.flag {
                    Flag::Ok => CheckOutcome::default(),
                    Flag::Warn => CheckOutcome {
                        note: Some(c.message),
                        ..CheckOutcome::default()
                    },
                    Flag::Flag if slip => CheckOutcome {
                        unit_slip: Some(c.message),
                        ..CheckOutcome::default()
                    },
                    Flag::Flag => CheckOutcome {
                        flag: Some(c.message),
                        ..CheckOutcome::default()
                    },
                }
            }
            // An unknown name (a custom set's measurement the model lacks)
            // cannot be checked; the reading is kept and the operator told.
            Err(e) => CheckOutcome {
                note: Some(format!("{} not checked: {e}", req.name)),
                ..CheckOutcome::default()
            },
        }
    }

    fn start_estimate(&self, job: EstimateJob, sink: ProgressSink) -> Box<dyn Cancel> {
        sink(EstimateEvent::Stage {
            stage: Stage::Check,
            fraction: 0.0,
        });
        let engine = match engine() {
            Ok(e) => e,
            Err(e) => {
                sink(EstimateEvent::Failed(e));
                return Box::new(NoCancel);
            }
        };
        let readings: Vec<estimate::Reading> = job
            .readings
            .iter()
            .map(|(name, mm)| estimate::Reading {
                tolerance: self.reading_tolerance,
                ..estimate::Reading::new(name.clone(), mm / 1000.0)
            })
            .collect();
        let t0 = Instant::now();
        let running = match estimate::start_estimate(engine, &readings, &PredictOptions::default())
        {
            Ok(j) => j,
            Err(e) => {
                sink(EstimateEvent::Failed(e.to_string()));
                return Box::new(NoCancel);
            }
        };
        let cancel = running.cancel_handle();
        let last = self.last.clone();
        let session = job.session;
        // Forwards the job's progress to the sink, then its outcome.
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
                        let summary = summarise(session, &est, t0.elapsed().as_secs_f64());
                        last.lock()
                            .unwrap_or_else(|e| e.into_inner())
                            .insert(session, Arc::new(est));
                        EstimateEvent::Done(Box::new(summary))
                    }
                    Err(estimate::EstimateError::Cancelled(_)) => EstimateEvent::Cancelled,
                    Err(e) => EstimateEvent::Failed(e.to_string()),
                };
                sink(ev);
            });
        if let Err(e) = watcher {
            // The job is dropped with the closure, which cancels it.
            tracing::error!("starting the estimate's progress thread: {e}");
        }
        Box::new(cancel)
    }

    fn export(
        &self,
        session: &Session,
        format: ExportFormat,
        folder: &Path,
    ) -> Result<Vec<PathBuf>, String> {
        let est = self
            .last
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(&session.id)
            .cloned()
            .ok_or_else(|| {
                format!(
                    "session {} has no estimate yet: estimate it first",
                    session.id
                )
            })?;
        let info = estimate::SessionInfo {
            customer_id: session.customer_id.clone(),
            session_id: session.id.0,
            set: session.measurement_set.clone().unwrap_or_default(),
            exported_at_ms: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_millis() as i64)
                .unwrap_or(0),
        };
        let format = match format {
            ExportFormat::Obj => estimate::MeshFormat::Obj,
            ExportFormat::Ply => estimate::MeshFormat::Ply,
            ExportFormat::Glb => estimate::MeshFormat::Glb,
        };
        estimate::export(&est, &info, folder, &[format]).map_err(|e| e.to_string())
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

/// The interface's view of an estimate.
pub fn summarise(session: SessionId, est: &Estimate, seconds: f64) -> EstimateSummary {
    let p = &est.report.prediction;
    let rows = p
        .measurements
        .iter()
        .filter_map(|m| {
            Some(ResultRow {
                name: m.name.clone(),
                target_mm: m.target_mm?,
                achieved_mm: m.step2_mm.or(m.step1_mm)?,
            })
        })
        .collect();
    let pl = &p.plausibility;
    EstimateSummary {
        session,
        rows,
        plausibility: format!(
            "{:?} body (Mahalanobis {:.1}), readings {:?} ({:.1})",
            pl.label, pl.mahalanobis, pl.measurements_label, pl.measurements_mahalanobis
        )
        .to_lowercase(),
        warnings: est.report.warnings.clone(),
        silhouettes: silhouettes(&est.mesh.vertices),
        seconds,
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
