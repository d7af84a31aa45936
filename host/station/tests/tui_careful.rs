//! Careful mode on the measuring screen, through `update` alone: each
//! measurement asked twice, a third time when the two are apart, the
//! median going on to the check and the estimate (quick set: stature 4 mm,
//! chest 9 mm allowed).

mod tui_fixture;

use tapeshape::services::CheckOutcome;
use tapeshape::session::{allowed_errors, CarefulView};
use tapeshape::store::{ReadingId, SessionId};
use tapeshape::tui::app::{Effect, Event, ItemState, SessionView};
use tui_fixture::*;

fn status(app: &tapeshape::tui::app::App) -> String {
    app.current_item()
        .and_then(|i| i.careful_status(app.unit))
        .unwrap_or_default()
}

fn checks(fx: &[Effect]) -> Vec<(String, f64)> {
    fx.iter()
        .filter_map(|e| match e {
            Effect::Check(r) => Some((r.name.clone(), r.value_mm)),
            _ => None,
        })
        .collect()
}

#[test]
fn careful_mode_asks_for_a_second_and_a_third_reading_and_keeps_the_median() {
    let mut a = app(false);
    connect(&mut a);
    open_careful(&mut a);
    assert_eq!(current(&a).as_deref(), Some("stature"));
    assert_eq!(status(&a), "reading 1 of 2");

    // The first reading: not checked, not estimated; the same measurement
    // is asked again (the link keeps naming readings after it).
    let fx = committed(&mut a, 0, "stature", 17_650);
    assert!(checks(&fx).is_empty(), "{fx:?}");
    assert_eq!(current(&a).as_deref(), Some("stature"));
    assert!(status(&a).starts_with("reading 2 of 2"), "{}", status(&a));
    assert_eq!(a.current_item().unwrap().state, ItemState::Todo);
    assert!(a.session.as_ref().unwrap().accepted().is_empty());

    // 5 mm apart, 4 mm allowed: a third reading is asked for.
    let fx = committed(&mut a, 1, "stature", 17_700);
    assert!(checks(&fx).is_empty(), "{fx:?}");
    assert_eq!(
        status(&a),
        "third reading needed: the two differ by 5 mm (allowed 4 mm)"
    );
    assert!(a
        .notice
        .as_ref()
        .unwrap()
        .1
        .contains("third reading needed"));

    // Undo withdraws the second reading and asks for it again.
    let fx = send(&mut a, [ch('u')]);
    assert!(
        fx.contains(&Effect::WithdrawReading(ReadingId(101))),
        "{fx:?}"
    );
    assert!(status(&a).starts_with("reading 2 of 2"), "{}", status(&a));

    committed(&mut a, 2, "stature", 17_700);
    assert!(status(&a).starts_with("third reading needed"));
    // The third reading closes the round: its median, 1766.0 mm, is checked.
    let fx = committed(&mut a, 3, "stature", 17_660);
    assert_eq!(checks(&fx), vec![("stature".to_string(), 1766.0)]);
    send(
        &mut a,
        [Event::Checked {
            name: "stature".into(),
            value_tenth_mm: 17_660,
            outcome: CheckOutcome::default(),
        }],
    );
    assert_eq!(current(&a).as_deref(), Some("chest"));
    assert_eq!(status(&a), "reading 1 of 2");

    // Chest: 4 mm apart, 9 mm allowed: two readings, their mean kept.
    committed(&mut a, 4, "chest", 9_820);
    let fx = committed(&mut a, 5, "chest", 9_860);
    assert_eq!(checks(&fx), vec![("chest".to_string(), 984.0)]);
    checked(&mut a, "chest", 9_840, None);
    let s = a.session.as_ref().unwrap();
    assert_eq!(
        s.accepted(),
        vec![
            ("stature".to_string(), 1766.0),
            ("chest".to_string(), 984.0)
        ]
    );
    // The live estimate is asked for with the kept values.
    assert_eq!(a.live.readings, s.accepted());
    // TEM over the two pairs: d = 5 and 4 mm: sqrt((25 + 16) / 4) mm.
    let t = s.careful_tem().unwrap();
    assert_eq!(t.pairs, 2);
    assert!((t.tem_mm - (41.0f64 / 4.0).sqrt()).abs() < 1e-9, "{t:?}");
}

#[test]
fn a_careful_session_resumed_between_readings_asks_for_the_missing_one() {
    let mut a = app(false);
    connect(&mut a);
    send(
        &mut a,
        [Event::SessionReady(SessionView {
            id: SessionId(3),
            customer: "c-test".into(),
            set: "quick".into(),
            notes: None,
            measurements: quick(),
            // Stature kept (two agreeing readings); chest two apart.
            readings: vec![("stature".into(), 17_655)],
            superseded: Vec::new(),
            marks: Vec::new(),
            estimate: None,
            careful: Some(CarefulView {
                allowed: allowed_errors("quick").unwrap(),
                chains: vec![
                    ("stature".into(), vec![17_650, 17_660]),
                    ("chest".into(), vec![9_820, 9_930]),
                ],
            }),
            status: tapeshape::store::SessionStatus::Open,
        })],
    );
    assert_eq!(current(&a).as_deref(), Some("chest"));
    assert_eq!(
        status(&a),
        "third reading needed: the two differ by 11 mm (allowed 9 mm)"
    );
}
