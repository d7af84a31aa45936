//! Styles and small drawing helpers shared by the screens.
//!
//! Colour carries no meaning on its own: every mark is also a symbol or a
//! word, so the monochrome palette (`NO_COLOR`, `--mono`) loses nothing.

use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};

use crate::tui::keys::Hint;

/// Roles of text, mapped to colours or (monochrome) to modifiers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// Titles.
    Title,
    /// Good news (connected, done).
    Ok,
    /// Needs a look.
    Warn,
    /// Failed or dangerous.
    Bad,
    /// Secondary text.
    Dim,
    /// The focused field or row.
    Focus,
    /// A key's name.
    Key,
    /// Prominent values.
    Big,
}

/// The style of `role` (`mono`: no colours).
pub fn st(mono: bool, role: Role) -> Style {
    let s = Style::default();
    if mono {
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

/// A line of key hints: each key in the key style, then its footer word
/// (both in the chosen language).
pub fn hint_line(mono: bool, hints: &[Hint]) -> Line<'static> {
    let mut spans = Vec::new();
    for h in hints {
        if let Some(word) = h.footer_text() {
            spans.push(Span::styled(h.shown_text(), st(mono, Role::Key)));
            spans.push(Span::raw(format!(" {word}  ")));
        }
    }
    Line::from(spans)
}

/// A hint written out in place (popups), with its own words (message ids,
/// or words drawn as they are).
pub fn hint(shown: &'static str, footer: &'static str) -> Hint {
    Hint {
        shown,
        footer: Some(footer),
        help: footer,
    }
}

/// "key        value" with the key dimmed (`k`: text already in the
/// chosen language).
pub fn kv(mono: bool, k: &str, v: String) -> Line<'static> {
    Line::from(vec![
        Span::styled(format!("{k:<16}"), st(mono, Role::Dim)),
        Span::raw(v),
    ])
}

/// A `w` x `h` rectangle centred in `area` (clipped to it).
pub fn centered(area: Rect, w: u16, h: u16) -> Rect {
    let w = w.min(area.width);
    let h = h.min(area.height);
    Rect {
        x: area.x + (area.width - w) / 2,
        y: area.y + (area.height - h) / 2,
        width: w,
        height: h,
    }
}
