//! The station's layers (see the module map in `src/lib.rs`): no module
//! imports one above it, and nothing but the session layer writes to the
//! store. Read from the source text: every `crate::<module>` path (and a
//! top-level file's `super::<module>`) outside comments is an import.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The top-level modules from the bottom up: each may import only those
/// before it (and itself). `check` and `estimate` share a rank: neither
/// imports the other.
const RANKS: &[(&str, u32)] = &[
    ("alloc", 0),
    ("i18n", 0),
    ("text", 1),
    ("warning_text", 1),
    ("store", 2),
    ("link", 3),
    ("session", 4),
    ("check", 5),
    ("estimate", 5),
    ("sync", 5),
    ("services", 6),
    ("tui", 7),
    ("cli", 8),
];

fn rank(module: &str) -> Option<u32> {
    RANKS.iter().find(|(m, _)| *m == module).map(|(_, r)| *r)
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

/// The top-level module a source file belongs to (`None`: `lib.rs`, `main.rs`).
fn module_of(src: &Path, file: &Path) -> Option<String> {
    let rel = file.strip_prefix(src).unwrap();
    let first = rel
        .components()
        .next()?
        .as_os_str()
        .to_string_lossy()
        .into_owned();
    let name = first.strip_suffix(".rs").unwrap_or(&first).to_string();
    (name != "lib" && name != "main").then_some(name)
}

/// The top-level modules `code` (one file, comments removed) names through
/// `crate::` (also `crate::{a, b::c}`) and, in a top-level file, `super::`.
fn imports(code: &str, top_level_file: bool) -> BTreeSet<String> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = BTreeSet::new();
    let mut prefixes = vec!["crate::"];
    if top_level_file {
        prefixes.push("super::");
    }
    for prefix in prefixes {
        for (i, _) in code.match_indices(prefix) {
            let before = code[..i].chars().next_back();
            if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == '$') {
                continue; // `$crate::`, `my_crate::`
            }
            let rest = &code[i + prefix.len()..];
            if let Some(group) = rest.strip_prefix('{') {
                // crate::{a, b::c, d}: the first segment of each top-level item.
                let mut depth = 0;
                let mut start = true;
                for (k, c) in group.char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' if depth == 0 => break,
                        '}' => depth -= 1,
                        ',' if depth == 0 => start = true,
                        c if start && !c.is_whitespace() => {
                            out.insert(ident(&group[k..]));
                            start = false;
                        }
                        _ => {}
                    }
                }
            } else {
                out.insert(ident(rest));
            }
        }
    }
    out.retain(|m| !m.is_empty());
    out
}

fn without_comments(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            // A `//` inside a string literal would cut code; the station's
            // sources put no `crate::` after one on a line.
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn no_module_imports_a_layer_above_it() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    files.sort();
    let mut violations = Vec::new();
    let mut checked = 0;
    for file in &files {
        let Some(module) = module_of(&src, file) else {
            continue;
        };
        let own = rank(&module).unwrap_or_else(|| {
            panic!(
                "{}: module {module} has no layer; add it to RANKS here and to the map in src/lib.rs",
                file.display()
            )
        });
        let top_level_file = file.parent() == Some(src.as_path());
        let code = without_comments(&std::fs::read_to_string(file).unwrap());
        for used in imports(&code, top_level_file) {
            if used == module {
                continue;
            }
            match rank(&used) {
                Some(r) if r < own => {}
                Some(_) => violations.push(format!(
                    "{} (layer of {module}) imports crate::{used}, which is not below it",
                    file.strip_prefix(&src).unwrap().display()
                )),
                // Macros and items of the crate root (none today) are fine.
                None => {}
            }
        }
        checked += 1;
    }
    assert!(
        checked > 20,
        "only {checked} files checked: is src/ where it was?"
    );
    assert!(violations.is_empty(), "{}", violations.join("\n"));
}

#[test]
fn only_the_session_layer_writes_to_the_store() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let mut writers = Vec::new();
    for file in &files {
        let rel = file.strip_prefix(&src).unwrap();
        let code = without_comments(&std::fs::read_to_string(file).unwrap());
        let writes = code.contains("WriteTx") || code.contains(".write(|");
        // The session layer is session.rs and its submodules (session/outbox.rs).
        let session_layer = rel == Path::new("session.rs") || rel.starts_with("session");
        if writes && !(rel.starts_with("store") || session_layer) {
            writers.push(rel.display().to_string());
        }
    }
    assert!(
        writers.is_empty(),
        "these write to the store directly; go through session::Sessions instead: {writers:?}"
    );
}

/// The check above would pass on an empty set of imports: it must see them.
#[test]
fn the_import_scanner_sees_paths_groups_and_super() {
    let code = "use crate::tui::app::App;\nuse crate::{store::Store, text};\nfn f() { $crate::x; crate::cli::run() }";
    let got: Vec<String> = imports(code, false).into_iter().collect();
    assert_eq!(got, ["cli", "store", "text", "tui"]);
    let got: Vec<String> = imports("use super::session::Sessions;", true)
        .into_iter()
        .collect();
    assert_eq!(got, ["session"]);
    assert!(imports("use super::Global;", false).is_empty());
    assert_eq!(without_comments("a // crate::cli"), "a ");
}
