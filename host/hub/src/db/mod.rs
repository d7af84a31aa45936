//! The hub's database: the connection pool, the schema migrations, and the
//! head office's commands (stations and their tokens, users, a customer's
//! export and erasure, the retention purge, the pages' reads).
//!
//! Why tokio-postgres with a deadpool pool rather than an ORM: every query
//! is a short, reviewed SQL text with `$n` parameters (never a value pasted
//! into SQL), prepared once per connection; the pool hands a request a
//! connection and replaces broken ones (a PostgreSQL restart) by itself.
//!
//! Secrets: the database URL may hold a password. It is parsed once into a
//! [`DbTarget`], whose `Display` and `Debug` never show it, and no error of
//! this module repeats the URL: tokio-postgres's errors name the host and
//! the failure, not the password.

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

use deadpool_postgres::{Manager, ManagerConfig, Pool, RecyclingMethod};
use serde::Serialize;
use sha2::Digest as _;
use tapeshape_hub_api::{customer_hash, token_hash, valid_station_name, StationToken, Status};
use tokio_postgres::NoTls;

mod reads;
pub use reads::{EstimateRow, ReadingRow, SessionFull, SessionRow};

/// Errors of the hub's database and commands. No message holds the
/// database password or a token.
#[derive(Debug, thiserror::Error)]
pub enum HubError {
    /// The `--database` text is not a PostgreSQL connection URL.
    #[error(
        "the database URL is not a PostgreSQL connection string ({0}); \
         give postgres://USER[:PASSWORD]@HOST[:PORT]/DATABASE"
    )]
    BadUrl(String),
    /// The pool could not be built.
    #[error("setting up the connection pool for {target}: {why}")]
    Pool {
        /// The database (no password).
        target: String,
        /// Why.
        why: String,
    },
    /// No connection could be had (PostgreSQL down, refused, timed out).
    #[error("no connection to the database {target}: {why}; is PostgreSQL running there?")]
    Unavailable {
        /// The database (no password).
        target: String,
        /// Why.
        why: String,
    },
    /// A query failed.
    #[error("database error: {0}")]
    Db(#[from] tokio_postgres::Error),
    /// A migration failed; nothing of it was applied.
    #[error("migration {file} failed: {error}; the database is unchanged")]
    Migration {
        /// The migration file.
        file: &'static str,
        /// PostgreSQL's error.
        error: tokio_postgres::Error,
    },
    /// An applied migration differs from this program's file of the same
    /// number: the database was migrated by a program with other SQL.
    #[error(
        "the database's migration {version} ({file}) has SHA-256 {applied}, this hub's has \
         {ours}: a released migration was edited; use the hub release the database was \
         migrated with"
    )]
    MigrationChanged {
        /// Its number.
        version: i32,
        /// Its file here.
        file: &'static str,
        /// Checksum recorded in the database.
        applied: String,
        /// Checksum of this program's file.
        ours: String,
    },
    /// The database was migrated by a newer hub.
    #[error(
        "the database has hub schema version {found}; this hub knows up to {supported}: \
         use a newer tapeshape"
    )]
    SchemaTooNew {
        /// Version found.
        found: i32,
        /// Highest version this program knows.
        supported: i32,
    },
    /// A station name that is not 1-64 of `a-z 0-9 - _`.
    #[error("invalid station name {0:?}: use 1 to 64 of a-z, 0-9, - and _, starting with a letter or digit")]
    BadStationName(String),
    /// `add-station` for a name that exists.
    #[error("station {0} exists; `tapeshape hub add-station {0} --replace` gives it a new token")]
    StationExists(String),
    /// No station has this name.
    #[error("no station {0}; `tapeshape hub stations` lists them")]
    NoSuchStation(String),
    /// A user name that is not 1-64 of `a-z 0-9 - _ .`.
    #[error("invalid user name {0:?}: use 1 to 64 of a-z, 0-9, -, _ and .")]
    BadUserName(String),
    /// A password shorter than 12 characters.
    #[error("the password is too short: use at least 12 characters")]
    WeakPassword,
    /// Hashing a password failed.
    #[error("hashing the password: {0}")]
    Hash(String),
    /// The system's random source failed.
    #[error("no random numbers from the system: {0}")]
    Random(String),
    /// A customer id that is empty, too long or holds control characters.
    #[error("invalid customer id: use 1 to 128 bytes of printable text")]
    BadCustomerId,
}

/// A PostgreSQL connection URL, parsed once. `Display` and `Debug` show
/// user, host, port and database, never the password.
#[derive(Clone)]
pub struct DbTarget {
    config: tokio_postgres::Config,
}

impl DbTarget {
    /// Parses `url` (`postgres://USER:PASSWORD@HOST:PORT/DB`, or the
    /// key=value form). The error never repeats the URL.
    pub fn parse(url: &str) -> Result<Self, HubError> {
        let config = tokio_postgres::Config::from_str(url).map_err(|e| {
            // tokio-postgres's parse errors name the bad part ("invalid
            // port"), not the text: still, say only its kind.
            let what = e.to_string();
            let what = if what.contains(url) {
                "unreadable".to_string()
            } else {
                what
            };
            HubError::BadUrl(what)
        })?;
        Ok(Self { config })
    }

    /// The parsed configuration (for connecting).
    pub fn config(&self) -> &tokio_postgres::Config {
        &self.config
    }
}

impl fmt::Display for DbTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let user = self.config.get_user().unwrap_or("?");
        let host = match self.config.get_hosts().first() {
            Some(tokio_postgres::config::Host::Tcp(h)) => h.clone(),
            Some(tokio_postgres::config::Host::Unix(p)) => p.display().to_string(),
            None => "localhost".into(),
        };
        let port = self.config.get_ports().first().copied().unwrap_or(5432);
        let db = self.config.get_dbname().unwrap_or(user);
        write!(f, "postgres://{user}@{host}:{port}/{db}")
    }
}

impl fmt::Debug for DbTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "DbTarget({self})")
    }
}

/// One hub migration file.
#[derive(Clone, Copy, Debug)]
pub struct Migration {
    /// File name in `host/hub/migrations/`.
    pub file: &'static str,
    /// Its SQL.
    pub sql: &'static str,
}

/// Every hub migration in order: entry `i` takes the schema to version `i + 1`.
pub const MIGRATIONS: &[Migration] = &[
    Migration {
        file: "0001_chain.sql",
        sql: include_str!("../../migrations/0001_chain.sql"),
    },
    Migration {
        file: "0002_careful.sql",
        sql: include_str!("../../migrations/0002_careful.sql"),
    },
];

/// An advisory lock number the migrations take, so that two hubs started
/// at once against a new database do not both migrate it.
const MIGRATION_LOCK: i64 = 0x7461_7065_7368_6170; // "tapeshap"

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 (hex) of a migration's SQL.
pub fn migration_sha256(sql: &str) -> String {
    hex(&sha2::Sha256::digest(sql.as_bytes()))
}

/// The hub's database handle: a pool of connections. Cheap to clone.
#[derive(Clone)]
pub struct Db {
    pool: Pool,
    target: DbTarget,
}

impl fmt::Debug for Db {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Db").field("target", &self.target).finish()
    }
}

/// A station as `tapeshape hub stations` and the pages list it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct StationRow {
    /// Its name.
    pub name: String,
    /// Its events 1 ..= this are applied.
    pub last_seq: i64,
    /// Sessions the hub holds of it.
    pub sessions: i64,
    /// Readings the hub holds of it.
    pub readings: i64,
    /// Its token was revoked.
    pub revoked: bool,
    /// Last sync, seconds since the Unix epoch.
    pub last_sync_unix: Option<i64>,
}

fn random_bytes<const N: usize>() -> Result<[u8; N], HubError> {
    let mut b = [0u8; N];
    getrandom::fill(&mut b).map_err(|e| HubError::Random(e.to_string()))?;
    Ok(b)
}

fn valid_user_name(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 64
        && s.bytes().all(|b| {
            b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_' || b == b'.'
        })
}

fn status_of(word: &str) -> Status {
    match word {
        "done" => Status::Done,
        "abandoned" => Status::Abandoned,
        _ => Status::Open,
    }
}

/// ms since the Unix epoch now.
pub fn now_ms() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| i64::try_from(d.as_millis()).unwrap_or(i64::MAX))
        .unwrap_or(0)
}

impl Db {
    /// A pool of up to `max_connections` connections to `target`. Connects
    /// lazily: [`Db::migrate`] is the first contact.
    pub fn new(target: DbTarget, max_connections: usize) -> Result<Self, HubError> {
        let mut config = target.config.clone();
        config.connect_timeout(Duration::from_secs(5));
        config.application_name("tapeshape-hub");
        let manager = Manager::from_config(
            config,
            NoTls,
            ManagerConfig {
                // Fast: a connection whose socket closed (PostgreSQL
                // restarted) is dropped; one that fails a query is dropped
                // by deadpool when the query's error says it is closed.
                recycling_method: RecyclingMethod::Fast,
            },
        );
        let pool = Pool::builder(manager)
            .max_size(max_connections.max(1))
            .wait_timeout(Some(Duration::from_secs(10)))
            .create_timeout(Some(Duration::from_secs(5)))
            .recycle_timeout(Some(Duration::from_secs(5)))
            .runtime(deadpool_postgres::Runtime::Tokio1)
            .build()
            .map_err(|e| HubError::Pool {
                target: target.to_string(),
                why: e.to_string(),
            })?;
        Ok(Self { pool, target })
    }

    /// The database (no password), for messages.
    pub fn target(&self) -> &DbTarget {
        &self.target
    }

    /// A connection from the pool.
    pub async fn client(&self) -> Result<deadpool_postgres::Client, HubError> {
        self.pool.get().await.map_err(|e| HubError::Unavailable {
            target: self.target.to_string(),
            why: match e {
                deadpool_postgres::PoolError::Backend(e) => e.to_string(),
                other => other.to_string(),
            },
        })
    }

    /// Applies the migrations the database has not had, in one transaction
    /// each under an advisory lock; refuses a database whose applied
    /// migrations differ from this program's or that is newer.
    pub async fn migrate(&self) -> Result<i32, HubError> {
        let mut client = self.client().await?;
        client
            .batch_execute(
                "CREATE TABLE IF NOT EXISTS hub_schema (
                    version INTEGER PRIMARY KEY, file TEXT NOT NULL, sha256 TEXT NOT NULL,
                    applied_at TIMESTAMPTZ NOT NULL DEFAULT now())",
            )
            .await?;
        let tx = client.transaction().await?;
        tx.execute("SELECT pg_advisory_xact_lock($1)", &[&MIGRATION_LOCK])
            .await?;
        let applied = tx
            .query(
                "SELECT version, sha256 FROM hub_schema ORDER BY version",
                &[],
            )
            .await?;
        let supported = MIGRATIONS.len() as i32;
        for row in &applied {
            let version: i32 = row.get(0);
            let sha: String = row.get(1);
            let Some(m) = usize::try_from(version - 1)
                .ok()
                .and_then(|i| MIGRATIONS.get(i))
            else {
                return Err(HubError::SchemaTooNew {
                    found: version,
                    supported,
                });
            };
            let ours = migration_sha256(m.sql);
            if sha != ours {
                return Err(HubError::MigrationChanged {
                    version,
                    file: m.file,
                    applied: sha,
                    ours,
                });
            }
        }
        for (i, m) in MIGRATIONS.iter().enumerate().skip(applied.len()) {
            tx.batch_execute(m.sql)
                .await
                .map_err(|error| HubError::Migration {
                    file: m.file,
                    error,
                })?;
            tx.execute(
                "INSERT INTO hub_schema (version, file, sha256) VALUES ($1, $2, $3)",
                &[&(i as i32 + 1), &m.file, &migration_sha256(m.sql)],
            )
            .await?;
            tracing::info!(file = m.file, "hub schema migrated");
        }
        tx.commit().await?;
        Ok(supported)
    }

    /// Registers station `name` and returns its token (shown once; the hub
    /// keeps its SHA-256). With `replace`, an existing station gets a new
    /// token (the old one stops working; its record and sequence stay).
    pub async fn add_station(&self, name: &str, replace: bool) -> Result<StationToken, HubError> {
        if !valid_station_name(name) {
            return Err(HubError::BadStationName(name.to_string()));
        }
        let token = StationToken::new(name, &random_bytes::<32>()?);
        let client = self.client().await?;
        let n = if replace {
            client
                .execute(
                    "INSERT INTO stations (name, token_sha256) VALUES ($1, $2)
                     ON CONFLICT (name) DO UPDATE SET token_sha256 = excluded.token_sha256,
                        revoked_at = NULL",
                    &[&name, &token.hash()],
                )
                .await?
        } else {
            client
                .execute(
                    "INSERT INTO stations (name, token_sha256) VALUES ($1, $2)
                     ON CONFLICT (name) DO NOTHING",
                    &[&name, &token.hash()],
                )
                .await?
        };
        if n == 0 {
            return Err(HubError::StationExists(name.to_string()));
        }
        Ok(token)
    }

    /// Revokes station `name`'s token: its requests get 401 from now on.
    pub async fn revoke_station(&self, name: &str) -> Result<(), HubError> {
        let n = self
            .client()
            .await?
            .execute(
                "UPDATE stations SET revoked_at = now() WHERE name = $1",
                &[&name],
            )
            .await?;
        if n == 0 {
            return Err(HubError::NoSuchStation(name.to_string()));
        }
        Ok(())
    }

    /// The station a presented bearer token belongs to, if it is known and
    /// not revoked.
    pub async fn station_for_token(&self, token: &str) -> Result<Option<String>, HubError> {
        let row = self
            .client()
            .await?
            .query_opt(
                "SELECT name FROM stations WHERE token_sha256 = $1 AND revoked_at IS NULL",
                &[&token_hash(token)],
            )
            .await?;
        Ok(row.map(|r| r.get(0)))
    }

    /// Every station with its counts.
    pub async fn stations(&self) -> Result<Vec<StationRow>, HubError> {
        let rows = self
            .client()
            .await?
            .query(
                "SELECT s.name, s.last_seq,
                    (SELECT COUNT(*) FROM sessions x WHERE x.station = s.name),
                    (SELECT COUNT(*) FROM readings r WHERE r.station = s.name),
                    s.revoked_at IS NOT NULL,
                    EXTRACT(EPOCH FROM s.last_sync_at)::BIGINT
                 FROM stations s ORDER BY s.name",
                &[],
            )
            .await?;
        Ok(rows
            .iter()
            .map(|r| StationRow {
                name: r.get(0),
                last_seq: r.get(1),
                sessions: r.get(2),
                readings: r.get(3),
                revoked: r.get(4),
                last_sync_unix: r.get(5),
            })
            .collect())
    }

    /// Adds head-office user `name` with `password` (at least 12
    /// characters), or replaces their password. Stored as argon2id.
    pub async fn add_user(&self, name: &str, password: &str) -> Result<(), HubError> {
        if !valid_user_name(name) {
            return Err(HubError::BadUserName(name.to_string()));
        }
        if password.chars().count() < 12 {
            return Err(HubError::WeakPassword);
        }
        let phc = hash_password(password)?;
        self.client()
            .await?
            .execute(
                "INSERT INTO users (name, password_argon2) VALUES ($1, $2)
                 ON CONFLICT (name) DO UPDATE SET password_argon2 = excluded.password_argon2",
                &[&name, &phc],
            )
            .await?;
        Ok(())
    }

    /// Is `password` user `name`'s? (argon2 verification runs on a
    /// blocking thread: it takes tens of milliseconds on purpose.)
    pub async fn check_user(&self, name: &str, password: &str) -> Result<bool, HubError> {
        if !valid_user_name(name) {
            return Ok(false);
        }
        let row = self
            .client()
            .await?
            .query_opt(
                "SELECT password_argon2 FROM users WHERE name = $1",
                &[&name],
            )
            .await?;
        let Some(row) = row else { return Ok(false) };
        let phc: String = row.get(0);
        let password = password.to_string();
        Ok(
            tokio::task::spawn_blocking(move || verify_password(&phc, &password))
                .await
                .unwrap_or(false),
        )
    }

    /// Everything the hub holds about `customer` (every station), as JSON:
    /// the customer's right of access. Bodies are counted, not included.
    pub async fn customer_export(&self, customer: &str) -> Result<serde_json::Value, HubError> {
        if !tapeshape_hub_api::valid_text(customer, tapeshape_hub_api::MAX_CUSTOMER_ID_LEN) {
            return Err(HubError::BadCustomerId);
        }
        let hash = customer_hash(customer);
        let keys = self
            .client()
            .await?
            .query(
                "SELECT station, session FROM sessions WHERE customer_hash = $1 AND customer = $2
                 ORDER BY created_at_ms, station, session",
                &[&hash, &customer],
            )
            .await?;
        let mut sessions = Vec::new();
        for k in &keys {
            if let Some(s) = self.session_full(k.get(0), k.get(1)).await? {
                sessions.push(s);
            }
        }
        let erasures = self
            .client()
            .await?
            .query(
                "SELECT erased_at_ms, origin FROM erasures WHERE customer_hash = $1 ORDER BY id",
                &[&hash],
            )
            .await?
            .iter()
            .map(|r| serde_json::json!({"erased_at_ms": r.get::<_, i64>(0), "origin": r.get::<_, String>(1)}))
            .collect::<Vec<_>>();
        Ok(serde_json::json!({
            "format": "tapeshape customer export",
            "version": 1,
            "held_by": "hub",
            "customer": customer,
            "exported_at_ms": now_ms(),
            "units": "lengths in tenths of a millimetre (value_tenth_mm); times in ms since the Unix epoch (UTC)",
            "sessions": sessions,
            "earlier_erasures": erasures,
        }))
    }

    /// Erases `customer` chain-wide at the hub: deletes every session the
    /// hub holds of them, keeps an erasure record (id hash, time) and tells
    /// every station that held them (an erasure notice). Returns the number
    /// of sessions deleted and of stations told.
    pub async fn customer_erase(&self, customer: &str) -> Result<(u64, u64), HubError> {
        if !tapeshape_hub_api::valid_text(customer, tapeshape_hub_api::MAX_CUSTOMER_ID_LEN) {
            return Err(HubError::BadCustomerId);
        }
        let mut client = self.client().await?;
        let tx = client.transaction().await?;
        let (sessions, stations) =
            crate::apply::erase_customer(&tx, &customer_hash(customer), now_ms(), "hub").await?;
        tx.commit().await?;
        Ok((sessions, stations))
    }

    /// Deletes the sessions created before `cutoff_ms` whose customer did
    /// not choose "keep my data" (the retention of `--retain-days`).
    /// Returns how many.
    pub async fn purge_older_than(&self, cutoff_ms: i64) -> Result<u64, HubError> {
        Ok(self
            .client()
            .await?
            .execute(
                "DELETE FROM sessions WHERE created_at_ms < $1 AND consent IS DISTINCT FROM 'keep'",
                &[&cutoff_ms],
            )
            .await?)
    }
}

/// argon2id (the crate's default parameters) of `password`, PHC string.
pub fn hash_password(password: &str) -> Result<String, HubError> {
    use argon2::password_hash::{PasswordHasher as _, SaltString};
    let salt = SaltString::encode_b64(&random_bytes::<16>()?)
        .map_err(|e| HubError::Hash(e.to_string()))?;
    argon2::Argon2::default()
        .hash_password(password.as_bytes(), &salt)
        .map(|h| h.to_string())
        .map_err(|e| HubError::Hash(e.to_string()))
}

/// Does `password` match the PHC string `phc`?
pub fn verify_password(phc: &str, password: &str) -> bool {
    use argon2::password_hash::{PasswordHash, PasswordVerifier as _};
    PasswordHash::new(phc)
        .map(|h| {
            argon2::Argon2::default()
                .verify_password(password.as_bytes(), &h)
                .is_ok()
        })
        .unwrap_or(false)
}

/// A new random password for a head-office user: 20 characters of an
/// alphabet without look-alikes (about 116 bits).
pub fn generate_password() -> Result<String, HubError> {
    const ALPHABET: &[u8] = b"abcdefghijkmnpqrstuvwxyzACDEFGHJKLMNPQRSTUVWXYZ23456789";
    let bytes = random_bytes::<20>()?;
    // 256 is not a multiple of 55: the first 220 byte values map evenly,
    // and the few above bias a character by under 0.5 %, which costs well
    // under a bit of the password's 116.
    Ok(bytes
        .iter()
        .map(|b| ALPHABET[usize::from(*b) % ALPHABET.len()] as char)
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_target_never_shows_the_password() {
        let t = DbTarget::parse("postgres://hub:s3cret-pw@db.example:6543/chain").unwrap();
        let shown = format!("{t} {t:?}");
        assert!(!shown.contains("s3cret-pw"), "{shown}");
        assert!(
            shown.contains("postgres://hub@db.example:6543/chain"),
            "{shown}"
        );
        let e = DbTarget::parse("postgres://hub:s3cret-pw@db.example:notaport/chain").unwrap_err();
        assert!(!e.to_string().contains("s3cret-pw"), "{e}");
    }

    #[test]
    fn passwords_verify_only_themselves() {
        let phc = hash_password("correct horse battery").unwrap();
        assert!(phc.starts_with("$argon2id$"), "{phc}");
        assert!(verify_password(&phc, "correct horse battery"));
        assert!(!verify_password(&phc, "correct horse batterx"));
        assert!(!verify_password("not a phc", "x"));
        let a = generate_password().unwrap();
        assert_eq!(a.chars().count(), 20);
        assert_ne!(a, generate_password().unwrap());
    }

    fn dir() -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("migrations")
    }

    /// A released migration never changes (the hub would refuse every
    /// database migrated with the released file), and every file is listed.
    #[test]
    fn released_migrations_never_change() {
        let list = std::fs::read_to_string(dir().join("released.sha256")).unwrap();
        let released: Vec<(String, String)> = list
            .lines()
            .filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
            .map(|l| {
                let (sum, file) = l.split_once("  ").expect("`<sha256>  <file>` lines");
                (file.trim().to_string(), sum.trim().to_string())
            })
            .collect();
        assert_eq!(released.len(), MIGRATIONS.len());
        for (m, (file, sum)) in MIGRATIONS.iter().zip(&released) {
            assert_eq!(m.file, file);
            assert_eq!(
                &migration_sha256(m.sql),
                sum,
                "hub migration {} was edited after its release: add a new one instead",
                m.file
            );
        }
        let mut files: Vec<String> = std::fs::read_dir(dir())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.ends_with(".sql"))
            .collect();
        files.sort();
        let listed: Vec<&str> = MIGRATIONS.iter().map(|m| m.file).collect();
        assert_eq!(files, listed);
    }
}
