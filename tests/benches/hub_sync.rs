//! Sync throughput into PostgreSQL with 20 stations, and the lag from a
//! reading stored at a station to its commit at the hub.
//!
//! Set-up: a throwaway PostgreSQL cluster (`initdb` + `pg_ctl`, as the
//! tests start it), the hub served in this process on its own tokio
//! runtime (plain HTTP on loopback, 16 database connections), and 20
//! stations, each a session store in its own folder (SQLite, WAL,
//! `synchronous = FULL`) with its real sync task (`tapeshape::sync`: ureq,
//! batches of up to 500 events, marked sent only on the hub's answer).
//! Readings are stored through the session layer (`capture_keyboard`:
//! the reading and its outbox event in one SQLite transaction), in sessions
//! of 9 readings (created, 9 readings, closed: 11 events).
//!
//! Two phases:
//! 1. **Backlog** (capacity): every station first stores `BACKLOG`
//!    sessions with no hub configured, then all 20 sync tasks start at
//!    once; measured: readings committed at the hub per second until every
//!    station's outbox is committed.
//! 2. **Sustained** (throughput and lag under a steady load): the sync
//!    tasks run while the 20 stations store readings at `RATE` readings/s
//!    in all (each station `RATE / 20`, paced on a schedule, without
//!    skipping when late) for `SECONDS`; measured: the rate actually
//!    stored, the rate committed at the hub over the phase (until the
//!    last reading is committed), and per reading the lag from the moment
//!    its SQLite transaction committed at the station to the moment the
//!    station's sync task had the hub's answer that it is committed (the
//!    hub's commit plus the answer's way back and the station's note of
//!    it: an upper bound of the lag to the hub's commit), sampled every
//!    millisecond.
//!
//! At the end the hub's PostgreSQL is checked to hold every reading of
//! every station exactly once.
//!
//! Run (release profile; PostgreSQL must be installed: Debian's
//! `postgresql`; as root it runs as the `postgres` user):
//! `cargo bench -p tapeshape-tests --bench hub_sync -- [--rate N] [--seconds S] [--backlog SESSIONS] [--stations-dir DIR]`
//! (defaults: 5000 readings/s, 30 s, 100 sessions per station, the station
//! stores in the system's temporary folder, beside PostgreSQL's cluster).
//! `--stations-dir /dev/shm` puts the 20 station stores on tmpfs: on one
//! machine their fsyncs (one per reading) otherwise share one disk with
//! PostgreSQL's, where real stations each have their own.
//! Figures: `docs/results/hub-bench.md`.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use tapeshape::session::Sessions;
use tapeshape::store::{Consent, SessionStatus};
use tapeshape::sync::{GlbSource, SyncConfig, SyncHandle};
use tapeshape_hub::pgtest::PgCluster;
use tapeshape_hub::{Db, DbTarget, ServeConfig};
use tapeshape_hub_api::StationToken;

const STATIONS: usize = 20;
const READINGS: usize = 9;
const NAMES: [&str; READINGS] = [
    "stature", "chest", "waist", "hip", "neck", "arm", "inseam", "thigh", "calf",
];

struct Options {
    rate: f64,
    seconds: f64,
    backlog: usize,
    stations_dir: Option<std::path::PathBuf>,
}

fn options() -> Options {
    let mut o = Options {
        rate: 5000.0,
        seconds: 30.0,
        backlog: 100,
        stations_dir: None,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let value = || {
            args.get(i + 1)
                .and_then(|v| v.parse::<f64>().ok())
                .unwrap_or_else(|| panic!("{} takes a number", args[i]))
        };
        match args[i].as_str() {
            "--rate" => o.rate = value(),
            "--seconds" => o.seconds = value(),
            "--backlog" => o.backlog = value() as usize,
            "--stations-dir" => {
                o.stations_dir = Some(args.get(i + 1).expect("--stations-dir DIR").into())
            }
            // `cargo bench` passes --bench.
            _ => {
                i += 1;
                continue;
            }
        }
        i += 2;
    }
    o
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    // Nearest-rank percentile.
    let rank = ((p / 100.0) * sorted.len() as f64).ceil().max(1.0) as usize;
    sorted[rank.min(sorted.len()) - 1]
}

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

/// One session of 9 readings at `s`; `stored` is told each reading's
/// outbox sequence number and the moment its transaction committed.
fn one_session(
    s: &Sessions,
    station: usize,
    n: usize,
    mut stored: impl FnMut(i64, Instant),
    mut pace: impl FnMut(),
) {
    let consent = if n.is_multiple_of(2) {
        Consent::Keep
    } else {
        Consent::Visit
    };
    let v = s
        .start_with_consent(
            &format!("c-{station:02}-{n:05}"),
            "quick",
            Some("sex: female"),
            Some(consent),
        )
        .unwrap();
    for (k, name) in NAMES.iter().enumerate() {
        pace();
        s.capture_keyboard(v.id, name, 5_000 + (n * 10 + k) as u32)
            .unwrap();
        let at = Instant::now();
        // The station's only writer is this thread: the newest event is
        // this reading's.
        let seq = s.store().sync_state().unwrap().last_seq;
        stored(seq, at);
    }
    s.set_status(v.id, SessionStatus::Done).unwrap();
}

fn config(base: &str, token: StationToken) -> SyncConfig {
    let mut c = SyncConfig::new(base, token).unwrap();
    c.request_timeout = Duration::from_secs(30);
    c
}

fn wait_all_synced(stations: &[Sessions], timeout: Duration) -> Instant {
    let until = Instant::now() + timeout;
    loop {
        let behind = stations.iter().any(|s| {
            let st = s.store().sync_state().unwrap();
            st.hub_committed_seq < st.last_seq
        });
        if !behind {
            return Instant::now();
        }
        assert!(
            Instant::now() < until,
            "the stations did not sync within {timeout:?}"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
}

fn main() {
    let o = options();
    if !tapeshape_hub::pgtest::available_or_skip("hub_sync bench") {
        return;
    }
    println!(
        "hub_sync: {STATIONS} stations; backlog {} sessions per station; sustained {} readings/s \
         for {} s; {} CPUs; load average at start {}",
        o.backlog,
        o.rate,
        o.seconds,
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        loadavg()
    );
    let cluster = PgCluster::start().expect("starting a throwaway PostgreSQL");
    let hub_rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let db = Db::new(DbTarget::parse(&cluster.url()).unwrap(), 16).unwrap();
    hub_rt.block_on(db.migrate()).unwrap();
    let tokens: Vec<StationToken> = (0..STATIONS)
        .map(|i| {
            hub_rt
                .block_on(db.add_station(&format!("store-{i:02}"), false))
                .unwrap()
        })
        .collect();
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    let serve = ServeConfig {
        listen: listener.local_addr().unwrap(),
        tls: None,
        retain_days: None,
        purge_every: Duration::from_secs(3600),
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server_db = db.clone();
    hub_rt.spawn(async move {
        let stop = async move {
            let _ = stop_rx.await;
        };
        tapeshape_hub::serve_listener(server_db, listener, serve, stop)
            .await
            .expect("the hub stopped");
    });

    let work = match &o.stations_dir {
        Some(d) => tempfile::tempdir_in(d).unwrap(),
        None => tempfile::tempdir().unwrap(),
    };
    println!(
        "station stores in {} (PostgreSQL in {})",
        work.path().display(),
        std::env::temp_dir().display()
    );
    let stations: Vec<Sessions> = (0..STATIONS)
        .map(|i| Sessions::open(&work.path().join(format!("station-{i:02}"))).unwrap())
        .collect();

    // Phase 1: a backlog, then every sync task at once.
    let t = Instant::now();
    let writers: Vec<_> = stations
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let s = s.clone();
            let n = o.backlog;
            std::thread::spawn(move || {
                for k in 0..n {
                    one_session(&s, i, k, |_, _| {}, || {});
                }
            })
        })
        .collect();
    for w in writers {
        w.join().unwrap();
    }
    let backlog_readings = STATIONS * o.backlog * READINGS;
    println!(
        "backlog: {backlog_readings} readings stored in {:.2} s ({:.0} readings/s into the \
         20 SQLite stores)",
        t.elapsed().as_secs_f64(),
        backlog_readings as f64 / t.elapsed().as_secs_f64()
    );
    let no_body: GlbSource = Arc::new(|_| None);
    let t = Instant::now();
    let syncs: Arc<Vec<SyncHandle>> = stations
        .iter()
        .zip(&tokens)
        .map(|(s, tok)| {
            tapeshape::sync::spawn(s.clone(), config(&base, tok.clone()), no_body.clone()).unwrap()
        })
        .collect::<Vec<_>>()
        .into();
    let done = wait_all_synced(&stations, Duration::from_secs(600));
    let secs = done.duration_since(t).as_secs_f64();
    println!(
        "backlog: {backlog_readings} readings ({} events) committed at the hub in {secs:.2} s: \
         {:.0} readings/s (load average {})",
        STATIONS * o.backlog * (READINGS + 2),
        backlog_readings as f64 / secs,
        loadavg()
    );

    // Phase 2: a steady load with the sync running.
    type Pending = Arc<Mutex<VecDeque<(i64, Instant)>>>;
    let pending: Vec<Pending> = (0..STATIONS).map(|_| Arc::default()).collect();
    let lags: Arc<Mutex<Vec<f64>>> = Arc::default();
    let writing = Arc::new(AtomicBool::new(true));
    let monitor = {
        let pending = pending.clone();
        let lags = lags.clone();
        let writing = writing.clone();
        let syncs = syncs.clone();
        std::thread::spawn(move || loop {
            let now = Instant::now();
            let mut left = 0;
            for (p, h) in pending.iter().zip(syncs.iter()) {
                let committed = h.status().committed_through;
                let mut q = p.lock().unwrap();
                while q.front().is_some_and(|(seq, _)| *seq <= committed) {
                    let (_, at) = q.pop_front().unwrap();
                    lags.lock()
                        .unwrap()
                        .push(now.duration_since(at).as_secs_f64());
                }
                left += q.len();
            }
            if left == 0 && !writing.load(Ordering::SeqCst) {
                return now;
            }
            std::thread::sleep(Duration::from_millis(1));
        })
    };
    let per_station = o.rate / STATIONS as f64;
    let interval = Duration::from_secs_f64(1.0 / per_station);
    let total_per_station = (per_station * o.seconds).round() as usize;
    let sessions_per_station = total_per_station.div_ceil(READINGS);
    let t = Instant::now();
    let writers: Vec<_> = stations
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let s = s.clone();
            let p = pending[i].clone();
            // Staggered starts, so that the stations do not write in step.
            let start = t + interval.mul_f64(i as f64 / STATIONS as f64);
            std::thread::spawn(move || {
                let mut k = 0u32;
                let mut late = Duration::ZERO;
                for n in 0..sessions_per_station {
                    one_session(
                        &s,
                        i,
                        o.backlog + n,
                        |seq, at| p.lock().unwrap().push_back((seq, at)),
                        || {
                            let due = start + interval * k;
                            k += 1;
                            match due.checked_duration_since(Instant::now()) {
                                Some(d) => std::thread::sleep(d),
                                None => late = late.max(due.elapsed()),
                            }
                        },
                    );
                }
                late
            })
        })
        .collect();
    let mut latest = Duration::ZERO;
    for w in writers {
        latest = latest.max(w.join().unwrap());
    }
    let wrote = t.elapsed().as_secs_f64();
    writing.store(false, Ordering::SeqCst);
    let last_commit = monitor.join().unwrap();
    let committed_secs = last_commit.duration_since(t).as_secs_f64();
    let sustained = STATIONS * sessions_per_station * READINGS;
    let mut lags = std::mem::take(&mut *lags.lock().unwrap());
    assert_eq!(lags.len(), sustained, "every reading's commit was seen");
    lags.sort_by(f64::total_cmp);
    let ms = |x: f64| x * 1000.0;
    println!(
        "sustained: {sustained} readings offered at {:.0}/s, stored in {wrote:.2} s ({:.0}/s; the \
         most behind schedule a station fell: {:.0} ms)",
        o.rate,
        sustained as f64 / wrote,
        ms(latest.as_secs_f64())
    );
    println!(
        "sustained: committed at the hub through {committed_secs:.2} s: {:.0} readings/s \
         (load average {})",
        sustained as f64 / committed_secs,
        loadavg()
    );
    println!(
        "lag stored -> committed (station has the hub's answer): min {:.1} ms, median {:.1} ms, \
         p90 {:.1} ms, p99 {:.1} ms, max {:.1} ms",
        ms(lags[0]),
        ms(percentile(&lags, 50.0)),
        ms(percentile(&lags, 90.0)),
        ms(percentile(&lags, 99.0)),
        ms(*lags.last().unwrap())
    );

    // Exactly once at the hub.
    let want = (STATIONS * (o.backlog + sessions_per_station) * READINGS) as i64;
    let (readings, distinct): (i64, i64) = hub_rt.block_on(async {
        let c = db.client().await.unwrap();
        let r = c
            .query_one(
                "SELECT COUNT(*), COUNT(DISTINCT (station, reading)) FROM readings",
                &[],
            )
            .await
            .unwrap();
        (r.get(0), r.get(1))
    });
    assert_eq!((readings, distinct), (want, want), "the hub's readings");
    println!("hub: {readings} readings, each once");
    let syncs = Arc::try_unwrap(syncs).expect("the monitor has ended");
    for h in syncs {
        h.stop();
    }
    let _ = stop_tx.send(());
    drop(hub_rt);
}
