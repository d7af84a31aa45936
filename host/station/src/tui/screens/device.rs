//! The device screen (`d`): the tape's port, connection, device id, boot,
//! firmware and protocol versions, queue, bad frames, connections lost and
//! recent faults. Its state ([`DeviceState`]) is also what the top bar,
//! the banner and the measuring screen's live value read.

use std::collections::VecDeque;

use crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Paragraph, Wrap};
use ratatui::Frame;
use tapeshape_protocol::{DeviceHello, Live};

use crate::i18n::{msg, tr};
use crate::link::LinkEvent;
use crate::tui::app::{action, App, Global, Level, ShowLength as _};
use crate::tui::keys::{ch, code, hints as hints_of, Binding, Hint};
use crate::tui::theme::{kv, st, Role};

/// Most recent device faults kept for the device screen.
pub const FAULTS_KEPT: usize = 6;

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
    /// The state before the link said anything.
    pub fn new(port: String) -> Self {
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

    /// Takes in a link event about the tape; returns a notice to show, if any.
    pub fn on_link(&mut self, ev: LinkEvent) -> Option<(Level, String)> {
        match ev {
            LinkEvent::PortOpened { path } => {
                self.connection = Connection::PortOpen(path.display().to_string())
            }
            LinkEvent::Connected(h) => {
                let was_down = matches!(self.connection, Connection::Disconnected(_));
                self.connection = Connection::Connected;
                self.hello = Some(h);
                if was_down {
                    return Some((Level::Info, tr!("device-reconnected")));
                }
            }
            LinkEvent::VersionMismatch(m) => self.connection = Connection::Mismatch(m.to_string()),
            LinkEvent::Live(l) => self.live = Some(l),
            LinkEvent::Status(st) => self.queue = Some((st.queue_len, st.queue_capacity)),
            LinkEvent::Fault(f) => {
                let text = crate::text::describe_fault(&f);
                self.faults.push_back(text.clone());
                while self.faults.len() > FAULTS_KEPT {
                    self.faults.pop_front();
                }
                if matches!(f, tapeshape_protocol::Fault::QueueFull { .. }) {
                    return Some((Level::Error, text));
                }
            }
            LinkEvent::BadFrame { counters, .. } => self.bad_frames = counters.frames_bad,
            LinkEvent::Disconnected { reason, counters } => {
                self.connection = Connection::Disconnected(reason.to_string());
                self.disconnects = counters.disconnects;
                self.live = None;
            }
            LinkEvent::WaitingForPort { error } => {
                if !matches!(self.connection, Connection::Disconnected(_)) {
                    self.connection = Connection::WaitingForPort(error.to_string());
                }
            }
            LinkEvent::Stopped => self.connection = Connection::Stopped,
            // Readings, buttons and their troubles are the app's (measuring).
            LinkEvent::ReadingCommitted { .. }
            | LinkEvent::Duplicate { .. }
            | LinkEvent::Gap { .. }
            | LinkEvent::ReadingUnassigned { .. }
            | LinkEvent::CommitFailed { .. }
            | LinkEvent::Button(_)
            | LinkEvent::Pong { .. } => {}
        }
        None
    }

    /// The connection in a word or two (the chosen language), and how to
    /// show it.
    pub fn word(&self) -> (String, Role) {
        match &self.connection {
            Connection::Starting => (tr!("connection-starting"), Role::Dim),
            Connection::WaitingForPort(_) => (tr!("connection-waiting"), Role::Warn),
            Connection::PortOpen(_) => (tr!("connection-port-open"), Role::Warn),
            Connection::Connected => (tr!("connection-connected"), Role::Ok),
            Connection::Mismatch(_) => (tr!("connection-mismatch"), Role::Bad),
            Connection::Disconnected(_) => (tr!("connection-disconnected"), Role::Bad),
            Connection::Stopped => (tr!("connection-stopped"), Role::Dim),
        }
    }
}

/// What the device screen's keys do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    Back,
}

fn bindings() -> Vec<Binding<Action>> {
    vec![Binding::new(
        &[code(KeyCode::Esc), ch('b'), ch('d')],
        msg!("key-esc"),
        msg!("device-back"),
        msg!("device-back-help"),
        Action::Back,
    )]
}

/// The keys that work anywhere that the footer shows here.
pub const FOOTER_GLOBALS: &[Global] = &[Global::History, Global::Help, Global::Quit];

/// The device screen's keys, with their words.
pub fn hints(_app: &App) -> Vec<Hint> {
    hints_of(&bindings())
}

/// A key on the device screen.
pub fn on_key(app: &mut App, key: KeyEvent) {
    match action(&bindings(), &key) {
        Some(Action::Back) => app.screen = app.back_to,
        None => {}
    }
}

/// Draws the device screen into `area`.
pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let d = &app.device;
    let (word, role) = d.word();
    let mut lines = vec![
        kv(m, &tr!("device-port"), d.port.clone()),
        Line::from(vec![
            Span::styled(format!("{:<16}", tr!("device-state")), st(m, Role::Dim)),
            Span::styled(word, st(m, role)),
        ]),
    ];
    match &d.connection {
        Connection::WaitingForPort(e) | Connection::Disconnected(e) | Connection::Mismatch(e) => {
            lines.push(kv(m, &tr!("device-why"), e.clone()))
        }
        _ => {}
    }
    if let Some(h) = &d.hello {
        lines.push(kv(m, &tr!("device-id"), format!("{:016x}", h.device_id)));
        lines.push(kv(m, &tr!("device-boot"), h.boot_id.to_string()));
        lines.push(kv(
            m,
            &tr!("device-firmware"),
            format!(
                "{}.{}.{}",
                h.firmware.major, h.firmware.minor, h.firmware.patch
            ),
        ));
        lines.push(kv(
            m,
            &tr!("device-protocol"),
            format!("{}.{}", h.protocol.major, h.protocol.minor),
        ));
    } else {
        lines.push(kv(m, &tr!("device-device"), tr!("device-no-hello")));
    }
    lines.push(kv(
        m,
        &tr!("device-host"),
        tr!(
            "device-host-value",
            version = env!("CARGO_PKG_VERSION"),
            protocol = format!(
                "{}.{}",
                tapeshape_protocol::PROTOCOL_VERSION.major,
                tapeshape_protocol::PROTOCOL_VERSION.minor
            )
        ),
    ));
    if let Some((n, cap)) = d.queue {
        lines.push(kv(
            m,
            &tr!("device-queue"),
            tr!("device-queue-value", n = n, capacity = cap),
        ));
    }
    lines.push(kv(
        m,
        &tr!("device-link"),
        tr!(
            "device-link-value",
            bad = d.bad_frames,
            lost = d.disconnects
        ),
    ));
    if let Some(l) = d.live {
        lines.push(kv(
            m,
            &tr!("device-live"),
            app.unit.format(l.value_tenth_mm),
        ));
    }
    lines.push(Line::raw(""));
    lines.push(Line::styled(tr!("device-faults"), st(m, Role::Title)));
    if d.faults.is_empty() {
        lines.push(Line::styled(
            format!("  {}", tr!("device-no-faults")),
            st(m, Role::Dim),
        ));
    }
    for f in &d.faults {
        lines.push(Line::styled(format!("  {f}"), st(m, Role::Warn)));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(format!(" {} ", tr!("device-title")))),
        area,
    );
}
