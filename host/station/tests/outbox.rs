//! The outbox: every change to a session is an event with the next
//! sequence number, written in the change's own transaction (a refused
//! change writes none); erasing a session or a customer redacts their
//! earlier events; the store's files are owner-only.

use std::os::unix::fs::PermissionsExt as _;

use tapeshape::session::Sessions;
use tapeshape::store::{Consent, Mark, SessionStatus, DB_FILE_NAME};
use tapeshape_hub_api::{customer_hash, EventBody};

fn events(s: &Sessions) -> Vec<(i64, EventBody)> {
    s.store()
        .outbox_after(0, 10_000)
        .unwrap()
        .into_iter()
        .map(|e| {
            let body: EventBody = serde_json::from_str(&e.body).unwrap();
            assert_eq!(body.kind(), e.kind, "kind column and body agree");
            (e.seq, body)
        })
        .collect()
}

#[test]
fn every_change_is_one_event_in_order() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sessions::open(dir.path()).unwrap();
    let v = s
        .start_with_consent(
            "c-abc123",
            "quick",
            Some("sex: female"),
            Some(Consent::Keep),
        )
        .unwrap();
    let first = s.capture_keyboard(v.id, "stature", 17_000).unwrap();
    let retake = s.capture_keyboard(v.id, "stature", 17_050).unwrap();
    s.set_mark(v.id, "chest", Some(Mark::Skipped)).unwrap();
    s.withdraw(retake.id).unwrap();
    // Withdrawing twice changes nothing: no event.
    s.withdraw(retake.id).unwrap();
    // A refused change (a reading into a closed session) writes no event.
    s.set_status(v.id, SessionStatus::Done).unwrap();
    assert!(s.capture_keyboard(v.id, "chest", 9_000).is_err());
    let ev = events(&s);
    let seqs: Vec<i64> = ev.iter().map(|(q, _)| *q).collect();
    assert_eq!(
        seqs,
        (1..=6).collect::<Vec<_>>(),
        "1, 2, 3, ... without gaps"
    );
    let kinds: Vec<&str> = ev.iter().map(|(_, b)| b.kind()).collect();
    assert_eq!(
        kinds,
        [
            "created",
            "reading_stored",
            "reading_stored",
            "marked",
            "withdrawn",
            "status_set"
        ]
    );
    match &ev[0].1 {
        EventBody::Created {
            customer,
            consent,
            notes,
            set,
            ..
        } => {
            assert_eq!(customer, "c-abc123");
            assert_eq!(*consent, Some(tapeshape_hub_api::Consent::Keep));
            assert_eq!(notes.as_deref(), Some("sex: female"));
            assert_eq!(set.as_deref(), Some("quick"));
        }
        other => panic!("{other:?}"),
    }
    match &ev[2].1 {
        EventBody::ReadingStored {
            reading,
            supersedes,
            value_tenth_mm,
            ..
        } => {
            assert_eq!(*reading, retake.id.0);
            assert_eq!(
                *supersedes,
                Some(first.id.0),
                "the retake names what it replaced"
            );
            assert_eq!(*value_tenth_mm, 17_050);
        }
        other => panic!("{other:?}"),
    }
    match &ev[4].1 {
        EventBody::Withdrawn { restored, .. } => assert_eq!(*restored, Some(first.id.0)),
        other => panic!("{other:?}"),
    }
    assert_eq!(s.store().sync_state().unwrap().last_seq, 6);
    assert_eq!(s.store().sync_state().unwrap().hub_committed_seq, 0);
}

#[test]
fn erasing_a_customer_redacts_their_events_and_records_only_a_hash() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sessions::open(dir.path()).unwrap();
    let a = s.start("c-gone01", "quick", None).unwrap();
    s.capture_keyboard(a.id, "chest", 9_100).unwrap();
    let b = s.start("c-stays1", "quick", None).unwrap();
    s.capture_keyboard(b.id, "chest", 9_200).unwrap();
    let c = s.start("c-gone01", "quick", None).unwrap();
    let erased = s.erase_customer("c-gone01").unwrap();
    assert_eq!(erased, vec![a.id, c.id]);
    assert!(s.store().customer_sessions("c-gone01").unwrap().is_empty());
    assert_eq!(s.store().customer_sessions("c-stays1").unwrap().len(), 1);
    let ev = events(&s);
    assert_eq!(ev.len(), 6, "the sequence keeps its numbers");
    let all: String = s
        .store()
        .outbox_after(0, 100)
        .unwrap()
        .iter()
        .map(|e| e.body.clone())
        .collect();
    assert!(!all.contains("c-gone01"), "{all}");
    assert!(all.contains("c-stays1"));
    assert_eq!(
        ev.last().unwrap().1,
        EventBody::CustomerErased {
            customer_hash: customer_hash("c-gone01")
        }
    );
    // An erasure the hub sends for a customer this station holds.
    let gone = s.apply_hub_erasure(&customer_hash("c-stays1")).unwrap();
    assert_eq!(gone, vec![b.id]);
    assert!(s.store().list_sessions().unwrap().is_empty());
    let again = s.apply_hub_erasure(&customer_hash("c-stays1")).unwrap();
    assert!(again.is_empty());
    let all: String = s
        .store()
        .outbox_after(0, 100)
        .unwrap()
        .iter()
        .map(|e| e.body.clone())
        .collect();
    assert!(!all.contains("c-stays1"), "{all}");
    assert_eq!(
        events(&s).len(),
        6,
        "an erasure from the hub sends no event"
    );
}

#[test]
fn the_store_and_its_folder_are_owner_only() {
    let parent = tempfile::tempdir().unwrap();
    let dir = parent.path().join("data");
    let s = Sessions::open(&dir).unwrap();
    let v = s.start("c-1", "quick", None).unwrap();
    s.capture_keyboard(v.id, "chest", 9_000).unwrap();
    let mode = |p: &std::path::Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&dir), 0o700);
    let db = dir.join(DB_FILE_NAME);
    for p in [
        db.clone(),
        dir.join(format!("{DB_FILE_NAME}-wal")),
        dir.join(format!("{DB_FILE_NAME}-shm")),
    ] {
        assert_eq!(mode(&p), 0o600, "{}", p.display());
    }
    drop(s);
    // A store an older tapeshape left world-readable becomes owner-only.
    std::fs::set_permissions(&db, std::fs::Permissions::from_mode(0o644)).unwrap();
    let _s = Sessions::open(&dir).unwrap();
    assert_eq!(mode(&db), 0o600);
}

#[test]
fn the_hub_s_commit_marks_exactly_the_events_it_took() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sessions::open(dir.path()).unwrap();
    let v = s.start("c-1", "quick", None).unwrap();
    for k in 0..5 {
        s.capture_keyboard(v.id, "chest", 9_000 + k).unwrap();
    }
    let committed = |s: &Sessions| -> Vec<i64> {
        s.store()
            .outbox_after(0, 100)
            .unwrap()
            .iter()
            .filter(|e| e.committed_at_ms.is_some())
            .map(|e| e.seq)
            .collect()
    };
    assert!(committed(&s).is_empty());
    s.mark_hub_committed(2).unwrap();
    assert_eq!(committed(&s), [1, 2]);
    assert_eq!(s.store().sync_state().unwrap().hub_committed_seq, 2);
    s.mark_hub_committed(5).unwrap();
    assert_eq!(committed(&s), [1, 2, 3, 4, 5]);
    // A hub that holds less than it said (restored from a backup): the
    // station sends again from there; what was marked stays marked.
    s.mark_hub_committed(3).unwrap();
    assert_eq!(s.store().sync_state().unwrap().hub_committed_seq, 3);
    assert_eq!(committed(&s), [1, 2, 3, 4, 5]);
    s.mark_hub_committed(6).unwrap();
    assert_eq!(committed(&s), [1, 2, 3, 4, 5, 6]);
}

#[test]
fn a_careful_session_says_so_in_its_created_event() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sessions::open(dir.path()).unwrap();
    let careful = tapeshape::session::NewSession {
        careful: true,
        ..tapeshape::session::NewSession::default()
    };
    s.start_new("c-1", "quick", None, careful).unwrap();
    s.start_new("c-2", "quick", None, Default::default())
        .unwrap();
    let flags: Vec<(String, bool)> = events(&s)
        .into_iter()
        .filter_map(|(_, b)| match b {
            EventBody::Created {
                customer, careful, ..
            } => Some((customer, careful)),
            _ => None,
        })
        .collect();
    assert_eq!(
        flags,
        vec![("c-1".to_string(), true), ("c-2".to_string(), false)]
    );
}
