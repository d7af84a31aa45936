//! The session store: every customer's readings in one SQLite file.
//!
//! Why SQLite (through rusqlite, bundled): a fitting-room station must never
//! lose a customer's readings, even when the host is killed or loses power in
//! the middle of a measurement. SQLite gives atomic, durable transactions in
//! a single file the operator can back up, with no server to run.
//!
//! Durability rules, in order of importance:
//!
//! * The database runs in WAL mode with `synchronous = FULL`. In WAL mode
//!   `NORMAL` survives an application crash but may lose the last commits on
//!   power loss; the link acknowledges a reading to the tape only after the
//!   commit returns, and the tape then forgets it, so the commit must be on
//!   disk. `FULL` costs one fsync per reading, which at human measuring speed
//!   (a reading every few seconds) is nothing.
//! * [`Store::commit_reading`] stores the reading **and** advances the
//!   per-device sequence bookkeeping in one transaction, so after any crash
//!   the store either has the reading and knows its sequence number, or has
//!   neither: a retransmitted reading is then recognised as a duplicate or
//!   stored once, never twice. `UNIQUE(device_id, boot_id, seq)` backs this
//!   up at the schema level.
//! * A retake of a measurement keeps the earlier reading and marks it
//!   superseded, so the history of a session is never rewritten; an undo
//!   withdraws a reading (kept, no longer current) rather than deleting it.
//!
//! Schema versions are tracked with `PRAGMA user_version`; [`MIGRATIONS`] are
//! applied in order, each in its own immediate transaction, so opening a
//! store twice (or from two processes at once) is harmless.
//!
//! [`Store`] is a cheap, cloneable handle (`Arc<Mutex<Connection>>`): the link
//! commits on a blocking thread while the user interface reads through
//! another clone. Other processes (for example `tapeshape sessions` while the
//! station runs) open their own handle; WAL lets them read while the station
//! writes, and a 5 s busy timeout covers the short write locks.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use rusqlite::{params, Connection, OptionalExtension, TransactionBehavior};

/// File name of the session database inside the data directory.
pub const DB_FILE_NAME: &str = "tapeshape.sqlite3";

/// Environment variable that overrides the default data directory.
pub const DATA_DIR_ENV: &str = "TAPESHAPE_DATA_DIR";

/// Longest customer id accepted (bytes). Customer ids are opaque to the
/// station (a loyalty number, a ticket code), but a bound keeps a stray paste
/// from filling the database.
pub const MAX_CUSTOMER_ID_LEN: usize = 128;

/// Longest measurement name accepted (bytes).
pub const MAX_MEASUREMENT_NAME_LEN: usize = 128;

/// Schema migrations, applied in order. Migration `i` takes the database
/// from `user_version = i` to `user_version = i + 1`. Never edit a released
/// entry; append a new one.
pub const MIGRATIONS: &[&str] = &[
    // 1: sessions, readings, per-device sequence bookkeeping.
    r#"
    CREATE TABLE sessions (
        id              INTEGER PRIMARY KEY,
        customer_id     TEXT    NOT NULL,
        created_at_ms   INTEGER NOT NULL,
        updated_at_ms   INTEGER NOT NULL,
        status          TEXT    NOT NULL CHECK (status IN ('open', 'done', 'abandoned')),
        measurement_set TEXT,
        notes           TEXT
    );
    CREATE INDEX sessions_status_updated ON sessions (status, updated_at_ms);

    CREATE TABLE readings (
        id              INTEGER PRIMARY KEY,
        session_id      INTEGER NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
        measurement     TEXT    NOT NULL,
        value_tenth_mm  INTEGER NOT NULL,
        device_id       INTEGER NOT NULL,
        boot_id         INTEGER NOT NULL,
        seq             INTEGER NOT NULL,
        device_time_ms  INTEGER NOT NULL,
        received_at_ms  INTEGER NOT NULL,
        superseded_by   INTEGER REFERENCES readings (id) ON DELETE SET NULL,
        UNIQUE (device_id, boot_id, seq)
    );
    CREATE INDEX readings_session ON readings (session_id, measurement);

    CREATE TABLE link_state (
        device_id          INTEGER NOT NULL,
        boot_id            INTEGER NOT NULL,
        last_committed_seq INTEGER NOT NULL,
        updated_at_ms      INTEGER NOT NULL,
        PRIMARY KEY (device_id, boot_id)
    );
    "#,
    // 2: the operator's marks survive a restart: a reading withdrawn by
    // undo (kept in the history, no longer current) and per-measurement
    // marks (skipped, a flagged reading kept on purpose).
    r#"
    ALTER TABLE readings ADD COLUMN withdrawn_at_ms INTEGER;
    CREATE TABLE marks (
        session_id  INTEGER NOT NULL REFERENCES sessions (id) ON DELETE CASCADE,
        measurement TEXT    NOT NULL,
        mark        TEXT    NOT NULL CHECK (mark IN ('skipped', 'kept-flagged')),
        at_ms       INTEGER NOT NULL,
        PRIMARY KEY (session_id, measurement)
    );
    "#,
];

/// An operator's mark on one measurement of a session, stored so that a
/// resumed session looks as the operator left it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// The operator skipped the measurement.
    Skipped,
    /// The operator kept a reading the check flagged.
    KeptFlagged,
}

impl Mark {
    fn as_sql(self) -> &'static str {
        match self {
            Mark::Skipped => "skipped",
            Mark::KeptFlagged => "kept-flagged",
        }
    }

    fn from_sql(s: &str) -> Option<Mark> {
        match s {
            "skipped" => Some(Mark::Skipped),
            "kept-flagged" => Some(Mark::KeptFlagged),
            _ => None,
        }
    }
}

/// Errors from the session store. Each message says what went wrong and,
/// where the user can do something about it, what to do.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// No data directory was given and none could be derived from the
    /// user's home directory.
    #[error(
        "no data directory: could not find a home directory to place one in; \
         set one with --data-dir DIR or the {DATA_DIR_ENV} environment variable"
    )]
    NoDefaultDataDir,
    /// The data directory could not be created.
    #[error(
        "cannot create data directory {path}: {error}; \
         choose another with --data-dir DIR or {DATA_DIR_ENV}"
    )]
    CreateDataDir {
        /// The directory.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// The data directory exists but files cannot be written in it.
    #[error(
        "data directory {path} is not writable: {error}; \
         fix its permissions or choose another with --data-dir DIR or {DATA_DIR_ENV}"
    )]
    DataDirNotWritable {
        /// The directory.
        path: PathBuf,
        /// The underlying error.
        error: std::io::Error,
    },
    /// SQLite could not open or set up the database file.
    #[error("cannot open session database {path}: {error}")]
    Open {
        /// The database file.
        path: PathBuf,
        /// The underlying error.
        error: rusqlite::Error,
    },
    /// The database was written by a newer tapeshape.
    #[error(
        "session database {path} has schema version {found}, but this tapeshape \
         understands versions up to {supported}; use a newer tapeshape or another --data-dir"
    )]
    SchemaTooNew {
        /// The database file.
        path: PathBuf,
        /// `user_version` found in the file.
        found: i64,
        /// Highest version this build knows.
        supported: i64,
    },
    /// No session has this id.
    #[error("no session with id {0}; `tapeshape sessions` lists the existing ones")]
    NoSuchSession(SessionId),
    /// No reading has this id.
    #[error("no reading with id {0}; `tapeshape session show ID` lists a session's readings")]
    NoSuchReading(ReadingId),
    /// Readings can only be added to open sessions.
    #[error("session {id} is {status}; readings can only be added to an open session")]
    SessionNotOpen {
        /// The session.
        id: SessionId,
        /// Its status.
        status: SessionStatus,
    },
    /// A customer id was empty, too long or held control characters.
    #[error("invalid customer id {0:?}: use 1 to {MAX_CUSTOMER_ID_LEN} bytes of printable text")]
    InvalidCustomerId(String),
    /// A measurement name was empty, too long or held control characters.
    #[error(
        "invalid measurement name {0:?}: use 1 to {MAX_MEASUREMENT_NAME_LEN} bytes of printable text"
    )]
    InvalidMeasurementName(String),
    /// A row in the database holds a value this program does not understand
    /// (for example an unknown status): the file was edited by hand or
    /// damaged.
    #[error("session database holds an invalid value: {0}")]
    Corrupt(String),
    /// Any other SQLite error.
    #[error("session database error: {0}")]
    Sqlite(#[from] rusqlite::Error),
}

/// Row id of a session.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SessionId(pub i64);

impl fmt::Display for SessionId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// Row id of a stored reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ReadingId(pub i64);

impl fmt::Display for ReadingId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

/// Life cycle of a session.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SessionStatus {
    /// Being measured, or interrupted and resumable.
    Open,
    /// Finished by the operator.
    Done,
    /// Given up (customer left); kept for the record.
    Abandoned,
}

impl SessionStatus {
    /// The text stored in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            SessionStatus::Open => "open",
            SessionStatus::Done => "done",
            SessionStatus::Abandoned => "abandoned",
        }
    }

    fn parse(s: &str) -> Result<Self, StoreError> {
        match s {
            "open" => Ok(SessionStatus::Open),
            "done" => Ok(SessionStatus::Done),
            "abandoned" => Ok(SessionStatus::Abandoned),
            other => Err(StoreError::Corrupt(format!(
                "unknown session status {other:?}"
            ))),
        }
    }
}

impl fmt::Display for SessionStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for SessionStatus {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        SessionStatus::parse(s)
            .map_err(|_| format!("unknown status {s:?}: use open, done or abandoned"))
    }
}

/// A session's header row.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Session {
    /// Row id.
    pub id: SessionId,
    /// Opaque customer id, as typed by the operator.
    pub customer_id: String,
    /// Creation time, milliseconds since the Unix epoch (UTC).
    pub created_at_ms: i64,
    /// Last change (status, notes or a new reading), ms since the Unix epoch.
    pub updated_at_ms: i64,
    /// Life cycle state.
    pub status: SessionStatus,
    /// Name of the measurement set the session follows, if any.
    pub measurement_set: Option<String>,
    /// Free operator notes.
    pub notes: Option<String>,
}

/// A session with reading counts, for listings.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SessionSummary {
    /// The session.
    pub session: Session,
    /// Readings that are current (not superseded by a retake).
    pub current_readings: u64,
    /// All readings, retakes included.
    pub total_readings: u64,
}

/// A reading as it arrives from the tape: what the device said about it.
/// Integer units exactly as on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceReading {
    /// Id of the tape device that took it (stored as the same 64 bits in
    /// a signed SQLite INTEGER).
    pub device_id: u64,
    /// Boot id of the device (differs on every boot); sequence numbers
    /// restart at [`FIRST_SEQ`] with each boot.
    pub boot_id: u32,
    /// Sequence number within the boot.
    pub seq: u32,
    /// Measured length in tenths of a millimetre.
    pub value_tenth_mm: u32,
    /// Device clock when the reading was held, ms since the device booted.
    pub device_time_ms: u64,
}

/// A reading as stored in a session.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StoredReading {
    /// Row id.
    pub id: ReadingId,
    /// The session it belongs to.
    pub session_id: SessionId,
    /// Measurement name the host assigned (for example `chest_circumference`).
    pub measurement: String,
    /// What the device sent.
    pub device: DeviceReading,
    /// Host clock when it was committed, ms since the Unix epoch (UTC).
    pub received_at_ms: i64,
    /// The retake that replaced this reading, if any.
    pub superseded_by: Option<ReadingId>,
    /// When the operator withdrew it (undo), ms since the Unix epoch; a
    /// withdrawn reading stays in the history but is not current.
    pub withdrawn_at_ms: Option<i64>,
}

impl StoredReading {
    /// Value in millimetres (the wire carries tenths of a millimetre).
    pub fn value_mm(&self) -> f64 {
        f64::from(self.device.value_tenth_mm) / 10.0
    }
}

/// A session with all its readings (retakes included), oldest first.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SessionDetail {
    /// The header.
    pub session: Session,
    /// Every reading, in commit order; superseded ones have `superseded_by`.
    pub readings: Vec<StoredReading>,
}

impl SessionDetail {
    /// The readings neither superseded by a retake nor withdrawn, in commit
    /// order: at most one per measurement name.
    pub fn current_readings(&self) -> impl Iterator<Item = &StoredReading> {
        self.readings
            .iter()
            .filter(|r| r.superseded_by.is_none() && r.withdrawn_at_ms.is_none())
    }
}

/// What [`Store::commit_reading`] did with a reading.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CommitOutcome {
    /// Stored; acknowledge `reading.device.seq`.
    Committed(StoredReading),
    /// Already stored earlier (a retransmission); not stored again.
    /// Acknowledge `last_committed_seq` (cumulative).
    Duplicate {
        /// Highest sequence number committed for this device boot.
        last_committed_seq: u32,
    },
    /// One or more readings before this one are missing: not stored, must
    /// not be acknowledged; the device will send the missing ones first.
    Gap {
        /// The sequence number the store needs next.
        expected: u32,
        /// The sequence number that arrived.
        got: u32,
    },
}

/// Handle to the session database. Cheap to clone; all clones share one
/// connection. See the module docs for the durability rules.
#[derive(Clone)]
pub struct Store {
    conn: Arc<Mutex<Connection>>,
    path: PathBuf,
}

impl fmt::Debug for Store {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Store").field("path", &self.path).finish()
    }
}

/// The data directory to use: `explicit` if given (from `--data-dir`), else
/// the `TAPESHAPE_DATA_DIR` environment variable if set and non-empty, else
/// the platform's per-user data directory (`~/.local/share/tapeshape` on
/// Linux).
pub fn resolve_data_dir(explicit: Option<&Path>) -> Result<PathBuf, StoreError> {
    if let Some(dir) = explicit {
        return Ok(dir.to_path_buf());
    }
    if let Some(dir) = std::env::var_os(DATA_DIR_ENV) {
        if !dir.is_empty() {
            return Ok(PathBuf::from(dir));
        }
    }
    directories::ProjectDirs::from("", "", "tapeshape")
        .map(|p| p.data_dir().to_path_buf())
        .ok_or(StoreError::NoDefaultDataDir)
}

/// First sequence number of every device boot (`docs/wire-format.md`:
/// readings are numbered 0, 1, 2, ... per boot, without gaps).
pub const FIRST_SEQ: u32 = 0;

/// SQLite integers are signed 64-bit: a device id is stored as the same 64
/// bits (a bijection, so ids compare and stay unique exactly).
fn device_id_to_sql(id: u64) -> i64 {
    i64::from_ne_bytes(id.to_ne_bytes())
}

fn device_id_from_sql(v: i64) -> u64 {
    u64::from_ne_bytes(v.to_ne_bytes())
}

fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| i64::try_from(d.as_millis()).unwrap_or(i64::MAX))
        .unwrap_or(0)
}

fn valid_text(s: &str, max: usize) -> bool {
    !s.trim().is_empty() && s.len() <= max && !s.chars().any(char::is_control)
}

const SESSION_COLS: &str =
    "id, customer_id, created_at_ms, updated_at_ms, status, measurement_set, notes";
const READING_COLS: &str = "id, session_id, measurement, value_tenth_mm, device_id, boot_id, seq, \
     device_time_ms, received_at_ms, superseded_by, withdrawn_at_ms";

fn session_from_row(row: &rusqlite::Row<'_>) -> rusqlite::Result<(Session, String)> {
    let status: String = row.get(4)?;
    Ok((
        Session {
            id: SessionId(row.get(0)?),
            customer_id: row.get(1)?,
            created_at_ms: row.get(2)?,
            updated_at_ms: row.get(3)?,
            // Parsed by the caller, which can return a typed error.
            status: SessionStatus::Open,
            measurement_set: row.get(5)?,
            notes: row.get(6)?,
        },
        status,
    ))
}

fn finish_session((mut s, status): (Session, String)) -> Result<Session, StoreError> {
    s.status = SessionStatus::parse(&status)?;
    Ok(s)
}

fn reading_from_row(row: &rusqlite::Row<'_>) -> rusqlite::Result<StoredReading> {
    let device_time_ms: i64 = row.get(7)?;
    Ok(StoredReading {
        id: ReadingId(row.get(0)?),
        session_id: SessionId(row.get(1)?),
        measurement: row.get(2)?,
        device: DeviceReading {
            value_tenth_mm: row.get(3)?,
            device_id: device_id_from_sql(row.get(4)?),
            boot_id: row.get(5)?,
            seq: row.get(6)?,
            device_time_ms: u64::try_from(device_time_ms).unwrap_or(0),
        },
        received_at_ms: row.get(8)?,
        superseded_by: row.get::<_, Option<i64>>(9)?.map(ReadingId),
        withdrawn_at_ms: row.get(10)?,
    })
}

impl Store {
    /// Opens (creating if needed) the session database in `data_dir`,
    /// creating the directory and applying pending migrations.
    pub fn open(data_dir: &Path) -> Result<Store, StoreError> {
        std::fs::create_dir_all(data_dir).map_err(|error| StoreError::CreateDataDir {
            path: data_dir.to_path_buf(),
            error,
        })?;
        check_writable(data_dir)?;
        let path = data_dir.join(DB_FILE_NAME);
        let open_err = |error| StoreError::Open {
            path: path.clone(),
            error,
        };
        let mut conn = Connection::open(&path).map_err(open_err)?;
        conn.busy_timeout(Duration::from_secs(5))
            .map_err(open_err)?;
        // journal_mode returns the mode actually set; WAL is refused on some
        // file systems (network mounts), where we fall back to the rollback
        // journal, which is just as durable with synchronous = FULL.
        let mode: String = conn
            .pragma_update_and_check(None, "journal_mode", "wal", |r| r.get(0))
            .map_err(open_err)?;
        if !mode.eq_ignore_ascii_case("wal") {
            tracing::warn!(%mode, path = %path.display(), "WAL not available; using rollback journal");
        }
        conn.pragma_update(None, "synchronous", "FULL")
            .map_err(open_err)?;
        conn.pragma_update(None, "foreign_keys", true)
            .map_err(open_err)?;
        migrate(&mut conn, &path)?;
        Ok(Store {
            conn: Arc::new(Mutex::new(conn)),
            path,
        })
    }

    /// Path of the database file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn lock(&self) -> MutexGuard<'_, Connection> {
        // A panic while holding the lock cannot leave a transaction half
        // applied (rusqlite rolls back on drop), so a poisoned lock is safe
        // to keep using.
        self.conn.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Schema version of the open database (`PRAGMA user_version`).
    pub fn schema_version(&self) -> Result<i64, StoreError> {
        Ok(self
            .lock()
            .pragma_query_value(None, "user_version", |r| r.get(0))?)
    }

    /// Creates an open session for `customer_id` (opaque text: 1 to
    /// [`MAX_CUSTOMER_ID_LEN`] bytes, no control characters).
    pub fn create_session(
        &self,
        customer_id: &str,
        measurement_set: Option<&str>,
    ) -> Result<Session, StoreError> {
        if !valid_text(customer_id, MAX_CUSTOMER_ID_LEN) {
            return Err(StoreError::InvalidCustomerId(customer_id.to_owned()));
        }
        let conn = self.lock();
        let now = now_ms();
        conn.execute(
            "INSERT INTO sessions (customer_id, created_at_ms, updated_at_ms, status, measurement_set)
             VALUES (?1, ?2, ?2, 'open', ?3)",
            params![customer_id, now, measurement_set],
        )?;
        let id = SessionId(conn.last_insert_rowid());
        drop(conn);
        self.session(id)
    }

    /// The header of session `id`.
    pub fn session(&self, id: SessionId) -> Result<Session, StoreError> {
        let conn = self.lock();
        let row = conn
            .query_row(
                &format!("SELECT {SESSION_COLS} FROM sessions WHERE id = ?1"),
                [id.0],
                session_from_row,
            )
            .optional()?;
        finish_session(row.ok_or(StoreError::NoSuchSession(id))?)
    }

    /// All sessions, most recently updated first, with reading counts.
    pub fn list_sessions(&self) -> Result<Vec<SessionSummary>, StoreError> {
        let conn = self.lock();
        let mut stmt = conn.prepare(&format!(
            "SELECT {SESSION_COLS},
                (SELECT COUNT(*) FROM readings r WHERE r.session_id = s.id AND r.superseded_by IS NULL
                    AND r.withdrawn_at_ms IS NULL),
                (SELECT COUNT(*) FROM readings r WHERE r.session_id = s.id)
             FROM sessions s ORDER BY updated_at_ms DESC, id DESC"
        ))?;
        let rows = stmt.query_map([], |row| {
            Ok((
                session_from_row(row)?,
                row.get::<_, i64>(7)?,
                row.get::<_, i64>(8)?,
            ))
        })?;
        let mut out = Vec::new();
        for row in rows {
            let (s, current, total) = row?;
            out.push(SessionSummary {
                session: finish_session(s)?,
                current_readings: u64::try_from(current).unwrap_or(0),
                total_readings: u64::try_from(total).unwrap_or(0),
            });
        }
        Ok(out)
    }

    /// Number of readings in session `id`, retakes included (0 for a
    /// session that does not exist).
    pub fn reading_count(&self, id: SessionId) -> Result<u64, StoreError> {
        let n: i64 = self.lock().query_row(
            "SELECT COUNT(*) FROM readings WHERE session_id = ?1",
            [id.0],
            |r| r.get(0),
        )?;
        Ok(u64::try_from(n).unwrap_or(0))
    }

    /// Session `id` with every reading (retakes included), oldest first.
    pub fn open_session(&self, id: SessionId) -> Result<SessionDetail, StoreError> {
        let session = self.session(id)?;
        let conn = self.lock();
        let mut stmt = conn.prepare(&format!(
            "SELECT {READING_COLS} FROM readings WHERE session_id = ?1 ORDER BY id"
        ))?;
        let readings = stmt
            .query_map([id.0], reading_from_row)?
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SessionDetail { session, readings })
    }

    /// The most recently updated session that is still open, if any: the one
    /// to offer for resuming after a restart.
    pub fn latest_unfinished_session(&self) -> Result<Option<Session>, StoreError> {
        let conn = self.lock();
        let row = conn
            .query_row(
                &format!(
                    "SELECT {SESSION_COLS} FROM sessions WHERE status = 'open'
                     ORDER BY updated_at_ms DESC, id DESC LIMIT 1"
                ),
                [],
                session_from_row,
            )
            .optional()?;
        row.map(finish_session).transpose()
    }

    /// Sets the status of session `id`.
    pub fn set_status(&self, id: SessionId, status: SessionStatus) -> Result<(), StoreError> {
        let n = self.lock().execute(
            "UPDATE sessions SET status = ?2, updated_at_ms = ?3 WHERE id = ?1",
            params![id.0, status.as_str(), now_ms()],
        )?;
        if n == 0 {
            return Err(StoreError::NoSuchSession(id));
        }
        Ok(())
    }

    /// Replaces the notes of session `id`.
    pub fn set_notes(&self, id: SessionId, notes: Option<&str>) -> Result<(), StoreError> {
        let n = self.lock().execute(
            "UPDATE sessions SET notes = ?2, updated_at_ms = ?3 WHERE id = ?1",
            params![id.0, notes, now_ms()],
        )?;
        if n == 0 {
            return Err(StoreError::NoSuchSession(id));
        }
        Ok(())
    }

    /// Deletes session `id` and its readings. The per-device sequence
    /// bookkeeping is kept, so a late retransmission of a deleted reading is
    /// still recognised as a duplicate and not stored again.
    pub fn delete_session(&self, id: SessionId) -> Result<(), StoreError> {
        let n = self
            .lock()
            .execute("DELETE FROM sessions WHERE id = ?1", [id.0])?;
        if n == 0 {
            return Err(StoreError::NoSuchSession(id));
        }
        Ok(())
    }

    /// Highest sequence number committed for this device boot, if any.
    pub fn last_committed_seq(
        &self,
        device_id: u64,
        boot_id: u32,
    ) -> Result<Option<u32>, StoreError> {
        Ok(self
            .lock()
            .query_row(
                "SELECT last_committed_seq FROM link_state WHERE device_id = ?1 AND boot_id = ?2",
                params![device_id_to_sql(device_id), boot_id],
                |r| r.get(0),
            )
            .optional()?)
    }

    /// Commits one reading from the tape to session `session` under the
    /// measurement name `measurement`, applying the sequence rules in one
    /// transaction:
    ///
    /// * `seq <= last committed` for the device boot: [`CommitOutcome::Duplicate`],
    ///   nothing stored;
    /// * `seq == last committed + 1` (or [`FIRST_SEQ`] for a boot never seen):
    ///   stored, the bookkeeping advanced, an earlier current reading of the
    ///   same measurement in the session marked superseded (a retake):
    ///   [`CommitOutcome::Committed`];
    /// * otherwise [`CommitOutcome::Gap`], nothing stored.
    ///
    /// The outcome is durable on disk when this returns `Committed`: only then
    /// may the reading be acknowledged.
    pub fn commit_reading(
        &self,
        session: SessionId,
        measurement: &str,
        reading: &DeviceReading,
    ) -> Result<CommitOutcome, StoreError> {
        if !valid_text(measurement, MAX_MEASUREMENT_NAME_LEN) {
            return Err(StoreError::InvalidMeasurementName(measurement.to_owned()));
        }
        let mut conn = self.lock();
        // IMMEDIATE: take the write lock before reading the bookkeeping, so
        // two writers can never both decide "seq is new".
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let last: Option<u32> = tx
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
        let status: Option<String> = tx
            .query_row(
                "SELECT status FROM sessions WHERE id = ?1",
                [session.0],
                |r| r.get(0),
            )
            .optional()?;
        let status = SessionStatus::parse(&status.ok_or(StoreError::NoSuchSession(session))?)?;
        if status != SessionStatus::Open {
            return Err(StoreError::SessionNotOpen {
                id: session,
                status,
            });
        }
        let now = now_ms();
        let device_time = i64::try_from(reading.device_time_ms).unwrap_or(i64::MAX);
        tx.execute(
            "INSERT INTO readings (session_id, measurement, value_tenth_mm, device_id, boot_id, seq,
                                   device_time_ms, received_at_ms)
             VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
            params![
                session.0,
                measurement,
                reading.value_tenth_mm,
                device_id_to_sql(reading.device_id),
                reading.boot_id,
                reading.seq,
                device_time,
                now
            ],
        )?;
        let id = tx.last_insert_rowid();
        tx.execute(
            "UPDATE readings SET superseded_by = ?1
             WHERE session_id = ?2 AND measurement = ?3 AND id <> ?1 AND superseded_by IS NULL
               AND withdrawn_at_ms IS NULL",
            params![id, session.0, measurement],
        )?;
        tx.execute(
            "INSERT INTO link_state (device_id, boot_id, last_committed_seq, updated_at_ms)
             VALUES (?1, ?2, ?3, ?4)
             ON CONFLICT (device_id, boot_id)
             DO UPDATE SET last_committed_seq = excluded.last_committed_seq,
                           updated_at_ms = excluded.updated_at_ms",
            params![
                device_id_to_sql(reading.device_id),
                reading.boot_id,
                reading.seq,
                now
            ],
        )?;
        tx.execute(
            "UPDATE sessions SET updated_at_ms = ?2 WHERE id = ?1",
            params![session.0, now],
        )?;
        tx.commit()?;
        Ok(CommitOutcome::Committed(StoredReading {
            id: ReadingId(id),
            session_id: session,
            measurement: measurement.to_owned(),
            device: *reading,
            received_at_ms: now,
            superseded_by: None,
            withdrawn_at_ms: None,
        }))
    }

    /// Withdraws reading `id` (the operator's undo): it stays in the
    /// session's history but is no longer current, and the reading it had
    /// superseded (the value before a retake) is current again. Returns
    /// that restored reading, if any. Withdrawing twice is harmless.
    pub fn withdraw_reading(&self, id: ReadingId) -> Result<Option<ReadingId>, StoreError> {
        let mut conn = self.lock();
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let session: Option<i64> = tx
            .query_row(
                "SELECT session_id FROM readings WHERE id = ?1",
                [id.0],
                |r| r.get(0),
            )
            .optional()?;
        let Some(session) = session else {
            return Err(StoreError::NoSuchReading(id));
        };
        let now = now_ms();
        let changed = tx.execute(
            "UPDATE readings SET withdrawn_at_ms = ?2 WHERE id = ?1 AND withdrawn_at_ms IS NULL",
            params![id.0, now],
        )?;
        let mut restored = None;
        if changed > 0 {
            restored = tx
                .query_row(
                    "SELECT id FROM readings WHERE superseded_by = ?1 AND withdrawn_at_ms IS NULL
                     ORDER BY id DESC LIMIT 1",
                    [id.0],
                    |r| r.get::<_, i64>(0),
                )
                .optional()?;
            tx.execute(
                "UPDATE readings SET superseded_by = NULL WHERE superseded_by = ?1",
                [id.0],
            )?;
            tx.execute(
                "UPDATE sessions SET updated_at_ms = ?2 WHERE id = ?1",
                params![session, now],
            )?;
        }
        tx.commit()?;
        Ok(restored.map(ReadingId))
    }

    /// Sets (or with `None` clears) the operator's mark on `measurement` of
    /// `session`.
    pub fn set_mark(
        &self,
        session: SessionId,
        measurement: &str,
        mark: Option<Mark>,
    ) -> Result<(), StoreError> {
        let conn = self.lock();
        match mark {
            Some(m) => {
                conn.execute(
                    "INSERT INTO marks (session_id, measurement, mark, at_ms) VALUES (?1, ?2, ?3, ?4)
                     ON CONFLICT (session_id, measurement)
                     DO UPDATE SET mark = excluded.mark, at_ms = excluded.at_ms",
                    params![session.0, measurement, m.as_sql(), now_ms()],
                )
                .map_err(|e| match e {
                    rusqlite::Error::SqliteFailure(f, _)
                        if f.code == rusqlite::ErrorCode::ConstraintViolation =>
                    {
                        StoreError::NoSuchSession(session)
                    }
                    e => e.into(),
                })?;
            }
            None => {
                conn.execute(
                    "DELETE FROM marks WHERE session_id = ?1 AND measurement = ?2",
                    params![session.0, measurement],
                )?;
            }
        }
        Ok(())
    }

    /// The operator's marks in `session` (measurement name, mark), by name.
    pub fn marks(&self, session: SessionId) -> Result<Vec<(String, Mark)>, StoreError> {
        let conn = self.lock();
        let mut stmt = conn.prepare(
            "SELECT measurement, mark FROM marks WHERE session_id = ?1 ORDER BY measurement",
        )?;
        let rows = stmt.query_map([session.0], |r| {
            Ok((r.get::<_, String>(0)?, r.get::<_, String>(1)?))
        })?;
        let mut out = Vec::new();
        for row in rows {
            let (name, mark) = row?;
            // The CHECK constraint admits only known marks; an unknown one
            // (a newer program's) is skipped rather than failing the session.
            if let Some(m) = Mark::from_sql(&mark) {
                out.push((name, m));
            }
        }
        Ok(out)
    }
}

/// Creates and removes a probe file so that an unwritable data directory is
/// reported with its path, rather than as SQLite's terse "unable to open
/// database file".
fn check_writable(dir: &Path) -> Result<(), StoreError> {
    let probe = dir.join(format!(".tapeshape-write-test-{}", std::process::id()));
    let err = |error| StoreError::DataDirNotWritable {
        path: dir.to_path_buf(),
        error,
    };
    std::fs::write(&probe, b"").map_err(err)?;
    std::fs::remove_file(&probe).map_err(err)
}

fn migrate(conn: &mut Connection, path: &Path) -> Result<(), StoreError> {
    let supported = MIGRATIONS.len() as i64;
    loop {
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        // Read inside the write lock: another process may have migrated
        // between our checks.
        let version: i64 = tx.pragma_query_value(None, "user_version", |r| r.get(0))?;
        if version < 0 {
            return Err(StoreError::Corrupt(format!(
                "{} has negative schema version {version}",
                path.display()
            )));
        }
        if version > supported {
            return Err(StoreError::SchemaTooNew {
                path: path.to_path_buf(),
                found: version,
                supported,
            });
        }
        if version == supported {
            return Ok(());
        }
        let step = MIGRATIONS[usize::try_from(version).unwrap_or(0)];
        tx.execute_batch(step)?;
        tx.pragma_update(None, "user_version", version + 1)?;
        tx.commit()?;
        tracing::info!(path = %path.display(), version = version + 1, "session database migrated");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(device_id: u64, boot_id: u32, seq: u32, value: u32) -> DeviceReading {
        DeviceReading {
            device_id,
            boot_id,
            seq,
            value_tenth_mm: value,
            device_time_ms: u64::from(seq) * 1000,
        }
    }

    fn temp_store() -> (tempfile::TempDir, Store) {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        (dir, store)
    }

    fn committed(outcome: CommitOutcome) -> StoredReading {
        match outcome {
            CommitOutcome::Committed(r) => r,
            other => panic!("expected Committed, got {other:?}"),
        }
    }

    #[test]
    fn commit_duplicate_gap_rules() {
        let (_dir, store) = temp_store();
        let s = store.create_session("C-1", Some("basic")).unwrap();
        // A never-seen boot must start at FIRST_SEQ (0).
        assert_eq!(
            store
                .commit_reading(s.id, "a", &reading(7, 1, 1, 100))
                .unwrap(),
            CommitOutcome::Gap {
                expected: 0,
                got: 1
            }
        );
        let r0 = committed(
            store
                .commit_reading(s.id, "a", &reading(7, 1, 0, 100))
                .unwrap(),
        );
        assert_eq!(r0.device.seq, 0);
        assert_eq!(r0.value_mm(), 10.0);
        // Retransmission of 0: duplicate, acked as 0, the new value ignored.
        assert_eq!(
            store
                .commit_reading(s.id, "b", &reading(7, 1, 0, 999))
                .unwrap(),
            CommitOutcome::Duplicate {
                last_committed_seq: 0
            }
        );
        // 2 before 1: gap.
        assert_eq!(
            store
                .commit_reading(s.id, "b", &reading(7, 1, 2, 300))
                .unwrap(),
            CommitOutcome::Gap {
                expected: 1,
                got: 2
            }
        );
        committed(
            store
                .commit_reading(s.id, "b", &reading(7, 1, 1, 200))
                .unwrap(),
        );
        committed(
            store
                .commit_reading(s.id, "c", &reading(7, 1, 2, 300))
                .unwrap(),
        );
        // Another boot of the same device starts over; another device is independent.
        committed(
            store
                .commit_reading(s.id, "d", &reading(7, 2, 0, 400))
                .unwrap(),
        );
        committed(
            store
                .commit_reading(s.id, "e", &reading(8, 1, 0, 500))
                .unwrap(),
        );
        // Device ids use all 64 bits.
        committed(
            store
                .commit_reading(s.id, "f", &reading(u64::MAX, 1, 0, 600))
                .unwrap(),
        );
        let detail = store.open_session(s.id).unwrap();
        let got: Vec<(String, u64, u32, u32)> = detail
            .readings
            .iter()
            .map(|r| {
                (
                    r.measurement.clone(),
                    r.device.device_id,
                    r.device.value_tenth_mm,
                    r.device.seq,
                )
            })
            .collect();
        assert_eq!(
            got,
            vec![
                ("a".into(), 7, 100, 0),
                ("b".into(), 7, 200, 1),
                ("c".into(), 7, 300, 2),
                ("d".into(), 7, 400, 0),
                ("e".into(), 8, 500, 0),
                ("f".into(), u64::MAX, 600, 0),
            ]
        );
        assert_eq!(store.last_committed_seq(7, 1).unwrap(), Some(2));
        assert_eq!(store.last_committed_seq(u64::MAX, 1).unwrap(), Some(0));
        assert_eq!(store.last_committed_seq(7, 3).unwrap(), None);
    }

    #[test]
    fn schema_forbids_storing_a_reading_twice() {
        let (_dir, store) = temp_store();
        let s = store.create_session("C-1", None).unwrap();
        committed(
            store
                .commit_reading(s.id, "a", &reading(1, 1, 0, 10))
                .unwrap(),
        );
        // Bypass the bookkeeping: the UNIQUE constraint must still refuse it.
        let conn = store.lock();
        let err = conn
            .execute(
                "INSERT INTO readings (session_id, measurement, value_tenth_mm, device_id, boot_id, seq,
                 device_time_ms, received_at_ms) VALUES (?1, 'x', 1, 1, 1, 0, 0, 0)",
                [s.id.0],
            )
            .unwrap_err();
        assert!(err.to_string().contains("UNIQUE"), "{err}");
    }

    #[test]
    fn retake_supersedes_and_keeps_history() {
        let (_dir, store) = temp_store();
        let s = store.create_session("C-1", None).unwrap();
        for (seq, (name, v)) in [("waist", 800), ("hip", 950), ("waist", 812)]
            .into_iter()
            .enumerate()
        {
            let seq = u32::try_from(seq).unwrap();
            committed(
                store
                    .commit_reading(s.id, name, &reading(1, 1, seq, v))
                    .unwrap(),
            );
        }
        let detail = store.open_session(s.id).unwrap();
        assert_eq!(detail.readings.len(), 3);
        assert_eq!(
            detail.readings[0].superseded_by,
            Some(detail.readings[2].id)
        );
        assert_eq!(detail.readings[1].superseded_by, None);
        let current: Vec<(&str, u32)> = detail
            .current_readings()
            .map(|r| (r.measurement.as_str(), r.device.value_tenth_mm))
            .collect();
        assert_eq!(current, vec![("hip", 950), ("waist", 812)]);
        let summary = &store.list_sessions().unwrap()[0];
        assert_eq!((summary.current_readings, summary.total_readings), (2, 3));
    }

    #[test]
    fn withdrawing_a_retake_restores_the_value_before_and_keeps_history() {
        let (_dir, store) = temp_store();
        let s = store.create_session("C-2", None).unwrap();
        let mut ids = Vec::new();
        for (seq, (name, v)) in [("waist", 800), ("hip", 950), ("waist", 812)]
            .into_iter()
            .enumerate()
        {
            let seq = u32::try_from(seq).unwrap();
            match store
                .commit_reading(s.id, name, &reading(1, 1, seq, v))
                .unwrap()
            {
                CommitOutcome::Committed(r) => ids.push(r.id),
                other => panic!("{other:?}"),
            }
        }
        // Undo the retake: the first waist is current again.
        assert_eq!(store.withdraw_reading(ids[2]).unwrap(), Some(ids[0]));
        let current = |store: &Store| -> Vec<(String, u32)> {
            store
                .open_session(s.id)
                .unwrap()
                .current_readings()
                .map(|r| (r.measurement.clone(), r.device.value_tenth_mm))
                .collect()
        };
        assert_eq!(
            current(&store),
            vec![("waist".to_string(), 800), ("hip".to_string(), 950)]
        );
        // Twice is harmless; nothing is deleted.
        assert_eq!(store.withdraw_reading(ids[2]).unwrap(), None);
        let detail = store.open_session(s.id).unwrap();
        assert_eq!(detail.readings.len(), 3);
        assert!(detail.readings[2].withdrawn_at_ms.is_some());
        // Undo the hip: no hip is current, and a new waist supersedes only
        // the current one.
        assert_eq!(store.withdraw_reading(ids[1]).unwrap(), None);
        committed(
            store
                .commit_reading(s.id, "waist", &reading(1, 1, 3, 820))
                .unwrap(),
        );
        assert_eq!(current(&store), vec![("waist".to_string(), 820)]);
        let summary = &store.list_sessions().unwrap()[0];
        assert_eq!((summary.current_readings, summary.total_readings), (1, 4));
        assert!(matches!(
            store.withdraw_reading(ReadingId(999)),
            Err(StoreError::NoSuchReading(_))
        ));
    }

    #[test]
    fn marks_round_trip_and_clear() {
        let (_dir, store) = temp_store();
        let s = store.create_session("C-3", Some("quick")).unwrap();
        store.set_mark(s.id, "neck", Some(Mark::Skipped)).unwrap();
        store
            .set_mark(s.id, "chest", Some(Mark::KeptFlagged))
            .unwrap();
        store
            .set_mark(s.id, "neck", Some(Mark::KeptFlagged))
            .unwrap();
        assert_eq!(
            store.marks(s.id).unwrap(),
            vec![
                ("chest".to_string(), Mark::KeptFlagged),
                ("neck".to_string(), Mark::KeptFlagged)
            ]
        );
        store.set_mark(s.id, "chest", None).unwrap();
        assert_eq!(
            store.marks(s.id).unwrap(),
            vec![("neck".to_string(), Mark::KeptFlagged)]
        );
        assert!(matches!(
            store.set_mark(SessionId(77), "neck", Some(Mark::Skipped)),
            Err(StoreError::NoSuchSession(_))
        ));
        store.delete_session(s.id).unwrap();
        assert!(store.marks(s.id).unwrap().is_empty());
    }

    #[test]
    fn reopen_after_drop_keeps_everything_and_migrations_are_idempotent() {
        let dir = tempfile::tempdir().unwrap();
        let id = {
            let store = Store::open(dir.path()).unwrap();
            let s = store.create_session("C-9", Some("full")).unwrap();
            for seq in 0..5 {
                committed(
                    store
                        .commit_reading(s.id, &format!("m{seq}"), &reading(3, 4, seq, 100 + seq))
                        .unwrap(),
                );
            }
            s.id
        };
        for _ in 0..3 {
            let store = Store::open(dir.path()).unwrap();
            assert_eq!(store.schema_version().unwrap(), MIGRATIONS.len() as i64);
            let detail = store.open_session(id).unwrap();
            assert_eq!(detail.session.customer_id, "C-9");
            assert_eq!(detail.session.measurement_set.as_deref(), Some("full"));
            let values: Vec<u32> = detail
                .readings
                .iter()
                .map(|r| r.device.value_tenth_mm)
                .collect();
            assert_eq!(values, vec![100, 101, 102, 103, 104]);
            // The bookkeeping survived too: seq 4 is a duplicate, 5 is next.
            assert_eq!(
                store.commit_reading(id, "x", &reading(3, 4, 4, 0)).unwrap(),
                CommitOutcome::Duplicate {
                    last_committed_seq: 4
                }
            );
        }
        let store = Store::open(dir.path()).unwrap();
        committed(
            store
                .commit_reading(id, "m5", &reading(3, 4, 5, 105))
                .unwrap(),
        );
    }

    #[test]
    fn newer_schema_is_refused_with_a_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        drop(Store::open(dir.path()).unwrap());
        {
            let conn = Connection::open(dir.path().join(DB_FILE_NAME)).unwrap();
            conn.pragma_update(None, "user_version", 99).unwrap();
        }
        let err = Store::open(dir.path()).unwrap_err();
        let msg = err.to_string();
        assert!(
            matches!(err, StoreError::SchemaTooNew { found: 99, .. }),
            "{msg}"
        );
        assert!(msg.contains("99") && msg.contains("--data-dir"), "{msg}");
    }

    #[test]
    fn session_lifecycle() {
        let (_dir, store) = temp_store();
        assert_eq!(store.latest_unfinished_session().unwrap(), None);
        let a = store.create_session("A", None).unwrap();
        let b = store.create_session("B", None).unwrap();
        assert_eq!(a.status, SessionStatus::Open);
        assert_eq!(store.latest_unfinished_session().unwrap().unwrap().id, b.id);
        store.set_status(b.id, SessionStatus::Done).unwrap();
        assert_eq!(store.latest_unfinished_session().unwrap().unwrap().id, a.id);
        // Closed sessions take no readings...
        let err = store
            .commit_reading(b.id, "x", &reading(1, 1, 0, 1))
            .unwrap_err();
        assert!(matches!(
            err,
            StoreError::SessionNotOpen {
                status: SessionStatus::Done,
                ..
            }
        ));
        // ...and the refused reading did not advance the bookkeeping.
        assert_eq!(store.last_committed_seq(1, 1).unwrap(), None);
        committed(
            store
                .commit_reading(a.id, "x", &reading(1, 1, 0, 1))
                .unwrap(),
        );
        store.set_notes(a.id, Some("left early")).unwrap();
        assert_eq!(
            store.session(a.id).unwrap().notes.as_deref(),
            Some("left early")
        );
        store.delete_session(a.id).unwrap();
        assert!(matches!(
            store.open_session(a.id),
            Err(StoreError::NoSuchSession(_))
        ));
        assert!(matches!(
            store.delete_session(a.id),
            Err(StoreError::NoSuchSession(_))
        ));
        // A late retransmission of a deleted reading is still a duplicate.
        assert_eq!(
            store
                .commit_reading(b.id, "x", &reading(1, 1, 0, 1))
                .unwrap(),
            CommitOutcome::Duplicate {
                last_committed_seq: 0
            }
        );
        assert_eq!(store.list_sessions().unwrap().len(), 1);
    }

    #[test]
    fn bad_text_is_refused() {
        let (_dir, store) = temp_store();
        for bad in ["", "   ", "a\nb", &"x".repeat(MAX_CUSTOMER_ID_LEN + 1)] {
            assert!(matches!(
                store.create_session(bad, None),
                Err(StoreError::InvalidCustomerId(_))
            ));
        }
        let s = store.create_session("ok", None).unwrap();
        assert!(matches!(
            store.commit_reading(s.id, "", &reading(1, 1, 0, 1)),
            Err(StoreError::InvalidMeasurementName(_))
        ));
    }

    #[test]
    fn unwritable_data_dir_names_the_path() {
        let dir = tempfile::tempdir().unwrap();
        // A regular file where a parent directory should be: cannot be created.
        let file = dir.path().join("not-a-dir");
        std::fs::write(&file, b"x").unwrap();
        let target = file.join("data");
        let err = Store::open(&target).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains(&target.display().to_string()), "{msg}");
        assert!(msg.contains("--data-dir"), "{msg}");
    }

    #[test]
    fn a_damaged_database_file_is_named_in_the_error() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join(DB_FILE_NAME);
        std::fs::write(&file, vec![0x5au8; 8192]).unwrap();
        let err = Store::open(dir.path()).unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, StoreError::Open { .. }), "{msg}");
        assert!(msg.contains(&file.display().to_string()), "{msg}");
    }

    #[test]
    fn explicit_data_dir_wins() {
        let p = Path::new("/some/where");
        assert_eq!(resolve_data_dir(Some(p)).unwrap(), p);
    }
}
