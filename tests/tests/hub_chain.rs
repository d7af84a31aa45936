//! The chain end to end: 20 stations x 50 sessions x 9 readings synced to
//! the real hub binary (`tapeshape hub`) on a throwaway PostgreSQL, through
//! a fault-injecting proxy (connections reset, requests delayed and
//! duplicated, answers lost and cut), with the hub SIGKILLed twice and
//! PostgreSQL restarted once during the run, and one station offline for
//! the first half. At the end PostgreSQL holds every reading exactly once
//! (per station, against that station's SQLite), and a customer erased at
//! one station is gone from the hub and from every other station.
//!
//! The stations run in this process (the session layer and the sync task,
//! as the kiosk runs them); the hub is the real program, so that killing
//! it is a real SIGKILL.

use std::collections::BTreeSet;
use std::io::{BufRead as _, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use tapeshape::session::Sessions;
use tapeshape::store::{Consent, SessionStatus};
use tapeshape::sync::{SyncConfig, SyncHandle};
use tapeshape_hub::pgtest::{free_port, PgCluster};
use tapeshape_hub::{Db, DbTarget};
use tapeshape_hub_api::StationToken;
use tapeshape_tests::hub_proxy::{FaultRates, HubProxy};

const STATIONS: usize = 20;
const SESSIONS: usize = 50;
const READINGS: usize = 9;
/// Measured at stations 0 (the offline one), 1 and 2, erased at 1.
const SHARED: &str = "c-shared";

struct Hub {
    child: Child,
    log: std::path::PathBuf,
}

fn start_hub(bin: &std::path::Path, url: &str, port: u16, log: &std::path::Path) -> Hub {
    let err = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(log)
        .unwrap();
    let mut child = Command::new(bin)
        .args(["-vv", "hub", "--listen", &format!("127.0.0.1:{port}")])
        .env("TAPESHAPE_HUB_DATABASE", url)
        .stdout(Stdio::piped())
        .stderr(err)
        .spawn()
        .expect("starting tapeshape hub");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    assert!(line.starts_with("hub listening on http://"), "{line:?}");
    Hub {
        child,
        log: log.to_path_buf(),
    }
}

impl Drop for Hub {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn kill9(hub: &mut Hub) {
    // std's kill is SIGKILL: no shutdown, transactions in flight cut.
    hub.child.kill().unwrap();
    hub.child.wait().unwrap();
}

fn sync_config(base: &str, token: StationToken) -> SyncConfig {
    let mut c = SyncConfig::new(base, token).unwrap();
    c.batch_events = 200;
    c.min_backoff = Duration::from_millis(50);
    c.max_backoff = Duration::from_millis(800);
    c.idle_poll = Duration::from_millis(500);
    c.request_timeout = Duration::from_secs(10);
    c
}

/// One station's work: 50 customers, 9 readings each, each session closed;
/// `done` counts the sessions closed at all stations.
fn measure(s: &Sessions, station: usize, done: &AtomicUsize) {
    let names = [
        "stature", "chest", "waist", "hip", "neck", "arm", "inseam", "thigh", "calf",
    ];
    for n in 0..SESSIONS {
        let customer = if n == 0 && station <= 2 {
            SHARED.to_string()
        } else {
            format!("c-{station:02}-{n:02}")
        };
        let consent = if n % 2 == 0 {
            Consent::Keep
        } else {
            Consent::Visit
        };
        let v = s
            .start_with_consent(&customer, "quick", Some("sex: female"), Some(consent))
            .unwrap();
        for (k, name) in names.iter().enumerate().take(READINGS) {
            s.capture_keyboard(v.id, name, 5_000 + (station * 1000 + n * 10 + k) as u32)
                .unwrap();
        }
        s.set_status(v.id, SessionStatus::Done).unwrap();
        done.fetch_add(1, Ordering::SeqCst);
        // A kiosk's pace, sped up: the run spans the hub's and the
        // database's outages.
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn twenty_stations_sync_through_faults_kills_and_a_restart() {
    if !tapeshape_hub::pgtest::available_or_skip(
        "twenty_stations_sync_through_faults_kills_and_a_restart",
    ) {
        return;
    }
    let bin = tapeshape_tests::tapeshape_binary();
    let cluster = PgCluster::start().expect("starting a throwaway PostgreSQL");
    let url = cluster.url();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let db = Db::new(DbTarget::parse(&url).unwrap(), 4).unwrap();
    rt.block_on(db.migrate()).unwrap();
    let tokens: Vec<StationToken> = (0..STATIONS)
        .map(|i| {
            rt.block_on(db.add_station(&format!("store-{i:02}"), false))
                .unwrap()
        })
        .collect();

    let work = tempfile::tempdir().unwrap();
    let hub_log = work.path().join("hub.log");
    let port = free_port().unwrap();
    let mut hub = start_hub(&bin, &url, port, &hub_log);
    let upstream: std::net::SocketAddr = format!("127.0.0.1:{port}").parse().unwrap();
    let proxy = rt
        .block_on(HubProxy::start(
            upstream,
            0x5eed_0001,
            FaultRates::default(),
        ))
        .unwrap();
    // Station 0 has its own way to the hub, cut for the first half.
    let lonely = rt
        .block_on(HubProxy::start(
            upstream,
            0x5eed_0002,
            FaultRates::default(),
        ))
        .unwrap();
    lonely.offline.store(true, Ordering::SeqCst);

    let stations: Vec<Sessions> = (0..STATIONS)
        .map(|i| Sessions::open(&work.path().join(format!("station-{i:02}"))).unwrap())
        .collect();
    let no_body: tapeshape::sync::GlbSource = Arc::new(|_| None);
    let syncs: Vec<SyncHandle> = stations
        .iter()
        .zip(&tokens)
        .enumerate()
        .map(|(i, (s, t))| {
            let via = if i == 0 { &lonely } else { &proxy };
            tapeshape::sync::spawn(
                s.clone(),
                sync_config(&format!("http://{}", via.addr), t.clone()),
                no_body.clone(),
            )
            .unwrap()
        })
        .collect();

    let done = Arc::new(AtomicUsize::new(0));
    let producers: Vec<_> = stations
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let s = s.clone();
            let done = done.clone();
            std::thread::spawn(move || measure(&s, i, &done))
        })
        .collect();
    let all = STATIONS * SESSIONS;
    // Each outage must fall while the stations measure.
    let during = |what: &str| {
        let n = done.load(Ordering::SeqCst);
        assert!(n < all, "{what} came after the stations finished");
        eprintln!("hub_chain: {what} with {n} of {all} sessions measured");
    };

    // The outages, while the stations measure.
    let run0 = Instant::now();
    let at = |secs: f64| {
        let until = run0 + Duration::from_secs_f64(secs);
        if let Some(d) = until.checked_duration_since(Instant::now()) {
            std::thread::sleep(d);
        }
    };
    at(1.5);
    during("hub SIGKILL 1");
    kill9(&mut hub);
    at(2.0);
    hub = start_hub(&bin, &url, port, &hub_log);
    at(3.0);
    during("PostgreSQL restart");
    cluster.restart().expect("restarting PostgreSQL");
    // The erasure: at station 1, whose first session is the shared
    // customer's (stored long since).
    let erased_sessions = stations[1].erase_customer(SHARED).unwrap();
    assert_eq!(erased_sessions.len(), 1);
    // The second half: station 0 comes online.
    while done.load(Ordering::SeqCst) < all / 2 {
        std::thread::sleep(Duration::from_millis(20));
    }
    during("station 0 online");
    lonely.offline.store(false, Ordering::SeqCst);
    at(5.0);
    during("hub SIGKILL 2");
    kill9(&mut hub);
    at(5.5);
    hub = start_hub(&bin, &url, port, &hub_log);
    for p in producers {
        p.join().expect("a station's work failed");
    }
    let measured_in = run0.elapsed();

    // Every station's outbox reaches the hub; the erasure reaches 0 and 2.
    let deadline = Instant::now() + Duration::from_secs(180);
    loop {
        let behind: Vec<usize> = stations
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                let st = s.store().sync_state().unwrap();
                st.hub_committed_seq < st.last_seq
            })
            .map(|(i, _)| i)
            .collect();
        let shared_left = stations
            .iter()
            .any(|s| !s.store().customer_sessions(SHARED).unwrap().is_empty());
        if behind.is_empty() && !shared_left {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "after 180 s stations {behind:?} are behind (shared customer left: {shared_left}); \
             proxy: {}; station 0's: {}",
            proxy.stats.summary(),
            lonely.stats.summary()
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let synced_in = run0.elapsed();
    let errors: Vec<String> = syncs.iter().filter_map(|s| s.status().last_error).collect();
    for s in syncs {
        s.stop();
    }

    // PostgreSQL holds every reading exactly once, per station.
    let rows = rt.block_on(async {
        let c = db.client().await.unwrap();
        c.query(
            "SELECT station, reading, session, value_tenth_mm FROM readings",
            &[],
        )
        .await
        .unwrap()
    });
    let mut at_hub: Vec<BTreeSet<(i64, i64, i64)>> = vec![BTreeSet::new(); STATIONS];
    for r in &rows {
        let station: String = r.get(0);
        let i: usize = station["store-".len()..].parse().unwrap();
        assert!(
            at_hub[i].insert((r.get(1), r.get(2), r.get(3))),
            "a reading twice"
        );
    }
    let mut total = 0;
    for (i, s) in stations.iter().enumerate() {
        let mut here = BTreeSet::new();
        for summary in s.store().list_sessions().unwrap() {
            for r in s.store().open_session(summary.session.id).unwrap().readings {
                here.insert((r.id.0, r.session_id.0, i64::from(r.value_tenth_mm)));
            }
        }
        let want = if i <= 2 {
            (SESSIONS - 1) * READINGS
        } else {
            SESSIONS * READINGS
        };
        assert_eq!(here.len(), want, "station {i}'s store");
        assert_eq!(
            at_hub[i], here,
            "station {i}: the hub's readings differ from the station's"
        );
        total += here.len();
    }
    assert_eq!(rows.len(), total);
    assert_eq!(total, STATIONS * SESSIONS * READINGS - 3 * READINGS);
    let sessions_at_hub = rt.block_on(async {
        let c = db.client().await.unwrap();
        c.query_one("SELECT COUNT(*) FROM sessions", &[])
            .await
            .unwrap()
            .get::<_, i64>(0)
    });
    assert_eq!(sessions_at_hub as usize, STATIONS * SESSIONS - 3);

    // The erased customer: at the hub only the erasure's record.
    let (shared_rows, erasures) = rt.block_on(async {
        let c = db.client().await.unwrap();
        let n: i64 = c
            .query_one(
                "SELECT COUNT(*) FROM sessions WHERE customer = $1",
                &[&SHARED],
            )
            .await
            .unwrap()
            .get(0);
        let e: i64 = c
            .query_one(
                "SELECT COUNT(*) FROM erasures WHERE customer_hash = $1",
                &[&tapeshape_hub_api::customer_hash(SHARED)],
            )
            .await
            .unwrap()
            .get(0);
        (n, e)
    });
    assert_eq!(shared_rows, 0);
    assert_eq!(erasures, 1);

    // The faults happened.
    let g = |a: &std::sync::atomic::AtomicU64| a.load(Ordering::Relaxed);
    let st = &proxy.stats;
    for (what, n) in [
        ("resets", g(&st.reset_before)),
        ("lost answers", g(&st.answer_lost)),
        ("duplicates", g(&st.duplicated)),
        ("delays", g(&st.delayed)),
        ("cut answers", g(&st.answer_cut)),
        ("refusals while the hub was down", g(&st.refused)),
    ] {
        assert!(n > 0, "no {what}: {}", st.summary());
    }
    assert!(g(&lonely.stats.refused) > 0, "station 0 was never offline");

    // No secret in the hub's log or the stations' errors.
    let log = std::fs::read_to_string(&hub.log).unwrap_or_default();
    let secrets: Vec<String> = tokens
        .iter()
        .map(|t| t.expose())
        .chain([cluster.password().to_string()])
        .collect();
    for secret in &secrets {
        assert!(!log.contains(secret.as_str()), "a secret in the hub's log");
        for e in &errors {
            assert!(
                !e.contains(secret.as_str()),
                "a secret in a station's error: {e}"
            );
        }
        // The token's secret half alone, too.
        if let Some((_, tail)) = secret.rsplit_once('.') {
            assert!(!log.contains(tail), "a token's secret in the hub's log");
        }
    }
    eprintln!(
        "hub_chain: {total} readings of {STATIONS} stations; measured in {:.1} s, all synced \
         after {:.1} s; proxy: {}; station 0's proxy: {}; hub log {} bytes",
        measured_in.as_secs_f64(),
        synced_in.as_secs_f64(),
        proxy.stats.summary(),
        lonely.stats.summary(),
        log.len()
    );
    drop(hub);
}
