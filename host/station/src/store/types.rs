//! What the session store holds, as Rust values: ids, a session's header,
//! readings and where they came from, marks, the stored estimate.
//!
//! Why the SQL conversions live here: a domain value crosses into SQL only
//! through `ToSql`/`FromSql` (rusqlite's traits), so a value in the file
//! that this program does not understand (a hand-edited status, a damaged
//! row) is a typed error inside the row mapping, never a placeholder.

use std::fmt;

use rusqlite::types::{FromSql, FromSqlError, FromSqlResult, ToSql, ToSqlOutput, ValueRef};

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

/// A stored value this program does not understand (the file was edited by
/// hand, damaged, or written by a newer program that did not bump the
/// schema version): carried inside `rusqlite`'s conversion error and turned
/// into [`super::StoreError::Corrupt`].
#[derive(Debug, thiserror::Error)]
#[error("unknown {what} {value:?}")]
pub(crate) struct UnknownValue {
    what: &'static str,
    value: String,
}

fn unknown(what: &'static str, v: &str) -> FromSqlError {
    FromSqlError::Other(Box::new(UnknownValue {
        what,
        value: v.to_string(),
    }))
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
    /// Every status.
    pub const ALL: [SessionStatus; 3] = [
        SessionStatus::Open,
        SessionStatus::Done,
        SessionStatus::Abandoned,
    ];

    /// The word stored in the database and printed (`open`, `done`, `abandoned`).
    pub fn as_str(self) -> &'static str {
        match self {
            SessionStatus::Open => "open",
            SessionStatus::Done => "done",
            SessionStatus::Abandoned => "abandoned",
        }
    }

    fn from_word(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|st| st.as_str() == s)
    }
}

impl fmt::Display for SessionStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// `tapeshape sessions --status X` and `session set-status ID X` give a
/// status that is not one of the three.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown status {0:?}: use open, done or abandoned")]
pub struct UnknownStatus(pub String);

impl std::str::FromStr for SessionStatus {
    type Err = UnknownStatus;
    fn from_str(s: &str) -> Result<Self, UnknownStatus> {
        Self::from_word(s).ok_or_else(|| UnknownStatus(s.to_string()))
    }
}

impl ToSql for SessionStatus {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(self.as_str().into())
    }
}

impl FromSql for SessionStatus {
    fn column_result(value: ValueRef<'_>) -> FromSqlResult<Self> {
        let s = value.as_str()?;
        Self::from_word(s).ok_or_else(|| unknown("session status", s))
    }
}

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
    /// The word stored in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            Mark::Skipped => "skipped",
            Mark::KeptFlagged => "kept-flagged",
        }
    }
}

impl ToSql for Mark {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(self.as_str().into())
    }
}

impl FromSql for Mark {
    fn column_result(value: ValueRef<'_>) -> FromSqlResult<Self> {
        match value.as_str()? {
            "skipped" => Ok(Mark::Skipped),
            "kept-flagged" => Ok(Mark::KeptFlagged),
            other => Err(unknown("mark", other)),
        }
    }
}

/// What the customer chose on the new-customer screen about their data.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Consent {
    /// "Keep my data": the chain keeps the customer's sessions until they
    /// ask for them to be erased.
    Keep,
    /// "This visit only": the hub's retention purges the session after its
    /// `--retain-days`.
    Visit,
}

impl Consent {
    /// The word stored in the database (`keep`, `visit`).
    pub fn as_str(self) -> &'static str {
        match self {
            Consent::Keep => "keep",
            Consent::Visit => "visit",
        }
    }

    /// The operator's words for it.
    pub fn label(self) -> &'static str {
        match self {
            Consent::Keep => "keep my data",
            Consent::Visit => "this visit only",
        }
    }
}

impl std::str::FromStr for Consent {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "keep" => Ok(Consent::Keep),
            "visit" => Ok(Consent::Visit),
            other => Err(format!("unknown consent {other:?}: use keep or visit")),
        }
    }
}

impl ToSql for Consent {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(self.as_str().into())
    }
}

impl FromSql for Consent {
    fn column_result(value: ValueRef<'_>) -> FromSqlResult<Self> {
        let s = value.as_str()?;
        s.parse().map_err(|_| unknown("consent", s))
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
    /// The customer's choice about their data (`None`: not asked).
    pub consent: Option<Consent>,
}

/// A session with reading counts, for listings.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SessionSummary {
    /// The session.
    pub session: Session,
    /// Readings that are current (neither superseded by a retake nor withdrawn).
    pub current_readings: u64,
    /// All readings, retakes and withdrawn ones included.
    pub total_readings: u64,
    /// When its stored estimate was made (ms since the Unix epoch), if it has one.
    pub estimate_made_at_ms: Option<i64>,
}

/// A reading as it arrives from the tape: what the device said about it.
/// Integer units exactly as on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DeviceReading {
    /// Id of the tape device that took it (stored as the same 64 bits in
    /// a signed SQLite INTEGER).
    pub device_id: u64,
    /// Boot id of the device (differs on every boot); sequence numbers
    /// restart at [`super::FIRST_SEQ`] with each boot.
    pub boot_id: u32,
    /// Sequence number within the boot.
    pub seq: u32,
    /// Measured length in tenths of a millimetre.
    pub value_tenth_mm: u32,
    /// Device clock when the reading was held, ms since the device booted.
    pub device_time_ms: u64,
}

/// Where on the tape a stored reading came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TapeOrigin {
    /// Id of the tape device.
    pub device_id: u64,
    /// Its boot id.
    pub boot_id: u32,
    /// Sequence number within the boot.
    pub seq: u32,
    /// Device clock when the reading was held, ms since the device booted.
    pub device_time_ms: u64,
}

/// Where a stored reading came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadingSource {
    /// The tape's numbered queue (held on the tape, acknowledged after the commit).
    Tape(TapeOrigin),
    /// The keyboard: the operator pressed Enter to store the tape's live
    /// value, which never went through the tape's queue.
    Keyboard,
}

/// The `source` column.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SourceKind {
    Tape,
    Keyboard,
}

impl ToSql for SourceKind {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(match self {
            SourceKind::Tape => "tape",
            SourceKind::Keyboard => "keyboard",
        }
        .into())
    }
}

impl FromSql for SourceKind {
    fn column_result(value: ValueRef<'_>) -> FromSqlResult<Self> {
        match value.as_str()? {
            "tape" => Ok(SourceKind::Tape),
            "keyboard" => Ok(SourceKind::Keyboard),
            other => Err(unknown("reading source", other)),
        }
    }
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
    /// The length, tenths of a millimetre.
    pub value_tenth_mm: u32,
    /// The tape's queue or the keyboard.
    pub source: ReadingSource,
    /// Host clock when it was committed, ms since the Unix epoch (UTC).
    pub received_at_ms: i64,
    /// The retake that replaced this reading, if any.
    pub superseded_by: Option<ReadingId>,
    /// When the operator withdrew it (undo), ms since the Unix epoch; a
    /// withdrawn reading stays in the history but is not current.
    pub withdrawn_at_ms: Option<i64>,
}

impl StoredReading {
    /// Value in millimetres (the store keeps tenths of a millimetre).
    pub fn value_mm(&self) -> f64 {
        f64::from(self.value_tenth_mm) / 10.0
    }

    /// Where on the tape it came from (`None` for a keyboard reading).
    pub fn tape(&self) -> Option<&TapeOrigin> {
        match &self.source {
            ReadingSource::Tape(t) => Some(t),
            ReadingSource::Keyboard => None,
        }
    }

    /// Neither superseded by a retake nor withdrawn.
    pub fn is_current(&self) -> bool {
        self.superseded_by.is_none() && self.withdrawn_at_ms.is_none()
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
        self.readings.iter().filter(|r| r.is_current())
    }
}

/// What committing a reading from the tape did with it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CommitOutcome {
    /// Stored; acknowledge `reading`'s sequence number.
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

/// A session's estimate as the store keeps it (migration 0004 states the
/// columns' layout): enough to show the result and to export it again
/// without estimating again.
#[derive(Clone, Debug, PartialEq)]
pub struct StoredEstimate {
    /// The session.
    pub session_id: SessionId,
    /// When it was made, ms since the Unix epoch (UTC).
    pub made_at_ms: i64,
    /// Wall time the estimate took, seconds.
    pub seconds: f64,
    /// The model that made it (its report's `source`).
    pub model_source: String,
    /// SHA-256 (lower-case hex) of the template topology the vertices belong to.
    pub template_sha256: String,
    /// The body's vertices in template order, metres, station frame (Z up,
    /// +Y the body's front, +X its right, feet at z = 0).
    pub vertices: Vec<[f64; 3]>,
    /// The readings it was made from (name, tenths of a mm), in order.
    pub readings: Vec<(String, u32)>,
    /// The station's report of it as JSON (see `crate::estimate::ExportReport`).
    pub report_json: String,
}

/// Bytes per stored vertex: three little-endian f64.
pub const VERTEX_BYTES: usize = 24;

/// The `vertices` BLOB of `vertices` (see [`StoredEstimate::vertices`]):
/// `24 * n` bytes, x y z of each vertex as little-endian f64.
pub fn encode_vertices(vertices: &[[f64; 3]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(vertices.len() * VERTEX_BYTES);
    for v in vertices {
        for c in v {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

/// The vertices in a `vertices` BLOB, or `None` if its length is not a
/// whole number of vertices.
pub fn decode_vertices(bytes: &[u8]) -> Option<Vec<[f64; 3]>> {
    if !bytes.len().is_multiple_of(VERTEX_BYTES) {
        return None;
    }
    let f = |b: &[u8]| {
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        f64::from_le_bytes(a)
    };
    Some(
        bytes
            .chunks_exact(VERTEX_BYTES)
            .map(|c| [f(&c[0..8]), f(&c[8..16]), f(&c[16..24])])
            .collect(),
    )
}

/// SQLite integers are signed 64-bit: a device id is stored as the same 64
/// bits (a bijection, so ids compare and stay unique exactly).
pub(crate) fn device_id_to_sql(id: u64) -> i64 {
    i64::from_ne_bytes(id.to_ne_bytes())
}

pub(crate) fn device_id_from_sql(v: i64) -> u64 {
    u64::from_ne_bytes(v.to_ne_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertices_round_trip_bit_exactly_and_a_torn_blob_is_refused() {
        let v = vec![
            [0.0, -0.0, 1.0],
            [f64::MIN_POSITIVE, 1.0 / 3.0, -1.7654321e-9],
            [f64::MAX, 0.1, 2.5],
        ];
        let bytes = encode_vertices(&v);
        assert_eq!(bytes.len(), 3 * VERTEX_BYTES);
        // Little-endian x of the second vertex starts at byte 24.
        assert_eq!(&bytes[24..32], &f64::MIN_POSITIVE.to_le_bytes());
        let back = decode_vertices(&bytes).unwrap();
        for (a, b) in v.iter().zip(&back) {
            for k in 0..3 {
                assert_eq!(a[k].to_bits(), b[k].to_bits());
            }
        }
        assert!(decode_vertices(&bytes[..bytes.len() - 1]).is_none());
    }

    #[test]
    fn statuses_parse_from_their_words_only() {
        for s in SessionStatus::ALL {
            assert_eq!(s.as_str().parse::<SessionStatus>(), Ok(s));
        }
        let e = "finished".parse::<SessionStatus>().unwrap_err();
        assert!(e.to_string().contains("open, done or abandoned"), "{e}");
    }

    #[test]
    fn device_ids_use_all_64_bits() {
        for id in [0, 1, u64::MAX, 0x8000_0000_0000_0000] {
            assert_eq!(device_id_from_sql(device_id_to_sql(id)), id);
        }
    }
}
