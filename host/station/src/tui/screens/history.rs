//! The history screen (`h`): the stored sessions; Enter reopens one, `v`
//! shows its stored estimate, `e` estimates it again, `x` exports it, Del
//! deletes it after a `y`.

use crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::{Alignment, Constraint, Rect};
use ratatui::text::Line;
use ratatui::widgets::{Block, Cell, Clear, Paragraph, Row, Table};
use ratatui::Frame;

use crate::i18n::{msg, tr};
use crate::store::{SessionId, SessionStatus, SessionSummary};
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
            // `y` in every language: deleting for good asks for a key that
            // is pressed for nothing else here (German's `j` is `down`).
            Binding::new(
                &[ch('y')],
                "y",
                msg!("history-confirm-delete"),
                msg!("history-confirm-delete-help"),
                Action::ConfirmDelete,
            ),
            Binding::new(
                &[Key::Any],
                msg!("key-any"),
                msg!("history-keep"),
                msg!("history-keep-help"),
                Action::KeepIt,
            ),
        ];
    }
    let mut b = vec![
        Binding::help_only(
            &[code(KeyCode::Up), ch('k'), code(KeyCode::Down), ch('j')],
            msg!("key-up-down"),
            msg!("history-move-help"),
            Action::Move,
        ),
        Binding::new(
            &[code(KeyCode::Enter), ch('o')],
            msg!("key-enter"),
            msg!("history-reopen"),
            msg!("history-reopen-help"),
            Action::Reopen,
        ),
    ];
    if h.selected()
        .is_some_and(|s| s.estimate_made_at_ms.is_some())
    {
        b.push(Binding::new(
            &[ch('v')],
            "v",
            msg!("history-result"),
            msg!("history-result-help"),
            Action::ShowResult,
        ));
    }
    b.extend([
        Binding::new(
            &[ch('e')],
            "e",
            msg!("history-estimate"),
            msg!("history-estimate-help"),
            Action::Estimate,
        ),
        Binding::new(
            &[ch('x')],
            "x",
            msg!("history-export"),
            msg!("history-export-help"),
            Action::Export,
        ),
        Binding::new(
            &[code(KeyCode::Delete), ch('D')],
            msg!("key-del"),
            msg!("history-delete"),
            msg!("history-delete-help"),
            Action::Delete,
        ),
        Binding::new(
            &[code(KeyCode::Esc), ch('b')],
            msg!("key-esc"),
            msg!("history-back"),
            msg!("history-back-help"),
            Action::Back,
        ),
        Binding::help_only(&[ch('r')], "r", msg!("history-reload-help"), Action::Reload),
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
            app.note(Level::Info, tr!("history-deleted", id = id.to_string()));
        }
        Action::KeepIt => {
            h.confirm_delete = None;
            app.note(Level::Info, tr!("history-kept"));
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

/// A session's status in the chosen language (the store's word,
/// `SessionStatus::as_str`, is the one the commands print and parse).
fn status_text(status: SessionStatus) -> String {
    match status {
        SessionStatus::Open => tr!("status-open"),
        SessionStatus::Done => tr!("status-done"),
        SessionStatus::Abandoned => tr!("status-abandoned"),
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
                Cell::from(status_text(s.session.status)),
                Cell::from(format!("{:>3}", s.current_readings)),
                Cell::from(t.get(..16).unwrap_or(&t).replace('T', " ")),
            ])
        })
        .collect();
    let title = if h.loading {
        format!(" {} ", tr!("history-title-loading"))
    } else {
        format!(" {} ", tr!("history-title", n = h.sessions.len()))
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
                tr!("history-col-id"),
                tr!("history-col-customer"),
                tr!("history-col-set"),
                tr!("history-col-status"),
                tr!("history-col-readings"),
                tr!("history-col-updated"),
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
            Paragraph::new(tr!("history-empty")).alignment(Alignment::Center),
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
                        " {}",
                        tr!(
                            "history-delete-question",
                            id = id.to_string(),
                            customer = s.map_or("?", |s| s.session.customer_id.as_str()),
                            readings = s.map_or(0, |s| s.current_readings),
                            retaken = s.map_or(0, |s| s.total_readings - s.current_readings)
                        )
                    ),
                    st(m, Role::Big),
                ),
                Line::raw(""),
                hint_line(
                    m,
                    &[
                        hint("y", msg!("history-confirm-delete")),
                        hint(msg!("key-any-other"), msg!("history-keep-it")),
                    ],
                ),
            ])
            .block(
                Block::bordered()
                    .title(format!(" {} ", tr!("history-delete-title")))
                    .border_style(st(m, Role::Bad)),
            ),
            popup,
        );
    }
}
