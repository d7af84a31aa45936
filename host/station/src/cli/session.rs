//! `tapeshape session ...`: show one session's readings and stored
//! estimate (its sizes on a chart, its customer's card), export its stored
//! estimate again, close or delete it.

use std::path::PathBuf;

use anyhow::{bail, Context as _};

use crate::cli::Global;
use crate::estimate::MeshFormat;
use crate::services::station::StationServices;
use crate::services::Services as _;
use crate::store::{
    ReadingId, ReadingSource, SessionDetail, SessionId, SessionStatus, StoredEstimate,
};
use crate::text::{format_tenth_mm, format_time_ms};

/// Arguments of `tapeshape session`.
#[derive(clap::Args, Clone, Debug)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub action: Action,
}

/// A mesh format on the command line.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatArg {
    /// Binary glTF (Y up).
    Glb,
    /// Wavefront OBJ (station frame).
    Obj,
    /// Stanford PLY, f64 coordinates (station frame).
    Ply,
}

impl From<FormatArg> for MeshFormat {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Glb => MeshFormat::Glb,
            FormatArg::Obj => MeshFormat::Obj,
            FormatArg::Ply => MeshFormat::Ply,
        }
    }
}

/// `tapeshape session` actions.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum Action {
    /// Print a session, every reading (retakes included) and its stored estimate.
    Show {
        /// Session id (see `tapeshape sessions`).
        id: i64,
        /// A store's size chart (TOML, docs/size-charts.md): also print the
        /// stored estimate's size per garment.
        #[arg(long, value_name = "FILE")]
        chart: Option<PathBuf>,
        /// Write the customer's card of the stored estimate (PDF: the body,
        /// the readings, what was read off the body, the sizes with
        /// --chart; docs/card.md).
        #[arg(long, value_name = "FILE")]
        card: Option<PathBuf>,
        /// Lengths on the card in inches instead of centimetres.
        #[arg(long, requires = "card")]
        inches: bool,
    },
    /// Export the session's stored estimate again (no new estimate): the
    /// body in each format asked for, plus its report.
    Export {
        /// Session id.
        id: i64,
        /// Folder to write into [default: DATA_DIR/exports].
        #[arg(long, value_name = "DIR")]
        dir: Option<PathBuf>,
        /// Mesh formats (comma-separated).
        #[arg(long, value_enum, value_delimiter = ',', default_value = "glb")]
        format: Vec<FormatArg>,
    },
    /// Set a session's status (open, done, abandoned).
    SetStatus {
        /// Session id.
        id: i64,
        /// New status.
        status: SessionStatus,
    },
    /// Delete a session, its readings and its estimate for good.
    Delete {
        /// Session id.
        id: i64,
        /// Confirm the deletion.
        #[arg(long)]
        yes: bool,
    },
}

/// Runs the action.
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    let sessions = global.open_sessions()?;
    match args.action {
        Action::Show {
            id,
            chart,
            card,
            inches,
        } => {
            let store = sessions.store();
            // The chart first: a wrong one is said before anything prints.
            let chart = match &chart {
                Some(p) => {
                    let e = tapeshape_estimator::Estimator::default_model()?;
                    Some((e, crate::estimate::sizes::load_chart(p, e)?))
                }
                None => None,
            };
            let detail = store.open_session(SessionId(id))?;
            let careful = sessions.careful_reading_notes(&detail)?;
            out!("{}", render(&detail, &careful))?;
            if let Some(report) = sessions.careful_report(&detail)? {
                for line in crate::session::careful::lines(&report) {
                    outln!("{line}")?;
                }
            }
            let estimate = store.estimate(SessionId(id))?;
            if let Some(e) = &estimate {
                let kept = sessions.kept_readings(&detail)?;
                outln!("{}", render_estimate(e, &detail, &kept))?;
            }
            if let Some((estimator, chart)) = &chart {
                let Some(e) = &estimate else {
                    bail!("session {id} has no estimate yet: estimate it first, then ask for its sizes");
                };
                let report: crate::estimate::ExportReport = serde_json::from_str(&e.report_json)
                    .with_context(|| format!("reading session {id}'s stored report"))?;
                let r: tapeshape_estimator::EstimateReport =
                    serde_json::from_value(report.estimator).with_context(|| {
                        format!(
                            "session {id}'s stored report has no estimator part: estimate it again"
                        )
                    })?;
                outln!("{}", crate::estimate::sizes::sizes(estimator, &r, chart))?;
            }
            if let Some(path) = &card {
                let Some(e) = &estimate else {
                    bail!(
                        "session {id} has no estimate yet: estimate it first, then make its card"
                    );
                };
                let unit = if inches {
                    tapeshape_estimator::Unit::In
                } else {
                    tapeshape_estimator::Unit::Cm
                };
                let pdf = crate::services::station::stored_card(
                    e,
                    &detail.session,
                    chart.as_ref().map(|c| &c.1),
                    unit,
                )?;
                crate::estimate::card::write_card(path, &pdf)?;
                outln!("card: {}", path.display())?;
            }
        }
        Action::Export { id, dir, format } => {
            let dir = match dir {
                Some(d) => d,
                None => global.data_dir()?.join("exports"),
            };
            let services = StationServices::new(sessions, None);
            let mut files = Vec::new();
            for f in format {
                files.extend(services.export(SessionId(id), f.into(), &dir)?);
            }
            files.sort();
            files.dedup();
            for f in files {
                outln!("exported {}", f.display())?;
            }
        }
        Action::SetStatus { id, status } => {
            sessions.set_status(SessionId(id), status)?;
            outln!("session {id} is now {status}")?;
        }
        Action::Delete { id, yes } => {
            let s = sessions.store().session(SessionId(id))?;
            if !yes {
                bail!(
                    "this would delete session {id} (customer {}) and all its readings; \
                     run again with --yes to confirm",
                    s.customer_id
                );
            }
            sessions.delete(SessionId(id))?;
            outln!("session {id} deleted")?;
        }
    }
    Ok(())
}

/// A session as text: header lines, then one line per reading in commit
/// order; superseded readings (retaken later) are marked, keyboard
/// readings say so. `careful`: what each reading of a careful session was
/// (`Sessions::careful_reading_notes`); such a reading's repeat is not
/// called a retake.
pub fn render(d: &SessionDetail, careful: &[(ReadingId, String)]) -> String {
    let s = &d.session;
    let mut out = format!(
        "session {}  customer {}  status {}  set {}\ncreated {}  updated {}\n",
        s.id,
        s.customer_id,
        s.status,
        s.measurement_set.as_deref().unwrap_or("-"),
        format_time_ms(s.created_at_ms),
        format_time_ms(s.updated_at_ms)
    );
    if let Some(n) = &s.notes {
        out.push_str(&format!("notes: {n}\n"));
    }
    if d.readings.is_empty() {
        out.push_str("no readings\n");
        return out;
    }
    out.push_str(&format!(
        "{:<28}  {:>12}  {:>16}  {:>10}  {:>6}  {:<20}  {}\n",
        "MEASUREMENT", "VALUE", "DEVICE", "BOOT", "SEQ", "RECEIVED (UTC)", "NOTE"
    ));
    for r in &d.readings {
        let mut notes = Vec::new();
        match careful.iter().find(|(id, _)| *id == r.id) {
            Some((_, note)) => notes.push(note.clone()),
            None => {
                if let Some(by) = r.superseded_by {
                    notes.push(format!("retaken (reading {by})"));
                }
            }
        }
        if r.withdrawn_at_ms.is_some() {
            notes.push("undone".to_string());
        }
        let (device, boot, seq) = match &r.source {
            ReadingSource::Tape(t) => (
                format!("{:x}", t.device_id),
                t.boot_id.to_string(),
                t.seq.to_string(),
            ),
            ReadingSource::Keyboard => ("keyboard".to_string(), "-".into(), "-".into()),
        };
        out.push_str(&format!(
            "{:<28}  {:>12}  {:>16}  {:>10}  {:>6}  {:<20}  {}\n",
            r.measurement,
            format_tenth_mm(r.value_tenth_mm),
            device,
            boot,
            seq,
            format_time_ms(r.received_at_ms),
            notes.join(", ")
        ));
    }
    out
}

/// The stored estimate in one line: when, from how many readings, whether
/// the readings changed since (`kept`: what the session stands for now,
/// `Sessions::kept_readings`), and how to export it again.
pub fn render_estimate(e: &StoredEstimate, d: &SessionDetail, kept: &[(String, u32)]) -> String {
    let mut current: Vec<(String, u32)> = kept.to_vec();
    let mut made_from = e.readings.clone();
    current.sort();
    made_from.sort();
    format!(
        "estimate stored {} from {} readings ({:.2} s, {}; {} vertices){}; \
         `tapeshape session export {}` writes it again",
        format_time_ms(e.made_at_ms),
        e.readings.len(),
        e.seconds,
        e.model_source,
        e.vertices.len(),
        if current == made_from {
            ""
        } else {
            "; the readings changed since"
        },
        d.session.id
    )
}

#[cfg(test)]
mod tests {
    use super::render;
    use crate::session::{NewSession, Sessions};

    /// A careful session's repeats are named by their round, not called
    /// retakes; an undone reading says so; a session taken once still
    /// calls a superseded reading "retaken".
    #[test]
    fn session_show_names_careful_repeats_and_retakes_apart() {
        let dir = tempfile::tempdir().unwrap();
        let s = Sessions::open(dir.path()).unwrap();
        let careful = NewSession {
            careful: true,
            ..NewSession::default()
        };
        let c = s.start_new("c-careful", "quick", None, careful).unwrap().id;
        let once = s
            .start_new("c-once", "quick", None, NewSession::default())
            .unwrap()
            .id;
        for id in [c, once] {
            for v in [9_820, 9_930, 9_850] {
                s.capture_keyboard(id, "chest", v).unwrap();
            }
            let undo = s.capture_keyboard(id, "stature", 17_650).unwrap().id;
            s.withdraw(undo).unwrap();
        }
        let text = |id| {
            let d = s.store().open_session(id).unwrap();
            render(&d, &s.careful_reading_notes(&d).unwrap())
        };
        let careful_text = text(c);
        assert!(!careful_text.contains("retaken"), "{careful_text}");
        for note in [
            "careful round 1, reading 1 of 2",
            "careful round 1, reading 2 of 3",
            "careful round 1, reading 3 of 3, kept 985.0 mm",
        ] {
            assert_eq!(
                careful_text.matches(note).count(),
                1,
                "{note}: {careful_text}"
            );
        }
        assert_eq!(careful_text.matches("undone").count(), 1, "{careful_text}");
        let once_text = text(once);
        assert!(!once_text.contains("careful"), "{once_text}");
        assert_eq!(
            once_text.matches("retaken (reading").count(),
            2,
            "{once_text}"
        );
        assert_eq!(once_text.matches("undone").count(), 1, "{once_text}");
    }
}
