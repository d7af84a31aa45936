//! The store's writes, each a step inside one transaction ([`WriteTx`],
//! handed out by [`Store::write`](super::Store::write)).
//!
//! Why steps inside a caller's transaction rather than methods that commit:
//! the session layer decides what one change is, and a change must land with
//! everything it implies in one commit (later also its outbox event), so the
//! transaction belongs to the caller. The steps here apply the storage rules
//! (sequence bookkeeping, supersede on retake, open sessions only) and know
//! nothing of screens or tapes.

use rusqlite::{params, OptionalExtension, Transaction};

use super::types::{device_id_to_sql, SourceKind};
use super::{
    encode_vertices, now_ms, valid_text, CommitOutcome, Consent, DeviceReading, Mark, ReadingId,
    ReadingSource, Session, SessionId, SessionStatus, StoreError, StoredEstimate, StoredReading,
    TapeOrigin, FIRST_SEQ, MAX_CUSTOMER_ID_LEN, MAX_MEASUREMENT_NAME_LEN,
};

/// One open write transaction (see the module docs). Dropped without the
/// caller returning `Ok`, it rolls back.
pub(crate) struct WriteTx<'a> {
    tx: &'a Transaction<'a>,
}

impl<'a> WriteTx<'a> {
    pub(super) fn new(tx: &'a Transaction<'a>) -> Self {
        Self { tx }
    }

    /// Creates an open session for `customer_id` (opaque text: 1 to
    /// [`MAX_CUSTOMER_ID_LEN`] bytes, no control characters).
    pub fn create_session(
        &self,
        customer_id: &str,
        measurement_set: Option<&str>,
        notes: Option<&str>,
        consent: Option<Consent>,
    ) -> Result<Session, StoreError> {
        if !valid_text(customer_id, MAX_CUSTOMER_ID_LEN) {
            return Err(StoreError::InvalidCustomerId(customer_id.to_owned()));
        }
        let now = now_ms();
        self.tx.execute(
            "INSERT INTO sessions (customer_id, created_at_ms, updated_at_ms, status, measurement_set,
                                   notes, consent)
             VALUES (?1, ?2, ?2, ?3, ?4, ?5, ?6)",
            params![customer_id, now, SessionStatus::Open, measurement_set, notes, consent],
        )?;
        super::session_header(self.tx, SessionId(self.tx.last_insert_rowid()))
    }

    /// Sets whether session `id` takes each measurement twice (careful
    /// mode); done in the transaction that creates it.
    pub fn set_careful(&self, id: SessionId, careful: bool) -> Result<(), StoreError> {
        let n = self.tx.execute(
            "UPDATE sessions SET careful = ?2 WHERE id = ?1",
            params![id.0, careful],
        )?;
        if n == 0 {
            return Err(StoreError::NoSuchSession(id));
        }
        Ok(())
    }

    /// Does session `id` take each measurement twice, inside this
    /// transaction (as [`super::Store::is_careful`])?
    pub fn is_careful(&self, id: SessionId) -> Result<bool, StoreError> {
        self.tx
            .query_row("SELECT careful FROM sessions WHERE id = ?1", [id.0], |r| {
                r.get::<_, bool>(0)
            })
            .optional()?
            .ok_or(StoreError::NoSuchSession(id))
    }

    fn status(&self, session: SessionId) -> Result<SessionStatus, StoreError> {
        self.tx
            .query_row(
                "SELECT status FROM sessions WHERE id = ?1",
                [session.0],
                |r| r.get(0),
            )
            .optional()?
            .ok_or(StoreError::NoSuchSession(session))
    }

    fn touch(&self, session: SessionId, now: i64) -> Result<(), StoreError> {
        self.tx.execute(
            "UPDATE sessions SET updated_at_ms = ?2 WHERE id = ?1",
            params![session.0, now],
        )?;
        Ok(())
    }

    /// Stores a reading in an open session; an earlier current reading of
    /// the same measurement is marked superseded by it (a retake keeps
    /// history).
    fn insert_reading(
        &self,
        session: SessionId,
        measurement: &str,
        value_tenth_mm: u32,
        source: ReadingSource,
    ) -> Result<StoredReading, StoreError> {
        if !valid_text(measurement, MAX_MEASUREMENT_NAME_LEN) {
            return Err(StoreError::InvalidMeasurementName(measurement.to_owned()));
        }
        let status = self.status(session)?;
        if status != SessionStatus::Open {
            return Err(StoreError::SessionNotOpen {
                id: session,
                status,
            });
        }
        let now = now_ms();
        let (kind, device_id, boot_id, seq, device_time) = match &source {
            ReadingSource::Tape(t) => (
                SourceKind::Tape,
                Some(device_id_to_sql(t.device_id)),
                Some(t.boot_id),
                Some(t.seq),
                Some(i64::try_from(t.device_time_ms).unwrap_or(i64::MAX)),
            ),
            ReadingSource::Keyboard => (SourceKind::Keyboard, None, None, None, None),
        };
        self.tx.execute(
            "INSERT INTO readings (session_id, measurement, value_tenth_mm, source, device_id, boot_id,
                                   seq, device_time_ms, received_at_ms)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
            params![
                session.0,
                measurement,
                value_tenth_mm,
                kind,
                device_id,
                boot_id,
                seq,
                device_time,
                now
            ],
        )?;
        let id = self.tx.last_insert_rowid();
        self.tx.execute(
            "UPDATE readings SET superseded_by = ?1
             WHERE session_id = ?2 AND measurement = ?3 AND id <> ?1 AND superseded_by IS NULL
               AND withdrawn_at_ms IS NULL",
            params![id, session.0, measurement],
        )?;
        self.touch(session, now)?;
        Ok(StoredReading {
            id: ReadingId(id),
            session_id: session,
            measurement: measurement.to_owned(),
            value_tenth_mm,
            source,
            received_at_ms: now,
            superseded_by: None,
            withdrawn_at_ms: None,
        })
    }

    /// Commits one reading from the tape to `session` under `measurement`
    /// (`None`: `reading-N`, N one more than the session's readings so far),
    /// applying the sequence rules:
    ///
    /// * `seq <= last committed` for the device boot: [`CommitOutcome::Duplicate`],
    ///   nothing stored;
    /// * `seq == last committed + 1` (or [`FIRST_SEQ`] for a boot never seen):
    ///   stored, the bookkeeping advanced, an earlier current reading of the
    ///   same measurement marked superseded: [`CommitOutcome::Committed`];
    /// * otherwise [`CommitOutcome::Gap`], nothing stored.
    pub fn commit_tape_reading(
        &self,
        session: SessionId,
        measurement: Option<&str>,
        reading: &DeviceReading,
    ) -> Result<CommitOutcome, StoreError> {
        if let Some(m) = measurement {
            if !valid_text(m, MAX_MEASUREMENT_NAME_LEN) {
                return Err(StoreError::InvalidMeasurementName(m.to_owned()));
            }
        }
        let last: Option<u32> = self
            .tx
            .query_row(
                "SELECT last_committed_seq FROM link_state WHERE device_id = ?1 AND boot_id = ?2",
                params![device_id_to_sql(reading.device_id), reading.boot_id],
                |r| r.get(0),
            )
            .optional()?;
        let expected = match last {
            Some(last) if reading.seq <= last => {
                return Ok(CommitOutcome::Duplicate {
                    last_committed_seq: last,
                })
            }
            Some(last) => last.checked_add(1),
            // A boot never seen: only its first reading may start it. Any
            // other number means readings were lost on the way (or the
            // device misbehaves): a gap, not stored and not acknowledged.
            None => Some(FIRST_SEQ),
        };
        if expected != Some(reading.seq) {
            return Ok(CommitOutcome::Gap {
                expected: expected.unwrap_or(u32::MAX),
                got: reading.seq,
            });
        }
        let name = match measurement {
            Some(m) => m.to_owned(),
            None => {
                let n: i64 = self.tx.query_row(
                    "SELECT COUNT(*) FROM readings WHERE session_id = ?1",
                    [session.0],
                    |r| r.get(0),
                )?;
                format!("reading-{}", n + 1)
            }
        };
        let stored = self.insert_reading(
            session,
            &name,
            reading.value_tenth_mm,
            ReadingSource::Tape(TapeOrigin {
                device_id: reading.device_id,
                boot_id: reading.boot_id,
                seq: reading.seq,
                device_time_ms: reading.device_time_ms,
            }),
        )?;
        self.tx.execute(
            "INSERT INTO link_state (device_id, boot_id, last_committed_seq, updated_at_ms)
             VALUES (?1, ?2, ?3, ?4)
             ON CONFLICT (device_id, boot_id)
             DO UPDATE SET last_committed_seq = excluded.last_committed_seq,
                           updated_at_ms = excluded.updated_at_ms",
            params![
                device_id_to_sql(reading.device_id),
                reading.boot_id,
                reading.seq,
                stored.received_at_ms
            ],
        )?;
        Ok(CommitOutcome::Committed(stored))
    }

    /// Stores a value the operator captured with the keyboard (Enter: the
    /// tape's live value, not held on the tape): no device, no sequence.
    pub fn insert_keyboard_reading(
        &self,
        session: SessionId,
        measurement: &str,
        value_tenth_mm: u32,
    ) -> Result<StoredReading, StoreError> {
        self.insert_reading(
            session,
            measurement,
            value_tenth_mm,
            ReadingSource::Keyboard,
        )
    }

    /// Withdraws reading `id` (the operator's undo): it stays in the
    /// session's history but is no longer current, and the reading it had
    /// superseded (the value before a retake) is current again. Returns the
    /// session and, if the reading was current until now, the restored
    /// reading (`Some(None)`: withdrawn, nothing restored; `None`: it was
    /// withdrawn already, nothing changed).
    pub fn withdraw_reading(
        &self,
        id: ReadingId,
    ) -> Result<(SessionId, Option<Option<ReadingId>>), StoreError> {
        let session: Option<i64> = self
            .tx
            .query_row(
                "SELECT session_id FROM readings WHERE id = ?1",
                [id.0],
                |r| r.get(0),
            )
            .optional()?;
        let Some(session) = session.map(SessionId) else {
            return Err(StoreError::NoSuchReading(id));
        };
        let now = now_ms();
        let changed = self.tx.execute(
            "UPDATE readings SET withdrawn_at_ms = ?2 WHERE id = ?1 AND withdrawn_at_ms IS NULL",
            params![id.0, now],
        )?;
        if changed == 0 {
            return Ok((session, None));
        }
        let restored = self
            .tx
            .query_row(
                "SELECT id FROM readings WHERE superseded_by = ?1 AND withdrawn_at_ms IS NULL
                 ORDER BY id DESC LIMIT 1",
                [id.0],
                |r| r.get::<_, i64>(0),
            )
            .optional()?;
        self.tx.execute(
            "UPDATE readings SET superseded_by = NULL WHERE superseded_by = ?1",
            [id.0],
        )?;
        self.touch(session, now)?;
        Ok((session, Some(restored.map(ReadingId))))
    }

    /// Sets (or with `None` clears) the operator's mark on `measurement` of
    /// `session`.
    pub fn set_mark(
        &self,
        session: SessionId,
        measurement: &str,
        mark: Option<Mark>,
    ) -> Result<(), StoreError> {
        self.status(session)?;
        match mark {
            Some(m) => {
                self.tx.execute(
                    "INSERT INTO marks (session_id, measurement, mark, at_ms) VALUES (?1, ?2, ?3, ?4)
                     ON CONFLICT (session_id, measurement)
                     DO UPDATE SET mark = excluded.mark, at_ms = excluded.at_ms",
                    params![session.0, measurement, m, now_ms()],
                )?;
            }
            None => {
                self.tx.execute(
                    "DELETE FROM marks WHERE session_id = ?1 AND measurement = ?2",
                    params![session.0, measurement],
                )?;
            }
        }
        Ok(())
    }

    /// Sets the status of session `id`; returns the status it had.
    pub fn set_status(
        &self,
        id: SessionId,
        status: SessionStatus,
    ) -> Result<SessionStatus, StoreError> {
        let before = self.status(id)?;
        self.tx.execute(
            "UPDATE sessions SET status = ?2, updated_at_ms = ?3 WHERE id = ?1",
            params![id.0, status, now_ms()],
        )?;
        Ok(before)
    }

    /// Deletes session `id` with its readings, marks and estimate. The
    /// per-device sequence bookkeeping is kept, so a late retransmission of
    /// a deleted reading is still recognised as a duplicate and not stored
    /// again.
    pub fn delete_session(&self, id: SessionId) -> Result<(), StoreError> {
        let n = self
            .tx
            .execute("DELETE FROM sessions WHERE id = ?1", [id.0])?;
        if n == 0 {
            return Err(StoreError::NoSuchSession(id));
        }
        Ok(())
    }

    /// Stores `estimate` as its session's estimate, replacing an earlier one.
    pub fn put_estimate(&self, estimate: &StoredEstimate) -> Result<(), StoreError> {
        self.status(estimate.session_id)?;
        let readings = serde_json::to_string(&estimate.readings)
            .map_err(|e| StoreError::Corrupt(format!("encoding the estimate's readings: {e}")))?;
        self.tx.execute(
            "INSERT INTO estimates (session_id, made_at_ms, seconds, model_source, template_sha256,
                                    n_vertices, vertices, readings_json, report_json)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)
             ON CONFLICT (session_id) DO UPDATE SET
                made_at_ms = excluded.made_at_ms, seconds = excluded.seconds,
                model_source = excluded.model_source, template_sha256 = excluded.template_sha256,
                n_vertices = excluded.n_vertices, vertices = excluded.vertices,
                readings_json = excluded.readings_json, report_json = excluded.report_json",
            params![
                estimate.session_id.0,
                estimate.made_at_ms,
                estimate.seconds,
                estimate.model_source,
                estimate.template_sha256,
                i64::try_from(estimate.vertices.len()).unwrap_or(i64::MAX),
                encode_vertices(&estimate.vertices),
                readings,
                estimate.report_json
            ],
        )?;
        Ok(())
    }

    /// The header of session `id`, inside this transaction.
    pub fn session(&self, id: SessionId) -> Result<Session, StoreError> {
        super::session_header(self.tx, id)
    }

    /// Reading `id` as stored, inside this transaction.
    pub fn reading(&self, id: ReadingId) -> Result<StoredReading, StoreError> {
        self.tx
            .query_row(
                &format!("SELECT {} FROM readings WHERE id = ?1", super::READING_COLS),
                [id.0],
                super::reading_from_row,
            )
            .optional()?
            .ok_or(StoreError::NoSuchReading(id))
    }

    /// The reading that reading `id` superseded (a retake's earlier value), if any.
    ///
    /// A retake supersedes a reading of its own session and measurement
    /// (`insert_reading`), so only those are searched, through the
    /// `(session_id, measurement)` index: `superseded_by` has no index, and
    /// a search by it alone read the whole table for every reading stored.
    pub fn superseded_by_reading(&self, id: ReadingId) -> Result<Option<ReadingId>, StoreError> {
        Ok(self
            .tx
            .query_row(
                "SELECT o.id FROM readings r JOIN readings o
                   ON o.session_id = r.session_id AND o.measurement = r.measurement
                  AND o.superseded_by = r.id
                 WHERE r.id = ?1 ORDER BY o.id DESC LIMIT 1",
                [id.0],
                |r| r.get::<_, i64>(0),
            )
            .optional()?
            .map(ReadingId))
    }

    /// The stored estimate's header of `session` (made at, model, readings
    /// JSON, report JSON), inside this transaction.
    pub fn estimate_header(
        &self,
        session: SessionId,
    ) -> Result<Option<(i64, String, String, String)>, StoreError> {
        Ok(self
            .tx
            .query_row(
                "SELECT made_at_ms, model_source, readings_json, report_json
                 FROM estimates WHERE session_id = ?1",
                [session.0],
                |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)),
            )
            .optional()?)
    }

    /// Appends an event to the outbox (the next sequence number): `kind`
    /// and `body` as `tapeshape-hub-api` writes them.
    pub fn append_outbox(
        &self,
        session: Option<SessionId>,
        kind: &str,
        body: &str,
    ) -> Result<i64, StoreError> {
        self.tx.execute(
            "INSERT INTO outbox (session_id, at_ms, kind, body) VALUES (?1, ?2, ?3, ?4)",
            params![session.map(|s| s.0), now_ms(), kind, body],
        )?;
        Ok(self.tx.last_insert_rowid())
    }

    /// Replaces the content of every outbox event of `session` by a
    /// redacted event (same sequence number): an erased session's readings
    /// and customer id leave the outbox with it.
    pub fn redact_outbox_of(&self, session: SessionId) -> Result<usize, StoreError> {
        Ok(self.tx.execute(
            "UPDATE outbox SET kind = 'redacted', body = '{\"kind\":\"redacted\"}', session_id = NULL
             WHERE session_id = ?1",
            [session.0],
        )?)
    }

    /// Every session (id, customer id) of the store, for matching a
    /// customer by their id's hash.
    pub fn session_customers(&self) -> Result<Vec<(SessionId, String)>, StoreError> {
        let mut stmt = self
            .tx
            .prepare("SELECT id, customer_id FROM sessions ORDER BY id")?;
        let rows = stmt.query_map([], |r| Ok((SessionId(r.get(0)?), r.get(1)?)))?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// Records that the hub holds events 1 ..= `through`.
    pub fn mark_committed(&self, through: i64) -> Result<(), StoreError> {
        let now = now_ms();
        let before: i64 = self.tx.query_row(
            "SELECT hub_committed_seq FROM sync_state WHERE id = 1",
            [],
            |r| r.get(0),
        )?;
        self.tx.execute(
            "UPDATE sync_state SET hub_committed_seq = ?1 WHERE id = 1",
            [through],
        )?;
        // Only the events newly committed: a range of the primary key, so a
        // batch costs its own rows, not a scan of the whole outbox (which
        // grows with every change the station ever made).
        self.tx.execute(
            "UPDATE outbox SET committed_at_ms = ?3
             WHERE seq > ?1 AND seq <= ?2 AND committed_at_ms IS NULL",
            params![before, through, now],
        )?;
        Ok(())
    }

    /// Binds the store to station `name` (the first time), or checks that
    /// it is bound to it; returns the name it is bound to.
    pub fn bind_station(&self, name: &str) -> Result<String, StoreError> {
        self.tx.execute(
            "UPDATE sync_state SET station = ?1 WHERE id = 1 AND station IS NULL",
            [name],
        )?;
        Ok(self
            .tx
            .query_row("SELECT station FROM sync_state WHERE id = 1", [], |r| {
                r.get::<_, String>(0)
            })?)
    }
}
