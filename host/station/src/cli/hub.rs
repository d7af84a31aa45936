//! `tapeshape hub ...`: the chain's head-office hub (`tapeshape-hub`):
//! serve it, register stations and head-office users, and a customer's
//! export and erasure for the whole chain.
//!
//! Built with the cargo feature `hub` (on by default); a kiosk built with
//! `--no-default-features` carries none of the hub's server stack.
//!
//! The database URL may hold a password: give it in the
//! `TAPESHAPE_HUB_DATABASE` environment variable rather than on the command
//! line (where `ps` shows it). It is never printed or logged.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _};
use tapeshape_hub::{Db, DbTarget, ServeConfig};

use crate::cli::Global;

/// Environment variable holding the hub's database URL.
pub const DATABASE_ENV: &str = "TAPESHAPE_HUB_DATABASE";

/// Arguments of `tapeshape hub`.
#[derive(clap::Args, Clone, Debug)]
#[command(args_conflicts_with_subcommands = false)]
pub struct Args {
    /// PostgreSQL connection URL (postgres://USER:PASSWORD@HOST:PORT/DB)
    /// [default: $TAPESHAPE_HUB_DATABASE, which keeps the password off the
    /// command line].
    #[arg(long, value_name = "URL", global = true)]
    pub database: Option<String>,

    /// Address to serve on (IP:PORT; port 0 takes a free one and prints it).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8750")]
    pub listen: SocketAddr,

    /// TLS certificate chain (PEM); with --tls-key the hub serves HTTPS.
    #[arg(long, value_name = "FILE", requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,

    /// TLS private key (PEM).
    #[arg(long, value_name = "FILE", requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,

    /// Purge sessions older than N days unless their customer chose "keep
    /// my data" (checked at start and every hour).
    #[arg(long, value_name = "N")]
    pub retain_days: Option<u32>,

    /// Most connections to PostgreSQL this hub process opens.
    #[arg(long, value_name = "N", default_value_t = 16)]
    pub max_connections: usize,

    /// A head-office command instead of serving.
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// The head office's commands.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum Command {
    /// Register a station and print its token (shown once; the hub keeps a hash).
    AddStation {
        /// The station's name (a-z, 0-9, -, _).
        name: String,
        /// Give an existing station a new token (the old one stops working).
        #[arg(long)]
        replace: bool,
        /// Write the token to this file (owner-only) instead of printing it.
        #[arg(long, value_name = "FILE")]
        token_file: Option<PathBuf>,
    },
    /// Revoke a station's token: its requests get 401 from now on.
    RevokeStation {
        /// The station.
        name: String,
    },
    /// List the stations with what the hub holds of each.
    Stations,
    /// Add a head-office user for the pages (or set their password).
    AddUser {
        /// User name (a-z, 0-9, -, _, .).
        name: String,
        /// Read the password (at least 12 characters) from this file;
        /// without it a random one is made and printed once.
        #[arg(long, value_name = "FILE")]
        password_file: Option<PathBuf>,
    },
    /// A customer's data in the whole chain.
    Customer {
        /// What to do.
        #[command(subcommand)]
        action: CustomerAction,
    },
    /// Purge, once, sessions older than N days unless their customer chose
    /// "keep my data".
    Purge {
        /// Days to keep.
        #[arg(long, value_name = "N")]
        retain_days: u32,
    },
}

/// `tapeshape hub customer ...`.
#[derive(clap::Subcommand, Clone, Debug)]
pub enum CustomerAction {
    /// Write everything the hub holds about a customer (every store) as JSON.
    Export {
        /// The customer's id.
        id: String,
        /// File to write (owner-only); `-` or none: stdout.
        #[arg(long, value_name = "FILE")]
        out: Option<PathBuf>,
    },
    /// Erase a customer at the hub now and at every store that holds them
    /// on its next sync; the hub keeps only a record (id hash, time).
    Erase {
        /// The customer's id.
        id: String,
        /// Confirm.
        #[arg(long)]
        yes: bool,
    },
}

fn database_url(args: &Args) -> anyhow::Result<DbTarget> {
    let url = match &args.database {
        Some(u) => u.clone(),
        None => match std::env::var(DATABASE_ENV) {
            Ok(u) if !u.trim().is_empty() => u,
            _ => bail!(
                "no database: give --database postgres://... or set {DATABASE_ENV} \
                 (which keeps the password off the command line)"
            ),
        },
    };
    Ok(DbTarget::parse(&url)?)
}

/// Runs the hub or one of its commands.
pub fn run(args: Args, _global: &Global) -> anyhow::Result<()> {
    let target = database_url(&args)?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let db = Db::new(target, args.max_connections)?;
    runtime.block_on(async move {
        let Some(command) = args.command.clone() else {
            let config = ServeConfig {
                listen: args.listen,
                tls: args.tls_cert.clone().zip(args.tls_key.clone()),
                retain_days: args.retain_days,
                purge_every: Duration::from_secs(3600),
            };
            let stop = async {
                let mut term =
                    match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate())
                    {
                        Ok(t) => t,
                        Err(_) => {
                            let _ = tokio::signal::ctrl_c().await;
                            return;
                        }
                    };
                tokio::select! {
                    _ = tokio::signal::ctrl_c() => {}
                    _ = term.recv() => {}
                }
            };
            return tapeshape_hub::serve(db, config, stop).await;
        };
        db.migrate().await?;
        match command {
            Command::AddStation {
                name,
                replace,
                token_file,
            } => {
                let token = db.add_station(&name, replace).await?;
                match token_file {
                    Some(path) => {
                        crate::cli::customer::write_private(
                            &path,
                            format!("{}\n", token.expose()).as_bytes(),
                        )?;
                        outln!("station {name}: token written to {}", path.display())?;
                    }
                    None => {
                        outln!("{}", token.expose())?;
                        eprintln!(
                            "station {name}: the line above is its token, shown only now; \
                             put it in a file for `tapeshape station --station-token FILE`"
                        );
                    }
                }
            }
            Command::RevokeStation { name } => {
                db.revoke_station(&name).await?;
                outln!("station {name} revoked")?;
            }
            Command::Stations => {
                outln!(
                    "{:<24} {:>9} {:>9} {:>8}  STATE",
                    "STATION",
                    "EVENTS",
                    "SESSIONS",
                    "READINGS"
                )?;
                for s in db.stations().await? {
                    outln!(
                        "{:<24} {:>9} {:>9} {:>8}  {}",
                        s.name,
                        s.last_seq,
                        s.sessions,
                        s.readings,
                        if s.revoked { "revoked" } else { "active" }
                    )?;
                }
            }
            Command::AddUser {
                name,
                password_file,
            } => {
                let (password, made) = match password_file {
                    Some(f) => (
                        std::fs::read_to_string(&f)
                            .with_context(|| format!("reading {}", f.display()))?
                            .trim_end_matches(['\r', '\n'])
                            .to_string(),
                        false,
                    ),
                    None => (tapeshape_hub::db::generate_password()?, true),
                };
                db.add_user(&name, &password).await?;
                if made {
                    outln!("{password}")?;
                    eprintln!("user {name}: the line above is the password, shown only now");
                } else {
                    outln!("user {name}: password set")?;
                }
            }
            Command::Customer { action } => match action {
                CustomerAction::Export { id, out } => {
                    let value = db.customer_export(&id).await?;
                    let text = serde_json::to_string_pretty(&value)?;
                    match out {
                        Some(p) if p != std::path::Path::new("-") => {
                            crate::cli::customer::write_private(&p, text.as_bytes())?;
                            outln!(
                                "exported {} sessions of the customer to {}",
                                value["sessions"].as_array().map_or(0, |a| a.len()),
                                p.display()
                            )?;
                        }
                        _ => outln!("{text}")?,
                    }
                }
                CustomerAction::Erase { id, yes } => {
                    if !yes {
                        bail!(
                            "this erases the customer at the hub and at every store; run again \
                             with --yes to confirm"
                        );
                    }
                    let (sessions, stations) = db.customer_erase(&id).await?;
                    outln!(
                        "erased {sessions} sessions at the hub; {stations} stores are told on \
                         their next sync"
                    )?;
                }
            },
            Command::Purge { retain_days } => {
                let cutoff = tapeshape_hub::db::now_ms() - i64::from(retain_days) * 86_400_000;
                let n = db.purge_older_than(cutoff).await?;
                outln!("purged {n} sessions older than {retain_days} days")?;
            }
        }
        Ok(())
    })
}
