//! `tapeshape station`: the fitting-room station on a real tape.
//!
//! `tapeshape station` runs the kiosk terminal interface ([`crate::tui`]).
//! With `--customer`, `--session` or `--resume` it runs the plain line mode
//! instead, which scripts and end-to-end tests drive: one line per event
//! for one session. Every line on stdout starts with a fixed word
//! (`found`, `looking`, `seen`, `session`, `port`, `connected`, `live`,
//! `next`, `committed`, `kept`, `complete`, `duplicate`, `gap`, `held`,
//! `commit-failed`, `fault`, `status`, `button`, `bad-frame`,
//! `disconnected`, `waiting`, `done`, `stopped`) so it can be followed by
//! eye or by a program. Logs go to stderr.
//!
//! The tape's port: `--port PATH` when given (it wins); otherwise the
//! station finds it ([`crate::link::probe`]): it probes the serial ports
//! that look like a tape station and connects to the one that answers,
//! under its `/dev/serial/by-id` name when it has one (so that an unplug
//! and replug that renumbers `ttyACM` still finds it). With two answering,
//! the kiosk asks which (a key per station) and the line mode stops with
//! an error naming the `--port` of each. With none, it says what to plug
//! in and what it saw, and looks again every second until one answers
//! (q or Ctrl-C leaves).

use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _};
use tapeshape_protocol::UnitShown;

use crate::cli::{mono_wanted, reading_tolerance, Global};
use crate::i18n::{self, tr};
use crate::link::probe::{self, Decision, Outcome, ProbeConfig, Probed, Survey, SystemPorts};
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
    /// Without it the station finds the tape among the serial ports (see `tapeshape ports`).
    #[arg(long, value_name = "PATH")]
    pub port: Option<PathBuf>,

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

    /// Careful mode (ISO 20685-1): each measurement twice, a third time
    /// when the two differ by more than the measurement's allowable error
    /// (its ISO 20685-1 tolerance), the median kept (of two: their mean);
    /// the report states the session's technical error of measurement
    /// (TEM). The kiosk offers it to every new customer (the form's
    /// `readings` field changes it per customer); in line mode it applies
    /// to the new session. A resumed session keeps the mode it was started
    /// in.
    #[arg(long)]
    pub careful: bool,

    /// Syncing to the chain's hub.
    #[command(flatten)]
    pub hub: crate::cli::HubArgs,
}

/// The size chart of `tapeshape station`: `--chart FILE`, else
/// `DATA_DIR/size-chart.toml` if there is one. A chart that cannot be
/// read stops the start with its error (better than a fitting room
/// without sizes it thinks it has).
pub(crate) fn station_chart(
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

/// Runs the terminal interface on the tape's port (the real-tape station).
fn run_tui(args: Args, global: &Global) -> anyhow::Result<()> {
    use std::io::IsTerminal as _;
    if !std::io::stdout().is_terminal() || !std::io::stdin().is_terminal() {
        bail!(
            "the station's interface needs a terminal; for scripts use the line mode: \
             tapeshape station [--port PATH] --customer ID [--set quick]"
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
    // The chart is read before the search, so that a bad one stops the
    // start at once, not after the tape is found.
    let data_dir = global.data_dir()?;
    let chart = station_chart(args.chart.as_deref(), &data_dir)?;
    let port = match &args.port {
        Some(p) => p.clone(),
        None => match find_kiosk(probe_config(args.baud))? {
            Some(p) => p,
            None => return Ok(()),
        },
    };
    let sessions = global.open_sessions()?;
    let sync = args.hub.start(&sessions)?;
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
    if let Some(chart) = chart {
        services = services.with_chart(chart);
    }
    let services = std::sync::Arc::new(services);
    // Load the model while the operator types the first customer, so that
    // the first estimate is as fast as the tenth (an error shows at the
    // first estimate, where the interface reports it).
    let _ = crate::services::station::warm_up_in_background();
    let options = crate::tui::runner::RunOptions {
        sessions,
        port_label: port.display().to_string(),
        port,
        baud: args.baud,
        mono: mono_wanted(args.mono),
        export_dir,
        log_dir: data_dir,
        default_set,
        careful: args.careful,
        demo: None,
    };
    let result = crate::tui::runner::run_with_log(options, services, &runtime);
    crate::cli::finish_sync(sync, Duration::from_secs(5));
    result
}

/// Runs the station until Ctrl-C (or completion with
/// `--exit-when-complete`).
pub fn run(args: Args, global: &Global) -> anyhow::Result<()> {
    if let Some(port) = &args.port {
        check_port(port)?;
    }
    if !line_mode(&args) {
        return run_tui(args, global);
    }
    if args.reading_tolerance.is_some() || args.mono || args.export_dir.is_some() {
        bail!(
            "--reading-tolerance, --mono and --export-dir belong to the terminal interface; \
             the line mode (--customer, --session, --resume) only records readings"
        );
    }
    // Found before the session is chosen, so that a search that ends
    // (two stations, Ctrl-C) leaves no new session behind.
    let port = match &args.port {
        Some(p) => p.clone(),
        None => {
            let runtime = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .context("starting the async runtime")?;
            match runtime.block_on(find_line(probe_config(args.baud)))? {
                Some(p) => p,
                None => return Ok(()),
            }
        }
    };
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
        port,
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
    // What the session has: its current readings, or in careful mode the
    // measurements with a kept value (one between its readings is still
    // to take).
    let detail = sessions.store().open_session(session.id)?;
    let have: std::collections::HashSet<String> = sessions
        .kept_readings(&detail)?
        .into_iter()
        .map(|(name, _)| name)
        .collect();
    Ok(Some(
        all.into_iter()
            .filter(|p| !have.contains(&p.name))
            .collect(),
    ))
}

/// Careful mode: which reading of the round is expected next (" reading 2
/// of 2", " reading 3 of 3: the two differ by 11.0 mm (allowed 9.0 mm)");
/// empty outside careful mode and for a round not begun.
fn reading_of(round: Option<&crate::session::careful::Round>) -> String {
    let Some(r) = round else {
        return String::new();
    };
    let Some(n) = r.next_reading() else {
        return String::new();
    };
    let mut out = format!(" reading {n} of {}", r.needed());
    if let (Some(apart), Some(allowed), true) = (r.apart(), r.allowed, n > 2) {
        out.push_str(&format!(
            ": the two differ by {:.1} mm (allowed {:.1} mm)",
            f64::from(apart) / 10.0,
            f64::from(allowed) / 10.0
        ));
    }
    out
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
        return Ok(sessions.create_new(
            customer,
            args.measurement_set.as_deref(),
            None,
            crate::session::NewSession {
                consent: args.consent,
                careful: args.careful,
            },
        )?);
    }
    if args.careful {
        bail!(
            "--careful applies to a new session (--customer); a resumed session keeps the mode \
             it was started in"
        );
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
    // Careful mode names each reading after the measurement the operator
    // is on (it is taken two or three times), set anew after every commit.
    let careful = sessions.store().is_careful(session)?;
    link.set_naming(match &plan {
        Some(_) if careful => match todo.front() {
            Some(next) => Naming::Current(next.name.clone()),
            None => Naming::None,
        },
        Some(p) => Naming::Script(p.iter().map(|p| p.name.clone()).collect()),
        None => Naming::Numbered,
    });
    if let Some(next) = todo.front() {
        let detail = sessions.store().open_session(session)?;
        let round = sessions.open_round(&detail, &next.name)?;
        outln!(
            "next {} ({}){}",
            next.name,
            next.label,
            reading_of(round.as_ref())
        )?;
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
                    let mut again = None;
                    if careful {
                        let detail = sessions.store().open_session(session)?;
                        match sessions.open_round(&detail, &reading.measurement)? {
                            Some(r) if !r.readings.is_empty() => again = Some(r),
                            _ => {
                                if let Some((_, v)) = sessions
                                    .kept_readings(&detail)?
                                    .into_iter()
                                    .find(|(n, _)| *n == reading.measurement)
                                {
                                    outln!(
                                        "kept {} = {} (the median of its last round)",
                                        reading.measurement,
                                        format_tenth_mm(v)
                                    )?;
                                }
                            }
                        }
                    }
                    if again.is_none()
                        && todo.front().map(|p| &p.name) == Some(&reading.measurement)
                    {
                        todo.pop_front();
                        if careful {
                            link.set_naming(match todo.front() {
                                Some(next) => Naming::Current(next.name.clone()),
                                None => Naming::None,
                            });
                        }
                    }
                    match todo.front() {
                        Some(next) => outln!(
                            "next {} ({}){}",
                            next.name,
                            next.label,
                            reading_of(again.as_ref().filter(|_| next.name == reading.measurement))
                        )?,
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

/// How the station probes for its tape: the defaults at `baud`.
fn probe_config(baud: u32) -> ProbeConfig {
    ProbeConfig {
        baud_rate: baud,
        ..ProbeConfig::default()
    }
}

/// How often the search looks again while no station answers.
const LOOK_AGAIN: Duration = Duration::from_secs(1);

/// The path to connect to for a found station: its stable name.
fn connect_path(p: &Probed) -> PathBuf {
    probe::stable_path(&p.candidate.path)
}

/// The line-mode error for two or more answering stations.
fn several_error(stations: &[&Probed]) -> anyhow::Error {
    let mut text = format!(
        "{} tape stations answered; give the one to use with --port:",
        stations.len()
    );
    for p in stations {
        text.push_str(&format!(
            "\n  --port {}   ({})",
            connect_path(p).display(),
            p.outcome
        ));
    }
    anyhow::anyhow!(text)
}

/// What the operator sees of a survey without a station, as a key that
/// changes only when the ports or their kind of outcome change (not when a
/// talkative port sent a few more bytes), so the line mode does not repeat
/// itself every second.
fn survey_key(survey: &Survey) -> Vec<(PathBuf, std::mem::Discriminant<Outcome>)> {
    survey
        .ports
        .iter()
        .map(|p| (p.candidate.path.clone(), std::mem::discriminant(&p.outcome)))
        .collect()
}

/// The line mode's search (see the module docs): `found ...` and the path,
/// or `looking` / `seen` lines while none answers, an error naming each
/// `--port` when several answer, `None` after Ctrl-C.
async fn find_line(config: ProbeConfig) -> anyhow::Result<Option<PathBuf>> {
    let lister = SystemPorts::default();
    let ctrl_c = tokio::signal::ctrl_c();
    tokio::pin!(ctrl_c);
    let mut last_key = None;
    loop {
        let survey = probe::survey(&lister, &config).await?;
        match survey.decision() {
            Decision::One(p) => {
                let path = connect_path(p);
                outln!("found {}: {}", path.display(), p.outcome)?;
                return Ok(Some(path));
            }
            Decision::Several(ps) => return Err(several_error(&ps)),
            Decision::None => {
                let key = survey_key(&survey);
                if last_key.as_ref() != Some(&key) {
                    outln!(
                        "looking no tape station answered: plug the tape station's USB cable \
                         into this computer (on the nRF52840-DK: the nRF USB connector, not the \
                         debug one); looking again every second, Ctrl-C leaves"
                    )?;
                    if survey.ports.is_empty() {
                        outln!("seen no serial ports")?;
                    }
                    for p in &survey.ports {
                        outln!("seen {}", probe::describe(p))?;
                    }
                    last_key = Some(key);
                }
            }
        }
        tokio::select! {
            _ = tokio::time::sleep(LOOK_AGAIN) => {}
            r = &mut ctrl_c => {
                r.context("listening for Ctrl-C")?;
                outln!("stopped (Ctrl-C) before a tape station was found")?;
                return Ok(None);
            }
        }
    }
}

/// Raw mode for the kiosk's search screen, left on drop (also on an
/// error), so the terminal is never left raw.
struct RawScreen;

impl RawScreen {
    fn enter() -> anyhow::Result<RawScreen> {
        crossterm::terminal::enable_raw_mode().context("setting up the terminal")?;
        Ok(RawScreen)
    }

    /// Clears the screen and writes `text` from the top (raw mode needs
    /// `\r\n` line ends).
    fn draw(&self, text: &str) -> anyhow::Result<()> {
        use std::io::Write as _;
        let mut out = std::io::stdout().lock();
        crossterm::execute!(
            out,
            crossterm::terminal::Clear(crossterm::terminal::ClearType::All),
            crossterm::cursor::MoveTo(0, 0)
        )?;
        out.write_all(text.replace('\n', "\r\n").as_bytes())?;
        out.flush()?;
        Ok(())
    }
}

impl Drop for RawScreen {
    fn drop(&mut self) {
        let _ = crossterm::terminal::disable_raw_mode();
        let _ = crossterm::execute!(
            std::io::stdout(),
            crossterm::terminal::Clear(crossterm::terminal::ClearType::All),
            crossterm::cursor::MoveTo(0, 0)
        );
    }
}

/// A key the search screen acts on.
enum Key {
    Leave,
    Digit(usize),
    Other,
}

/// Waits up to `wait` for a key press.
fn next_key(wait: Duration) -> anyhow::Result<Option<Key>> {
    use crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
    if !event::poll(wait).context("reading the keyboard")? {
        return Ok(None);
    }
    let Event::Key(k) = event::read().context("reading the keyboard")? else {
        return Ok(Some(Key::Other));
    };
    if k.kind != KeyEventKind::Press {
        return Ok(Some(Key::Other));
    }
    Ok(Some(match k.code {
        KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => Key::Leave,
        KeyCode::Char('q') | KeyCode::Esc => Key::Leave,
        KeyCode::Char(c) => match c.to_digit(10) {
            Some(d) if d > 0 => Key::Digit(d as usize),
            _ => Key::Other,
        },
        _ => Key::Other,
    }))
}

/// The kiosk's search (see the module docs): with exactly one station at
/// the first look, no screen at all; otherwise a small screen that lists
/// what it saw and looks again every second, or asks which station (a
/// digit key). `None` when the operator leaves (q, Esc, Ctrl-C).
fn find_kiosk(config: ProbeConfig) -> anyhow::Result<Option<PathBuf>> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")?;
    let lister = SystemPorts::default();
    let look = || runtime.block_on(probe::survey(&lister, &config));
    let mut survey = look()?;
    if let Decision::One(p) = survey.decision() {
        return Ok(Some(connect_path(p)));
    }
    let screen = RawScreen::enter()?;
    let mut shown = String::new();
    loop {
        let (text, choices) = match survey.decision() {
            Decision::One(p) => return Ok(Some(connect_path(p))),
            Decision::Several(ps) => {
                let mut text = format!(
                    "tapeshape station\n\n{}\n",
                    tr!("search-several", n = ps.len())
                );
                for (i, p) in ps.iter().enumerate().take(9) {
                    text.push_str(&format!(
                        "\n  {}  {}\n     {}\n",
                        i + 1,
                        connect_path(p).display(),
                        p.outcome.words_in(i18n::lang())
                    ));
                }
                text.push_str(&format!("\n{}", tr!("search-press-number")));
                let choices: Vec<PathBuf> = ps.iter().take(9).map(|p| connect_path(p)).collect();
                (text, choices)
            }
            Decision::None => (
                format!(
                    "tapeshape station\n\n{}\n\n{}",
                    survey.nothing_found(),
                    tr!("search-looking-again")
                ),
                Vec::new(),
            ),
        };
        if text != shown {
            screen.draw(&text)?;
            shown = text;
        }
        match next_key(LOOK_AGAIN)? {
            Some(Key::Leave) => return Ok(None),
            Some(Key::Digit(d)) if d <= choices.len() => {
                return Ok(Some(choices[d - 1].clone()));
            }
            // A key that means nothing here: wait for the next one
            // without probing again.
            Some(_) => continue,
            None => {}
        }
        survey = look()?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::link::probe::Candidate;
    use tapeshape_protocol::{DeviceHello, SoftwareVersion, PROTOCOL_VERSION};

    fn answered(path: &str, device_id: u64) -> Probed {
        Probed {
            candidate: Candidate::named(path),
            outcome: Outcome::Answered(DeviceHello {
                protocol: PROTOCOL_VERSION,
                firmware: SoftwareVersion {
                    major: 1,
                    minor: 0,
                    patch: 0,
                },
                device_id,
                boot_id: 3,
                queue_capacity: 32,
            }),
        }
    }

    #[test]
    fn two_stations_in_line_mode_name_the_port_of_each() {
        let survey = Survey {
            ports: vec![
                answered("/nonexistent/ttyACM0", 0xa),
                answered("/nonexistent/ttyACM1", 0xb),
            ],
        };
        let Decision::Several(ps) = survey.decision() else {
            panic!("two stations expected");
        };
        let text = several_error(&ps).to_string();
        assert!(text.starts_with("2 tape stations answered"), "{text}");
        assert!(text.contains("--port /nonexistent/ttyACM0   (tape station 000000000000000a"));
        assert!(text.contains("--port /nonexistent/ttyACM1   (tape station 000000000000000b"));
    }

    #[test]
    fn the_line_mode_repeats_itself_only_when_what_it_sees_changes() {
        let port = |outcome| Survey {
            ports: vec![Probed {
                candidate: Candidate::named("/nonexistent/ttyUSB0"),
                outcome,
            }],
        };
        let talk = |bytes| Outcome::NotTheProtocol {
            bytes,
            bad_frames: 1,
            waited: Duration::from_millis(500),
        };
        // A few more bytes of the same garbage: the same.
        assert_eq!(survey_key(&port(talk(10))), survey_key(&port(talk(12))));
        // Another kind of answer: said again.
        assert_ne!(
            survey_key(&port(talk(10))),
            survey_key(&port(Outcome::Busy))
        );
        assert_ne!(
            survey_key(&port(Outcome::Busy)),
            survey_key(&Survey::default())
        );
    }
}
