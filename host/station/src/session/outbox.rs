//! The outbox: each [`Change`] as the event the chain's hub applies
//! (`tapeshape_hub_api::EventBody`), written inside the change's own
//! transaction.
//!
//! Why the event is built here, from the rows inside the transaction: the
//! event must say exactly what was committed (the reading as stored, the
//! reading a retake replaced, the session's header with its consent), and
//! nothing can change between the commit and the event because they are one
//! commit. Erasing a session also redacts its earlier events (their
//! sequence numbers stay, so the hub's record has no gap), so a customer's
//! data does not outlive its session in the outbox.
//!
//! The one thing not in the event is an estimate's body (its GLB, about
//! half a megabyte): the sync task adds it from the stored estimate when it
//! sends the event (see `crate::sync`).

use tapeshape_hub_api as api;

use super::Change;
use crate::store::{Consent, Mark, ReadingSource, SessionId, SessionStatus, StoreError, WriteTx};

/// The wire form of a status.
pub fn status(s: SessionStatus) -> api::Status {
    match s {
        SessionStatus::Open => api::Status::Open,
        SessionStatus::Done => api::Status::Done,
        SessionStatus::Abandoned => api::Status::Abandoned,
    }
}

/// The wire form of a consent.
pub fn consent(c: Consent) -> api::Consent {
    match c {
        Consent::Keep => api::Consent::Keep,
        Consent::Visit => api::Consent::Visit,
    }
}

fn mark(m: Mark) -> api::Mark {
    match m {
        Mark::Skipped => api::Mark::Skipped,
        Mark::KeptFlagged => api::Mark::KeptFlagged,
    }
}

fn source(s: &ReadingSource) -> api::Source {
    match s {
        ReadingSource::Tape(t) => api::Source::Tape {
            device_id: t.device_id,
            boot_id: t.boot_id,
            seq: t.seq,
            device_time_ms: t.device_time_ms,
        },
        ReadingSource::Keyboard => api::Source::Keyboard,
    }
}

fn append(
    tx: &WriteTx<'_>,
    session: Option<SessionId>,
    body: &api::EventBody,
) -> Result<(), StoreError> {
    let json = serde_json::to_string(body)
        .map_err(|e| StoreError::Corrupt(format!("encoding an outbox event: {e}")))?;
    tx.append_outbox(session, body.kind(), &json)?;
    Ok(())
}

/// Writes the event of `change` (and, for an erasure, redacts the erased
/// sessions' earlier events) inside `tx`.
pub(crate) fn record(tx: &WriteTx<'_>, change: &Change) -> Result<(), StoreError> {
    match change {
        Change::Created { session } => {
            let s = tx.session(*session)?;
            append(
                tx,
                Some(*session),
                &api::EventBody::Created {
                    session: session.0,
                    customer: s.customer_id,
                    set: s.measurement_set,
                    notes: s.notes,
                    consent: s.consent.map(consent),
                    careful: tx.is_careful(*session)?,
                    created_at_ms: s.created_at_ms,
                },
            )
        }
        Change::ReadingStored {
            session, reading, ..
        } => {
            let r = tx.reading(*reading)?;
            let supersedes = tx.superseded_by_reading(*reading)?;
            append(
                tx,
                Some(*session),
                &api::EventBody::ReadingStored {
                    session: session.0,
                    reading: reading.0,
                    measurement: r.measurement,
                    value_tenth_mm: r.value_tenth_mm,
                    source: source(&r.source),
                    received_at_ms: r.received_at_ms,
                    supersedes: supersedes.map(|id| id.0),
                },
            )
        }
        Change::Withdrawn {
            session,
            reading,
            restored,
        } => append(
            tx,
            Some(*session),
            &api::EventBody::Withdrawn {
                session: session.0,
                reading: reading.0,
                restored: restored.map(|id| id.0),
            },
        ),
        Change::Marked {
            session,
            measurement,
            mark: m,
        } => append(
            tx,
            Some(*session),
            &api::EventBody::Marked {
                session: session.0,
                measurement: measurement.clone(),
                mark: m.map(mark),
            },
        ),
        Change::StatusSet { session, to, .. } => append(
            tx,
            Some(*session),
            &api::EventBody::StatusSet {
                session: session.0,
                status: status(*to),
            },
        ),
        Change::EstimateStored { session } => {
            let Some((made_at_ms, model_source, readings, report_json)) =
                tx.estimate_header(*session)?
            else {
                return Err(StoreError::Corrupt(format!(
                    "session {session}: an estimate was stored but is not there"
                )));
            };
            let readings: Vec<(String, u32)> = serde_json::from_str(&readings)
                .map_err(|e| StoreError::Corrupt(format!("an estimate's readings: {e}")))?;
            append(
                tx,
                Some(*session),
                &api::EventBody::EstimateStored {
                    session: session.0,
                    made_at_ms,
                    model_source,
                    readings,
                    report_json,
                    glb_base64: None,
                },
            )
        }
        Change::Erased { session } => {
            tx.redact_outbox_of(*session)?;
            // Not tied to the session id: a later session may get the same
            // id, and erasing that one must not redact this event.
            append(tx, None, &api::EventBody::Erased { session: session.0 })
        }
        Change::CustomerErased {
            customer_hash,
            sessions,
        } => {
            for s in sessions {
                tx.redact_outbox_of(*s)?;
            }
            append(
                tx,
                None,
                &api::EventBody::CustomerErased {
                    customer_hash: customer_hash.clone(),
                },
            )
        }
        Change::ErasedByHub { sessions, .. } => {
            for s in sessions {
                tx.redact_outbox_of(*s)?;
            }
            Ok(())
        }
    }
}

/// A change in words for the log: ids only, never a customer's id.
pub fn describe(change: &Change) -> String {
    match change {
        Change::CustomerErased { sessions, .. } => {
            format!("customer erased here ({} sessions)", sessions.len())
        }
        Change::ErasedByHub { sessions, .. } => {
            format!(
                "customer erased elsewhere in the chain ({} sessions here)",
                sessions.len()
            )
        }
        other => format!("{other:?}"),
    }
}
