//! The hub's HTTP service: the stations' API (bearer tokens) and the head
//! office's pages (HTTP basic authentication), plain or over TLS.
//!
//! Why axum (with axum-server for TLS through rustls): a well-kept, small
//! stack on tokio and hyper; every handler is a plain async function over
//! the [`Db`]. The handlers read request bodies as bytes and parse them
//! themselves, so that every refusal (malformed JSON, bytes that are not
//! UTF-8, an oversized batch, an unknown field) is a 4xx with a JSON body
//! that says what was wrong, in the same shape as the hub's other answers.
//!
//! Nothing here logs a request's headers or body: a station's token and a
//! user's password arrive in headers and are only ever hashed.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{DefaultBodyLimit, Path, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use tapeshape_hub_api::{
    ApiError, LookupRequest, LookupResponse, SyncRequest, WhoAmI, LOOKUP_PATH, MAX_BODY_BYTES,
    SYNC_PATH, WHOAMI_PATH,
};

use crate::apply::{apply_batch, BatchError};
use crate::db::{Db, HubError};

/// How [`serve`] runs.
#[derive(Clone, Debug)]
pub struct ServeConfig {
    /// Address to listen on (port 0: any free port; the one taken is
    /// printed).
    pub listen: SocketAddr,
    /// TLS certificate chain and private key (PEM files), or plain HTTP.
    pub tls: Option<(PathBuf, PathBuf)>,
    /// Purge sessions older than this many days unless their customer chose
    /// "keep my data" (checked at start and every `purge_every`).
    pub retain_days: Option<u32>,
    /// How often the retention purge runs.
    pub purge_every: Duration,
}

/// An answer with an [`ApiError`] body.
#[derive(Debug)]
pub struct Refusal {
    status: StatusCode,
    message: String,
    challenge: Option<&'static str>,
}

impl Refusal {
    fn new(status: StatusCode, message: impl Into<String>) -> Self {
        Self {
            status,
            message: message.into(),
            challenge: None,
        }
    }

    fn unauthorized(message: &str, challenge: &'static str) -> Self {
        Self {
            status: StatusCode::UNAUTHORIZED,
            message: message.to_string(),
            challenge: Some(challenge),
        }
    }
}

impl IntoResponse for Refusal {
    fn into_response(self) -> Response {
        let mut r = (
            self.status,
            axum::Json(ApiError {
                error: self.message,
            }),
        )
            .into_response();
        if let Some(c) = self.challenge {
            r.headers_mut()
                .insert(header::WWW_AUTHENTICATE, HeaderValue::from_static(c));
        }
        r
    }
}

impl From<HubError> for Refusal {
    fn from(e: HubError) -> Self {
        match e {
            HubError::Unavailable { .. } | HubError::Db(_) => {
                tracing::warn!(error = %e, "database error answering a request");
                Refusal::new(
                    StatusCode::SERVICE_UNAVAILABLE,
                    "the hub's database is unavailable or failed; try again later \
                     (a station retries by itself)",
                )
            }
            HubError::BadCustomerId => {
                Refusal::new(StatusCode::UNPROCESSABLE_ENTITY, e.to_string())
            }
            other => {
                tracing::error!(error = %other, "hub error answering a request");
                Refusal::new(
                    StatusCode::INTERNAL_SERVER_ERROR,
                    "the hub failed; see its log",
                )
            }
        }
    }
}

const BEARER_CHALLENGE: &str = "Bearer realm=\"tapeshape hub\"";
const BASIC_CHALLENGE: &str = "Basic realm=\"tapeshape hub\", charset=\"UTF-8\"";

/// The station whose token the request carries (`Authorization: Bearer`).
async fn station_of(db: &Db, headers: &HeaderMap) -> Result<String, Refusal> {
    let refuse = || {
        Refusal::unauthorized(
            "no valid station token: send `Authorization: Bearer <token>` with the token \
             `tapeshape hub add-station NAME` printed (a revoked token no longer works)",
            BEARER_CHALLENGE,
        )
    };
    let value = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .ok_or_else(refuse)?;
    let token = value
        .strip_prefix("Bearer ")
        .map(str::trim)
        .filter(|t| !t.is_empty() && t.len() <= 256)
        .ok_or_else(refuse)?;
    db.station_for_token(token).await?.ok_or_else(refuse)
}

/// The head-office user of the request (`Authorization: Basic`).
async fn user_of(db: &Db, headers: &HeaderMap) -> Result<String, Refusal> {
    use base64::Engine as _;
    let refuse = || {
        Refusal::unauthorized(
            "head-office pages need a user name and password (`tapeshape hub add-user NAME`)",
            BASIC_CHALLENGE,
        )
    };
    let value = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .ok_or_else(refuse)?;
    let encoded = value.strip_prefix("Basic ").ok_or_else(refuse)?;
    let decoded = base64::engine::general_purpose::STANDARD
        .decode(encoded.trim())
        .map_err(|_| refuse())?;
    let text = String::from_utf8(decoded).map_err(|_| refuse())?;
    let (user, password) = text.split_once(':').ok_or_else(refuse)?;
    if db.check_user(user, password).await? {
        Ok(user.to_string())
    } else {
        Err(refuse())
    }
}

/// Parses a JSON body, refusing what is not (with what was wrong).
fn json_body<T: serde::de::DeserializeOwned>(
    body: Result<Bytes, BytesRejection>,
) -> Result<T, Refusal> {
    let bytes = body.map_err(|r| {
        let status = r.status();
        if status == StatusCode::PAYLOAD_TOO_LARGE {
            Refusal::new(
                status,
                format!(
                    "the request is larger than {MAX_BODY_BYTES} bytes; send fewer events per batch"
                ),
            )
        } else {
            Refusal::new(status, format!("the request body could not be read: {r}"))
        }
    })?;
    serde_json::from_slice(&bytes).map_err(|e| {
        Refusal::new(
            StatusCode::BAD_REQUEST,
            format!("the request body is not the JSON this endpoint takes: {e}"),
        )
    })
}

async fn sync(
    State(db): State<Db>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, Refusal> {
    let station = station_of(&db, &headers).await?;
    let req: SyncRequest = json_body(body)?;
    let mut client = db.client().await?;
    match apply_batch(&mut client, &station, &req).await {
        Ok(applied) => {
            tracing::debug!(
                station,
                applied = applied.applied,
                skipped = applied.skipped,
                through = applied.response.committed_through,
                "batch committed"
            );
            Ok(axum::Json(applied.response).into_response())
        }
        Err(e @ BatchError::WrongStation { .. }) => {
            tracing::warn!(station, error = %e, "batch for another station refused");
            Err(Refusal::new(StatusCode::FORBIDDEN, e.to_string()))
        }
        Err(e @ BatchError::Revoked(_)) => {
            Err(Refusal::unauthorized(&e.to_string(), BEARER_CHALLENGE))
        }
        Err(e @ (BatchError::BadEvent { .. } | BatchError::TooMany(_))) => {
            let status = if matches!(e, BatchError::TooMany(_)) {
                StatusCode::PAYLOAD_TOO_LARGE
            } else {
                StatusCode::UNPROCESSABLE_ENTITY
            };
            Err(Refusal::new(
                status,
                format!("{e}; nothing of the batch was stored"),
            ))
        }
        Err(BatchError::Hub(e)) => Err(e.into()),
    }
}

async fn lookup(
    State(db): State<Db>,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, Refusal> {
    station_of(&db, &headers).await?;
    let req: LookupRequest = json_body(body)?;
    if !tapeshape_hub_api::valid_text(&req.customer, tapeshape_hub_api::MAX_CUSTOMER_ID_LEN) {
        return Err(HubError::BadCustomerId.into());
    }
    let sessions = db.lookup(&req.customer).await?;
    Ok(axum::Json(LookupResponse { sessions }).into_response())
}

async fn whoami(State(db): State<Db>, headers: HeaderMap) -> Result<Response, Refusal> {
    let station = station_of(&db, &headers).await?;
    Ok(axum::Json(WhoAmI { station }).into_response())
}

/// `GET /healthz`: 200 when the database answers (no data, no auth).
async fn healthz(State(db): State<Db>) -> Response {
    match db.client().await {
        Ok(c) if c.simple_query("SELECT 1").await.is_ok() => {
            (StatusCode::OK, "ok\n").into_response()
        }
        _ => (StatusCode::SERVICE_UNAVAILABLE, "database unavailable\n").into_response(),
    }
}

async fn page_index(State(db): State<Db>, headers: HeaderMap) -> Result<Response, Refusal> {
    user_of(&db, &headers).await?;
    let stations = db.stations().await?;
    Ok(crate::web::html(crate::web::index_page(&stations)))
}

fn station_param(name: &str) -> Result<(), Refusal> {
    if tapeshape_hub_api::valid_station_name(name) {
        Ok(())
    } else {
        Err(Refusal::new(StatusCode::NOT_FOUND, "no such store"))
    }
}

async fn page_store(
    State(db): State<Db>,
    headers: HeaderMap,
    Path(station): Path<String>,
) -> Result<Response, Refusal> {
    user_of(&db, &headers).await?;
    station_param(&station)?;
    let sessions = db.station_sessions(&station).await?;
    Ok(crate::web::html(crate::web::store_page(
        &station, &sessions,
    )))
}

async fn page_session(
    State(db): State<Db>,
    headers: HeaderMap,
    Path((station, session)): Path<(String, String)>,
) -> Result<Response, Refusal> {
    user_of(&db, &headers).await?;
    station_param(&station)?;
    let session: i64 = session
        .parse()
        .map_err(|_| Refusal::new(StatusCode::NOT_FOUND, "no such session"))?;
    match db.session_full(&station, session).await? {
        Some(s) => Ok(crate::web::html(crate::web::session_page(&s))),
        None => Err(Refusal::new(StatusCode::NOT_FOUND, "no such session")),
    }
}

async fn body_glb(
    State(db): State<Db>,
    headers: HeaderMap,
    Path((station, session)): Path<(String, String)>,
) -> Result<Response, Refusal> {
    user_of(&db, &headers).await?;
    station_param(&station)?;
    let session: i64 = session
        .parse()
        .map_err(|_| Refusal::new(StatusCode::NOT_FOUND, "no such session"))?;
    match db.body_glb(&station, session).await? {
        Some(glb) => Ok((
            [
                (header::CONTENT_TYPE, "model/gltf-binary"),
                (header::CACHE_CONTROL, "private, no-store"),
            ],
            glb,
        )
            .into_response()),
        None => Err(Refusal::new(
            StatusCode::NOT_FOUND,
            "this session has no body",
        )),
    }
}

async fn static_file(
    State(db): State<Db>,
    headers: HeaderMap,
    Path(path): Path<String>,
) -> Result<Response, Refusal> {
    user_of(&db, &headers).await?;
    match crate::web::static_asset(&path) {
        Some((mime, bytes)) => Ok((
            [
                (header::CONTENT_TYPE, mime),
                (header::CACHE_CONTROL, "private, max-age=3600"),
            ],
            bytes,
        )
            .into_response()),
        None => Err(Refusal::new(StatusCode::NOT_FOUND, "no such file")),
    }
}

async fn not_found() -> Refusal {
    Refusal::new(StatusCode::NOT_FOUND, "no such page or endpoint")
}

/// The hub's routes over `db`.
pub fn router(db: Db) -> Router {
    Router::new()
        .route(SYNC_PATH, post(sync))
        .route(LOOKUP_PATH, post(lookup))
        .route(WHOAMI_PATH, get(whoami))
        .route("/healthz", get(healthz))
        .route("/", get(page_index))
        .route("/stores/{station}", get(page_store))
        .route("/stores/{station}/sessions/{session}", get(page_session))
        .route(
            "/stores/{station}/sessions/{session}/body.glb",
            get(body_glb),
        )
        .route("/static/three/{*path}", get(static_file))
        .fallback(not_found)
        .layer(DefaultBodyLimit::max(MAX_BODY_BYTES))
        .with_state(db)
}

/// Serves the hub on `config.listen` until `shutdown` completes: migrates
/// the database first (refusing one migrated by other SQL), prints
/// `hub listening on http(s)://ADDR` on stdout once it accepts connections,
/// and runs the retention purge if asked.
pub async fn serve(
    db: Db,
    config: ServeConfig,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    use anyhow::Context as _;
    let listener = std::net::TcpListener::bind(config.listen)
        .with_context(|| format!("listening on {}", config.listen))?;
    serve_listener(db, listener, config, shutdown).await
}

/// [`serve`] on a socket already bound (`config.listen` is not used).
pub async fn serve_listener(
    db: Db,
    listener: std::net::TcpListener,
    config: ServeConfig,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> anyhow::Result<()> {
    use anyhow::Context as _;
    use std::io::Write as _;
    let version = db.migrate().await?;
    tracing::info!(target = %db.target(), version, "hub database ready");
    listener
        .set_nonblocking(true)
        .context("setting up the listening socket")?;
    let addr = listener
        .local_addr()
        .context("reading the listening address")?;
    if let Some(days) = config.retain_days {
        let db = db.clone();
        let every = config.purge_every;
        tokio::spawn(async move {
            let mut tick = tokio::time::interval(every);
            loop {
                tick.tick().await;
                let cutoff = crate::db::now_ms() - i64::from(days) * 86_400_000;
                match db.purge_older_than(cutoff).await {
                    Ok(0) => {}
                    Ok(n) => tracing::info!(sessions = n, days, "retention purge"),
                    Err(e) => {
                        tracing::warn!(error = %e, "retention purge failed; tried again later")
                    }
                }
            }
        });
    }
    let handle = axum_server::Handle::new();
    let stopper = handle.clone();
    tokio::spawn(async move {
        shutdown.await;
        stopper.graceful_shutdown(Some(Duration::from_secs(5)));
    });
    let app = router(db).into_make_service();
    // A closed stdout (nobody reads the line) is no reason to stop serving.
    let announce = |scheme: &str| {
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "hub listening on {scheme}://{addr}");
        let _ = out.flush();
    };
    match &config.tls {
        None => {
            announce("http");
            axum_server::from_tcp(listener)
                .context("serving")?
                .handle(handle)
                .serve(app)
                .await
                .context("serving")?;
        }
        Some((cert, key)) => {
            let tls = axum_server::tls_rustls::RustlsConfig::from_pem_file(cert, key)
                .await
                .with_context(|| {
                    format!(
                        "reading the TLS certificate {} and key {} (PEM files)",
                        cert.display(),
                        key.display()
                    )
                })?;
            announce("https");
            axum_server::from_tcp_rustls(listener, tls)
                .context("serving")?
                .handle(handle)
                .serve(app)
                .await
                .context("serving")?;
        }
    }
    Ok(())
}
