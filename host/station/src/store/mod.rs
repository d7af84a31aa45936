//! The session store: every customer's readings in one SQLite file.
//!
//! Why SQLite (through rusqlite, bundled): a fitting-room station must never
//! lose a customer's readings, even when the host is killed or loses power in
//! the middle of a measurement. SQLite gives atomic, durable transactions in
//! a single file the operator can back up, with no server to run.
//!
//! Layer: the bottom of the station (with the link). The store reads and
//! writes rows; what a session *is* (which change is allowed, what a change
//! records) is the session layer's ([`crate::session`]), which is the only
//! caller of `Store::write` (crate-private). Reads are open to every layer above.
//!
//! Durability rules, in order of importance:
//!
//! * The database runs in WAL mode with `synchronous = FULL`. In WAL mode
//!   `NORMAL` survives an application crash but may lose the last commits on
//!   power loss; the link acknowledges a reading to the tape only after the
//!   commit returns, and the tape then forgets it, so the commit must be on
//!   disk. `FULL` costs one fsync per reading, which at human measuring speed
//!   (a reading every few seconds) is nothing.
//! * `WriteTx::commit_tape_reading` stores the reading **and** advances the
//!   per-device sequence bookkeeping in one transaction, so after any crash
//!   the store either has the reading and knows its sequence number, or has
//!   neither: a retransmitted reading is then recognised as a duplicate or
//!   stored once, never twice. `UNIQUE(device_id, boot_id, seq)` backs this
//!   up at the schema level.
//! * A retake of a measurement keeps the earlier reading and marks it
//!   superseded, so the history of a session is never rewritten; an undo
//!   withdraws a reading (kept, no longer current) rather than deleting it.
//!
//! Schema versions are tracked with `PRAGMA user_version`; the migrations are
//! SQL files ([`migrations`]).
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

pub mod migrations;
mod types;
mod write;

pub use migrations::{Migration, MIGRATIONS};
pub use types::{
    decode_vertices, encode_vertices, CommitOutcome, Consent, DeviceReading, Mark, ReadingId,
    ReadingSource, Session, SessionDetail, SessionId, SessionStatus, SessionSummary,
    StoredEstimate, StoredReading, TapeOrigin, UnknownStatus, VERTEX_BYTES,
};
pub(crate) use write::WriteTx;

use types::{device_id_from_sql, device_id_to_sql, SourceKind, UnknownValue};

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

/// First sequence number of every device boot (`docs/wire-format.md`:
/// readings are numbered 0, 1, 2, ... per boot, without gaps).
pub const FIRST_SEQ: u32 = 0;

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
    /// A migration failed; nothing of it was applied.
    #[error(
        "cannot bring session database {path} up to date (migration {file}): {error}; \
         the database is unchanged: keep a copy and report this"
    )]
    Migration {
        /// The database file.
        path: PathBuf,
        /// The migration file.
        file: &'static str,
        /// SQLite's error.
        error: rusqlite::Error,
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
    Sqlite(rusqlite::Error),
}

impl From<rusqlite::Error> for StoreError {
    /// A value the row mapping does not understand (`UnknownValue`) is
    /// [`StoreError::Corrupt`]; anything else is [`StoreError::Sqlite`].
    fn from(e: rusqlite::Error) -> Self {
        match e {
            rusqlite::Error::FromSqlConversionFailure(col, _, inner)
                if inner.downcast_ref::<UnknownValue>().is_some() =>
            {
                StoreError::Corrupt(format!("{inner} (column {col})"))
            }
            e => StoreError::Sqlite(e),
        }
    }
}

/// One event of the outbox (migration 0005 describes the columns).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutboxEvent {
    /// The station's sequence number (1, 2, ...).
    pub seq: i64,
    /// The session it concerns (`None`: a customer's erasure, or redacted).
    pub session: Option<SessionId>,
    /// When the change was committed, ms since the Unix epoch.
    pub at_ms: i64,
    /// Its kind (`created`, `reading_stored`, ..., `redacted`).
    pub kind: String,
    /// The event as JSON (`tapeshape_hub_api::EventBody`).
    pub body: String,
    /// When the hub answered that it committed it.
    pub committed_at_ms: Option<i64>,
}

/// The station's sync bookkeeping.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SyncState {
    /// The station's name at the hub (set by the first start with a token).
    pub station: Option<String>,
    /// The hub holds events 1 ..= this.
    pub hub_committed_seq: i64,
    /// The last event written (0: none).
    pub last_seq: i64,
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

pub(crate) fn now_ms() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| i64::try_from(d.as_millis()).unwrap_or(i64::MAX))
        .unwrap_or(0)
}

pub(crate) fn valid_text(s: &str, max: usize) -> bool {
    !s.trim().is_empty() && s.len() <= max && !s.chars().any(char::is_control)
}

const SESSION_COLS: &str =
    "id, customer_id, created_at_ms, updated_at_ms, status, measurement_set, notes, consent";
const READING_COLS: &str = "id, session_id, measurement, value_tenth_mm, source, device_id, \
     boot_id, seq, device_time_ms, received_at_ms, superseded_by, withdrawn_at_ms";

fn session_from_row(row: &rusqlite::Row<'_>) -> rusqlite::Result<Session> {
    Ok(Session {
        id: SessionId(row.get(0)?),
        customer_id: row.get(1)?,
        created_at_ms: row.get(2)?,
        updated_at_ms: row.get(3)?,
        status: row.get(4)?,
        measurement_set: row.get(5)?,
        notes: row.get(6)?,
        consent: row.get(7)?,
    })
}

pub(crate) fn reading_from_row(row: &rusqlite::Row<'_>) -> rusqlite::Result<StoredReading> {
    let source = match row.get::<_, SourceKind>(4)? {
        SourceKind::Keyboard => ReadingSource::Keyboard,
        SourceKind::Tape => {
            let device_time_ms: i64 = row.get(8)?;
            ReadingSource::Tape(TapeOrigin {
                device_id: device_id_from_sql(row.get(5)?),
                boot_id: row.get(6)?,
                seq: row.get(7)?,
                device_time_ms: u64::try_from(device_time_ms).unwrap_or(0),
            })
        }
    };
    Ok(StoredReading {
        id: ReadingId(row.get(0)?),
        session_id: SessionId(row.get(1)?),
        measurement: row.get(2)?,
        value_tenth_mm: row.get(3)?,
        source,
        received_at_ms: row.get(9)?,
        superseded_by: row.get::<_, Option<i64>>(10)?.map(ReadingId),
        withdrawn_at_ms: row.get(11)?,
    })
}

impl Store {
    /// Opens (creating if needed) the session database in `data_dir`,
    /// creating the directory and applying pending migrations.
    pub fn open(data_dir: &Path) -> Result<Store, StoreError> {
        // Owner-only: the folder and every file of the store hold customer
        // data (a folder made here is 0700; the database and its -wal and
        // -shm files are 0600, which SQLite copies from the database file
        // to the files it makes beside it).
        {
            use std::os::unix::fs::DirBuilderExt as _;
            std::fs::DirBuilder::new()
                .recursive(true)
                .mode(0o700)
                .create(data_dir)
                .map_err(|error| StoreError::CreateDataDir {
                    path: data_dir.to_path_buf(),
                    error,
                })?;
        }
        check_writable(data_dir)?;
        let path = data_dir.join(DB_FILE_NAME);
        owner_only(&path, true).map_err(|error| StoreError::DataDirNotWritable {
            path: data_dir.to_path_buf(),
            error,
        })?;
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
        migrations::migrate(&mut conn, &path)?;
        // A store made by an older tapeshape (0644): its files become
        // owner-only too.
        for suffix in ["-wal", "-shm", "-journal"] {
            let mut p = path.clone().into_os_string();
            p.push(suffix);
            let _ = owner_only(Path::new(&p), false);
        }
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

    /// Runs `f` in one immediate transaction (the write lock taken first, so
    /// two writers never both decide on the same rows): committed when `f`
    /// returns `Ok`, rolled back when it returns `Err` (or panics).
    ///
    /// Only the session layer calls this ([`crate::session::Sessions`]):
    /// every change to a session goes through one of its functions.
    pub(crate) fn write<T>(
        &self,
        f: impl FnOnce(&WriteTx<'_>) -> Result<T, StoreError>,
    ) -> Result<T, StoreError> {
        let mut conn = self.lock();
        let tx = conn.transaction_with_behavior(TransactionBehavior::Immediate)?;
        let wtx = WriteTx::new(&tx);
        let value = f(&wtx)?;
        tx.commit()?;
        Ok(value)
    }

    /// Schema version of the open database (`PRAGMA user_version`).
    pub fn schema_version(&self) -> Result<i64, StoreError> {
        Ok(self
            .lock()
            .pragma_query_value(None, "user_version", |r| r.get(0))?)
    }

    /// The header of session `id`.
    pub fn session(&self, id: SessionId) -> Result<Session, StoreError> {
        session_header(&self.lock(), id)
    }

    /// Does session `id` take each measurement twice (careful mode,
    /// `crate::session::careful`)? Sessions from before careful mode do not.
    pub fn is_careful(&self, id: SessionId) -> Result<bool, StoreError> {
        self.lock()
            .query_row("SELECT careful FROM sessions WHERE id = ?1", [id.0], |r| {
                r.get::<_, bool>(0)
            })
            .optional()?
            .ok_or(StoreError::NoSuchSession(id))
    }

    /// All sessions, most recently updated first, with reading counts.
    pub fn list_sessions(&self) -> Result<Vec<SessionSummary>, StoreError> {
        let conn = self.lock();
        let mut stmt = conn.prepare(&format!(
            "SELECT {SESSION_COLS},
                (SELECT COUNT(*) FROM readings r WHERE r.session_id = s.id AND r.superseded_by IS NULL
                    AND r.withdrawn_at_ms IS NULL),
                (SELECT COUNT(*) FROM readings r WHERE r.session_id = s.id),
                (SELECT made_at_ms FROM estimates e WHERE e.session_id = s.id)
             FROM sessions s ORDER BY updated_at_ms DESC, id DESC"
        ))?;
        let rows = stmt.query_map([], |row| {
            Ok(SessionSummary {
                session: session_from_row(row)?,
                current_readings: u64::try_from(row.get::<_, i64>(8)?).unwrap_or(0),
                total_readings: u64::try_from(row.get::<_, i64>(9)?).unwrap_or(0),
                estimate_made_at_ms: row.get(10)?,
            })
        })?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
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
        let conn = self.lock();
        let session = session_header(&conn, id)?;
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
        Ok(self
            .lock()
            .query_row(
                &format!(
                    "SELECT {SESSION_COLS} FROM sessions WHERE status = ?1
                     ORDER BY updated_at_ms DESC, id DESC LIMIT 1"
                ),
                [SessionStatus::Open],
                session_from_row,
            )
            .optional()?)
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

    /// The operator's marks in `session` (measurement name, mark), by name.
    pub fn marks(&self, session: SessionId) -> Result<Vec<(String, Mark)>, StoreError> {
        let conn = self.lock();
        let mut stmt = conn.prepare(
            "SELECT measurement, mark FROM marks WHERE session_id = ?1 ORDER BY measurement",
        )?;
        let rows = stmt.query_map([session.0], |r| Ok((r.get(0)?, r.get(1)?)))?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// The stored estimate of `session`, if it has one.
    pub fn estimate(&self, session: SessionId) -> Result<Option<StoredEstimate>, StoreError> {
        let row = self
            .lock()
            .query_row(
                "SELECT made_at_ms, seconds, model_source, template_sha256, n_vertices, vertices,
                        readings_json, report_json
                 FROM estimates WHERE session_id = ?1",
                [session.0],
                |r| {
                    Ok((
                        r.get::<_, i64>(0)?,
                        r.get::<_, f64>(1)?,
                        r.get::<_, String>(2)?,
                        r.get::<_, String>(3)?,
                        r.get::<_, i64>(4)?,
                        r.get::<_, Vec<u8>>(5)?,
                        r.get::<_, String>(6)?,
                        r.get::<_, String>(7)?,
                    ))
                },
            )
            .optional()?;
        let Some((made_at_ms, seconds, model_source, template_sha256, n, blob, readings, report)) =
            row
        else {
            return Ok(None);
        };
        let corrupt = |what: &str| {
            StoreError::Corrupt(format!("the stored estimate of session {session}: {what}"))
        };
        let vertices = decode_vertices(&blob)
            .filter(|v| i64::try_from(v.len()).ok() == Some(n))
            .ok_or_else(|| corrupt("its vertices do not match their count"))?;
        let readings: Vec<(String, u32)> = serde_json::from_str(&readings)
            .map_err(|e| corrupt(&format!("its list of readings does not read ({e})")))?;
        Ok(Some(StoredEstimate {
            session_id: session,
            made_at_ms,
            seconds,
            model_source,
            template_sha256,
            vertices,
            readings,
            report_json: report,
        }))
    }

    /// Outbox events after `after` (their `seq` greater), oldest first, at
    /// most `limit`: what the sync task sends next.
    pub fn outbox_after(&self, after: i64, limit: usize) -> Result<Vec<OutboxEvent>, StoreError> {
        let conn = self.lock();
        let mut stmt = conn.prepare(
            "SELECT seq, session_id, at_ms, kind, body, committed_at_ms FROM outbox
             WHERE seq > ?1 ORDER BY seq LIMIT ?2",
        )?;
        let rows = stmt.query_map(
            params![after, i64::try_from(limit).unwrap_or(i64::MAX)],
            |r| {
                Ok(OutboxEvent {
                    seq: r.get(0)?,
                    session: r.get::<_, Option<i64>>(1)?.map(SessionId),
                    at_ms: r.get(2)?,
                    kind: r.get(3)?,
                    body: r.get(4)?,
                    committed_at_ms: r.get(5)?,
                })
            },
        )?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }

    /// The station's sync bookkeeping.
    pub fn sync_state(&self) -> Result<SyncState, StoreError> {
        let conn = self.lock();
        let (station, committed): (Option<String>, i64) = conn.query_row(
            "SELECT station, hub_committed_seq FROM sync_state WHERE id = 1",
            [],
            |r| Ok((r.get(0)?, r.get(1)?)),
        )?;
        let last: i64 =
            conn.query_row("SELECT COALESCE(MAX(seq), 0) FROM outbox", [], |r| r.get(0))?;
        Ok(SyncState {
            station,
            hub_committed_seq: committed,
            last_seq: last,
        })
    }

    /// The sessions of `customer` (exactly this id), oldest first.
    pub fn customer_sessions(&self, customer: &str) -> Result<Vec<Session>, StoreError> {
        let conn = self.lock();
        let mut stmt = conn.prepare(&format!(
            "SELECT {SESSION_COLS} FROM sessions WHERE customer_id = ?1 ORDER BY created_at_ms, id"
        ))?;
        let rows = stmt.query_map([customer], session_from_row)?;
        Ok(rows.collect::<Result<Vec<_>, _>>()?)
    }
}

fn session_header(conn: &Connection, id: SessionId) -> Result<Session, StoreError> {
    conn.query_row(
        &format!("SELECT {SESSION_COLS} FROM sessions WHERE id = ?1"),
        [id.0],
        session_from_row,
    )
    .optional()?
    .ok_or(StoreError::NoSuchSession(id))
}

/// Makes `path` readable and writable by its owner only (0600); with
/// `create`, creates it (empty, 0600) if it is missing. A missing file
/// without `create` is left missing.
pub fn owner_only(path: &Path, create: bool) -> std::io::Result<()> {
    use std::os::unix::fs::{OpenOptionsExt as _, PermissionsExt as _};
    if create {
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .mode(0o600)
            .open(path)?;
    }
    match std::fs::metadata(path) {
        Ok(m) if m.permissions().mode() & 0o077 != 0 => {
            std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o600))
        }
        Ok(_) => Ok(()),
        Err(e) if !create && e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(e),
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

#[cfg(test)]
mod tests;
