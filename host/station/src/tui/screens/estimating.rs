//! The estimating screen: the estimate's stages with progress; Esc cancels;
//! a refusal says which readings to retake.

use crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::Line;
use ratatui::widgets::{Block, Gauge, Paragraph, Wrap};
use ratatui::Frame;

use crate::i18n::{msg, tr};
use crate::services::{EstimateEvent, Stage, STAGES};
use crate::tui::app::{action, AfterOpen, App, Effect, Global, Level, Screen};
use crate::tui::keys::{code, hints as hints_of, Binding, Hint};
use crate::tui::theme::{st, Role};

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

/// What the screen's keys do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    Cancel,
    Back,
}

fn bindings(app: &App) -> Vec<Binding<Action>> {
    if app.estimate.running {
        vec![Binding::new(
            &[code(KeyCode::Esc)],
            msg!("key-esc"),
            msg!("estimating-cancel"),
            msg!("estimating-cancel-help"),
            Action::Cancel,
        )]
    } else {
        vec![Binding::new(
            &[code(KeyCode::Esc)],
            msg!("key-esc"),
            msg!("estimating-back"),
            msg!("estimating-back-help"),
            Action::Back,
        )]
    }
}

/// The keys that work anywhere that the footer shows here (none: the
/// estimate is short, and Esc is the one thing to do).
pub const FOOTER_GLOBALS: &[Global] = &[];

/// The screen's keys, with their words.
pub fn hints(app: &App) -> Vec<Hint> {
    hints_of(&bindings(app))
}

/// A key on the estimating screen.
pub fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    match action(&bindings(app), &key) {
        Some(Action::Cancel) => {
            app.estimate.cancelling = true;
            fx.push(Effect::CancelEstimate);
        }
        Some(Action::Back) => app.screen = Screen::Measuring,
        None => {}
    }
}

/// Progress of the running estimate.
pub fn on_estimate(app: &mut App, ev: EstimateEvent, fx: &mut Vec<Effect>) {
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
            app.result.summary = Some(*summary);
            app.result.exported = None;
            app.result.card = None;
            app.result.stored = None;
            app.notice = None;
            if app.screen == Screen::Estimating {
                app.screen = Screen::Result;
            }
            if export {
                fx.push(Effect::Export {
                    session,
                    format: app.result.format,
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
            app.note(Level::Info, tr!("estimating-cancelled"));
        }
    }
}

/// A stage of the estimate in the chosen language (the services' own label,
/// `stage_label`, is English, for logs).
fn stage_text(stage: Stage) -> String {
    match stage {
        Stage::Check => tr!("stage-check"),
        Stage::Start => tr!("stage-start"),
        Stage::Step1 => tr!("stage-step1"),
        Stage::Step2 => tr!("stage-step2"),
        Stage::Done => tr!("stage-done"),
    }
}

/// Draws the estimating screen into `area`.
pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let e = &app.estimate;
    let [stages, gauge, msg] = Layout::vertical([
        Constraint::Length(STAGES.len() as u16 + 2),
        Constraint::Length(3),
        Constraint::Min(3),
    ])
    .areas(area);
    let current = e.stages.last().copied();
    let lines: Vec<Line> = STAGES
        .iter()
        .map(|s| {
            let (mark, role) = if !e.stages.contains(s) {
                ("  ", Role::Dim)
            } else if Some(*s) == current && e.running {
                ("> ", Role::Big)
            } else if Some(*s) == current && e.error.is_some() {
                ("x ", Role::Bad)
            } else {
                ("✓ ", Role::Ok)
            };
            Line::styled(format!(" {mark}{}", stage_text(*s)), st(m, role))
        })
        .collect();
    frame.render_widget(
        Paragraph::new(lines)
            .block(Block::bordered().title(format!(" {} ", tr!("estimating-title")))),
        stages,
    );
    frame.render_widget(
        Gauge::default()
            .block(Block::bordered())
            .gauge_style(st(m, Role::Ok))
            .ratio(e.fraction.clamp(0.0, 1.0)),
        gauge,
    );
    let text = if let Some(err) = &e.error {
        vec![
            Line::styled(tr!("estimating-refused"), st(m, Role::Bad)),
            Line::raw(err.clone()),
            Line::raw(""),
            Line::styled(tr!("estimating-refused-back"), st(m, Role::Dim)),
        ]
    } else if e.cancelling {
        vec![Line::styled(
            tr!("estimating-cancelling"),
            st(m, Role::Warn),
        )]
    } else {
        let n = app.session.as_ref().map_or(0, |s| s.accepted().len());
        vec![Line::styled(
            tr!("estimating-fitting", n = n),
            st(m, Role::Dim),
        )]
    };
    frame.render_widget(Paragraph::new(text).wrap(Wrap { trim: true }), msg);
}
