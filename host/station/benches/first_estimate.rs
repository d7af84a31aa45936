//! Issue 13: the station's first estimate is as fast as its tenth.
//!
//! Each run is a fresh process (this bench starts itself again with
//! `TAPESHAPE_FIRST_ESTIMATE_CHILD` set) that starts as `tapeshape station`
//! does: the data directory's cache chosen, the model warmed up on a thread
//! of its own ([`warm_up_in_background`]), then, after a pause (the operator
//! typing the first customer), ten estimates of the quick set one after the
//! other through `StationServices`, each timed from the request to `Done`
//! (body and report stored with the session), each after a retaken last
//! reading. Before the runs one process writes the caches, as the first
//! start on a machine does. Printed: per estimate number, the median and
//! range over the runs, for a pause of 0 (a reading the moment the station
//! is up) and of 1 s.
//!
//! The processes use the `tapeshape` binary's allocator and its tuning
//! (`tapeshape::alloc`), as the station does.
//!
//! Run: `cargo bench -p tapeshape --bench first_estimate` (after `--`: the
//! number of runs, default 10).

use std::path::Path;
use std::process::Command;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use tapeshape::services::station::{warm_up_in_background, StationServices};
use tapeshape::services::{EstimateEvent, EstimateRequest, Services as _};
use tapeshape::session::Sessions;

/// The `tapeshape` binary's allocator (see `host/station/src/main.rs`).
#[cfg(target_os = "linux")]
#[global_allocator]
static ALLOC: tapeshape::alloc::HugePageHint = tapeshape::alloc::HugePageHint;

/// Estimates per process.
const ESTIMATES: usize = 10;
const CHILD: &str = "TAPESHAPE_FIRST_ESTIMATE_CHILD";

/// A typical man's quick set (tenths of a mm); the last is retaken before
/// each estimate.
const READINGS: [(&str, u32); 9] = [
    ("stature", 17_650),
    ("chest", 9_820),
    ("waist", 8_400),
    ("hip", 10_000),
    ("neck", 3_900),
    ("inside_leg", 8_300),
    ("arm_length", 6_100),
    ("thigh", 5_800),
    ("upper_arm", 3_300),
];

/// One station process: the start, the pause, then the estimates' latencies
/// (ms) on one line of stdout.
fn child(data: &Path, pause: Duration) {
    tapeshape_estimator::Estimator::use_cache_dir(data.join("cache"));
    let _warm = warm_up_in_background();
    std::thread::sleep(pause);
    let sessions = Sessions::open(data).expect("the session store");
    let services = StationServices::new(sessions.clone(), None);
    let session = sessions
        .start("bench", "quick", None)
        .expect("a session")
        .id;
    for (name, v) in &READINGS[..8] {
        sessions
            .capture_keyboard(session, name, *v)
            .expect("a reading");
    }
    let mut latencies = Vec::new();
    for k in 0..ESTIMATES as u32 {
        let (name, v) = READINGS[8];
        sessions
            .capture_keyboard(session, name, v + k)
            .expect("a reading");
        let request = EstimateRequest {
            session,
            readings: READINGS
                .iter()
                .map(|(n, v)| {
                    let v = if *n == name { v + k } else { *v };
                    (n.to_string(), f64::from(v) / 10.0)
                })
                .collect(),
            sex: None,
            kept: Vec::new(),
        };
        let (tx, rx) = mpsc::channel();
        let start = Instant::now();
        let _cancel = services.start_estimate(
            request,
            Box::new(move |ev| {
                if !matches!(ev, EstimateEvent::Stage { .. }) {
                    let _ = tx.send(ev);
                }
            }),
        );
        match rx.recv().expect("an estimate event") {
            EstimateEvent::Done(_) => latencies.push(start.elapsed().as_secs_f64() * 1e3),
            other => panic!("the estimate did not finish: {other:?}"),
        }
    }
    let line: Vec<String> = latencies.iter().map(|l| format!("{l:.2}")).collect();
    println!("{}", line.join(" "));
}

/// Runs one child process; its latencies (ms).
fn run(data: &Path, pause_ms: u64) -> Vec<f64> {
    let exe = std::env::current_exe().expect("this bench's path");
    let out = Command::new(exe)
        .env(CHILD, format!("{pause_ms} {}", data.display()))
        .output()
        .expect("starting a station process");
    assert!(
        out.status.success(),
        "a station process failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .map(|t| t.parse().expect("a latency"))
        .collect()
}

fn main() {
    #[cfg(target_os = "linux")]
    tapeshape::alloc::tune();
    if let Ok(spec) = std::env::var(CHILD) {
        let (pause, dir) = spec.split_once(' ').expect("pause and folder");
        child(
            Path::new(dir),
            Duration::from_millis(pause.parse().expect("a pause in ms")),
        );
        return;
    }
    let runs: usize = std::env::args()
        .skip(1)
        .find(|a| !a.starts_with('-'))
        .and_then(|a| a.parse().ok())
        .unwrap_or(10);
    let data = tempfile::tempdir().expect("a data folder");
    // The first start on a machine: decodes the model and writes the caches.
    let first = run(data.path(), 0);
    println!(
        "first start on a machine (no cache yet): first estimate {:.1} ms, then {:.1} ms",
        first[0],
        first[ESTIMATES - 1]
    );
    for pause_ms in [0u64, 1000] {
        let all: Vec<Vec<f64>> = (0..runs).map(|_| run(data.path(), pause_ms)).collect();
        println!(
            "pause {pause_ms} ms after start, {runs} processes, ms from request to stored estimate:"
        );
        for i in 0..ESTIMATES {
            let mut v: Vec<f64> = all.iter().map(|r| r[i]).collect();
            v.sort_by(f64::total_cmp);
            println!(
                "  estimate {:>2}: median {:6.1}  ({:.1}-{:.1})",
                i + 1,
                v[v.len() / 2],
                v[0],
                v[v.len() - 1]
            );
        }
    }
}
