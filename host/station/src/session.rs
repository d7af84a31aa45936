//! The session layer: what a session is, and the one way to change one.
//!
//! A session is one customer's visit: it follows a measurement set, collects
//! readings (from the tape's queue, committed by the link, or typed with the
//! keyboard), the operator's marks (undo withdraws a reading, skip and
//! "keep this flagged reading" are marks), and the latest estimate of the
//! body. [`Sessions`] creates, opens and resumes sessions and makes every
//! change to them.
//!
//! Why one layer for it: every front end (the kiosk interface, the line-mode
//! station, the demo, the `session` commands) and the link change sessions,
//! and each change must land in one SQLite transaction with everything it
//! implies. Each change is one call of `Sessions::change` (private), which owns the
//! transaction and records what changed as a [`Change`]: in the log, and as
//! an event in the outbox, in the same transaction ([`outbox`]), which the
//! sync task (`crate::sync`) pushes to the chain's hub when the station has
//! one. So an event exists exactly when its change was committed. Nothing
//! else writes to the store: `crate::store::Store::write` is private to the
//! crate and only called here.
//!
//! Layer: above the store and the link (it implements the link's
//! [`ReadingSink`], so the link commits tape readings through it without
//! knowing it), below the services and the front ends.

use std::path::Path;
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use tapeshape_measure::{MeasureError, MeasurementSet};

use crate::link::ReadingSink;
use crate::store::{
    CommitOutcome, Consent, DeviceReading, Mark, ReadingId, ReadingSource, Session, SessionDetail,
    SessionId, SessionStatus, Store, StoreError, StoredEstimate, StoredReading, WriteTx,
};

pub mod careful;
pub mod outbox;

/// One change to a session, as the session layer records it.
#[derive(Clone, Debug, PartialEq)]
pub enum Change {
    /// A session was created.
    Created {
        /// The new session.
        session: SessionId,
    },
    /// A reading was stored (from the tape or the keyboard).
    ReadingStored {
        /// Its session.
        session: SessionId,
        /// The reading.
        reading: ReadingId,
        /// Tape or keyboard.
        source: ReadingSource,
    },
    /// The operator withdrew a reading (undo).
    Withdrawn {
        /// Its session.
        session: SessionId,
        /// The reading.
        reading: ReadingId,
        /// The reading current again (the value before a retake), if any.
        restored: Option<ReadingId>,
    },
    /// The operator marked a measurement (skipped, a flagged reading kept)
    /// or cleared its mark (`None`).
    Marked {
        /// The session.
        session: SessionId,
        /// The measurement.
        measurement: String,
        /// The mark.
        mark: Option<Mark>,
    },
    /// The session was closed (done, abandoned) or opened again.
    StatusSet {
        /// The session.
        session: SessionId,
        /// Its status before.
        from: SessionStatus,
        /// Its status now.
        to: SessionStatus,
    },
    /// The session's estimate was stored (replacing an earlier one).
    EstimateStored {
        /// The session.
        session: SessionId,
    },
    /// The session and everything it held were deleted.
    Erased {
        /// The session.
        session: SessionId,
    },
    /// A customer asked to be erased here (`tapeshape customer erase`):
    /// all their sessions were deleted; the hub erases them chain-wide.
    CustomerErased {
        /// `tapeshape_hub_api::customer_hash` of their id.
        customer_hash: String,
        /// The sessions deleted here.
        sessions: Vec<SessionId>,
    },
    /// The hub told this station that a customer was erased elsewhere in
    /// the chain: their sessions here were deleted (no event: the hub has
    /// the erasure already).
    ErasedByHub {
        /// `tapeshape_hub_api::customer_hash` of their id.
        customer_hash: String,
        /// The sessions deleted here.
        sessions: Vec<SessionId>,
    },
}

/// Why a session could not be started or opened.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The store refused or failed.
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The session's measurement set could not be loaded.
    #[error("loading the measurement set {set:?}: {source}")]
    Set {
        /// The set's name or file.
        set: String,
        /// Why.
        #[source]
        source: Box<MeasureError>,
    },
}

/// One measurement of a session's set, as the front ends show it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementInfo {
    /// Name stored with readings.
    pub name: String,
    /// Human label.
    pub label: String,
    /// Instruction for the operator.
    pub description: String,
}

/// What is known about a session's stored estimate when it is opened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EstimateInfo {
    /// When it was made, ms since the Unix epoch.
    pub made_at_ms: i64,
    /// It was made from exactly the session's current readings (no retake,
    /// undo or new reading since).
    pub current: bool,
}

/// A session as opened for measuring: its set, readings and marks.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionView {
    /// The session.
    pub id: SessionId,
    /// Customer id.
    pub customer: String,
    /// Measurement set name (or file).
    pub set: String,
    /// Notes (sex, age).
    pub notes: Option<String>,
    /// Its status as opened (open, unless opened only to look at it).
    pub status: SessionStatus,
    /// The set's measurements, in order (then any stored names the set lacks).
    pub measurements: Vec<MeasurementInfo>,
    /// Current readings (name, tenths of a mm), commit order.
    pub readings: Vec<(String, u32)>,
    /// Superseded (retaken) readings (name, tenths of a mm), commit order.
    pub superseded: Vec<(String, u32)>,
    /// The operator's stored marks (skipped, flagged reading kept).
    pub marks: Vec<(String, Mark)>,
    /// Its stored estimate, if it has one.
    pub estimate: Option<EstimateInfo>,
    /// Careful mode's readings, if the session takes each measurement
    /// twice (then `readings` holds the kept values: see [`careful`]).
    pub careful: Option<CarefulView>,
}

/// A careful session's readings as the measuring screen needs them (see
/// [`careful`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CarefulView {
    /// Each measurement's allowable error, tenths of a mm (its ISO
    /// 20685-1 tolerance in the set), in the set's order; a name the set
    /// lacks has none.
    pub allowed: Vec<(String, u32)>,
    /// Each measurement's chain of readings (tenths of a mm, oldest first:
    /// [`careful::chains`]), in the order of their latest readings.
    pub chains: Vec<(String, Vec<u32>)>,
}

impl CarefulView {
    /// The allowable error of `name`, tenths of a mm.
    pub fn allowed_of(&self, name: &str) -> Option<u32> {
        self.allowed
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, a)| *a)
    }

    /// The chain of `name` (empty when it has no readings).
    pub fn chain_of(&self, name: &str) -> &[u32] {
        self.chains
            .iter()
            .find(|(n, _)| n == name)
            .map_or(&[], |(_, c)| c.as_slice())
    }
}

/// How a new session is taken.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NewSession {
    /// The customer's choice about their data (`None`: not asked).
    pub consent: Option<Consent>,
    /// Careful mode: each measurement taken twice ([`careful`]).
    pub careful: bool,
}

/// An unfinished session the store holds, offered for resuming.
#[derive(Clone, Debug, PartialEq)]
pub struct ResumeOffer {
    /// The session.
    pub session: SessionId,
    /// Its customer id.
    pub customer: String,
    /// Its measurement set.
    pub set: Option<String>,
    /// Readings it holds (current ones).
    pub readings: u64,
}

/// The session layer's handle: every change to a session goes through it
/// (see the module docs). Cheap to clone; clones share the store and the
/// signal that wakes the sync task.
#[derive(Clone, Debug)]
pub struct Sessions {
    store: Store,
    changed: Arc<ChangeSignal>,
}

/// Counts committed changes and wakes whoever waits for one (the sync task:
/// an event is pushed as soon as it is in the outbox, not on the next poll).
#[derive(Debug, Default)]
struct ChangeSignal {
    count: Mutex<u64>,
    cond: Condvar,
}

fn load_definitions(set: &str) -> Result<MeasurementSet, SessionError> {
    MeasurementSet::load(set).map_err(|source| SessionError::Set {
        set: set.to_string(),
        source: Box::new(source),
    })
}

/// Each measurement of `set` with its allowable error in careful mode,
/// tenths of a mm (its ISO 20685-1 tolerance), in the set's order.
pub fn allowed_errors(set: &str) -> Result<Vec<(String, u32)>, SessionError> {
    Ok(load_definitions(set)?
        .definitions
        .into_iter()
        .map(|d| (d.name, careful::allowed_tenth_mm(d.tolerance)))
        .collect())
}

/// The measurements of `set` (a built-in name or a set file).
pub fn load_set(set: &str) -> Result<Vec<MeasurementInfo>, SessionError> {
    Ok(load_definitions(set)?
        .definitions
        .into_iter()
        .map(|d| MeasurementInfo {
            name: d.name,
            label: d.label,
            description: d.description,
        })
        .collect())
}

impl Sessions {
    /// The session layer over `store`.
    pub fn new(store: Store) -> Self {
        Self {
            store,
            changed: Arc::default(),
        }
    }

    /// Opens the store in `data_dir` (see [`Store::open`]).
    pub fn open(data_dir: &Path) -> Result<Self, StoreError> {
        Store::open(data_dir).map(Self::new)
    }

    /// The store, for reading.
    pub fn store(&self) -> &Store {
        &self.store
    }

    /// Makes one change: runs `f` in one transaction of the store, records
    /// the [`Change`] it reports (`None`: nothing changed, e.g. a
    /// retransmitted reading) as an outbox event in the same transaction,
    /// and logs it. Every public change below is one call of this.
    fn change<T>(
        &self,
        f: impl FnOnce(&WriteTx<'_>) -> Result<(T, Option<Change>), StoreError>,
    ) -> Result<T, StoreError> {
        let (value, change) = self.store.write(|tx| {
            let (value, change) = f(tx)?;
            if let Some(c) = &change {
                outbox::record(tx, c)?;
            }
            Ok((value, change))
        })?;
        if let Some(change) = change {
            tracing::info!(change = %outbox::describe(&change), "session changed");
            self.notify();
        }
        Ok(value)
    }

    fn notify(&self) {
        let mut n = self.changed.count.lock().unwrap_or_else(|e| e.into_inner());
        *n += 1;
        self.changed.cond.notify_all();
    }

    /// The number of changes committed through this handle (and its clones).
    pub fn changes(&self) -> u64 {
        *self.changed.count.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Waits until more than `seen` changes were committed through this
    /// handle, or `timeout` passed; returns the count.
    pub fn wait_for_change(&self, seen: u64, timeout: Duration) -> u64 {
        let n = self.changed.count.lock().unwrap_or_else(|e| e.into_inner());
        let (n, _) = self
            .changed
            .cond
            .wait_timeout_while(n, timeout, |n| *n <= seen)
            .unwrap_or_else(|e| e.into_inner());
        *n
    }

    /// Creates an open session for `customer` (opaque text) following
    /// `measurement_set` (not checked here: [`Sessions::start`] checks it).
    pub fn create(
        &self,
        customer: &str,
        measurement_set: Option<&str>,
        notes: Option<&str>,
    ) -> Result<Session, StoreError> {
        self.create_with_consent(customer, measurement_set, notes, None)
    }

    /// [`Sessions::create`] with the customer's choice about their data.
    pub fn create_with_consent(
        &self,
        customer: &str,
        measurement_set: Option<&str>,
        notes: Option<&str>,
        consent: Option<Consent>,
    ) -> Result<Session, StoreError> {
        self.create_new(
            customer,
            measurement_set,
            notes,
            NewSession {
                consent,
                careful: false,
            },
        )
    }

    /// [`Sessions::create`] taken as `options` says (consent, careful
    /// mode), in one change.
    pub fn create_new(
        &self,
        customer: &str,
        measurement_set: Option<&str>,
        notes: Option<&str>,
        options: NewSession,
    ) -> Result<Session, StoreError> {
        self.change(|tx| {
            let s = tx.create_session(customer, measurement_set, notes, options.consent)?;
            if options.careful {
                tx.set_careful(s.id, true)?;
            }
            let id = s.id;
            Ok((s, Some(Change::Created { session: id })))
        })
    }

    /// Starts a session for `customer` following `set`, which is loaded
    /// first: an unknown set stores nothing. Returns it ready for measuring.
    pub fn start(
        &self,
        customer: &str,
        set: &str,
        notes: Option<&str>,
    ) -> Result<SessionView, SessionError> {
        self.start_with_consent(customer, set, notes, None)
    }

    /// [`Sessions::start`] with the customer's choice about their data (the
    /// new-customer screen asks it).
    pub fn start_with_consent(
        &self,
        customer: &str,
        set: &str,
        notes: Option<&str>,
        consent: Option<Consent>,
    ) -> Result<SessionView, SessionError> {
        self.start_new(
            customer,
            set,
            notes,
            NewSession {
                consent,
                careful: false,
            },
        )
    }

    /// [`Sessions::start`] taken as `options` says (consent, careful mode).
    pub fn start_new(
        &self,
        customer: &str,
        set: &str,
        notes: Option<&str>,
        options: NewSession,
    ) -> Result<SessionView, SessionError> {
        let measurements = load_set(set)?;
        let careful = if options.careful {
            Some(CarefulView {
                allowed: allowed_errors(set)?,
                chains: Vec::new(),
            })
        } else {
            None
        };
        let s = self.create_new(customer, Some(set), notes, options)?;
        Ok(SessionView {
            id: s.id,
            customer: s.customer_id,
            set: set.to_string(),
            notes: s.notes,
            status: s.status,
            measurements,
            readings: Vec::new(),
            superseded: Vec::new(),
            marks: Vec::new(),
            estimate: None,
            careful,
        })
    }

    /// Opens session `id` for measuring with its readings, marks and
    /// estimate, reopening it if it was closed (so readings can be added
    /// again). A session without a set follows `quick`.
    pub fn open_for_measuring(&self, id: SessionId) -> Result<SessionView, SessionError> {
        self.view(id, true)
    }

    /// Opens session `id` to look at it (its stored estimate, its
    /// readings): as [`Sessions::open_for_measuring`], but a closed session
    /// stays closed.
    pub fn open_for_viewing(&self, id: SessionId) -> Result<SessionView, SessionError> {
        self.view(id, false)
    }

    fn view(&self, id: SessionId, reopen: bool) -> Result<SessionView, SessionError> {
        let detail = self.store.open_session(id)?;
        let set = detail
            .session
            .measurement_set
            .clone()
            .unwrap_or_else(|| "quick".to_string());
        let mut measurements = load_set(&set)?;
        let mut status = detail.session.status;
        if reopen && status != SessionStatus::Open {
            self.set_status(id, SessionStatus::Open)?;
            status = SessionStatus::Open;
        }
        // Readings under names the set does not have (a numbered session, an
        // edited set file) still show, after the set's own.
        for r in detail.current_readings() {
            if !measurements.iter().any(|m| m.name == r.measurement) {
                measurements.push(MeasurementInfo {
                    name: r.measurement.clone(),
                    label: r.measurement.clone(),
                    description: "A reading stored under a name this set does not have.".into(),
                });
            }
        }
        let careful = self.careful_view(&detail)?;
        let readings = kept_of(&detail, careful.as_ref());
        let estimate = self.store.estimate(id)?.map(|e| EstimateInfo {
            made_at_ms: e.made_at_ms,
            current: same_readings(&e.readings, &readings),
        });
        Ok(SessionView {
            id,
            customer: detail.session.customer_id.clone(),
            set,
            notes: detail.session.notes.clone(),
            status,
            measurements,
            superseded: detail
                .readings
                .iter()
                .filter(|r| r.superseded_by.is_some())
                .map(|r| (r.measurement.clone(), r.value_tenth_mm))
                .collect(),
            readings,
            marks: self.store.marks(id)?,
            estimate,
            careful,
        })
    }

    /// The values session `detail` stands for (name, tenths of a mm), in
    /// the order of their latest readings: its current readings, or in a
    /// careful session each measurement's kept value (the median of its
    /// last finished round; one still in its first round has none yet).
    /// What an estimate of the session is made from.
    pub fn kept_readings(
        &self,
        detail: &SessionDetail,
    ) -> Result<Vec<(String, u32)>, SessionError> {
        Ok(kept_of(detail, self.careful_view(detail)?.as_ref()))
    }

    fn careful_view(&self, detail: &SessionDetail) -> Result<Option<CarefulView>, SessionError> {
        let id = detail.session.id;
        if !self.store.is_careful(id)? {
            return Ok(None);
        }
        let set = detail.session.measurement_set.as_deref().unwrap_or("quick");
        Ok(Some(CarefulView {
            allowed: allowed_errors(set)?,
            chains: careful::chains(detail)
                .into_iter()
                .map(|(n, c)| (n, c.iter().map(|r| r.value_tenth_mm).collect()))
                .collect(),
        }))
    }

    /// The careful part of session `detail`'s report (its readings round by
    /// round, kept values, TEM), or `None` for a session that takes each
    /// measurement once.
    pub fn careful_report(
        &self,
        detail: &SessionDetail,
    ) -> Result<Option<careful::CarefulReport>, SessionError> {
        Ok(self
            .careful_view(detail)?
            .map(|v| careful::report(detail, |name| v.allowed_of(name))))
    }

    /// What each reading of careful session `detail` was (`careful round
    /// 1, reading 2 of 2, kept 98.0 mm`), for its reading table; empty for a
    /// session that takes each measurement once.
    pub fn careful_reading_notes(
        &self,
        detail: &SessionDetail,
    ) -> Result<Vec<(ReadingId, String)>, SessionError> {
        Ok(self
            .careful_view(detail)?
            .map(|v| careful::reading_notes(detail, |name| v.allowed_of(name)))
            .unwrap_or_default())
    }

    /// The round the next reading of `measurement` in careful session
    /// `detail` goes to (its readings so far and how many it takes), or
    /// `None` when the session takes each measurement once.
    pub fn open_round(
        &self,
        detail: &SessionDetail,
        measurement: &str,
    ) -> Result<Option<careful::Round>, SessionError> {
        Ok(self
            .careful_view(detail)?
            .map(|v| careful::open_round(v.chain_of(measurement), v.allowed_of(measurement))))
    }

    /// The unfinished session to offer for resuming after a restart (the
    /// most recently updated open one), if any.
    pub fn resume_offer(&self) -> Result<Option<ResumeOffer>, StoreError> {
        let Some(s) = self.store.latest_unfinished_session()? else {
            return Ok(None);
        };
        let readings = self.store.open_session(s.id)?.current_readings().count() as u64;
        Ok(Some(ResumeOffer {
            session: s.id,
            customer: s.customer_id,
            set: s.measurement_set,
            readings,
        }))
    }

    /// Stores a value the operator captured with the keyboard (Enter: the
    /// tape's live value) as a reading of `measurement`: a keyboard
    /// reading, with no device or sequence number.
    pub fn capture_keyboard(
        &self,
        session: SessionId,
        measurement: &str,
        value_tenth_mm: u32,
    ) -> Result<StoredReading, StoreError> {
        self.change(|tx| {
            let r = tx.insert_keyboard_reading(session, measurement, value_tenth_mm)?;
            let change = Change::ReadingStored {
                session,
                reading: r.id,
                source: r.source,
            };
            Ok((r, Some(change)))
        })
    }

    /// Withdraws reading `id` (the operator's undo): kept in the history,
    /// no longer current; the value it had replaced by a retake is current
    /// again and returned. Withdrawing twice changes nothing.
    pub fn withdraw(&self, id: ReadingId) -> Result<Option<ReadingId>, StoreError> {
        self.change(|tx| {
            let (session, outcome) = tx.withdraw_reading(id)?;
            Ok(match outcome {
                None => (None, None),
                Some(restored) => (
                    restored,
                    Some(Change::Withdrawn {
                        session,
                        reading: id,
                        restored,
                    }),
                ),
            })
        })
    }

    /// Sets (or with `None` clears) the operator's mark on `measurement`.
    pub fn set_mark(
        &self,
        session: SessionId,
        measurement: &str,
        mark: Option<Mark>,
    ) -> Result<(), StoreError> {
        self.change(|tx| {
            tx.set_mark(session, measurement, mark)?;
            let change = Change::Marked {
                session,
                measurement: measurement.to_string(),
                mark,
            };
            Ok(((), Some(change)))
        })
    }

    /// Sets the status of session `id` (closes it, or opens it again).
    pub fn set_status(&self, id: SessionId, status: SessionStatus) -> Result<(), StoreError> {
        self.change(|tx| {
            let from = tx.set_status(id, status)?;
            let change = (from != status).then_some(Change::StatusSet {
                session: id,
                from,
                to: status,
            });
            Ok(((), change))
        })
    }

    /// Deletes session `id` with its readings, marks and estimate.
    pub fn delete(&self, id: SessionId) -> Result<(), StoreError> {
        self.change(|tx| {
            tx.delete_session(id)?;
            Ok(((), Some(Change::Erased { session: id })))
        })
    }

    /// Erases customer `customer` at this station: deletes every session
    /// of theirs (readings, marks, estimates) and the content of their
    /// events still in the outbox, and records the erasure as an event, so
    /// the hub erases them chain-wide on the next sync. One transaction.
    /// Returns the sessions deleted (none is not an error: the hub may hold
    /// sessions of theirs from other stores).
    pub fn erase_customer(&self, customer: &str) -> Result<Vec<SessionId>, StoreError> {
        let hash = tapeshape_hub_api::customer_hash(customer);
        self.change(|tx| {
            let sessions: Vec<SessionId> = tx
                .session_customers()?
                .into_iter()
                .filter(|(_, c)| c == customer)
                .map(|(id, _)| id)
                .collect();
            for id in &sessions {
                tx.delete_session(*id)?;
            }
            let change = Change::CustomerErased {
                customer_hash: hash,
                sessions: sessions.clone(),
            };
            Ok((sessions, Some(change)))
        })
    }

    /// Carries out an erasure the hub asked for: deletes every session
    /// whose customer id has `customer_hash` (and their outbox content).
    /// Doing it twice deletes nothing the second time.
    pub fn apply_hub_erasure(&self, customer_hash: &str) -> Result<Vec<SessionId>, StoreError> {
        self.change(|tx| {
            let sessions: Vec<SessionId> = tx
                .session_customers()?
                .into_iter()
                .filter(|(_, c)| tapeshape_hub_api::customer_hash(c) == customer_hash)
                .map(|(id, _)| id)
                .collect();
            for id in &sessions {
                tx.delete_session(*id)?;
            }
            let change = (!sessions.is_empty()).then(|| Change::ErasedByHub {
                customer_hash: customer_hash.to_string(),
                sessions: sessions.clone(),
            });
            Ok((sessions, change))
        })
    }

    /// Records that the hub holds this station's events 1 ..= `through`
    /// (the sync task, after the hub's answer). Sync bookkeeping, not a
    /// change to a session: no event.
    pub fn mark_hub_committed(&self, through: i64) -> Result<(), StoreError> {
        self.store.write(|tx| tx.mark_committed(through))
    }

    /// Binds this store to the hub's station `name` the first time; returns
    /// the name the store belongs to (another name: the token is for
    /// another station than this store's).
    pub fn bind_station(&self, name: &str) -> Result<String, StoreError> {
        self.store.write(|tx| tx.bind_station(name))
    }

    /// Stores `estimate` as its session's estimate (replacing an earlier one).
    pub fn store_estimate(&self, estimate: &StoredEstimate) -> Result<(), StoreError> {
        self.change(|tx| {
            tx.put_estimate(estimate)?;
            let change = Change::EstimateStored {
                session: estimate.session_id,
            };
            Ok(((), Some(change)))
        })
    }
}

impl ReadingSink for Sessions {
    fn last_committed_seq(&self, device_id: u64, boot_id: u32) -> Result<Option<u32>, StoreError> {
        self.store.last_committed_seq(device_id, boot_id)
    }

    fn commit_tape_reading(
        &self,
        session: SessionId,
        measurement: Option<&str>,
        reading: &DeviceReading,
    ) -> Result<CommitOutcome, StoreError> {
        self.change(|tx| {
            let outcome = tx.commit_tape_reading(session, measurement, reading)?;
            let change = match &outcome {
                CommitOutcome::Committed(r) => Some(Change::ReadingStored {
                    session,
                    reading: r.id,
                    source: r.source,
                }),
                CommitOutcome::Duplicate { .. } | CommitOutcome::Gap { .. } => None,
            };
            Ok((outcome, change))
        })
    }
}

/// What `detail` stands for (see [`Sessions::kept_readings`]), given its
/// careful view (`None`: not a careful session).
fn kept_of(detail: &SessionDetail, careful: Option<&CarefulView>) -> Vec<(String, u32)> {
    match careful {
        None => detail
            .current_readings()
            .map(|r| (r.measurement.clone(), r.value_tenth_mm))
            .collect(),
        Some(v) => v
            .chains
            .iter()
            .filter_map(|(n, c)| Some((n.clone(), careful::kept(c, v.allowed_of(n))?)))
            .collect(),
    }
}

/// The same readings, in any order.
fn same_readings(a: &[(String, u32)], b: &[(String, u32)]) -> bool {
    let mut a = a.to_vec();
    let mut b = b.to_vec();
    a.sort();
    b.sort();
    a == b
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sessions() -> (tempfile::TempDir, Sessions) {
        let dir = tempfile::tempdir().unwrap();
        let s = Sessions::open(dir.path()).unwrap();
        (dir, s)
    }

    #[test]
    fn start_refuses_an_unknown_set_before_storing_anything() {
        let (_dir, s) = sessions();
        let err = s.start("c-1", "no-such-set", None).unwrap_err();
        assert!(matches!(err, SessionError::Set { .. }), "{err}");
        assert!(err.to_string().contains("no-such-set"), "{err}");
        assert!(s.store().list_sessions().unwrap().is_empty());
    }

    #[test]
    fn a_started_session_has_its_set_and_notes_in_one_change() {
        let (_dir, s) = sessions();
        let v = s.start("c-1", "quick", Some("sex: female")).unwrap();
        assert_eq!(v.measurements.len(), 9);
        assert_eq!(v.measurements[0].name, "stature");
        let header = s.store().session(v.id).unwrap();
        assert_eq!(header.notes.as_deref(), Some("sex: female"));
        assert_eq!(header.measurement_set.as_deref(), Some("quick"));
    }

    #[test]
    fn an_estimate_is_current_until_the_readings_change() {
        let (_dir, s) = sessions();
        let v = s.start("c-2", "quick", None).unwrap();
        s.capture_keyboard(v.id, "stature", 17_650).unwrap();
        let chest = s.capture_keyboard(v.id, "chest", 9_820).unwrap();
        s.store_estimate(&StoredEstimate {
            session_id: v.id,
            made_at_ms: 5,
            seconds: 0.3,
            model_source: "test".into(),
            template_sha256: String::new(),
            vertices: vec![[0.0, 0.0, 1.0]],
            // Another order than the readings': still the same readings.
            readings: vec![("chest".into(), 9_820), ("stature".into(), 17_650)],
            report_json: "{}".into(),
        })
        .unwrap();
        let opened = s.open_for_measuring(v.id).unwrap();
        assert_eq!(
            opened.estimate,
            Some(EstimateInfo {
                made_at_ms: 5,
                current: true
            })
        );
        // Undo the chest reading: the estimate is no longer of these readings.
        s.withdraw(chest.id).unwrap();
        let opened = s.open_for_measuring(v.id).unwrap();
        assert_eq!(opened.estimate.map(|e| e.current), Some(false));
    }
}
