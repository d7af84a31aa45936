//! The interface's state and its one state transition, [`update`]: the
//! router over the screens.
//!
//! Why this shape (the Elm architecture that well-kept ratatui apps use):
//! [`App`] is plain data with no I/O; [`update`] takes one [`Event`] (a key,
//! a link event, estimate progress, a tick) and returns the [`Effect`]s the
//! runner must perform (set the link's naming, create a session, start an
//! estimate, export ...). Results of effects come back as events. So tests
//! drive the whole operator flow without a terminal, a tape or an estimator.
//!
//! This file keeps what is not one screen's: the keys that work anywhere
//! (help, device, history, quit), routing a key to the screen shown, the
//! events that are not keys, and the link's naming. Each screen
//! (`tui/screens/<screen>.rs`) owns its state, its keys and their words
//! (footer and help come from the same list the key handler uses) and its
//! drawing. The demo's simulated operator is not here: it is an event source
//! of its own (`tui::operator::Autopilot`, [`crate::tui::runner::Demo`]) that only tells the app
//! when a person takes over ([`Event::TakenOver`]).
//!
//! Readings are never held here: every reading is committed to the store
//! (by the link, or by the session layer for a keyboard capture) **before**
//! the app hears of it, so the app only reflects what is stored (plus the
//! operator's marks: skipped, flagged, undone).

use std::path::PathBuf;

use crossterm::event::{KeyCode, KeyEvent, KeyEventKind};
use tapeshape_estimator::Unit;
use tapeshape_protocol::UnitShown;

use crate::estimate::MeshFormat;
use crate::i18n::{msg, tr};
use crate::link::LinkEvent;
use crate::services::{
    CheckOutcome, CheckRequest, EstimateEvent, EstimateRequest, EstimateSummary,
};
use crate::store::{Mark, ReadingId, SessionId, SessionStatus, SessionSummary, StoredReading};
use crate::tui::keys::{ch, lookup, Binding, Hint, Key};
use crate::tui::screens::measuring::live;
use crate::tui::screens::{device, estimating, history, measuring, new_customer, result};

pub use crate::session::{EstimateInfo, MeasurementInfo, ResumeOffer, SessionView};
pub use crate::tui::screens::device::{Connection, DeviceState, FAULTS_KEPT};
pub use crate::tui::screens::estimating::EstimateState;
pub use crate::tui::screens::history::HistoryState;
pub use crate::tui::screens::measuring::live::LiveEstimate;
pub use crate::tui::screens::measuring::{Item, ItemState, SessionState, StoreRevert, UndoEntry};
pub use crate::tui::screens::new_customer::{
    customer_id, CustomerForm, FormField, BUILTIN_SET_CHOICES,
};
pub use crate::tui::screens::result::ResultScreen;

/// The screens.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Screen {
    /// Connection, device id, versions, faults.
    Device,
    /// New customer form (and the offer to resume an unfinished session).
    NewCustomer,
    /// Taking the measurements.
    Measuring,
    /// Estimate running (or refused).
    Estimating,
    /// Silhouettes, table, plausibility, export.
    Result,
    /// Past sessions.
    History,
}

impl Screen {
    /// Title shown in the top bar (the chosen language).
    pub fn title(self) -> String {
        match self {
            Screen::Device => tr!("screen-device"),
            Screen::NewCustomer => tr!("screen-new-customer"),
            Screen::Measuring => tr!("screen-measuring"),
            Screen::Estimating => tr!("screen-estimating"),
            Screen::Result => tr!("screen-result"),
            Screen::History => tr!("screen-history"),
        }
    }
}

/// Who is at the keys in the demo (shown in the top bar).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pilot {
    /// The simulated operator; a person's first key takes over.
    Simulated,
    /// A person took over.
    Person,
}

/// How important a notice is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Information.
    Info,
    /// Needs the operator's attention.
    Warn,
    /// Something failed.
    Error,
}

/// What to do once a session opened from history (or resumed) is loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AfterOpen {
    /// Continue measuring.
    Measure,
    /// Estimate it.
    Estimate,
    /// Export it: its stored estimate if that is of its current readings,
    /// else a new one.
    Export,
    /// Show its stored estimate.
    ShowResult,
}

/// A length unit shown the way the interface shows lengths.
pub trait ShowLength {
    /// `value_tenth_mm` in this unit with its symbol (`98.2 cm`, `38.66 in`).
    fn format(self, value_tenth_mm: u32) -> String;
    /// A length in millimetres in this unit with its symbol.
    fn format_mm(self, mm: f64) -> String;
}

impl ShowLength for Unit {
    fn format(self, value_tenth_mm: u32) -> String {
        self.format_mm(f64::from(value_tenth_mm) / 10.0)
    }

    fn format_mm(self, mm: f64) -> String {
        crate::text::format_length_mm(self, mm)
    }
}

/// The unit the interface shows after `u` is toggled: centimetres and
/// inches, what a tape shows.
pub fn toggled(unit: Unit) -> Unit {
    match unit {
        Unit::In => Unit::Cm,
        _ => Unit::In,
    }
}

/// Everything the interface shows. Plain data; see the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct App {
    /// Screen shown.
    pub screen: Screen,
    /// Screen to go back to from Device/History.
    pub back_to: Screen,
    /// Monochrome drawing.
    pub mono: bool,
    /// The demo (simulated tape; `m`/`M` keys): who is at the keys. `None`
    /// at a real station.
    pub demo: Option<Pilot>,
    /// Help overlay shown.
    pub help: bool,
    /// The tape (device screen).
    pub device: DeviceState,
    /// New customer screen (form, resume offer).
    pub form: CustomerForm,
    /// Session being measured (measuring screen).
    pub session: Option<SessionState>,
    /// Estimate progress (estimating screen).
    pub estimate: EstimateState,
    /// The live estimate of the readings so far (measuring screen).
    pub live: LiveEstimate,
    /// Result screen.
    pub result: ResultScreen,
    /// History screen.
    pub history: HistoryState,
    /// Unit values are shown in (the store always keeps tenths of a mm).
    pub unit: Unit,
    /// One-line notice.
    pub notice: Option<(Level, String)>,
    /// What to do after a session from history loads.
    pub after_open: Option<AfterOpen>,
    /// `q` was pressed once: a second `q` quits.
    pub quit_armed: bool,
    /// The runner should stop.
    pub quit: bool,
    link: LinkSync,
}

/// What the link was last told, so that it is told again only on a change.
#[derive(Clone, Debug, Default, PartialEq)]
struct LinkSync {
    naming: Option<Option<String>>,
    session: Option<Option<SessionId>>,
}

/// How the app starts.
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// Port path or a description of the simulated tape.
    pub port: String,
    /// Demo mode (the simulated operator starts at the keys).
    pub demo: bool,
    /// Monochrome.
    pub mono: bool,
    /// Seed of generated customer ids (the runner uses the clock).
    pub id_seed: u64,
    /// Set preselected on the form.
    pub default_set: String,
}

/// Inputs to [`update`].
#[derive(Clone, Debug)]
pub enum Event {
    /// A key pressed (by a person, or by the demo's simulated operator while
    /// it has the keys).
    Key(KeyEvent),
    /// A person took the keys from the demo's simulated operator.
    TakenOver,
    /// Something the tape link reported.
    Link(LinkEvent),
    /// A reading typed with the keyboard was stored (result of
    /// [`Effect::CaptureLive`]).
    ReadingStored {
        /// The stored reading.
        reading: StoredReading,
        /// The unit the tape showed.
        unit_shown: UnitShown,
    },
    /// Estimate progress.
    Estimate(EstimateEvent),
    /// Progress of live estimate number `generation` (result of
    /// [`Effect::LiveEstimate`]).
    Live {
        /// Which request it answers.
        generation: u64,
        /// What happened.
        event: EstimateEvent,
    },
    /// Result of [`Effect::Check`].
    Checked {
        /// Measurement checked.
        name: String,
        /// Its value, tenths of a mm.
        value_tenth_mm: u32,
        /// What the check found.
        outcome: CheckOutcome,
    },
    /// The store holds an unfinished session (at start).
    Resumable(ResumeOffer),
    /// A session was created or opened (result of [`Effect::CreateSession`],
    /// [`Effect::OpenSession`] or [`Effect::ViewSession`]).
    SessionReady(SessionView),
    /// A stored estimate (result of [`Effect::LoadResult`]).
    ResultLoaded(Result<EstimateSummary, String>),
    /// The history list (result of [`Effect::LoadHistory`]).
    History(Vec<SessionSummary>),
    /// Result of [`Effect::Export`].
    Exported(Result<Vec<PathBuf>, String>),
    /// Result of [`Effect::Card`]: the file written, or why not.
    CardWritten(Result<PathBuf, String>),
    /// An effect failed: the message says what and what to do.
    Failed(String),
    /// Time passes (the runner's tick).
    Tick,
}

/// Work for the runner.
#[derive(Clone, Debug, PartialEq)]
pub enum Effect {
    /// Point the link's readings at this session (or none: held by the tape).
    SetLinkSession(Option<SessionId>),
    /// Name the next readings after this measurement (or none: held).
    SetNaming(Option<String>),
    /// Create a session; answer with [`Event::SessionReady`].
    CreateSession {
        /// Customer id.
        customer: String,
        /// Measurement set (built-in name or file).
        set: String,
        /// Notes to store (sex, age).
        notes: Option<String>,
        /// The customer's choice about their data.
        consent: crate::store::Consent,
        /// Careful mode: each measurement taken twice.
        careful: bool,
    },
    /// Load a session (reopening a closed one); answer with [`Event::SessionReady`].
    OpenSession(SessionId),
    /// Load a session to look at it (a closed one stays closed); answer
    /// with [`Event::SessionReady`].
    ViewSession(SessionId),
    /// Store the tape's live value as a keyboard reading (Enter instead of
    /// hold); answer with [`Event::ReadingStored`].
    CaptureLive {
        /// Session.
        session: SessionId,
        /// Measurement name.
        name: String,
        /// Value, tenths of a mm.
        value_tenth_mm: u32,
        /// Unit the tape showed.
        unit_shown: UnitShown,
    },
    /// Check a reading; answer with [`Event::Checked`].
    Check(CheckRequest),
    /// Withdraw a stored reading (undo): it stays in the session's history,
    /// the value it replaced is current again.
    WithdrawReading(ReadingId),
    /// Store (or clear) the operator's mark on a measurement.
    SetMark {
        /// Session.
        session: SessionId,
        /// Measurement name.
        name: String,
        /// The mark, or `None` to clear it.
        mark: Option<Mark>,
    },
    /// Start an estimate; progress comes as [`Event::Estimate`].
    StartEstimate(EstimateRequest),
    /// Cancel the running estimate.
    CancelEstimate,
    /// Estimate the readings so far in the background, cancelling the live
    /// estimate still running; progress comes as [`Event::Live`]. A
    /// [`Effect::StartEstimate`] of the same request while it runs adopts it.
    LiveEstimate {
        /// Number of this request.
        generation: u64,
        /// What to estimate.
        request: EstimateRequest,
    },
    /// Cancel the running live estimate.
    CancelLive,
    /// Export the session's stored estimate; answer with [`Event::Exported`].
    Export {
        /// Session.
        session: SessionId,
        /// Mesh format.
        format: MeshFormat,
    },
    /// Write the customer's card of the session's stored estimate into the
    /// export folder; answer with [`Event::CardWritten`].
    Card {
        /// Session.
        session: SessionId,
        /// The unit the card prints lengths in (the screen's).
        unit: Unit,
    },
    /// Load the session's stored estimate; answer with [`Event::ResultLoaded`].
    LoadResult(SessionId),
    /// Set a session's status.
    SetStatus(SessionId, SessionStatus),
    /// Load the history; answer with [`Event::History`].
    LoadHistory,
    /// Delete a session (confirmed), then reload the history.
    DeleteSession(SessionId),
    /// Demo: let the simulated tape measure this measurement (`slip`: a
    /// wrong value, to show a flagged reading).
    SimTape {
        /// Measurement name.
        name: String,
        /// Take a wrong value on purpose.
        slip: bool,
    },
    /// Stop the program.
    Quit,
}

impl App {
    /// A fresh app on the new customer screen.
    pub fn new(config: AppConfig) -> Self {
        Self {
            screen: Screen::NewCustomer,
            back_to: Screen::NewCustomer,
            mono: config.mono,
            demo: config.demo.then_some(Pilot::Simulated),
            help: false,
            device: DeviceState::new(config.port),
            form: CustomerForm::new(config.id_seed, &config.default_set),
            session: None,
            estimate: EstimateState::default(),
            live: LiveEstimate::default(),
            result: ResultScreen::default(),
            history: HistoryState::default(),
            unit: Unit::Cm,
            notice: None,
            after_open: None,
            quit_armed: false,
            quit: false,
            link: LinkSync::default(),
        }
    }

    /// The effects to send first (link session and naming, as none yet).
    pub fn start(&mut self) -> Vec<Effect> {
        let mut fx = Vec::new();
        self.sync_link(&mut fx);
        fx
    }

    /// Shows a one-line notice.
    pub fn note(&mut self, level: Level, text: impl Into<String>) {
        self.notice = Some((level, text.into()));
    }

    /// Is this the demo (simulated tape)?
    pub fn is_demo(&self) -> bool {
        self.demo.is_some()
    }

    /// The measurement the tape's next reading goes to, if the app is
    /// measuring.
    pub fn current_item(&self) -> Option<&Item> {
        let s = self.session.as_ref()?;
        s.items.get(s.current?)
    }

    fn desired_naming(&self) -> Option<String> {
        if self.screen != Screen::Measuring && self.screen != Screen::Device {
            // Device screen keeps the naming so a glance at it loses nothing.
            return None;
        }
        if self.screen == Screen::Device && self.back_to != Screen::Measuring {
            return None;
        }
        self.current_item().map(|i| i.info.name.clone())
    }

    fn sync_link(&mut self, fx: &mut Vec<Effect>) {
        let session = self.session.as_ref().map(|s| s.id);
        if self.link.session != Some(session) {
            self.link.session = Some(session);
            fx.push(Effect::SetLinkSession(session));
        }
        let naming = self.desired_naming();
        if self.link.naming.as_ref() != Some(&naming) {
            self.link.naming = Some(naming.clone());
            fx.push(Effect::SetNaming(naming));
        }
    }

    /// Is a text field taking the keys (so the keys that work anywhere are
    /// typed instead)?
    fn typing(&self) -> bool {
        self.screen == Screen::NewCustomer && self.form.typing()
    }

    /// The keys of the screen shown, with their words.
    pub fn screen_hints(&self) -> Vec<Hint> {
        match self.screen {
            Screen::Device => device::hints(self),
            Screen::NewCustomer => new_customer::hints(self),
            Screen::Measuring => measuring::hints(self),
            Screen::Estimating => estimating::hints(self),
            Screen::Result => result::hints(self),
            Screen::History => history::hints(self),
        }
    }

    /// The footer: the screen's keys, then the keys that work anywhere that
    /// the screen shows there.
    pub fn footer_hints(&self) -> Vec<Hint> {
        let shown = match self.screen {
            Screen::Device => device::FOOTER_GLOBALS,
            Screen::NewCustomer => new_customer::footer_globals(self),
            Screen::Measuring => measuring::FOOTER_GLOBALS,
            Screen::Estimating => estimating::FOOTER_GLOBALS,
            Screen::Result => result::FOOTER_GLOBALS,
            Screen::History => history::FOOTER_GLOBALS,
        };
        let globals = global_bindings(self);
        let mut hints = self.screen_hints();
        hints.extend(
            shown
                .iter()
                .filter_map(|g| globals.iter().find(|b| b.action == *g).map(Binding::hint)),
        );
        hints
    }

    /// The keys that work anywhere (now), with their words.
    pub fn global_hints(&self) -> Vec<Hint> {
        global_bindings(self).iter().map(Binding::hint).collect()
    }
}

/// The keys that work on (almost) every screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Global {
    /// Ctrl-C: quit at once.
    QuitNow,
    /// `?`: the help.
    Help,
    /// `d`: the device screen.
    Device,
    /// `h`: the history.
    History,
    /// `q` twice: quit.
    Quit,
}

/// The keys that work anywhere, as they stand on the screen shown.
fn global_bindings(app: &App) -> Vec<Binding<Global>> {
    let mut b = vec![
        Binding::help_only(
            &[Key::Ctrl('c')],
            msg!("key-ctrl-c"),
            msg!("global-quit-now-help"),
            Global::QuitNow,
        ),
        Binding::new(
            &[ch('?')],
            "?",
            msg!("global-help"),
            msg!("global-help-help"),
            Global::Help,
        ),
    ];
    if app.screen != Screen::Device {
        b.push(Binding::new(
            &[ch('d')],
            "d",
            msg!("global-device"),
            msg!("global-device-help"),
            Global::Device,
        ));
    }
    if app.screen != Screen::History && app.screen != Screen::Estimating {
        b.push(Binding::new(
            &[ch('h')],
            "h",
            msg!("global-history"),
            msg!("global-history-help"),
            Global::History,
        ));
    }
    b.push(Binding::new(
        &[ch('q')],
        "q",
        msg!("global-quit"),
        msg!("global-quit-help"),
        Global::Quit,
    ));
    b
}

/// Applies one event; returns the work for the runner.
pub fn update(app: &mut App, event: Event) -> Vec<Effect> {
    let mut fx = Vec::new();
    match event {
        Event::Key(key) => on_key(app, key, &mut fx),
        Event::TakenOver => {
            if app.demo.is_some() {
                app.demo = Some(Pilot::Person);
                app.note(Level::Info, tr!("notice-taken-over"));
            }
        }
        Event::Link(ev) => on_link(app, ev, &mut fx),
        Event::ReadingStored {
            reading,
            unit_shown,
        } => measuring::on_reading_stored(app, reading, unit_shown, &mut fx),
        Event::Estimate(ev) => estimating::on_estimate(app, ev, &mut fx),
        Event::Live { generation, event } => live::on_live(app, generation, event),
        Event::Checked {
            name,
            value_tenth_mm,
            outcome,
        } => measuring::on_checked(app, &name, value_tenth_mm, outcome),
        Event::Resumable(offer) => {
            if app.session.is_none() {
                app.form.resume = Some(offer);
            }
        }
        Event::SessionReady(view) => measuring::on_session_ready(app, view, &mut fx),
        Event::ResultLoaded(r) => result::on_loaded(app, r, &mut fx),
        Event::History(list) => history::on_loaded(app, list),
        Event::Exported(r) => result::on_exported(app, r, &mut fx),
        Event::CardWritten(r) => result::on_card(app, r),
        Event::Failed(msg) => {
            if app.screen == Screen::NewCustomer {
                app.form.error = Some(msg.clone());
            }
            app.history.loading = false;
            app.note(Level::Error, msg);
        }
        Event::Tick => {}
    }
    live::sync(app, &mut fx);
    app.sync_link(&mut fx);
    fx
}

fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    if key.kind == KeyEventKind::Release {
        return;
    }
    if app.help {
        // Any key closes the help overlay (Ctrl-C still quits).
        if !Key::Ctrl('c').matches(&key) {
            app.help = false;
            return;
        }
    }
    let global = if app.typing() {
        // Only Ctrl-C while typing: the other keys are text.
        lookup(&global_bindings(app), &key)
            .filter(|g| **g == Global::QuitNow)
            .copied()
    } else {
        lookup(&global_bindings(app), &key).copied()
    };
    if global != Some(Global::Quit) {
        app.quit_armed = false;
    }
    match global {
        Some(Global::QuitNow) => {
            // Every reading is already stored.
            app.quit = true;
            fx.push(Effect::Quit);
        }
        Some(Global::Quit) => {
            if app.quit_armed {
                app.quit = true;
                fx.push(Effect::Quit);
            } else {
                app.quit_armed = true;
                app.note(Level::Warn, tr!("notice-quit-again"));
            }
        }
        Some(Global::Help) => app.help = true,
        Some(Global::Device) => {
            app.back_to = app.screen;
            app.screen = Screen::Device;
            app.notice = None;
        }
        Some(Global::History) => {
            app.back_to = app.screen;
            app.screen = Screen::History;
            app.notice = None;
            app.history.loading = true;
            app.history.confirm_delete = None;
            fx.push(Effect::LoadHistory);
        }
        None => on_screen_key(app, key, fx),
    }
}

/// A key for the screen shown.
pub(crate) fn on_screen_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    match app.screen {
        Screen::Device => device::on_key(app, key),
        Screen::NewCustomer => new_customer::on_key(app, key, fx),
        Screen::Measuring => measuring::on_key(app, key, fx),
        Screen::Estimating => estimating::on_key(app, key, fx),
        Screen::Result => result::on_key(app, key, fx),
        Screen::History => history::on_key(app, key, fx),
    }
}

fn on_link(app: &mut App, ev: LinkEvent, fx: &mut Vec<Effect>) {
    match ev {
        LinkEvent::ReadingCommitted {
            reading,
            unit_shown,
        } => measuring::on_reading_stored(app, reading, unit_shown, fx),
        LinkEvent::Button(b) => {
            use tapeshape_protocol::ButtonKind;
            if app.screen == Screen::Measuring {
                // The tape's buttons act like the keys; the cursor is on the
                // current measurement for a redo.
                let key = match b {
                    ButtonKind::Next => KeyCode::Char('s'),
                    ButtonKind::Back => KeyCode::Char('u'),
                    ButtonKind::Redo => KeyCode::Char('r'),
                };
                if b == ButtonKind::Redo {
                    if let Some(s) = app.session.as_mut() {
                        if let Some(c) = s.current {
                            s.selected = c;
                        }
                    }
                }
                measuring::on_key(app, KeyEvent::from(key), fx);
            }
        }
        LinkEvent::Gap { expected, got, .. } => app.note(
            Level::Warn,
            tr!(
                "notice-gap",
                got = got.to_string(),
                expected = expected.to_string()
            ),
        ),
        LinkEvent::ReadingUnassigned { reading, .. } => {
            let text = tr!(
                "notice-unassigned",
                value = app.unit.format(reading.value_tenth_mm)
            );
            app.note(Level::Warn, text);
        }
        LinkEvent::CommitFailed { reading, error } => {
            let text = tr!(
                "notice-commit-failed",
                value = app.unit.format(reading.value_tenth_mm),
                error = error.to_string()
            );
            app.note(Level::Error, text);
        }
        other => {
            if let Some((level, text)) = app.device.on_link(other) {
                app.note(level, text);
            }
        }
    }
}

/// The first of `bindings` that `key` presses (the screens' handlers).
pub(crate) fn action<A: Copy>(bindings: &[Binding<A>], key: &KeyEvent) -> Option<A> {
    lookup(bindings, key).copied()
}
