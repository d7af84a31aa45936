//! Kill-safety of the real `tapeshape station` binary: the station is
//! SIGKILLed again and again at random moments while a device (played by
//! this test over a pseudo-terminal, retransmitting every reading until it is
//! acknowledged, as the protocol requires) keeps taking readings. Afterwards
//! the session must hold every reading exactly once, in order: nothing
//! acknowledged is lost and nothing retransmitted is doubled.

mod common;

use std::time::Duration;

use common::{station, SimDevice};
use tapeshape::store::{SessionStatus, Store};

const TOTAL: u32 = 60;

fn value_of(seq: u32) -> u32 {
    5000 + seq * 7
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn station_killed_at_random_keeps_every_reading_once() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("data");
    let dev = SimDevice::start(common::compatible());
    let (port, state) = (dev.port.clone(), dev.state.clone());

    // A small deterministic pseudo-random sequence of kill delays.
    let mut rng: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next_delay = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        Duration::from_millis(30 + rng % 400)
    };
    let mut kills = 0;
    let mut first = true;
    while state.lock().unwrap().next_seq < TOTAL {
        let mut child = if first {
            station(&port, &data, &["--customer", "kill-test"])
        } else {
            station(&port, &data, &["--resume"])
        };
        if first {
            // The first run creates the session; a kill before that leaves
            // nothing to resume (every later `--resume` then exits with "no
            // open session"). A debug binary under CI load can take longer to
            // get there than the first random delay, so the first kill waits
            // for the first acknowledged reading.
            let started = tokio::time::Instant::now() + Duration::from_secs(60);
            state.lock().unwrap().take(value_of(0));
            while state.lock().unwrap().acked.is_none() {
                assert!(
                    tokio::time::Instant::now() < started,
                    "the first station run acknowledged nothing in 60 s"
                );
                tokio::time::sleep(Duration::from_millis(15)).await;
            }
        }
        first = false;
        let deadline = tokio::time::Instant::now() + next_delay();
        while tokio::time::Instant::now() < deadline {
            {
                let mut st = state.lock().unwrap();
                if st.next_seq < TOTAL {
                    let seq = st.next_seq;
                    st.take(value_of(seq));
                }
            }
            tokio::time::sleep(Duration::from_millis(15)).await;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        kills += 1;
        let st = state.lock().unwrap();
        eprintln!(
            "kill {kills}: {} taken, acked up to {:?}, {} waiting",
            st.next_seq,
            st.acked,
            st.unacked.len()
        );
    }
    // A last station run until the device has nothing left unacknowledged.
    let mut child = station(&port, &data, &["--resume"]);
    let deadline = tokio::time::Instant::now() + Duration::from_secs(20);
    while state.lock().unwrap().acked != Some(TOTAL - 1) {
        assert!(
            tokio::time::Instant::now() < deadline,
            "station did not acknowledge everything"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    child.kill().unwrap();
    child.wait().unwrap();
    drop(dev);
    assert!(kills >= 3, "only {kills} kills");

    let store = Store::open(&data).unwrap();
    let sessions = store.list_sessions().unwrap();
    assert_eq!(sessions.len(), 1, "resume must reuse the one session");
    let s = &sessions[0].session;
    assert_eq!(s.status, SessionStatus::Open);
    let got: Vec<(u32, u32)> = store
        .open_session(s.id)
        .unwrap()
        .readings
        .iter()
        .map(|r| (r.tape().unwrap().seq, r.value_tenth_mm))
        .collect();
    let want: Vec<(u32, u32)> = (0..TOTAL).map(|seq| (seq, value_of(seq))).collect();
    assert_eq!(got, want);
}
