//! The terminal loop: owns the terminal, the tape link, the session layer
//! and the services, feeds [`Event`]s to [`update`] and performs the
//! [`Effect`]s.
//!
//! Why a separate runner: everything with I/O lives here, so the app stays
//! testable; and it only performs effects: what a session is and how it
//! changes is the session layer's ([`Sessions`]), the work on readings and
//! bodies the services'. Keys come from a small input thread (crossterm's
//! blocking `poll`/`read`, stopped through a flag), link events from the
//! link's channel, estimate progress from the services' sink, and the
//! demo's simulated operator from its [`Demo`] on the tick. Session changes
//! are short (a few milliseconds with the fsync) and run inline; checks,
//! estimates, exports and keyboard captures run on blocking threads.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use crossterm::event::{self as ct, KeyEventKind};
use tokio::sync::mpsc;

use crate::i18n::tr;
use crate::link::{Link, LinkConfig, LinkHandle, Naming};
use crate::services::{Cancel, EstimateEvent, EstimateRequest, SharedServices};
use crate::session::Sessions;
use crate::tui::app::{update, App, AppConfig, Effect, Event};

/// How the runner starts.
pub struct RunOptions {
    /// The session layer (and its store).
    pub sessions: Sessions,
    /// The tape's port (the firmware's host port in the demo).
    pub port: PathBuf,
    /// What to show as the port.
    pub port_label: String,
    /// Baud rate.
    pub baud: u32,
    /// Monochrome.
    pub mono: bool,
    /// Folder that exports go to.
    pub export_dir: PathBuf,
    /// Folder of the log file (`tapeshape.log`) while the screen is up.
    pub log_dir: PathBuf,
    /// Set preselected for new customers.
    pub default_set: String,
    /// What the new-customer form offers: each measurement twice (careful
    /// mode); the operator changes it per customer.
    pub careful: bool,
    /// The demo's simulated tape and keyboard (`tapeshape demo`; the kiosk
    /// has none).
    pub demo: Option<Box<dyn Demo>>,
}

/// The demo's simulated tape and keyboard, as the runner sees them.
///
/// Why a trait: the simulated tape needs the simulator (`tapeshape-sim`),
/// which the kiosk build leaves out (the `demo` feature); through this
/// trait the runner is the same code in both builds. The demo's
/// implementation is `tui::operator::SimDemo`.
pub trait Demo: Send {
    /// A key a person pressed, as the app should hear it (the first one
    /// takes over from the simulated operator).
    fn person_key(&mut self, key: ct::KeyEvent) -> Event;
    /// The simulated operator's keys for this tick.
    fn tick(&mut self, app: &App, now: Instant) -> Vec<Event>;
    /// Has the simulated tape measure `name` (`slip`: read off the wrong
    /// scale); the error is operator text.
    fn measure(&self, name: &str, slip: bool) -> Result<(), String>;
}

/// Runs the interface in the current terminal until the operator quits.
/// Must run inside a tokio runtime.
pub async fn run(options: RunOptions, services: SharedServices) -> anyhow::Result<()> {
    let mut terminal = ratatui::try_init().with_context(|| tr!("run-terminal-failed"))?;
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
        sessions,
        port,
        port_label,
        baud,
        mono,
        export_dir,
        log_dir: _,
        default_set,
        careful,
        demo,
    } = options;
    let (tx, mut rx) = mpsc::unbounded_channel::<Event>();

    let stop_input = Arc::new(AtomicBool::new(false));
    let input = spawn_input(tx.clone(), stop_input.clone())?;

    let config = LinkConfig {
        baud_rate: baud,
        ..LinkConfig::default()
    };
    let (link, mut link_events, link_task) = Link::spawn(&port, config, sessions.clone());
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
    // The measuring screen's pictograms of the default set are made while
    // the operator fills in the form (loading the body template takes about
    // half a second once), not in the first measuring frame (which makes
    // them itself if no thread could be started).
    let warm = default_set.clone();
    let _ = std::thread::Builder::new()
        .name("pictograms".into())
        .spawn(move || drop(crate::tui::screens::measuring::pictogram::for_set(&warm)));
    let mut app = App::new(AppConfig {
        port: port_label,
        demo: demo.is_some(),
        mono,
        id_seed,
        default_set,
    });
    app.form = app.form.with_careful_default(careful);
    let mut ctx = Ctx {
        sessions,
        link,
        tx: tx.clone(),
        services,
        export_dir,
        cancel: None,
        live: None,
        demo,
    };
    for fx in app.start() {
        ctx.perform(fx);
    }
    if let Some(offer) = ctx.sessions.resume_offer()? {
        let _ = tx.send(Event::Resumable(offer));
    }

    let mut tick = tokio::time::interval(Duration::from_millis(100));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    terminal.draw(|f| crate::tui::draw(&app, f))?;
    loop {
        let ev = tokio::select! {
            ev = rx.recv() => match ev { Some(ev) => ev, None => break },
            _ = tick.tick() => Event::Tick,
        };
        let mut events = Vec::new();
        match (ev, ctx.demo.as_mut()) {
            // In the demo a person's key goes through the autopilot (the
            // first one takes over).
            (Event::Key(k), Some(pilot)) => events.push(pilot.person_key(k)),
            (Event::Tick, Some(pilot)) => {
                events.push(Event::Tick);
                events.extend(pilot.tick(&app, Instant::now()));
            }
            (ev, _) => events.push(ev),
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
                            let _ = tx.send(Event::Failed(tr!(
                                "run-keyboard-failed",
                                error = e.to_string()
                            )));
                            break;
                        }
                    },
                    Ok(false) => {}
                    Err(e) => {
                        let _ = tx.send(Event::Failed(tr!(
                            "run-keyboard-failed",
                            error = e.to_string()
                        )));
                        break;
                    }
                }
            }
        })
        .with_context(|| tr!("run-keyboard-thread-failed"))
}

struct Ctx {
    sessions: Sessions,
    link: LinkHandle,
    tx: mpsc::UnboundedSender<Event>,
    services: SharedServices,
    export_dir: PathBuf,
    cancel: Option<Box<dyn Cancel>>,
    live: Option<LiveJob>,
    demo: Option<Box<dyn Demo>>,
}

/// The live estimate running in the background (`tui::screens::measuring::live`).
struct LiveJob {
    request: EstimateRequest,
    cancel: Box<dyn Cancel>,
    /// `adopted`: its events are also the estimate's (an `e` while it ran;
    /// its cancel handle then moves to `Ctx::cancel`); `finished`: it has
    /// sent its last event. One lock, so that adopting and finishing cannot
    /// cross (a job that finished first is not adopted: a new estimate
    /// starts).
    state: Arc<Mutex<LiveFlags>>,
}

#[derive(Default)]
struct LiveFlags {
    adopted: bool,
    finished: bool,
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
                consent,
                careful,
            } => {
                let r = self.sessions.start_new(
                    &customer,
                    &set,
                    notes.as_deref(),
                    crate::session::NewSession {
                        consent: Some(consent),
                        careful,
                    },
                );
                self.send(match r {
                    Ok(v) => Event::SessionReady(v),
                    Err(e) => Event::Failed(e.to_string()),
                });
            }
            Effect::OpenSession(id) | Effect::ViewSession(id) => {
                let r = if matches!(fx, Effect::ViewSession(_)) {
                    self.sessions.open_for_viewing(id)
                } else {
                    self.sessions.open_for_measuring(id)
                };
                self.send(match r {
                    Ok(v) => Event::SessionReady(v),
                    Err(e) => Event::Failed(tr!(
                        "run-open-failed",
                        id = id.to_string(),
                        error = e.to_string()
                    )),
                });
            }
            Effect::CaptureLive {
                session,
                name,
                value_tenth_mm,
                unit_shown,
            } => {
                let sessions = self.sessions.clone();
                let tx = self.tx.clone();
                tokio::task::spawn_blocking(move || {
                    let ev = match sessions.capture_keyboard(session, &name, value_tenth_mm) {
                        Ok(reading) => Event::ReadingStored {
                            reading,
                            unit_shown,
                        },
                        Err(e) => Event::Failed(tr!("run-capture-failed", error = e.to_string())),
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
            Effect::StartEstimate(request) => {
                if let Some(c) = self.cancel.take() {
                    c.cancel();
                }
                // The live estimate of these readings is running: it becomes
                // the estimate (nothing is computed twice).
                if let Some(live) = self.live.take() {
                    let adopted = live.request == request && {
                        let mut flags = live.state.lock().unwrap_or_else(|e| e.into_inner());
                        flags.adopted = !flags.finished;
                        flags.adopted
                    };
                    if adopted {
                        self.cancel = Some(live.cancel);
                        return;
                    }
                    live.cancel.cancel();
                }
                let tx = self.tx.clone();
                let sink = Box::new(move |ev| {
                    let _ = tx.send(Event::Estimate(ev));
                });
                self.cancel = Some(self.services.start_estimate(request, sink));
            }
            Effect::CancelEstimate => {
                if let Some(c) = self.cancel.take() {
                    c.cancel();
                }
            }
            Effect::LiveEstimate {
                generation,
                request,
            } => {
                if let Some(old) = self.live.take() {
                    old.cancel.cancel();
                }
                let tx = self.tx.clone();
                let state = Arc::new(Mutex::new(LiveFlags::default()));
                let flags = state.clone();
                let sink = Box::new(move |ev: EstimateEvent| {
                    let mut f = flags.lock().unwrap_or_else(|e| e.into_inner());
                    if matches!(
                        ev,
                        EstimateEvent::Done(_)
                            | EstimateEvent::Failed(_)
                            | EstimateEvent::Cancelled
                    ) {
                        f.finished = true;
                    }
                    let _ = tx.send(Event::Live {
                        generation,
                        event: ev.clone(),
                    });
                    if f.adopted {
                        let _ = tx.send(Event::Estimate(ev));
                    }
                });
                let cancel = self.services.start_estimate(request.clone(), sink);
                self.live = Some(LiveJob {
                    request,
                    cancel,
                    state,
                });
            }
            Effect::CancelLive => {
                if let Some(live) = self.live.take() {
                    live.cancel.cancel();
                }
            }
            Effect::Export { session, format } => {
                let services = self.services.clone();
                let tx = self.tx.clone();
                let folder = self.export_dir.clone();
                tokio::task::spawn_blocking(move || {
                    let r = services
                        .export(session, format, &folder)
                        .map_err(|e| e.to_string());
                    let _ = tx.send(Event::Exported(r));
                });
            }
            Effect::Card { session, unit } => {
                let services = self.services.clone();
                let tx = self.tx.clone();
                let folder = self.export_dir.clone();
                tokio::task::spawn_blocking(move || {
                    let r = services
                        .card(session, unit, &folder)
                        .map_err(|e| e.to_string());
                    let _ = tx.send(Event::CardWritten(r));
                });
            }
            Effect::LoadResult(session) => {
                let services = self.services.clone();
                let tx = self.tx.clone();
                tokio::task::spawn_blocking(move || {
                    let r = match services.stored_result(session) {
                        Ok(Some(summary)) => Ok(summary),
                        Ok(None) => {
                            Err(tr!("run-no-stored-estimate", session = session.to_string()))
                        }
                        Err(e) => Err(e.to_string()),
                    };
                    let _ = tx.send(Event::ResultLoaded(r));
                });
            }
            Effect::WithdrawReading(id) => {
                if let Err(e) = self.sessions.withdraw(id) {
                    self.send(Event::Failed(tr!(
                        "run-withdraw-failed",
                        id = id.to_string(),
                        error = e.to_string()
                    )));
                }
            }
            Effect::SetMark {
                session,
                name,
                mark,
            } => {
                if let Err(e) = self.sessions.set_mark(session, &name, mark) {
                    self.send(Event::Failed(tr!(
                        "run-mark-failed",
                        name = name.as_str(),
                        error = e.to_string()
                    )));
                }
            }
            Effect::SetStatus(id, status) => {
                if let Err(e) = self.sessions.set_status(id, status) {
                    self.send(Event::Failed(tr!(
                        "run-status-failed",
                        id = id.to_string(),
                        status = status.to_string(),
                        error = e.to_string()
                    )));
                }
            }
            Effect::LoadHistory => match self.sessions.store().list_sessions() {
                Ok(list) => self.send(Event::History(list)),
                Err(e) => self.send(Event::Failed(tr!("run-list-failed", error = e.to_string()))),
            },
            Effect::DeleteSession(id) => {
                if let Err(e) = self.sessions.delete(id) {
                    self.send(Event::Failed(tr!(
                        "run-delete-failed",
                        id = id.to_string(),
                        error = e.to_string()
                    )));
                }
                self.perform(Effect::LoadHistory);
            }
            Effect::SimTape { name, slip } => match &self.demo {
                Some(d) => {
                    if let Err(e) = d.measure(&name, slip) {
                        self.send(Event::Failed(e));
                    }
                }
                None => self.send(Event::Failed(tr!("run-no-sim-tape"))),
            },
            Effect::Quit => {}
        }
    }
}

/// Runs [`run`] on `runtime` with stderr (where the logs go) sent to
/// `options.log_dir/tapeshape.log` meanwhile, so a log line cannot scribble
/// over the screen; tells on stderr afterwards if anything was logged.
pub fn run_with_log(
    options: RunOptions,
    services: SharedServices,
    runtime: &tokio::runtime::Runtime,
) -> anyhow::Result<()> {
    use std::os::fd::AsFd as _;
    let log_path = options.log_dir.join("tapeshape.log");
    let log = {
        use std::os::unix::fs::OpenOptionsExt as _;
        std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            // Owner-only: a log line may name a customer's session.
            .mode(0o600)
            .open(&log_path)
    }
    .with_context(|| tr!("run-log-open-failed", path = log_path.display().to_string()))?;
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
        eprintln!(
            "{}",
            tr!("run-log-written", path = log_path.display().to_string())
        );
    }
    match result {
        Ok(r) => r,
        Err(_) => anyhow::bail!(
            "{}",
            tr!("run-internal-error", path = log_path.display().to_string())
        ),
    }
}
