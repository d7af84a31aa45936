//! The operator flow through `update` alone: no terminal, no tape, no
//! estimator. Each test states what an operator would see go wrong if the
//! transition were wrong.

mod tui_fixture;

use crossterm::event::KeyCode;
use tapeshape::services::{EstimateEvent, Stage};
use tapeshape::store::{Consent, Mark, ReadingId, SessionId, SessionStatus};
use tapeshape::tui::app::{Effect, Event, ItemState, Screen};
use tapeshape::tui::ShowLength as _;
use tapeshape_estimator::Unit;
use tui_fixture::*;

#[test]
fn a_new_customer_form_creates_a_session_with_the_chosen_set_and_notes() {
    let mut a = app(false);
    assert_eq!(a.screen, Screen::NewCustomer);
    // Sex field is focused first: f = female; down to age, type 34; down to
    // the set, right = ansur.
    let fx = send(
        &mut a,
        [
            ch('f'),
            key(KeyCode::Down),
            ch('3'),
            ch('4'),
            ch('x'), // not a digit: ignored
            key(KeyCode::Down),
            key(KeyCode::Right),
            key(KeyCode::Enter),
        ],
    );
    let create = fx
        .iter()
        .find_map(|e| match e {
            Effect::CreateSession {
                customer,
                set,
                notes,
                consent,
                ..
            } => Some((customer.clone(), set.clone(), notes.clone(), *consent)),
            _ => None,
        })
        .expect("Enter creates a session");
    assert!(
        create.0.starts_with("c-") && create.0.len() == 8,
        "{create:?}"
    );
    assert_eq!(create.1, "ansur");
    assert_eq!(create.2.as_deref(), Some("sex: female, age: 34"));
    // Not asked otherwise: this visit only (the chain keeps nothing past its
    // retention unless the customer chooses to).
    assert_eq!(create.3, Consent::Visit);
}

#[test]
fn the_customer_chooses_to_keep_their_data_on_the_form() {
    let consent_of = |keys: Vec<Event>| {
        let mut a = app(false);
        let fx = send(&mut a, keys);
        fx.iter()
            .find_map(|e| match e {
                Effect::CreateSession { consent, .. } => Some(*consent),
                _ => None,
            })
            .expect("Enter creates a session")
    };
    // Sex, age, set, readings, then the data choice (the last field): k
    // keeps.
    let to_consent = || vec![key(KeyCode::Down); 4];
    let with = |extra: &[Event]| {
        let mut k = to_consent();
        k.extend_from_slice(extra);
        k.push(key(KeyCode::Enter));
        k
    };
    assert_eq!(consent_of(with(&[ch('k')])), Consent::Keep);
    assert_eq!(consent_of(with(&[key(KeyCode::Right)])), Consent::Keep);
    assert_eq!(
        consent_of(with(&[ch('k'), ch('v')])),
        Consent::Visit,
        "v takes the choice back"
    );
    assert_eq!(
        consent_of(with(&[key(KeyCode::Right), key(KeyCode::Left)])),
        Consent::Visit
    );
    // k elsewhere (typed into the customer id) does not choose.
    assert_eq!(
        consent_of(vec![key(KeyCode::Up), ch('k'), key(KeyCode::Enter)]),
        Consent::Visit
    );
}

#[test]
fn careful_mode_is_chosen_per_customer_on_the_form() {
    let careful_of = |a: &mut tapeshape::tui::app::App, keys: Vec<Event>| {
        let fx = send(a, keys);
        fx.iter()
            .find_map(|e| match e {
                Effect::CreateSession { careful, .. } => Some(*careful),
                _ => None,
            })
            .expect("Enter creates a session")
    };
    // Sex, age, set, then the readings field.
    let with = |extra: &[Event]| {
        let mut k = vec![key(KeyCode::Down); 3];
        k.extend_from_slice(extra);
        k.push(key(KeyCode::Enter));
        k
    };
    assert!(!careful_of(&mut app(false), with(&[])), "once by default");
    assert!(careful_of(&mut app(false), with(&[ch('2')])));
    assert!(careful_of(&mut app(false), with(&[key(KeyCode::Right)])));
    assert!(!careful_of(&mut app(false), with(&[ch('2'), ch('1')])));
    // 2 typed into the age is an age, not the choice.
    assert!(!careful_of(
        &mut app(false),
        vec![key(KeyCode::Down), ch('2'), ch('5'), key(KeyCode::Enter)]
    ));

    // A station started with --careful offers it to each customer, and one
    // customer taken once does not make the next one once too.
    let mut a = app(false);
    a.form = a.form.clone().with_careful_default(true);
    assert!(!careful_of(&mut a, with(&[ch('1')])));
    let next = a.form.next_customer();
    assert!(next.careful, "the next customer gets the station's default");
    let mut a = app(false);
    a.form = a.form.clone().with_careful_default(false);
    assert!(careful_of(&mut a, with(&[ch('2')])));
    assert!(!a.form.next_customer().careful);
}

#[test]
fn an_impossible_age_is_refused_with_a_message() {
    let mut a = app(false);
    let fx = send(&mut a, [key(KeyCode::Down), ch('7'), key(KeyCode::Enter)]);
    assert!(!fx.iter().any(|e| matches!(e, Effect::CreateSession { .. })));
    assert!(a.form.error.as_deref().unwrap().contains("16 and 110"));
}

#[test]
fn readings_go_to_the_current_measurement_and_advance_after_the_check() {
    let mut a = app(false);
    connect(&mut a);
    let fx = open_session(&mut a, &[]);
    assert_eq!(a.screen, Screen::Measuring);
    assert!(fx.contains(&Effect::SetLinkSession(Some(SessionId(3)))));
    assert_eq!(naming(&fx), Some(Some("stature".into())));
    let fx = committed(&mut a, 0, "stature", 17_650);
    // Checked before the app moves on; the tape's naming stays put so a
    // quick second hold is a retake of the same measurement.
    assert!(fx.iter().any(|e| matches!(e, Effect::Check(r) if r.name == "stature" && (r.value_mm - 1765.0).abs() < 1e-9)));
    assert_eq!(current(&a).as_deref(), Some("stature"));
    let fx = checked(&mut a, "stature", 17_650, None);
    assert_eq!(current(&a).as_deref(), Some("chest"));
    assert_eq!(naming(&fx), Some(Some("chest".into())));
    // The next check sees the accepted reading as evidence.
    let fx = committed(&mut a, 1, "chest", 9_820);
    let req = fx
        .iter()
        .find_map(|e| match e {
            Effect::Check(r) => Some(r.clone()),
            _ => None,
        })
        .unwrap();
    assert_eq!(req.others, vec![("stature".to_string(), 1765.0)]);
}

#[test]
fn a_flagged_reading_stays_current_until_retaken_or_kept() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    committed(&mut a, 1, "chest", 5_800);
    checked(
        &mut a,
        "chest",
        5_800,
        Some("chest 58.0 cm is 6 SD below what stature predicts"),
    );
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[1].state, ItemState::Flagged);
    assert_eq!(
        current(&a).as_deref(),
        Some("chest"),
        "flag keeps it current"
    );
    assert!(a.notice.as_ref().unwrap().1.contains("Measure again"));
    // Measured again: the retake replaces the value, the old one is history.
    committed(&mut a, 2, "chest", 9_820);
    checked(&mut a, "chest", 9_820, None);
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[1].state, ItemState::Done);
    assert_eq!(s.items[1].value, Some(9_820));
    assert_eq!(s.items[1].previous, vec![5_800]);
    assert_eq!(current(&a).as_deref(), Some("waist"));

    // Another flag, this time kept with Enter.
    committed(&mut a, 3, "waist", 3_000);
    checked(&mut a, "waist", 3_000, Some("waist 30.0 cm is 9 SD below"));
    send(&mut a, [key(KeyCode::Enter)]);
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[2].state, ItemState::Done);
    assert!(s.items[2].kept_flagged);
    assert_eq!(current(&a).as_deref(), Some("hip"));
    // The estimate asks for the kept reading to be kept (the estimator then
    // estimates with it instead of refusing), and only that one.
    let request = s.estimate_request();
    assert_eq!(request.kept, vec!["waist".to_string()]);
    assert_eq!(request.readings.len(), 3);
}

#[test]
fn the_estimate_takes_the_sex_from_the_new_customer_form() {
    use tapeshape::tui::screens::new_customer::sex_of_notes;
    use tapeshape_population::ansur::Sex;
    assert_eq!(
        sex_of_notes(Some("sex: female, age: 34")),
        Some(Sex::Female)
    );
    assert_eq!(sex_of_notes(Some("sex: male")), Some(Sex::Male));
    assert_eq!(sex_of_notes(Some("sex: not given, age: 50")), None);
    assert_eq!(sex_of_notes(Some("met at the door")), None);
    assert_eq!(sex_of_notes(None), None);
}

#[test]
fn a_stale_check_result_does_not_overwrite_a_retake() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    committed(&mut a, 0, "stature", 1_765);
    committed(&mut a, 1, "stature", 17_650);
    // The first reading's (flagged) check arrives late: ignored.
    checked(
        &mut a,
        "stature",
        1_765,
        Some("stature 17.7 cm looks like ..."),
    );
    assert_eq!(
        a.session.as_ref().unwrap().items[0].state,
        ItemState::Checking
    );
    checked(&mut a, "stature", 17_650, None);
    assert_eq!(a.session.as_ref().unwrap().items[0].state, ItemState::Done);
}

#[test]
fn retake_moves_the_tape_to_the_selected_measurement() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    take(&mut a, 1, "chest", 9_820);
    assert_eq!(current(&a).as_deref(), Some("waist"));
    // Cursor up to chest, r.
    let fx = send(&mut a, [key(KeyCode::Up), ch('r')]);
    assert_eq!(current(&a).as_deref(), Some("chest"));
    assert_eq!(naming(&fx), Some(Some("chest".into())));
    take(&mut a, 2, "chest", 9_900);
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[1].value, Some(9_900));
    assert_eq!(s.items[1].previous, vec![9_820]);
    assert!(
        a.notice
            .as_ref()
            .unwrap()
            .1
            .contains("99.0 cm (retake; was 98.2 cm)"),
        "{:?}",
        a.notice
    );
    // After the retake the tape goes on with the first one still to take.
    assert_eq!(current(&a).as_deref(), Some("waist"));
}

#[test]
fn skip_then_undo_restores_the_measurement() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    let fx = send(&mut a, [ch('s')]);
    assert_eq!(
        a.session.as_ref().unwrap().items[0].state,
        ItemState::Skipped
    );
    // The skip is stored, so a resumed session still shows it.
    assert!(fx.contains(&Effect::SetMark {
        session: SessionId(3),
        name: "stature".into(),
        mark: Some(Mark::Skipped)
    }));
    assert_eq!(current(&a).as_deref(), Some("chest"));
    let fx = send(&mut a, [ch('u')]);
    assert!(fx.contains(&Effect::SetMark {
        session: SessionId(3),
        name: "stature".into(),
        mark: None
    }));
    assert_eq!(a.session.as_ref().unwrap().items[0].state, ItemState::Todo);
    assert_eq!(current(&a).as_deref(), Some("stature"));
    assert_eq!(naming(&fx), Some(Some("stature".into())));
    // Skipped measurements are left out of the estimate.
    send(&mut a, [ch('s')]);
    take(&mut a, 0, "chest", 9_820);
    let fx = send(&mut a, [ch('e')]);
    let job = fx
        .iter()
        .find_map(|e| match e {
            Effect::StartEstimate(j) => Some(j.clone()),
            _ => None,
        })
        .unwrap();
    assert_eq!(job.readings, vec![("chest".to_string(), 982.0)]);
}

#[test]
fn undo_of_a_reading_leaves_it_out_of_the_estimate_and_asks_for_it_again() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    take(&mut a, 1, "chest", 9_820);
    let fx = send(&mut a, [ch('u')]);
    // Withdrawn in the store too (reading ids are 100 + seq in the fixture),
    // so a resumed session does not bring it back.
    assert!(fx.contains(&Effect::WithdrawReading(ReadingId(101))));
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[1].state, ItemState::Todo);
    assert_eq!(s.items[1].value, None);
    assert_eq!(current(&a).as_deref(), Some("chest"));
    assert_eq!(s.accepted(), vec![("stature".to_string(), 1765.0)]);
    assert!(a.notice.as_ref().unwrap().1.contains("history"));
    // Nothing more to undo after everything is undone.
    send(&mut a, [ch('u'), ch('u'), ch('u')]);
    assert_eq!(a.notice.as_ref().unwrap().1, "Nothing to undo");
    assert!(a.session.as_ref().unwrap().accepted().is_empty());
}

#[test]
fn unit_toggle_changes_display_only() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    send(&mut a, [ch('i')]);
    assert_eq!(a.unit, Unit::In);
    assert_eq!(a.unit.format(254), "1.00 in");
    assert_eq!(a.unit.format(17_650), "69.49 in");
    send(&mut a, [ch('i')]);
    assert_eq!(a.unit, Unit::Cm);
    assert_eq!(a.unit.format(17_650), "176.5 cm");
    assert_eq!(a.session.as_ref().unwrap().items[0].value, Some(17_650));
}

#[test]
fn enter_captures_the_live_value_only_when_a_tape_is_connected() {
    let mut a = app(false);
    open_session(&mut a, &[]);
    let fx = send(&mut a, [key(KeyCode::Enter)]);
    assert!(!fx.iter().any(|e| matches!(e, Effect::CaptureLive { .. })));
    connect(&mut a);
    live(&mut a, 17_642);
    let fx = send(&mut a, [key(KeyCode::Enter)]);
    assert!(fx.contains(&Effect::CaptureLive {
        session: SessionId(3),
        name: "stature".into(),
        value_tenth_mm: 17_642,
        unit_shown: tapeshape_protocol::UnitShown::Metric,
    }));
    unplug(&mut a);
    let fx = send(&mut a, [key(KeyCode::Enter)]);
    assert!(!fx.iter().any(|e| matches!(e, Effect::CaptureLive { .. })));
}

#[test]
fn unplugging_keeps_the_session_and_its_readings() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    let fx = send(&mut a, []);
    assert!(fx.is_empty());
    unplug(&mut a);
    let fx = send(&mut a, [Event::Tick]);
    // Nothing is re-pointed: the link keeps the session and naming.
    assert!(fx.is_empty(), "{fx:?}");
    assert_eq!(a.session.as_ref().unwrap().items[0].value, Some(17_650));
    assert_eq!(current(&a).as_deref(), Some("chest"));
    connect(&mut a);
    take(&mut a, 1, "chest", 9_820);
    assert_eq!(a.session.as_ref().unwrap().accepted().len(), 2);
}

#[test]
fn a_resumed_session_continues_with_the_first_missing_measurement() {
    let mut a = app(false);
    send(
        &mut a,
        [Event::Resumable(tapeshape::session::ResumeOffer {
            session: SessionId(3),
            customer: "c-test".into(),
            set: Some("quick".into()),
            readings: 2,
        })],
    );
    let fx = send(&mut a, [ch('y')]);
    assert!(fx.contains(&Effect::OpenSession(SessionId(3))));
    open_session(&mut a, &[("stature", 17_650), ("waist", 8_400)]);
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[0].state, ItemState::Done);
    assert_eq!(s.items[2].state, ItemState::Done);
    assert_eq!(current(&a).as_deref(), Some("chest"));
}

/// The demo's simulated operator (the `demo` feature).
#[cfg(feature = "demo")]
mod simulated_operator {
    use super::*;
    use crossterm::event::KeyEvent;
    use tapeshape::tui::app::Pilot;
    use tapeshape::tui::operator::{Autopilot, SimOperator};

    #[test]
    fn the_first_human_key_takes_over_from_the_simulated_operator() {
        let mut a = app(true);
        assert_eq!(a.demo, Some(Pilot::Simulated));
        let mut pilot = Autopilot::new(SimOperator::new(None, std::time::Duration::ZERO));
        assert!(pilot.driving());
        connect(&mut a);
        open_session(&mut a, &[]);
        // The simulated operator's keys act while it drives: on the measuring
        // screen it asks the simulated tape for the current measurement.
        let keys = pilot.tick(&a, std::time::Instant::now());
        let fx = send(&mut a, keys);
        assert!(fx.contains(&Effect::SimTape {
            name: "stature".into(),
            slip: false
        }));
        // A person presses s: it only takes over (no skip).
        let person = |pilot: &mut Autopilot, c| pilot.person_key(KeyEvent::from(KeyCode::Char(c)));
        let ev = person(&mut pilot, 's');
        send(&mut a, [ev]);
        assert_eq!(a.demo, Some(Pilot::Person));
        assert!(!pilot.driving());
        assert_eq!(a.session.as_ref().unwrap().items[0].state, ItemState::Todo);
        // From now on the simulated operator's keys are not given ...
        let later = std::time::Instant::now() + std::time::Duration::from_secs(60);
        assert!(pilot.tick(&a, later).is_empty());
        // ... and the person's keys act.
        let ev = person(&mut pilot, 's');
        send(&mut a, [ev]);
        assert_eq!(
            a.session.as_ref().unwrap().items[0].state,
            ItemState::Skipped
        );
    }
}

#[test]
fn estimate_progress_cancel_and_failure() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    let fx = send(&mut a, [ch('e')]);
    assert!(fx.is_empty() || !fx.iter().any(|e| matches!(e, Effect::StartEstimate(_))));
    assert_eq!(a.screen, Screen::Measuring, "no readings: no estimate");
    take(&mut a, 0, "stature", 17_650);
    let fx = send(&mut a, [ch('e')]);
    assert!(fx.iter().any(|e| matches!(e, Effect::StartEstimate(_))));
    // The tape's readings are held while estimating.
    assert_eq!(naming(&fx), Some(None));
    send(
        &mut a,
        [Event::Estimate(EstimateEvent::Stage {
            stage: Stage::Step1,
            fraction: 0.05,
        })],
    );
    assert_eq!(a.estimate.stages, vec![Stage::Step1]);
    let fx = send(&mut a, [key(KeyCode::Esc)]);
    assert!(fx.contains(&Effect::CancelEstimate));
    let fx = send(&mut a, [Event::Estimate(EstimateEvent::Cancelled)]);
    assert_eq!(a.screen, Screen::Measuring);
    assert_eq!(naming(&fx), Some(Some("chest".into())));
    send(&mut a, [ch('e')]);
    send(
        &mut a,
        [Event::Estimate(EstimateEvent::Failed(
            "chest 58 cm contradicts".into(),
        ))],
    );
    assert_eq!(a.screen, Screen::Estimating);
    assert!(!a.estimate.running);
    send(&mut a, [key(KeyCode::Esc)]);
    assert_eq!(a.screen, Screen::Measuring);
}

#[test]
fn p_writes_the_card_in_the_screens_unit_and_a_failed_card_keeps_the_session() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[("stature", 17_650)]);
    send(&mut a, [ch('e')]);
    send(
        &mut a,
        [Event::Estimate(EstimateEvent::Done(Box::new(
            tapeshape::services::EstimateSummary {
                session: SessionId(3),
                rows: Vec::new(),
                plausibility: "typical".into(),
                warnings: Vec::new(),
                silhouettes: Default::default(),
                seconds: 0.3,
                sizes: Vec::new(),
            },
        )))],
    );
    assert_eq!(a.screen, Screen::Result);
    // In the unit the screen shows (i: inches).
    let fx = send(&mut a, [ch('i'), ch('p')]);
    assert!(
        fx.contains(&Effect::Card {
            session: SessionId(3),
            unit: Unit::In
        }),
        "{fx:?}"
    );
    // A card does not close the session (the export does).
    assert!(!fx.iter().any(|e| matches!(e, Effect::SetStatus(..))));
    let fx = send(
        &mut a,
        [Event::CardWritten(Err(
            "writing the card /ro/session3-card.pdf: \
             Read-only file system"
                .into(),
        ))],
    );
    assert!(fx.iter().all(|e| !matches!(e, Effect::SetStatus(..))));
    let (_, msg) = a.notice.clone().unwrap();
    assert!(
        msg.contains("Read-only file system") && msg.contains("kept"),
        "{msg}"
    );
    assert_eq!(a.screen, Screen::Result);
    assert!(a.session.is_some() && a.result.summary.is_some());
    assert_eq!(a.result.card, None);
    send(
        &mut a,
        [Event::CardWritten(Ok("/tmp/x/session3-card.pdf".into()))],
    );
    assert_eq!(a.result.card, Some("/tmp/x/session3-card.pdf".into()));
    assert!(a
        .notice
        .as_ref()
        .unwrap()
        .1
        .contains("/tmp/x/session3-card.pdf"));
}

#[test]
fn export_marks_the_session_done_and_history_delete_asks_first() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[("stature", 17_650)]);
    send(&mut a, [ch('e')]);
    send(
        &mut a,
        [Event::Estimate(EstimateEvent::Done(Box::new(
            tapeshape::services::EstimateSummary {
                session: SessionId(3),
                rows: Vec::new(),
                plausibility: "typical".into(),
                warnings: Vec::new(),
                silhouettes: Default::default(),
                seconds: 0.3,
                sizes: Vec::new(),
            },
        )))],
    );
    assert_eq!(a.screen, Screen::Result);
    let fx = send(&mut a, [ch('f'), ch('x')]);
    assert!(fx.contains(&Effect::Export {
        session: SessionId(3),
        format: tapeshape::estimate::MeshFormat::Obj
    }));
    let fx = send(
        &mut a,
        [Event::Exported(Ok(vec!["/tmp/x/body.obj".into()]))],
    );
    assert!(fx.contains(&Effect::SetStatus(SessionId(3), SessionStatus::Done)));
    // Back to measuring (a retake after the export): the session opens
    // again, or the store would refuse the new reading.
    let fx = send(&mut a, [ch('b')]);
    assert_eq!(a.screen, Screen::Measuring);
    assert!(fx.contains(&Effect::SetStatus(SessionId(3), SessionStatus::Open)));
    send(&mut a, [ch('e')]);
    send(
        &mut a,
        [Event::Estimate(EstimateEvent::Done(Box::new(
            tapeshape::services::EstimateSummary {
                session: SessionId(3),
                rows: Vec::new(),
                plausibility: "typical".into(),
                warnings: Vec::new(),
                silhouettes: Default::default(),
                seconds: 0.3,
                sizes: Vec::new(),
            },
        )))],
    );

    let fx = send(&mut a, [ch('h')]);
    assert!(fx.contains(&Effect::LoadHistory));
    assert_eq!(a.screen, Screen::History);
    send(&mut a, [Event::History(history_rows())]);
    // Delete: asks; any key but y keeps.
    let fx = send(&mut a, [key(KeyCode::Delete), ch('n')]);
    assert!(!fx.iter().any(|e| matches!(e, Effect::DeleteSession(_))));
    let fx = send(&mut a, [key(KeyCode::Delete), ch('y')]);
    assert!(fx.contains(&Effect::DeleteSession(SessionId(3))));
    assert!(
        a.session.is_none(),
        "the deleted session is no longer measured"
    );
}

fn history_rows() -> Vec<tapeshape::store::SessionSummary> {
    use tapeshape::store::{Session, SessionSummary};
    vec![SessionSummary {
        session: Session {
            id: SessionId(3),
            customer_id: "c-test".into(),
            created_at_ms: 1_700_000_000_000,
            updated_at_ms: 1_700_000_060_000,
            status: SessionStatus::Done,
            measurement_set: Some("quick".into()),
            notes: None,
            consent: None,
        },
        current_readings: 1,
        total_readings: 1,
        estimate_made_at_ms: None,
    }]
}

#[test]
fn quit_needs_two_presses_and_ctrl_c_one() {
    let mut a = app(false);
    let fx = send(&mut a, [ch('q')]);
    assert!(!a.quit && fx.is_empty());
    send(&mut a, [ch('x')]);
    send(&mut a, [ch('q')]);
    assert!(!a.quit, "another key in between disarms");
    let fx = send(&mut a, [ch('q')]);
    assert!(a.quit && fx.contains(&Effect::Quit));
    let mut b = app(false);
    let fx = send(
        &mut b,
        [Event::Key(crossterm::event::KeyEvent::new(
            KeyCode::Char('c'),
            crossterm::event::KeyModifiers::CONTROL,
        ))],
    );
    assert!(b.quit && fx.contains(&Effect::Quit));
}

#[test]
fn a_resumed_session_shows_the_operator_marks_it_was_left_with() {
    let mut a = app(false);
    connect(&mut a);
    send(
        &mut a,
        [Event::SessionReady(tapeshape::tui::app::SessionView {
            id: SessionId(3),
            customer: "c-test".into(),
            set: "quick".into(),
            notes: None,
            measurements: quick(),
            readings: vec![("chest".into(), 5_800)],
            superseded: Vec::new(),
            estimate: None,
            careful: None,
            status: tapeshape::store::SessionStatus::Open,
            marks: vec![
                ("stature".into(), Mark::Skipped),
                ("chest".into(), Mark::KeptFlagged),
            ],
        })],
    );
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[0].state, ItemState::Skipped);
    assert_eq!(s.items[1].state, ItemState::Done);
    assert!(s.items[1].kept_flagged);
    // Neither skipped nor taken: the tape goes to the next one.
    assert_ne!(current(&a).as_deref(), Some("stature"));
    assert_ne!(current(&a).as_deref(), Some("chest"));
}

/// A reading flagged before a restart and never answered comes back
/// flagged: the resumed readings without a kept-flagged mark are checked
/// again, and a flag moves the tape to that reading; a kept one is not
/// re-checked.
#[test]
fn an_unanswered_flag_comes_back_after_a_restart() {
    let mut a = app(false);
    connect(&mut a);
    let fx = send(
        &mut a,
        [Event::SessionReady(tapeshape::tui::app::SessionView {
            id: SessionId(4),
            customer: "c-test".into(),
            set: "quick".into(),
            notes: None,
            measurements: quick(),
            readings: vec![("chest".into(), 5_800), ("waist".into(), 8_000)],
            superseded: Vec::new(),
            estimate: None,
            careful: None,
            status: tapeshape::store::SessionStatus::Open,
            marks: vec![("waist".into(), Mark::KeptFlagged)],
        })],
    );
    let checks: Vec<&tapeshape::services::CheckRequest> = fx
        .iter()
        .filter_map(|f| match f {
            Effect::Check(r) => Some(r),
            _ => None,
        })
        .collect();
    assert_eq!(checks.len(), 1, "{fx:?}");
    assert_eq!(checks[0].name, "chest");
    assert_eq!(checks[0].value_mm, 580.0);
    assert!(checks[0]
        .others
        .iter()
        .any(|(n, v)| n == "waist" && *v == 800.0));
    let s = a.session.as_ref().unwrap();
    let at = |n: &str| s.items.iter().position(|i| i.info.name == n).unwrap();
    let (chest, waist) = (at("chest"), at("waist"));
    assert_eq!(s.items[chest].state, ItemState::Checking);
    assert_eq!(s.items[waist].state, ItemState::Done);
    send(
        &mut a,
        [Event::Checked {
            name: "chest".into(),
            value_tenth_mm: 5_800,
            outcome: tapeshape::services::CheckOutcome {
                flag: Some("chest 58.0 cm is 6 SD below the others' prediction".into()),
                unit_slip: None,
                note: None,
            },
        }],
    );
    let s = a.session.as_ref().unwrap();
    assert_eq!(s.items[chest].state, ItemState::Flagged);
    assert_eq!(current(&a).as_deref(), Some("chest"));
}

fn summary(seconds: f64) -> tapeshape::services::EstimateSummary {
    tapeshape::services::EstimateSummary {
        session: SessionId(3),
        rows: Vec::new(),
        plausibility: "typical".into(),
        warnings: Vec::new(),
        silhouettes: Default::default(),
        seconds,
        sizes: Vec::new(),
    }
}

fn live_requests(fx: &[Effect]) -> Vec<(u64, Vec<(String, f64)>)> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::LiveEstimate {
                generation,
                request,
            } => Some((*generation, request.readings.clone())),
            _ => None,
        })
        .collect()
}

/// The station estimates in the background after each accepted reading;
/// a newer reading asks again (the runner cancels the older one) and the
/// older one's answer is ignored; with the live body of exactly the
/// readings taken, `e` shows the result at once, with no new estimate.
#[test]
fn each_accepted_reading_re_estimates_live_and_e_shows_the_ready_body() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    // Stored but still being checked: nothing yet (it may be refused).
    let fx = committed(&mut a, 0, "stature", 17_650);
    assert!(live_requests(&fx).is_empty());
    let fx = checked(&mut a, "stature", 17_650, None);
    let first = live_requests(&fx);
    assert_eq!(first, vec![(1, vec![("stature".to_string(), 1765.0)])]);
    // Other events with the same readings ask nothing more.
    assert!(live_requests(&send(&mut a, [Event::Tick])).is_empty());
    take(&mut a, 1, "chest", 9_820);
    assert_eq!(a.live.generation, 2);
    assert!(a.live.running);
    // The first request's answer comes late: ignored.
    send(
        &mut a,
        [Event::Live {
            generation: 1,
            event: EstimateEvent::Done(Box::new(summary(0.1))),
        }],
    );
    assert!(a.live.shown.is_none() && a.live.running);
    send(
        &mut a,
        [Event::Live {
            generation: 2,
            event: EstimateEvent::Done(Box::new(summary(0.2))),
        }],
    );
    assert!(!a.live.running);
    assert_eq!(a.live.shown.as_ref().unwrap().2.seconds, 0.2);
    let fx = send(&mut a, [ch('e')]);
    assert_eq!(a.screen, Screen::Result, "the body is ready");
    assert_eq!(a.result.summary.as_ref().unwrap().seconds, 0.2);
    assert!(!fx.iter().any(|e| matches!(e, Effect::StartEstimate(_))));
}

/// `e` while the live estimate of these readings still runs: the estimate
/// is asked for (the runner adopts the running one); an undo withdraws a
/// reading and asks for a live estimate of what is left; undoing the last
/// one cancels it.
#[test]
fn live_estimate_follows_undo_and_e_while_running_asks_for_the_estimate() {
    let mut a = app(false);
    connect(&mut a);
    open_session(&mut a, &[]);
    take(&mut a, 0, "stature", 17_650);
    take(&mut a, 1, "chest", 9_820);
    let fx = send(&mut a, [ch('u')]);
    assert_eq!(
        live_requests(&fx),
        vec![(3, vec![("stature".to_string(), 1765.0)])]
    );
    let fx = send(&mut a, [ch('e')]);
    let job = fx
        .iter()
        .find_map(|e| match e {
            Effect::StartEstimate(j) => Some(j.clone()),
            _ => None,
        })
        .expect("not ready yet: an estimate is asked for");
    assert_eq!(job.readings, a.live.readings);
    assert_eq!(a.screen, Screen::Estimating);
    send(&mut a, [Event::Estimate(EstimateEvent::Cancelled)]);
    assert_eq!(a.screen, Screen::Measuring);
    let fx = send(&mut a, [ch('u')]);
    assert!(fx.contains(&Effect::CancelLive), "{fx:?}");
    assert!(!a.live.running && a.live.readings.is_empty());
}
