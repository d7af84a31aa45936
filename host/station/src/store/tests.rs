//! The store's rules against a real SQLite file in a temporary folder:
//! sequence bookkeeping, retakes, undo, marks, keyboard readings, the
//! stored estimate, migrations of an old store, and errors that name what
//! to do.

use super::*;

/// The writes as single-step changes (the session layer composes them the
/// same way, one transaction each).
trait Writes {
    fn create_session(&self, customer: &str, set: Option<&str>) -> Result<Session, StoreError>;
    fn commit_reading(
        &self,
        s: SessionId,
        name: &str,
        r: &DeviceReading,
    ) -> Result<CommitOutcome, StoreError>;
    fn withdraw_reading(&self, id: ReadingId) -> Result<Option<ReadingId>, StoreError>;
    fn set_mark(&self, s: SessionId, name: &str, mark: Option<Mark>) -> Result<(), StoreError>;
    fn set_status(&self, s: SessionId, status: SessionStatus) -> Result<(), StoreError>;
    fn delete_session(&self, s: SessionId) -> Result<(), StoreError>;
}

impl Writes for Store {
    fn create_session(&self, customer: &str, set: Option<&str>) -> Result<Session, StoreError> {
        self.write(|tx| tx.create_session(customer, set, None, None))
    }
    fn commit_reading(
        &self,
        s: SessionId,
        name: &str,
        r: &DeviceReading,
    ) -> Result<CommitOutcome, StoreError> {
        self.write(|tx| tx.commit_tape_reading(s, Some(name), r))
    }
    fn withdraw_reading(&self, id: ReadingId) -> Result<Option<ReadingId>, StoreError> {
        self.write(|tx| tx.withdraw_reading(id))
            .map(|(_, restored)| restored.flatten())
    }
    fn set_mark(&self, s: SessionId, name: &str, mark: Option<Mark>) -> Result<(), StoreError> {
        self.write(|tx| tx.set_mark(s, name, mark))
    }
    fn set_status(&self, s: SessionId, status: SessionStatus) -> Result<(), StoreError> {
        self.write(|tx| tx.set_status(s, status)).map(|_| ())
    }
    fn delete_session(&self, s: SessionId) -> Result<(), StoreError> {
        self.write(|tx| tx.delete_session(s))
    }
}

fn reading(device_id: u64, boot_id: u32, seq: u32, value: u32) -> DeviceReading {
    DeviceReading {
        device_id,
        boot_id,
        seq,
        value_tenth_mm: value,
        device_time_ms: u64::from(seq) * 1000,
    }
}

fn temp_store() -> (tempfile::TempDir, Store) {
    let dir = tempfile::tempdir().unwrap();
    let store = Store::open(dir.path()).unwrap();
    (dir, store)
}

fn committed(outcome: CommitOutcome) -> StoredReading {
    match outcome {
        CommitOutcome::Committed(r) => r,
        other => panic!("expected Committed, got {other:?}"),
    }
}

#[test]
fn commit_duplicate_gap_rules() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-1", Some("basic")).unwrap();
    // A never-seen boot must start at FIRST_SEQ (0).
    assert_eq!(
        store
            .commit_reading(s.id, "a", &reading(7, 1, 1, 100))
            .unwrap(),
        CommitOutcome::Gap {
            expected: 0,
            got: 1
        }
    );
    let r0 = committed(
        store
            .commit_reading(s.id, "a", &reading(7, 1, 0, 100))
            .unwrap(),
    );
    assert_eq!(r0.tape().unwrap().seq, 0);
    assert_eq!(r0.value_mm(), 10.0);
    // Retransmission of 0: duplicate, acked as 0, the new value ignored.
    assert_eq!(
        store
            .commit_reading(s.id, "b", &reading(7, 1, 0, 999))
            .unwrap(),
        CommitOutcome::Duplicate {
            last_committed_seq: 0
        }
    );
    // 2 before 1: gap.
    assert_eq!(
        store
            .commit_reading(s.id, "b", &reading(7, 1, 2, 300))
            .unwrap(),
        CommitOutcome::Gap {
            expected: 1,
            got: 2
        }
    );
    committed(
        store
            .commit_reading(s.id, "b", &reading(7, 1, 1, 200))
            .unwrap(),
    );
    committed(
        store
            .commit_reading(s.id, "c", &reading(7, 1, 2, 300))
            .unwrap(),
    );
    // Another boot of the same device starts over; another device is independent.
    committed(
        store
            .commit_reading(s.id, "d", &reading(7, 2, 0, 400))
            .unwrap(),
    );
    committed(
        store
            .commit_reading(s.id, "e", &reading(8, 1, 0, 500))
            .unwrap(),
    );
    // Device ids use all 64 bits.
    committed(
        store
            .commit_reading(s.id, "f", &reading(u64::MAX, 1, 0, 600))
            .unwrap(),
    );
    let detail = store.open_session(s.id).unwrap();
    let got: Vec<(String, u64, u32, u32)> = detail
        .readings
        .iter()
        .map(|r| {
            (
                r.measurement.clone(),
                r.tape().unwrap().device_id,
                r.value_tenth_mm,
                r.tape().unwrap().seq,
            )
        })
        .collect();
    assert_eq!(
        got,
        vec![
            ("a".into(), 7, 100, 0),
            ("b".into(), 7, 200, 1),
            ("c".into(), 7, 300, 2),
            ("d".into(), 7, 400, 0),
            ("e".into(), 8, 500, 0),
            ("f".into(), u64::MAX, 600, 0),
        ]
    );
    assert_eq!(store.last_committed_seq(7, 1).unwrap(), Some(2));
    assert_eq!(store.last_committed_seq(u64::MAX, 1).unwrap(), Some(0));
    assert_eq!(store.last_committed_seq(7, 3).unwrap(), None);
}

#[test]
fn schema_forbids_storing_a_reading_twice() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-1", None).unwrap();
    committed(
        store
            .commit_reading(s.id, "a", &reading(1, 1, 0, 10))
            .unwrap(),
    );
    // Bypass the bookkeeping: the UNIQUE constraint must still refuse it.
    let conn = store.lock();
    let err = conn
        .execute(
            "INSERT INTO readings (session_id, measurement, value_tenth_mm, source, device_id,
             boot_id, seq, device_time_ms, received_at_ms) VALUES (?1, 'x', 1, 'tape', 1, 1, 0, 0, 0)",
            [s.id.0],
        )
        .unwrap_err();
    assert!(err.to_string().contains("UNIQUE"), "{err}");
}

#[test]
fn retake_supersedes_and_keeps_history() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-1", None).unwrap();
    for (seq, (name, v)) in [("waist", 800), ("hip", 950), ("waist", 812)]
        .into_iter()
        .enumerate()
    {
        let seq = u32::try_from(seq).unwrap();
        committed(
            store
                .commit_reading(s.id, name, &reading(1, 1, seq, v))
                .unwrap(),
        );
    }
    let detail = store.open_session(s.id).unwrap();
    assert_eq!(detail.readings.len(), 3);
    assert_eq!(
        detail.readings[0].superseded_by,
        Some(detail.readings[2].id)
    );
    assert_eq!(detail.readings[1].superseded_by, None);
    let current: Vec<(&str, u32)> = detail
        .current_readings()
        .map(|r| (r.measurement.as_str(), r.value_tenth_mm))
        .collect();
    assert_eq!(current, vec![("hip", 950), ("waist", 812)]);
    let summary = &store.list_sessions().unwrap()[0];
    assert_eq!((summary.current_readings, summary.total_readings), (2, 3));
}

#[test]
fn withdrawing_a_retake_restores_the_value_before_and_keeps_history() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-2", None).unwrap();
    let mut ids = Vec::new();
    for (seq, (name, v)) in [("waist", 800), ("hip", 950), ("waist", 812)]
        .into_iter()
        .enumerate()
    {
        let seq = u32::try_from(seq).unwrap();
        match store
            .commit_reading(s.id, name, &reading(1, 1, seq, v))
            .unwrap()
        {
            CommitOutcome::Committed(r) => ids.push(r.id),
            other => panic!("{other:?}"),
        }
    }
    // Undo the retake: the first waist is current again.
    assert_eq!(store.withdraw_reading(ids[2]).unwrap(), Some(ids[0]));
    let current = |store: &Store| -> Vec<(String, u32)> {
        store
            .open_session(s.id)
            .unwrap()
            .current_readings()
            .map(|r| (r.measurement.clone(), r.value_tenth_mm))
            .collect()
    };
    assert_eq!(
        current(&store),
        vec![("waist".to_string(), 800), ("hip".to_string(), 950)]
    );
    // Twice is harmless; nothing is deleted.
    assert_eq!(store.withdraw_reading(ids[2]).unwrap(), None);
    let detail = store.open_session(s.id).unwrap();
    assert_eq!(detail.readings.len(), 3);
    assert!(detail.readings[2].withdrawn_at_ms.is_some());
    // Undo the hip: no hip is current, and a new waist supersedes only
    // the current one.
    assert_eq!(store.withdraw_reading(ids[1]).unwrap(), None);
    committed(
        store
            .commit_reading(s.id, "waist", &reading(1, 1, 3, 820))
            .unwrap(),
    );
    assert_eq!(current(&store), vec![("waist".to_string(), 820)]);
    let summary = &store.list_sessions().unwrap()[0];
    assert_eq!((summary.current_readings, summary.total_readings), (1, 4));
    assert!(matches!(
        store.withdraw_reading(ReadingId(999)),
        Err(StoreError::NoSuchReading(_))
    ));
}

#[test]
fn marks_round_trip_and_clear() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-3", Some("quick")).unwrap();
    store.set_mark(s.id, "neck", Some(Mark::Skipped)).unwrap();
    store
        .set_mark(s.id, "chest", Some(Mark::KeptFlagged))
        .unwrap();
    store
        .set_mark(s.id, "neck", Some(Mark::KeptFlagged))
        .unwrap();
    assert_eq!(
        store.marks(s.id).unwrap(),
        vec![
            ("chest".to_string(), Mark::KeptFlagged),
            ("neck".to_string(), Mark::KeptFlagged)
        ]
    );
    store.set_mark(s.id, "chest", None).unwrap();
    assert_eq!(
        store.marks(s.id).unwrap(),
        vec![("neck".to_string(), Mark::KeptFlagged)]
    );
    assert!(matches!(
        store.set_mark(SessionId(77), "neck", Some(Mark::Skipped)),
        Err(StoreError::NoSuchSession(_))
    ));
    store.delete_session(s.id).unwrap();
    assert!(store.marks(s.id).unwrap().is_empty());
}

#[test]
fn reopen_after_drop_keeps_everything_and_migrations_are_idempotent() {
    let dir = tempfile::tempdir().unwrap();
    let id = {
        let store = Store::open(dir.path()).unwrap();
        let s = store.create_session("C-9", Some("full")).unwrap();
        for seq in 0..5 {
            committed(
                store
                    .commit_reading(s.id, &format!("m{seq}"), &reading(3, 4, seq, 100 + seq))
                    .unwrap(),
            );
        }
        s.id
    };
    for _ in 0..3 {
        let store = Store::open(dir.path()).unwrap();
        assert_eq!(store.schema_version().unwrap(), MIGRATIONS.len() as i64);
        let detail = store.open_session(id).unwrap();
        assert_eq!(detail.session.customer_id, "C-9");
        assert_eq!(detail.session.measurement_set.as_deref(), Some("full"));
        let values: Vec<u32> = detail.readings.iter().map(|r| r.value_tenth_mm).collect();
        assert_eq!(values, vec![100, 101, 102, 103, 104]);
        // The bookkeeping survived too: seq 4 is a duplicate, 5 is next.
        assert_eq!(
            store.commit_reading(id, "x", &reading(3, 4, 4, 0)).unwrap(),
            CommitOutcome::Duplicate {
                last_committed_seq: 4
            }
        );
    }
    let store = Store::open(dir.path()).unwrap();
    committed(
        store
            .commit_reading(id, "m5", &reading(3, 4, 5, 105))
            .unwrap(),
    );
}

#[test]
fn newer_schema_is_refused_with_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    drop(Store::open(dir.path()).unwrap());
    {
        let conn = Connection::open(dir.path().join(DB_FILE_NAME)).unwrap();
        conn.pragma_update(None, "user_version", 99).unwrap();
    }
    let err = Store::open(dir.path()).unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, StoreError::SchemaTooNew { found: 99, .. }),
        "{msg}"
    );
    assert!(msg.contains("99") && msg.contains("--data-dir"), "{msg}");
}

#[test]
fn session_lifecycle() {
    let (_dir, store) = temp_store();
    assert_eq!(store.latest_unfinished_session().unwrap(), None);
    let a = store.create_session("A", None).unwrap();
    let b = store.create_session("B", None).unwrap();
    assert_eq!(a.status, SessionStatus::Open);
    assert_eq!(store.latest_unfinished_session().unwrap().unwrap().id, b.id);
    store.set_status(b.id, SessionStatus::Done).unwrap();
    assert_eq!(store.latest_unfinished_session().unwrap().unwrap().id, a.id);
    // Closed sessions take no readings...
    let err = store
        .commit_reading(b.id, "x", &reading(1, 1, 0, 1))
        .unwrap_err();
    assert!(matches!(
        err,
        StoreError::SessionNotOpen {
            status: SessionStatus::Done,
            ..
        }
    ));
    // ...and the refused reading did not advance the bookkeeping.
    assert_eq!(store.last_committed_seq(1, 1).unwrap(), None);
    committed(
        store
            .commit_reading(a.id, "x", &reading(1, 1, 0, 1))
            .unwrap(),
    );
    let noted = store
        .write(|tx| tx.create_session("N", None, Some("left early"), None))
        .unwrap();
    assert_eq!(
        store.session(noted.id).unwrap().notes.as_deref(),
        Some("left early")
    );
    store.delete_session(noted.id).unwrap();
    store.delete_session(a.id).unwrap();
    assert!(matches!(
        store.open_session(a.id),
        Err(StoreError::NoSuchSession(_))
    ));
    assert!(matches!(
        store.delete_session(a.id),
        Err(StoreError::NoSuchSession(_))
    ));
    // A late retransmission of a deleted reading is still a duplicate.
    assert_eq!(
        store
            .commit_reading(b.id, "x", &reading(1, 1, 0, 1))
            .unwrap(),
        CommitOutcome::Duplicate {
            last_committed_seq: 0
        }
    );
    assert_eq!(store.list_sessions().unwrap().len(), 1);
}

#[test]
fn bad_text_is_refused() {
    let (_dir, store) = temp_store();
    for bad in ["", "   ", "a\nb", &"x".repeat(MAX_CUSTOMER_ID_LEN + 1)] {
        assert!(matches!(
            store.create_session(bad, None),
            Err(StoreError::InvalidCustomerId(_))
        ));
    }
    let s = store.create_session("ok", None).unwrap();
    assert!(matches!(
        store.commit_reading(s.id, "", &reading(1, 1, 0, 1)),
        Err(StoreError::InvalidMeasurementName(_))
    ));
}

#[test]
fn unwritable_data_dir_names_the_path() {
    let dir = tempfile::tempdir().unwrap();
    // A regular file where a parent directory should be: cannot be created.
    let file = dir.path().join("not-a-dir");
    std::fs::write(&file, b"x").unwrap();
    let target = file.join("data");
    let err = Store::open(&target).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains(&target.display().to_string()), "{msg}");
    assert!(msg.contains("--data-dir"), "{msg}");
}

#[test]
fn a_damaged_database_file_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join(DB_FILE_NAME);
    std::fs::write(&file, vec![0x5au8; 8192]).unwrap();
    let err = Store::open(dir.path()).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, StoreError::Open { .. }), "{msg}");
    assert!(msg.contains(&file.display().to_string()), "{msg}");
}

#[test]
fn explicit_data_dir_wins() {
    let p = Path::new("/some/where");
    assert_eq!(resolve_data_dir(Some(p)).unwrap(), p);
}

#[test]
fn keyboard_readings_have_no_device_and_supersede_like_any_other() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-k", Some("quick")).unwrap();
    let tape = committed(
        store
            .commit_reading(s.id, "stature", &reading(7, 1, 0, 17_650))
            .unwrap(),
    );
    let typed = store
        .write(|tx| tx.insert_keyboard_reading(s.id, "stature", 17_700))
        .unwrap();
    assert_eq!(typed.source, ReadingSource::Keyboard);
    assert_eq!(typed.tape(), None);
    let detail = store.open_session(s.id).unwrap();
    assert_eq!(detail.readings[0].superseded_by, Some(typed.id));
    assert_eq!(detail.readings[1], typed);
    assert_eq!(
        detail.readings[0],
        StoredReading {
            superseded_by: Some(typed.id),
            ..tape
        }
    );
    // The keyboard takes no sequence number: the tape's numbering goes on.
    assert_eq!(store.last_committed_seq(7, 1).unwrap(), Some(0));
    committed(
        store
            .commit_reading(s.id, "chest", &reading(7, 1, 1, 9_820))
            .unwrap(),
    );
    // The schema refuses a keyboard row with device fields, and a tape row without.
    let conn = store.lock();
    for bad in [
        "INSERT INTO readings (session_id, measurement, value_tenth_mm, source, device_id, boot_id,
         seq, device_time_ms, received_at_ms) VALUES (?1, 'x', 1, 'keyboard', 5, 1, 0, 0, 0)",
        "INSERT INTO readings (session_id, measurement, value_tenth_mm, source, received_at_ms)
         VALUES (?1, 'x', 1, 'tape', 0)",
    ] {
        let err = conn.execute(bad, [s.id.0]).unwrap_err();
        assert!(err.to_string().contains("CHECK"), "{err}");
    }
}

#[test]
fn a_closed_session_refuses_keyboard_readings_too() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-c", None).unwrap();
    store.set_status(s.id, SessionStatus::Abandoned).unwrap();
    let err = store
        .write(|tx| tx.insert_keyboard_reading(s.id, "stature", 17_650))
        .unwrap_err();
    assert!(
        matches!(
            err,
            StoreError::SessionNotOpen {
                status: SessionStatus::Abandoned,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("open session"), "{err}");
}

/// A store written by the previous schema (version 2), where a keyboard
/// reading was a made-up device 0 with its own sequence, opens with its
/// readings, retakes, undo and marks intact and the keyboard readings as
/// what they are.
#[test]
fn a_version_2_store_migrates_keyboard_readings_and_keeps_everything_else() {
    let dir = tempfile::tempdir().unwrap();
    {
        let mut conn = Connection::open(dir.path().join(DB_FILE_NAME)).unwrap();
        let tx = conn.transaction().unwrap();
        for m in &MIGRATIONS[..2] {
            tx.execute_batch(m.sql).unwrap();
        }
        tx.pragma_update(None, "user_version", 2).unwrap();
        tx.execute_batch(
            "INSERT INTO sessions VALUES (1, 'c-old', 1000, 2000, 'open', 'quick', 'sex: male');
             INSERT INTO readings (id, session_id, measurement, value_tenth_mm, device_id, boot_id,
                                   seq, device_time_ms, received_at_ms, superseded_by, withdrawn_at_ms)
             VALUES (1, 1, 'stature', 17650, 8839457, 4, 0, 1500, 1100, 3, NULL),
                    (2, 1, 'chest', 9820, 0, 0, 0, 1700000000000, 1200, NULL, NULL),
                    (3, 1, 'stature', 17700, 0, 0, 1, 1700000000100, 1300, NULL, NULL),
                    (4, 1, 'waist', 8400, 8839457, 4, 1, 1900, 1400, NULL, 1450);
             INSERT INTO link_state VALUES (8839457, 4, 1, 1400), (0, 0, 1, 1300);
             INSERT INTO marks VALUES (1, 'neck', 'skipped', 1500);",
        )
        .unwrap();
        tx.commit().unwrap();
    }
    let store = Store::open(dir.path()).unwrap();
    assert_eq!(store.schema_version().unwrap(), MIGRATIONS.len() as i64);
    let d = store.open_session(SessionId(1)).unwrap();
    assert_eq!(d.session.notes.as_deref(), Some("sex: male"));
    // (id, name, value, tape seq, superseded by, withdrawn)
    type Row<'a> = (i64, &'a str, u32, Option<u32>, Option<i64>, bool);
    let got: Vec<Row> = d
        .readings
        .iter()
        .map(|r| {
            (
                r.id.0,
                r.measurement.as_str(),
                r.value_tenth_mm,
                r.tape().map(|t| t.seq),
                r.superseded_by.map(|s| s.0),
                r.withdrawn_at_ms.is_some(),
            )
        })
        .collect();
    assert_eq!(
        got,
        vec![
            (1, "stature", 17650, Some(0), Some(3), false),
            (2, "chest", 9820, None, None, false),
            (3, "stature", 17700, None, None, false),
            (4, "waist", 8400, Some(1), None, true),
        ]
    );
    assert_eq!(d.readings[1].source, ReadingSource::Keyboard);
    assert_eq!(
        d.readings[0].tape(),
        Some(&TapeOrigin {
            device_id: 8839457,
            boot_id: 4,
            seq: 0,
            device_time_ms: 1500
        })
    );
    // The made-up device's bookkeeping is gone, the real tape's kept.
    assert_eq!(store.last_committed_seq(0, 0).unwrap(), None);
    assert_eq!(store.last_committed_seq(8839457, 4).unwrap(), Some(1));
    assert_eq!(
        store.marks(SessionId(1)).unwrap(),
        vec![("neck".to_string(), Mark::Skipped)]
    );
    // Retakes and deletes still follow the foreign keys after the rebuild.
    store
        .write(|tx| tx.insert_keyboard_reading(SessionId(1), "chest", 9900))
        .unwrap();
    assert_eq!(
        store.open_session(SessionId(1)).unwrap().readings[1].superseded_by,
        Some(ReadingId(5))
    );
    store.delete_session(SessionId(1)).unwrap();
    assert_eq!(store.reading_count(SessionId(1)).unwrap(), 0);
}

fn estimate_of(session: SessionId, made_at_ms: i64, x: f64) -> StoredEstimate {
    StoredEstimate {
        session_id: session,
        made_at_ms,
        seconds: 0.42,
        model_source: "embedded default".into(),
        template_sha256: "ab".repeat(32),
        vertices: vec![[x, 0.1, 1.7], [-x, -0.05, 0.0]],
        readings: vec![("stature".into(), 17_650), ("chest".into(), 9_820)],
        report_json: r#"{"warnings":[]}"#.into(),
    }
}

#[test]
fn an_estimate_is_stored_replaced_and_goes_with_its_session() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-e", Some("quick")).unwrap();
    assert_eq!(store.estimate(s.id).unwrap(), None);
    let first = estimate_of(s.id, 1_000, 0.25);
    store.write(|tx| tx.put_estimate(&first)).unwrap();
    assert_eq!(store.estimate(s.id).unwrap().as_ref(), Some(&first));
    assert_eq!(
        store.list_sessions().unwrap()[0].estimate_made_at_ms,
        Some(1_000)
    );
    let second = estimate_of(s.id, 2_000, 1.0 / 3.0);
    store.write(|tx| tx.put_estimate(&second)).unwrap();
    let back = store.estimate(s.id).unwrap().unwrap();
    assert_eq!(back, second);
    assert_eq!(back.vertices[0][0].to_bits(), (1.0f64 / 3.0).to_bits());
    // An estimate for a session that does not exist is refused.
    assert!(matches!(
        store.write(|tx| tx.put_estimate(&estimate_of(SessionId(99), 0, 0.0))),
        Err(StoreError::NoSuchSession(_))
    ));
    store.delete_session(s.id).unwrap();
    assert_eq!(store.estimate(s.id).unwrap(), None);
}

#[test]
fn a_value_the_program_does_not_know_is_a_corrupt_error_not_a_placeholder() {
    let (_dir, store) = temp_store();
    let s = store.create_session("C-x", None).unwrap();
    {
        let conn = store.lock();
        conn.pragma_update(None, "ignore_check_constraints", true)
            .unwrap();
        conn.execute(
            "UPDATE sessions SET status = 'paused' WHERE id = ?1",
            [s.id.0],
        )
        .unwrap();
        conn.pragma_update(None, "ignore_check_constraints", false)
            .unwrap();
    }
    for err in [
        store.session(s.id).unwrap_err(),
        store.list_sessions().unwrap_err(),
    ] {
        assert!(matches!(err, StoreError::Corrupt(_)), "{err}");
        assert!(err.to_string().contains("paused"), "{err}");
    }
}
