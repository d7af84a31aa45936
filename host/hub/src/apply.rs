//! Applying one batch of a station's events: one PostgreSQL transaction.
//!
//! The rules (docs/hub.md, "Idempotency and ordering"):
//!
//! * The station's row is locked (`FOR UPDATE`) for the transaction, so two
//!   hub processes given the same station's batches at once (a retry while
//!   the first is still running, a request the network duplicated) apply
//!   them one after the other.
//! * Exactly the events that continue the hub's record are applied:
//!   `seq = last_seq + 1`, then the next, ... Events the hub has are
//!   skipped (a batch sent twice changes nothing); the first gap stops the
//!   batch (an event arriving before one it follows changes nothing). The
//!   answer's `committed_through` tells the station where to go on.
//! * Every statement is written so that applying an event to a state that
//!   lacks its session (erased, purged by retention, or dropped because the
//!   customer was erased before it arrived) does nothing, instead of
//!   failing the batch: the station would otherwise send it forever.
//! * The statements of one batch are sent pipelined (tokio-postgres sends
//!   requests issued together without waiting for each answer), so a batch
//!   of hundreds of events costs a few round trips, not hundreds.

use futures_util::future::try_join_all;
use tapeshape_hub_api::{
    decode_glb, ErasureNotice, Event, EventBody, Mark, Source, Status, SyncRequest, SyncResponse,
};
use tokio_postgres::types::ToSql;
use tokio_postgres::Transaction;

use crate::db::HubError;

/// Why a batch was refused as a whole (nothing of it stored).
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// The batch names another station than the token's.
    #[error("this token belongs to station {token}, but the batch is for station {batch}")]
    WrongStation {
        /// The token's station.
        token: String,
        /// The station the batch names.
        batch: String,
    },
    /// The station was revoked while the request ran.
    #[error("station {0} is revoked")]
    Revoked(String),
    /// An event is malformed (a bad field, a non-positive sequence number).
    #[error("event seq {seq}: {why}")]
    BadEvent {
        /// Its sequence number.
        seq: i64,
        /// What is wrong.
        why: String,
    },
    /// Too many events.
    #[error("{0} events in one batch; at most {max}", max = tapeshape_hub_api::MAX_BATCH_EVENTS)]
    TooMany(usize),
    /// The database failed.
    #[error(transparent)]
    Hub(#[from] HubError),
}

impl From<tokio_postgres::Error> for BatchError {
    fn from(e: tokio_postgres::Error) -> Self {
        BatchError::Hub(HubError::Db(e))
    }
}

/// What one batch did, besides the answer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Applied {
    /// The answer to send.
    pub response: SyncResponse,
    /// Events applied now.
    pub applied: usize,
    /// Events the hub had already.
    pub skipped: usize,
}

/// One statement to send: its SQL and its parameters.
struct Stmt {
    sql: &'static str,
    params: Vec<Box<dyn ToSql + Sync + Send>>,
}

macro_rules! stmt {
    ($sql:expr $(, $p:expr)* $(,)?) => {
        Stmt { sql: $sql, params: vec![$(Box::new($p) as Box<dyn ToSql + Sync + Send>),*] }
    };
}

/// Serialises, per customer, a session's arrival with that customer's
/// erasure: without it the two, in concurrent transactions at READ
/// COMMITTED, miss each other (the erasure's notices do not see the
/// uncommitted session, the session's guard does not see the uncommitted
/// erasure) and a late session of an erased customer survives at the hub
/// and its station. A transaction takes its customers' locks first, in
/// sorted order, so two batches cannot deadlock on them; PostgreSQL frees
/// them at commit or rollback.
const LOCK_CUSTOMER: &str = "SELECT pg_advisory_xact_lock(hashtextextended($1, 0))";
const CREATE_SESSION: &str =
    "INSERT INTO sessions (station, session, customer, customer_hash, set_name, notes,
        consent, status, created_at_ms, updated_at_ms, careful)
     SELECT $1, $2, $3, $4, $5, $6, $7, 'open', $8, $8, $9
     WHERE NOT EXISTS (SELECT 1 FROM erasures WHERE customer_hash = $4 AND erased_at_ms >= $8)
     ON CONFLICT (station, session) DO NOTHING";
/// A session of a customer erased after it was created, arriving late (its
/// station was offline): not stored (above), and the station is told.
const NOTICE_LATE_ERASURE: &str = "INSERT INTO erasure_notices (erasure, station)
     SELECT id, $1 FROM erasures WHERE customer_hash = $2 AND erased_at_ms >= $3
     ON CONFLICT DO NOTHING";
const INSERT_READING: &str =
    "INSERT INTO readings (station, session, reading, measurement, value_tenth_mm, source,
        device_id, boot_id, device_seq, device_time_ms, received_at_ms)
     SELECT $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11
     WHERE EXISTS (SELECT 1 FROM sessions WHERE station = $1 AND session = $2)
     ON CONFLICT (station, reading) DO NOTHING";
const SUPERSEDE: &str =
    "UPDATE readings SET superseded_by = $3 WHERE station = $1 AND session = $2 AND reading = $4";
const WITHDRAW: &str =
    "UPDATE readings SET withdrawn = true WHERE station = $1 AND session = $2 AND reading = $3";
const RESTORE: &str =
    "UPDATE readings SET superseded_by = NULL WHERE station = $1 AND session = $2 AND superseded_by = $3";
const SET_MARK: &str = "INSERT INTO marks (station, session, measurement, mark)
     SELECT $1, $2, $3, $4
     WHERE EXISTS (SELECT 1 FROM sessions WHERE station = $1 AND session = $2)
     ON CONFLICT (station, session, measurement) DO UPDATE SET mark = excluded.mark";
const CLEAR_MARK: &str =
    "DELETE FROM marks WHERE station = $1 AND session = $2 AND measurement = $3";
const SET_STATUS: &str =
    "UPDATE sessions SET status = $3, updated_at_ms = $4 WHERE station = $1 AND session = $2";
const PUT_ESTIMATE: &str =
    "INSERT INTO estimates (station, session, made_at_ms, model_source, readings_json,
        report_json, glb)
     SELECT $1, $2, $3, $4, $5, $6, $7
     WHERE EXISTS (SELECT 1 FROM sessions WHERE station = $1 AND session = $2)
     ON CONFLICT (station, session) DO UPDATE SET made_at_ms = excluded.made_at_ms,
        model_source = excluded.model_source, readings_json = excluded.readings_json,
        report_json = excluded.report_json, glb = excluded.glb";
const DELETE_SESSION: &str = "DELETE FROM sessions WHERE station = $1 AND session = $2";
const ERASURE_RECORD_AND_NOTICES: &str = "WITH e AS (
        INSERT INTO erasures (customer_hash, erased_at_ms, origin) VALUES ($1, $2, $3) RETURNING id)
     INSERT INTO erasure_notices (erasure, station)
     SELECT e.id, h.station FROM e, (SELECT DISTINCT station FROM sessions
        WHERE customer_hash = $1 AND station <> $3) h";
const ERASE_SESSIONS: &str = "DELETE FROM sessions WHERE customer_hash = $1";

/// A tape's 64-bit id as the same 64 bits in a signed BIGINT.
fn device_id_sql(id: u64) -> i64 {
    i64::from_ne_bytes(id.to_ne_bytes())
}

fn mark_word(m: Mark) -> &'static str {
    match m {
        Mark::Skipped => "skipped",
        Mark::KeptFlagged => "kept_flagged",
    }
}

fn status_word(s: Status) -> &'static str {
    match s {
        Status::Open => "open",
        Status::Done => "done",
        Status::Abandoned => "abandoned",
    }
}

/// The statements of one event (see the module docs for their guards).
fn statements(station: &str, e: &Event, out: &mut Vec<Stmt>) -> Result<(), BatchError> {
    let st = || station.to_string();
    match &e.body {
        EventBody::Created {
            session,
            customer,
            set,
            notes,
            consent,
            careful,
            created_at_ms,
        } => {
            let hash = tapeshape_hub_api::customer_hash(customer);
            out.push(stmt!(
                CREATE_SESSION,
                st(),
                *session,
                customer.clone(),
                hash.clone(),
                set.clone(),
                notes.clone(),
                consent.map(|c| c.as_str().to_string()),
                *created_at_ms,
                *careful
            ));
            out.push(stmt!(NOTICE_LATE_ERASURE, st(), hash, *created_at_ms));
        }
        EventBody::ReadingStored {
            session,
            reading,
            measurement,
            value_tenth_mm,
            source,
            received_at_ms,
            supersedes,
        } => {
            let (kind, device, boot, seq, time) = match *source {
                Source::Tape {
                    device_id,
                    boot_id,
                    seq,
                    device_time_ms,
                } => (
                    "tape",
                    Some(device_id_sql(device_id)),
                    Some(i64::from(boot_id)),
                    Some(i64::from(seq)),
                    Some(i64::try_from(device_time_ms).unwrap_or(i64::MAX)),
                ),
                Source::Keyboard => ("keyboard", None, None, None, None),
            };
            out.push(stmt!(
                INSERT_READING,
                st(),
                *session,
                *reading,
                measurement.clone(),
                i64::from(*value_tenth_mm),
                kind.to_string(),
                device,
                boot,
                seq,
                time,
                *received_at_ms
            ));
            if let Some(old) = supersedes {
                out.push(stmt!(SUPERSEDE, st(), *session, *reading, *old));
            }
        }
        EventBody::Withdrawn {
            session, reading, ..
        } => {
            out.push(stmt!(WITHDRAW, st(), *session, *reading));
            out.push(stmt!(RESTORE, st(), *session, *reading));
        }
        EventBody::Marked {
            session,
            measurement,
            mark,
        } => match mark {
            Some(m) => out.push(stmt!(
                SET_MARK,
                st(),
                *session,
                measurement.clone(),
                mark_word(*m).to_string()
            )),
            None => out.push(stmt!(CLEAR_MARK, st(), *session, measurement.clone())),
        },
        EventBody::StatusSet { session, status } => out.push(stmt!(
            SET_STATUS,
            st(),
            *session,
            status_word(*status).to_string(),
            e.at_ms
        )),
        EventBody::EstimateStored {
            session,
            made_at_ms,
            model_source,
            readings,
            report_json,
            glb_base64,
        } => {
            let glb = match glb_base64 {
                Some(b) => {
                    Some(decode_glb(b).map_err(|why| BatchError::BadEvent { seq: e.seq, why })?)
                }
                None => None,
            };
            let readings = serde_json::to_string(readings).unwrap_or_else(|_| "[]".into());
            out.push(stmt!(
                PUT_ESTIMATE,
                st(),
                *session,
                *made_at_ms,
                model_source.clone(),
                readings,
                report_json.clone(),
                glb
            ));
        }
        EventBody::Erased { session } => out.push(stmt!(DELETE_SESSION, st(), *session)),
        EventBody::CustomerErased { customer_hash } => {
            out.push(stmt!(
                ERASURE_RECORD_AND_NOTICES,
                customer_hash.clone(),
                e.at_ms,
                st()
            ));
            out.push(stmt!(ERASE_SESSIONS, customer_hash.clone()));
        }
        EventBody::Redacted => {}
    }
    Ok(())
}

/// Every statement an event may need, in one list, so that a pooled
/// connection prepares each once (deadpool caches prepared statements per
/// connection) before its first transaction.
const ALL_STATEMENTS: &[&str] = &[
    LOCK_CUSTOMER,
    CREATE_SESSION,
    NOTICE_LATE_ERASURE,
    INSERT_READING,
    SUPERSEDE,
    WITHDRAW,
    RESTORE,
    SET_MARK,
    CLEAR_MARK,
    SET_STATUS,
    PUT_ESTIMATE,
    DELETE_SESSION,
    ERASURE_RECORD_AND_NOTICES,
    ERASE_SESSIONS,
];

/// Sends `stmts` in order, pipelined, inside `tx`; `prepared[i]` is
/// `ALL_STATEMENTS[i]` prepared on this connection.
async fn run_pipelined(
    tx: &Transaction<'_>,
    prepared: &[tokio_postgres::Statement],
    stmts: &[Stmt],
) -> Result<(), tokio_postgres::Error> {
    let futures = stmts.iter().map(|s| {
        let i = ALL_STATEMENTS
            .iter()
            .position(|sql| *sql == s.sql)
            .expect("every statement is in ALL_STATEMENTS");
        let params: Vec<&(dyn ToSql + Sync)> = s
            .params
            .iter()
            .map(|b| b.as_ref() as &(dyn ToSql + Sync))
            .collect();
        let p = &prepared[i];
        async move { tx.execute(p, &params).await }
    });
    try_join_all(futures).await?;
    Ok(())
}

/// Erases a customer chain-wide inside `tx`: the erasure record, a notice
/// for every other station holding them, and their sessions deleted.
/// Returns (sessions deleted, stations told).
pub async fn erase_customer(
    tx: &Transaction<'_>,
    customer_hash: &str,
    at_ms: i64,
    origin: &str,
) -> Result<(u64, u64), HubError> {
    tx.execute(LOCK_CUSTOMER, &[&customer_hash]).await?;
    let told = tx
        .execute(
            ERASURE_RECORD_AND_NOTICES,
            &[&customer_hash, &at_ms, &origin],
        )
        .await?;
    let deleted = tx.execute(ERASE_SESSIONS, &[&customer_hash]).await?;
    Ok((deleted, told))
}

/// The events of `events` to apply after `last_seq`, in order: skips those
/// at or below it and stops at the first gap. Returns them and how many
/// were skipped.
pub fn continuing(last_seq: i64, events: &[Event]) -> (Vec<&Event>, usize) {
    let mut sorted: Vec<&Event> = events.iter().collect();
    sorted.sort_by_key(|e| e.seq);
    let mut next = last_seq + 1;
    let mut take = Vec::new();
    let mut skipped = 0;
    for e in sorted {
        if e.seq < next {
            skipped += 1;
        } else if e.seq == next {
            take.push(e);
            next += 1;
        } else {
            break;
        }
    }
    (take, skipped)
}

/// Applies `req` for `token_station` (the station its token belongs to)
/// in one transaction on `client`; see the module docs.
pub async fn apply_batch(
    client: &mut deadpool_postgres::Client,
    token_station: &str,
    req: &SyncRequest,
) -> Result<Applied, BatchError> {
    if req.station != token_station {
        return Err(BatchError::WrongStation {
            token: token_station.to_string(),
            batch: req.station.clone(),
        });
    }
    if req.events.len() > tapeshape_hub_api::MAX_BATCH_EVENTS {
        return Err(BatchError::TooMany(req.events.len()));
    }
    for e in &req.events {
        if e.seq < 1 {
            return Err(BatchError::BadEvent {
                seq: e.seq,
                why: "sequence numbers start at 1".into(),
            });
        }
        e.body
            .validate()
            .map_err(|why| BatchError::BadEvent { seq: e.seq, why })?;
    }
    let station = token_station;
    let mut prepared = Vec::with_capacity(ALL_STATEMENTS.len());
    for sql in ALL_STATEMENTS {
        prepared.push(client.prepare_cached(sql).await?);
    }
    let tx = client.transaction().await?;
    let Some(row) = tx
        .query_opt(
            "SELECT last_seq FROM stations WHERE name = $1 AND revoked_at IS NULL FOR UPDATE",
            &[&station],
        )
        .await?
    else {
        return Err(BatchError::Revoked(station.to_string()));
    };
    let last_seq: i64 = row.get(0);
    let (take, skipped) = continuing(last_seq, &req.events);
    let mut stmts = Vec::new();
    // The customers whose sessions arrive or who are erased: locked first
    // (see LOCK_CUSTOMER).
    let mut customers: Vec<String> = take
        .iter()
        .filter_map(|e| match &e.body {
            EventBody::Created { customer, .. } => Some(tapeshape_hub_api::customer_hash(customer)),
            EventBody::CustomerErased { customer_hash } => Some(customer_hash.clone()),
            _ => None,
        })
        .collect();
    customers.sort();
    customers.dedup();
    for hash in customers {
        stmts.push(stmt!(LOCK_CUSTOMER, hash));
    }
    for e in &take {
        statements(station, e, &mut stmts)?;
    }
    run_pipelined(&tx, &prepared, &stmts).await?;
    let committed_through = last_seq + take.len() as i64;
    tx.execute(
        "UPDATE stations SET last_seq = $2, last_sync_at = now() WHERE name = $1",
        &[&station, &committed_through],
    )
    .await?;
    if !req.erasures_done.is_empty() {
        tx.execute(
            "UPDATE erasure_notices SET done_at = now()
             WHERE station = $1 AND erasure = ANY($2) AND done_at IS NULL",
            &[&station, &req.erasures_done],
        )
        .await?;
    }
    let erasures = tx
        .query(
            "SELECT n.erasure, e.customer_hash FROM erasure_notices n
             JOIN erasures e ON e.id = n.erasure
             WHERE n.station = $1 AND n.done_at IS NULL ORDER BY n.erasure LIMIT 1000",
            &[&station],
        )
        .await?
        .iter()
        .map(|r| ErasureNotice {
            id: r.get(0),
            customer_hash: r.get(1),
        })
        .collect();
    tx.commit().await?;
    Ok(Applied {
        response: SyncResponse {
            committed_through,
            erasures,
        },
        applied: take.len(),
        skipped,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(seq: i64) -> Event {
        Event {
            seq,
            at_ms: 0,
            body: EventBody::Redacted,
        }
    }

    #[test]
    fn only_the_continuation_of_the_record_is_taken() {
        let seqs = |v: Vec<&Event>| v.iter().map(|e| e.seq).collect::<Vec<_>>();
        // In order after 3: 4, 5, 6.
        let events = [ev(4), ev(5), ev(6)];
        let (t, s) = continuing(3, &events);
        assert_eq!((seqs(t), s), (vec![4, 5, 6], 0));
        // Sent twice: nothing new.
        let (t, s) = continuing(6, &events);
        assert_eq!((seqs(t), s), (vec![], 3));
        // Overlapping and shuffled: the new part only, in order.
        let events = [ev(7), ev(5), ev(6), ev(8)];
        let (t, s) = continuing(6, &events);
        assert_eq!((seqs(t), s), (vec![7, 8], 2));
        // A gap: nothing after it.
        let events = [ev(4), ev(6), ev(7)];
        let (t, _) = continuing(3, &events);
        assert_eq!(seqs(t), vec![4]);
        let later = [ev(5)];
        let (t, _) = continuing(3, &later);
        assert!(t.is_empty());
        // A seq twice in one batch is applied once.
        let events = [ev(1), ev(1), ev(2)];
        let (t, s) = continuing(0, &events);
        assert_eq!((seqs(t), s), (vec![1, 2], 1));
    }
}
