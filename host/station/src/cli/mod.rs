//! Subcommands of the `tapeshape` binary, one module each.
//!
//! Why in the library: `src/main.rs` stays a thin dispatcher, and each
//! subcommand's arguments and behaviour can be tested without spawning the
//! binary. To add a subcommand `foo`: write `cli/foo.rs` with a
//! `#[derive(clap::Args)] pub struct Args` and
//! `pub fn run(args: Args, global: &Global) -> anyhow::Result<()>`, add
//! `pub mod foo;` here, one variant to `Command` in `main.rs` and one
//! dispatch line.
//!
//! Printing: commands print with `outln!` (and `out!`), which return the
//! write's error instead of panicking as `println!` does, so that a closed
//! pipe (`tapeshape predict --list | head`) ends the command quietly: `main`
//! exits with success on a broken pipe, as ripgrep and grep do
//! ([`is_broken_pipe`]).
//!
//! Layer: the top; the commands may use every module of the station.

use std::path::PathBuf;

use anyhow::Context as _;

use crate::session::Sessions;
use crate::store::{resolve_data_dir, Store};

/// `print!` to stdout that returns `std::io::Result<()>` instead of
/// panicking when stdout is closed. (Defined before the command modules, so
/// they see it.)
macro_rules! out {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        ::std::write!(::std::io::stdout().lock(), $($arg)*)
    }};
}

/// `println!` to stdout that returns `std::io::Result<()>` instead of
/// panicking when stdout is closed (see the module docs).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use ::std::io::Write as _;
        ::std::writeln!(::std::io::stdout().lock(), $($arg)*)
    }};
}

pub mod batch;
pub mod customer;
pub mod dataset;
#[cfg(feature = "demo")]
pub mod demo;
#[cfg(feature = "hub")]
pub mod hub;
pub mod measure;
pub mod moved;
pub mod ports;
pub mod predict;
pub mod session;
pub mod sessions;
pub mod station;
pub mod sync;
pub mod train;

/// Options every subcommand takes.
#[derive(clap::Args, Clone, Debug, Default)]
pub struct Global {
    /// Directory holding the session database [default: $TAPESHAPE_DATA_DIR,
    /// else the user's data directory, e.g. ~/.local/share/tapeshape].
    #[arg(long, global = true, value_name = "DIR")]
    pub data_dir: Option<PathBuf>,

    /// More log output on stderr (-v info, -vv debug, -vvv trace). The
    /// TAPESHAPE_LOG environment variable (tracing filter syntax) overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,

    /// Language of the operator text (the kiosk screens, device faults)
    /// [default: from LC_ALL, LC_MESSAGES or LANG: German for de_*, else
    /// English]. The line mode's fixed words that scripts read (`session`,
    /// `port`, `fault queue-full`, ...) stay English.
    #[arg(long, global = true, value_name = "LANG")]
    pub lang: Option<crate::i18n::Lang>,
}

impl Global {
    /// The language of the operator text: `--lang`, else the locale's.
    pub fn lang(&self) -> crate::i18n::Lang {
        self.lang.unwrap_or_else(crate::i18n::Lang::from_env)
    }

    /// The data directory (`--data-dir`, `TAPESHAPE_DATA_DIR` or the user's).
    pub fn data_dir(&self) -> anyhow::Result<PathBuf> {
        Ok(resolve_data_dir(self.data_dir.as_deref())?)
    }

    /// Opens the session store in the chosen data directory.
    pub fn open_store(&self) -> anyhow::Result<Store> {
        let dir = self.data_dir()?;
        Store::open(&dir).with_context(|| format!("opening the session store in {}", dir.display()))
    }

    /// The session layer over the store in the chosen data directory.
    pub fn open_sessions(&self) -> anyhow::Result<Sessions> {
        self.open_store().map(Sessions::new)
    }
}

/// Options of the front ends that sync to the chain's hub (`station`,
/// `demo`). Without `--hub` nothing is sent anywhere (the outbox is kept,
/// so a station can join a chain later with its history).
#[derive(clap::Args, Clone, Debug, Default)]
pub struct HubArgs {
    /// The chain's head-office hub to sync this station's sessions to
    /// (http://HOST:PORT or https://HOST:PORT); needs --station-token.
    #[arg(long, value_name = "URL", requires = "station_token")]
    pub hub: Option<String>,

    /// File holding this station's token (`tapeshape hub add-station NAME`
    /// prints it; keep the file owner-only).
    #[arg(long, value_name = "FILE", requires = "hub")]
    pub station_token: Option<PathBuf>,

    /// PEM file with the certificate of the CA that signed the hub's TLS
    /// certificate (a private CA or a self-signed hub), instead of the
    /// public web's roots.
    #[arg(long, value_name = "FILE", requires = "hub")]
    pub hub_ca: Option<PathBuf>,
}

impl HubArgs {
    /// The sync settings, if a hub is given.
    pub fn config(&self) -> anyhow::Result<Option<crate::sync::SyncConfig>> {
        let (Some(hub), Some(token)) = (&self.hub, &self.station_token) else {
            return Ok(None);
        };
        let token = crate::sync::read_token(token)?;
        let mut config = crate::sync::SyncConfig::new(hub, token)?;
        if let Some(ca) = &self.hub_ca {
            config.ca_pem =
                Some(std::fs::read(ca).with_context(|| {
                    format!("reading the hub's CA certificate {}", ca.display())
                })?);
        }
        Ok(Some(config))
    }

    /// Starts the sync task for `sessions` if a hub is given.
    pub fn start(&self, sessions: &Sessions) -> anyhow::Result<Option<crate::sync::SyncHandle>> {
        let Some(config) = self.config()? else {
            return Ok(None);
        };
        let hub = config.hub.clone();
        let glb: crate::sync::GlbSource = std::sync::Arc::new(crate::services::station::glb_of);
        let handle = crate::sync::spawn(sessions.clone(), config, glb)
            .with_context(|| format!("starting the sync with the hub {hub}"))?;
        tracing::info!(%hub, "syncing with the hub");
        Ok(Some(handle))
    }
}

/// Stops a sync task after giving it up to `wait` to send what is left;
/// says on stderr if something is still unsent (it goes on the next start).
pub fn finish_sync(sync: Option<crate::sync::SyncHandle>, wait: std::time::Duration) {
    let Some(sync) = sync else { return };
    let synced = sync.wait_synced(wait);
    let st = sync.status();
    if !synced {
        eprintln!(
            "the hub holds this station's events up to {} of {}; the rest is sent on the next start with --hub{}",
            st.committed_through,
            st.last_seq,
            st.last_error
                .map(|e| format!(" (last error: {e})"))
                .unwrap_or_default()
        );
    }
    sync.stop();
}

/// Libraries that see requests, headers or connection strings: capped at
/// info by [`init_logging`].
pub const WIRE_LOGGERS: [&str; 11] = [
    "ureq",
    "ureq_proto",
    "rustls",
    "hyper",
    "hyper_util",
    "h2",
    "axum",
    "axum_server",
    "tower_http",
    "tokio_postgres",
    "postgres_protocol",
];

/// Sets up logging to stderr: level from `-v` unless `TAPESHAPE_LOG` is set
/// (the [`WIRE_LOGGERS`] never log below info).
pub fn init_logging(verbose: u8) {
    let default = match verbose {
        0 => "warn",
        1 => "info",
        2 => "debug",
        _ => "trace",
    };
    let mut filter = tracing_subscriber::EnvFilter::try_from_env("TAPESHAPE_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    // The HTTP, TLS and PostgreSQL libraries trace what goes over the wire
    // (ureq's trace level dumps each request, the station's token in its
    // Authorization header included): when anything is logged below info
    // (-vv, -vvv or TAPESHAPE_LOG), they stay at info, so that no secret
    // reaches a log.
    let below_info = filter
        .max_level_hint()
        .is_none_or(|l| l > tracing_subscriber::filter::LevelFilter::INFO);
    if below_info {
        for quiet in WIRE_LOGGERS {
            if let Ok(d) = format!("{quiet}=info").parse() {
                filter = filter.add_directive(d);
            }
        }
    }
    // Ignore the error of a second initialisation (tests may call this).
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Is `err` (or anything in its chain) a write to a closed pipe? Then the
/// reader has what it wanted (`| head`) and the command ends quietly.
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// `err` and its causes on one line, `outer: cause: ...`, leaving out a
/// cause whose text the message before it already ends with. Many of the
/// library errors print their source in their own message ("{path}:
/// {source}") and also return it as their source, and anyhow's `{:#}`
/// then printed it twice ("No such file or directory (os error 2): No such
/// file or directory (os error 2)").
pub fn error_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.ends_with(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line
}

/// Monochrome when asked, or when `NO_COLOR` is set to anything non-empty
/// (<https://no-color.org>).
pub fn mono_wanted(flag: bool) -> bool {
    flag || std::env::var_os("NO_COLOR").is_some_and(|v| !v.is_empty())
}

/// Parses `--reading-tolerance MM` into metres (see
/// [`crate::services::station::reading_tolerance_m`]).
pub fn reading_tolerance(mm: Option<f64>) -> anyhow::Result<Option<f64>> {
    Ok(crate::services::station::reading_tolerance_m(mm)?)
}

#[cfg(test)]
mod tests {
    #[test]
    fn error_line_prints_each_cause_once() {
        #[derive(Debug, thiserror::Error)]
        #[error("{path}: {source}")]
        struct Shown {
            path: String,
            source: std::io::Error,
        }
        let io = || std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        // A source the message already shows: once.
        let e = anyhow::Error::new(Shown {
            path: "/x.tsd".into(),
            source: io(),
        })
        .context("reading the dataset /x.tsd");
        assert_eq!(
            super::error_line(&e),
            "reading the dataset /x.tsd: /x.tsd: no such file"
        );
        // A source the message does not show: appended, as {:#} does.
        let e = anyhow::Error::new(io()).context("opening the store");
        assert_eq!(super::error_line(&e), "opening the store: no such file");
        assert_eq!(super::error_line(&anyhow::anyhow!("plain")), "plain");
    }

    use super::*;

    #[test]
    fn a_broken_pipe_is_found_under_context() {
        let e = anyhow::Error::new(std::io::Error::from(std::io::ErrorKind::BrokenPipe))
            .context("writing the list");
        assert!(is_broken_pipe(&e));
        let other = anyhow::Error::new(std::io::Error::from(std::io::ErrorKind::NotFound));
        assert!(!is_broken_pipe(&other));
    }
}
