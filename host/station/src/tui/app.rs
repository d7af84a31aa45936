//! The interface's state and its one state transition, [`update`].
//!
//! Why this shape (the Elm architecture that well-kept ratatui apps use):
//! [`App`] is plain data with no I/O; [`update`] takes one [`Event`] (a key,
//! a link event, estimate progress, a tick) and returns the [`Effect`]s the
//! runner must perform (set the link's naming, create a session, start an
//! estimate, export ...). Results of effects come back as events. So tests
//! drive the whole operator flow without a terminal, a tape or an engine, and
//! the demo's simulated operator is one more event source that a human's
//! first key press switches off.
//!
//! Readings are never held here: every reading is committed to the store by
//! the link **before** the app hears of it, so the app only reflects what is
//! stored (plus the operator's marks: skipped, flagged, undone).

use std::collections::VecDeque;
use std::path::PathBuf;

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use tapeshape_protocol::{DeviceHello, Live, UnitShown};

use crate::link::LinkEvent;
use crate::services::{
    CheckOutcome, CheckRequest, EstimateEvent, EstimateJob, EstimateSummary, ExportFormat, Stage,
};
use crate::store::{Mark, ReadingId, SessionId, SessionStatus, SessionSummary};

/// Measurement sets offered for a new customer (besides a custom file).
pub const BUILTIN_SET_CHOICES: [&str; 3] = ["quick", "ansur", "paper34"];

/// Most recent device faults kept for the device screen.
pub const FAULTS_KEPT: usize = 6;

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
    /// Title shown in the top bar.
    pub fn title(self) -> &'static str {
        match self {
            Screen::Device => "Device",
            Screen::NewCustomer => "New customer",
            Screen::Measuring => "Measuring",
            Screen::Estimating => "Estimating",
            Screen::Result => "Result",
            Screen::History => "History",
        }
    }
}

/// Unit values are shown in (the store always keeps tenths of a mm).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DisplayUnit {
    /// Centimetres, one decimal.
    Cm,
    /// Inches, two decimals.
    Inch,
}

impl DisplayUnit {
    /// `value_tenth_mm` in this unit with its symbol (`98.2 cm`, `38.66 in`).
    pub fn format(self, value_tenth_mm: u32) -> String {
        let mm = f64::from(value_tenth_mm) / 10.0;
        self.format_mm(mm)
    }

    /// A length in millimetres in this unit with its symbol.
    pub fn format_mm(self, mm: f64) -> String {
        match self {
            DisplayUnit::Cm => format!("{:.1} cm", mm / 10.0),
            DisplayUnit::Inch => format!("{:.2} in", mm / 25.4),
        }
    }
}

/// Is the demo's simulated operator driving?
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Autopilot {
    /// No simulated operator (a real station).
    Off,
    /// The simulated operator drives; a human key press takes over.
    Driving,
    /// A human took over.
    TakenOver,
}

/// Connection state of the tape.
#[derive(Clone, Debug, PartialEq)]
pub enum Connection {
    /// The link is starting.
    Starting,
    /// The port cannot be opened (yet): the error.
    WaitingForPort(String),
    /// Port open, waiting for the tape's hello.
    PortOpen(String),
    /// A compatible tape said hello.
    Connected,
    /// The tape speaks another protocol version: the message names both.
    Mismatch(String),
    /// The connection ended; the link reconnects.
    Disconnected(String),
    /// The link stopped.
    Stopped,
}

/// What the app knows about the tape.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceState {
    /// Port path (or "simulated ...").
    pub port: String,
    /// Connection state.
    pub connection: Connection,
    /// The last hello (kept while reconnecting).
    pub hello: Option<DeviceHello>,
    /// The last live value.
    pub live: Option<Live>,
    /// Recent faults, newest last.
    pub faults: VecDeque<String>,
    /// Frames dropped so far.
    pub bad_frames: u64,
    /// Connections lost so far.
    pub disconnects: u64,
    /// Readings the tape's queue holds (from its last status).
    pub queue: Option<(u16, u16)>,
}

impl DeviceState {
    fn new(port: String) -> Self {
        Self {
            port,
            connection: Connection::Starting,
            hello: None,
            live: None,
            faults: VecDeque::new(),
            bad_frames: 0,
            disconnects: 0,
            queue: None,
        }
    }

    /// True when a compatible tape is connected.
    pub fn connected(&self) -> bool {
        self.connection == Connection::Connected
    }
}

/// Sex as entered on the new customer form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sex {
    /// Not given.
    Unspecified,
    /// Female.
    Female,
    /// Male.
    Male,
}

impl Sex {
    /// Word shown and stored in the session notes.
    pub fn word(self) -> &'static str {
        match self {
            Sex::Unspecified => "not given",
            Sex::Female => "female",
            Sex::Male => "male",
        }
    }

    fn cycle(self, forward: bool) -> Sex {
        let all = [Sex::Unspecified, Sex::Female, Sex::Male];
        let i = all.iter().position(|s| *s == self).unwrap_or(0);
        let n = all.len();
        all[if forward {
            (i + 1) % n
        } else {
            (i + n - 1) % n
        }]
    }
}

/// Fields of the new customer form.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormField {
    /// Customer id (generated, editable).
    Customer,
    /// Sex.
    Sex,
    /// Age in years (optional).
    Age,
    /// Measurement set.
    Set,
    /// Path of a custom set file.
    File,
}

/// The new customer form.
#[derive(Clone, Debug, PartialEq)]
pub struct CustomerForm {
    /// Opaque customer id.
    pub customer: String,
    /// Sex.
    pub sex: Sex,
    /// Age digits as typed.
    pub age: String,
    /// Index into [`BUILTIN_SET_CHOICES`], or its length for a custom file.
    pub set_choice: usize,
    /// Custom set file path as typed.
    pub file: String,
    /// Focused field.
    pub field: FormField,
    /// What is wrong with the form, if the last Enter was refused.
    pub error: Option<String>,
}

impl CustomerForm {
    fn new(customer: String, set: &str) -> Self {
        let set_choice = BUILTIN_SET_CHOICES
            .iter()
            .position(|s| *s == set)
            .unwrap_or(BUILTIN_SET_CHOICES.len());
        let file = if set_choice == BUILTIN_SET_CHOICES.len() {
            set.to_string()
        } else {
            String::new()
        };
        Self {
            customer,
            sex: Sex::Unspecified,
            age: String::new(),
            set_choice,
            file,
            field: FormField::Sex,
            error: None,
        }
    }

    /// The set the form names (built-in name or file path).
    pub fn set(&self) -> String {
        BUILTIN_SET_CHOICES
            .get(self.set_choice)
            .map(|s| s.to_string())
            .unwrap_or_else(|| self.file.trim().to_string())
    }

    fn fields(&self) -> Vec<FormField> {
        let mut f = vec![
            FormField::Customer,
            FormField::Sex,
            FormField::Age,
            FormField::Set,
        ];
        if self.set_choice == BUILTIN_SET_CHOICES.len() {
            f.push(FormField::File);
        }
        f
    }
}

/// An unfinished session the store holds, offered for resuming.
#[derive(Clone, Debug, PartialEq)]
pub struct ResumeOffer {
    /// The session.
    pub session: SessionId,
    /// Its customer id.
    pub customer: String,
    /// Its measurement set.
    pub set: Option<String>,
    /// Readings it holds (current ones).
    pub readings: u64,
}

/// One measurement of the set, as the runner loads it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementInfo {
    /// Name stored with readings.
    pub name: String,
    /// Human label.
    pub label: String,
    /// Instruction for the operator.
    pub description: String,
}

/// A session as loaded from the store, for the app.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionView {
    /// The session.
    pub id: SessionId,
    /// Customer id.
    pub customer: String,
    /// Measurement set name (or file).
    pub set: String,
    /// Notes (sex, age).
    pub notes: Option<String>,
    /// The set's measurements, in order.
    pub measurements: Vec<MeasurementInfo>,
    /// Current readings (name, tenths of a mm), commit order.
    pub readings: Vec<(String, u32)>,
    /// Superseded (retaken) readings (name, tenths of a mm), commit order.
    pub superseded: Vec<(String, u32)>,
    /// The operator's stored marks (skipped, flagged reading kept).
    pub marks: Vec<(String, Mark)>,
}

/// State of one measurement in the session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ItemState {
    /// Not taken yet.
    Todo,
    /// Taken; the check is running.
    Checking,
    /// Taken and accepted.
    Done,
    /// Taken, but the check found it far off: measure again or keep (Enter).
    Flagged,
    /// Skipped by the operator.
    Skipped,
}

/// One measurement of the session.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    /// Set entry.
    pub info: MeasurementInfo,
    /// State.
    pub state: ItemState,
    /// The reading in use (tenths of a mm), if any.
    pub value: Option<u32>,
    /// Earlier readings of this measurement (retakes), oldest first.
    pub previous: Vec<u32>,
    /// The check's message (flag), if any.
    pub flag: Option<String>,
    /// The check's unit slip message, if any.
    pub unit_slip: Option<String>,
    /// The operator kept a flagged reading.
    pub kept_flagged: bool,
}

/// What undoing a step changes in the store, so that a resumed session
/// looks as the operator left it.
#[derive(Clone, Debug, PartialEq)]
pub enum StoreRevert {
    /// Withdraw this reading (it stays in the history).
    Withdraw(ReadingId),
    /// Set this measurement's mark back to this.
    Mark(String, Option<Mark>),
}

/// An operator step that `u` undoes.
#[derive(Clone, Debug, PartialEq)]
pub struct UndoEntry {
    /// What it was, in words (for the notice).
    pub what: String,
    /// What undoing it changes in the store.
    pub reverts: Vec<StoreRevert>,
    /// Item index and its state before the step.
    pub item: Option<(usize, Item)>,
    /// The current measurement before the step.
    pub current: Option<usize>,
}

/// The session being measured.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionState {
    /// Session id.
    pub id: SessionId,
    /// Customer id.
    pub customer: String,
    /// Measurement set.
    pub set: String,
    /// Notes (sex, age).
    pub notes: Option<String>,
    /// The measurements.
    pub items: Vec<Item>,
    /// The one the tape's next reading goes to.
    pub current: Option<usize>,
    /// Cursor in the list.
    pub selected: usize,
    /// Undo stack.
    pub undo: Vec<UndoEntry>,
    /// The session was marked done (after an export); going back to
    /// measuring opens it again, or the store would refuse new readings.
    pub marked_done: bool,
}

impl SessionState {
    /// Readings used for an estimate (name, millimetres): done and flagged
    /// ones, not skipped or undone.
    pub fn accepted(&self) -> Vec<(String, f64)> {
        self.items
            .iter()
            .filter(|i| matches!(i.state, ItemState::Done | ItemState::Flagged))
            .filter_map(|i| i.value.map(|v| (i.info.name.clone(), f64::from(v) / 10.0)))
            .collect()
    }

    /// Count of items in `state`.
    pub fn count(&self, state: ItemState) -> usize {
        self.items.iter().filter(|i| i.state == state).count()
    }

    fn index_of(&self, name: &str) -> Option<usize> {
        self.items.iter().position(|i| i.info.name == name)
    }

    /// The next measurement still to take after `from` (wrapping), if any.
    fn next_todo(&self, from: Option<usize>) -> Option<usize> {
        let n = self.items.len();
        let start = from.map_or(0, |i| i + 1);
        (0..n)
            .map(|k| (start + k) % n)
            .find(|&i| self.items[i].state == ItemState::Todo)
    }
}

/// The estimate screen's state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EstimateState {
    /// An estimate is running.
    pub running: bool,
    /// Cancel was asked for.
    pub cancelling: bool,
    /// Stages started so far, in order.
    pub stages: Vec<Stage>,
    /// Fraction done (0 to 1).
    pub fraction: f64,
    /// Why the last estimate failed.
    pub error: Option<String>,
}

/// The history screen's state.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HistoryState {
    /// Sessions, most recent first.
    pub sessions: Vec<SessionSummary>,
    /// Cursor.
    pub selected: usize,
    /// Session awaiting delete confirmation.
    pub confirm_delete: Option<SessionId>,
    /// The list is being loaded.
    pub loading: bool,
}

/// What to do once a session opened from history is loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AfterOpen {
    /// Continue measuring.
    Measure,
    /// Estimate it.
    Estimate,
    /// Estimate and export it.
    Export,
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

/// Everything the interface shows. Plain data; see the module docs.
#[derive(Clone, Debug, PartialEq)]
pub struct App {
    /// Screen shown.
    pub screen: Screen,
    /// Screen to go back to from Device/History.
    pub back_to: Screen,
    /// Monochrome drawing.
    pub mono: bool,
    /// Demo mode (simulated tape; `m`/`M` keys).
    pub demo: bool,
    /// Help overlay shown.
    pub help: bool,
    /// The tape.
    pub device: DeviceState,
    /// New customer form.
    pub form: CustomerForm,
    /// Unfinished session offered for resuming.
    pub resume: Option<ResumeOffer>,
    /// Session being measured.
    pub session: Option<SessionState>,
    /// Estimate progress.
    pub estimate: EstimateState,
    /// Last estimate.
    pub result: Option<EstimateSummary>,
    /// History screen.
    pub history: HistoryState,
    /// Unit values are shown in.
    pub unit: DisplayUnit,
    /// Simulated operator state.
    pub autopilot: Autopilot,
    /// One-line notice.
    pub notice: Option<(Level, String)>,
    /// Format of the next export.
    pub export_format: ExportFormat,
    /// Files of the last export.
    pub exported: Option<Vec<PathBuf>>,
    /// What to do after a session from history loads.
    pub after_open: Option<AfterOpen>,
    /// `q` was pressed once: a second `q` quits.
    pub quit_armed: bool,
    /// The runner should stop.
    pub quit: bool,
    /// Customer ids handed out so far (makes the next one differ).
    pub customers_started: u64,
    /// Seed of the generated customer ids.
    pub id_seed: u64,
    naming_sent: Option<Option<String>>,
    session_sent: Option<Option<SessionId>>,
}

/// How the app starts.
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// Port path or a description of the simulated tape.
    pub port: String,
    /// Demo mode.
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
    /// A key pressed by a person.
    Key(KeyEvent),
    /// A key "pressed" by the demo's simulated operator.
    SimKey(KeyEvent),
    /// Something the tape link reported.
    Link(LinkEvent),
    /// Estimate progress.
    Estimate(EstimateEvent),
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
    /// A session was created or opened (result of [`Effect::CreateSession`]
    /// or [`Effect::OpenSession`]).
    SessionReady(SessionView),
    /// The history list (result of [`Effect::LoadHistory`]).
    History(Vec<SessionSummary>),
    /// Result of [`Effect::Export`].
    Exported(Result<Vec<PathBuf>, String>),
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
    },
    /// Load a session (reopening a closed one); answer with [`Event::SessionReady`].
    OpenSession(SessionId),
    /// Commit the tape's live value as a reading (Enter instead of hold).
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
    StartEstimate(EstimateJob),
    /// Cancel the running estimate.
    CancelEstimate,
    /// Export the last estimate; answer with [`Event::Exported`].
    Export {
        /// Session.
        session: SessionId,
        /// Mesh format.
        format: ExportFormat,
    },
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
        let customer = customer_id(config.id_seed, 0);
        Self {
            screen: Screen::NewCustomer,
            back_to: Screen::NewCustomer,
            mono: config.mono,
            demo: config.demo,
            help: false,
            device: DeviceState::new(config.port),
            form: CustomerForm::new(customer, &config.default_set),
            resume: None,
            session: None,
            estimate: EstimateState::default(),
            result: None,
            history: HistoryState::default(),
            unit: DisplayUnit::Cm,
            autopilot: if config.demo {
                Autopilot::Driving
            } else {
                Autopilot::Off
            },
            notice: None,
            export_format: ExportFormat::Glb,
            exported: None,
            after_open: None,
            quit_armed: false,
            quit: false,
            customers_started: 0,
            id_seed: config.id_seed,
            naming_sent: None,
            session_sent: None,
        }
    }

    /// The effects to send first (link session and naming, as none yet).
    pub fn start(&mut self) -> Vec<Effect> {
        let mut fx = Vec::new();
        self.sync_link(&mut fx);
        fx
    }

    fn note(&mut self, level: Level, text: impl Into<String>) {
        self.notice = Some((level, text.into()));
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
        if self.session_sent != Some(session) {
            self.session_sent = Some(session);
            fx.push(Effect::SetLinkSession(session));
        }
        let naming = self.desired_naming();
        if self.naming_sent.as_ref() != Some(&naming) {
            self.naming_sent = Some(naming.clone());
            fx.push(Effect::SetNaming(naming));
        }
    }
}

/// An opaque customer id from a seed and a counter (`c-` and 6 base-32
/// characters): no name, nothing personal, differs per customer.
pub fn customer_id(seed: u64, n: u64) -> String {
    // splitmix64: a tiny, well-known mixer; a crate would be overkill for
    // six characters of an id.
    let mut z = seed.wrapping_add(n.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    const ALPHABET: &[u8; 32] = b"0123456789abcdefghjkmnpqrstvwxyz";
    let s: String = (0..6)
        .map(|k| ALPHABET[((z >> (5 * k)) & 31) as usize] as char)
        .collect();
    format!("c-{s}")
}

/// Applies one event; returns the work for the runner.
pub fn update(app: &mut App, event: Event) -> Vec<Effect> {
    let mut fx = Vec::new();
    match event {
        Event::Key(key) => {
            if app.autopilot == Autopilot::Driving {
                // A person's key stops the simulated operator; the key itself
                // only takes over, so a stray press does nothing else.
                app.autopilot = Autopilot::TakenOver;
                app.note(
                    Level::Info,
                    "You have the keyboard: the simulated operator stopped (? for keys)",
                );
            } else {
                on_key(app, key, &mut fx);
            }
        }
        Event::SimKey(key) => {
            if app.autopilot == Autopilot::Driving {
                on_key(app, key, &mut fx);
            }
        }
        Event::Link(ev) => on_link(app, ev, &mut fx),
        Event::Estimate(ev) => on_estimate(app, ev, &mut fx),
        Event::Checked {
            name,
            value_tenth_mm,
            outcome,
        } => on_checked(app, &name, value_tenth_mm, outcome),
        Event::Resumable(offer) => {
            if app.session.is_none() {
                app.resume = Some(offer);
            }
        }
        Event::SessionReady(view) => on_session_ready(app, view, &mut fx),
        Event::History(list) => {
            app.history.loading = false;
            app.history.sessions = list;
            app.history.selected = app
                .history
                .selected
                .min(app.history.sessions.len().saturating_sub(1));
        }
        Event::Exported(r) => match r {
            Ok(files) => {
                app.note(
                    Level::Info,
                    format!(
                        "Exported {} files to {}",
                        files.len(),
                        files
                            .first()
                            .and_then(|f| f.parent())
                            .map(|p| p.display().to_string())
                            .unwrap_or_default()
                    ),
                );
                app.exported = Some(files);
                if let Some(s) = app.session.as_mut() {
                    s.marked_done = true;
                    fx.push(Effect::SetStatus(s.id, SessionStatus::Done));
                }
            }
            Err(e) => app.note(Level::Error, format!("Export failed: {e}")),
        },
        Event::Failed(msg) => {
            if app.screen == Screen::NewCustomer {
                app.form.error = Some(msg.clone());
            }
            app.history.loading = false;
            app.note(Level::Error, msg);
        }
        Event::Tick => {}
    }
    app.sync_link(&mut fx);
    fx
}

fn plain(key: &KeyEvent) -> Option<char> {
    match key.code {
        KeyCode::Char(c) if !key.modifiers.contains(KeyModifiers::CONTROL) => Some(c),
        _ => None,
    }
}

fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    if key.kind == crossterm::event::KeyEventKind::Release {
        return;
    }
    // Ctrl-C quits at once: every reading is already stored.
    if key.code == KeyCode::Char('c') && key.modifiers.contains(KeyModifiers::CONTROL) {
        app.quit = true;
        fx.push(Effect::Quit);
        return;
    }
    let typing = app.screen == Screen::NewCustomer
        && app.resume.is_none()
        && matches!(
            app.form.field,
            FormField::Customer | FormField::File | FormField::Age
        );
    let c = plain(&key);
    if app.help {
        // Any key closes the help overlay.
        app.help = false;
        return;
    }
    if c == Some('q') && !typing {
        if app.quit_armed {
            app.quit = true;
            fx.push(Effect::Quit);
        } else {
            app.quit_armed = true;
            app.note(
                Level::Warn,
                "Press q again to quit (every reading taken is already stored)",
            );
        }
        return;
    }
    app.quit_armed = false;
    if !typing {
        match c {
            Some('?') => {
                app.help = true;
                return;
            }
            Some('d') if app.screen != Screen::Device => {
                app.back_to = app.screen;
                app.screen = Screen::Device;
                app.notice = None;
                return;
            }
            Some('h') if app.screen != Screen::History && app.screen != Screen::Estimating => {
                app.back_to = app.screen;
                app.screen = Screen::History;
                app.notice = None;
                app.history.loading = true;
                app.history.confirm_delete = None;
                fx.push(Effect::LoadHistory);
                return;
            }
            _ => {}
        }
    }
    match app.screen {
        Screen::Device => {
            if key.code == KeyCode::Esc || c == Some('b') || c == Some('d') {
                app.screen = app.back_to;
            }
        }
        Screen::NewCustomer => on_key_form(app, key, fx),
        Screen::Measuring => on_key_measuring(app, key, fx),
        Screen::Estimating => {
            if key.code == KeyCode::Esc {
                if app.estimate.running {
                    app.estimate.cancelling = true;
                    fx.push(Effect::CancelEstimate);
                } else {
                    app.screen = Screen::Measuring;
                }
            }
        }
        Screen::Result => on_key_result(app, key, fx),
        Screen::History => on_key_history(app, key, fx),
    }
}

fn on_key_form(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    if let Some(offer) = app.resume.clone() {
        match plain(&key) {
            Some('y') | Some('r') => {
                app.resume = None;
                app.after_open = Some(AfterOpen::Measure);
                fx.push(Effect::OpenSession(offer.session));
            }
            Some('n') => {
                app.resume = None;
                app.note(
                    Level::Info,
                    format!(
                        "Session {} stays open; find it under h (history)",
                        offer.session
                    ),
                );
            }
            _ => {}
        }
        if key.code == KeyCode::Enter {
            app.resume = None;
            app.after_open = Some(AfterOpen::Measure);
            fx.push(Effect::OpenSession(offer.session));
        } else if key.code == KeyCode::Esc {
            app.resume = None;
        }
        return;
    }
    let form = &mut app.form;
    let fields = form.fields();
    let pos = fields.iter().position(|f| *f == form.field).unwrap_or(0);
    match key.code {
        KeyCode::Up | KeyCode::BackTab => {
            form.field = fields[(pos + fields.len() - 1) % fields.len()];
        }
        KeyCode::Down | KeyCode::Tab => form.field = fields[(pos + 1) % fields.len()],
        KeyCode::Left | KeyCode::Right => {
            let forward = key.code == KeyCode::Right;
            match form.field {
                FormField::Sex => form.sex = form.sex.cycle(forward),
                FormField::Set => {
                    let n = BUILTIN_SET_CHOICES.len() + 1;
                    form.set_choice = if forward {
                        (form.set_choice + 1) % n
                    } else {
                        (form.set_choice + n - 1) % n
                    };
                }
                _ => {}
            }
        }
        KeyCode::Backspace => match form.field {
            FormField::Customer => {
                form.customer.pop();
            }
            FormField::Age => {
                form.age.pop();
            }
            FormField::File => {
                form.file.pop();
            }
            _ => {}
        },
        KeyCode::Char(ch) if !key.modifiers.contains(KeyModifiers::CONTROL) => match form.field {
            FormField::Customer if form.customer.len() < 64 && !ch.is_control() => {
                form.customer.push(ch)
            }
            FormField::Age if ch.is_ascii_digit() && form.age.len() < 3 => form.age.push(ch),
            FormField::File if form.file.len() < 512 && !ch.is_control() => form.file.push(ch),
            FormField::Sex => match ch {
                'f' | 'F' => form.sex = Sex::Female,
                'm' | 'M' => form.sex = Sex::Male,
                _ => {}
            },
            _ => {}
        },
        KeyCode::Enter => submit_form(app, fx),
        _ => {}
    }
}

fn submit_form(app: &mut App, fx: &mut Vec<Effect>) {
    let form = &mut app.form;
    let customer = form.customer.trim().to_string();
    if customer.is_empty() {
        form.error = Some("Give a customer id (any text; a new one is suggested)".into());
        form.field = FormField::Customer;
        return;
    }
    let age = if form.age.is_empty() {
        None
    } else {
        match form.age.parse::<u32>() {
            Ok(a) if (16..=110).contains(&a) => Some(a),
            _ => {
                form.error = Some(format!(
                    "Age {} is not between 16 and 110: correct it or leave it empty",
                    form.age
                ));
                form.field = FormField::Age;
                return;
            }
        }
    };
    let set = form.set();
    if set.is_empty() {
        form.error = Some("Give the path of the measurement set file (TOML)".into());
        form.field = FormField::File;
        return;
    }
    form.error = None;
    let mut notes = format!("sex: {}", form.sex.word());
    if let Some(a) = age {
        notes.push_str(&format!(", age: {a}"));
    }
    app.after_open = Some(AfterOpen::Measure);
    fx.push(Effect::CreateSession {
        customer,
        set,
        notes: Some(notes),
    });
}

fn on_session_ready(app: &mut App, view: SessionView, fx: &mut Vec<Effect>) {
    let mut items: Vec<Item> = view
        .measurements
        .into_iter()
        .map(|info| Item {
            info,
            state: ItemState::Todo,
            value: None,
            previous: Vec::new(),
            flag: None,
            unit_slip: None,
            kept_flagged: false,
        })
        .collect();
    for (name, v) in &view.superseded {
        if let Some(i) = items.iter_mut().find(|i| &i.info.name == name) {
            i.previous.push(*v);
        }
    }
    let mut unknown = Vec::new();
    for (name, v) in &view.readings {
        match items.iter_mut().find(|i| &i.info.name == name) {
            Some(i) => {
                i.value = Some(*v);
                i.state = ItemState::Done;
            }
            None => unknown.push(name.clone()),
        }
    }
    for (name, mark) in &view.marks {
        if let Some(i) = items.iter_mut().find(|i| &i.info.name == name) {
            match mark {
                Mark::Skipped if i.value.is_none() => i.state = ItemState::Skipped,
                Mark::KeptFlagged if i.value.is_some() => i.kept_flagged = true,
                _ => {}
            }
        }
    }
    let resumed = view.readings.len();
    let mut s = SessionState {
        id: view.id,
        customer: view.customer,
        set: view.set,
        notes: view.notes,
        items,
        current: None,
        selected: 0,
        undo: Vec::new(),
        marked_done: false,
    };
    s.current = s.next_todo(None);
    s.selected = s.current.unwrap_or(0);
    app.session = Some(s);
    app.result = None;
    app.exported = None;
    app.estimate = EstimateState::default();
    app.customers_started += 1;
    app.form = CustomerForm::new(
        customer_id(app.id_seed, app.customers_started),
        &app.form.set(),
    );
    let after = app.after_open.take().unwrap_or(AfterOpen::Measure);
    app.screen = Screen::Measuring;
    let id = app.session.as_ref().map(|s| s.id);
    if resumed > 0 {
        app.note(
            Level::Info,
            format!(
                "Session {} opened with its {resumed} stored readings{}",
                id.map(|i| i.to_string()).unwrap_or_default(),
                if unknown.is_empty() {
                    String::new()
                } else {
                    format!(
                        " ({} not in its set: {})",
                        unknown.len(),
                        unknown.join(", ")
                    )
                }
            ),
        );
    } else {
        app.notice = None;
    }
    match after {
        AfterOpen::Measure => recheck_resumed(app, fx),
        AfterOpen::Estimate => start_estimate(app, fx, false),
        AfterOpen::Export => start_estimate(app, fx, true),
    }
}

/// Moves the current measurement to the next one still to take.
fn advance(app: &mut App) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    s.current = s.next_todo(s.current);
    if let Some(c) = s.current {
        s.selected = c;
    } else {
        let skipped = s.count(ItemState::Skipped);
        let flagged = s.count(ItemState::Flagged);
        app.note(
            Level::Info,
            format!(
                "All measurements taken{}: press e to estimate the body",
                match (skipped, flagged) {
                    (0, 0) => String::new(),
                    _ => format!(" ({skipped} skipped, {flagged} flagged)"),
                }
            ),
        );
    }
}

fn on_key_measuring(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    let Some(s) = app.session.as_mut() else {
        app.screen = Screen::NewCustomer;
        return;
    };
    let n = s.items.len();
    match (key.code, plain(&key)) {
        (KeyCode::Up, _) | (_, Some('k')) => s.selected = (s.selected + n - 1) % n.max(1),
        (KeyCode::Down, _) | (_, Some('j')) => s.selected = (s.selected + 1) % n.max(1),
        (KeyCode::Enter, _) => {
            let Some(c) = s.current else {
                app.note(
                    Level::Info,
                    "Every measurement is taken: press e to estimate",
                );
                return;
            };
            let item = &s.items[c];
            match item.state {
                ItemState::Flagged => {
                    let before = item.clone();
                    let name = item.info.name.clone();
                    s.undo.push(UndoEntry {
                        what: format!("kept flagged {}", item.info.label),
                        reverts: vec![StoreRevert::Mark(name.clone(), stored_mark(&before))],
                        item: Some((c, before)),
                        current: s.current,
                    });
                    fx.push(Effect::SetMark {
                        session: s.id,
                        name,
                        mark: Some(Mark::KeptFlagged),
                    });
                    let item = &mut s.items[c];
                    item.state = ItemState::Done;
                    item.kept_flagged = true;
                    let label = item.info.label.clone();
                    advance(app);
                    if app.notice.is_none() || app.current_item().is_some() {
                        app.note(Level::Warn, format!("Kept the flagged {label} reading"));
                    }
                }
                ItemState::Checking => app.note(Level::Info, "Checking the reading..."),
                _ => match app.device.live {
                    Some(live) if app.device.connected() && live.value_tenth_mm > 0 => {
                        fx.push(Effect::CaptureLive {
                            session: s.id,
                            name: item.info.name.clone(),
                            value_tenth_mm: live.value_tenth_mm,
                            unit_shown: live.unit_shown,
                        });
                    }
                    _ => app.note(
                        Level::Warn,
                        "No tape value to capture: pull the tape out (or press its hold button)",
                    ),
                },
            }
        }
        (_, Some('s')) => {
            let Some(c) = s.current else { return };
            let before = s.items[c].clone();
            let name = before.info.name.clone();
            s.undo.push(UndoEntry {
                what: format!("skipped {}", before.info.label),
                reverts: vec![StoreRevert::Mark(name.clone(), stored_mark(&before))],
                item: Some((c, before)),
                current: s.current,
            });
            fx.push(Effect::SetMark {
                session: s.id,
                name,
                mark: Some(Mark::Skipped),
            });
            s.items[c].state = ItemState::Skipped;
            let label = s.items[c].info.label.clone();
            advance(app);
            if app.current_item().is_some() {
                app.note(Level::Info, format!("Skipped {label} (u undoes)"));
            }
        }
        (_, Some('r')) | (KeyCode::Char(' '), _) => {
            let i = s.selected.min(n.saturating_sub(1));
            if n == 0 {
                return;
            }
            let before = s.items[i].clone();
            let mut reverts = Vec::new();
            if before.state == ItemState::Skipped {
                reverts.push(StoreRevert::Mark(
                    before.info.name.clone(),
                    Some(Mark::Skipped),
                ));
                fx.push(Effect::SetMark {
                    session: s.id,
                    name: before.info.name.clone(),
                    mark: None,
                });
            }
            s.undo.push(UndoEntry {
                what: format!("retake of {}", before.info.label),
                reverts,
                item: Some((i, before)),
                current: s.current,
            });
            if s.items[i].state == ItemState::Skipped {
                s.items[i].state = ItemState::Todo;
            }
            s.current = Some(i);
            let label = s.items[i].info.label.clone();
            app.note(
                Level::Info,
                format!("Retake {label}: measure again and hold the tape"),
            );
        }
        (_, Some('u')) => match s.undo.pop() {
            Some(entry) => {
                for revert in entry.reverts {
                    fx.push(match revert {
                        StoreRevert::Withdraw(id) => Effect::WithdrawReading(id),
                        StoreRevert::Mark(name, mark) => Effect::SetMark {
                            session: s.id,
                            name,
                            mark,
                        },
                    });
                }
                if let Some((i, item)) = entry.item {
                    s.items[i] = item;
                }
                s.current = entry.current;
                if let Some(c) = s.current {
                    s.selected = c;
                }
                app.note(
                    Level::Info,
                    format!(
                        "Undone: {} (stored readings stay in the session's history)",
                        entry.what
                    ),
                );
            }
            None => app.note(Level::Info, "Nothing to undo"),
        },
        (_, Some('i')) => {
            app.unit = match app.unit {
                DisplayUnit::Cm => DisplayUnit::Inch,
                DisplayUnit::Inch => DisplayUnit::Cm,
            };
        }
        (_, Some('e')) => start_estimate(app, fx, false),
        (_, Some('n')) => {
            app.screen = Screen::NewCustomer;
        }
        (_, Some(ch @ ('m' | 'M'))) if app.demo => match s.current {
            Some(c) => fx.push(Effect::SimTape {
                name: s.items[c].info.name.clone(),
                slip: ch == 'M',
            }),
            None => app.note(Level::Info, "Nothing left to measure"),
        },
        _ => {}
    }
}

fn start_estimate(app: &mut App, fx: &mut Vec<Effect>, then_export: bool) {
    let Some(s) = &app.session else { return };
    let readings = s.accepted();
    if readings.is_empty() {
        app.note(
            Level::Warn,
            "No readings yet: take at least one measurement before estimating",
        );
        app.screen = Screen::Measuring;
        return;
    }
    if s.items.iter().any(|i| i.state == ItemState::Checking) {
        app.note(Level::Info, "A reading is still being checked; try again");
        return;
    }
    app.estimate = EstimateState {
        running: true,
        ..EstimateState::default()
    };
    app.after_open = then_export.then_some(AfterOpen::Export);
    app.screen = Screen::Estimating;
    app.notice = None;
    fx.push(Effect::StartEstimate(EstimateJob {
        session: s.id,
        readings,
    }));
}

fn on_key_result(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    match (key.code, plain(&key)) {
        (_, Some('x')) => {
            if let Some(s) = &app.session {
                fx.push(Effect::Export {
                    session: s.id,
                    format: app.export_format,
                });
                app.note(Level::Info, "Exporting...");
            }
        }
        (_, Some('f')) => {
            let all = ExportFormat::ALL;
            let i = all
                .iter()
                .position(|f| *f == app.export_format)
                .unwrap_or(0);
            app.export_format = all[(i + 1) % all.len()];
        }
        (_, Some('i')) => {
            app.unit = match app.unit {
                DisplayUnit::Cm => DisplayUnit::Inch,
                DisplayUnit::Inch => DisplayUnit::Cm,
            };
        }
        (_, Some('n')) => {
            if let Some(s) = app.session.take() {
                fx.push(Effect::SetStatus(s.id, SessionStatus::Done));
            }
            app.result = None;
            app.exported = None;
            app.screen = Screen::NewCustomer;
            app.notice = None;
        }
        (KeyCode::Esc, _) | (_, Some('b')) => {
            app.screen = Screen::Measuring;
            if let Some(s) = app.session.as_mut() {
                if s.marked_done {
                    s.marked_done = false;
                    fx.push(Effect::SetStatus(s.id, SessionStatus::Open));
                }
            }
        }
        _ => {}
    }
}

fn on_key_history(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    let h = &mut app.history;
    let n = h.sessions.len();
    if let Some(id) = h.confirm_delete {
        match plain(&key) {
            Some('y') => {
                h.confirm_delete = None;
                h.loading = true;
                fx.push(Effect::DeleteSession(id));
                if app.session.as_ref().map(|s| s.id) == Some(id) {
                    app.session = None;
                    app.result = None;
                    app.back_to = Screen::NewCustomer;
                }
                app.note(Level::Info, format!("Session {id} deleted"));
            }
            _ => {
                h.confirm_delete = None;
                app.note(Level::Info, "Kept the session");
            }
        }
        return;
    }
    let selected = h.sessions.get(h.selected).map(|s| s.session.id);
    match (key.code, plain(&key)) {
        (KeyCode::Up, _) | (_, Some('k')) => h.selected = h.selected.saturating_sub(1),
        (KeyCode::Down, _) | (_, Some('j')) => {
            h.selected = (h.selected + 1).min(n.saturating_sub(1))
        }
        (KeyCode::Esc, _) | (_, Some('b')) => {
            app.screen = if app.back_to == Screen::History {
                Screen::NewCustomer
            } else {
                app.back_to
            };
        }
        (KeyCode::Enter, _) | (_, Some('o')) => {
            if let Some(id) = selected {
                app.after_open = Some(AfterOpen::Measure);
                fx.push(Effect::OpenSession(id));
            }
        }
        (_, Some('e')) => {
            if let Some(id) = selected {
                app.after_open = Some(AfterOpen::Estimate);
                fx.push(Effect::OpenSession(id));
            }
        }
        (_, Some('x')) => {
            if let Some(id) = selected {
                app.after_open = Some(AfterOpen::Export);
                fx.push(Effect::OpenSession(id));
            }
        }
        (KeyCode::Delete, _) | (_, Some('D')) => {
            if let Some(id) = selected {
                h.confirm_delete = Some(id);
            }
        }
        (_, Some('r')) => {
            h.loading = true;
            fx.push(Effect::LoadHistory);
        }
        _ => {}
    }
}

fn on_link(app: &mut App, ev: LinkEvent, fx: &mut Vec<Effect>) {
    let d = &mut app.device;
    match ev {
        LinkEvent::PortOpened { path } => {
            d.connection = Connection::PortOpen(path.display().to_string())
        }
        LinkEvent::Connected(h) => {
            let was_down = matches!(d.connection, Connection::Disconnected(_));
            d.connection = Connection::Connected;
            d.hello = Some(h);
            if was_down {
                app.note(
                    Level::Info,
                    "Tape reconnected: carry on (readings it held are being stored)",
                );
            }
        }
        LinkEvent::VersionMismatch(m) => d.connection = Connection::Mismatch(m.to_string()),
        LinkEvent::Live(l) => d.live = Some(l),
        LinkEvent::ReadingCommitted {
            reading,
            unit_shown,
        } => {
            let Some(s) = app.session.as_mut() else {
                return;
            };
            if reading.session_id != s.id {
                return;
            }
            let v = reading.device.value_tenth_mm;
            let Some(i) = s.index_of(&reading.measurement) else {
                app.note(
                    Level::Warn,
                    format!(
                        "Stored {} as {} (not in this set)",
                        app.unit.format(v),
                        reading.measurement
                    ),
                );
                return;
            };
            let before = s.items[i].clone();
            let mut reverts = vec![StoreRevert::Withdraw(reading.id)];
            if let Some(mark) = stored_mark(&before) {
                // A new reading replaces a skip or a kept flag.
                reverts.push(StoreRevert::Mark(before.info.name.clone(), Some(mark)));
                fx.push(Effect::SetMark {
                    session: s.id,
                    name: before.info.name.clone(),
                    mark: None,
                });
            }
            s.undo.push(UndoEntry {
                what: format!("reading of {}", before.info.label),
                reverts,
                item: Some((i, before)),
                current: s.current,
            });
            let item = &mut s.items[i];
            if let Some(old) = item.value {
                item.previous.push(old);
            }
            item.value = Some(v);
            item.state = ItemState::Checking;
            item.flag = None;
            item.unit_slip = None;
            item.kept_flagged = false;
            let others = other_values(&s.items, i, |it| {
                matches!(it.state, ItemState::Done | ItemState::Flagged)
            });
            fx.push(Effect::Check(CheckRequest {
                set: s.set.clone(),
                name: reading.measurement.clone(),
                value_mm: f64::from(v) / 10.0,
                others,
                tape_inches: unit_shown == UnitShown::Imperial,
            }));
            let label = s.items[i].info.label.clone();
            let was = s.items[i].previous.last().copied();
            let shown = match unit_shown {
                UnitShown::Metric => "",
                UnitShown::Imperial => " (tape showing inches)",
            };
            let retake = match was {
                Some(w) => format!(" (retake; was {})", app.unit.format(w)),
                None => String::new(),
            };
            app.note(
                Level::Info,
                format!("Stored {label} = {}{retake}{shown}", app.unit.format(v)),
            );
        }
        LinkEvent::Duplicate { .. } | LinkEvent::Pong { .. } => {}
        LinkEvent::Gap { expected, got, .. } => {
            app.note(
                Level::Warn,
                format!("Tape sent reading {got} before {expected}: waiting for it to resend"),
            );
        }
        LinkEvent::ReadingUnassigned { reading, .. } => {
            app.note(
                Level::Warn,
                format!(
                    "The tape holds a reading ({}): it is kept on the tape until a measurement is chosen",
                    app.unit.format(reading.value_tenth_mm)
                ),
            );
        }
        LinkEvent::CommitFailed { reading, error } => app.note(
            Level::Error,
            format!(
                "Could not store {} ({error}); the tape keeps it",
                app.unit.format(reading.value_tenth_mm)
            ),
        ),
        LinkEvent::Button(b) => {
            use tapeshape_protocol::ButtonKind;
            let key = match b {
                ButtonKind::Next => KeyCode::Char('s'),
                ButtonKind::Back => KeyCode::Char('u'),
                ButtonKind::Redo => KeyCode::Char('r'),
            };
            if app.screen == Screen::Measuring {
                // The tape's buttons act like the keys; the cursor is on the
                // current measurement for a redo.
                if b == ButtonKind::Redo {
                    if let Some(s) = app.session.as_mut() {
                        if let Some(c) = s.current {
                            s.selected = c;
                        }
                    }
                }
                on_key_measuring(app, KeyEvent::from(key), fx);
            }
        }
        LinkEvent::Status(st) => d.queue = Some((st.queue_len, st.queue_capacity)),
        LinkEvent::Fault(f) => {
            let text = crate::cli::station::describe_fault(&f);
            d.faults.push_back(text.clone());
            while d.faults.len() > FAULTS_KEPT {
                d.faults.pop_front();
            }
            if matches!(f, tapeshape_protocol::Fault::QueueFull { .. }) {
                app.note(Level::Error, text);
            }
        }
        LinkEvent::BadFrame { counters, .. } => d.bad_frames = counters.frames_bad,
        LinkEvent::Disconnected { reason, counters } => {
            d.connection = Connection::Disconnected(reason);
            d.disconnects = counters.disconnects;
            d.live = None;
        }
        LinkEvent::WaitingForPort { error } => {
            if !matches!(d.connection, Connection::Disconnected(_)) {
                d.connection = Connection::WaitingForPort(error);
            }
        }
        LinkEvent::Stopped => d.connection = Connection::Stopped,
    }
}

/// The mark the store keeps for an item in this state, if any.
fn stored_mark(item: &Item) -> Option<Mark> {
    if item.state == ItemState::Skipped {
        Some(Mark::Skipped)
    } else if item.kept_flagged {
        Some(Mark::KeptFlagged)
    } else {
        None
    }
}

/// A reading the check flagged before a restart, and that the operator had
/// not answered (kept with Enter, or retaken), must come back flagged: the
/// store keeps only answers (`Mark::KeptFlagged`), so every resumed reading
/// without that mark is checked again against the other resumed readings.
/// The check depends only on the values, so a reading that passed passes
/// again; the tape's unit at capture is not stored, so a unit slip is looked
/// for as on a metric tape.
fn recheck_resumed(app: &mut App, fx: &mut Vec<Effect>) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    let taken: Vec<(usize, u32)> = s
        .items
        .iter()
        .enumerate()
        .filter(|(_, it)| it.state == ItemState::Done && !it.kept_flagged)
        .filter_map(|(k, it)| it.value.map(|v| (k, v)))
        .collect();
    for &(i, v) in &taken {
        let others = other_values(&s.items, i, |_| true);
        fx.push(Effect::Check(CheckRequest {
            set: s.set.clone(),
            name: s.items[i].info.name.clone(),
            value_mm: f64::from(v) / 10.0,
            others,
            tape_inches: false,
        }));
    }
    for &(i, _) in &taken {
        s.items[i].state = ItemState::Checking;
    }
}

/// The values (mm) of the items other than `i` that have one and pass
/// `include`: what a reading is checked against.
fn other_values(items: &[Item], i: usize, include: impl Fn(&Item) -> bool) -> Vec<(String, f64)> {
    items
        .iter()
        .enumerate()
        .filter(|(k, it)| *k != i && include(it))
        .filter_map(|(_, it)| {
            it.value
                .map(|v| (it.info.name.clone(), f64::from(v) / 10.0))
        })
        .collect()
}

fn on_checked(app: &mut App, name: &str, value_tenth_mm: u32, outcome: CheckOutcome) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    let Some(i) = s.index_of(name) else { return };
    let item = &mut s.items[i];
    if item.value != Some(value_tenth_mm) || item.state != ItemState::Checking {
        return; // retaken or undone meanwhile
    }
    item.flag = outcome.flag;
    item.unit_slip = outcome.unit_slip;
    if item.flag.is_some() || item.unit_slip.is_some() {
        item.state = ItemState::Flagged;
        s.current = Some(i);
        s.selected = i;
        let label = item.info.label.clone();
        let what = if item.flag.is_some() {
            "far off."
        } else {
            "unit slip?"
        };
        app.note(
            Level::Warn,
            format!("{label}: {what} Measure again, or Enter to keep it"),
        );
    } else {
        item.state = ItemState::Done;
        let note = outcome.note;
        if s.current == Some(i) {
            advance(app);
        }
        if let Some(n) = note {
            app.note(Level::Warn, n);
        }
    }
}

fn on_estimate(app: &mut App, ev: EstimateEvent, fx: &mut Vec<Effect>) {
    match ev {
        EstimateEvent::Stage { stage, fraction } => {
            if !app.estimate.stages.contains(&stage) {
                app.estimate.stages.push(stage);
            }
            app.estimate.fraction = fraction.clamp(0.0, 1.0);
        }
        EstimateEvent::Done(summary) => {
            app.estimate.running = false;
            app.estimate.fraction = 1.0;
            let export = app.after_open.take() == Some(AfterOpen::Export);
            let session = summary.session;
            app.result = Some(*summary);
            app.exported = None;
            app.notice = None;
            if app.screen == Screen::Estimating {
                app.screen = Screen::Result;
            }
            if export {
                fx.push(Effect::Export {
                    session,
                    format: app.export_format,
                });
            }
        }
        EstimateEvent::Failed(msg) => {
            app.estimate.running = false;
            app.after_open = None;
            app.estimate.error = Some(msg);
        }
        EstimateEvent::Cancelled => {
            app.estimate = EstimateState::default();
            app.after_open = None;
            app.screen = Screen::Measuring;
            app.note(
                Level::Info,
                "Estimate cancelled; the readings are unchanged",
            );
        }
    }
}
