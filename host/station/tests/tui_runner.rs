//! The runner's store effects against a real store in a temporary folder:
//! creating and reopening sessions, and the Enter capture's own numbering.

use tapeshape::store::{Mark, SessionStatus, Store};
use tapeshape::tui::runner::{
    capture_live, create_session, open_session, KEYBOARD_CAPTURE_DEVICE_ID,
};

#[test]
fn create_refuses_an_unknown_set_before_storing_anything() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).unwrap();
    let err = create_session(&store, "c-1", "no-such-set", None).unwrap_err();
    assert!(format!("{err:#}").contains("no-such-set"), "{err:#}");
    assert!(store.list_sessions().unwrap().is_empty());
}

#[test]
fn enter_captures_are_numbered_stored_and_retakes_supersede() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).unwrap();
    let view = create_session(&store, "c-1", "quick", Some("sex: female")).unwrap();
    assert_eq!(view.measurements.len(), 9);
    assert_eq!(view.measurements[0].name, "stature");
    let a = capture_live(&store, view.id, "stature", 17_650).unwrap();
    let b = capture_live(&store, view.id, "chest", 9_820).unwrap();
    let c = capture_live(&store, view.id, "stature", 17_700).unwrap();
    assert_eq!(
        [a.device.seq, b.device.seq, c.device.seq],
        [0, 1, 2],
        "the keyboard's own sequence"
    );
    assert!([a.device.device_id, b.device.device_id]
        .iter()
        .all(|&d| d == KEYBOARD_CAPTURE_DEVICE_ID));
    let detail = store.open_session(view.id).unwrap();
    assert_eq!(detail.readings.len(), 3);
    assert_eq!(detail.readings[0].superseded_by, Some(c.id));
    assert_eq!(
        store.session(view.id).unwrap().notes.as_deref(),
        Some("sex: female")
    );

    // Reopened (a done session becomes open again) with current and
    // superseded readings apart.
    store.set_status(view.id, SessionStatus::Done).unwrap();
    let again = open_session(&store, view.id).unwrap();
    assert_eq!(store.session(view.id).unwrap().status, SessionStatus::Open);
    assert_eq!(
        again.readings,
        vec![
            ("chest".to_string(), 9_820),
            ("stature".to_string(), 17_700)
        ]
    );
    assert_eq!(again.superseded, vec![("stature".to_string(), 17_650)]);
    // A second store handle (another station process) continues the numbering.
    let other = Store::open(dir.path()).unwrap();
    let d = capture_live(&other, view.id, "waist", 8_400).unwrap();
    assert_eq!(d.device.seq, 3);
}

#[test]
fn capture_into_a_closed_session_is_an_error_not_a_loss() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).unwrap();
    let view = create_session(&store, "c-1", "quick", None).unwrap();
    store.set_status(view.id, SessionStatus::Done).unwrap();
    let err = capture_live(&store, view.id, "stature", 17_650).unwrap_err();
    assert!(format!("{err:#}").contains("open session"), "{err:#}");
}

#[test]
fn undo_and_skip_survive_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).unwrap();
    let view = create_session(&store, "c-2", "quick", None).unwrap();
    let first = capture_live(&store, view.id, "stature", 17_650).unwrap();
    let retake = capture_live(&store, view.id, "stature", 17_900).unwrap();
    let chest = capture_live(&store, view.id, "chest", 9_820).unwrap();
    // The operator undoes the retake and the chest reading, skips the neck.
    assert_eq!(store.withdraw_reading(retake.id).unwrap(), Some(first.id));
    store.withdraw_reading(chest.id).unwrap();
    store
        .set_mark(view.id, "neck", Some(Mark::Skipped))
        .unwrap();
    // A restart (a new store handle) sees the session as it was left.
    drop(store);
    let store = Store::open(dir.path()).unwrap();
    let again = open_session(&store, view.id).unwrap();
    assert_eq!(again.readings, vec![("stature".to_string(), 17_650)]);
    assert_eq!(again.marks, vec![("neck".to_string(), Mark::Skipped)]);
    // Nothing was deleted: all three readings are in the history.
    assert_eq!(store.open_session(view.id).unwrap().readings.len(), 3);
}
