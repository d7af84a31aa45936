//! Operator text from one message catalogue: English, and German for the
//! measuring flow.
//!
//! Why Fluent (`fluent-bundle`): it is Mozilla's well-kept localisation
//! system, its messages are plain text files a translator can edit
//! (`host/station/locales/<lang>/station.ftl`), and it handles what string
//! tables do not (plural forms, variables placed where each language wants
//! them). The catalogues are embedded with `include_str!`, so the program
//! needs no files beside it.
//!
//! The language is chosen once at start ([`choose`]: `--lang`, else the
//! locale, [`Lang::from_env`]) and read by every thread ([`lang`]); the
//! library's and the tests' default is English. Text is looked up by
//! message id with `tr!` (formatted now) or kept as an id
//! with `msg!` (the key bindings' words, formatted where
//! they are drawn, [`text`]). A message missing in German falls back to
//! English; one missing in English shows the id itself (never a panic
//! or an empty line over words). The catalogue test
//! (`tests/i18n_catalogue.rs`) checks that every language has every key,
//! that every message formats, and that every `tr!`/`msg!` id in the
//! sources is in the English catalogue.
//!
//! Fixed machine-readable words (the line mode's `session`, `port`,
//! `fault queue-full`, ... that scripts parse) are not in the catalogue:
//! they stay English in every language.
//!
//! Layer: words, at the bottom with [`crate::text`]; it imports nothing of
//! the station.

use std::sync::OnceLock;

use fluent_bundle::concurrent::FluentBundle;
use fluent_bundle::FluentResource;
use unic_langid::LanguageIdentifier;

pub use fluent_bundle::FluentArgs;

/// A language the station speaks to its operator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, clap::ValueEnum)]
pub enum Lang {
    /// English (complete; the default).
    #[default]
    En,
    /// German (Deutsch).
    De,
}

impl Lang {
    /// Every shipped language, English first.
    pub const ALL: [Lang; 2] = [Lang::En, Lang::De];

    /// The language's code (`en`, `de`): its folder under `locales/`.
    pub fn code(self) -> &'static str {
        match self {
            Lang::En => "en",
            Lang::De => "de",
        }
    }

    /// The language's catalogue, as shipped (Fluent syntax).
    pub fn catalogue(self) -> &'static str {
        match self {
            Lang::En => include_str!("../locales/en/station.ftl"),
            Lang::De => include_str!("../locales/de/station.ftl"),
        }
    }

    /// The language of a POSIX locale value (`de_DE.UTF-8`, `de`, `de_AT`:
    /// German; anything else, `C` and `POSIX` included: English).
    pub fn from_locale(value: &str) -> Lang {
        let language = value
            .split(['_', '.', '@', '-'])
            .next()
            .unwrap_or("")
            .to_ascii_lowercase();
        match language.as_str() {
            "de" => Lang::De,
            _ => Lang::En,
        }
    }

    /// The language of the first of `LC_ALL`, `LC_MESSAGES` and `LANG` that
    /// is set and not empty (the POSIX order for messages); English when
    /// none is.
    pub fn from_env() -> Lang {
        Self::from_vars(|name| std::env::var(name).ok())
    }

    /// [`Lang::from_env`] over any source of variables (for tests).
    pub fn from_vars(var: impl Fn(&str) -> Option<String>) -> Lang {
        ["LC_ALL", "LC_MESSAGES", "LANG"]
            .iter()
            .filter_map(|name| var(name))
            .find(|v| !v.is_empty())
            .map_or(Lang::En, |v| Lang::from_locale(&v))
    }

    /// The language's identifier (for Fluent's plural rules).
    fn langid(self) -> LanguageIdentifier {
        // A two-letter code always parses; the default ("und") would only
        // lose the plural rules, never the text.
        self.code().parse().unwrap_or_default()
    }
}

/// [`choose`] was called a second time with another language.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the station's language is already {chosen:?}; it is chosen once, at start")]
pub struct AlreadyChosen {
    /// The language chosen first (still in use).
    pub chosen: Lang,
}

static CHOSEN: OnceLock<Lang> = OnceLock::new();

/// Chooses the language of the operator text for the rest of the process
/// (once, at start; choosing the same language again is no error).
pub fn choose(lang: Lang) -> Result<(), AlreadyChosen> {
    let chosen = *CHOSEN.get_or_init(|| lang);
    if chosen == lang {
        Ok(())
    } else {
        Err(AlreadyChosen { chosen })
    }
}

/// The language of the operator text: the one chosen, else English.
pub fn lang() -> Lang {
    CHOSEN.get().copied().unwrap_or_default()
}

type Bundle = FluentBundle<FluentResource>;

/// The bundle of `lang`, built on first use from its embedded catalogue.
fn bundle(lang: Lang) -> &'static Bundle {
    static EN: OnceLock<Bundle> = OnceLock::new();
    static DE: OnceLock<Bundle> = OnceLock::new();
    let cell = match lang {
        Lang::En => &EN,
        Lang::De => &DE,
    };
    cell.get_or_init(|| build(lang))
}

fn build(lang: Lang) -> Bundle {
    // A shipped catalogue that does not parse is a bug the catalogue test
    // catches; at a station the entries that did parse are still used and
    // the rest fall back (never a panic over words).
    let resource = match FluentResource::try_new(lang.catalogue().to_string()) {
        Ok(r) => r,
        Err((partial, errors)) => {
            tracing::error!(lang = lang.code(), ?errors, "catalogue does not parse");
            partial
        }
    };
    let mut bundle = Bundle::new_concurrent(vec![lang.langid()]);
    // Terminal output: no Unicode isolation marks around placeables.
    bundle.set_use_isolating(false);
    if let Err(errors) = bundle.add_resource(resource) {
        tracing::error!(lang = lang.code(), ?errors, "catalogue has duplicate ids");
    }
    bundle
}

/// What went wrong formatting a message in one language ([`format`](fn@format)).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TextError {
    /// The language's catalogue has no message (with a value) of this id.
    #[error("the {lang:?} catalogue has no message {id:?}: add it to locales/{code}/station.ftl", code = lang.code())]
    Missing {
        /// The language.
        lang: Lang,
        /// The message id.
        id: String,
    },
    /// The message formatted with errors (a variable not given, a
    /// reference to a message that does not exist, ...).
    #[error(
        "message {id:?} of the {lang:?} catalogue formats with errors: {errors:?} (text: {text:?})"
    )]
    Format {
        /// The language.
        lang: Lang,
        /// The message id.
        id: String,
        /// Fluent's errors, in words.
        errors: Vec<String>,
        /// The text as formatted despite them.
        text: String,
    },
}

/// Formats message `id` of `lang`'s catalogue with `args`, or says why not.
pub fn format(lang: Lang, id: &str, args: Option<&FluentArgs>) -> Result<String, TextError> {
    let b = bundle(lang);
    let Some(pattern) = b.get_message(id).and_then(|m| m.value()) else {
        return Err(TextError::Missing {
            lang,
            id: id.to_string(),
        });
    };
    let mut errors = Vec::new();
    let text = b.format_pattern(pattern, args, &mut errors).into_owned();
    if errors.is_empty() {
        Ok(text)
    } else {
        Err(TextError::Format {
            lang,
            id: id.to_string(),
            errors: errors.iter().map(ToString::to_string).collect(),
            text,
        })
    }
}

/// Does `lang`'s catalogue have a message `id`?
pub fn has(lang: Lang, id: &str) -> bool {
    bundle(lang)
        .get_message(id)
        .is_some_and(|m| m.value().is_some())
}

/// Message `id` with `args` in the chosen language: German falls back to
/// English message by message, and an id in no catalogue is shown as it is
/// (see the module docs). A message that formats with errors is shown as
/// Fluent formatted it (the missing variable in braces) and logged.
pub fn text(id: &str, args: Option<&FluentArgs>) -> String {
    text_in(lang(), id, args)
}

/// [`text`] in a given language.
pub fn text_in(lang: Lang, id: &str, args: Option<&FluentArgs>) -> String {
    let mut tried = vec![lang];
    if lang != Lang::En {
        tried.push(Lang::En);
    }
    for l in tried {
        match format(l, id, args) {
            Ok(t) => return t,
            Err(TextError::Format { text, errors, .. }) => {
                tracing::warn!(id, lang = l.code(), ?errors, "message formats with errors");
                return text;
            }
            Err(TextError::Missing { .. }) => {}
        }
    }
    id.to_string()
}

/// Message `id` in the chosen language (falling back to English), else
/// `fallback` (for ids made at run time, `measure-<set>-<name>`, that only
/// some names have).
pub fn text_or(id: &str, fallback: &str) -> String {
    let l = lang();
    if has(l, id) || has(Lang::En, id) {
        text_in(l, id, None)
    } else {
        fallback.to_string()
    }
}

/// The operator's name of measurement `name` of set `set`, whose own label
/// is `label`: the catalogue's `measure-<set>-<name>` where it has one (the
/// built-in `quick` set, the measuring flow's), else the set's label.
pub fn measurement_label(set: &str, name: &str, label: &str) -> String {
    text_or(&format!("measure-{set}-{name}"), label)
}

/// The instruction for measurement `name` of set `set`, whose own
/// description is `description`: the catalogue's `measure-<set>-<name>-how`
/// where it has one (the `quick` set), else the set's description.
pub fn measurement_instruction(set: &str, name: &str, description: &str) -> String {
    text_or(&format!("measure-{set}-{name}-how"), description)
}

/// Operator text of message `id` in the chosen language, formatted now:
/// `tr!("key")`, `tr!("key", name = value, n = 3)` (a value is anything
/// Fluent takes: text, or a number for plural forms). The id must be a
/// literal, so that the catalogue test finds it in the sources.
macro_rules! tr {
    ($id:literal $(,)?) => {
        $crate::i18n::text($id, None)
    };
    ($id:literal, $($name:ident = $value:expr),+ $(,)?) => {{
        let mut args = $crate::i18n::FluentArgs::new();
        $( args.set(stringify!($name), $value); )+
        $crate::i18n::text($id, Some(&args))
    }};
}
pub(crate) use tr;

/// A message id kept to be formatted later, where it is drawn (the key
/// bindings' words): `msg!("key")` is the id itself, marked so that the
/// catalogue test finds it.
macro_rules! msg {
    ($id:literal) => {
        $id
    };
}
pub(crate) use msg;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locales_name_their_language() {
        assert_eq!(Lang::from_locale("de_DE.UTF-8"), Lang::De);
        assert_eq!(Lang::from_locale("de"), Lang::De);
        assert_eq!(Lang::from_locale("de_AT@euro"), Lang::De);
        assert_eq!(Lang::from_locale("en_GB.UTF-8"), Lang::En);
        assert_eq!(Lang::from_locale("C"), Lang::En);
        assert_eq!(Lang::from_locale("POSIX"), Lang::En);
        assert_eq!(Lang::from_locale("fr_FR.UTF-8"), Lang::En);
        assert_eq!(Lang::from_locale("deu"), Lang::En);
    }

    #[test]
    fn lc_all_then_lc_messages_then_lang() {
        let vars = |all: &'static str, msgs: &'static str, lang: &'static str| {
            move |name: &str| {
                let v = match name {
                    "LC_ALL" => all,
                    "LC_MESSAGES" => msgs,
                    "LANG" => lang,
                    _ => "",
                };
                (!v.is_empty()).then(|| v.to_string())
            }
        };
        assert_eq!(Lang::from_vars(vars("", "", "de_DE.UTF-8")), Lang::De);
        assert_eq!(Lang::from_vars(vars("C", "", "de_DE.UTF-8")), Lang::En);
        assert_eq!(Lang::from_vars(vars("", "de_CH", "en_US")), Lang::De);
        assert_eq!(Lang::from_vars(vars("", "", "")), Lang::En);
        // Set but empty counts as unset.
        let empty_all = |name: &str| match name {
            "LC_ALL" => Some(String::new()),
            "LANG" => Some("de_DE".to_string()),
            _ => None,
        };
        assert_eq!(Lang::from_vars(empty_all), Lang::De);
    }

    #[test]
    fn german_falls_back_to_english_and_unknown_ids_show_themselves() {
        assert_eq!(
            text_in(Lang::De, "no-such-message", None),
            "no-such-message"
        );
        assert_eq!(text_in(Lang::En, "export", None), "export");
        // A message of both languages differs between them.
        let en = text_in(Lang::En, "screen-new-customer", None);
        let de = text_in(Lang::De, "screen-new-customer", None);
        assert_eq!(en, "New customer");
        assert_ne!(en, de);
    }

    #[test]
    fn variables_and_plurals_are_placed() {
        let mut args = FluentArgs::new();
        args.set("n", 1);
        assert_eq!(
            format(Lang::En, "estimating-fitting", Some(&args)).unwrap(),
            "Fitting the body to 1 reading; Esc cancels."
        );
        args.set("n", 4);
        assert_eq!(
            format(Lang::En, "estimating-fitting", Some(&args)).unwrap(),
            "Fitting the body to 4 readings; Esc cancels."
        );
        let de = format(Lang::De, "estimating-fitting", Some(&args)).unwrap();
        assert!(de.contains('4') && !de.contains('\u{2068}'), "{de}");
        // A variable not given is an error, not a panic.
        assert!(matches!(
            format(Lang::En, "estimating-fitting", None),
            Err(TextError::Format { .. })
        ));
    }

    #[test]
    fn quick_measurements_have_german_names_and_others_keep_their_label() {
        // The library's default language is English: the set's own label.
        assert_eq!(
            measurement_label("quick", "chest", "Chest / bust"),
            "Chest / bust"
        );
        assert_eq!(measurement_label("ansur", "chest", "Chest"), "Chest");
        assert_eq!(
            text_in(Lang::De, "measure-quick-chest", None),
            "Brustumfang"
        );
    }
}
