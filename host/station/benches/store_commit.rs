//! Cost of committing one reading to the session store with the durability
//! the link relies on (WAL, `synchronous = FULL`: one fsync per commit), and
//! of recognising a retransmitted duplicate. The link acknowledges a reading
//! only after this returns, so it bounds the station's ack latency.
//!
//! Run: `cargo bench -p tapeshape --bench store_commit`. The store lives in a
//! temporary directory (the system's temp dir: the file system matters more
//! than the CPU for the fsync).

// criterion_group! generates an undocumented `pub fn benches`.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, Criterion};
use tapeshape::link::ReadingSink as _;
use tapeshape::session::Sessions;
use tapeshape::store::{CommitOutcome, DeviceReading};

fn commit(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let session = sessions.create("bench", None, None).unwrap().id;
    let mut seq = 0u32;
    c.bench_function("commit_tape_reading (new, fsync)", |b| {
        b.iter(|| {
            let r = DeviceReading {
                device_id: 1,
                boot_id: 1,
                seq,
                value_tenth_mm: 9000 + seq % 1000,
                device_time_ms: u64::from(seq),
            };
            seq += 1;
            let out = sessions
                .commit_tape_reading(session, Some("chest"), &r)
                .unwrap();
            assert!(matches!(out, CommitOutcome::Committed(_)));
        })
    });
    let dup = DeviceReading {
        device_id: 1,
        boot_id: 1,
        seq: 0,
        value_tenth_mm: 9000,
        device_time_ms: 0,
    };
    c.bench_function("commit_tape_reading (duplicate)", |b| {
        b.iter(|| {
            let out = sessions
                .commit_tape_reading(session, Some("chest"), &dup)
                .unwrap();
            assert!(matches!(out, CommitOutcome::Duplicate { .. }));
        })
    });
}

criterion_group!(benches, commit);
criterion_main!(benches);
