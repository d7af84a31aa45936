//! The live estimate's latency: from a reading stored in the session store
//! to the new estimate done and stored with its session, through the
//! station's services as the kiosk runs them (issue 13's target: the last
//! reading's body on screen within 0.3 s).
//!
//! Each iteration stores the quick set's last reading (a keyboard capture:
//! one SQLite transaction with fsync), then asks `StationServices` for the
//! estimate of the session's readings and waits for its `Done` (the body and
//! report are stored before `Done` is sent). The embedded model is loaded
//! before timing (the station loads it at start, see `tapeshape station`).
//!
//! Run: `cargo bench -p tapeshape --bench live` (one estimate at a time,
//! as the kiosk runs them).

// criterion_group! generates an undocumented `pub fn benches`.
#![allow(missing_docs)]

use std::sync::mpsc;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion};
use tapeshape::services::station::StationServices;
use tapeshape::services::{EstimateEvent, EstimateRequest, Services as _};
use tapeshape::session::Sessions;

fn live(c: &mut Criterion) {
    tapeshape_estimator::Estimator::default_model().expect("embedded model");
    let dir = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(dir.path()).unwrap();
    let services = StationServices::new(sessions.clone(), None);
    let session = sessions.start("bench", "quick", None).unwrap().id;
    // A typical man's quick set (tenths of a mm), the last one stored in the loop.
    let readings: [(&str, u32); 9] = [
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
    for (name, v) in &readings[..8] {
        sessions.capture_keyboard(session, name, *v).unwrap();
    }
    let mut g = c.benchmark_group("live");
    g.sample_size(20);
    g.measurement_time(Duration::from_secs(20));
    let mut k = 0u32;
    g.bench_function("stored_reading_to_stored_estimate_quick9", |b| {
        b.iter(|| {
            // A slightly different last reading each time (as a retake).
            k = (k + 1) % 20;
            let (name, v) = readings[8];
            sessions.capture_keyboard(session, name, v + k).unwrap();
            let request = EstimateRequest {
                session,
                readings: readings
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
            let _cancel = services.start_estimate(
                request,
                Box::new(move |ev| {
                    if !matches!(ev, EstimateEvent::Stage { .. }) {
                        let _ = tx.send(ev);
                    }
                }),
            );
            match rx.recv().unwrap() {
                EstimateEvent::Done(_) => {}
                other => panic!("{other:?}"),
            }
        })
    });
    g.finish();
}

criterion_group!(benches, live);
criterion_main!(benches);
