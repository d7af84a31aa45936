//! End-to-end latency from a tape hold to the reading being committed in SQLite.
//!
//! Path: the simulated tape writes a confirmed line into the tape pty -> the firmware logic
//! (`tapeshape_firmware::run` on a host thread, `sim::harness`) parses it and sends a Reading
//! frame into its host pty -> the station's real link (tokio-serial) decodes it, commits it to
//! the SQLite store (WAL, synchronous = FULL: one fsync per reading) and emits
//! `ReadingCommitted`. Measured: from the moment the confirmed line's last byte was handed to
//! the tape pty until the link's event is received.
//!
//! Readings are spaced `PACE` apart, well beyond the latency, so each one is measured alone
//! (an operator confirms one reading every few seconds). No faults are injected.
//!
//! Run: `cargo bench -p tapeshape-tests --bench link_latency` (optionally `-- N` readings,
//! default 300). Prints min, median, p95, p99 and max in milliseconds.

use std::time::Duration;

use tapeshape::link::{Link, LinkEvent, Naming};
use tapeshape::session::Sessions;
use tapeshape_sim::tape::{Script, TapeTiming};
use tapeshape_tests::{fast_link_config, spawn_tape, DeviceUnderTest};
use tokio::time::Instant;

const PACE: Duration = Duration::from_millis(60);

fn percentile(sorted: &[f64], p: f64) -> f64 {
    // Nearest-rank percentile.
    let rank = ((p / 100.0) * sorted.len() as f64).ceil().max(1.0) as usize;
    sorted[rank.min(sorted.len()) - 1]
}

fn main() {
    // `cargo bench` passes `--bench`; the first plain number, if any, is the reading count.
    let n: usize = std::env::args()
        .skip(1)
        .find_map(|a| a.parse().ok())
        .unwrap_or(300);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("tokio runtime");
    let latencies = rt.block_on(measure(n));
    let mut ms: Vec<f64> = latencies.iter().map(|d| d.as_secs_f64() * 1e3).collect();
    ms.sort_by(f64::total_cmp);
    println!(
        "tape hold -> committed in SQLite (host-harness firmware, real ptys, tokio-serial link, \
         WAL + synchronous=FULL), {} readings:",
        ms.len()
    );
    println!(
        "  min {:.2} ms | median {:.2} ms | p95 {:.2} ms | p99 {:.2} ms | max {:.2} ms",
        ms[0],
        percentile(&ms, 50.0),
        percentile(&ms, 95.0),
        percentile(&ms, 99.0),
        ms[ms.len() - 1]
    );
}

async fn measure(n: usize) -> Vec<Duration> {
    let device = DeviceUnderTest::harness(0x0000_BE4C);
    let data = tempfile::tempdir().expect("temp dir");
    let sessions = Sessions::open(data.path()).expect("store");
    let session = sessions.create("bench", None, None).expect("session");
    let (link, mut events, _task) =
        Link::spawn(device.host_path(), fast_link_config(), sessions.clone());
    link.set_session(Some(session.id));
    link.set_naming(Naming::Numbered);
    // Wait for the handshake so that the first reading is not delayed by it.
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        match tokio::time::timeout_at(deadline, events.recv()).await {
            Ok(Some(LinkEvent::Connected(_))) => break,
            Ok(Some(_)) => {}
            _ => panic!("the link did not connect within 10 s"),
        }
    }

    let script = Script::session(n, 0xBE4C, 2000..15000, PACE * 2 / 3);
    let timeline = script
        .timeline(TapeTiming {
            live_interval: PACE / 3,
            heartbeat_interval: Duration::from_secs(1),
        })
        .expect("timeline");
    let (tape, mut confirms) = spawn_tape(device.tape_path(), timeline, 1.0);
    let mut written = Vec::with_capacity(n);
    let mut latencies = Vec::with_capacity(n);
    let deadline = Instant::now() + PACE * n as u32 + Duration::from_secs(30);
    while latencies.len() < n {
        tokio::select! {
            c = confirms.recv() => {
                if let Some(c) = c {
                    written.push(c.written_at);
                }
            }
            ev = tokio::time::timeout_at(deadline, events.recv()) => match ev {
                Ok(Some(LinkEvent::ReadingCommitted { reading, .. })) => {
                    let at = Instant::now();
                    // Drain confirmations written before this commit.
                    while let Ok(c) = confirms.try_recv() {
                        written.push(c.written_at);
                    }
                    let i = reading.tape().expect("a tape reading").seq as usize;
                    let Some(&w) = written.get(i) else {
                        panic!("reading {i} committed before its hold was recorded");
                    };
                    latencies.push(at - w);
                }
                Ok(Some(_)) => {}
                _ => panic!("stalled after {} of {n} readings", latencies.len()),
            },
        }
    }
    tape.await.expect("tape task").expect("tape I/O");
    latencies
}
