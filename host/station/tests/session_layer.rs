//! The session layer against a real store in a temporary folder, as the
//! kiosk's runner uses it: starting and reopening sessions, keyboard
//! readings, undo and skip across a restart.

use tapeshape::session::Sessions;
use tapeshape::store::{Mark, ReadingSource, SessionStatus};

#[test]
fn start_refuses_an_unknown_set_before_storing_anything() {
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let err = sessions.start("c-1", "no-such-set", None).unwrap_err();
    assert!(err.to_string().contains("no-such-set"), "{err}");
    assert!(sessions.store().list_sessions().unwrap().is_empty());
}

/// A value stored with Enter is a keyboard reading: no device, no sequence
/// number of its own, and a retake of it supersedes like any other.
#[test]
fn keyboard_readings_are_stored_as_such_and_retakes_supersede() {
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let view = sessions.start("c-1", "quick", Some("sex: female")).unwrap();
    assert_eq!(view.measurements.len(), 9);
    assert_eq!(view.measurements[0].name, "stature");
    let a = sessions
        .capture_keyboard(view.id, "stature", 17_650)
        .unwrap();
    let b = sessions.capture_keyboard(view.id, "chest", 9_820).unwrap();
    let c = sessions
        .capture_keyboard(view.id, "stature", 17_700)
        .unwrap();
    for r in [&a, &b, &c] {
        assert_eq!(r.source, ReadingSource::Keyboard);
        assert_eq!(r.tape(), None);
    }
    let detail = sessions.store().open_session(view.id).unwrap();
    assert_eq!(detail.readings.len(), 3);
    assert_eq!(detail.readings[0].superseded_by, Some(c.id));
    assert_eq!(
        sessions.store().session(view.id).unwrap().notes.as_deref(),
        Some("sex: female")
    );

    // Reopened (a done session becomes open again) with current and
    // superseded readings apart.
    sessions.set_status(view.id, SessionStatus::Done).unwrap();
    let again = sessions.open_for_measuring(view.id).unwrap();
    assert_eq!(
        sessions.store().session(view.id).unwrap().status,
        SessionStatus::Open
    );
    assert_eq!(
        again.readings,
        vec![
            ("chest".to_string(), 9_820),
            ("stature".to_string(), 17_700)
        ]
    );
    assert_eq!(again.superseded, vec![("stature".to_string(), 17_650)]);
    // A second handle (another station process) adds to the same session.
    let other = Sessions::open(dir.path()).unwrap();
    let d = other.capture_keyboard(view.id, "waist", 8_400).unwrap();
    assert_eq!(d.source, ReadingSource::Keyboard);
    assert_eq!(sessions.store().reading_count(view.id).unwrap(), 4);
}

#[test]
fn capture_into_a_closed_session_is_an_error_not_a_loss() {
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let view = sessions.start("c-1", "quick", None).unwrap();
    sessions.set_status(view.id, SessionStatus::Done).unwrap();
    let err = sessions
        .capture_keyboard(view.id, "stature", 17_650)
        .unwrap_err();
    assert!(err.to_string().contains("open session"), "{err}");
    assert_eq!(sessions.store().reading_count(view.id).unwrap(), 0);
}

#[test]
fn undo_and_skip_survive_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let view = sessions.start("c-2", "quick", None).unwrap();
    let first = sessions
        .capture_keyboard(view.id, "stature", 17_650)
        .unwrap();
    let retake = sessions
        .capture_keyboard(view.id, "stature", 17_900)
        .unwrap();
    let chest = sessions.capture_keyboard(view.id, "chest", 9_820).unwrap();
    // The operator undoes the retake and the chest reading, skips the neck.
    assert_eq!(sessions.withdraw(retake.id).unwrap(), Some(first.id));
    sessions.withdraw(chest.id).unwrap();
    sessions
        .set_mark(view.id, "neck", Some(Mark::Skipped))
        .unwrap();
    // A restart (a new handle) sees the session as it was left.
    drop(sessions);
    let sessions = Sessions::open(dir.path()).unwrap();
    let again = sessions.open_for_measuring(view.id).unwrap();
    assert_eq!(again.readings, vec![("stature".to_string(), 17_650)]);
    assert_eq!(again.marks, vec![("neck".to_string(), Mark::Skipped)]);
    // Nothing was deleted: all three readings are in the history.
    assert_eq!(
        sessions
            .store()
            .open_session(view.id)
            .unwrap()
            .readings
            .len(),
        3
    );
}
