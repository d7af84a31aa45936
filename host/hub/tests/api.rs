//! The hub's API against a real PostgreSQL (a throwaway cluster each test
//! starts): idempotent, ordered application of batches; tokens, revocation
//! and one station writing for another; malformed, oversized and hostile
//! input; erasure across stations; the lookup; retention; migrations.

mod common;

use common::{post, TestHub};
use serde_json::json;
use tapeshape_hub_api::{
    customer_hash, Consent, Event, EventBody, Source, SyncRequest, SyncResponse, SYNC_PATH,
};

fn created(seq: i64, session: i64, customer: &str, at: i64) -> Event {
    Event {
        seq,
        at_ms: at,
        body: EventBody::Created {
            session,
            customer: customer.into(),
            set: Some("quick".into()),
            notes: None,
            consent: Some(Consent::Visit),
            careful: false,
            created_at_ms: at,
        },
    }
}

fn reading(seq: i64, session: i64, reading: i64, name: &str, supersedes: Option<i64>) -> Event {
    Event {
        seq,
        at_ms: 1_000 + seq,
        body: EventBody::ReadingStored {
            session,
            reading,
            measurement: name.into(),
            value_tenth_mm: 9_000 + reading as u32,
            source: Source::Keyboard,
            received_at_ms: 1_000 + seq,
            supersedes,
        },
    }
}

fn batch(station: &str, events: Vec<Event>) -> Vec<u8> {
    serde_json::to_vec(&SyncRequest {
        station: station.into(),
        events,
        erasures_done: vec![],
    })
    .unwrap()
}

fn sync(hub: &TestHub, token: &str, station: &str, events: Vec<Event>) -> SyncResponse {
    let (status, body) = post(
        &format!("{}{SYNC_PATH}", hub.base),
        Some(token),
        &batch(station, events),
    );
    assert_eq!(status, 200, "{body}");
    serde_json::from_str(&body).unwrap()
}

#[test]
fn batches_apply_once_and_in_order_whatever_arrives() {
    let Some(hub) = TestHub::start("batches_apply_once_and_in_order_whatever_arrives") else {
        return;
    };
    let token = hub.station("store-a");
    let events = vec![
        created(1, 1, "c-1", 100),
        reading(2, 1, 1, "stature", None),
        reading(3, 1, 2, "chest", None),
        // A retake of the chest.
        reading(4, 1, 3, "chest", Some(2)),
    ];
    // The later half first (a reordered request): nothing of it applies.
    let r = sync(&hub, &token, "store-a", events[2..].to_vec());
    assert_eq!(r.committed_through, 0);
    assert_eq!(hub.count("SELECT COUNT(*) FROM readings"), 0);
    // The first half, then the whole batch twice (a duplicated request).
    assert_eq!(
        sync(&hub, &token, "store-a", events[..2].to_vec()).committed_through,
        2
    );
    assert_eq!(
        sync(&hub, &token, "store-a", events.clone()).committed_through,
        4
    );
    assert_eq!(
        sync(&hub, &token, "store-a", events.clone()).committed_through,
        4
    );
    assert_eq!(hub.count("SELECT COUNT(*) FROM readings"), 3);
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM readings WHERE superseded_by IS NULL"),
        2,
        "the retake supersedes the first chest reading"
    );
    assert_eq!(
        hub.count("SELECT superseded_by FROM readings WHERE reading = 2"),
        3
    );
    // An undo of the retake brings the first chest reading back.
    let undo = Event {
        seq: 5,
        at_ms: 2_000,
        body: EventBody::Withdrawn {
            session: 1,
            reading: 3,
            restored: Some(2),
        },
    };
    assert_eq!(
        sync(&hub, &token, "store-a", vec![undo]).committed_through,
        5
    );
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM readings WHERE superseded_by IS NULL AND NOT withdrawn"),
        2
    );
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM readings WHERE reading = 2 AND superseded_by IS NULL"),
        1
    );
}

#[test]
fn tokens_guard_every_write() {
    let Some(hub) = TestHub::start("tokens_guard_every_write") else {
        return;
    };
    let a = hub.station("store-a");
    let _b = hub.station("store-b");
    let url = format!("{}{SYNC_PATH}", hub.base);
    let body = batch("store-a", vec![created(1, 1, "c-1", 1)]);
    // No token, a made-up one, a malformed one: 401, nothing stored.
    let fake = format!("store-a.{}", "0".repeat(64));
    for token in [None, Some(fake.as_str()), Some("x"), Some("")] {
        let (status, text) = post(&url, token, &body);
        assert_eq!(status, 401, "{token:?}: {text}");
        assert!(text.contains("station token"), "{text}");
    }
    // A's token writing B's events: 403, nothing stored.
    let (status, text) = post(
        &url,
        Some(&a),
        &batch("store-b", vec![created(1, 1, "c-1", 1)]),
    );
    assert_eq!(status, 403, "{text}");
    assert!(text.contains("belongs to station store-a"), "{text}");
    assert_eq!(hub.count("SELECT COUNT(*) FROM sessions"), 0);
    // Revoked: 401 from then on.
    hub.rt.block_on(hub.db.revoke_station("store-a")).unwrap();
    let (status, _) = post(&url, Some(&a), &body);
    assert_eq!(status, 401);
    assert_eq!(hub.count("SELECT COUNT(*) FROM sessions"), 0);
    // A new token works; the old one still does not.
    let a2 = hub
        .rt
        .block_on(hub.db.add_station("store-a", true))
        .unwrap()
        .expose();
    assert_eq!(post(&url, Some(&a2), &body).0, 200);
    assert_eq!(post(&url, Some(&a), &body).0, 401);
    // The hub keeps only the hash of a token.
    assert_eq!(
        hub.count(&format!(
            "SELECT COUNT(*) FROM stations WHERE token_sha256 LIKE '%{}%'",
            &a2[a2.len() - 20..]
        )),
        0
    );
}

#[test]
fn bad_and_hostile_input_gets_a_clear_4xx_and_stores_nothing() {
    let Some(hub) = TestHub::start("bad_and_hostile_input_gets_a_clear_4xx_and_stores_nothing")
    else {
        return;
    };
    let t = hub.station("store-a");
    let url = format!("{}{SYNC_PATH}", hub.base);
    let cases: Vec<(&str, Vec<u8>, u16, &str)> = vec![
        (
            "not JSON",
            b"{this is not json".to_vec(),
            400,
            "not the JSON",
        ),
        (
            "not UTF-8",
            b"{\"station\":\"store-a\",\"events\":[\xff\xfe]}".to_vec(),
            400,
            "not the JSON",
        ),
        (
            "unknown kind",
            br#"{"station":"store-a","events":[{"seq":1,"at_ms":1,"kind":"drop_table"}]}"#.to_vec(),
            400,
            "unknown variant",
        ),
        (
            "unknown field",
            br#"{"station":"store-a","events":[],"admin":true}"#.to_vec(),
            400,
            "unknown field",
        ),
        (
            "negative seq",
            batch("store-a", vec![created(0, 1, "c-1", 1)]),
            422,
            "start at 1",
        ),
        (
            "long customer id",
            batch("store-a", vec![created(1, 1, &"x".repeat(10_000), 1)]),
            422,
            "1 to 128 bytes",
        ),
        (
            "control characters",
            batch("store-a", vec![created(1, 1, "c-\u{0}1", 1)]),
            422,
            "printable",
        ),
        (
            "too many events",
            batch(
                "store-a",
                (1..=2_001).map(|i| reading(i, 1, i, "x", None)).collect(),
            ),
            413,
            "at most 2000",
        ),
        (
            "oversized body",
            {
                let mut b = batch("store-a", vec![]);
                b.extend(std::iter::repeat_n(
                    b' ',
                    tapeshape_hub_api::MAX_BODY_BYTES + 1,
                ));
                b
            },
            413,
            "larger than",
        ),
    ];
    for (what, body, want, says) in cases {
        let (status, text) = post(&url, Some(&t), &body);
        assert_eq!(status, want, "{what}: {text}");
        let err: tapeshape_hub_api::ApiError = serde_json::from_str(&text)
            .unwrap_or_else(|e| panic!("{what}: the answer is not an ApiError ({e}): {text}"));
        assert!(err.error.contains(says), "{what}: {}", err.error);
    }
    assert_eq!(hub.count("SELECT COUNT(*) FROM sessions"), 0);
    assert_eq!(hub.count("SELECT last_seq FROM stations"), 0);
    // SQL in an id is only text: stored as given, every table intact.
    let hostile = "'; DROP TABLE sessions; --";
    let r = sync(
        &hub,
        &t,
        "store-a",
        vec![
            created(1, 1, hostile, 5),
            reading(2, 1, 1, "chest'); DELETE FROM readings; --", None),
        ],
    );
    assert_eq!(r.committed_through, 2);
    let stored: String = hub.rt.block_on(async {
        let c = hub.db.client().await.unwrap();
        c.query_one("SELECT customer FROM sessions", &[])
            .await
            .unwrap()
            .get(0)
    });
    assert_eq!(stored, hostile);
    assert_eq!(hub.count("SELECT COUNT(*) FROM readings"), 1);
    // Hostile path parameters on the pages (401 first: no password) and an
    // unknown path: clean answers, and the hub still serves.
    for path in [
        "/stores/'%20OR%201=1--",
        "/stores/a/sessions/1%3BDROP",
        "/no/such/path",
        "/static/three/..%2F..%2FCargo.toml",
    ] {
        let (status, _) = common::post(&format!("{}{path}", hub.base), None, b"");
        assert!((400..500).contains(&status), "{path}: {status}");
    }
    let r = common::agent()
        .get(format!("{}/healthz", hub.base))
        .call()
        .unwrap();
    assert_eq!(r.status(), 200);
}

#[test]
fn an_erasure_reaches_every_station_and_leaves_only_its_record() {
    let Some(hub) = TestHub::start("an_erasure_reaches_every_station_and_leaves_only_its_record")
    else {
        return;
    };
    let a = hub.station("store-a");
    let b = hub.station("store-b");
    let c = hub.station("store-c");
    let x = "c-erase-me";
    sync(
        &hub,
        &a,
        "store-a",
        vec![created(1, 1, x, 100), reading(2, 1, 1, "chest", None)],
    );
    sync(
        &hub,
        &b,
        "store-b",
        vec![created(1, 7, x, 200), created(2, 8, "c-other", 200)],
    );
    // The returning-customer lookup sees both stores' sessions.
    let (status, text) = post(
        &format!("{}{}", hub.base, tapeshape_hub_api::LOOKUP_PATH),
        Some(&c),
        json!({"customer": x}).to_string().as_bytes(),
    );
    assert_eq!(status, 200, "{text}");
    let found: tapeshape_hub_api::LookupResponse = serde_json::from_str(&text).unwrap();
    let mut at: Vec<(String, i64)> = found
        .sessions
        .iter()
        .map(|s| (s.station.clone(), s.session))
        .collect();
    at.sort();
    assert_eq!(at, [("store-a".to_string(), 1), ("store-b".to_string(), 7)]);
    assert_eq!(
        found
            .sessions
            .iter()
            .find(|s| s.station == "store-a")
            .unwrap()
            .readings,
        vec![("chest".to_string(), 9_001)]
    );
    // Erased at A.
    let erase = Event {
        seq: 3,
        at_ms: 1_000,
        body: EventBody::CustomerErased {
            customer_hash: customer_hash(x),
        },
    };
    let r = sync(&hub, &a, "store-a", vec![erase]);
    assert!(r.erasures.is_empty(), "A erased it itself: {r:?}");
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM sessions"),
        1,
        "only c-other is left"
    );
    assert_eq!(hub.count("SELECT COUNT(*) FROM readings"), 0);
    assert_eq!(
        hub.count(&format!(
            "SELECT COUNT(*) FROM erasures WHERE customer_hash = '{}'",
            customer_hash(x)
        )),
        1
    );
    // Nothing of the id itself is left anywhere at the hub.
    let dump: String = hub.rt.block_on(async {
        let c = hub.db.client().await.unwrap();
        let mut all = String::new();
        for t in [
            "sessions",
            "readings",
            "erasures",
            "erasure_notices",
            "estimates",
            "marks",
        ] {
            for row in c
                .query(&format!("SELECT row_to_json(t)::text FROM {t} t"), &[])
                .await
                .unwrap()
            {
                all.push_str(row.get::<_, &str>(0));
            }
        }
        all
    });
    assert!(!dump.contains(x), "{dump}");
    // B is told on its next sync, again until it says it is done.
    let r = sync(&hub, &b, "store-b", vec![]);
    assert_eq!(r.erasures.len(), 1);
    assert_eq!(r.erasures[0].customer_hash, customer_hash(x));
    let again = sync(&hub, &b, "store-b", vec![]);
    assert_eq!(again.erasures, r.erasures);
    let (status, text) = post(
        &format!("{}{SYNC_PATH}", hub.base),
        Some(&b),
        &serde_json::to_vec(&SyncRequest {
            station: "store-b".into(),
            events: vec![],
            erasures_done: vec![r.erasures[0].id],
        })
        .unwrap(),
    );
    assert_eq!(status, 200);
    assert!(serde_json::from_str::<SyncResponse>(&text)
        .unwrap()
        .erasures
        .is_empty());
    // C was offline and held an older session of the customer: when it
    // arrives it is not stored, and C is told to erase it.
    let r = sync(
        &hub,
        &c,
        "store-c",
        vec![created(1, 3, x, 500), reading(2, 3, 1, "chest", None)],
    );
    assert_eq!(r.committed_through, 2);
    assert_eq!(r.erasures.len(), 1);
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM sessions WHERE station = 'store-c'"),
        0
    );
    // Measured again after the erasure (a new visit): kept.
    sync(&hub, &c, "store-c", vec![created(3, 4, x, 5_000)]);
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM sessions WHERE station = 'store-c'"),
        1
    );
}

#[test]
fn the_head_office_exports_erases_and_purges() {
    let Some(hub) = TestHub::start("the_head_office_exports_erases_and_purges") else {
        return;
    };
    let a = hub.station("store-a");
    let now = tapeshape_hub::db::now_ms();
    let old = now - 40 * 86_400_000;
    let mut keep = created(1, 1, "c-keeper", old);
    if let EventBody::Created { consent, .. } = &mut keep.body {
        *consent = Some(Consent::Keep);
    }
    sync(
        &hub,
        &a,
        "store-a",
        vec![
            keep,
            created(2, 2, "c-visitor", old),
            created(3, 3, "c-visitor", now),
            reading(4, 3, 1, "chest", None),
        ],
    );
    let export = hub
        .rt
        .block_on(hub.db.customer_export("c-visitor"))
        .unwrap();
    assert_eq!(export["sessions"].as_array().unwrap().len(), 2);
    assert_eq!(export["sessions"][1]["readings"][0]["measurement"], "chest");
    // Retention of 30 days: the old visit goes, the kept one and the new one stay.
    let purged = hub
        .rt
        .block_on(hub.db.purge_older_than(now - 30 * 86_400_000))
        .unwrap();
    assert_eq!(purged, 1);
    assert_eq!(hub.count("SELECT COUNT(*) FROM sessions"), 2);
    let (sessions, _) = hub.rt.block_on(hub.db.customer_erase("c-visitor")).unwrap();
    assert_eq!(sessions, 1);
    assert_eq!(hub.count("SELECT COUNT(*) FROM sessions"), 1);
    assert_eq!(
        hub.count("SELECT COUNT(*) FROM erasures WHERE origin = 'hub'"),
        1
    );
}

#[test]
fn an_edited_migration_is_refused() {
    let Some(hub) = TestHub::start("an_edited_migration_is_refused") else {
        return;
    };
    hub.rt.block_on(async {
        let c = hub.db.client().await.unwrap();
        c.execute(
            "UPDATE hub_schema SET sha256 = 'edited' WHERE version = 1",
            &[],
        )
        .await
        .unwrap();
    });
    let e = hub.rt.block_on(hub.db.migrate()).unwrap_err();
    assert!(
        matches!(e, tapeshape_hub::HubError::MigrationChanged { .. }),
        "{e}"
    );
    assert!(e.to_string().contains("was edited"), "{e}");
}

#[test]
fn a_careful_session_is_stored_as_careful_and_its_page_says_repeated() {
    let Some(hub) =
        TestHub::start("a_careful_session_is_stored_as_careful_and_its_page_says_repeated")
    else {
        return;
    };
    let token = hub.station("store-a");
    let mut careful = created(1, 1, "c-1", 100);
    if let EventBody::Created { careful: c, .. } = &mut careful.body {
        *c = true;
    }
    let events = vec![
        careful,
        reading(2, 1, 1, "chest", None),
        // The second reading of the round supersedes the first.
        reading(3, 1, 2, "chest", Some(1)),
        created(4, 2, "c-2", 200),
        reading(5, 2, 3, "chest", None),
        reading(6, 2, 4, "chest", Some(3)),
    ];
    assert_eq!(sync(&hub, &token, "store-a", events).committed_through, 6);
    assert_eq!(hub.count("SELECT COUNT(*) FROM sessions WHERE careful"), 1);
    let page = |session| {
        let full = hub
            .rt
            .block_on(hub.db.session_full("store-a", session))
            .unwrap()
            .expect("the hub holds it");
        (full.careful, tapeshape_hub::web::session_page(&full))
    };
    let (c, p) = page(1);
    assert!(c);
    assert!(
        p.contains("id=careful") && p.contains("repeated (reading 2)"),
        "{p}"
    );
    assert!(!p.contains("retaken"), "{p}");
    let (c, p) = page(2);
    assert!(!c);
    assert!(
        p.contains("retaken (reading 4)") && !p.contains("id=careful"),
        "{p}"
    );
}
