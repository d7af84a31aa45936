//! `tapeshape station`: the fitting-room station on a real tape.
//!
//! `tapeshape station --port PATH` runs the kiosk terminal interface
//! ([`crate::tui`]). With `--customer`, `--session` or `--resume` it runs
//! the plain line mode instead, which scripts and end-to-end tests drive:
//! one line per event for one session. Every line on stdout starts with a fixed word (`session`, `port`,
//! `connected`, `live`, `next`, `committed`, `complete`, `duplicate`, `gap`, `held`,
//! `commit-failed`, `fault`, `status`, `button`, `bad-frame`,
//! `disconnected`, `waiting`, `done`, `stopped`) so it can be followed by
//! eye or by a program. Logs go to stderr.

use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _};
use tapeshape_protocol::UnitShown;

use crate::cli::{mono_wanted, reading_tolerance, Global};
use crate::link::{Link, LinkConfig, LinkEvent, Naming, Unassigned};
use crate::session::Sessions;
use crate::store::{Session, SessionId, SessionStatus};
use crate::text::{describe_fault, format_tenth_mm};

/// Arguments of `tapeshape station`.
#[derive(clap::Args, Clone, Debug)]
#[command(group(
    clap::ArgGroup::new("which").required(false).args(["customer", "session", "resume"])
))]
pub struct Args {
    /// Serial port of the tape's firmware (e.g. /dev/ttyACM0, or a simulator's pty path).
    #[arg(long, value_name = "PATH")]
    pub port: PathBuf,

    /// Line mode: start a new session for this customer id (opaque text).
    /// Without --customer, --session or --resume the terminal interface runs.
    #[arg(long, value_name = "ID")]
    pub customer: Option<String>,

    /// Continue this open session.
    #[arg(long, value_name = "ID")]
    pub session: Option<i64>,

    /// Continue the most recently updated open session.
    #[arg(long)]
    pub resume: bool,

    /// Measurement set the new session follows (a built-in set such as
    /// paper34, ansur, quick, face7, or a set's TOML file): readings take the
    /// set's measurement names in order. A resumed session keeps its set and
    /// continues with the measurements it does not have yet. In the
    /// interface: the set preselected for new customers.
    #[arg(long = "set", value_name = "NAME")]
    pub measurement_set: Option<String>,

    /// Names of the measurements, in the order they will be taken
    /// (comma-separated); overrides the set's order. Without this or a set,
    /// readings are named reading-1, reading-2, ...
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub measurements: Vec<String>,

    /// With a set or --measurements: mark the session done and exit once
    /// every measurement is committed.
    #[arg(long)]
    pub exit_when_complete: bool,

    /// Print live tape values as they change.
    #[arg(long)]
    pub live: bool,

    /// Baud rate of the host link (ignored by pseudo-terminals).
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,

    /// Terminal interface without colours (also when NO_COLOR is set).
    #[arg(long)]
    pub mono: bool,

    /// Folder for exported bodies and reports, and the customers' cards (`p`)
    /// [default: DATA_DIR/exports].
    #[arg(long, value_name = "DIR")]
    pub export_dir: Option<PathBuf>,

    /// The operator's reading uncertainty in millimetres (standard
    /// deviation; about 10 for a novice with a tape). Readings are checked
    /// and fitted with it instead of a skilled measurer's ISO 20685-1
    /// tolerances.
    #[arg(long, value_name = "MM")]
    pub reading_tolerance: Option<f64>,

    /// Line mode: the new customer's choice about their data: keep (keep my
    /// data) or visit (this visit only). The interface asks it on the new
    /// customer screen.
    #[arg(long, value_name = "CHOICE")]
    pub consent: Option<crate::store::Consent>,

    /// The store's size chart (TOML, docs/size-charts.md): the result
    /// screen shows a size per garment [default: DATA_DIR/size-chart.toml
    /// when it exists].
    #[arg(long, value_name = "FILE")]
    pub chart: Option<PathBuf>,

    /// Syncing to the chain's hub.
    #[command(flatten)]
    pub hub: crate::cli::HubArgs,
}

/// The size chart of `tapeshape station`: `--chart FILE`, else
/// `DATA_DIR/size-chart.toml` if there is one. A chart that cannot be
/// read stops the start with its error (better than a fitting room
/// without sizes it thinks it has).
fn station_chart(
    chart: Option<&std::path::Path>,
    data_dir: &std::path::Path,
) -> anyhow::Result<Option<tapeshape_sizes::Chart>> {
    let path = match chart {
        Some(p) => p.to_path_buf(),
        None => {
            let p = data_dir.join("size-chart.toml");
            if !p.exists() {
                return Ok(None);
            }
            p
        }
    };
    let estimator = tapeshape_estimator::Estimator::default_model()?;
    Ok(Some(crate::estimate::sizes::load_chart(&path, estimator)?))
}

/// Is the line mode asked for (a session named on the command line)?
fn line_mode(args: &Args) -> bool {
    args.customer.is_some() || args.session.is_some() || args.resume
}

/// Runs the terminal interface on `port` (the real-tape station).
fn run_tui(args: Args, global: &Global) -> anyhow::Result<()> {
    use std::io::IsTerminal as _;
    if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
        bail!(
            "the station's interface needs a terminal; for scripts use the line mode: \
             tapeshape station --port {} --customer ID [--set quick]",
            args.port.display()
        );
    }
    for (given, what) in [
        (!args.measurements.is_empty(), "--measurements"),
        (args.exit_when_complete, "--exit-when-complete"),
        (args.live, "--live"),
    ] {
        if given {
            bail!("{what} belongs to the line mode (with --customer, --session or --resume)");
        }
    }
    let tolerance = reading_tolerance(args.reading_tolerance)?;
    // --set preselects the set on the new customer form.
    let default_set = match &args.measurement_set {
        Some(set) => {
            tapeshape_measure::MeasurementSet::load(set)?;
            set.clone()
        }
        None => "quick".to_string(),
    };
    let sessions = global.open_sessions()?;
    let sync = args.hub.start(&sessions)?;
    let data_dir = global.data_dir()?;
    let export_dir = match args.export_dir {
        Some(d) => d,
        None => data_dir.join("exports"),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let mut services = crate::services::station::StationServices::new(sessions.clone(), tolerance);
    if let Some(chart) = station_chart(args.chart.as_deref(), &data_dir)? {
        services = services.with_chart(chart);
    }
    let services = std::sync::Arc::new(services);
    // Load the model while the operator types the first customer, so that
    // the first estimate is as fast as the tenth (an error shows at the
    // first estimate, where the interface reports it).
    let _ = std::thread::Builder::new()
        .name("model-warm-up".into())
        .spawn(|| {
            let _ = tapeshape_estimator::Estimator::default_model();
        });
    let options = crate::tui::runner::RunOptions {
        sessions,
        port_label: args.port.display().to_string(),
        port: args.port,
        baud: args.baud,
        mono: mono_wanted(args.mono),
        export_dir,
        log_dir: data_dir,
        default_set,
        demo: None,
    };
    let result = crate::tui::runner::run_with_log(options, services, &runtime);
    crate::cli::finish_sync(sync, Duration::from_secs(5));
    result
}

/// Runs the station until Ctrl-C (or completion with
/// `--exit-when-complete`).
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    check_port(&args.port)?;
    if !line_mode(&args) {
        return run_tui(args, global);
    }
    if args.reading_tolerance.is_some() || args.mono || args.export_dir.is_some() {
        bail!(
            "--reading-tolerance, --mono and --export-dir belong to the terminal interface; \
             the line mode (--customer, --session, --resume) only records readings"
        );
    }
    let sessions = global.open_sessions()?;
    let sync = args.hub.start(&sessions)?;
    let session = choose_session(&sessions, &args)?;
    let plan = plan(&sessions, &session, &args.measurements)?;
    outln!(
        "session {} customer {} set {} ({} readings so far); store {}",
        session.id,
        session.customer_id,
        session.measurement_set.as_deref().unwrap_or("-"),
        sessions.store().reading_count(session.id)?,
        sessions.store().path().display()
    )?;
    if args.exit_when_complete && plan.as_ref().is_none_or(|p| p.is_empty()) {
        bail!(
            "--exit-when-complete needs something to complete: a --set or --measurements \
             with measurements this session does not have yet"
        );
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let options = RecordOptions {
        port: args.port.clone(),
        baud: args.baud,
        live: args.live,
        exit_when_complete: args.exit_when_complete,
    };
    let result = runtime.block_on(record(options, sessions, session.id, plan));
    crate::cli::finish_sync(sync, Duration::from_secs(5));
    result
}

/// One measurement still to take: its name and what to tell the operator.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Planned {
    /// Measurement name stored with the reading.
    pub name: String,
    /// Human label (the name itself when there is none).
    pub label: String,
}

/// The measurements still to take in this session, in order: `measurements`
/// if not empty, else the session's measurement set, else `None` (readings
/// are numbered). Names the session already has are skipped, so a resumed
/// session continues where it stopped.
pub fn plan(
    sessions: &Sessions,
    session: &Session,
    measurements: &[String],
) -> anyhow::Result<Option<Vec<Planned>>> {
    let all: Vec<Planned> = if !measurements.is_empty() {
        measurements
            .iter()
            .map(|n| Planned {
                name: n.trim().to_string(),
                label: n.trim().to_string(),
            })
            .collect()
    } else if let Some(set) = &session.measurement_set {
        let set = tapeshape_measure::MeasurementSet::load(set).with_context(|| {
            format!("loading measurement set {set:?} of session {}", session.id)
        })?;
        set.definitions
            .into_iter()
            .map(|d| Planned {
                name: d.name,
                label: d.label,
            })
            .collect()
    } else {
        return Ok(None);
    };
    let have: std::collections::HashSet<String> = sessions
        .store()
        .open_session(session.id)?
        .current_readings()
        .map(|r| r.measurement.clone())
        .collect();
    Ok(Some(
        all.into_iter()
            .filter(|p| !have.contains(&p.name))
            .collect(),
    ))
}

/// A port that exists must be a character device; one that does not exist
/// yet is fine (the link waits for it: a tape plugged in later).
fn check_port(port: &std::path::Path) -> anyhow::Result<()> {
    use std::os::unix::fs::FileTypeExt;
    if let Ok(meta) = std::fs::metadata(port) {
        if !meta.file_type().is_char_device() {
            bail!(
                "{} is not a serial port (not a character device); give the tape's port, \
                 e.g. /dev/ttyACM0 or /dev/ttyUSB0",
                port.display()
            );
        }
    }
    Ok(())
}

fn choose_session(sessions: &Sessions, args: &Args) -> anyhow::Result<Session> {
    if let Some(customer) = &args.customer {
        if let Some(set) = &args.measurement_set {
            // Refuse an unknown set before creating the session.
            tapeshape_measure::MeasurementSet::load(set)?;
        }
        return Ok(sessions.create_with_consent(
            customer,
            args.measurement_set.as_deref(),
            None,
            args.consent,
        )?);
    }
    if args.measurement_set.is_some() {
        bail!("--set applies to a new session (--customer); a resumed session keeps its own set");
    }
    let store = sessions.store();
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

/// How [`record`] runs.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// Serial port path.
    pub port: PathBuf,
    /// Baud rate (ignored by pseudo-terminals).
    pub baud: u32,
    /// Print live values.
    pub live: bool,
    /// Mark the session done and return once `plan` is fully committed.
    pub exit_when_complete: bool,
}

/// Runs the link on `options.port` for `session`, printing one line per
/// event on stdout (the format described in the module docs), until Ctrl-C,
/// completion (with `exit_when_complete`) or a version mismatch (an error).
/// `plan` names the readings in order (see [`plan`]); `None` numbers them.
/// Must run inside a tokio runtime with time, I/O and signals enabled. The
/// `demo` command reuses this with a simulated tape's port.
pub async fn record(
    options: RecordOptions,
    sessions: Sessions,
    session: SessionId,
    plan: Option<Vec<Planned>>,
) -> anyhow::Result<()> {
    let args = options;
    let config = LinkConfig {
        baud_rate: args.baud,
        ..LinkConfig::default()
    };
    let (link, mut events, task) = Link::spawn(&args.port, config, sessions.clone());
    link.set_session(Some(session));
    let mut todo: VecDeque<Planned> = plan.clone().unwrap_or_default().into();
    link.set_naming(match &plan {
        Some(p) => Naming::Script(p.iter().map(|p| p.name.clone()).collect()),
        None => Naming::Numbered,
    });
    if let Some(next) = todo.front() {
        outln!("next {} ({})", next.name, next.label)?;
    }
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
                outln!("stopping (Ctrl-C)")?;
                stopping = true;
                link.shutdown();
                continue;
            }
        };
        let Some(ev) = ev else { break };
        match ev {
            LinkEvent::PortOpened { path } => outln!(
                "port {} opened; waiting for the tape's hello",
                path.display()
            )?,
            LinkEvent::Connected(h) => outln!(
                "connected tape {:016x} boot {} firmware {}.{}.{} protocol {}.{} queue {}",
                h.device_id,
                h.boot_id,
                h.firmware.major,
                h.firmware.minor,
                h.firmware.patch,
                h.protocol.major,
                h.protocol.minor,
                h.queue_capacity
            )?,
            LinkEvent::VersionMismatch(m) => {
                outln!("error {m}")?;
                result = Err(anyhow::Error::new(m));
                link.shutdown();
            }
            LinkEvent::Live(l) => {
                if args.live && last_live != Some(l.value_tenth_mm) {
                    last_live = Some(l.value_tenth_mm);
                    outln!("live {}", format_tenth_mm(l.value_tenth_mm))?;
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
                outln!(
                    "committed {} = {} (seq {}, tape showing {unit})",
                    reading.measurement,
                    format_tenth_mm(reading.value_tenth_mm),
                    reading
                        .tape()
                        .map_or(String::from("-"), |t| t.seq.to_string())
                )?;
                if plan.is_some() {
                    if todo.front().map(|p| &p.name) == Some(&reading.measurement) {
                        todo.pop_front();
                    }
                    match todo.front() {
                        Some(next) => outln!("next {} ({})", next.name, next.label)?,
                        None => {
                            outln!("complete every measurement of the session is stored")?;
                            if args.exit_when_complete {
                                sessions.set_status(session, SessionStatus::Done)?;
                                outln!("done session {session} marked done")?;
                                link.shutdown();
                            }
                        }
                    }
                }
            }
            LinkEvent::Duplicate {
                seq,
                last_committed_seq,
                ..
            } => outln!(
                "duplicate seq {seq} already stored; acknowledged up to {last_committed_seq}"
            )?,
            LinkEvent::Gap { expected, got, .. } => outln!(
                "gap got seq {got} but {expected} is missing; waiting for the tape to resend"
            )?,
            LinkEvent::ReadingUnassigned { reading, why } => outln!(
                "held seq {} {} not stored: {}",
                reading.seq,
                format_tenth_mm(reading.value_tenth_mm),
                match why {
                    Unassigned::NoSession => "no session",
                    Unassigned::NoName => "no measurement name left",
                }
            )?,
            LinkEvent::CommitFailed { reading, error } => outln!(
                "commit-failed seq {} {}: {error}; the tape keeps it",
                reading.seq,
                format_tenth_mm(reading.value_tenth_mm)
            )?,
            LinkEvent::Button(b) => outln!("button {b:?}")?,
            LinkEvent::Status(s) => tracing::info!(?s, "device status"),
            LinkEvent::Fault(f) => outln!("fault {}", describe_fault(&f))?,
            LinkEvent::Pong { rtt } => tracing::debug!(?rtt, "pong"),
            LinkEvent::BadFrame { error, counters } => {
                outln!("bad-frame {error} ({} so far)", counters.frames_bad)?
            }
            LinkEvent::Disconnected { reason, .. } => {
                outln!("disconnected {reason}; reconnecting")?
            }
            LinkEvent::WaitingForPort { error } => outln!("waiting {error}")?,
            LinkEvent::Stopped => {
                outln!("stopped")?;
                break;
            }
        }
    }
    // The task ends right after Stopped; give it a moment, then go.
    let _ = tokio::time::timeout(Duration::from_secs(2), task).await;
    let detail = sessions.store().open_session(session)?;
    outln!(
        "session {session}: {} readings stored ({} current)",
        detail.readings.len(),
        detail.current_readings().count()
    )?;
    result
}
