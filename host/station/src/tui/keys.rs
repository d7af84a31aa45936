//! Key bindings as data: each screen lists the keys it answers, and that one
//! list drives its key handler, its footer and its part of the help.
//!
//! Why data and not a `match` per screen: a footer or help text written
//! apart from the handler drifts from it (a key renamed in one place and not
//! the other). Here a screen's handler looks the pressed key up in the same
//! list the footer and the help are drawn from (gitui's `commands`), so they
//! cannot disagree.
//!
//! A binding's words are message ids of the catalogue ([`crate::i18n`]),
//! written with `msg!("id")`, and formatted where they are drawn
//! ([`Hint::shown_text`], [`Hint::footer_text`], [`Hint::help_text`]), so
//! that the lists stay plain data and the language is the drawing's. A word
//! that is no id (a single key such as `r`, or the English words of a screen
//! not yet converted) is drawn as it is.

use crossterm::event::{KeyCode, KeyEvent, KeyModifiers};

use crate::i18n;

/// A key a binding answers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    /// This key (a character only without Ctrl; other keys with any modifiers).
    Code(KeyCode),
    /// Ctrl and this character.
    Ctrl(char),
    /// Any key at all (a confirmation's "any other key").
    Any,
}

impl Key {
    /// Does `key` press this key?
    pub fn matches(self, key: &KeyEvent) -> bool {
        let ctrl = key.modifiers.contains(KeyModifiers::CONTROL);
        match self {
            Key::Any => true,
            Key::Ctrl(c) => ctrl && key.code == KeyCode::Char(c),
            Key::Code(KeyCode::Char(c)) => !ctrl && key.code == KeyCode::Char(c),
            Key::Code(code) => key.code == code,
        }
    }
}

/// A character key.
pub const fn ch(c: char) -> Key {
    Key::Code(KeyCode::Char(c))
}

/// A key by its code.
pub const fn code(c: KeyCode) -> Key {
    Key::Code(c)
}

/// One thing a screen does on a key, with its words (message ids, see the
/// module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Binding<A> {
    /// The keys that do it.
    pub keys: Vec<Key>,
    /// How the key is written in the footer and the help (`key-enter`,
    /// `r`, `key-left-right`).
    pub shown: &'static str,
    /// The footer's word for it (an id); `None`: in the help only.
    pub footer: Option<&'static str>,
    /// The help's line for it (an id).
    pub help: &'static str,
    /// What it does.
    pub action: A,
}

impl<A> Binding<A> {
    /// A binding shown in the footer and the help.
    pub fn new(
        keys: &[Key],
        shown: &'static str,
        footer: &'static str,
        help: &'static str,
        action: A,
    ) -> Self {
        Self {
            keys: keys.to_vec(),
            shown,
            footer: Some(footer),
            help,
            action,
        }
    }

    /// A binding shown in the help only.
    pub fn help_only(keys: &[Key], shown: &'static str, help: &'static str, action: A) -> Self {
        Self {
            keys: keys.to_vec(),
            shown,
            footer: None,
            help,
            action,
        }
    }

    /// Its words, without the action.
    pub fn hint(&self) -> Hint {
        Hint {
            shown: self.shown,
            footer: self.footer,
            help: self.help,
        }
    }
}

/// The first binding in `bindings` that `key` presses, and its action.
pub fn lookup<'a, A>(bindings: &'a [Binding<A>], key: &KeyEvent) -> Option<&'a A> {
    bindings
        .iter()
        .find(|b| b.keys.iter().any(|k| k.matches(key)))
        .map(|b| &b.action)
}

/// A binding's words (message ids), as the footer and the help draw them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hint {
    /// The key as written.
    pub shown: &'static str,
    /// The footer's word (`None`: help only).
    pub footer: Option<&'static str>,
    /// The help's line.
    pub help: &'static str,
}

impl Hint {
    /// The key as written, in the chosen language.
    pub fn shown_text(&self) -> String {
        i18n::text(self.shown, None)
    }

    /// The footer's word in the chosen language (`None`: help only).
    pub fn footer_text(&self) -> Option<String> {
        self.footer.map(|f| i18n::text(f, None))
    }

    /// The help's line in the chosen language.
    pub fn help_text(&self) -> String {
        i18n::text(self.help, None)
    }
}

/// The words of every binding in `bindings`.
pub fn hints<A>(bindings: &[Binding<A>]) -> Vec<Hint> {
    bindings.iter().map(Binding::hint).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn characters_need_no_ctrl_and_ctrl_keys_need_it() {
        let plain = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::NONE);
        let with_ctrl = KeyEvent::new(KeyCode::Char('c'), KeyModifiers::CONTROL);
        assert!(ch('c').matches(&plain) && !ch('c').matches(&with_ctrl));
        assert!(Key::Ctrl('c').matches(&with_ctrl) && !Key::Ctrl('c').matches(&plain));
        let shifted = KeyEvent::new(KeyCode::Char('M'), KeyModifiers::SHIFT);
        assert!(ch('M').matches(&shifted));
        let enter = KeyEvent::new(KeyCode::Enter, KeyModifiers::SHIFT);
        assert!(code(KeyCode::Enter).matches(&enter));
        assert!(Key::Any.matches(&plain));
    }

    #[test]
    fn lookup_takes_the_first_binding_that_answers() {
        let b = vec![
            Binding::new(&[ch('x')], "x", "export", "export", 1),
            Binding::help_only(&[ch('x'), ch('y')], "x/y", "never for x", 2),
        ];
        let key = |c| KeyEvent::new(KeyCode::Char(c), KeyModifiers::NONE);
        assert_eq!(lookup(&b, &key('x')), Some(&1));
        assert_eq!(lookup(&b, &key('y')), Some(&2));
        assert_eq!(lookup(&b, &key('z')), None);
    }
}
