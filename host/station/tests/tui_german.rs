//! The screens in German (`--lang de`), rendered into ratatui's
//! `TestBackend` at 80x24 and compared with reviewed snapshots
//! (`tests/snapshots/tui_german__*.snap`, insta), as `tui_screens` does in
//! English, from the same apps (`tui_fixture`).
//!
//! A test binary of its own: the language is chosen once per process
//! (`i18n::choose`), so German here cannot leak into the English snapshots.

mod tui_fixture;

use crossterm::event::KeyCode;
use ratatui::backend::TestBackend;
use ratatui::Terminal;
use tapeshape::i18n::{self, Lang};
use tapeshape::link::LinkEvent;
use tapeshape::session::ResumeOffer;
use tapeshape::store::SessionId;
use tapeshape::tui::app::{App, Event};
use tapeshape::tui::draw;
use tapeshape_protocol::Fault;
use tui_fixture::*;

/// Renders `app` in German (every test chooses it first; choosing the same
/// language again is no error).
fn render(app: &App) -> String {
    german();
    let mut t = Terminal::new(TestBackend::new(80, 24)).unwrap();
    t.draw(|f| draw(app, f)).unwrap();
    t.backend().to_string()
}

fn german() {
    i18n::choose(Lang::De).expect("nothing in this binary chooses another language");
}

#[test]
fn new_customer_in_german() {
    german();
    let mut a = app(false);
    connect(&mut a);
    // `w` (weiblich) chooses female as `f` does.
    send(&mut a, [ch('w'), key(KeyCode::Down), ch('3'), ch('4')]);
    let screen = render(&a);
    assert!(
        screen.contains("Kunden-ID") && screen.contains("weiblich"),
        "{screen}"
    );
    insta::assert_snapshot!(screen);
}

#[test]
fn refused_age_is_explained_in_german() {
    german();
    let mut a = app(false);
    send(
        &mut a,
        [
            key(KeyCode::Down),
            ch('9'),
            ch('9'),
            ch('9'),
            key(KeyCode::Enter),
        ],
    );
    let e = a.form.error.clone().unwrap();
    assert!(
        e.contains("999") && e.contains("zwischen 16 und 110"),
        "{e}"
    );
}

#[test]
fn resume_offer_in_german() {
    german();
    let mut a = app(false);
    connect(&mut a);
    send(
        &mut a,
        [Event::Resumable(ResumeOffer {
            session: SessionId(12),
            customer: "c-8f3k2a".into(),
            set: Some("quick".into()),
            readings: 4,
        })],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn device_screen_with_faults_in_german() {
    german();
    let mut a = app(false);
    connect(&mut a);
    send(
        &mut a,
        [
            Event::Link(LinkEvent::Fault(Fault::TapeSilent { silent_ms: 3200 })),
            Event::Link(LinkEvent::Fault(Fault::TapeRecovered)),
            ch('d'),
        ],
    );
    let screen = render(&a);
    // The fault's fixed word stays English (scripts match it), its words
    // are German.
    assert!(screen.contains("tape-silent: seit 3.2 s"), "{screen}");
    insta::assert_snapshot!(screen);
}

#[test]
fn history_delete_asks_first_in_german() {
    german();
    let mut a = app(false);
    connect(&mut a);
    send(
        &mut a,
        [
            ch('h'),
            // The two closed sessions (no session is open here).
            Event::History(summaries().split_off(1)),
            key(KeyCode::Down),
            key(KeyCode::Delete),
        ],
    );
    insta::assert_snapshot!(render(&a));
}

#[test]
fn help_in_german() {
    german();
    let mut a = app(false);
    connect(&mut a);
    send(&mut a, [ch('?')]);
    let screen = render(&a);
    assert!(
        screen.contains("Strg-C") && screen.contains("Überall"),
        "{screen}"
    );
    insta::assert_snapshot!(screen);
}

#[test]
fn measuring_with_a_flag_in_german() {
    german();
    let mut a = measuring();
    committed(&mut a, 2, "waist", 5_800);
    // The check's own sentence stays English (`check.rs`, shared with the
    // line mode); the screen's words around it are German.
    checked(
        &mut a,
        "waist",
        5_800,
        Some("waist 58.0 cm is 6 SD below what stature, chest predict (84.1 +/- 4.3 cm)"),
    );
    let screen = render(&a);
    for words in [
        "Jetzt: Taille (Nabelhöhe)",
        "Körperhöhe",
        "Brustumfang",
        "Neu messen (Band halten)",
        "3 von 9 genommen",
    ] {
        assert!(screen.contains(words), "{words:?} missing:\n{screen}");
    }
    assert!(
        !screen.contains("Chest / bust") && !screen.contains("Now:"),
        "{screen}"
    );
    insta::assert_snapshot!(screen);
}

#[test]
fn careful_second_reading_in_german() {
    german();
    let mut a = app(false);
    connect(&mut a);
    open_careful(&mut a);
    committed(&mut a, 0, "stature", 17_650);
    live(&mut a, 17_655);
    let screen = render(&a);
    assert!(
        screen.contains("Doppelt Messung 2 von 2 (bisher 176.5"),
        "{screen}"
    );
    // The instruction is the quick set's, in German.
    assert!(screen.contains("Boden bis zum Scheitel"), "{screen}");
    insta::assert_snapshot!(screen);
}

/// A hand-made chart whose answers are known: chest 103.8 cm sits 2 mm
/// below M's upper edge, the inside leg is beyond every size (too short),
/// the hip above the dress's only size (tight).
fn sizes_in_german() -> Vec<String> {
    use tapeshape_sizes::{recommend, Chart, DimensionKind, KnownDimension, Readings};
    let known = [
        KnownDimension::new("chest", DimensionKind::Girth),
        KnownDimension::new("waist", DimensionKind::Girth),
        KnownDimension::new("hip", DimensionKind::Girth),
        KnownDimension::new("inside_leg", DimensionKind::Length),
    ];
    let chart = Chart::from_toml_str(
        r#"
[chart]
name = "hand-made"
units = "cm"

[[garment]]
name = "shirt"
primary = ["chest"]
[[garment.size]]
label = "M"
chest = [96, 104]
[[garment.size]]
label = "L"
chest = [104, 112]

[[garment]]
name = "trousers"
primary = ["waist", "inside_leg"]
[[garment.size]]
label = "W88/L80"
waist = [84, 92]
inside_leg = [76, 84]

[[garment]]
name = "dress"
primary = ["hip"]
[[garment.size]]
label = "40"
hip = [96, 104]
"#,
        "hand-made",
        &known,
    )
    .unwrap();
    let mut r = Readings::new();
    for (name, mm) in [
        ("chest", 1038.0),
        ("waist", 860.0),
        ("inside_leg", 860.0),
        ("hip", 1060.0),
    ] {
        r.insert_measured(name, mm, 5.0).unwrap();
    }
    tapeshape::estimate::sizes::screen_lines(&recommend(&chart, &r))
}

#[test]
fn result_with_sizes_in_german() {
    german();
    let mut a = result_app();
    let sizes = sizes_in_german();
    assert_eq!(sizes.len(), 3, "{sizes:?}");
    assert!(
        sizes[0].starts_with("shirt: M (") && sizes[0].contains("oder L"),
        "{sizes:?}"
    );
    assert!(sizes[1].ends_with("; Innenbeinlänge zu kurz"), "{sizes:?}");
    assert!(sizes[2].ends_with("; Hüftumfang zu eng"), "{sizes:?}");
    if let Some(s) = a.result.summary.as_mut() {
        s.sizes = sizes;
        // As the services word it (`summarise`), in German.
        let mut args = i18n::FluentArgs::new();
        args.set("shape", i18n::text("plausibility-typical", None));
        args.set("body", "6.5");
        args.set("readings", i18n::text("plausibility-typical", None));
        args.set("distance", "1.2");
        s.plausibility = i18n::text("result-plausibility-value", Some(&args));
    }
    let screen = render(&a);
    for words in [
        "Größen",
        "Messung",
        "Körperhöhe",
        "Plausibilität",
        "Körper typisch",
    ] {
        assert!(screen.contains(words), "{words:?} missing:\n{screen}");
    }
    insta::assert_snapshot!(screen);
}
