//! The terminal loop: owns the terminal, the tape link, the store and the
//! services, feeds [`Event`]s to [`update`] and performs the [`Effect`]s.
//!
//! Why a separate runner: everything with I/O lives here, so the app stays
//! testable. Keys come from a small input thread (crossterm's blocking
//! `poll`/`read`, stopped through a flag), link events from the link's
//! channel, estimate progress from the services' sink, and the demo's
//! simulated operator from [`crate::tui::operator`] on the tick. Store
//! operations are short (a few milliseconds with the fsync) and run inline;
//! checks, estimates and exports run on blocking threads.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use crossterm::event::{self as ct, KeyEventKind};
use tokio::sync::mpsc;

use crate::link::{Link, LinkConfig, LinkEvent, LinkHandle, Naming};
use crate::services::{Cancel, SharedServices};
use crate::store::{CommitOutcome, DeviceReading, SessionId, SessionStatus, Store, FIRST_SEQ};
use crate::tui::app::{
    update, App, Autopilot, Effect, Event, MeasurementInfo, ResumeOffer, SessionView,
};
use crate::tui::operator::{SimOperator, SimTape};

/// Device id under which a value captured with Enter (the tape's live value,
/// not held on the tape) is stored. Such readings do not come through the
/// tape's numbered queue, so they get their own sequence (boot 0) in the
/// store's bookkeeping; no real tape has id 0 (ids are random 64-bit values).
pub const KEYBOARD_CAPTURE_DEVICE_ID: u64 = 0;

/// How the runner starts.
pub struct RunOptions {
    /// The store.
    pub store: Store,
    /// The tape's port (the firmware's host port in the demo).
    pub port: PathBuf,
    /// What to show as the port.
    pub port_label: String,
    /// Baud rate.
    pub baud: u32,
    /// Monochrome.
    pub mono: bool,
    /// Folder that exports go to (one sub-folder per session).
    pub export_dir: PathBuf,
    /// Set preselected for new customers.
    pub default_set: String,
    /// The demo's simulated tape and operator.
    pub demo: Option<(SimTape, SimOperator)>,
}

/// Runs the interface in the current terminal until the operator quits.
/// Must run inside a tokio runtime.
pub async fn run(options: RunOptions, services: SharedServices) -> anyhow::Result<()> {
    let mut terminal = ratatui::try_init().context("setting up the terminal")?;
    let result = run_in(&mut terminal, options, services).await;
    ratatui::restore();
    result
}

async fn run_in(
    terminal: &mut ratatui::DefaultTerminal,
    options: RunOptions,
    services: SharedServices,
) -> anyhow::Result<()> {
    let RunOptions {
        store,
        port,
        port_label,
        baud,
        mono,
        export_dir,
        default_set,
        demo,
    } = options;
    let (tx, mut rx) = mpsc::unbounded_channel::<Event>();

    let stop_input = Arc::new(AtomicBool::new(false));
    let input = spawn_input(tx.clone(), stop_input.clone())?;

    let config = LinkConfig {
        baud_rate: baud,
        ..LinkConfig::default()
    };
    let (link, mut link_events, link_task) = Link::spawn(&port, config, store.clone());
    let link_tx = tx.clone();
    let forward = tokio::spawn(async move {
        while let Some(ev) = link_events.recv().await {
            if link_tx.send(Event::Link(ev)).is_err() {
                break;
            }
        }
    });

    let id_seed = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(1);
    let (sim_tape, mut operator) = match demo {
        Some((t, o)) => (Some(t), Some(o)),
        None => (None, None),
    };
    let mut app = App::new(crate::tui::app::AppConfig {
        port: port_label,
        demo: sim_tape.is_some(),
        mono,
        id_seed,
        default_set,
    });
    let mut ctx = Ctx {
        store,
        link,
        tx: tx.clone(),
        services,
        export_dir,
        cancel: None,
        sim_tape,
    };
    for fx in app.start() {
        ctx.perform(fx);
    }
    if let Some(s) = ctx.store.latest_unfinished_session()? {
        let readings = ctx
            .store
            .open_session(s.id)
            .map(|d| d.current_readings().count() as u64)
            .unwrap_or(0);
        let _ = tx.send(Event::Resumable(ResumeOffer {
            session: s.id,
            customer: s.customer_id,
            set: s.measurement_set,
            readings,
        }));
    }

    let mut tick = tokio::time::interval(Duration::from_millis(100));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    terminal.draw(|f| crate::tui::draw(&app, f))?;
    loop {
        let ev = tokio::select! {
            ev = rx.recv() => match ev { Some(ev) => ev, None => break },
            _ = tick.tick() => Event::Tick,
        };
        let mut events = vec![ev];
        if matches!(events[0], Event::Tick) && app.autopilot == Autopilot::Driving {
            if let Some(op) = operator.as_mut() {
                events.extend(op.next(&app, Instant::now()));
            }
        }
        for ev in events {
            for fx in update(&mut app, ev) {
                ctx.perform(fx);
            }
        }
        if app.quit {
            break;
        }
        terminal.draw(|f| crate::tui::draw(&app, f))?;
    }
    stop_input.store(true, Ordering::SeqCst);
    if let Some(c) = ctx.cancel.take() {
        c.cancel();
    }
    ctx.link.shutdown();
    let _ = tokio::time::timeout(Duration::from_secs(2), link_task).await;
    forward.abort();
    let _ = input.join();
    Ok(())
}

/// Reads keys on a thread of its own (crossterm's reader blocks) until
/// `stop` is set.
fn spawn_input(
    tx: mpsc::UnboundedSender<Event>,
    stop: Arc<AtomicBool>,
) -> anyhow::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("tui-input".into())
        .spawn(move || {
            while !stop.load(Ordering::SeqCst) {
                match ct::poll(Duration::from_millis(100)) {
                    Ok(true) => match ct::read() {
                        Ok(ct::Event::Key(k)) if k.kind != KeyEventKind::Release => {
                            if tx.send(Event::Key(k)).is_err() {
                                break;
                            }
                        }
                        Ok(ct::Event::Resize(..)) => {
                            let _ = tx.send(Event::Tick);
                        }
                        Ok(_) => {}
                        Err(e) => {
                            let _ = tx.send(Event::Failed(format!("reading the keyboard: {e}")));
                            break;
                        }
                    },
                    Ok(false) => {}
                    Err(e) => {
                        let _ = tx.send(Event::Failed(format!("reading the keyboard: {e}")));
                        break;
                    }
                }
            }
        })
        .context("starting the keyboard thread")
}

struct Ctx {
    store: Store,
    link: LinkHandle,
    tx: mpsc::UnboundedSender<Event>,
    services: SharedServices,
    export_dir: PathBuf,
    cancel: Option<Box<dyn Cancel>>,
    sim_tape: Option<SimTape>,
}

impl Ctx {
    fn send(&self, ev: Event) {
        let _ = self.tx.send(ev);
    }

    fn perform(&mut self, fx: Effect) {
        match fx {
            Effect::SetLinkSession(s) => self.link.set_session(s),
            Effect::SetNaming(n) => self.link.set_naming(match n {
                Some(name) => Naming::Current(name),
                None => Naming::None,
            }),
            Effect::CreateSession {
                customer,
                set,
                notes,
            } => {
                let r = create_session(&self.store, &customer, &set, notes.as_deref());
                self.send(match r {
                    Ok(v) => Event::SessionReady(v),
                    Err(e) => Event::Failed(format!("{e:#}")),
                });
            }
            Effect::OpenSession(id) => {
                let r = open_session(&self.store, id);
                self.send(match r {
                    Ok(v) => Event::SessionReady(v),
                    Err(e) => Event::Failed(format!("{e:#}")),
                });
            }
            Effect::CaptureLive {
                session,
                name,
                value_tenth_mm,
                unit_shown,
            } => {
                let store = self.store.clone();
                let tx = self.tx.clone();
                tokio::task::spawn_blocking(move || {
                    let ev = match capture_live(&store, session, &name, value_tenth_mm) {
                        Ok(reading) => Event::Link(LinkEvent::ReadingCommitted {
                            reading,
                            unit_shown,
                        }),
                        Err(e) => Event::Failed(format!("storing the captured value: {e:#}")),
                    };
                    let _ = tx.send(ev);
                });
            }
            Effect::Check(req) => {
                let services = self.services.clone();
                let tx = self.tx.clone();
                tokio::task::spawn_blocking(move || {
                    let outcome = services.check(&req);
                    let _ = tx.send(Event::Checked {
                        name: req.name.clone(),
                        value_tenth_mm: (req.value_mm * 10.0).round() as u32,
                        outcome,
                    });
                });
            }
            Effect::StartEstimate(job) => {
                if let Some(c) = self.cancel.take() {
                    c.cancel();
                }
                let tx = self.tx.clone();
                let sink = Box::new(move |ev| {
                    let _ = tx.send(Event::Estimate(ev));
                });
                self.cancel = Some(self.services.start_estimate(job, sink));
            }
            Effect::CancelEstimate => {
                if let Some(c) = self.cancel.take() {
                    c.cancel();
                }
            }
            Effect::Export { session, format } => {
                let services = self.services.clone();
                let tx = self.tx.clone();
                let folder = self.export_dir.clone();
                let store = self.store.clone();
                tokio::task::spawn_blocking(move || {
                    let r = store
                        .session(session)
                        .map_err(|e| e.to_string())
                        .and_then(|s| services.export(&s, format, &folder));
                    let _ = tx.send(Event::Exported(r));
                });
            }
            Effect::WithdrawReading(id) => {
                if let Err(e) = self.store.withdraw_reading(id) {
                    self.send(Event::Failed(format!("withdrawing reading {id}: {e}")));
                }
            }
            Effect::SetMark {
                session,
                name,
                mark,
            } => {
                if let Err(e) = self.store.set_mark(session, &name, mark) {
                    self.send(Event::Failed(format!("storing the mark on {name}: {e}")));
                }
            }
            Effect::SetStatus(id, status) => {
                if let Err(e) = self.store.set_status(id, status) {
                    self.send(Event::Failed(format!("marking session {id} {status}: {e}")));
                }
            }
            Effect::LoadHistory => match self.store.list_sessions() {
                Ok(list) => self.send(Event::History(list)),
                Err(e) => self.send(Event::Failed(format!("reading the sessions: {e}"))),
            },
            Effect::DeleteSession(id) => {
                if let Err(e) = self.store.delete_session(id) {
                    self.send(Event::Failed(format!("deleting session {id}: {e}")));
                }
                self.perform(Effect::LoadHistory);
            }
            Effect::SimTape { name, slip } => match &self.sim_tape {
                Some(t) => {
                    if let Err(e) = t.measure(&name, slip) {
                        self.send(Event::Failed(e));
                    }
                }
                None => self.send(Event::Failed("no simulated tape outside the demo".into())),
            },
            Effect::Quit => {}
        }
    }
}

fn notes_of(notes: Option<&str>) -> Option<String> {
    notes.map(str::to_string)
}

fn load_set(set: &str) -> anyhow::Result<Vec<MeasurementInfo>> {
    let set = tapeshape_measure::MeasurementSet::load(set)
        .with_context(|| format!("loading the measurement set {set:?}"))?;
    Ok(set
        .definitions
        .into_iter()
        .map(|d| MeasurementInfo {
            name: d.name,
            label: d.label,
            description: d.description,
        })
        .collect())
}

/// Creates a session for `customer` following `set` (checked first) and
/// returns it as the app sees it.
pub fn create_session(
    store: &Store,
    customer: &str,
    set: &str,
    notes: Option<&str>,
) -> anyhow::Result<SessionView> {
    let measurements = load_set(set)?;
    let s = store.create_session(customer, Some(set))?;
    if notes.is_some() {
        store.set_notes(s.id, notes)?;
    }
    Ok(SessionView {
        id: s.id,
        customer: s.customer_id,
        set: set.to_string(),
        notes: notes_of(notes),
        measurements,
        readings: Vec::new(),
        superseded: Vec::new(),
        marks: Vec::new(),
    })
}

/// Loads session `id` with its readings, reopening it if it was closed
/// (so readings can be added again).
pub fn open_session(store: &Store, id: SessionId) -> anyhow::Result<SessionView> {
    let detail = store.open_session(id)?;
    if detail.session.status != SessionStatus::Open {
        store.set_status(id, SessionStatus::Open)?;
    }
    let set = detail
        .session
        .measurement_set
        .clone()
        .unwrap_or_else(|| "quick".to_string());
    let mut measurements = load_set(&set)?;
    // Readings under names the set does not have (a numbered session, an
    // edited set file) still show, after the set's own.
    for r in detail.current_readings() {
        if !measurements.iter().any(|m| m.name == r.measurement) {
            measurements.push(MeasurementInfo {
                name: r.measurement.clone(),
                label: r.measurement.clone(),
                description: "A reading stored under a name this set does not have.".into(),
            });
        }
    }
    Ok(SessionView {
        id,
        customer: detail.session.customer_id.clone(),
        set,
        notes: detail.session.notes.clone(),
        measurements,
        readings: detail
            .current_readings()
            .map(|r| (r.measurement.clone(), r.device.value_tenth_mm))
            .collect(),
        superseded: detail
            .readings
            .iter()
            .filter(|r| r.superseded_by.is_some())
            .map(|r| (r.measurement.clone(), r.device.value_tenth_mm))
            .collect(),
        marks: store.marks(id)?,
    })
}

/// Stores a value captured with Enter (see [`KEYBOARD_CAPTURE_DEVICE_ID`]).
pub fn capture_live(
    store: &Store,
    session: SessionId,
    name: &str,
    value_tenth_mm: u32,
) -> anyhow::Result<crate::store::StoredReading> {
    // Two tries: another station process may have taken the number.
    for _ in 0..2 {
        let seq = match store.last_committed_seq(KEYBOARD_CAPTURE_DEVICE_ID, 0)? {
            Some(s) => s + 1,
            None => FIRST_SEQ,
        };
        let device_time_ms = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.as_millis() as u64)
            .unwrap_or(0);
        let reading = DeviceReading {
            device_id: KEYBOARD_CAPTURE_DEVICE_ID,
            boot_id: 0,
            seq,
            value_tenth_mm,
            device_time_ms,
        };
        match store.commit_reading(session, name, &reading)? {
            CommitOutcome::Committed(r) => return Ok(r),
            CommitOutcome::Duplicate { .. } | CommitOutcome::Gap { .. } => continue,
        }
    }
    anyhow::bail!(
        "the store's keyboard capture numbering changed twice meanwhile; press Enter again"
    )
}

/// Runs [`run`] on `runtime` with stderr (where the logs go) sent to
/// `DATA_DIR/tapeshape.log` meanwhile, so a log line cannot scribble over
/// the screen; tells on stderr afterwards if anything was logged.
pub fn run_with_log(
    options: RunOptions,
    services: SharedServices,
    runtime: &tokio::runtime::Runtime,
    global: &crate::cli::Global,
) -> anyhow::Result<()> {
    use std::os::fd::AsFd as _;
    let dir = crate::store::resolve_data_dir(global.data_dir.as_deref())?;
    let log_path = dir.join("tapeshape.log");
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .with_context(|| format!("opening the log file {}", log_path.display()))?;
    let before = log.metadata().map(|m| m.len()).unwrap_or(0);
    let saved = rustix::io::dup(std::io::stderr().as_fd()).context("saving stderr")?;
    rustix::stdio::dup2_stderr(log.as_fd()).context("sending stderr to the log file")?;
    // A panic is caught here so stderr comes back and the operator is told
    // where its message went (ratatui's hook has restored the terminal);
    // every reading taken is already in the store.
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        runtime.block_on(run(options, services))
    }));
    let restored = rustix::stdio::dup2_stderr(saved.as_fd());
    drop(saved);
    restored.context("restoring stderr")?;
    let after = std::fs::metadata(&log_path).map(|m| m.len()).unwrap_or(0);
    if after > before {
        eprintln!("log messages of this run: {}", log_path.display());
    }
    match result {
        Ok(r) => r,
        Err(_) => anyhow::bail!(
            "the interface stopped on an internal error (details in {}); every reading \
             taken is stored: start again and resume the session",
            log_path.display()
        ),
    }
}
