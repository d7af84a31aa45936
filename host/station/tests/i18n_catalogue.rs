//! The operator text's catalogues (`locales/<lang>/station.ftl`): each
//! parses, every shipped language has exactly the keys of every other, each
//! message uses the same variables in every language and formats without
//! errors given them, every id the sources name (`tr!("...")`, `msg!("...")`)
//! is in the English catalogue and every English key is named somewhere, and
//! the keys made at run time (`measure-quick-<name>`,
//! `measure-quick-<name>-how`, `set-description-<set>`) match the built-in
//! sets, in English word for word.
//!
//! Read from the catalogues as the program embeds them
//! ([`Lang::catalogue`]) and formatted through the program's own bundles
//! ([`i18n::format`]).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use fluent_syntax::ast;
use tapeshape::i18n::{self, FluentArgs, Lang};
use tapeshape::tui::app::BUILTIN_SET_CHOICES;

/// Message id -> the variables its value uses.
type Keys = BTreeMap<String, BTreeSet<String>>;

fn inline_vars(e: &ast::InlineExpression<&str>, out: &mut BTreeSet<String>) {
    match e {
        ast::InlineExpression::VariableReference { id } => {
            out.insert(id.name.to_string());
        }
        ast::InlineExpression::FunctionReference { arguments, .. } => {
            for p in &arguments.positional {
                inline_vars(p, out);
            }
            for n in &arguments.named {
                inline_vars(&n.value, out);
            }
        }
        ast::InlineExpression::TermReference {
            arguments: Some(arguments),
            ..
        } => {
            for p in &arguments.positional {
                inline_vars(p, out);
            }
        }
        ast::InlineExpression::Placeable { expression } => expr_vars(expression, out),
        _ => {}
    }
}

fn expr_vars(e: &ast::Expression<&str>, out: &mut BTreeSet<String>) {
    match e {
        ast::Expression::Inline(i) => inline_vars(i, out),
        ast::Expression::Select { selector, variants } => {
            inline_vars(selector, out);
            for v in variants {
                pattern_vars(&v.value, out);
            }
        }
    }
}

fn pattern_vars(p: &ast::Pattern<&str>, out: &mut BTreeSet<String>) {
    for el in &p.elements {
        if let ast::PatternElement::Placeable { expression } = el {
            expr_vars(expression, out);
        }
    }
}

/// The messages of `lang`'s catalogue, with their variables; fails on a
/// parse error, junk, a duplicate id or a message without a value.
fn keys(lang: Lang) -> Keys {
    let res = match fluent_syntax::parser::parse(lang.catalogue()) {
        Ok(r) => r,
        Err((_, errors)) => panic!("{lang:?} catalogue does not parse: {errors:?}"),
    };
    let mut keys = Keys::new();
    for entry in &res.body {
        match entry {
            ast::Entry::Message(m) => {
                let Some(value) = &m.value else {
                    panic!("{lang:?}: message {} has no value", m.id.name)
                };
                let mut vars = BTreeSet::new();
                pattern_vars(value, &mut vars);
                let dup = keys.insert(m.id.name.to_string(), vars);
                assert!(dup.is_none(), "{lang:?}: {} is defined twice", m.id.name);
            }
            ast::Entry::Junk { content } => panic!("{lang:?}: junk in the catalogue: {content}"),
            _ => {}
        }
    }
    assert!(!keys.is_empty(), "{lang:?} catalogue is empty");
    keys
}

#[test]
fn every_language_has_every_key_with_the_same_variables() {
    let en = keys(Lang::En);
    for lang in Lang::ALL {
        let other = keys(lang);
        let missing: Vec<_> = en.keys().filter(|k| !other.contains_key(*k)).collect();
        let extra: Vec<_> = other.keys().filter(|k| !en.contains_key(*k)).collect();
        assert!(
            missing.is_empty() && extra.is_empty(),
            "{lang:?}: keys missing {missing:?}, keys English does not have {extra:?}"
        );
        for (k, vars) in &en {
            assert_eq!(
                &other[k], vars,
                "{lang:?}: message {k} uses other variables than English's"
            );
        }
    }
}

#[test]
fn every_message_formats_without_errors_given_its_variables() {
    for lang in Lang::ALL {
        for (id, vars) in keys(lang) {
            // Numbers (1: a plural's `one`, 3: `other`) and text: each kind
            // of value a variable may be given.
            for value in [Some(1), Some(3), None] {
                let mut args = FluentArgs::new();
                for v in &vars {
                    match value {
                        Some(n) => args.set(v.clone(), n),
                        None => args.set(v.clone(), format!("<{v}>")),
                    }
                }
                let text = i18n::format(lang, &id, Some(&args)).unwrap_or_else(|e| panic!("{e}"));
                assert!(!text.trim().is_empty(), "{lang:?}: {id} is empty");
                assert!(
                    !text.contains(['\u{2068}', '\u{2069}']),
                    "{lang:?}: {id} has isolation marks: {text:?}"
                );
                if value.is_none() {
                    // Text selects a plural's default variant, and every
                    // variable shows there: none is dropped.
                    for v in &vars {
                        assert!(
                            text.contains(&format!("<{v}>")),
                            "{lang:?}: {id} drops ${v}: {text:?}"
                        );
                    }
                }
            }
        }
    }
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Every `tr!("id"` and `msg!("id"` literal in `src/**/*.rs`, with where it is.
fn ids_in_sources() -> BTreeMap<String, String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut ids = BTreeMap::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        // Docs and comments name ids by way of example: blanked, lines kept.
        let code: String = text
            .lines()
            .map(|l| {
                if l.trim_start().starts_with("//") {
                    ""
                } else {
                    l
                }
            })
            .collect::<Vec<_>>()
            .join("\n");
        for mac in ["tr!(", "msg!("] {
            for (i, _) in code.match_indices(mac) {
                let before = code[..i].chars().next_back();
                if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                    continue; // `include_str!(`
                }
                // The id may be on the next line (`tr!(\n    "id",`).
                let rest = code[i + mac.len()..].trim_start();
                let Some(rest) = rest.strip_prefix('"') else {
                    continue; // the macros' own definitions
                };
                let id: String = rest.chars().take_while(|c| *c != '"').collect();
                let line = code[..i].matches('\n').count() + 1;
                let place = format!("{}:{line}", file.strip_prefix(&src).unwrap().display());
                ids.entry(id).or_insert(place);
            }
        }
    }
    ids
}

/// Ids made at run time: the prefixes, and the names they are made of.
fn runtime_ids() -> BTreeSet<String> {
    let mut ids = BTreeSet::new();
    let quick = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    for d in &quick.definitions {
        ids.insert(format!("measure-quick-{}", d.name));
        ids.insert(format!("measure-quick-{}-how", d.name));
    }
    for set in BUILTIN_SET_CHOICES {
        ids.insert(format!("set-description-{set}"));
    }
    ids
}

#[test]
fn every_id_in_the_sources_is_in_english_and_every_english_key_is_used() {
    let en = keys(Lang::En);
    let used = ids_in_sources();
    assert!(used.len() > 100, "the scan found only {} ids", used.len());
    let missing: Vec<_> = used
        .iter()
        .filter(|(id, _)| !en.contains_key(*id))
        .map(|(id, at)| format!("{id} ({at})"))
        .collect();
    assert!(
        missing.is_empty(),
        "ids not in locales/en/station.ftl: {missing:?}"
    );
    let runtime = runtime_ids();
    let unused: Vec<_> = en
        .keys()
        .filter(|k| !used.contains_key(*k) && !runtime.contains(*k))
        .collect();
    assert!(unused.is_empty(), "English keys nothing uses: {unused:?}");
}

#[test]
fn runtime_ids_match_the_built_in_sets_word_for_word_in_english() {
    let en = keys(Lang::En);
    let quick = tapeshape_measure::MeasurementSet::builtin("quick").unwrap();
    for d in &quick.definitions {
        let id = format!("measure-quick-{}", d.name);
        assert!(
            en.contains_key(&id),
            "no {id} for the quick set's {}",
            d.name
        );
        assert_eq!(i18n::format(Lang::En, &id, None).unwrap(), d.label, "{id}");
        let de = i18n::format(Lang::De, &id, None).unwrap();
        assert_ne!(de, d.label, "{id} is not German");
        let how = format!("{id}-how");
        assert_eq!(
            i18n::format(Lang::En, &how, None).unwrap(),
            d.description,
            "{how}"
        );
        let de = i18n::format(Lang::De, &how, None).unwrap();
        assert_ne!(de, d.description, "{how} is not German");
    }
    for set in BUILTIN_SET_CHOICES {
        let s = tapeshape_measure::MeasurementSet::builtin(set).unwrap();
        let first = s.description.split(". ").next().unwrap().trim();
        let id = format!("set-description-{set}");
        assert_eq!(i18n::format(Lang::En, &id, None).unwrap(), first, "{id}");
    }
}

#[test]
fn the_library_speaks_english_until_told_otherwise() {
    // This binary never chooses a language (the German screens have their
    // own test binary): the default is English.
    assert_eq!(i18n::lang(), Lang::En);
    assert_eq!(i18n::text("screen-history", None), "History");
    assert_eq!(
        i18n::measurement_label("quick", "inside_leg", "Inside leg"),
        "Inside leg"
    );
}
