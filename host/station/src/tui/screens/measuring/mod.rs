//! The measuring screen: the set with ✓ done, `!` flagged, `-` skipped,
//! `~` checking and `>` the one the tape's next hold goes to; the current
//! measurement's instruction and the live tape value. Its keys: capture,
//! retake, skip, undo, units, estimate (and in the demo, the simulated
//! tape). The session's state and what happens to it when readings arrive
//! are in its `session` module.

use crossterm::event::{KeyCode, KeyEvent};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, List, ListItem, ListState, Paragraph, Wrap};
use ratatui::Frame;

use crate::i18n::{msg, tr};
use crate::store::Mark;
use crate::tui::app::{action, toggled, App, Effect, Global, Level, Screen, ShowLength as _};
use crate::tui::keys::{ch, code, hints as hints_of, Binding, Hint};
use crate::tui::theme::{hint, hint_line, st, Role};

pub mod big_digits;
pub mod live;
pub mod pictogram;
mod session;

use session::{advance, start_estimate, stored_mark};
pub use session::{
    on_checked, on_reading_stored, on_session_ready, CarefulItem, Item, ItemState, SessionState,
    StoreRevert, UndoEntry,
};

/// What the measuring screen's keys do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    /// The tape's own hold button (listed for the help; the link stores it).
    Hold,
    Move,
    Capture,
    Retake,
    Skip,
    Undo,
    Units,
    Estimate,
    NewCustomer,
    SimTape {
        slip: bool,
    },
}

fn bindings(app: &App) -> Vec<Binding<Action>> {
    let mut b = vec![
        Binding::help_only(
            &[],
            msg!("measuring-hold-key"),
            msg!("measuring-hold-help"),
            Action::Hold,
        ),
        Binding::help_only(
            &[code(KeyCode::Up), ch('k'), code(KeyCode::Down), ch('j')],
            msg!("key-up-down"),
            msg!("measuring-move-help"),
            Action::Move,
        ),
        Binding::new(
            &[code(KeyCode::Enter)],
            msg!("key-enter"),
            msg!("measuring-capture"),
            msg!("measuring-capture-help"),
            Action::Capture,
        ),
        Binding::new(
            &[ch('r'), ch(' ')],
            "r",
            msg!("measuring-retake"),
            msg!("measuring-retake-help"),
            Action::Retake,
        ),
        Binding::new(
            &[ch('s')],
            "s",
            msg!("measuring-skip"),
            msg!("measuring-skip-help"),
            Action::Skip,
        ),
        Binding::new(
            &[ch('u')],
            "u",
            msg!("measuring-undo"),
            msg!("measuring-undo-help"),
            Action::Undo,
        ),
        Binding::new(
            &[ch('i')],
            "i",
            msg!("measuring-units"),
            msg!("measuring-units-help"),
            Action::Units,
        ),
        Binding::new(
            &[ch('e')],
            "e",
            msg!("measuring-estimate"),
            msg!("measuring-estimate-help"),
            Action::Estimate,
        ),
        Binding::help_only(
            &[ch('n')],
            "n",
            msg!("measuring-new-customer-help"),
            Action::NewCustomer,
        ),
    ];
    if app.is_demo() {
        b.push(Binding::new(
            &[ch('m')],
            "m",
            msg!("measuring-sim-tape"),
            msg!("measuring-sim-tape-help"),
            Action::SimTape { slip: false },
        ));
        b.push(Binding::help_only(
            &[ch('M')],
            "M",
            msg!("measuring-sim-slip-help"),
            Action::SimTape { slip: true },
        ));
    }
    b
}

/// The keys that work anywhere that the footer shows here.
pub const FOOTER_GLOBALS: &[Global] = &[Global::Help];

/// The measuring screen's keys, with their words.
pub fn hints(app: &App) -> Vec<Hint> {
    hints_of(&bindings(app))
}

/// A key on the measuring screen (also the tape's buttons: next, back, redo).
pub fn on_key(app: &mut App, key: KeyEvent, fx: &mut Vec<Effect>) {
    let Some(a) = action(&bindings(app), &key) else {
        return;
    };
    let Some(s) = app.session.as_mut() else {
        app.screen = Screen::NewCustomer;
        return;
    };
    let n = s.items.len();
    match a {
        Action::Hold => {}
        Action::Move if up(&key) => s.selected = (s.selected + n - 1) % n.max(1),
        Action::Move => s.selected = (s.selected + 1) % n.max(1),
        Action::Capture => capture(app, fx),
        Action::Skip => {
            let Some(c) = s.current else { return };
            let before = s.items[c].clone();
            let name = before.info.name.clone();
            s.undo.push(UndoEntry {
                what: tr!("measuring-undo-skipped", name = before.info.label.clone()),
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
                app.note(Level::Info, tr!("measuring-skipped", name = label));
            }
        }
        Action::Retake => {
            if n == 0 {
                return;
            }
            let i = s.selected.min(n - 1);
            let before = s.items[i].clone();
            let mut reverts = Vec::new();
            if before.state == ItemState::Skipped {
                session::clear_mark(s.id, &before, Mark::Skipped, &mut reverts, fx);
            }
            s.undo.push(UndoEntry {
                what: tr!("measuring-undo-retake", name = before.info.label.clone()),
                reverts,
                item: Some((i, before)),
                current: s.current,
            });
            if s.items[i].state == ItemState::Skipped {
                s.items[i].state = ItemState::Todo;
            }
            s.current = Some(i);
            let label = s.items[i].info.label.clone();
            app.note(Level::Info, tr!("measuring-retaking", name = label));
        }
        Action::Undo => match s.undo.pop() {
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
                app.note(Level::Info, tr!("measuring-undone", what = entry.what));
            }
            None => app.note(Level::Info, tr!("measuring-nothing-to-undo")),
        },
        Action::Units => app.unit = toggled(app.unit),
        Action::Estimate => start_estimate(app, fx, false),
        Action::NewCustomer => app.screen = Screen::NewCustomer,
        Action::SimTape { slip } => match s.current {
            Some(c) => fx.push(Effect::SimTape {
                name: s.items[c].info.name.clone(),
                slip,
            }),
            None => app.note(Level::Info, tr!("measuring-nothing-left")),
        },
    }
}

/// Is `key` the up half of an up/down binding (up, k)?
pub(crate) fn up(key: &KeyEvent) -> bool {
    matches!(key.code, KeyCode::Up | KeyCode::Char('k'))
}

/// Enter: keep a flagged reading, or store the tape's live value.
fn capture(app: &mut App, fx: &mut Vec<Effect>) {
    let Some(s) = app.session.as_mut() else {
        return;
    };
    let Some(c) = s.current else {
        app.note(Level::Info, tr!("measuring-all-taken-press-e"));
        return;
    };
    let item = &s.items[c];
    match item.state {
        ItemState::Flagged => {
            let before = item.clone();
            let name = item.info.name.clone();
            s.undo.push(UndoEntry {
                what: tr!("measuring-undo-kept", name = item.info.label.clone()),
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
                app.note(Level::Warn, tr!("measuring-kept-flagged", name = label));
            }
        }
        ItemState::Checking => app.note(Level::Info, tr!("measuring-checking")),
        _ => match app.device.live {
            Some(live) if app.device.connected() && live.value_tenth_mm > 0 => {
                fx.push(Effect::CaptureLive {
                    session: s.id,
                    name: item.info.name.clone(),
                    value_tenth_mm: live.value_tenth_mm,
                    unit_shown: live.unit_shown,
                });
            }
            _ => app.note(Level::Warn, tr!("measuring-no-tape-value")),
        },
    }
}

fn mark(state: ItemState) -> &'static str {
    match state {
        ItemState::Todo => " ",
        ItemState::Checking => "~",
        ItemState::Done => "✓",
        ItemState::Flagged => "!",
        ItemState::Skipped => "-",
    }
}

/// The live estimate's silhouette (front) and what it is of.
fn draw_live(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let live = &app.live;
    // What the body is of: the side view's title, or the empty frame's.
    let status = match (&live.shown, live.running, &live.error) {
        (_, true, _) => format!(" {} ", tr!("measuring-live-updating")),
        (_, false, Some(_)) => format!(" {} ", tr!("measuring-live-no-body")),
        (Some((r, _, _)), false, None) => {
            format!(" {} ", tr!("measuring-live-readings", n = r.len()))
        }
        (None, false, None) => String::new(),
    };
    match &live.shown {
        Some((_, _, summary)) => {
            let [front, side] =
                Layout::horizontal([Constraint::Ratio(1, 2), Constraint::Ratio(1, 2)]).areas(area);
            frame.render_widget(
                crate::tui::screens::result::silhouette(
                    m,
                    &summary.silhouettes.front,
                    &format!(" {} ", tr!("measuring-live-body")),
                    front,
                ),
                front,
            );
            frame.render_widget(
                crate::tui::screens::result::silhouette(
                    m,
                    &summary.silhouettes.side,
                    &status,
                    side,
                ),
                side,
            );
        }
        None => frame.render_widget(
            Block::bordered()
                .title(format!(" {}:{status}", tr!("measuring-live-body")))
                .border_style(st(m, Role::Dim)),
            area,
        ),
    }
}

/// Draws the measuring screen into `area`.
pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let Some(s) = &app.session else {
        frame.render_widget(Paragraph::new(tr!("measuring-no-session")), area);
        return;
    };
    let [list_area, detail] =
        Layout::horizontal([Constraint::Length(38), Constraint::Min(20)]).areas(area);
    // The live estimate under the list when the set leaves room (quick at
    // 80x24), else beside the instructions on a wide terminal.
    let live = &app.live;
    let has_live = live.running || live.shown.is_some() || live.error.is_some();
    let list_rows = s.items.len() as u16 + 2;
    let (list_area, detail, live_area) = if has_live && list_area.height >= list_rows + 8 {
        let [l, v] =
            Layout::vertical([Constraint::Length(list_rows), Constraint::Min(8)]).areas(list_area);
        (l, detail, Some(v))
    } else if has_live && detail.width >= 70 {
        let [d, v] =
            Layout::horizontal([Constraint::Min(40), Constraint::Length(30)]).areas(detail);
        (list_area, d, Some(v))
    } else {
        (list_area, detail, None)
    };
    if let Some(v) = live_area {
        draw_live(app, frame, v);
    }
    let items: Vec<ListItem> = s
        .items
        .iter()
        .enumerate()
        .map(|(k, it)| {
            let cur = if s.current == Some(k) { ">" } else { " " };
            let value = it.value.map(|v| app.unit.format(v)).unwrap_or_default();
            let role = match it.state {
                ItemState::Done => Role::Ok,
                ItemState::Flagged => Role::Warn,
                ItemState::Skipped => Role::Dim,
                _ => Role::Big,
            };
            let label: String = it.info.label.chars().take(22).collect();
            ListItem::new(Line::from(vec![
                Span::raw(cur),
                Span::styled(format!("{} ", mark(it.state)), st(m, role)),
                Span::raw(format!("{label:<22}")),
                Span::styled(format!("{value:>10}"), st(m, role)),
            ]))
        })
        .collect();
    let mut state = ListState::default().with_selected(Some(s.selected));
    frame.render_stateful_widget(
        List::new(items)
            .block(Block::bordered().title(format!(
                " {} ",
                tr!(
                    "measuring-list-title",
                    taken = s.count(ItemState::Done) + s.count(ItemState::Flagged),
                    total = s.items.len()
                )
            )))
            .highlight_style(st(m, Role::Focus)),
        list_area,
        &mut state,
    );

    let mut lines: Vec<Line> = Vec::new();
    let title;
    let now = s.current.and_then(|c| s.items.get(c));
    match now {
        Some(it) => {
            title = format!(" {} ", tr!("measuring-now", name = it.info.label.clone()));
            // The instruction and the tape value come first: drawn by
            // `draw_guided` with the pictogram, or put before these lines
            // when the screen has no room for it.
            // Careful mode: which reading of how many is expected.
            if let Some(status) = it.careful_status(app.unit) {
                let role = if it.careful_third_needed() {
                    Role::Warn
                } else {
                    Role::Big
                };
                lines.push(Line::from(vec![
                    Span::styled(label(tr!("measuring-careful")), st(m, Role::Dim)),
                    Span::styled(status, st(m, role)),
                ]));
            }
            if let Some(v) = it.value {
                let mut spans = vec![
                    Span::styled(label(tr!("measuring-stored-label")), st(m, Role::Dim)),
                    Span::raw(app.unit.format(v)),
                ];
                if !it.previous.is_empty() {
                    let prev: Vec<String> =
                        it.previous.iter().map(|p| app.unit.format(*p)).collect();
                    spans.push(Span::styled(
                        format!("  {}", tr!("measuring-earlier", values = prev.join(", "))),
                        st(m, Role::Dim),
                    ));
                }
                lines.push(Line::from(spans));
            }
            lines.push(Line::raw(""));
            match it.state {
                ItemState::Flagged => {
                    for msg in it.flag.iter().chain(it.unit_slip.iter()) {
                        lines.push(Line::styled(format!("! {msg}"), st(m, Role::Warn)));
                    }
                    lines.push(Line::styled(
                        tr!("measuring-flagged-what-now"),
                        st(m, Role::Bad),
                    ));
                }
                ItemState::Checking => {
                    lines.push(Line::styled(tr!("measuring-checking"), st(m, Role::Dim)))
                }
                _ if it.value.is_some() => {
                    lines.push(Line::styled(tr!("measuring-retake-hint"), st(m, Role::Dim)))
                }
                _ => lines.push(Line::styled(tr!("measuring-hold-hint"), st(m, Role::Dim))),
            }
        }
        None => {
            title = format!(" {} ", tr!("measuring-done-title"));
            lines.push(Line::styled(tr!("measuring-all-done"), st(m, Role::Big)));
            lines.push(Line::raw(""));
            lines.push(hint_line(m, &[hint("e", msg!("measuring-done-estimate"))]));
            lines.push(hint_line(m, &[hint("r", msg!("measuring-done-retake"))]));
        }
    }
    // Flags of other measurements, so none is forgotten.
    let other_flags: Vec<&str> = s
        .items
        .iter()
        .enumerate()
        .filter(|(k, it)| it.state == ItemState::Flagged && Some(*k) != s.current)
        .map(|(_, it)| it.info.label.as_str())
        .collect();
    if !other_flags.is_empty() {
        lines.push(Line::raw(""));
        lines.push(Line::styled(
            tr!("measuring-flagged-others", names = other_flags.join(", ")),
            st(m, Role::Warn),
        ));
    }
    let skipped = s.count(ItemState::Skipped);
    if skipped > 0 {
        lines.push(Line::styled(
            tr!("measuring-skipped-count", n = skipped),
            st(m, Role::Dim),
        ));
    }
    let block = Block::bordered().title(title);
    let inner = block.inner(detail);
    frame.render_widget(block, detail);
    match now {
        Some(it) if draw_guided(app, &s.set, it, &lines, frame, inner) => {}
        _ => {
            if let Some(it) = now {
                let head = [
                    Line::styled(it.info.description.clone(), st(m, Role::Big)),
                    Line::raw(""),
                    Line::from(vec![
                        Span::styled(label(tr!("measuring-tape-label")), st(m, Role::Dim)),
                        Span::styled(tape_value(app), st(m, Role::Big)),
                    ]),
                ];
                lines.splice(0..0, head);
            }
            frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: true }), inner);
        }
    }
}

/// A dimmed label before a value on the instruction's lines ("Tape",
/// "Stored", "Careful"): padded to 8 columns so that the values line up
/// (a longer word keeps one blank after it).
fn label(word: String) -> String {
    format!("{word:<7} ")
}

/// The tape's live value with its unit ("83.7 cm"), or "--" without one.
fn tape_value(app: &App) -> String {
    match app.device.live {
        Some(l) if app.device.connected() => app.unit.format(l.value_tenth_mm),
        _ => "--".to_string(),
    }
}

/// The current measurement's instruction across the top of `area`; under
/// it the body pictogram with the measurement highlighted and, beside it,
/// the tape value in big digits over `lines` (the stored value, what to do
/// next). Parts are left out as the room shrinks: the second view of the
/// pictogram, then the pictogram, then the big digits for a plain line;
/// `false` (nothing drawn) when even that leaves `lines` no room, and the
/// caller draws everything as one paragraph.
fn draw_guided(
    app: &App,
    set: &str,
    it: &Item,
    lines: &[Line],
    frame: &mut Frame,
    area: Rect,
) -> bool {
    let m = app.mono;
    let wrap = Wrap { trim: true };
    let desc =
        Paragraph::new(Line::styled(it.info.description.clone(), st(m, Role::Big))).wrap(wrap);
    let desc_rows = u16::try_from(desc.line_count(area.width)).unwrap_or(u16::MAX);
    let rest_rows = area.height.saturating_sub(desc_rows.saturating_add(1));
    let tape = tape_value(app);
    let (number, unit) = tape.rsplit_once(' ').unwrap_or((tape.as_str(), ""));
    let text = Paragraph::new(lines.to_vec()).wrap(wrap);
    let pics = pictogram::for_set(set);
    let pic = match pics.as_ref() {
        Ok(p) => p
            .measurements
            .get(&it.info.name)
            .and_then(|r| r.as_ref().ok())
            .map(|pic| (p, pic)),
        Err(_) => None,
    };
    let pic_cols = |both| match pic {
        Some((set, pic)) if rest_rows >= pictogram::MIN_ROWS => {
            Some(pictogram::width_for(set, pic, rest_rows, both))
        }
        _ => None,
    };
    // (pictogram columns, big digits) in the order they are tried.
    let tries = [
        (pic_cols(true), true),
        (pic_cols(false), true),
        (Some(0), true),
        (pic_cols(false), false),
        (Some(0), false),
    ];
    for (cols, big) in tries {
        let Some(cols) = cols else { continue };
        let gap = u16::from(cols > 0);
        let Some(text_w) = area
            .width
            .checked_sub(cols.saturating_add(gap))
            .filter(|w| *w > 0)
        else {
            continue;
        };
        let unit_w = unit.chars().count() + 1;
        let scale = if !big {
            None
        } else {
            [2, 1].into_iter().find(|&k| {
                big_digits::width(number, k).is_some_and(|w| w + unit_w <= usize::from(text_w))
            })
        };
        if big && scale.is_none() {
            continue;
        }
        let head_rows = if scale.is_some() {
            big_digits::ROWS + 1
        } else {
            1
        };
        let text_rows = text.line_count(text_w);
        if usize::from(head_rows) + text_rows > usize::from(rest_rows) {
            continue;
        }
        frame.render_widget(
            desc,
            Rect {
                height: desc_rows,
                ..area
            },
        );
        let rest = Rect {
            y: area.y + desc_rows + 1,
            height: rest_rows,
            ..area
        };
        if cols > 0 {
            if let Some((set, pic)) = pic {
                let picture = Rect {
                    width: cols,
                    ..rest
                };
                pictogram::render(set, pic, m, picture, frame.buffer_mut());
            }
        }
        let column = Rect {
            x: rest.x + cols + gap,
            width: text_w,
            ..rest
        };
        let mut head: Vec<Line> = Vec::new();
        match scale.and_then(|k| big_digits::render(number, k)) {
            Some(rows) => {
                let last = rows.len() - 1;
                for (i, row) in rows.into_iter().enumerate() {
                    let mut spans = vec![Span::styled(row, st(m, Role::Big))];
                    if i == last && !unit.is_empty() {
                        spans.push(Span::styled(format!(" {unit}"), st(m, Role::Big)));
                    }
                    head.push(Line::from(spans));
                }
                head.push(Line::raw(""));
            }
            None => head.push(Line::from(vec![
                Span::styled(label(tr!("measuring-tape-label")), st(m, Role::Dim)),
                Span::styled(tape.clone(), st(m, Role::Big)),
            ])),
        }
        let head_h = u16::try_from(head.len()).unwrap_or(u16::MAX);
        frame.render_widget(
            Paragraph::new(head),
            Rect {
                height: head_h,
                ..column
            },
        );
        frame.render_widget(
            text,
            Rect {
                y: column.y + head_h,
                height: column.height - head_h,
                ..column
            },
        );
        return true;
    }
    false
}
