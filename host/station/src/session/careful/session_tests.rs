//! Careful mode through the session layer and the store, with answers
//! worked out by hand (quick set: stature 4 mm, chest 9 mm, arm length
//! 5 mm allowed).

use crate::session::{careful::Round, NewSession, Sessions};
use crate::store::{ReadingId, SessionId};

fn careful_session() -> (tempfile::TempDir, Sessions, SessionId) {
    let dir = tempfile::tempdir().unwrap();
    let s = Sessions::open(dir.path()).unwrap();
    let v = s
        .start_new(
            "c-careful",
            "quick",
            None,
            NewSession {
                careful: true,
                ..NewSession::default()
            },
        )
        .unwrap();
    assert!(v.careful.is_some());
    (dir, s, v.id)
}

fn take(s: &Sessions, id: SessionId, name: &str, v: u32) -> ReadingId {
    s.capture_keyboard(id, name, v).unwrap().id
}

fn round(s: &Sessions, id: SessionId, name: &str) -> Round {
    let d = s.store().open_session(id).unwrap();
    s.open_round(&d, name).unwrap().expect("a careful session")
}

fn kept(s: &Sessions, id: SessionId) -> Vec<(String, u32)> {
    let d = s.store().open_session(id).unwrap();
    s.kept_readings(&d).unwrap()
}

#[test]
fn two_readings_within_the_allowed_error_keep_their_mean_and_ask_no_third() {
    let (_dir, s, id) = careful_session();
    assert_eq!(round(&s, id, "stature").next_reading(), Some(1));
    take(&s, id, "stature", 17_650);
    // One reading: the second is asked for, nothing is kept yet.
    assert_eq!(round(&s, id, "stature").next_reading(), Some(2));
    assert_eq!(round(&s, id, "stature").needed(), 2);
    assert!(kept(&s, id).is_empty());
    // 3 mm apart (4 mm allowed): done, the mean kept.
    take(&s, id, "stature", 17_680);
    assert_eq!(kept(&s, id), vec![("stature".to_string(), 17_665)]);
    assert_eq!(round(&s, id, "stature").readings, Vec::<u32>::new());
    let view = s.open_for_measuring(id).unwrap();
    assert_eq!(view.readings, vec![("stature".to_string(), 17_665)]);
    assert_eq!(
        view.careful.unwrap().chain_of("stature"),
        &[17_650, 17_680][..]
    );
}

#[test]
fn two_readings_apart_ask_for_a_third_and_the_median_is_kept() {
    let (_dir, s, id) = careful_session();
    take(&s, id, "chest", 9_820);
    take(&s, id, "chest", 9_930); // 11 mm apart, 9 mm allowed
    let r = round(&s, id, "chest");
    assert_eq!(
        (r.next_reading(), r.needed(), r.apart()),
        (Some(3), 3, Some(110))
    );
    assert!(kept(&s, id).is_empty(), "nothing kept before the third");
    take(&s, id, "chest", 9_850);
    assert_eq!(kept(&s, id), vec![("chest".to_string(), 9_850)]);
    // All three stay in the store.
    assert_eq!(s.store().open_session(id).unwrap().readings.len(), 3);
}

#[test]
fn undoing_the_third_reading_asks_for_it_again() {
    let (_dir, s, id) = careful_session();
    take(&s, id, "arm_length", 6_000);
    take(&s, id, "arm_length", 6_080); // 8 mm apart, 5 mm allowed
    let third = take(&s, id, "arm_length", 6_020);
    assert_eq!(kept(&s, id), vec![("arm_length".to_string(), 6_020)]);
    s.withdraw(third).unwrap();
    let r = round(&s, id, "arm_length");
    assert_eq!(r.readings, vec![6_000, 6_080]);
    assert_eq!(r.next_reading(), Some(3));
    assert!(kept(&s, id).is_empty());
    // The withdrawn reading stays in the history.
    let d = s.store().open_session(id).unwrap();
    assert_eq!(d.readings.len(), 3);
    assert!(d.readings[2].withdrawn_at_ms.is_some());
    // A new third reading closes the round again.
    take(&s, id, "arm_length", 6_050);
    assert_eq!(kept(&s, id), vec![("arm_length".to_string(), 6_050)]);
}

#[test]
fn a_retake_after_a_finished_round_keeps_the_earlier_value_until_it_is_finished() {
    let (_dir, s, id) = careful_session();
    take(&s, id, "stature", 17_650);
    take(&s, id, "stature", 17_660);
    take(&s, id, "stature", 17_700); // a retake: a new round
    assert_eq!(kept(&s, id), vec![("stature".to_string(), 17_655)]);
    assert_eq!(round(&s, id, "stature").next_reading(), Some(2));
    take(&s, id, "stature", 17_710);
    assert_eq!(kept(&s, id), vec![("stature".to_string(), 17_705)]);
}

#[test]
fn the_tem_of_three_measurements_against_a_hand_computed_value() {
    let (_dir, s, id) = careful_session();
    // stature d = 3 mm; chest d = 11 mm (a third taken, not in the pair);
    // arm length d = 2 mm. sum d^2 = 9 + 121 + 4 = 134, n = 3:
    // TEM = sqrt(134 / 6) = 4.7258 mm. Mean of the six paired readings:
    // (1765.0 + 1768.0 + 982.0 + 993.0 + 600.0 + 602.0) / 6 = 1118.333 mm.
    for (name, values) in [
        ("stature", &[17_650, 17_680][..]),
        ("chest", &[9_820, 9_930, 9_850][..]),
        ("arm_length", &[6_000, 6_020][..]),
    ] {
        for &v in values {
            take(&s, id, name, v);
        }
    }
    let d = s.store().open_session(id).unwrap();
    let r = s.careful_report(&d).unwrap().expect("careful");
    let t = r.session_tem.unwrap();
    assert_eq!(t.pairs, 3);
    let want = (134.0f64 / 6.0).sqrt();
    assert!((t.tem_mm - want).abs() < 1e-9, "{t:?}");
    let mean = (1765.0 + 1768.0 + 982.0 + 993.0 + 600.0 + 602.0) / 6.0;
    assert!((t.mean_mm - mean).abs() < 1e-9, "{t:?}");
    assert!((t.relative_percent - want / mean * 100.0).abs() < 1e-9);
    // Per measurement: one pair each, TEM = |d| / sqrt(2).
    let chest = r.measurements.iter().find(|m| m.name == "chest").unwrap();
    assert!((chest.tem.unwrap().tem_mm - 11.0 / 2f64.sqrt()).abs() < 1e-9);
    assert_eq!(chest.kept_mm, Some(985.0));
    assert_eq!(chest.rounds_mm, vec![vec![982.0, 993.0, 985.0]]);
    assert_eq!(chest.allowed_mm, Some(9.0));
}

#[test]
fn a_crash_mid_measurement_keeps_every_reading_and_the_same_expectation() {
    let (dir, s, id) = careful_session();
    take(&s, id, "chest", 9_820);
    take(&s, id, "chest", 9_930);
    drop(s); // the station dies here: nothing but the file remains
    let s = Sessions::open(dir.path()).unwrap();
    let d = s.store().open_session(id).unwrap();
    assert_eq!(d.readings.len(), 2);
    let r = round(&s, id, "chest");
    assert_eq!(
        (r.readings.clone(), r.next_reading()),
        (vec![9_820, 9_930], Some(3))
    );
    let view = s.open_for_measuring(id).unwrap();
    assert!(
        view.careful.is_some(),
        "careful mode is the session's, kept across restarts"
    );
    assert!(view.readings.is_empty());
}

#[test]
fn a_session_taken_once_per_measurement_is_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sessions::open(dir.path()).unwrap();
    let v = s.start("c-once", "quick", None).unwrap();
    assert!(v.careful.is_none());
    take(&s, v.id, "chest", 9_820);
    take(&s, v.id, "chest", 9_930); // a retake replaces
    assert_eq!(kept(&s, v.id), vec![("chest".to_string(), 9_930)]);
    let d = s.store().open_session(v.id).unwrap();
    assert!(s.careful_report(&d).unwrap().is_none());
    assert!(s.open_round(&d, "chest").unwrap().is_none());
    assert!(!s.store().is_careful(v.id).unwrap());
}

#[test]
fn a_store_from_before_careful_mode_opens_with_its_sessions_taken_once() {
    use crate::store::{DB_FILE_NAME, MIGRATIONS};
    let dir = tempfile::tempdir().unwrap();
    {
        let mut conn = rusqlite::Connection::open(dir.path().join(DB_FILE_NAME)).unwrap();
        let tx = conn.transaction().unwrap();
        for m in &MIGRATIONS[..5] {
            tx.execute_batch(m.sql).unwrap();
        }
        tx.pragma_update(None, "user_version", 5).unwrap();
        tx.execute_batch(
            "INSERT INTO sessions (id, customer_id, created_at_ms, updated_at_ms, status,
                                   measurement_set)
             VALUES (1, 'c-old', 1000, 2000, 'open', 'quick');
             INSERT INTO readings (id, session_id, measurement, value_tenth_mm, source,
                                   received_at_ms, superseded_by)
             VALUES (1, 1, 'stature', 17650, 'keyboard', 1100, 2),
                    (2, 1, 'stature', 17700, 'keyboard', 1200, NULL);",
        )
        .unwrap();
        tx.commit().unwrap();
    }
    let s = Sessions::open(dir.path()).unwrap();
    assert!(!s.store().is_careful(SessionId(1)).unwrap());
    let v = s.open_for_measuring(SessionId(1)).unwrap();
    assert!(v.careful.is_none());
    // A retake of a session taken once replaces: the latest reading stands.
    assert_eq!(v.readings, vec![("stature".to_string(), 17_700)]);
}

#[test]
fn each_reading_of_a_careful_session_says_which_round_and_reading_it_was() {
    let (_dir, s, id) = careful_session();
    let a = take(&s, id, "chest", 9_820);
    let b = take(&s, id, "chest", 9_930); // 11 mm apart, 9 mm allowed
    let c = take(&s, id, "chest", 9_850);
    let d = take(&s, id, "stature", 17_650);
    let e = take(&s, id, "stature", 17_660);
    let f = take(&s, id, "stature", 17_700); // a retake: round 2
    let undone = take(&s, id, "stature", 17_990);
    s.withdraw(undone).unwrap();
    let detail = s.store().open_session(id).unwrap();
    let mut notes = s.careful_reading_notes(&detail).unwrap();
    notes.sort();
    let want = |id: ReadingId, t: &str| (id, t.to_string());
    assert_eq!(
        notes,
        vec![
            want(a, "careful round 1, reading 1 of 2"),
            want(b, "careful round 1, reading 2 of 3"),
            want(c, "careful round 1, reading 3 of 3, kept 985.0 mm"),
            want(d, "careful round 1, reading 1 of 2"),
            want(e, "careful round 1, reading 2 of 2, kept 1765.5 mm"),
            want(f, "careful round 2, reading 1 of 2"),
        ]
    );
    // A session taken once has no such notes.
    let dir = tempfile::tempdir().unwrap();
    let once = Sessions::open(dir.path()).unwrap();
    let v = once
        .start_new("c-once", "quick", None, NewSession::default())
        .unwrap();
    take(&once, v.id, "chest", 9_820);
    take(&once, v.id, "chest", 9_930);
    let detail = once.store().open_session(v.id).unwrap();
    assert!(once.careful_reading_notes(&detail).unwrap().is_empty());
}
