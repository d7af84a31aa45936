//! The converted screens in German (`--lang de`), rendered into ratatui's
//! `TestBackend` at 80x24 and compared with reviewed snapshots
//! (`tests/snapshots/tui_german__*.snap`, insta), as `tui_screens` does in
//! English.
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
use tapeshape::store::{Session, SessionId, SessionStatus, SessionSummary};
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

fn summaries() -> Vec<SessionSummary> {
    let s = |id: i64, customer: &str, status, n, minute: i64| SessionSummary {
        session: Session {
            id: SessionId(id),
            customer_id: customer.into(),
            created_at_ms: 1_790_000_000_000 + minute * 60_000,
            updated_at_ms: 1_790_000_000_000 + minute * 60_000 + 180_000,
            status,
            measurement_set: Some("quick".into()),
            notes: None,
            consent: None,
        },
        current_readings: n,
        total_readings: n + 1,
        estimate_made_at_ms: None,
    };
    vec![
        s(2, "c-8f3k2a", SessionStatus::Done, 9, 20),
        s(1, "c-0q9z7m", SessionStatus::Abandoned, 1, 10),
    ]
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
            Event::History(summaries()),
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
