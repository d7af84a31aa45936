//! The history screen (`h`): the stored sessions; Enter reopens one, `v`
//! shows its stored estimate, `e` estimates it again, `x` exports it, Del
//! deletes it after a `y`.

use crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::{Alignment, Constraint, Rect};
use ratatui::text::Line;
use ratatui::widgets::{Block, Cell, Clear, Paragraph, Row, Table};
use ratatui::Frame;

use crate::store::{SessionId, SessionSummary};
use crate::tui::app::{action, AfterOpen, App, Effect, Global, Level, Screen};
use crate::tui::keys::{ch, code, hints as hints_of, Binding, Hint, Key};
use crate::tui::theme::{centered, hint, hint_line, st, Role};

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

impl HistoryState {
    fn selected(&self) -> Option<&SessionSummary> {
        self.sessions.get(self.selected)
    }
}

/// What the screen's keys do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    ConfirmDelete,
    KeepIt,
    Move,
    Reopen,
    ShowResult,
    Estimate,
    Export,
    Delete,
    Back,
    Reload,
}

fn bindings(app: &App) -> Vec<Binding<Action>> {
    let h = &app.history;
    if h.confirm_delete.is_some() {
        return vec![
            Binding::new(
                &[ch('y')],
                "y",
                "delete",
                "delete it for good",
                Action::ConfirmDelete,
            ),
            Binding::new(&[Key::Any], "any key", "keep", "keep it", Action::KeepIt),
        ];
    }
    let mut b = vec![
        Binding::help_only(
            &[code(KeyCode::Up), ch('k'), code(KeyCode::Down), ch('j')],
            "up/down",
            "choose a session in the list (also k / j)",
            Action::Move,
        ),
        Binding::new(
            &[code(KeyCode::Enter), ch('o')],
            "Enter",
            "reopen",
            "reopen the session to measure (also o)",
            Action::Reopen,
        ),
    ];
    if h.selected()
        .is_some_and(|s| s.estimate_made_at_ms.is_some())
    {
        b.push(Binding::new(
            &[ch('v')],
            "v",
            "result",
            "show its stored estimate (nothing is estimated again)",
            Action::ShowResult,
        ));
    }
    b.extend([
        Binding::new(
            &[ch('e')],
            "e",
            "estimate",
            "estimate the session again",
            Action::Estimate,
        ),
        Binding::new(
            &[ch('x')],
            "x",
            "export",
            "export it (its stored estimate if that is of its readings)",
            Action::Export,
        ),
        Binding::new(
            &[code(KeyCode::Delete), ch('D')],
            "Del",
            "delete",
            "delete the session (asks first; also D)",
            Action::Delete,
        ),
        Binding::new(
            &[code(KeyCode::Esc), ch('b')],
            "Esc",
            "back",
            "back to the screen before (also b)",
            Action::Back,
        ),
        Binding::help_only(&[ch('r')], "r", "load the list again", Action::Reload),
    ]);
    b
}

/// The keys that work anywhere that the footer shows here (none: the
/// screen's own fill it).
pub const FOOTER_GLOBALS: &[Global] = &[];

/// The screen's keys, with their words.
pub fn hints(app: &App) -> Vec<Hint> {
    hints_of(&bindings(app))
}

/// The history list arrived ([`Effect::LoadHistory`]).
pub fn on_loaded(app: &mut App, list: Vec<SessionSummary>) {
    let h = &mut app.history;
    h.loading = false;
    h.sessions = list;
    h.selected = h.selected.min(h.sessions.len().saturating_sub(1));
}

/// A key on the history screen.
pub fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    let Some(a) = action(&bindings(app), &key) else {
        return;
    };
    let h = &mut app.history;
    let n = h.sessions.len();
    let selected = h.selected().map(|s| s.session.id);
    let mut open = |app: &mut App, after: AfterOpen| {
        if let Some(id) = selected {
            app.after_open = Some(after);
            fx.push(Effect::OpenSession(id));
        }
    };
    match a {
        Action::ConfirmDelete => {
            let Some(id) = h.confirm_delete.take() else {
                return;
            };
            h.loading = true;
            fx.push(Effect::DeleteSession(id));
            if app.session.as_ref().map(|s| s.id) == Some(id) {
                app.session = None;
                app.result.summary = None;
                app.back_to = Screen::NewCustomer;
            }
            app.note(Level::Info, format!("Session {id} deleted"));
        }
        Action::KeepIt => {
            h.confirm_delete = None;
            app.note(Level::Info, "Kept the session");
        }
        Action::Move if crate::tui::screens::measuring::up(&key) => {
            h.selected = h.selected.saturating_sub(1)
        }
        Action::Move => h.selected = (h.selected + 1).min(n.saturating_sub(1)),
        Action::Back => {
            app.screen = if app.back_to == Screen::History {
                Screen::NewCustomer
            } else {
                app.back_to
            };
        }
        Action::Reopen => open(app, AfterOpen::Measure),
        Action::ShowResult => {
            // Looking at it does not reopen it.
            if let Some(id) = selected {
                app.after_open = Some(AfterOpen::ShowResult);
                fx.push(Effect::ViewSession(id));
            }
        }
        Action::Estimate => open(app, AfterOpen::Estimate),
        Action::Export => open(app, AfterOpen::Export),
        Action::Delete => h.confirm_delete = selected,
        Action::Reload => {
            h.loading = true;
            fx.push(Effect::LoadHistory);
        }
    }
}

/// Draws the history screen into `area`.
pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let h = &app.history;
    let rows: Vec<Row> = h
        .sessions
        .iter()
        .map(|s| {
            let t = crate::text::format_time_ms(s.session.updated_at_ms);
            Row::new(vec![
                Cell::from(s.session.id.to_string()),
                Cell::from(s.session.customer_id.chars().take(14).collect::<String>()),
                Cell::from(
                    s.session
                        .measurement_set
                        .as_deref()
                        .unwrap_or("-")
                        .chars()
                        .take(8)
                        .collect::<String>(),
                ),
                Cell::from(s.session.status.to_string()),
                Cell::from(format!("{:>3}", s.current_readings)),
                Cell::from(t.get(..16).unwrap_or(&t).replace('T', " ")),
            ])
        })
        .collect();
    let title = if h.loading {
        " Sessions (loading...) ".to_string()
    } else {
        format!(" Sessions ({}) ", h.sessions.len())
    };
    let mut state = ratatui::widgets::TableState::default().with_selected(Some(h.selected));
    frame.render_stateful_widget(
        Table::new(
            rows,
            [
                Constraint::Length(4),
                Constraint::Length(14),
                Constraint::Length(8),
                Constraint::Length(9),
                Constraint::Length(4),
                Constraint::Min(16),
            ],
        )
        .header(
            Row::new(vec![
                "id",
                "customer",
                "set",
                "status",
                "rd",
                "updated (UTC)",
            ])
            .style(st(m, Role::Dim)),
        )
        .row_highlight_style(st(m, Role::Focus))
        .block(Block::bordered().title(title)),
        area,
        &mut state,
    );
    if h.sessions.is_empty() && !h.loading {
        let inner = centered(area, 40, 3);
        frame.render_widget(
            Paragraph::new("No sessions stored yet").alignment(Alignment::Center),
            inner,
        );
    }
    if let Some(id) = h.confirm_delete {
        let popup = centered(area, 60, 6);
        frame.render_widget(Clear, popup);
        let s = h.sessions.iter().find(|s| s.session.id == id);
        frame.render_widget(
            Paragraph::new(vec![
                Line::raw(""),
                Line::styled(
                    format!(
                        " Delete session {id} ({}, {} readings, {} retaken) for good?",
                        s.map_or("?", |s| s.session.customer_id.as_str()),
                        s.map_or(0, |s| s.current_readings),
                        s.map_or(0, |s| s.total_readings - s.current_readings)
                    ),
                    st(m, Role::Big),
                ),
                Line::raw(""),
                hint_line(m, &[hint("y", "delete"), hint("any other key", "keep it")]),
            ])
            .block(
                Block::bordered()
                    .title(" Delete? ")
                    .border_style(st(m, Role::Bad)),
            ),
            popup,
        );
    }
}
