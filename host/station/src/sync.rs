//! The station's side of the chain: the sync task that pushes the outbox to
//! the head-office hub, and the returning-customer lookup.
//!
//! Why one blocking thread with a plain HTTP client (ureq, rustls): the
//! station's SQLite stays the source of truth and the kiosk works offline,
//! so the sync is a background follower with one job, in order: read the
//! unsent events, send them in one batch, and only when the hub answers that
//! it has committed them, record that (`Sessions::mark_hub_committed`).
//! While the hub is away it retries with exponential backoff (with jitter,
//! so that a chain's stations do not all come back at once). The hub
//! applies a batch at most once and only in order (`docs/hub.md`), so a
//! batch sent again after a lost answer, or a rewind when the hub says it
//! holds less than the station thought, changes nothing there.
//!
//! Each answer also carries erasures the hub asks this station to carry
//! out (a customer erased at another store): the task deletes their
//! sessions through the session layer and says so in its next request.
//!
//! Layer: a service (with `check` and `estimate`), over the session layer;
//! the front ends start it (`tapeshape station --hub`, the demo).

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tapeshape_hub_api::{
    self as api, EventBody, LookupRequest, LookupResponse, StationToken, SyncRequest, SyncResponse,
    WhoAmI,
};

use crate::session::Sessions;
use crate::store::{OutboxEvent, StoreError, StoredEstimate};

/// Builds an estimate's body as GLB bytes (the station's services know the
/// template; `None`: cannot, the event goes without a body).
pub type GlbSource = Arc<dyn Fn(&StoredEstimate) -> Option<Vec<u8>> + Send + Sync>;

/// Why the sync could not start, or a request failed.
#[derive(Debug, thiserror::Error)]
pub enum SyncError {
    /// The token file could not be read.
    #[error("reading the station token file {path}: {error}")]
    TokenFile {
        /// The file.
        path: String,
        /// Why.
        error: std::io::Error,
    },
    /// The token file holds no station token (the message never shows it).
    #[error("the station token file {path} holds no station token: {error}")]
    BadToken {
        /// The file.
        path: String,
        /// Why.
        error: api::BadToken,
    },
    /// The hub's URL is not http(s)://.
    #[error("the hub URL must start with http:// or https:// (got {0:?})")]
    BadUrl(String),
    /// The CA certificate file could not be read.
    #[error("reading the hub's CA certificate {path}: {why}")]
    Ca {
        /// The file.
        path: String,
        /// Why.
        why: String,
    },
    /// The store is another station's.
    #[error(
        "this store belongs to station {store}, but the token is station {token}'s; \
         use that station's token, or another --data-dir"
    )]
    OtherStation {
        /// The store's station.
        store: String,
        /// The token's.
        token: String,
    },
    /// The hub could not be reached or did not answer.
    #[error("the hub did not answer: {0}")]
    Unreachable(String),
    /// The hub refused the request.
    #[error("the hub refused the request ({status}): {message}")]
    Refused {
        /// HTTP status.
        status: u16,
        /// The hub's message.
        message: String,
    },
    /// The store failed.
    #[error(transparent)]
    Store(#[from] StoreError),
}

/// How the sync task runs.
#[derive(Clone, Debug)]
pub struct SyncConfig {
    /// The hub's base URL (`https://hub.example:8443`).
    pub hub: String,
    /// The station's token.
    pub token: StationToken,
    /// Root certificate(s) to trust for the hub (PEM), instead of the
    /// public web's roots (a hub with a private CA or self-signed cert).
    pub ca_pem: Option<Vec<u8>>,
    /// Most events per batch.
    pub batch_events: usize,
    /// Most bytes of events per batch (an estimate's body is ~0.7 MB).
    pub batch_bytes: usize,
    /// First retry delay after a failure (doubles up to `max_backoff`).
    pub min_backoff: Duration,
    /// Longest retry delay.
    pub max_backoff: Duration,
    /// How often an idle station asks the hub (for erasures), and the
    /// longest wait for a change from another process.
    pub idle_poll: Duration,
    /// Timeout of one request.
    pub request_timeout: Duration,
    /// After a change wakes the idle task, how long it waits for more
    /// before sending: a busy station then sends a batch every `linger`
    /// instead of one request per reading (each request costs the hub a
    /// transaction and a commit), for at most this much more lag.
    pub linger: Duration,
}

impl SyncConfig {
    /// The defaults for `hub` and `token`: batches of 500 events or 4 MB,
    /// backoff 0.5 s to 30 s, an idle request every 10 s, 50 ms of linger.
    pub fn new(hub: &str, token: StationToken) -> Result<Self, SyncError> {
        if !(hub.starts_with("http://") || hub.starts_with("https://")) {
            return Err(SyncError::BadUrl(hub.to_string()));
        }
        Ok(Self {
            hub: hub.trim_end_matches('/').to_string(),
            token,
            ca_pem: None,
            batch_events: 500,
            batch_bytes: 4 * 1024 * 1024,
            min_backoff: Duration::from_millis(500),
            max_backoff: Duration::from_secs(30),
            idle_poll: Duration::from_secs(10),
            request_timeout: Duration::from_secs(30),
            linger: Duration::from_millis(50),
        })
    }
}

/// Reads a station token file (`tapeshape hub add-station` printed it).
/// The errors never show the file's content.
pub fn read_token(path: &Path) -> Result<StationToken, SyncError> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|error| SyncError::TokenFile {
        path: shown.clone(),
        error,
    })?;
    StationToken::parse(&text).map_err(|error| SyncError::BadToken { path: shown, error })
}

/// What the sync task last did, for a front end to show.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SyncStatus {
    /// The hub holds events 1 ..= this.
    pub committed_through: i64,
    /// Last event written here.
    pub last_seq: i64,
    /// The last request failed with this (cleared by a success).
    pub last_error: Option<String>,
    /// Batches the hub committed.
    pub batches: u64,
    /// Erasures the hub asked for and this station carried out.
    pub erasures_applied: u64,
}

/// A running sync task. Dropping it does not stop it: call [`SyncHandle::stop`].
#[derive(Debug)]
pub struct SyncHandle {
    stop: Arc<AtomicBool>,
    status: Arc<Mutex<SyncStatus>>,
    thread: Option<JoinHandle<()>>,
    sessions: Sessions,
}

impl SyncHandle {
    /// What the task last did.
    pub fn status(&self) -> SyncStatus {
        self.status
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .clone()
    }

    /// Waits up to `timeout` until the hub holds every event written so far
    /// (by the time of the call); `true` if it does.
    pub fn wait_synced(&self, timeout: Duration) -> bool {
        let until = Instant::now() + timeout;
        let target = self.sessions.store().sync_state().map(|s| s.last_seq);
        let Ok(target) = target else { return false };
        loop {
            let committed = self
                .sessions
                .store()
                .sync_state()
                .map(|s| s.hub_committed_seq)
                .unwrap_or(0);
            if committed >= target {
                return true;
            }
            if Instant::now() >= until {
                return false;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Stops the task (after its request in flight, if any) and waits for it.
    pub fn stop(mut self) {
        self.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The HTTP side: one agent, the hub's base and the token.
#[derive(Clone)]
pub struct HubClient {
    agent: ureq::Agent,
    base: String,
    token: StationToken,
}

impl std::fmt::Debug for HubClient {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HubClient")
            .field("base", &self.base)
            .field("station", &self.token.station())
            .finish()
    }
}

impl HubClient {
    /// A client for `config`'s hub.
    pub fn new(config: &SyncConfig) -> Result<Self, SyncError> {
        let mut builder = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_global(Some(config.request_timeout))
            .timeout_connect(Some(Duration::from_secs(5)));
        if let Some(pem) = &config.ca_pem {
            let certs = ureq::tls::parse_pem(pem)
                .filter_map(|item| match item {
                    Ok(ureq::tls::PemItem::Certificate(c)) => Some(Ok(c)),
                    Ok(_) => None,
                    Err(e) => Some(Err(e)),
                })
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| SyncError::Ca {
                    path: "(PEM)".into(),
                    why: e.to_string(),
                })?;
            if certs.is_empty() {
                return Err(SyncError::Ca {
                    path: "(PEM)".into(),
                    why: "no certificate in it".into(),
                });
            }
            builder = builder.tls_config(
                ureq::tls::TlsConfig::builder()
                    .root_certs(ureq::tls::RootCerts::new_with_certs(&certs))
                    .build(),
            );
        }
        Ok(Self {
            agent: builder.build().into(),
            base: config.hub.clone(),
            token: config.token.clone(),
        })
    }

    fn send(&self, path: &str, body: Option<Vec<u8>>) -> Result<String, SyncError> {
        let url = format!("{}{path}", self.base);
        let auth = format!("Bearer {}", self.token.expose());
        let result = match body {
            Some(b) => self
                .agent
                .post(&url)
                .header("Authorization", &auth)
                .header("Content-Type", "application/json")
                .send(&b[..]),
            None => self.agent.get(&url).header("Authorization", &auth).call(),
        };
        // ureq's errors name the host and what failed, never a header.
        let mut resp = result.map_err(|e| SyncError::Unreachable(e.to_string()))?;
        let status = resp.status().as_u16();
        let text = resp
            .body_mut()
            .with_config()
            .limit(64 * 1024 * 1024)
            .read_to_string()
            .map_err(|e| SyncError::Unreachable(format!("reading the answer: {e}")))?;
        if status == 200 {
            return Ok(text);
        }
        let message = serde_json::from_str::<api::ApiError>(&text)
            .map(|e| e.error)
            .unwrap_or_else(|_| text.chars().take(200).collect());
        Err(SyncError::Refused { status, message })
    }

    /// Which station the hub says the token is.
    pub fn whoami(&self) -> Result<String, SyncError> {
        let text = self.send(api::WHOAMI_PATH, None)?;
        serde_json::from_str::<WhoAmI>(&text)
            .map(|w| w.station)
            .map_err(|e| SyncError::Unreachable(format!("an answer that does not read: {e}")))
    }

    /// Sends one batch.
    pub fn sync(&self, req: &SyncRequest) -> Result<SyncResponse, SyncError> {
        let body = serde_json::to_vec(req)
            .map_err(|e| SyncError::Unreachable(format!("encoding the batch: {e}")))?;
        let text = self.send(api::SYNC_PATH, Some(body))?;
        serde_json::from_str(&text)
            .map_err(|e| SyncError::Unreachable(format!("an answer that does not read: {e}")))
    }

    /// A customer's sessions at every store of the chain.
    pub fn lookup(&self, customer: &str) -> Result<LookupResponse, SyncError> {
        let body = serde_json::to_vec(&LookupRequest {
            customer: customer.to_string(),
        })
        .map_err(|e| SyncError::Unreachable(format!("encoding the lookup: {e}")))?;
        let text = self.send(api::LOOKUP_PATH, Some(body))?;
        serde_json::from_str(&text)
            .map_err(|e| SyncError::Unreachable(format!("an answer that does not read: {e}")))
    }
}

/// Binds the store to the token's station (refusing a store of another
/// station) and starts the sync task on its own thread.
pub fn spawn(
    sessions: Sessions,
    config: SyncConfig,
    glb: GlbSource,
) -> Result<SyncHandle, SyncError> {
    let token_station = config.token.station().to_string();
    let bound = sessions.bind_station(&token_station)?;
    if bound != token_station {
        return Err(SyncError::OtherStation {
            store: bound,
            token: token_station,
        });
    }
    let client = HubClient::new(&config)?;
    let stop = Arc::new(AtomicBool::new(false));
    let status = Arc::new(Mutex::new(SyncStatus::default()));
    let task = Task {
        sessions: sessions.clone(),
        client,
        config,
        glb,
        stop: stop.clone(),
        status: status.clone(),
    };
    let thread = std::thread::Builder::new()
        .name("hub-sync".into())
        .spawn(move || task.run())
        .map_err(|e| SyncError::Unreachable(format!("starting the sync thread: {e}")))?;
    Ok(SyncHandle {
        stop,
        status,
        thread: Some(thread),
        sessions,
    })
}

struct Task {
    sessions: Sessions,
    client: HubClient,
    config: SyncConfig,
    glb: GlbSource,
    stop: Arc<AtomicBool>,
    status: Arc<Mutex<SyncStatus>>,
}

/// A small xorshift for the backoff's jitter (not for anything secret).
fn jitter(state: &mut u64, d: Duration) -> Duration {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    let f = 0.5 + (*state % 1000) as f64 / 1000.0;
    d.mul_f64(f)
}

impl Task {
    fn set_status(&self, f: impl FnOnce(&mut SyncStatus)) {
        f(&mut self.status.lock().unwrap_or_else(|e| e.into_inner()));
    }

    /// Sleeps `d` in short steps, returning early when asked to stop.
    fn sleep(&self, d: Duration) {
        let until = Instant::now() + d;
        while !self.stop.load(Ordering::SeqCst) {
            let now = Instant::now();
            if now >= until {
                return;
            }
            std::thread::sleep((until - now).min(Duration::from_millis(50)));
        }
    }

    fn run(self) {
        let mut backoff = self.config.min_backoff;
        let mut seed = u64::from(std::process::id()) << 20 | 0x9e37;
        let mut acks: Vec<i64> = Vec::new();
        let mut last_request: Option<Instant> = None;
        while !self.stop.load(Ordering::SeqCst) {
            let seen = self.sessions.changes();
            let poll_due = last_request.is_none_or(|t| t.elapsed() >= self.config.idle_poll);
            match self.round(&mut acks, poll_due) {
                Ok(Round::More) => {
                    backoff = self.config.min_backoff;
                    last_request = Some(Instant::now());
                }
                Ok(Round::Idle { asked }) => {
                    backoff = self.config.min_backoff;
                    if asked {
                        last_request = Some(Instant::now());
                    }
                    // Woken at once by a change through this process's
                    // session layer; a change by another process (the
                    // `customer erase` command) is found within 0.5 s.
                    let until_poll = last_request
                        .map(|t| self.config.idle_poll.saturating_sub(t.elapsed()))
                        .unwrap_or_default();
                    let wait = until_poll.min(Duration::from_millis(500));
                    if !wait.is_zero() && self.sessions.wait_for_change(seen, wait) > seen {
                        self.sleep(self.config.linger);
                    }
                }
                Err(e) => {
                    let text = e.to_string();
                    tracing::warn!(error = %text, retry_in = ?backoff, "sync with the hub failed");
                    self.set_status(|s| s.last_error = Some(text));
                    self.sleep(jitter(&mut seed, backoff));
                    backoff = (backoff * 2).min(self.config.max_backoff);
                }
            }
        }
    }

    /// The events after `after` as the request carries them (with their
    /// bodies' GLB added), within the batch limits.
    fn batch(&self, after: i64) -> Result<Vec<api::Event>, SyncError> {
        let rows = self
            .sessions
            .store()
            .outbox_after(after, self.config.batch_events)?;
        let mut events = Vec::with_capacity(rows.len());
        let mut bytes = 0usize;
        for row in rows {
            let event = self.event_of(&row)?;
            bytes += row.body.len()
                + match &event.body {
                    EventBody::EstimateStored {
                        glb_base64: Some(b),
                        ..
                    } => b.len(),
                    _ => 0,
                };
            if !events.is_empty() && bytes > self.config.batch_bytes {
                break;
            }
            events.push(event);
        }
        Ok(events)
    }

    fn event_of(&self, row: &OutboxEvent) -> Result<api::Event, SyncError> {
        let mut body: EventBody = serde_json::from_str(&row.body).map_err(|e| {
            StoreError::Corrupt(format!("outbox event {} does not read: {e}", row.seq))
        })?;
        if let EventBody::EstimateStored {
            session,
            made_at_ms,
            glb_base64,
            ..
        } = &mut body
        {
            // The body of the estimate the event is about, if it is still
            // the stored one (a later estimate has its own event).
            if let Some(stored) = self
                .sessions
                .store()
                .estimate(crate::store::SessionId(*session))?
            {
                if stored.made_at_ms == *made_at_ms {
                    *glb_base64 = (self.glb)(&stored).map(|g| api::encode_glb(&g));
                }
            }
        }
        Ok(api::Event {
            seq: row.seq,
            at_ms: row.at_ms,
            body,
        })
    }

    fn round(&self, acks: &mut Vec<i64>, poll_due: bool) -> Result<Round, SyncError> {
        let state = self.sessions.store().sync_state()?;
        let events = self.batch(state.hub_committed_seq)?;
        if events.is_empty() && acks.is_empty() && !poll_due {
            self.set_status(|s| {
                s.committed_through = state.hub_committed_seq;
                s.last_seq = state.last_seq;
            });
            return Ok(Round::Idle { asked: false });
        }
        let sent_through = events.last().map(|e| e.seq);
        let req = SyncRequest {
            station: self.config.token.station().to_string(),
            events,
            erasures_done: acks.clone(),
        };
        let resp = self.client.sync(&req)?;
        acks.clear();
        if resp.committed_through != state.hub_committed_seq {
            self.sessions.mark_hub_committed(resp.committed_through)?;
        }
        for notice in &resp.erasures {
            if !api::is_customer_hash(&notice.customer_hash) {
                continue;
            }
            let erased = self.sessions.apply_hub_erasure(&notice.customer_hash)?;
            tracing::info!(sessions = erased.len(), "erasure from the hub carried out");
            acks.push(notice.id);
            self.set_status(|s| s.erasures_applied += 1);
        }
        self.set_status(|s| {
            s.committed_through = resp.committed_through;
            s.last_seq = state.last_seq;
            s.last_error = None;
            s.batches += 1;
        });
        match sent_through {
            // The hub took everything sent: go on at once if there is more.
            Some(t) if resp.committed_through >= t => Ok(Round::More),
            // It took less (a gap at the hub: it holds less than this
            // station thought) and rewound us: go on from there.
            Some(_) if resp.committed_through < state.hub_committed_seq => Ok(Round::More),
            Some(_) => Err(SyncError::Refused {
                status: 200,
                message: format!(
                    "the hub committed through {} of a batch up to {}",
                    resp.committed_through,
                    sent_through.unwrap_or(0)
                ),
            }),
            None if !acks.is_empty() => Ok(Round::More),
            None => Ok(Round::Idle { asked: true }),
        }
    }
}

/// What a round found.
enum Round {
    /// It sent events: look for more at once.
    More,
    /// Nothing to send (`asked`: it asked the hub anyway, for erasures).
    Idle { asked: bool },
}

/// Where a lookup's sessions came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LookupSource {
    /// The chain's hub (every store).
    Hub,
    /// This station's own store: the hub was not configured or did not
    /// answer (the reason is shown to the operator).
    Local {
        /// Why not the hub.
        why: String,
    },
}

/// A returning customer's earlier sessions.
#[derive(Clone, Debug, PartialEq)]
pub struct CustomerHistory {
    /// Where they came from.
    pub source: LookupSource,
    /// The sessions, newest first.
    pub sessions: Vec<api::RemoteSession>,
}

/// Looks `customer` up at the hub (with `client`), or in this station's own
/// store when there is no hub or it does not answer, saying so.
pub fn lookup(
    sessions: &Sessions,
    client: Option<&HubClient>,
    station: Option<&str>,
    customer: &str,
) -> Result<CustomerHistory, StoreError> {
    let why = match client {
        None => {
            "this station has no hub (start it with --hub URL --station-token FILE)".to_string()
        }
        Some(c) => match c.lookup(customer) {
            Ok(r) => {
                return Ok(CustomerHistory {
                    source: LookupSource::Hub,
                    sessions: r.sessions,
                })
            }
            Err(e) => format!("the hub could not be asked ({e})"),
        },
    };
    let store = sessions.store();
    let mut local = Vec::new();
    for s in store.customer_sessions(customer)?.into_iter().rev() {
        let detail = store.open_session(s.id)?;
        local.push(api::RemoteSession {
            station: station.unwrap_or("this station").to_string(),
            session: s.id.0,
            created_at_ms: s.created_at_ms,
            status: crate::session::outbox::status(s.status),
            set: s.measurement_set.clone(),
            consent: s.consent.map(crate::session::outbox::consent),
            readings: detail
                .current_readings()
                .map(|r| (r.measurement.clone(), r.value_tenth_mm))
                .collect(),
            estimate_made_at_ms: store.estimate(s.id)?.map(|e| e.made_at_ms),
        });
    }
    Ok(CustomerHistory {
        source: LookupSource::Local { why },
        sessions: local,
    })
}
