//! The wire types of the chain's sync API: what a station sends to the
//! head-office hub and what the hub answers, as JSON over HTTP.
//!
//! Why a crate of its own: both ends must agree on every field, and the
//! station (a kiosk) must not carry the hub's server stack (axum,
//! PostgreSQL) to get them. This crate has only serde, sha2 and base64; the
//! station's sync client (`tapeshape::sync`) and the hub
//! (`tapeshape-hub`) both build on it. `docs/hub.md` describes the API,
//! the ordering and idempotency rules and the schema.
//!
//! The rules in one paragraph: every change to a session at a station is an
//! [`Event`] with the station's next sequence number (1, 2, 3, ... without
//! gaps, per station). A station pushes its unsent events in order in a
//! [`SyncRequest`]; the hub applies, in one PostgreSQL transaction, exactly
//! the events that continue its record of that station (`seq` = the last
//! one it committed + 1, then the next ...), skips those it has (a batch
//! sent twice changes nothing) and stops at a gap (events arriving out of
//! order change nothing), and answers with [`SyncResponse::committed_through`]:
//! the station marks its events up to there sent, and sends from the next
//! one. So the hub's record of a station is always a prefix of the
//! station's outbox, whatever the network did.

use serde::{Deserialize, Serialize};
use sha2::Digest as _;

/// Path of the sync endpoint (POST a [`SyncRequest`], get a [`SyncResponse`]).
pub const SYNC_PATH: &str = "/api/v1/sync";
/// Path of the returning-customer lookup (POST a [`LookupRequest`], get a
/// [`LookupResponse`]).
pub const LOOKUP_PATH: &str = "/api/v1/lookup";
/// Path that answers `200 {"station": NAME}` to a valid token (a station's
/// check of its token at start).
pub const WHOAMI_PATH: &str = "/api/v1/whoami";

/// Most events one [`SyncRequest`] may carry; more is refused (413).
pub const MAX_BATCH_EVENTS: usize = 2_000;
/// Largest request body the hub reads, bytes (an estimate's body, its GLB
/// as base64, is about 0.7 MB); more is refused (413).
pub const MAX_BODY_BYTES: usize = 16 * 1024 * 1024;
/// Longest customer id (bytes), as the station's store allows.
pub const MAX_CUSTOMER_ID_LEN: usize = 128;
/// Longest measurement or set name (bytes).
pub const MAX_NAME_LEN: usize = 128;
/// Longest station name (bytes).
pub const MAX_STATION_NAME_LEN: usize = 64;
/// Longest notes or model description (bytes).
pub const MAX_NOTES_LEN: usize = 1_024;
/// Longest estimate report (JSON text, bytes).
pub const MAX_REPORT_LEN: usize = 1024 * 1024;
/// Most readings an estimate may name.
pub const MAX_ESTIMATE_READINGS: usize = 512;

/// What a customer chose on the new-customer screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Consent {
    /// "Keep my data": the chain keeps the customer's sessions until they
    /// ask for them to be erased (the hub's retention does not purge them).
    Keep,
    /// "This visit only": kept for the visit; the hub's retention purges
    /// the session after its `--retain-days`.
    Visit,
}

impl Consent {
    /// The word stored and sent (`keep`, `visit`).
    pub fn as_str(self) -> &'static str {
        match self {
            Consent::Keep => "keep",
            Consent::Visit => "visit",
        }
    }

    /// The consent a word names.
    pub fn from_word(s: &str) -> Option<Self> {
        match s {
            "keep" => Some(Consent::Keep),
            "visit" => Some(Consent::Visit),
            _ => None,
        }
    }
}

/// Where a reading came from (the station's `ReadingSource`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// The tape's numbered queue.
    Tape {
        /// The tape's 64-bit device id.
        device_id: u64,
        /// Its boot id.
        boot_id: u32,
        /// Sequence number within the boot.
        seq: u32,
        /// Device clock when held, ms since the device booted.
        device_time_ms: u64,
    },
    /// The keyboard (the tape's live value stored with Enter).
    Keyboard,
}

/// An operator's mark on a measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mark {
    /// Skipped.
    Skipped,
    /// A flagged reading kept on purpose.
    KeptFlagged,
}

/// A session's life-cycle state.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Being measured.
    Open,
    /// Finished.
    Done,
    /// Given up.
    Abandoned,
}

/// What changed. Session and reading numbers are the station's own row ids:
/// at the hub a session is `(station, session)`, a reading `(station, reading)`.
/// Times are milliseconds since the Unix epoch (UTC) on the station's clock;
/// lengths are tenths of a millimetre, as the station stores them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum EventBody {
    /// A session was created.
    Created {
        /// The station's session id.
        session: i64,
        /// The customer's id (opaque text).
        customer: String,
        /// Measurement set followed.
        set: Option<String>,
        /// Operator notes (sex, age).
        notes: Option<String>,
        /// The customer's choice (`None`: not asked, e.g. a session from
        /// the line-mode station; the retention treats it as `visit`).
        consent: Option<Consent>,
        /// Careful mode: each measurement taken twice (a third time when the
        /// two differ by more than its allowable error) and the median kept,
        /// so a reading superseded in it is a repeat, not a retake. `false`
        /// when absent (stations from before careful mode).
        #[serde(default)]
        careful: bool,
        /// When it was created.
        created_at_ms: i64,
    },
    /// A reading was stored.
    ReadingStored {
        /// Its session.
        session: i64,
        /// The station's reading id.
        reading: i64,
        /// Measurement name.
        measurement: String,
        /// Tenths of a millimetre.
        value_tenth_mm: u32,
        /// Tape or keyboard.
        source: Source,
        /// When the station committed it.
        received_at_ms: i64,
        /// The earlier reading of the same measurement it replaced (a retake).
        supersedes: Option<i64>,
    },
    /// A reading was withdrawn (undo).
    Withdrawn {
        /// Its session.
        session: i64,
        /// The reading.
        reading: i64,
        /// The reading current again (the value before a retake), if any.
        restored: Option<i64>,
    },
    /// A measurement was marked (or its mark cleared: `None`).
    Marked {
        /// The session.
        session: i64,
        /// The measurement.
        measurement: String,
        /// The mark.
        mark: Option<Mark>,
    },
    /// The session's status changed.
    StatusSet {
        /// The session.
        session: i64,
        /// Its status now.
        status: Status,
    },
    /// The session's estimate was stored (replacing an earlier one).
    EstimateStored {
        /// The session.
        session: i64,
        /// When it was made.
        made_at_ms: i64,
        /// The model that made it.
        model_source: String,
        /// The readings it was made from (name, tenths of a mm).
        readings: Vec<(String, u32)>,
        /// The station's estimate report (JSON text: sizes, targets and
        /// achieved values, plausibility, warnings).
        report_json: String,
        /// The body as binary glTF (Y up, metres), base64 (standard
        /// alphabet, padded). `None`: the station could not build it (the
        /// estimate was replaced or erased before it was sent).
        glb_base64: Option<String>,
    },
    /// The session was deleted at the station (`session delete`).
    Erased {
        /// The session.
        session: i64,
    },
    /// The customer asked to be erased (`customer erase` at the station):
    /// the hub erases them chain-wide and tells every other station.
    CustomerErased {
        /// [`customer_hash`] of their id: the event carries no id.
        customer_hash: String,
    },
    /// An event whose content the station erased before sending it (its
    /// session was erased): it only keeps the sequence without gaps.
    Redacted,
}

impl EventBody {
    /// The session the event concerns, if any.
    pub fn session(&self) -> Option<i64> {
        match self {
            EventBody::Created { session, .. }
            | EventBody::ReadingStored { session, .. }
            | EventBody::Withdrawn { session, .. }
            | EventBody::Marked { session, .. }
            | EventBody::StatusSet { session, .. }
            | EventBody::EstimateStored { session, .. }
            | EventBody::Erased { session } => Some(*session),
            EventBody::CustomerErased { .. } | EventBody::Redacted => None,
        }
    }

    /// The event's kind, as its JSON `kind` field says it.
    pub fn kind(&self) -> &'static str {
        match self {
            EventBody::Created { .. } => "created",
            EventBody::ReadingStored { .. } => "reading_stored",
            EventBody::Withdrawn { .. } => "withdrawn",
            EventBody::Marked { .. } => "marked",
            EventBody::StatusSet { .. } => "status_set",
            EventBody::EstimateStored { .. } => "estimate_stored",
            EventBody::Erased { .. } => "erased",
            EventBody::CustomerErased { .. } => "customer_erased",
            EventBody::Redacted => "redacted",
        }
    }

    /// Checks the event's text fields against the limits above (non-empty,
    /// bounded, no control characters where names are concerned): what the
    /// hub refuses with 422 before it stores anything.
    pub fn validate(&self) -> Result<(), String> {
        let name = |what: &str, s: &str, max: usize| -> Result<(), String> {
            if valid_text(s, max) {
                Ok(())
            } else {
                Err(format!(
                    "{what} must be 1 to {max} bytes of printable text (got {} bytes)",
                    s.len()
                ))
            }
        };
        let bounded = |what: &str, s: &str, max: usize| -> Result<(), String> {
            if s.len() <= max {
                Ok(())
            } else {
                Err(format!("{what} is {} bytes; at most {max}", s.len()))
            }
        };
        match self {
            EventBody::Created {
                customer,
                set,
                notes,
                ..
            } => {
                name("customer", customer, MAX_CUSTOMER_ID_LEN)?;
                if let Some(s) = set {
                    name("set", s, MAX_NAME_LEN)?;
                }
                if let Some(n) = notes {
                    bounded("notes", n, MAX_NOTES_LEN)?;
                }
            }
            EventBody::ReadingStored { measurement, .. }
            | EventBody::Marked { measurement, .. } => {
                name("measurement", measurement, MAX_NAME_LEN)?
            }
            EventBody::EstimateStored {
                model_source,
                readings,
                report_json,
                glb_base64,
                ..
            } => {
                bounded("model_source", model_source, MAX_NOTES_LEN)?;
                bounded("report_json", report_json, MAX_REPORT_LEN)?;
                if readings.len() > MAX_ESTIMATE_READINGS {
                    return Err(format!(
                        "an estimate names {} readings; at most {MAX_ESTIMATE_READINGS}",
                        readings.len()
                    ));
                }
                for (n, _) in readings {
                    name("an estimate's measurement", n, MAX_NAME_LEN)?;
                }
                if let Some(b) = glb_base64 {
                    bounded("glb_base64", b, MAX_BODY_BYTES)?;
                }
            }
            EventBody::CustomerErased { customer_hash } => {
                if !is_customer_hash(customer_hash) {
                    return Err("customer_hash must be 64 lower-case hex digits".into());
                }
            }
            EventBody::Withdrawn { .. }
            | EventBody::StatusSet { .. }
            | EventBody::Erased { .. }
            | EventBody::Redacted => {}
        }
        Ok(())
    }
}

/// One event of a station's outbox.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// The station's sequence number: 1, 2, 3, ... without gaps.
    pub seq: i64,
    /// When the change was committed at the station (ms since the Unix epoch).
    pub at_ms: i64,
    /// What changed.
    #[serde(flatten)]
    pub body: EventBody,
}

/// `POST /api/v1/sync`: a station's unsent events, in order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SyncRequest {
    /// The station's name at the hub (must be the token's station).
    pub station: String,
    /// Events in increasing `seq`, at most [`MAX_BATCH_EVENTS`].
    pub events: Vec<Event>,
    /// Erasure notices (their [`ErasureNotice::id`]) the station has
    /// carried out since its last request.
    #[serde(default)]
    pub erasures_done: Vec<i64>,
}

/// An erasure the hub asks a station to carry out: delete every session of
/// the customer whose [`customer_hash`] this is.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ErasureNotice {
    /// The notice's id, to acknowledge in [`SyncRequest::erasures_done`].
    pub id: i64,
    /// [`customer_hash`] of the customer's id.
    pub customer_hash: String,
}

/// The hub's answer to a [`SyncRequest`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SyncResponse {
    /// The hub holds this station's events 1 ..= this (committed in
    /// PostgreSQL before the answer was sent); the station sends from the
    /// next one.
    pub committed_through: i64,
    /// Erasures this station has still to carry out.
    pub erasures: Vec<ErasureNotice>,
}

/// `POST /api/v1/lookup`: a returning customer's earlier sessions.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LookupRequest {
    /// The customer's id.
    pub customer: String,
}

/// One earlier session of a customer, at any station of the chain.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RemoteSession {
    /// The station (store) that measured it.
    pub station: String,
    /// That station's session id.
    pub session: i64,
    /// When it was created (ms since the Unix epoch, the station's clock).
    pub created_at_ms: i64,
    /// Its status.
    pub status: Status,
    /// Its measurement set.
    pub set: Option<String>,
    /// The customer's choice.
    pub consent: Option<Consent>,
    /// Its current readings (name, tenths of a mm), in the order taken.
    pub readings: Vec<(String, u32)>,
    /// When its estimate was made, if it has one.
    pub estimate_made_at_ms: Option<i64>,
}

/// The hub's answer to a [`LookupRequest`]: newest first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LookupResponse {
    /// The customer's sessions the hub holds.
    pub sessions: Vec<RemoteSession>,
}

/// `GET /api/v1/whoami`'s answer.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WhoAmI {
    /// The token's station.
    pub station: String,
}

/// The body of every 4xx/5xx answer: what was wrong and what to do.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ApiError {
    /// The message.
    pub error: String,
}

/// The hash the chain keeps of a customer id where it must not keep the id
/// (an erasure record, an erasure notice, a `customer_erased` event):
/// SHA-256 of `"tapeshape-customer:"` and the id, lower-case hex.
///
/// A customer id is opaque and short (the kiosk hands out `c-` and six
/// base-32 characters): the hash says "this customer was erased" without
/// storing the id, but it does not hide an id from someone who tries them
/// all. `docs/hub.md` says so.
pub fn customer_hash(customer: &str) -> String {
    let digest = sha2::Sha256::digest(format!("tapeshape-customer:{customer}").as_bytes());
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Is `s` a [`customer_hash`] (64 lower-case hex digits)?
pub fn is_customer_hash(s: &str) -> bool {
    s.len() == 64
        && s.bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

/// A station name: 1 to [`MAX_STATION_NAME_LEN`] bytes of `a-z`, `0-9`,
/// `-` and `_`, starting with a letter or digit (it appears in URLs and
/// file names).
pub fn valid_station_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= MAX_STATION_NAME_LEN
        && s.bytes().next().is_some_and(|b| b.is_ascii_alphanumeric())
        && s.bytes()
            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_')
}

/// Printable text of 1 to `max` bytes: not blank, no control characters
/// (the station store's rule for customer ids and measurement names).
pub fn valid_text(s: &str, max: usize) -> bool {
    !s.trim().is_empty() && s.len() <= max && !s.chars().any(char::is_control)
}

/// A station token as `tapeshape hub add-station` prints it:
/// `<station>.<64 hex digits>` (256 random bits). The station's name is
/// public; the secret part is what the hub keeps only a hash of.
#[derive(Clone, PartialEq, Eq)]
pub struct StationToken {
    station: String,
    secret: String,
}

impl std::fmt::Debug for StationToken {
    /// Never prints the secret.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StationToken")
            .field("station", &self.station)
            .field("secret", &"<redacted>")
            .finish()
    }
}

/// A token that does not read as `<station>.<64 hex digits>`. The message
/// never repeats the text it was given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BadToken;

impl std::fmt::Display for BadToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(
            "not a station token (expected STATION.<64 hex digits>, as `tapeshape hub \
             add-station NAME` prints it)",
        )
    }
}

impl std::error::Error for BadToken {}

impl StationToken {
    /// A token for `station` with `secret` (32 random bytes).
    pub fn new(station: &str, secret: &[u8; 32]) -> Self {
        Self {
            station: station.to_string(),
            secret: secret.iter().map(|b| format!("{b:02x}")).collect(),
        }
    }

    /// Reads a token (surrounding whitespace ignored).
    pub fn parse(text: &str) -> Result<Self, BadToken> {
        let (station, secret) = text.trim().rsplit_once('.').ok_or(BadToken)?;
        if !valid_station_name(station)
            || secret.len() != 64
            || !secret.bytes().all(|b| b.is_ascii_hexdigit())
        {
            return Err(BadToken);
        }
        Ok(Self {
            station: station.to_string(),
            secret: secret.to_ascii_lowercase(),
        })
    }

    /// The station it belongs to.
    pub fn station(&self) -> &str {
        &self.station
    }

    /// The whole token, as sent in `Authorization: Bearer ...` (a secret:
    /// never log it).
    pub fn expose(&self) -> String {
        format!("{}.{}", self.station, self.secret)
    }

    /// SHA-256 (hex) of the whole token: what the hub stores. A token is
    /// 256 random bits, so a fast hash is enough: no one can try 2^256
    /// tokens, which is what a slow password hash (argon2) guards against
    /// for human-chosen passwords.
    pub fn hash(&self) -> String {
        token_hash(&self.expose())
    }
}

/// SHA-256 (hex) of a presented bearer token (see [`StationToken::hash`]).
pub fn token_hash(token: &str) -> String {
    sha2::Sha256::digest(token.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The GLB bytes of an [`EventBody::EstimateStored`]'s `glb_base64`.
pub fn decode_glb(b64: &str) -> Result<Vec<u8>, String> {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD
        .decode(b64)
        .map_err(|e| format!("glb_base64 is not base64: {e}"))
}

/// `glb` as an [`EventBody::EstimateStored`]'s `glb_base64`.
pub fn encode_glb(glb: &[u8]) -> String {
    use base64::Engine as _;
    base64::engine::general_purpose::STANDARD.encode(glb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_created_event_without_the_careful_flag_reads_as_taken_once() {
        // What a station from before careful mode sends.
        let old = r#"{"seq":1,"at_ms":2,"kind":"created","session":4,"customer":"c-1",
            "set":"quick","notes":null,"consent":"visit","created_at_ms":2}"#;
        let e: Event = serde_json::from_str(old).unwrap();
        assert!(matches!(e.body, EventBody::Created { careful: false, .. }));
        let careful = Event {
            body: match e.body {
                EventBody::Created {
                    session,
                    customer,
                    set,
                    notes,
                    consent,
                    created_at_ms,
                    ..
                } => EventBody::Created {
                    session,
                    customer,
                    set,
                    notes,
                    consent,
                    careful: true,
                    created_at_ms,
                },
                other => other,
            },
            ..e
        };
        let json = serde_json::to_value(&careful).unwrap();
        assert_eq!(json["careful"], true);
        assert_eq!(serde_json::from_value::<Event>(json).unwrap(), careful);
    }

    #[test]
    fn events_read_as_flat_json_with_their_kind() {
        let e = Event {
            seq: 7,
            at_ms: 1_700_000_000_000,
            body: EventBody::ReadingStored {
                session: 3,
                reading: 12,
                measurement: "chest".into(),
                value_tenth_mm: 9_820,
                source: Source::Tape {
                    device_id: u64::MAX,
                    boot_id: 9,
                    seq: 0,
                    device_time_ms: 5,
                },
                received_at_ms: 1_700_000_000_001,
                supersedes: Some(11),
            },
        };
        let json = serde_json::to_value(&e).unwrap();
        assert_eq!(json["kind"], "reading_stored");
        assert_eq!(json["seq"], 7);
        assert_eq!(json["source"]["tape"]["device_id"], u64::MAX);
        let back: Event = serde_json::from_value(json).unwrap();
        assert_eq!(back, e);
        let r: Event = serde_json::from_str(r#"{"seq":1,"at_ms":2,"kind":"redacted"}"#).unwrap();
        assert_eq!(r.body, EventBody::Redacted);
        assert!(
            serde_json::from_str::<Event>(r#"{"seq":1,"at_ms":2,"kind":"drop_table"}"#).is_err()
        );
    }

    #[test]
    fn validation_refuses_long_blank_and_control_text() {
        let created = |customer: &str| EventBody::Created {
            session: 1,
            customer: customer.into(),
            set: None,
            notes: None,
            consent: Some(Consent::Keep),
            careful: false,
            created_at_ms: 0,
        };
        assert!(created("c-12ab34").validate().is_ok());
        // SQL text is just text: valid (it is stored as a parameter).
        assert!(created("'; DROP TABLE sessions; --").validate().is_ok());
        let long = created(&"x".repeat(MAX_CUSTOMER_ID_LEN + 1)).validate();
        assert!(long.unwrap_err().contains("1 to 128 bytes"));
        assert!(created("  ").validate().is_err());
        assert!(created("a\u{0}b").validate().is_err());
        let erased = EventBody::CustomerErased {
            customer_hash: "ABC".into(),
        };
        assert!(erased.validate().is_err());
        let ok = EventBody::CustomerErased {
            customer_hash: customer_hash("c-1"),
        };
        assert!(ok.validate().is_ok());
    }

    #[test]
    fn customer_hashes_differ_per_id_and_look_like_hashes() {
        let a = customer_hash("c-000001");
        assert!(is_customer_hash(&a));
        assert_ne!(a, customer_hash("c-000002"));
        assert_eq!(a, customer_hash("c-000001"));
        // Not the plain SHA-256 of the id.
        assert_ne!(
            a,
            sha2::Sha256::digest(b"c-000001")
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        );
    }

    #[test]
    fn tokens_round_trip_and_never_print_their_secret() {
        let t = StationToken::new("store-7", &[0xab; 32]);
        let text = t.expose();
        assert_eq!(text, format!("store-7.{}", "ab".repeat(32)));
        let back = StationToken::parse(&format!("  {text}\n")).unwrap();
        assert_eq!(back, t);
        assert_eq!(back.station(), "store-7");
        assert!(!format!("{t:?}").contains("abab"));
        assert_eq!(t.hash(), token_hash(&text));
        for bad in [
            "",
            "store-7",
            "store-7.abcd",
            "Store.0000",
            &format!("bad name.{}", "0".repeat(64)),
        ] {
            let e = StationToken::parse(bad).unwrap_err();
            assert!(!e.to_string().contains("abcd"));
        }
    }

    #[test]
    fn station_names_are_url_safe() {
        assert!(valid_station_name("berlin-mitte_2"));
        for bad in ["", "-x", "Berlin", "a b", "a/b", "a.b", &"x".repeat(65)] {
            assert!(!valid_station_name(bad), "{bad}");
        }
    }

    #[test]
    fn glb_base64_round_trips() {
        let bytes = b"glTF\x02\x00\x00\x00binary";
        assert_eq!(decode_glb(&encode_glb(bytes)).unwrap(), bytes);
        assert!(decode_glb("not base64!").is_err());
    }
}
