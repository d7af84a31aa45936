//! The screens of the kiosk interface, one module each: the screen's
//! state, its keys (one list for the handler, the footer and the help) and
//! its drawing, side by side (gitui's components, ratatui's demo2 tabs).
//! [`crate::tui::app`] routes keys and events to them; [`draw`] puts the
//! shown one between the top bar, the banner and the footer.

use ratatui::layout::{Alignment, Constraint, Layout, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Clear, Paragraph};
use ratatui::Frame;

use crate::i18n::tr;
use crate::tui::app::{App, Connection, Level, Pilot, Screen};
use crate::tui::keys::Hint;
use crate::tui::theme::{centered, hint_line, st, Role};

pub mod device;
pub mod estimating;
pub mod history;
pub mod measuring;
pub mod new_customer;
pub mod result;

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
        Screen::Device => device::draw(app, frame, body),
        Screen::NewCustomer => new_customer::draw(app, frame, body),
        Screen::Measuring => measuring::draw(app, frame, body),
        Screen::Estimating => estimating::draw(app, frame, body),
        Screen::Result => result::draw(app, frame, body),
        Screen::History => history::draw(app, frame, body),
    }
    frame.render_widget(
        Paragraph::new(hint_line(app.mono, &app.footer_hints())),
        footer,
    );
    if app.help {
        draw_help(app, frame, body);
    }
}

fn draw_top(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let mut left = vec![
        Span::styled(" tapeshape ", st(m, Role::Title)),
        Span::raw("| "),
        Span::styled(app.screen.title(), st(m, Role::Big)),
    ];
    if let Some(s) = &app.session {
        let session = tr!(
            "top-session",
            id = s.id.to_string(),
            customer = s.customer.as_str(),
            set = s.set.as_str()
        );
        left.push(Span::styled(format!(" | {session}"), st(m, Role::Dim)));
    }
    let (word, role) = app.device.word();
    let mut right = vec![
        Span::raw(format!("{} ", tr!("top-tape"))),
        Span::styled(word, st(m, role)),
    ];
    match app.demo {
        Some(Pilot::Simulated) => right.push(Span::styled(
            format!(" {}", tr!("top-demo-autopilot")),
            st(m, Role::Warn),
        )),
        Some(Pilot::Person) => right.push(Span::styled(
            format!(" {}", tr!("top-demo-manual")),
            st(m, Role::Dim),
        )),
        None => {}
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
    let m = app.mono;
    let session_kept = app.session.is_some();
    let banner = match &app.device.connection {
        Connection::Disconnected(_) => Some((
            Role::Bad,
            format!(
                " {} ",
                if session_kept {
                    tr!("banner-disconnected-kept")
                } else {
                    tr!("banner-disconnected")
                }
            ),
        )),
        Connection::Mismatch(msg) => Some((Role::Bad, format!(" {msg} "))),
        Connection::WaitingForPort(_) if session_kept => {
            Some((Role::Bad, format!(" {} ", tr!("banner-no-tape-kept"))))
        }
        _ => None,
    };
    let line = match (banner, &app.notice) {
        (Some((role, text)), _) => Line::styled(text, st(m, role)),
        (None, Some((level, text))) => {
            let role = match level {
                Level::Info => Role::Ok,
                Level::Warn => Role::Warn,
                Level::Error => Role::Bad,
            };
            Line::styled(format!(" {text}"), st(m, role))
        }
        (None, None) => Line::raw(""),
    };
    frame.render_widget(Paragraph::new(line), area);
}

/// The help: the keys of the screen shown, then those that work anywhere,
/// from the very lists the key handlers use.
fn draw_help(app: &App, frame: &mut Frame, area: Rect) {
    let m = app.mono;
    let popup = centered(area, 78, 21);
    frame.render_widget(Clear, popup);
    let line = |h: &Hint| {
        Line::from(vec![
            Span::styled(format!(" {:<10}", h.shown_text()), st(m, Role::Key)),
            Span::raw(h.help_text()),
        ])
    };
    let mut lines = vec![Line::styled(
        format!(" {}", app.screen.title()),
        st(m, Role::Title),
    )];
    lines.extend(app.screen_hints().iter().map(line));
    lines.push(Line::styled(
        format!(" {}", tr!("help-anywhere")),
        st(m, Role::Title),
    ));
    lines.extend(app.global_hints().iter().map(line));
    // (No word on the demo's takeover: a person's first key has taken over
    // before they could open this.)
    lines.push(Line::styled(
        format!(" {}", tr!("help-close")),
        st(m, Role::Dim),
    ));
    frame.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(format!(" {} ", tr!("help-title")))),
        popup,
    );
}
