//! What the head office's pages and the returning-customer lookup read:
//! a store's sessions, one session with everything the hub holds of it,
//! its body, and a customer's sessions at every store. Reads only; every
//! query parameterised.

use serde::Serialize;
use tapeshape_hub_api::{customer_hash, Consent, RemoteSession};

use super::{status_of, Db, HubError};

/// A session as the store page lists it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct SessionRow {
    /// The station's session id.
    pub session: i64,
    /// The customer.
    pub customer: String,
    /// Status word.
    pub status: String,
    /// Set.
    pub set: Option<String>,
    /// Consent word.
    pub consent: Option<String>,
    /// Created, ms since the Unix epoch.
    pub created_at_ms: i64,
    /// Current readings.
    pub readings: i64,
    /// It has an estimate (with a body).
    pub has_body: bool,
}

/// One reading as the hub holds it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ReadingRow {
    /// The station's reading id.
    pub reading: i64,
    /// Measurement name.
    pub measurement: String,
    /// Tenths of a millimetre.
    pub value_tenth_mm: i64,
    /// `tape` or `keyboard`.
    pub source: String,
    /// When the station stored it.
    pub received_at_ms: i64,
    /// The retake that replaced it.
    pub superseded_by: Option<i64>,
    /// Withdrawn (undo).
    pub withdrawn: bool,
}

/// One session with everything the hub holds of it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SessionFull {
    /// Its station.
    pub station: String,
    /// The station's session id.
    pub session: i64,
    /// The customer.
    pub customer: String,
    /// Status word.
    pub status: String,
    /// Set.
    pub set: Option<String>,
    /// Notes.
    pub notes: Option<String>,
    /// Consent word.
    pub consent: Option<String>,
    /// Created, ms since the Unix epoch.
    pub created_at_ms: i64,
    /// Careful mode: a superseded reading is a repeat of its round, not a
    /// retake.
    pub careful: bool,
    /// Every reading (retakes and withdrawn ones included), oldest first.
    pub readings: Vec<ReadingRow>,
    /// Marks (measurement, mark word).
    pub marks: Vec<(String, String)>,
    /// The estimate, if any.
    pub estimate: Option<EstimateRow>,
}

/// A session's estimate as the hub holds it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EstimateRow {
    /// When it was made, ms since the Unix epoch.
    pub made_at_ms: i64,
    /// The model.
    pub model_source: String,
    /// The station's report (sizes, targets, achieved values).
    pub report: serde_json::Value,
    /// Bytes of its body (GLB), if it has one.
    pub glb_bytes: Option<i64>,
}

impl Db {
    /// The sessions of `station` the hub holds, newest first.
    pub async fn station_sessions(&self, station: &str) -> Result<Vec<SessionRow>, HubError> {
        let rows = self
            .client()
            .await?
            .query(
                "SELECT s.session, s.customer, s.status, s.set_name, s.consent, s.created_at_ms,
                    (SELECT COUNT(*) FROM readings r WHERE r.station = s.station
                        AND r.session = s.session AND r.superseded_by IS NULL AND NOT r.withdrawn),
                    EXISTS (SELECT 1 FROM estimates e WHERE e.station = s.station
                        AND e.session = s.session AND e.glb IS NOT NULL)
                 FROM sessions s WHERE s.station = $1
                 ORDER BY s.created_at_ms DESC, s.session DESC LIMIT 1000",
                &[&station],
            )
            .await?;
        Ok(rows
            .iter()
            .map(|r| SessionRow {
                session: r.get(0),
                customer: r.get(1),
                status: r.get(2),
                set: r.get(3),
                consent: r.get(4),
                created_at_ms: r.get(5),
                readings: r.get(6),
                has_body: r.get(7),
            })
            .collect())
    }

    /// Everything the hub holds of one session, if it holds it.
    pub async fn session_full(
        &self,
        station: &str,
        session: i64,
    ) -> Result<Option<SessionFull>, HubError> {
        let client = self.client().await?;
        let Some(s) = client
            .query_opt(
                "SELECT customer, status, set_name, notes, consent, created_at_ms, careful
                 FROM sessions WHERE station = $1 AND session = $2",
                &[&station, &session],
            )
            .await?
        else {
            return Ok(None);
        };
        let readings = client
            .query(
                "SELECT reading, measurement, value_tenth_mm, source, received_at_ms,
                    superseded_by, withdrawn
                 FROM readings WHERE station = $1 AND session = $2 ORDER BY reading",
                &[&station, &session],
            )
            .await?
            .iter()
            .map(|r| ReadingRow {
                reading: r.get(0),
                measurement: r.get(1),
                value_tenth_mm: r.get(2),
                source: r.get(3),
                received_at_ms: r.get(4),
                superseded_by: r.get(5),
                withdrawn: r.get(6),
            })
            .collect();
        let marks = client
            .query(
                "SELECT measurement, mark FROM marks WHERE station = $1 AND session = $2
                 ORDER BY measurement",
                &[&station, &session],
            )
            .await?
            .iter()
            .map(|r| (r.get(0), r.get(1)))
            .collect();
        let estimate = client
            .query_opt(
                "SELECT made_at_ms, model_source, report_json, octet_length(glb)::BIGINT
                 FROM estimates WHERE station = $1 AND session = $2",
                &[&station, &session],
            )
            .await?
            .map(|r| EstimateRow {
                made_at_ms: r.get(0),
                model_source: r.get(1),
                report: serde_json::from_str(&r.get::<_, String>(2))
                    .unwrap_or(serde_json::Value::Null),
                glb_bytes: r.get(3),
            });
        Ok(Some(SessionFull {
            station: station.to_string(),
            session,
            customer: s.get(0),
            status: s.get(1),
            set: s.get(2),
            notes: s.get(3),
            consent: s.get(4),
            created_at_ms: s.get(5),
            careful: s.get(6),
            readings,
            marks,
            estimate,
        }))
    }

    /// The body (GLB) of a session's estimate, if the hub holds one.
    pub async fn body_glb(&self, station: &str, session: i64) -> Result<Option<Vec<u8>>, HubError> {
        let row = self
            .client()
            .await?
            .query_opt(
                "SELECT glb FROM estimates WHERE station = $1 AND session = $2 AND glb IS NOT NULL",
                &[&station, &session],
            )
            .await?;
        Ok(row.map(|r| r.get(0)))
    }

    /// A returning customer's sessions at every station, newest first, with
    /// their current readings.
    pub async fn lookup(&self, customer: &str) -> Result<Vec<RemoteSession>, HubError> {
        let client = self.client().await?;
        let hash = customer_hash(customer);
        let sessions = client
            .query(
                "SELECT s.station, s.session, s.created_at_ms, s.status, s.set_name, s.consent,
                    (SELECT made_at_ms FROM estimates e WHERE e.station = s.station
                        AND e.session = s.session)
                 FROM sessions s WHERE s.customer_hash = $1 AND s.customer = $2
                 ORDER BY s.created_at_ms DESC, s.station, s.session LIMIT 200",
                &[&hash, &customer],
            )
            .await?;
        let readings = client
            .query(
                "SELECT r.station, r.session, r.measurement, r.value_tenth_mm
                 FROM readings r JOIN sessions s USING (station, session)
                 WHERE s.customer_hash = $1 AND s.customer = $2
                   AND r.superseded_by IS NULL AND NOT r.withdrawn
                 ORDER BY r.station, r.session, r.reading",
                &[&hash, &customer],
            )
            .await?;
        Ok(sessions
            .iter()
            .map(|s| {
                let station: String = s.get(0);
                let session: i64 = s.get(1);
                let consent: Option<String> = s.get(5);
                RemoteSession {
                    readings: readings
                        .iter()
                        .filter(|r| r.get::<_, &str>(0) == station && r.get::<_, i64>(1) == session)
                        .map(|r| {
                            (
                                r.get::<_, String>(2),
                                u32::try_from(r.get::<_, i64>(3)).unwrap_or(u32::MAX),
                            )
                        })
                        .collect(),
                    station,
                    session,
                    created_at_ms: s.get(2),
                    status: status_of(s.get(3)),
                    set: s.get(4),
                    consent: consent.as_deref().and_then(Consent::from_word),
                    estimate_made_at_ms: s.get(6),
                }
            })
            .collect())
    }
}
