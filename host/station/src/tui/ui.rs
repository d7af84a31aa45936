//! Drawing: `draw(&App, &mut Frame)`, one function per screen.
//!
//! Why apart from the state: drawing reads the [`App`] and nothing else, so
//! every screen can be rendered into ratatui's `TestBackend` and compared
//! with a snapshot. Layout is made for 80x24 (a kiosk's smallest terminal)
//! and grows with larger ones. Colour carries no meaning on its own: every
//! mark is also a symbol or a word, so the monochrome palette (`NO_COLOR`,
//! `--mono`) loses nothing.

use ratatui::layout::{Alignment, Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::canvas::{Canvas, Points};
use ratatui::widgets::{
    Block, Cell, Clear, Gauge, List, ListItem, ListState, Paragraph, Row, Table, Wrap,
};
use ratatui::Frame;

use crate::tui::app::{
    App, Autopilot, Connection, FormField, ItemState, Level, Screen, BUILTIN_SET_CHOICES,
};
use crate::tui::services::{stage_label, STAGES};

/// Roles of text, mapped to colours or (monochrome) to modifiers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    Title,
    Ok,
    Warn,
    Bad,
    Dim,
    Focus,
    Key,
    Big,
}

fn st(app: &App, role: Role) -> Style {
    let s = Style::default();
    if app.mono {
        return match role {
            Role::Title | Role::Big | Role::Key => s.add_modifier(Modifier::BOLD),
            Role::Bad => s.add_modifier(Modifier::BOLD | Modifier::REVERSED),
            Role::Warn => s.add_modifier(Modifier::BOLD),
            Role::Focus => s.add_modifier(Modifier::REVERSED),
            Role::Dim | Role::Ok => s,
        };
    }
    match role {
        Role::Title => s.fg(Color::Cyan).add_modifier(Modifier::BOLD),
        Role::Ok => s.fg(Color::Green),
        Role::Warn => s.fg(Color::Yellow).add_modifier(Modifier::BOLD),
        Role::Bad => s
            .fg(Color::White)
            .bg(Color::Red)
            .add_modifier(Modifier::BOLD),
        Role::Dim => s.fg(Color::DarkGray),
        Role::Focus => s.fg(Color::Black).bg(Color::Cyan),
        Role::Key => s.fg(Color::Cyan).add_modifier(Modifier::BOLD),
        Role::Big => s.fg(Color::White).add_modifier(Modifier::BOLD),
    }
}

/// Draws the whole interface.
pub fn draw(app: &App, frame: &mut Frame) {
    let [top, banner, body, footer] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(1),
        Constraint::Min(10),
        Constraint::Length(1),
    ])
    .areas(frame.area());
    draw_top(app, frame, top);
    draw_banner(app, frame, banner);
    match app.screen {
        Screen::Device => draw_device(app, frame, body),
        Screen::NewCustomer => draw_form(app, frame, body),
        Screen::Measuring => draw_measuring(app, frame, body),
        Screen::Estimating => draw_estimating(app, frame, body),
        Screen::Result => draw_result(app, frame, body),
        Screen::History => draw_history(app, frame, body),
    }
    draw_footer(app, frame, footer);
    if app.help {
        draw_help(app, frame, body);
    }
}

fn conn_word(app: &App) -> (String, Role) {
    match &app.device.connection {
        Connection::Starting => ("starting".into(), Role::Dim),
        Connection::WaitingForPort(_) => ("no tape (waiting)".into(), Role::Warn),
        Connection::PortOpen(_) => ("port open, handshake".into(), Role::Warn),
        Connection::Connected => ("connected".into(), Role::Ok),
        Connection::Mismatch(_) => ("WRONG VERSION".into(), Role::Bad),
        Connection::Disconnected(_) => ("DISCONNECTED".into(), Role::Bad),
        Connection::Stopped => ("stopped".into(), Role::Dim),
    }
}

fn draw_top(app: &App, frame: &mut Frame, area: Rect) {
    let mut left = vec![
        Span::styled(" tapeshape ", st(app, Role::Title)),
        Span::raw("| "),
        Span::styled(app.screen.title(), st(app, Role::Big)),
    ];
    if let Some(s) = &app.session {
        left.push(Span::styled(
            format!(" | session {} {} {}", s.id, s.customer, s.set),
            st(app, Role::Dim),
        ));
    }
    let (word, role) = conn_word(app);
    let mut right = vec![Span::raw("tape: "), Span::styled(word, st(app, role))];
    match app.autopilot {
        Autopilot::Driving => right.push(Span::styled(" DEMO autopilot", st(app, Role::Warn))),
        Autopilot::TakenOver => right.push(Span::styled(" DEMO manual", st(app, Role::Dim))),
        Autopilot::Off => {}
    }
    right.insert(0, Span::raw("  "));
    right.push(Span::raw(" "));
    let rw: u16 = right.iter().map(|s| s.width() as u16).sum();
    let [l, r] = Layout::horizontal([Constraint::Min(1), Constraint::Length(rw)]).areas(area);
    frame.render_widget(Paragraph::new(Line::from(left)), l);
    frame.render_widget(
        Paragraph::new(Line::from(right)).alignment(Alignment::Right),
        r,
    );
}

fn draw_banner(app: &App, frame: &mut Frame, area: Rect) {
    let session_kept = app.session.is_some();
    let banner = match &app.device.connection {
        Connection::Disconnected(_) => Some((
            Role::Bad,
            format!(
                " TAPE DISCONNECTED: reconnecting...{} (d: details) ",
                if session_kept {
                    " session kept, no reading lost"
                } else {
                    ""
                }
            ),
        )),
        Connection::Mismatch(m) => Some((Role::Bad, format!(" {m} "))),
        Connection::WaitingForPort(_) if session_kept => Some((
            Role::Bad,
            " NO TAPE: plug it in; the session is kept (d: details) ".to_string(),
        )),
        _ => None,
    };
    let line = match (banner, &app.notice) {
        (Some((role, text)), _) => Line::styled(text, st(app, role)),
        (None, Some((level, text))) => {
            let role = match level {
                Level::Info => Role::Ok,
                Level::Warn => Role::Warn,
                Level::Error => Role::Bad,
            };
            Line::styled(format!(" {text}"), st(app, role))
        }
        (None, None) => Line::raw(""),
    };
    frame.render_widget(Paragraph::new(line), area);
}

fn hint<'a>(app: &App, keys: &[(&'a str, &'a str)]) -> Line<'a> {
    let mut spans = Vec::new();
    for (k, what) in keys {
        spans.push(Span::styled(*k, st(app, Role::Key)));
        spans.push(Span::raw(format!(" {what}  ")));
    }
    Line::from(spans)
}

fn draw_footer(app: &App, frame: &mut Frame, area: Rect) {
    let keys: Vec<(&str, &str)> = match app.screen {
        Screen::Device => vec![
            ("Esc", "back"),
            ("h", "history"),
            ("?", "help"),
            ("q", "quit"),
        ],
        Screen::NewCustomer if app.resume.is_some() => {
            vec![("y", "resume"), ("n", "new customer"), ("q", "quit")]
        }
        Screen::NewCustomer => vec![
            ("Tab", "field"),
            ("<-/->", "choose"),
            ("Enter", "start"),
            ("h", "history"),
            ("d", "device"),
            ("?", "help"),
        ],
        Screen::Measuring => {
            let mut k = vec![
                ("Enter", "capture"),
                ("r", "retake"),
                ("s", "skip"),
                ("u", "undo"),
                ("i", "cm/in"),
                ("e", "estimate"),
            ];
            if app.demo {
                k.push(("m", "sim tape"));
            }
            k.push(("?", "help"));
            k
        }
        Screen::Estimating if app.estimate.running => vec![("Esc", "cancel")],
        Screen::Estimating => vec![("Esc", "back to measuring")],
        Screen::Result => vec![
            ("x", "export"),
            ("f", "format"),
            ("b", "back"),
            ("n", "next customer"),
            ("h", "history"),
            ("?", "help"),
        ],
        Screen::History if app.history.confirm_delete.is_some() => {
            vec![("y", "delete"), ("any key", "keep")]
        }
        Screen::History => vec![
            ("Enter", "reopen"),
            ("e", "estimate"),
            ("x", "export"),
            ("Del", "delete"),
            ("Esc", "back"),
        ],
    };
    frame.render_widget(Paragraph::new(hint(app, &keys)), area);
}

fn kv<'a>(app: &App, k: &'a str, v: String) -> Line<'a> {
    Line::from(vec![
        Span::styled(format!("{k:<16}"), st(app, Role::Dim)),
        Span::raw(v),
    ])
}

fn draw_device(app: &App, frame: &mut Frame, area: Rect) {
    let d = &app.device;
    let (word, role) = conn_word(app);
    let mut lines = vec![
        kv(app, "port", d.port.clone()),
        Line::from(vec![
            Span::styled(format!("{:<16}", "state"), st(app, Role::Dim)),
            Span::styled(word, st(app, role)),
        ]),
    ];
    match &d.connection {
        Connection::WaitingForPort(e) | Connection::Disconnected(e) | Connection::Mismatch(e) => {
            lines.push(kv(app, "why", e.clone()))
        }
        _ => {}
    }
    if let Some(h) = &d.hello {
        lines.push(kv(app, "device id", format!("{:016x}", h.device_id)));
        lines.push(kv(app, "boot", h.boot_id.to_string()));
        lines.push(kv(
            app,
            "firmware",
            format!(
                "{}.{}.{}",
                h.firmware.major, h.firmware.minor, h.firmware.patch
            ),
        ));
        lines.push(kv(
            app,
            "protocol",
            format!("{}.{}", h.protocol.major, h.protocol.minor),
        ));
    } else {
        lines.push(kv(app, "device", "no hello yet".into()));
    }
    lines.push(kv(
        app,
        "host",
        format!(
            "tapeshape {} protocol {}.{}",
            env!("CARGO_PKG_VERSION"),
            tapeshape_protocol::PROTOCOL_VERSION.major,
            tapeshape_protocol::PROTOCOL_VERSION.minor
        ),
    ));
    if let Some((n, cap)) = d.queue {
        lines.push(kv(
            app,
            "tape queue",
            format!("{n} of {cap} unacknowledged"),
        ));
    }
    lines.push(kv(
        app,
        "link",
        format!(
            "{} bad frames, {} connections lost",
            d.bad_frames, d.disconnects
        ),
    ));
    if let Some(l) = d.live {
        lines.push(kv(app, "live", app.unit.format(l.value_tenth_mm)));
    }
    lines.push(Line::raw(""));
    lines.push(Line::styled("Recent faults", st(app, Role::Title)));
    if d.faults.is_empty() {
        lines.push(Line::styled("  none", st(app, Role::Dim)));
    }
    for f in &d.faults {
        lines.push(Line::styled(format!("  {f}"), st(app, Role::Warn)));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(" Tape ")),
        area,
    );
}

fn draw_form(app: &App, frame: &mut Frame, area: Rect) {
    let f = &app.form;
    let field = |name: FormField, label: &str, value: String, help: &str| -> Line<'static> {
        let focus = f.field == name && app.resume.is_none();
        let marker = if focus { "> " } else { "  " };
        Line::from(vec![
            Span::raw(marker.to_string()),
            Span::styled(format!("{label:<16}"), st(app, Role::Dim)),
            Span::styled(
                value,
                if focus {
                    st(app, Role::Focus)
                } else {
                    st(app, Role::Big)
                },
            ),
            Span::styled(format!("  {help}"), st(app, Role::Dim)),
        ])
    };
    let set_value = match BUILTIN_SET_CHOICES.get(f.set_choice) {
        Some(s) => format!("< {s} >"),
        None => "< custom file >".to_string(),
    };
    let mut lines = vec![
        Line::raw(""),
        field(
            FormField::Customer,
            "customer id",
            format!("{} ", f.customer),
            "opaque; no name needed",
        ),
        field(
            FormField::Sex,
            "sex",
            format!("< {} >", f.sex.word()),
            "f / m",
        ),
        field(
            FormField::Age,
            "age (optional)",
            format!("{:<3}", f.age),
            "years",
        ),
        field(FormField::Set, "measurements", set_value, "<- -> to choose"),
    ];
    if f.set_choice == BUILTIN_SET_CHOICES.len() {
        lines.push(field(
            FormField::File,
            "set file",
            format!("{} ", f.file),
            "TOML file",
        ));
    }
    lines.push(Line::raw(""));
    let blurb = match BUILTIN_SET_CHOICES.get(f.set_choice) {
        Some(name) => set_blurb(name),
        None => "a measurement set file (TOML, as host/measure/sets/*.toml)".to_string(),
    };
    lines.push(Line::styled(format!("  {blurb}"), st(app, Role::Dim)));
    if let Some(e) = &f.error {
        lines.push(Line::raw(""));
        lines.push(Line::styled(format!("  {e}"), st(app, Role::Bad)));
    }
    lines.push(Line::raw(""));
    lines.push(Line::styled(
        "  Enter starts the session; readings are stored as they are taken.",
        st(app, Role::Dim),
    ));
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: false })
            .block(Block::bordered().title(" New customer ")),
        area,
    );
    if let Some(r) = &app.resume {
        let popup = centered(area, 64, 8);
        frame.render_widget(Clear, popup);
        let text = vec![
            Line::raw(""),
            Line::from(vec![Span::styled(
                format!(
                    " Session {} (customer {}, {}) is not finished:",
                    r.session,
                    r.customer,
                    r.set.as_deref().unwrap_or("no set")
                ),
                st(app, Role::Big),
            )]),
            Line::raw(format!(
                " {} readings are stored. Resume it with them?",
                r.readings
            )),
            Line::raw(""),
            hint(app, &[("y", "resume"), ("n", "start a new customer")]),
        ];
        frame.render_widget(
            Paragraph::new(text).block(
                Block::bordered()
                    .title(" Resume? ")
                    .border_style(st(app, Role::Warn)),
            ),
            popup,
        );
    }
}

/// "name: N measurements; description" of a built-in set, parsed once.
fn set_blurb(name: &str) -> String {
    static BLURBS: std::sync::OnceLock<Vec<(String, String)>> = std::sync::OnceLock::new();
    let all = BLURBS.get_or_init(|| {
        BUILTIN_SET_CHOICES
            .iter()
            .filter_map(|n| tapeshape_measure::MeasurementSet::builtin(n).ok())
            .map(|s| {
                let first = s
                    .description
                    .split(". ")
                    .next()
                    .unwrap_or("")
                    .trim()
                    .to_string();
                (
                    s.name.clone(),
                    format!("{}: {} measurements. {first}", s.name, s.definitions.len()),
                )
            })
            .collect()
    });
    all.iter()
        .find(|(n, _)| n == name)
        .map(|(_, b)| b.clone())
        .unwrap_or_else(|| name.to_string())
}

fn centered(area: Rect, w: u16, h: u16) -> Rect {
    let w = w.min(area.width);
    let h = h.min(area.height);
    Rect {
        x: area.x + (area.width - w) / 2,
        y: area.y + (area.height - h) / 2,
        width: w,
        height: h,
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

fn draw_measuring(app: &App, frame: &mut Frame, area: Rect) {
    let Some(s) = &app.session else {
        frame.render_widget(Paragraph::new("No session"), area);
        return;
    };
    let [list_area, detail] =
        Layout::horizontal([Constraint::Length(38), Constraint::Min(20)]).areas(area);
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
                Span::styled(format!("{} ", mark(it.state)), st(app, role)),
                Span::raw(format!("{label:<22}")),
                Span::styled(format!("{value:>10}"), st(app, role)),
            ]))
        })
        .collect();
    let mut state = ListState::default().with_selected(Some(s.selected));
    frame.render_stateful_widget(
        List::new(items)
            .block(Block::bordered().title(format!(
                " {} of {} taken ",
                s.count(ItemState::Done) + s.count(ItemState::Flagged),
                s.items.len()
            )))
            .highlight_style(st(app, Role::Focus)),
        list_area,
        &mut state,
    );

    let mut lines: Vec<Line> = Vec::new();
    let title;
    match s.current.and_then(|c| s.items.get(c)) {
        Some(it) => {
            title = format!(" Now: {} ", it.info.label);
            lines.push(Line::styled(
                it.info.description.clone(),
                st(app, Role::Big),
            ));
            lines.push(Line::raw(""));
            let live = match app.device.live {
                Some(l) if app.device.connected() => app.unit.format(l.value_tenth_mm),
                _ => "--".to_string(),
            };
            lines.push(Line::from(vec![
                Span::styled("Tape    ", st(app, Role::Dim)),
                Span::styled(live, st(app, Role::Big)),
            ]));
            if let Some(v) = it.value {
                let mut spans = vec![
                    Span::styled("Stored  ", st(app, Role::Dim)),
                    Span::raw(app.unit.format(v)),
                ];
                if !it.previous.is_empty() {
                    let prev: Vec<String> =
                        it.previous.iter().map(|p| app.unit.format(*p)).collect();
                    spans.push(Span::styled(
                        format!("  earlier {}", prev.join(", ")),
                        st(app, Role::Dim),
                    ));
                }
                lines.push(Line::from(spans));
            }
            lines.push(Line::raw(""));
            match it.state {
                ItemState::Flagged => {
                    for m in it.flag.iter().chain(it.unit_slip.iter()) {
                        lines.push(Line::styled(format!("! {m}"), st(app, Role::Warn)));
                    }
                    lines.push(Line::styled(
                        "Measure again (hold the tape), or Enter to keep this value",
                        st(app, Role::Bad),
                    ));
                }
                ItemState::Checking => {
                    lines.push(Line::styled("Checking the reading...", st(app, Role::Dim)))
                }
                _ if it.value.is_some() => lines.push(Line::styled(
                    "Retake: hold the tape to replace the stored value",
                    st(app, Role::Dim),
                )),
                _ => lines.push(Line::styled(
                    "Hold the tape's button to capture (or Enter)",
                    st(app, Role::Dim),
                )),
            }
        }
        None => {
            title = " Done ".to_string();
            lines.push(Line::styled(
                "Every measurement is taken or skipped.",
                st(app, Role::Big),
            ));
            lines.push(Line::raw(""));
            lines.push(hint(app, &[("e", "estimate the body")]));
            lines.push(hint(app, &[("r", "retake the selected one")]));
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
            format!("Flagged: {}", other_flags.join(", ")),
            st(app, Role::Warn),
        ));
    }
    let skipped = s.count(ItemState::Skipped);
    if skipped > 0 {
        lines.push(Line::styled(
            format!("{skipped} skipped"),
            st(app, Role::Dim),
        ));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: true })
            .block(Block::bordered().title(title)),
        detail,
    );
}

fn draw_estimating(app: &App, frame: &mut Frame, area: Rect) {
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
            let (m, role) = if !e.stages.contains(s) {
                ("  ", Role::Dim)
            } else if Some(*s) == current && e.running {
                ("> ", Role::Big)
            } else if Some(*s) == current && e.error.is_some() {
                ("x ", Role::Bad)
            } else {
                ("✓ ", Role::Ok)
            };
            Line::styled(format!(" {m}{}", stage_label(*s)), st(app, role))
        })
        .collect();
    frame.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" Estimating the body ")),
        stages,
    );
    frame.render_widget(
        Gauge::default()
            .block(Block::bordered())
            .gauge_style(st(app, Role::Ok))
            .ratio(e.fraction.clamp(0.0, 1.0)),
        gauge,
    );
    let text = if let Some(err) = &e.error {
        vec![
            Line::styled("The estimate was refused:", st(app, Role::Bad)),
            Line::raw(err.clone()),
            Line::raw(""),
            Line::styled(
                "Esc goes back to measuring: retake the readings named above.",
                st(app, Role::Dim),
            ),
        ]
    } else if e.cancelling {
        vec![Line::styled("Cancelling...", st(app, Role::Warn))]
    } else {
        let n = app.session.as_ref().map_or(0, |s| s.accepted().len());
        vec![Line::styled(
            format!("Fitting the body to {n} readings; Esc cancels."),
            st(app, Role::Dim),
        )]
    };
    frame.render_widget(Paragraph::new(text).wrap(Wrap { trim: true }), msg);
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

fn silhouette<'a>(
    app: &App,
    points: &'a [(f64, f64)],
    title: &'a str,
    area: Rect,
) -> impl ratatui::widgets::Widget + 'a {
    let (xb, yb) = bounds(
        points,
        area.width.saturating_sub(2),
        area.height.saturating_sub(2),
    );
    let color = if app.mono { Color::Reset } else { Color::Cyan };
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

fn draw_result(app: &App, frame: &mut Frame, area: Rect) {
    let Some(r) = &app.result else {
        frame.render_widget(
            Paragraph::new("No estimate yet: press e on the measuring screen"),
            area,
        );
        return;
    };
    let [front, side, right] = Layout::horizontal([
        Constraint::Length(20),
        Constraint::Length(12),
        Constraint::Min(30),
    ])
    .areas(area);
    frame.render_widget(
        silhouette(app, &r.silhouettes.front, " front ", front),
        front,
    );
    frame.render_widget(silhouette(app, &r.silhouettes.side, " side ", side), side);

    let [table_area, info] =
        Layout::vertical([Constraint::Min(4), Constraint::Length(7)]).areas(right);
    let u = app.unit;
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
                Cell::from(match u {
                    crate::tui::app::DisplayUnit::Cm => format!("{err:+.1}"),
                    crate::tui::app::DisplayUnit::Inch => format!("{:+.2}", err / 25.4),
                })
                .style(if err.abs() > 10.0 {
                    st(app, Role::Warn)
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
                "measurement",
                "target",
                "body",
                match u {
                    crate::tui::app::DisplayUnit::Cm => "err mm",
                    crate::tui::app::DisplayUnit::Inch => "err in",
                },
            ])
            .style(st(app, Role::Dim)),
        )
        .column_spacing(1)
        .block(Block::bordered().title(format!(" Estimate ({:.1} s) ", r.seconds))),
        table_area,
    );
    let mut lines = vec![Line::from(vec![
        Span::styled("plausibility ", st(app, Role::Dim)),
        Span::raw(r.plausibility.clone()),
    ])];
    if let Some(w) = r.warnings.first() {
        lines.push(Line::styled(
            format!(
                "! {w}{}",
                if r.warnings.len() > 1 {
                    format!(" (+{} more)", r.warnings.len() - 1)
                } else {
                    String::new()
                }
            ),
            st(app, Role::Warn),
        ));
    }
    match &app.exported {
        Some(files) => {
            let names: Vec<String> = files
                .iter()
                .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().into_owned()))
                .collect();
            lines.push(Line::styled(
                format!("exported {}", names.join(", ")),
                st(app, Role::Ok),
            ));
            if let Some(dir) = files.first().and_then(|f| f.parent()) {
                lines.push(Line::styled(
                    format!("in {}", dir.display()),
                    st(app, Role::Dim),
                ));
            }
        }
        None => lines.push(Line::from(vec![
            Span::styled("x", st(app, Role::Key)),
            Span::raw(format!(
                " exports {} + report.json  ",
                app.export_format.ext().to_uppercase()
            )),
            Span::styled("f", st(app, Role::Key)),
            Span::raw(" other format"),
        ])),
    }
    frame.render_widget(Paragraph::new(lines).wrap(Wrap { trim: true }), info);
}

fn draw_history(app: &App, frame: &mut Frame, area: Rect) {
    let h = &app.history;
    let rows: Vec<Row> = h
        .sessions
        .iter()
        .map(|s| {
            let t = crate::cli::format_time_ms(s.session.updated_at_ms);
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
            .style(st(app, Role::Dim)),
        )
        .row_highlight_style(st(app, Role::Focus))
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
                    st(app, Role::Big),
                ),
                Line::raw(""),
                hint(app, &[("y", "delete"), ("any other key", "keep it")]),
            ])
            .block(
                Block::bordered()
                    .title(" Delete? ")
                    .border_style(st(app, Role::Bad)),
            ),
            popup,
        );
    }
}

fn draw_help(app: &App, frame: &mut Frame, area: Rect) {
    let popup = centered(area, 78, 21);
    frame.render_widget(Clear, popup);
    let k = |key: &'static str, what: &'static str| {
        Line::from(vec![
            Span::styled(format!(" {key:<10}"), st(app, Role::Key)),
            Span::raw(what),
        ])
    };
    let mut lines = vec![
        Line::styled(" Measuring", st(app, Role::Title)),
        k(
            "hold",
            "the tape's hold button stores the reading (Enter: the live value)",
        ),
        k(
            "up/down",
            "choose a measurement; r retakes it; s skips the current one",
        ),
        k(
            "u",
            "undo the last step (stored readings stay in the history)",
        ),
        k("Enter", "keep a flagged reading; i toggles cm/inches"),
        k("e", "estimate the body from the readings taken"),
        Line::styled(" Result and history", st(app, Role::Title)),
        k(
            "x / f",
            "export body + report.json / change format (GLB, OBJ, PLY)",
        ),
        k("n", "next customer (the session is marked done)"),
        k(
            "Enter",
            "history: reopen; e re-estimate, x re-export, Del delete",
        ),
        Line::styled(" Anywhere", st(app, Role::Title)),
        k("d / h", "device screen / history"),
        k("q q", "quit (nothing is lost: readings are stored at once)"),
    ];
    if app.demo {
        lines.push(Line::styled(" Demo", st(app, Role::Title)));
        lines.push(k("any key", "takes over from the simulated operator"));
        lines.push(k(
            "m / M",
            "simulated tape measures the current one / with a slip",
        ));
    }
    lines.push(Line::styled(
        " any key closes this help",
        st(app, Role::Dim),
    ));
    frame.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(" Keys ")),
        popup,
    );
}
