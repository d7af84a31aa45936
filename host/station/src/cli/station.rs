//! `tapeshape station`: run the tape link for one session and print what
//! happens, line by line.
//!
//! This is the plain-text face of the station until the terminal interface
//! (a later issue) replaces it; it is also what scripts and end-to-end tests
//! drive. Every line on stdout starts with a fixed word (`session`, `port`,
//! `connected`, `live`, `committed`, `duplicate`, `gap`, `held`,
//! `commit-failed`, `fault`, `status`, `button`, `bad-frame`,
//! `disconnected`, `waiting`, `done`, `stopped`) so it can be followed by
//! eye or by a program. Logs go to stderr.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _};
use tapeshape_protocol::{Fault, UnitShown};

use crate::cli::{format_tenth_mm, Global};
use crate::link::{Link, LinkConfig, LinkEvent, Naming, Unassigned};
use crate::store::{Session, SessionId, SessionStatus, Store};

/// Arguments of `tapeshape station`.
#[derive(clap::Args, Clone, Debug)]
#[command(group(
    clap::ArgGroup::new("which").required(true).args(["customer", "session", "resume"])
))]
pub struct Args {
    /// Serial port of the tape's firmware (e.g. /dev/ttyACM0, or a simulator's pty path).
    #[arg(long, value_name = "PATH")]
    pub port: PathBuf,

    /// Start a new session for this customer id (opaque text).
    #[arg(long, value_name = "ID")]
    pub customer: Option<String>,

    /// Continue this open session.
    #[arg(long, value_name = "ID")]
    pub session: Option<i64>,

    /// Continue the most recently updated open session.
    #[arg(long)]
    pub resume: bool,

    /// Measurement set the new session follows (recorded with the session).
    #[arg(long = "set", value_name = "NAME")]
    pub measurement_set: Option<String>,

    /// Names of the measurements, in the order they will be taken
    /// (comma-separated); each committed reading takes the next name. Without
    /// it, readings are named reading-1, reading-2, ...
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub measurements: Vec<String>,

    /// With --measurements: mark the session done and exit once every named
    /// measurement is committed.
    #[arg(long, requires = "measurements")]
    pub exit_when_complete: bool,

    /// Print live tape values as they change.
    #[arg(long)]
    pub live: bool,

    /// Baud rate of the host link (ignored by pseudo-terminals).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
}

/// Runs the station until Ctrl-C (or completion with
/// `--exit-when-complete`).
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    let store = global.open_store()?;
    let session = choose_session(&store, &args)?;
    println!(
        "session {} customer {} ({} readings so far); store {}",
        session.id,
        session.customer_id,
        store.open_session(session.id)?.readings.len(),
        store.path().display()
    );
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    runtime.block_on(run_link(args, store, session.id))
}

fn choose_session(store: &Store, args: &Args) -> anyhow::Result<Session> {
    if let Some(customer) = &args.customer {
        return Ok(store.create_session(customer, args.measurement_set.as_deref())?);
    }
    let session = if let Some(id) = args.session {
        store.session(SessionId(id))?
    } else {
        match store.latest_unfinished_session()? {
            Some(s) => s,
            None => bail!("--resume: there is no open session; start one with --customer ID"),
        }
    };
    if session.status != SessionStatus::Open {
        bail!(
            "session {} is {}; reopen it with `tapeshape session set-status {} open` \
             or start a new one with --customer ID",
            session.id,
            session.status,
            session.id
        );
    }
    Ok(session)
}

async fn run_link(args: Args, store: Store, session: SessionId) -> anyhow::Result<()> {
    let config = LinkConfig {
        baud_rate: args.baud,
        ..LinkConfig::default()
    };
    let (link, mut events, task) = Link::spawn(&args.port, config, store.clone());
    link.set_session(Some(session));
    let scripted = !args.measurements.is_empty();
    link.set_naming(if scripted {
        Naming::Script(args.measurements.iter().cloned().collect::<VecDeque<_>>())
    } else {
        Naming::Numbered
    });
    let mut remaining = args.measurements.len();
    let mut last_live = None;
    let mut result = Ok(());
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let mut stopping = false;
    loop {
        let ev = tokio::select! {
            ev = events.recv() => ev,
            r = &mut ctrl_c, if !stopping => {
                r.context("listening for Ctrl-C")?;
                println!("stopping (Ctrl-C)");
                stopping = true;
                link.shutdown();
                continue;
            }
        };
        let Some(ev) = ev else { break };
        match ev {
            LinkEvent::PortOpened { path } => {
                println!(
                    "port {} opened; waiting for the tape's hello",
                    path.display()
                )
            }
            LinkEvent::Connected(h) => println!(
                "connected tape {:016x} boot {} firmware {}.{}.{} protocol {}.{} queue {}",
                h.device_id,
                h.boot_id,
                h.firmware.major,
                h.firmware.minor,
                h.firmware.patch,
                h.protocol.major,
                h.protocol.minor,
                h.queue_capacity
            ),
            LinkEvent::VersionMismatch(m) => {
                println!("error {m}");
                result = Err(anyhow::Error::new(m));
                link.shutdown();
            }
            LinkEvent::Live(l) => {
                if args.live && last_live != Some(l.value_tenth_mm) {
                    last_live = Some(l.value_tenth_mm);
                    println!("live {}", format_tenth_mm(l.value_tenth_mm));
                }
            }
            LinkEvent::ReadingCommitted {
                reading,
                unit_shown,
            } => {
                let unit = match unit_shown {
                    UnitShown::Metric => "cm",
                    UnitShown::Imperial => "in",
                };
                println!(
                    "committed {} = {} (seq {}, tape showing {unit})",
                    reading.measurement,
                    format_tenth_mm(reading.device.value_tenth_mm),
                    reading.device.seq
                );
                if scripted {
                    remaining = remaining.saturating_sub(1);
                    if remaining == 0 && args.exit_when_complete {
                        store.set_status(session, SessionStatus::Done)?;
                        println!("done session {session}: every measurement committed");
                        link.shutdown();
                    }
                }
            }
            LinkEvent::Duplicate {
                seq,
                last_committed_seq,
                ..
            } => println!(
                "duplicate seq {seq} already stored; acknowledged up to {last_committed_seq}"
            ),
            LinkEvent::Gap { expected, got, .. } => println!(
                "gap got seq {got} but {expected} is missing; waiting for the tape to resend"
            ),
            LinkEvent::ReadingUnassigned { reading, why } => println!(
                "held seq {} {} not stored: {}",
                reading.seq,
                format_tenth_mm(reading.value_tenth_mm),
                match why {
                    Unassigned::NoSession => "no session",
                    Unassigned::NoName => "no measurement name left",
                }
            ),
            LinkEvent::CommitFailed { reading, error } => println!(
                "commit-failed seq {} {}: {error}; the tape keeps it",
                reading.seq,
                format_tenth_mm(reading.value_tenth_mm)
            ),
            LinkEvent::Button(b) => println!("button {b:?}"),
            LinkEvent::Status(s) => tracing::info!(?s, "device status"),
            LinkEvent::Fault(f) => println!("fault {}", describe_fault(&f)),
            LinkEvent::Pong { rtt } => tracing::debug!(?rtt, "pong"),
            LinkEvent::BadFrame { error, counters } => {
                println!("bad-frame {error} ({} so far)", counters.frames_bad)
            }
            LinkEvent::Disconnected { reason, .. } => {
                println!("disconnected {reason}; reconnecting")
            }
            LinkEvent::WaitingForPort { error } => println!("waiting {error}"),
            LinkEvent::Stopped => {
                println!("stopped");
                break;
            }
        }
    }
    // The task ends right after Stopped; give it a moment, then go.
    let _ = tokio::time::timeout(Duration::from_secs(2), task).await;
    let detail = store.open_session(session)?;
    println!(
        "session {session}: {} readings stored ({} current)",
        detail.readings.len(),
        detail.current_readings().count()
    );
    result
}

fn describe_fault(f: &Fault) -> String {
    match *f {
        Fault::QueueFull {
            capacity,
            refused_value_tenth_mm,
            ..
        } => format!(
            "queue-full: the tape's queue ({capacity}) is full; {} was NOT recorded, take it again",
            format_tenth_mm(refused_value_tenth_mm)
        ),
        Fault::QueueRecovered { queue_len } => format!("queue-recovered ({queue_len} held)"),
        Fault::TapeSilent { silent_ms } => format!(
            "tape-silent: no line from the tape for {:.1} s; check its cable",
            f64::from(silent_ms) / 1000.0
        ),
        Fault::TapeRecovered => "tape-recovered".to_string(),
        Fault::LineRejected {
            reason,
            rejected_total,
        } => format!("line-rejected {reason:?} ({rejected_total} since boot)"),
        Fault::VersionMismatch { host, device } => format!(
            "version-mismatch: the tape speaks protocol {}.{}, it was greeted with {}.{}",
            device.major, device.minor, host.major, host.minor
        ),
        Fault::HostFrameBad { total } => {
            format!("host-frame-bad: the tape dropped a frame from us ({total} since boot)")
        }
    }
}
