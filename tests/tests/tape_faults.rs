//! Garbage and corrupted lines on the tape side: rejected and counted by the firmware,
//! reported to the station, never stored as readings.
//!
//! The tape stream mixes 200 clean confirmed readings with: corrupted copies of confirmed
//! lines (flipped bits, truncations, doubled characters; each checked to be invalid),
//! impossible values (negative, beyond the tape's length, a confirmed zero) and random garbage
//! lines from the fault injector. The oracle for "how many lines must be rejected" is the
//! firmware's own line assembler run over the exact byte stream the tape sends; the oracle
//! for "what must be stored" is the script: exactly its 200 values, in order.

use std::time::Duration;

use tapeshape::link::{Link, LinkEvent, Naming};
use tapeshape::session::Sessions;
use tapeshape_firmware::tape::{Line, LineAssembler};
use tapeshape_protocol::Fault;
use tapeshape_sim::faults::{FaultInjector, FaultPlan, Segment};
use tapeshape_sim::tape::{Script, TapeTiming, TimedOutput};
use tapeshape_tests::{
    check_session_exactly, fast_link_config, spawn_tape, watch_until_stored, DeviceUnderTest,
    Observed,
};
use tokio::time::Instant;

const READINGS: usize = 200;

/// Whether the firmware's assembler accepts any line in `bytes` (fed after a line end).
fn has_valid_line(bytes: &[u8]) -> bool {
    let mut a = LineAssembler::new();
    bytes
        .iter()
        .chain(b"\n")
        .filter_map(|&b| a.push(b))
        .any(|r| r.is_ok())
}

/// A corrupted copy of a tape line that the firmware must reject. `k` picks the corruption.
fn corrupt(line: &[u8], k: usize) -> Vec<u8> {
    let body = &line[..line.len() - 1]; // without '\n'
    for attempt in 0..64 {
        let j = k + attempt;
        let mut v = body.to_vec();
        match j % 3 {
            // Flip one bit of one character.
            0 => {
                let pos = (j * 7) % v.len();
                v[pos] ^= 1 << ((j * 3) % 8);
            }
            // Lose the end of the line.
            1 => v.truncate(1 + (j * 5) % (v.len() - 1)),
            // A character received twice.
            _ => {
                let pos = 1 + (j * 11) % (v.len() - 1);
                v.insert(pos, v[pos]);
            }
        }
        // Keep the corruption inside this line: no terminator, no new start character.
        if v.iter()
            .skip(1)
            .any(|&b| b == b'\n' || b == b'\r' || b == b'*')
        {
            continue;
        }
        if !has_valid_line(&v) {
            v.push(b'\n');
            return v;
        }
    }
    b"*garbage\n".to_vec()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn garbage_and_corrupted_tape_lines_are_rejected_counted_never_stored() {
    let device = DeviceUnderTest::harness(0x0000_6A7B);
    let data = tempfile::tempdir().unwrap();
    let sessions = Sessions::open(data.path()).unwrap();
    let store = sessions.store().clone();
    let session = sessions.create("e2e-tape-faults", None, None).unwrap();
    let (link, mut events, link_task) =
        Link::spawn(device.host_path(), fast_link_config(), sessions.clone());
    link.set_session(Some(session.id));
    link.set_naming(Naming::Numbered);

    let script = Script::session(
        READINGS,
        0x5EED_0004,
        2000..15000,
        Duration::from_millis(20),
    );
    let expected = script.confirmed_values();
    let clean = script
        .timeline(TapeTiming {
            live_interval: Duration::from_millis(10),
            heartbeat_interval: Duration::from_secs(1),
        })
        .unwrap();

    // Build the faulty stream: garbage lines from the injector, plus corrupted copies and
    // impossible values in front of every third confirmed line.
    let mut plan = FaultPlan::clean(0x5EED_0004);
    plan.garbage_line_rate = 0.1;
    let mut injector = FaultInjector::new(plan).unwrap();
    let impossible: [&[u8]; 3] = [
        b"*-0100;00000;0000SM\n",
        b"*99999;00000;0000SM\n",
        b"*00000;00000;0000SM\n",
    ];
    let mut timeline = Vec::with_capacity(clean.len() * 2);
    for (i, out) in clean.into_iter().enumerate() {
        let mut bytes = Vec::new();
        if let Some((idx, _)) = out.confirmation {
            if idx % 3 == 0 {
                bytes.extend(corrupt(&out.bytes, i));
                bytes.extend_from_slice(impossible[idx / 3 % 3]);
            }
        }
        for seg in injector.process(&out.bytes) {
            if let Segment::Bytes(b) = seg {
                bytes.extend(b);
            }
        }
        timeline.push(TimedOutput { bytes, ..out });
    }
    assert!(
        injector.stats().garbage_lines > 20,
        "{:?}",
        injector.stats()
    );

    // The oracle: what the firmware's assembler makes of the whole stream.
    let mut oracle = LineAssembler::new();
    let (mut want_ok, mut want_rejected, mut want_confirmed) = (0u32, 0u32, Vec::new());
    for out in &timeline {
        for &b in &out.bytes {
            match oracle.push(b) {
                Some(Ok(line)) => {
                    want_ok += 1;
                    if let Line::Value(v) = line {
                        if v.kind == tapeshape_firmware::tape::Kind::Confirmed {
                            want_confirmed.push(v.value_hundredths_cm);
                        }
                    }
                }
                Some(Err(_)) => want_rejected += 1,
                None => {}
            }
        }
    }
    assert_eq!(
        want_confirmed, expected,
        "the oracle sees exactly the script's confirmations"
    );
    assert!(
        want_rejected > 100,
        "{want_rejected} rejections is too few to test anything"
    );

    let (tape, _confirms) = spawn_tape(device.tape_path(), timeline, 1.0);
    let mut obs = Observed::default();
    watch_until_stored(
        &mut events,
        &store,
        session.id,
        READINGS,
        Instant::now() + Duration::from_secs(40),
        &mut obs,
        |_| {},
    )
    .await
    .unwrap();
    tape.await.unwrap().unwrap();

    // The device's counters, as the station receives them, match the oracle exactly.
    let deadline = Instant::now() + Duration::from_secs(5);
    let status = loop {
        link.request_status();
        let ev = tokio::time::timeout_at(deadline, events.recv())
            .await
            .unwrap_or_else(|_| {
                panic!(
                    "no status with {want_ok} lines ok and {want_rejected} rejected; last: {:?}",
                    obs.last_status
                )
            })
            .expect("link running");
        let s = match &ev {
            LinkEvent::Status(s) => Some(*s),
            _ => None,
        };
        obs.record(ev);
        if let Some(s) = s {
            if s.lines_ok == want_ok && s.rejected.total() >= want_rejected {
                break s;
            }
        }
    };
    assert_eq!(status.rejected.total(), want_rejected, "{status:?}");
    assert_eq!(status.readings_refused, 0);
    let reported = obs
        .faults
        .iter()
        .filter_map(|f| match f {
            Fault::LineRejected { rejected_total, .. } => Some(*rejected_total),
            _ => None,
        })
        .max();
    assert!(
        reported.is_some_and(|n| n > 0 && n <= want_rejected),
        "rejections reported to the station: {reported:?}"
    );

    // Never stored: exactly the script's values, in order.
    tokio::time::sleep(Duration::from_millis(200)).await;
    check_session_exactly(&store, session.id, &expected).unwrap();
    link.shutdown();
    let _ = link_task.await;
    eprintln!(
        "{READINGS} readings stored, {want_rejected} tape lines rejected and counted \
         ({} garbage lines injected)",
        injector.stats().garbage_lines
    );
}
