//! The result screen: front and side braille silhouettes, target / body /
//! error per reading, plausibility, and the export (`x`, in the format `f`
//! chooses, plus the report) and the customer's card (`p`, a PDF in the
//! same folder: `crate::estimate::card`). An estimate stored before a restart is
//! shown here again without estimating again.

use std::path::PathBuf;

use crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::canvas::{Canvas, Points};
use ratatui::widgets::{Block, Cell, Paragraph, Row, Table, Wrap};
use ratatui::Frame;
use tapeshape_estimator::Unit;

use crate::estimate::MeshFormat;
use crate::i18n::{msg, tr};
use crate::services::EstimateSummary;
use crate::session::EstimateInfo;
use crate::store::SessionStatus;
use crate::tui::app::{
    action, toggled, AfterOpen, App, Effect, Global, Level, Screen, ShowLength as _,
};
use crate::tui::keys::{ch, code, hints as hints_of, Binding, Hint};
use crate::tui::theme::{st, Role};

/// The order `f` cycles through the export formats (GLB first: what a
/// viewer opens).
pub const FORMAT_CYCLE: [MeshFormat; 3] = [MeshFormat::Glb, MeshFormat::Obj, MeshFormat::Ply];

/// The result screen's state.
#[derive(Clone, Debug, PartialEq)]
pub struct ResultScreen {
    /// The estimate shown.
    pub summary: Option<EstimateSummary>,
    /// Files of the last export.
    pub exported: Option<Vec<PathBuf>>,
    /// Format of the next export.
    pub format: MeshFormat,
    /// The customer's card last written for the estimate shown.
    pub card: Option<PathBuf>,
    /// The estimate shown was loaded from the store (not just made): when
    /// it was made, and whether it is of the session's current readings.
    pub stored: Option<EstimateInfo>,
}

impl Default for ResultScreen {
    fn default() -> Self {
        Self {
            summary: None,
            exported: None,
            format: FORMAT_CYCLE[0],
            card: None,
            stored: None,
        }
    }
}

/// What the screen's keys do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    Export,
    Format,
    Card,
    Back,
    NextCustomer,
    Units,
}

fn bindings() -> Vec<Binding<Action>> {
    vec![
        Binding::new(
            &[ch('x')],
            "x",
            msg!("result-export"),
            msg!("result-export-help"),
            Action::Export,
        ),
        Binding::new(
            &[ch('f')],
            "f",
            msg!("result-format"),
            msg!("result-format-help"),
            Action::Format,
        ),
        Binding::new(
            &[ch('p')],
            "p",
            msg!("result-card"),
            msg!("result-card-help"),
            Action::Card,
        ),
        Binding::new(
            &[ch('b'), code(KeyCode::Esc)],
            "b",
            msg!("result-back"),
            msg!("result-back-help"),
            Action::Back,
        ),
        Binding::new(
            &[ch('n')],
            "n",
            msg!("result-next-customer"),
            msg!("result-next-customer-help"),
            Action::NextCustomer,
        ),
        Binding::help_only(&[ch('i')], "i", msg!("measuring-units-help"), Action::Units),
    ]
}

/// The keys that work anywhere that the footer shows here.
pub const FOOTER_GLOBALS: &[Global] = &[Global::History, Global::Help];

/// The screen's keys, with their words.
pub fn hints(_app: &App) -> Vec<Hint> {
    hints_of(&bindings())
}

/// A key on the result screen.
pub fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    let Some(a) = action(&bindings(), &key) else {
        return;
    };
    match a {
        Action::Export => {
            if let Some(s) = &app.session {
                fx.push(Effect::Export {
                    session: s.id,
                    format: app.result.format,
                });
                app.note(Level::Info, tr!("result-exporting"));
            }
        }
        Action::Card => {
            if let Some(s) = &app.session {
                fx.push(Effect::Card {
                    session: s.id,
                    unit: app.unit,
                });
                app.note(Level::Info, tr!("result-writing-card"));
            }
        }
        Action::Format => {
            let i = FORMAT_CYCLE
                .iter()
                .position(|f| *f == app.result.format)
                .unwrap_or(0);
            app.result.format = FORMAT_CYCLE[(i + 1) % FORMAT_CYCLE.len()];
        }
        Action::Units => app.unit = toggled(app.unit),
        Action::NextCustomer => {
            if let Some(s) = app.session.take() {
                fx.push(Effect::SetStatus(s.id, SessionStatus::Done));
            }
            app.result = ResultScreen {
                format: app.result.format,
                ..ResultScreen::default()
            };
            app.screen = Screen::NewCustomer;
            app.notice = None;
        }
        Action::Back => {
            app.screen = Screen::Measuring;
            if let Some(s) = app.session.as_mut() {
                if s.marked_done {
                    s.marked_done = false;
                    fx.push(Effect::SetStatus(s.id, SessionStatus::Open));
                }
            }
        }
    }
}

/// A stored estimate was loaded ([`Effect::LoadResult`]): shown, and
/// exported if that is what was asked.
pub fn on_loaded(app: &mut App, r: Result<EstimateSummary, String>, fx: &mut Vec<Effect>) {
    match r {
        Ok(summary) => {
            let session = summary.session;
            app.result.summary = Some(summary);
            app.result.exported = None;
            app.result.card = None;
            app.screen = Screen::Result;
            let when = app
                .result
                .stored
                .map(|e| (crate::text::format_time_ms(e.made_at_ms), e.current));
            match when {
                Some((t, true)) => app.note(Level::Info, tr!("result-stored", time = t)),
                Some((t, false)) => app.note(Level::Warn, tr!("result-stored-earlier", time = t)),
                None => app.notice = None,
            }
            if app.after_open.take() == Some(AfterOpen::Export) {
                fx.push(Effect::Export {
                    session,
                    format: app.result.format,
                });
            }
        }
        Err(e) => {
            app.after_open = None;
            app.note(Level::Error, e);
        }
    }
}

/// An export finished ([`Effect::Export`]): the session is marked done.
pub fn on_exported(app: &mut App, r: Result<Vec<PathBuf>, String>, fx: &mut Vec<Effect>) {
    match r {
        Ok(files) => {
            app.note(
                Level::Info,
                tr!(
                    "result-exported-notice",
                    n = files.len(),
                    dir = files
                        .first()
                        .and_then(|f| f.parent())
                        .map(|p| p.display().to_string())
                        .unwrap_or_default()
                ),
            );
            app.result.exported = Some(files);
            if let Some(s) = app.session.as_mut() {
                s.marked_done = true;
                fx.push(Effect::SetStatus(s.id, SessionStatus::Done));
            }
        }
        Err(e) => app.note(Level::Error, tr!("result-export-failed", error = e)),
    }
}

/// A card was written ([`Effect::Card`]), or not: where it went, or why
/// not. Nothing else changes (a failed card loses nothing: the session and
/// its estimate are in the store).
pub fn on_card(app: &mut App, r: Result<PathBuf, String>) {
    match r {
        Ok(path) => {
            app.note(
                Level::Info,
                tr!("result-card-written", path = path.display().to_string()),
            );
            app.result.card = Some(path);
        }
        Err(e) => app.note(Level::Error, tr!("result-card-failed", error = e)),
    }
}

/// Canvas bounds that keep the body's proportions in a `w` x `h` cell area
/// (a braille cell is 2x4 dots and about twice as tall as wide, so dots are
/// about square).
fn bounds(points: &[(f64, f64)], w: u16, h: u16) -> ([f64; 2], [f64; 2]) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in points {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if points.is_empty() {
        return ([-1.0, 1.0], [0.0, 2.0]);
    }
    let dots_w = f64::from(w.max(1)) * 2.0;
    let dots_h = f64::from(h.max(1)) * 4.0;
    let span_y = (y1 - y0).max(1e-3) * 1.04;
    let span_x = (x1 - x0).max(1e-3) * 1.04;
    // metres per dot: whichever direction needs more.
    let per_dot = (span_y / dots_h).max(span_x / dots_w);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    (
        [cx - per_dot * dots_w / 2.0, cx + per_dot * dots_w / 2.0],
        [cy - per_dot * dots_h / 2.0, cy + per_dot * dots_h / 2.0],
    )
}

/// A braille silhouette of `points` in `area` (also the measuring
/// screen's live estimate).
pub(crate) fn silhouette<'a>(
    mono: bool,
    points: &'a [(f64, f64)],
    title: &'a str,
    area: Rect,
) -> impl ratatui::widgets::Widget + 'a {
    let (xb, yb) = bounds(
        points,
        area.width.saturating_sub(2),
        area.height.saturating_sub(2),
    );
    let color = if mono { Color::Reset } else { Color::Cyan };
    Canvas::default()
        .block(Block::bordered().title(title))
        .marker(Marker::Braille)
        .x_bounds(xb)
        .y_bounds(yb)
        .paint(move |ctx| {
            ctx.draw(&Points {
                coords: points,
                color,
            })
        })
}

/// Draws the result screen into `area`.
pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let Some(r) = &app.result.summary else {
        frame.render_widget(Paragraph::new(tr!("result-none")), area);
        return;
    };
    let [front, side, right] = Layout::horizontal([
        Constraint::Length(20),
        Constraint::Length(12),
        Constraint::Min(30),
    ])
    .areas(area);
    let (front_title, side_title) = (
        format!(" {} ", tr!("result-front")),
        format!(" {} ", tr!("result-side")),
    );
    frame.render_widget(
        silhouette(m, &r.silhouettes.front, &front_title, front),
        front,
    );
    frame.render_widget(silhouette(m, &r.silhouettes.side, &side_title, side), side);

    // The sizes box: as many rows as its lines take wrapped (a garment's
    // line with its misfits may need two), and its borders.
    let sizes = Paragraph::new(
        r.sizes
            .iter()
            .map(|l| Line::raw(l.clone()))
            .collect::<Vec<_>>(),
    )
    .wrap(Wrap { trim: true });
    let sizes_height = if r.sizes.is_empty() {
        0
    } else {
        u16::try_from(sizes.line_count(right.width.saturating_sub(2)) + 2).unwrap_or(u16::MAX)
    };
    // The table keeps every row when it can (an operator checks each
    // measurement against its target): it takes its rows and borders
    // first, the sizes their lines, and the plausibility and warnings what
    // is left, at least three lines; only on a screen too small for that
    // does the table give up rows (down to four lines).
    let table_height = u16::try_from(r.rows.len() + 3)
        .unwrap_or(u16::MAX)
        .min(right.height.saturating_sub(sizes_height.saturating_add(3)))
        .max(4);
    let [table_area, sizes_area, info] = Layout::vertical([
        Constraint::Length(table_height),
        Constraint::Length(sizes_height),
        Constraint::Min(0),
    ])
    .areas(right);
    if !r.sizes.is_empty() {
        frame.render_widget(
            sizes.block(Block::bordered().title(format!(" {} ", tr!("result-sizes")))),
            sizes_area,
        );
    }
    let u = app.unit;
    let inches = u == Unit::In;
    let rows: Vec<Row> = r
        .rows
        .iter()
        .map(|row| {
            let err = row.achieved_mm - row.target_mm;
            let label = app
                .session
                .as_ref()
                .and_then(|s| s.items.iter().find(|i| i.info.name == row.name))
                .map_or(row.name.as_str(), |i| i.info.label.as_str());
            Row::new(vec![
                Cell::from(label.chars().take(18).collect::<String>()),
                Cell::from(u.format_mm(row.target_mm)),
                Cell::from(u.format_mm(row.achieved_mm)),
                Cell::from(if inches {
                    format!("{:+.2}", err / 25.4)
                } else {
                    format!("{err:+.1}")
                })
                .style(if err.abs() > 10.0 {
                    st(m, Role::Warn)
                } else {
                    Style::default()
                }),
            ])
        })
        .collect();
    frame.render_widget(
        Table::new(
            rows,
            [
                Constraint::Min(12),
                Constraint::Length(9),
                Constraint::Length(9),
                Constraint::Length(6),
            ],
        )
        .header(
            Row::new(vec![
                tr!("result-col-measurement"),
                tr!("result-col-target"),
                tr!("result-col-body"),
                if inches {
                    tr!("result-col-error-in")
                } else {
                    tr!("result-col-error-mm")
                },
            ])
            .style(st(m, Role::Dim)),
        )
        .column_spacing(1)
        .block(Block::bordered().title(format!(
            " {} ",
            tr!("result-title", seconds = format!("{:.1}", r.seconds))
        ))),
        table_area,
    );
    let mut lines = vec![Line::from(vec![
        Span::styled(format!("{} ", tr!("result-plausibility")), st(m, Role::Dim)),
        Span::raw(r.plausibility.clone()),
    ])];
    // Careful mode: how repeatable the measuring was (ISO 20685-1 TEM).
    if let Some(t) = app
        .session
        .as_ref()
        .filter(|s| s.careful && s.id == r.session)
        .and_then(|s| s.careful_tem())
    {
        lines.push(Line::from(vec![
            Span::styled(format!("{} ", tr!("result-careful")), st(m, Role::Dim)),
            Span::raw(tr!(
                "result-tem",
                tem = format!("{:.1}", t.tem_mm),
                percent = format!("{:.2}", t.relative_percent),
                pairs = t.pairs
            )),
        ]));
    }
    if let Some(w) = r.warnings.first() {
        lines.push(Line::styled(
            format!(
                "! {w}{}",
                if r.warnings.len() > 1 {
                    format!(
                        " ({})",
                        tr!("result-more-warnings", n = r.warnings.len() - 1)
                    )
                } else {
                    String::new()
                }
            ),
            st(m, Role::Warn),
        ));
    }
    match &app.result.exported {
        Some(files) => {
            let names: Vec<String> = files
                .iter()
                .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
                .collect();
            lines.push(Line::styled(
                tr!("result-exported", files = names.join(", ")),
                st(m, Role::Ok),
            ));
            if let Some(dir) = files.first().and_then(|f| f.parent()) {
                lines.push(Line::styled(
                    tr!("result-exported-in", dir = dir.display().to_string()),
                    st(m, Role::Dim),
                ));
            }
        }
        None => lines.push(Line::from(vec![
            Span::styled("x", st(m, Role::Key)),
            Span::raw(format!(
                " {}  ",
                tr!(
                    "result-export-hint",
                    format = app.result.format.ext().to_uppercase()
                )
            )),
            Span::styled("f", st(m, Role::Key)),
            Span::raw(format!(" {}", tr!("result-other-format"))),
        ])),
    }
    if let Some(name) = app.result.card.as_ref().and_then(|c| c.file_name()) {
        lines.push(Line::styled(
            tr!(
                "result-card-file",
                file = name.to_string_lossy().into_owned()
            ),
            st(m, Role::Ok),
        ));
    }
    frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: true }), info);
}
